"""The ROS 2 message types parolkit speaks, declared as cyclonedds IDL structs.

ROS 2 maps a message ``pkg/msg/Name`` to the DDS type ``pkg::msg::dds_::Name_`` and a topic
``/a/b`` to the DDS topic ``rt/a/b``; the structs below have the exact field order and types of
the ROS 2 Jazzy ``.msg`` definitions (final extensibility, XCDR1 as ROS 2's middlewares send),
so a ROS 2 node on any middleware that interoperates over RTPS reads them unchanged.

Units are ROS's (REP 103): metres, radians, seconds.  No ``from __future__ import annotations``
here: cyclonedds resolves the field annotations at run time.
"""


from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, uint32

if TYPE_CHECKING:  # for the type checker a sequence field is a list (what it holds at run time)
    from builtins import list as sequence
else:
    from cyclonedds.idl.types import sequence

__all__ = [
    "Time", "Duration", "MsgHeader", "String", "JointState", "JointTrajectoryPoint", "JointTrajectory",
    "Vector3", "Quaternion", "Transform", "TransformStamped", "TFMessage",
    "topic_name", "time_from_ns", "duration_to_s",
]


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    """builtin_interfaces/msg/Time: seconds and nanoseconds (0..999999999)."""

    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    """builtin_interfaces/msg/Duration: seconds and nanoseconds (0..999999999)."""

    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class MsgHeader(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    """std_msgs/msg/Header (named MsgHeader here: parolkit has another Header class)."""

    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    """std_msgs/msg/String."""

    data: str = ""


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    """sensor_msgs/msg/JointState: positions in rad, velocities in rad/s, efforts in N m."""

    header: MsgHeader = field(default_factory=MsgHeader)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
class JointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectoryPoint_"):
    """trajectory_msgs/msg/JointTrajectoryPoint: rad, rad/s, rad/s^2; time from the start."""

    positions: sequence[float64] = field(default_factory=list)
    velocities: sequence[float64] = field(default_factory=list)
    accelerations: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)
    time_from_start: Duration = field(default_factory=Duration)


@dataclass
class JointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectory_"):
    """trajectory_msgs/msg/JointTrajectory."""

    header: MsgHeader = field(default_factory=MsgHeader)
    joint_names: sequence[str] = field(default_factory=list)
    points: sequence[JointTrajectoryPoint] = field(default_factory=list)


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    """geometry_msgs/msg/Vector3 (metres here)."""

    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    """geometry_msgs/msg/Quaternion (x, y, z, w)."""

    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    """geometry_msgs/msg/Transform."""

    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    """geometry_msgs/msg/TransformStamped."""

    header: MsgHeader = field(default_factory=MsgHeader)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    """tf2_msgs/msg/TFMessage."""

    transforms: sequence[TransformStamped] = field(default_factory=list)


def topic_name(namespace: str, name: str) -> str:
    """The DDS topic of ROS topic ``/<namespace>/<name>``: ``rt/<namespace>/<name>``."""
    ns = namespace.strip("/")
    return f"rt/{ns}/{name}" if ns else f"rt/{name}"


def time_from_ns(ns: int) -> Time:
    """A builtin_interfaces Time from integer nanoseconds since the epoch."""
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def duration_to_s(d: Duration) -> float:
    """A builtin_interfaces Duration in seconds."""
    return d.sec + d.nanosec * 1e-9
