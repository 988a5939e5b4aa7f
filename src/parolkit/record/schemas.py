"""What a parolkit recording contains: topics, ROS 2 message definitions and JSON schemas.

ROS 2 definitions are written in the concatenated ``.msg`` form ``ros2 bag`` and Foxglove read
(``ros2msg`` schema encoding, ``cdr`` message encoding).  Joint names are those of the URDF the
project exports (``L1`` .. ``L6``).
"""

from __future__ import annotations

__all__ = [
    "JOINT_NAMES", "BASE_FRAME", "TOPIC_JOINT_STATES", "TOPIC_TCP_POSE", "TOPIC_STATUS",
    "TOPIC_COMMANDS", "TOPIC_ACKS", "TOPIC_PLANS", "JSON_TOPICS", "JOINT_STATE", "POSE_STAMPED",
    "ROS2_DEFINITIONS", "JSON_SCHEMA", "RECORDING_METADATA", "PROFILE",
]

#: joint names in JointState: the URDF's (issue 17)
JOINT_NAMES = ("L1", "L2", "L3", "L4", "L5", "L6")
#: frame of /tcp_pose (the robot's base, as in the URDF)
BASE_FRAME = "base_link"

TOPIC_JOINT_STATES = "/joint_states"
TOPIC_TCP_POSE = "/tcp_pose"
#: the controller's whole status object at every tick (IO, gripper, state, errors, loop timing)
TOPIC_STATUS = "/parolkit/status"
#: commands seen: the active command of any client (from the status) and the recorder's own
TOPIC_COMMANDS = "/parolkit/commands"
#: acknowledgements the recorder receives (those of its own commands)
TOPIC_ACKS = "/parolkit/acks"
#: the plan of each motion (GET_PLAN, asked whenever ``plan_seq`` changes)
TOPIC_PLANS = "/parolkit/plans"
JSON_TOPICS = (TOPIC_STATUS, TOPIC_COMMANDS, TOPIC_ACKS, TOPIC_PLANS)

#: MCAP metadata record written when a recording is closed normally
RECORDING_METADATA = "parolkit.recording"
PROFILE = "ros2"

JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"

_SEP = "=" * 80
_HEADER = """MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id"""
_TIME = """MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec"""

_JOINT_STATE_DEF = f"""std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
{_SEP}
{_HEADER}
{_SEP}
{_TIME}
"""

_POSE_STAMPED_DEF = f"""std_msgs/Header header
geometry_msgs/Pose pose
{_SEP}
{_HEADER}
{_SEP}
{_TIME}
{_SEP}
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
{_SEP}
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
{_SEP}
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"""

#: schema name -> concatenated message definition
ROS2_DEFINITIONS: dict[str, str] = {JOINT_STATE: _JOINT_STATE_DEF, POSE_STAMPED: _POSE_STAMPED_DEF}

#: JSON schema of every JSON channel (an object; the fields are documented in docs/record.md)
JSON_SCHEMA = b'{"type": "object"}'
