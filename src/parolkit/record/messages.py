"""A controller status object -> ROS 2 message dicts (the field layout mcap-ros2-support encodes).

Units: JointState positions in rad, velocities in rad/s; PoseStamped position in metres and
orientation as a unit quaternion.  The status pose is ``[x, y, z, A, B, C]`` (mm, deg) with
``R = Rx(C) * Ry(B) * Rz(A)`` (see :mod:`parolkit.kinematics.pose`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from parolkit.record.schemas import BASE_FRAME, JOINT_NAMES

__all__ = ["stamp", "joint_state", "pose_stamped", "quaternion_from_abc"]

_DEG = math.pi / 180.0


def stamp(time_ns: int) -> dict[str, int]:
    """``builtin_interfaces/Time`` of a UNIX time in ns."""
    return {"sec": time_ns // 1_000_000_000, "nanosec": time_ns % 1_000_000_000}


def joint_state(status: dict[str, Any], time_ns: int) -> dict[str, Any]:
    """``sensor_msgs/msg/JointState`` of one status: angles (deg) and speeds (deg/s) in SI."""
    return {
        "header": {"stamp": stamp(time_ns), "frame_id": ""},
        "name": list(JOINT_NAMES),
        "position": [float(a) * _DEG for a in status["angles"]],
        "velocity": [float(v) * _DEG for v in status["speeds_deg_s"]],
        "effort": [],
    }


def _qmul(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    """Hamilton product of (x, y, z, w) quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def quaternion_from_abc(a_deg: float, b_deg: float, c_deg: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of ``R = Rx(C) * Ry(B) * Rz(A)`` (angles in deg)."""
    ha, hb, hc = a_deg * _DEG / 2, b_deg * _DEG / 2, c_deg * _DEG / 2
    qx = (math.sin(hc), 0.0, 0.0, math.cos(hc))
    qy = (0.0, math.sin(hb), 0.0, math.cos(hb))
    qz = (0.0, 0.0, math.sin(ha), math.cos(ha))
    return _qmul(_qmul(qx, qy), qz)


def pose_stamped(status: dict[str, Any], time_ns: int) -> dict[str, Any]:
    """``geometry_msgs/msg/PoseStamped`` of the status's TCP pose (current tool), in metres."""
    x, y, z, a, b, c = (float(v) for v in status["pose"])
    qx, qy, qz, qw = quaternion_from_abc(a, b, c)
    return {
        "header": {"stamp": stamp(time_ns), "frame_id": BASE_FRAME},
        "pose": {"position": {"x": x / 1000.0, "y": y / 1000.0, "z": z / 1000.0},
                 "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}},
    }
