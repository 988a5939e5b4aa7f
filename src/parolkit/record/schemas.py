"""What a parolkit recording contains: topics, their ROS 2 message types and QoS.

Every channel is CDR with a ROS 2 message schema (``ros2msg``: the concatenated ``.msg``
definitions rosbag2 writes, from :mod:`parolkit.ros2.interfaces`), so ``ros2 bag`` (rosbag2's
MCAP storage), rosbags, Foxglove and mcap-python read every message.  parolkit's own types are
the package ``parolkit_msgs`` (Status, CommandEvent, Ack, Plan; docs/record.md).  Joint names
are those of the URDF the project exports (``L1`` .. ``L6``, parolkit's joint convention).

Each channel's metadata carries what rosbag2 records with a topic: ``offered_qos_profiles``
(the QoS ``ros2 bag play`` republishes it with: transient local for ``/tf_static`` and
``/robot_description``, as tf2 and robot_state_publisher offer them) and ``topic_type_hash``.
Recordings made before the parolkit_msgs schema (JSON channels) are still read
(:mod:`parolkit.record.reader`).
"""

from __future__ import annotations

from parolkit.ros2.interfaces import concatenated_definition, hash_of

__all__ = [
    "JOINT_NAMES", "BASE_FRAME", "TOPIC_JOINT_STATES", "TOPIC_TCP_POSE", "TOPIC_STATUS", "TOPIC_COMMANDS",
    "TOPIC_ACKS", "TOPIC_PLANS", "TOPIC_TF", "TOPIC_TF_STATIC", "TOPIC_ROBOT_DESCRIPTION", "TOPIC_TYPES",
    "JOINT_STATE", "POSE_STAMPED", "TF_MESSAGE", "STRING", "STATUS", "COMMAND_EVENT", "ACK", "PLAN",
    "LATCHED_TOPICS", "RECORDING_METADATA", "PROFILE", "schema_text", "channel_metadata", "offered_qos_yaml",
]

#: joint names in JointState: the URDF's (issue 17; parolkit.ros2.urdf's, not imported here: it
#: brings numpy and the collision model into every tool that only reads a recording's topics)
JOINT_NAMES = ("L1", "L2", "L3", "L4", "L5", "L6")
#: frame of /tcp_pose and of the status (the robot's base: the URDF's base_link)
BASE_FRAME = "base_link"

TOPIC_JOINT_STATES = "/joint_states"
TOPIC_TCP_POSE = "/tcp_pose"
#: every link of the URDF at every tick, and its fixed frames once (again when the tool changes)
TOPIC_TF = "/tf"
TOPIC_TF_STATIC = "/tf_static"
#: the URDF (parolkit's joint convention, the current tool at its ``tcp`` link)
TOPIC_ROBOT_DESCRIPTION = "/robot_description"
#: the controller's whole status object at every tick (IO, gripper, state, errors, loop timing)
TOPIC_STATUS = "/parolkit/status"
#: commands seen: the active command of any client (from the status) and the recorder's own
TOPIC_COMMANDS = "/parolkit/commands"
#: acknowledgements the recorder receives (those of its own commands)
TOPIC_ACKS = "/parolkit/acks"
#: the plan of each motion (GET_PLAN, asked whenever ``plan_seq`` changes)
TOPIC_PLANS = "/parolkit/plans"

JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
STRING = "std_msgs/msg/String"
STATUS = "parolkit_msgs/msg/Status"
COMMAND_EVENT = "parolkit_msgs/msg/CommandEvent"
ACK = "parolkit_msgs/msg/Ack"
PLAN = "parolkit_msgs/msg/Plan"

#: topic -> its ROS 2 message type
TOPIC_TYPES: dict[str, str] = {
    TOPIC_JOINT_STATES: JOINT_STATE, TOPIC_TCP_POSE: POSE_STAMPED, TOPIC_TF: TF_MESSAGE, TOPIC_TF_STATIC: TF_MESSAGE,
    TOPIC_ROBOT_DESCRIPTION: STRING, TOPIC_STATUS: STATUS, TOPIC_COMMANDS: COMMAND_EVENT, TOPIC_ACKS: ACK,
    TOPIC_PLANS: PLAN,
}
#: topics offered transient local (a late subscriber of ``ros2 bag play`` still gets them)
LATCHED_TOPICS = (TOPIC_TF_STATIC, TOPIC_ROBOT_DESCRIPTION)

#: MCAP metadata record written when a recording is closed normally
RECORDING_METADATA = "parolkit.recording"
PROFILE = "ros2"


def schema_text(datatype: str) -> str:
    """The ``ros2msg`` schema of ``datatype`` (its definition and every type it uses)."""
    return concatenated_definition(datatype)


def offered_qos_yaml(latched: bool) -> str:
    """rosbag2's ``offered_qos_profiles`` of a topic: reliable, keep last 1 (transient local)
    when ``latched``, else keep last 10 (volatile); deadline, lifespan and lease the defaults."""
    depth, durability = (1, 1) if latched else (10, 2)  # rmw: 1 transient local, 2 volatile
    zero = "\n    sec: 0\n    nsec: 0"
    return (f"- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {durability}\n"
            f"  deadline:{zero}\n  lifespan:{zero}\n  liveliness: 1\n  liveliness_lease_duration:{zero}\n"
            "  avoid_ros_namespace_conventions: false\n")


def channel_metadata(topic: str, datatype: str) -> dict[str, str]:
    """The metadata rosbag2 keeps with a topic: its offered QoS and its type's RIHS01 hash."""
    return {"offered_qos_profiles": offered_qos_yaml(topic in LATCHED_TOPICS), "topic_type_hash": hash_of(datatype)}
