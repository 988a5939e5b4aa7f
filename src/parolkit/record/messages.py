"""A controller status object -> ROS 2 message dicts (the field layout mcap-ros2-support encodes),
and parolkit_msgs messages back to the dicts the tools read (commands, acks, plans, statuses).

Units: JointState positions in rad, velocities in rad/s; PoseStamped position in metres and
orientation as a unit quaternion.  The status pose is ``[x, y, z, A, B, C]`` (mm, deg) with
``R = Rx(C) * Ry(B) * Rz(A)`` (see :mod:`parolkit.kinematics.pose`).  Stamps are what the
caller gives (the recorder: the controller's tick time, docs/record.md).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from parolkit.record.schemas import BASE_FRAME, JOINT_NAMES

if TYPE_CHECKING:
    from parolkit.ros2.tf import FrameTransform

__all__ = ["stamp", "joint_state", "pose_stamped", "quaternion_from_abc", "status_message", "status_from_message",
           "command_event", "command_event_dict", "ack_message", "ack_dict", "plan_message", "plan_dict",
           "tf_message"]

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


# ---- parolkit_msgs (docs/record.md, "Schemas") and their dict layout for the tools ----

def _floats6(values: Any) -> list[float]:
    v = [float(x) for x in (values or [])][:6]
    return v + [0.0] * (6 - len(v))


def _ints6(values: Any) -> list[int]:
    v = [int(x) for x in (values or [])][:6]
    return v + [0] * (6 - len(v))


def status_message(status: dict[str, Any], json_text: str, time_ns: int) -> dict[str, Any]:
    """``parolkit_msgs/msg/Status`` of one status object; ``json_text``: the object as the
    controller sent it (kept whole in the ``json`` field, from which the tools read it back)."""
    io = status.get("io") or {}
    cmd = status.get("command") or {}
    homed = [bool(h) for h in (status.get("homed") or [])][:6]
    return {
        "header": {"stamp": stamp(time_ns), "frame_id": BASE_FRAME},
        "seq": int(status["seq"]), "time": float(status.get("time", 0.0)), "state": str(status.get("state", "")),
        "enabled": bool(status.get("enabled", False)), "all_homed": bool(status.get("all_homed", False)),
        "homed": homed + [False] * (6 - len(homed)),
        "estop_pressed": bool(status.get("estop_pressed", False)),
        "estop_latched": bool(status.get("estop_latched", False)),
        "angles": _floats6(status.get("angles")), "steps": _ints6(status.get("steps")),
        "speeds_deg_s": _floats6(status.get("speeds_deg_s")), "pose": _floats6(status.get("pose")),
        "tool": str(status.get("tool") or ""),
        "in1": int(io.get("in1", 0)), "in2": int(io.get("in2", 0)), "out1": int(io.get("out1", 0)),
        "out2": int(io.get("out2", 0)), "estop_input": int(io.get("estop", 0)),
        "gripper_position": int((status.get("gripper") or {}).get("position", 0)),
        "command_name": str(cmd.get("name") or ""), "command_id": str(cmd.get("id") or ""),
        "command_progress": float(cmd.get("progress") or 0.0), "queue": int(status.get("queue", 0)),
        "speed_pct": float(status.get("speed_pct", 100.0)), "paused": bool(status.get("paused", False)),
        "error": str((status.get("errors") or {}).get("message") or ""),
        "rate_hz": float((status.get("loop") or {}).get("rate_hz") or 0.0),
        "json": json_text,
    }


def status_from_message(msg: Any) -> dict[str, Any]:
    """The status object a decoded ``parolkit_msgs/msg/Status`` carries."""
    out: dict[str, Any] = json.loads(msg.json)
    return out


def _tick(tick: int | None) -> int:
    return -1 if tick is None else int(tick)


def _untick(tick: int) -> int | None:
    return None if tick < 0 else int(tick)


def command_event(event: dict[str, Any], time_ns: int) -> dict[str, Any]:
    """``parolkit_msgs/msg/CommandEvent`` of a command event dict (docs/record.md)."""
    return {"header": {"stamp": stamp(time_ns), "frame_id": ""}, "tick": _tick(event.get("tick")),
            "source": str(event["source"]), "event": str(event.get("event", "sent")),
            "id": str(event.get("id") or ""), "name": str(event.get("name") or ""), "sent": str(event.get("sent", ""))}


def command_event_dict(msg: Any) -> dict[str, Any]:
    """The command event dict of a decoded CommandEvent (the layout of docs/record.md)."""
    if msg.source == "recorder":
        return {"source": "recorder", "sent": msg.sent, "tick": _untick(msg.tick)}
    return {"source": msg.source, "event": msg.event, "tick": _untick(msg.tick), "id": msg.id or None,
            "name": msg.name or None}


def ack_message(ack: dict[str, Any], time_ns: int) -> dict[str, Any]:
    """``parolkit_msgs/msg/Ack`` of an ack dict ``{"id", "status", "details", "tick"}``."""
    return {"header": {"stamp": stamp(time_ns), "frame_id": ""}, "tick": _tick(ack.get("tick")),
            "id": str(ack.get("id") or ""), "status": str(ack.get("status") or ""),
            "details": str(ack.get("details") or "")}


def ack_dict(msg: Any) -> dict[str, Any]:
    return {"id": msg.id or None, "status": msg.status or None, "details": msg.details, "tick": _untick(msg.tick)}


def plan_message(plan: dict[str, Any], time_ns: int) -> dict[str, Any]:
    """``parolkit_msgs/msg/Plan`` of a GET_PLAN reply (``tcp_path`` mm -> metres)."""
    target = plan.get("target_angles")
    return {"header": {"stamp": stamp(time_ns), "frame_id": BASE_FRAME}, "tick": _tick(plan.get("tick")),
            "plan_seq": _tick(plan.get("seq")), "command": str(plan.get("command") or ""),
            "has_target": target is not None, "target_angles": _floats6(target),
            "tcp_path": [{"x": float(p[0]) / 1000.0, "y": float(p[1]) / 1000.0, "z": float(p[2]) / 1000.0}
                         for p in (plan.get("tcp_path") or [])]}


def plan_dict(msg: Any) -> dict[str, Any]:
    """The GET_PLAN reply layout of a decoded Plan (tcp_path back in mm)."""
    return {"seq": _untick(msg.plan_seq), "command": msg.command or None,
            "target_angles": list(msg.target_angles) if msg.has_target else None,
            "tcp_path": [[p.x * 1000.0, p.y * 1000.0, p.z * 1000.0] for p in msg.tcp_path],
            "tick": _untick(msg.tick)}


def tf_message(transforms: Sequence[FrameTransform], time_ns: int) -> dict[str, Any]:
    """``tf2_msgs/msg/TFMessage`` of frame transforms (:mod:`parolkit.ros2.tf`), one stamp."""
    st = stamp(time_ns)
    return {"transforms": [
        {"header": {"stamp": st, "frame_id": t.parent}, "child_frame_id": t.child,
         "transform": {"translation": {"x": t.translation[0], "y": t.translation[1], "z": t.translation[2]},
                       "rotation": {"x": t.rotation[0], "y": t.rotation[1], "z": t.rotation[2],
                                    "w": t.rotation[3]}}}
        for t in transforms]}
