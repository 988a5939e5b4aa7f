"""The ROS 2 message definitions parolkit speaks, as ``.msg`` text: one source for the type
hashes of its topics (:mod:`parolkit.ros2.typehash`), the schemas of its MCAP recordings
(:func:`concatenated_definition`, the ``ros2msg`` form ``ros2 bag`` and Foxglove read) and the
``parolkit_msgs`` package.

The standard types are ROS 2 Jazzy's (fields only: their comments and constants are not part
of a type's identity); ``parolkit_msgs`` is parolkit's own package, documented in
docs/record.md.  The cyclonedds structs of :mod:`parolkit.ros2.msgs` and
:mod:`parolkit.ros2.graph` are checked against these definitions field by field
(tests/unit/test_ros2_interfaces.py), and their hashes against ROS 2's own generator
(tests/integration/test_ros2_graph.py).

Pure standard library.
"""

from __future__ import annotations

import functools

from parolkit.errors import ParolkitValueError
from parolkit.ros2.typehash import msg_dependencies, type_hash

__all__ = ["DEFINITIONS", "PAROLKIT_MSGS", "definition", "hash_of", "concatenated_definition",
           "dds_type_name", "ros_type_name"]

_SEP = "=" * 80

#: ``pkg/msg/Name`` -> ``.msg`` text
DEFINITIONS: dict[str, str] = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "builtin_interfaces/msg/Duration": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/msg/String": "string data\n",
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"),
    "trajectory_msgs/msg/JointTrajectoryPoint": (
        "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\n"
        "builtin_interfaces/Duration time_from_start\n"),
    "trajectory_msgs/msg/JointTrajectory": (
        "std_msgs/Header header\nstring[] joint_names\nJointTrajectoryPoint[] points\n"),
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/msg/Pose": "Point position\nQuaternion orientation\n",
    "geometry_msgs/msg/PoseStamped": "std_msgs/Header header\nPose pose\n",
    "geometry_msgs/msg/Transform": "Vector3 translation\nQuaternion rotation\n",
    "geometry_msgs/msg/TransformStamped": "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "rmw_dds_common/msg/Gid": "char[16] data\n",
    "rmw_dds_common/msg/NodeEntitiesInfo": (
        "string<=256 node_namespace\nstring<=256 node_name\nGid[] reader_gid_seq\nGid[] writer_gid_seq\n"),
    "rmw_dds_common/msg/ParticipantEntitiesInfo": "Gid gid\nNodeEntitiesInfo[] node_entities_info_seq\n",
    # ---- parolkit's own (docs/record.md, "Schemas") ----
    "parolkit_msgs/msg/Status": """\
# The controller's status at one control tick (docs/protocol.md, "Status object").
# header.stamp: the controller's tick time; header.frame_id: the robot's base frame.
std_msgs/Header header
uint64 seq                # the controller tick
float64 time              # controller time: s since its first tick
string state              # IDLE MOVING HOMING DISABLED ESTOP ERROR DISCONNECTED
bool enabled
bool all_homed
bool[6] homed
bool estop_pressed
bool estop_latched
float64[6] angles         # joint angles J1..J6, deg
int32[6] steps            # board step counters
float64[6] speeds_deg_s   # joint speeds, deg/s
float64[6] pose           # TCP of the current tool: x y z mm, A B C deg
string tool               # the current tool
uint8 in1
uint8 in2
uint8 out1
uint8 out2
uint8 estop_input         # the E-stop input (1: released)
int32 gripper_position
string command_name       # the active command ("" when none)
string command_id
float64 command_progress  # 0..1 (0 when none)
uint32 queue              # commands waiting
float64 speed_pct         # the speed override, 1..100
bool paused
string error              # the latched error message ("" when none)
float64 rate_hz           # the control rate
string json               # the whole status object as the controller sent it (every field)
""",
    "parolkit_msgs/msg/CommandEvent": """\
# A command seen by the recorder: the active command (of any client) starting or ending, as the
# status shows it, or a datagram the recorder sent itself.
std_msgs/Header header
int64 tick                # the controller tick (-1: before the first status)
string source             # "status" or "recorder"
string event              # source status: "started" or "ended"; source recorder: "sent"
string id                 # the command's ID (source status)
string name               # the command's name (source status)
string sent               # the datagram (source recorder)
""",
    "parolkit_msgs/msg/Ack": """\
# An acknowledgement the recorder received (those of its own commands).
std_msgs/Header header
int64 tick                # the last tick received before it (-1: none yet)
string id
string status             # QUEUED EXECUTING COMPLETED FAILED INVALID CANCELLED
string details
""",
    "parolkit_msgs/msg/Plan": """\
# The plan of a motion (the GET_PLAN reply) when it starts.
std_msgs/Header header
int64 tick                # the last tick received before it (-1: none yet)
int64 plan_seq            # the status's plan_seq it answers (-1: not given)
string command
bool has_target
float64[6] target_angles  # deg (when has_target)
geometry_msgs/Point[] tcp_path  # metres
""",
}

#: the types of parolkit's own package
PAROLKIT_MSGS = tuple(sorted(n for n in DEFINITIONS if n.startswith("parolkit_msgs/")))


def definition(type_name: str) -> str:
    """The ``.msg`` text of ``type_name``; an error naming the known types when it is not one."""
    try:
        return DEFINITIONS[type_name]
    except KeyError:
        known = ", ".join(sorted(DEFINITIONS))
        raise ParolkitValueError(f"unknown ROS 2 type {type_name!r} (known: {known})") from None


@functools.cache
def hash_of(type_name: str) -> str:
    """The RIHS01 hash of ``type_name`` (REP 2011, :mod:`parolkit.ros2.typehash`)."""
    definition(type_name)
    return type_hash(type_name, DEFINITIONS)


def _short(type_name: str) -> str:
    pkg, _, name = type_name.split("/")
    return f"{pkg}/{name}"


@functools.cache
def concatenated_definition(type_name: str) -> str:
    """The ``ros2msg`` schema of ``type_name`` as rosbag2 writes it into MCAP: its own text,
    then every type it refers to after a line of 80 ``=`` and ``MSG: pkg/Name``."""
    parts = [definition(type_name).rstrip("\n")]
    for dep in msg_dependencies(type_name, DEFINITIONS):
        parts.append(f"{_SEP}\nMSG: {_short(dep)}\n{DEFINITIONS[dep].rstrip(chr(10))}")
    return "\n".join(parts) + "\n"


def dds_type_name(type_name: str) -> str:
    """The DDS type of a ROS 2 type: ``pkg/msg/Name`` -> ``pkg::msg::dds_::Name_``."""
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def ros_type_name(dds_name: str) -> str:
    """The ROS 2 type of a DDS type: ``pkg::msg::dds_::Name_`` -> ``pkg/msg/Name``."""
    parts = dds_name.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        raise ParolkitValueError(f"not the DDS name of a ROS 2 type (pkg::msg::dds_::Name_): {dds_name!r}")
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"
