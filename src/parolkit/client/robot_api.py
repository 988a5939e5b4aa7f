"""robot_api: the PAROL6 function API, compatible with existing user scripts.

Standard library only and free of imports from the rest of parolkit: copy this single file
next to a script (for example onto a Raspberry Pi) and ``from robot_api import ...`` works.

Usage, exactly as the original examples::

    from robot_api import move_robot_joints, get_robot_joint_angles
    move_robot_joints([90, -90, 160, 12, 12, 180], duration=5.5)
    print(get_robot_joint_angles())

Talking to a controller elsewhere: ``configure(host="192.168.1.20")`` (or set the module
attributes :data:`SERVER_IP`, :data:`SERVER_PORT`, :data:`ACK_PORT` before the first call).

Units on the wire and in every function: degrees, millimetres, percent (0..100), seconds.

Every motion/action function has the original keyword arguments ``wait_for_ack=False``,
``timeout`` and ``non_blocking=False``:

* ``wait_for_ack=False`` (default): fire and forget; returns a short confirmation string
  (``"Successfully sent command: '...'"``).
* ``wait_for_ack=True``: the command carries an 8-character ID; returns the original's dict
  ``{'command', 'sent_time', 'status', 'details', 'completed', 'ack_time', 'command_id'}``
  (times are ``datetime``; status ``'COMPLETED'|'FAILED'|'CANCELLED'|'INVALID'``, details e.g.
  ``"MoveJoint finished successfully"``) once the terminal acknowledgement arrives, or status
  ``'TIMEOUT'`` after ``timeout`` seconds (``last_status`` says how far it got; the command
  keeps running).
* ``wait_for_ack=True, non_blocking=True``: returns the command ID at once; poll it with
  :func:`check_command_status`.

Every datagram is the one the original client sent for the same call (``MOVECART|...|NONE|50.0``,
six fields per spline waypoint, ``SMOOTH_BLEND|...|DEFAULT``, frames and axes as written).
**(ext)** :func:`move_robot_joints`, :func:`move_robot_pose` and :func:`move_robot_cartesian`
also take the keyword-only ``blend`` (deg, deg, mm; 0..100): the corner into the next queued
move is rounded within that radius and the arm does not stop there (sent as a last field
``|r=10``).

Acknowledgements arrive on UDP :data:`ACK_PORT` (5002): one shared
:class:`LazyCommandTracker` binds it on first use (nothing runs before).  If another program
holds that port, :class:`AckPortBusyError` says so.  Once it runs, every command (tracked or
not) goes out from its socket: the controller knows a client by its socket, so the control
lease taken with :func:`take_control` covers all of this process's commands.

Arguments are checked BEFORE anything is sent: a bad value raises ``ValueError`` naming the
argument and the allowed range (for example ``speed_percentage must be in 0..100, got 150``).
Queries return parsed values, or ``None`` (with a message on stderr) when the controller does
not answer within :data:`QUERY_TIMEOUT` seconds.

Besides the original functions this module exposes the datagram builders (``build_*``) and
reply parsers (``parse_*``, :func:`matrix_to_pose`) that ``parolkit.Robot`` shares.
"""

from __future__ import annotations

import json
import math
import re
import secrets
import socket
import string
import sys
import threading
import time
from collections import OrderedDict
from datetime import datetime
from typing import Any, Callable, Dict, FrozenSet, List, Literal, Optional, Sequence, Tuple, TypedDict, Union, overload

__all__ = [
    # configuration
    "SERVER_IP", "SERVER_PORT", "ACK_PORT", "QUERY_TIMEOUT", "configure", "Settings",
    "AckPortBusyError", "TERMINAL_STATUSES",
    # sending and tracking
    "send_robot_command", "send_robot_command_tracked", "send_and_wait", "LazyCommandTracker",
    "CommandRecord", "Result", "TrackingStats",
    # motion and actions (original names and defaults)
    "move_robot_joints", "move_robot_pose", "move_robot_cartesian", "move_robot_cartesian_rel_trf",
    "jog_robot_joint", "jog_multiple_joints", "jog_cartesian",
    "control_pneumatic_gripper", "control_electric_gripper",
    "delay_robot", "home_robot", "stop_robot_movement",
    "smooth_circle", "smooth_arc_center", "smooth_arc_parametric", "smooth_spline",
    "smooth_helix", "smooth_blend", "chain_smooth_motions", "execute_trajectory",
    "safe_move_with_retry",
    # extensions
    "enable_robot", "disable_robot", "clear_robot_error", "estop_robot",
    "speed_robot_joints", "wait_robot_input", "set_robot_tool", "set_stream_mode",
    "set_speed_override", "pause_robot", "resume_robot", "checkpoint", "wait_checkpoint",
    "servo_joints", "servo_pose",
    # queries
    "get_robot_pose", "get_robot_pose_matrix", "get_robot_joint_angles", "get_robot_io",
    "get_electric_gripper_status", "get_robot_joint_speeds", "is_robot_stopped",
    "is_estop_pressed", "get_robot_status", "RobotStatusDict", "wait_for_robot_stopped", "ping_robot",
    # tracking
    "check_command_status", "is_tracking_active", "get_tracking_stats",
    # shared building blocks (used by parolkit.Robot / AsyncRobot)
    "new_command_id", "format_value", "matrix_to_pose", "parse_reply", "parse_ack",
    "parse_numbers", "parse_status_fields", "parse_cookie", "parse_control", "ControlInfo",
    "build_move_joint", "build_move_pose", "build_move_cart", "build_move_cart_rel_trf",
    "build_jog", "build_multijog", "build_cartjog", "build_pneumatic_gripper",
    "build_electric_gripper", "build_delay", "build_checkpoint", "build_speed", "build_servo_j",
    "build_servo_l", "build_home",
    "build_speed_joint", "build_move_joint_path",
    "build_wait_input", "build_smooth_circle", "build_smooth_arc_center",
    "build_smooth_arc_param", "build_smooth_spline", "build_smooth_helix", "build_smooth_blend",
    "build_stream", "build_set_tool", "build_set_port", "build_subscribe", "build_unsubscribe",
    "build_control", "take_control", "release_control", "get_control",
    "CARTESIAN_AXES", "FRAMES", "PLANES", "PROFILES", "TRACKING_MODES", "TIMING_MODES",
    "SEGMENT_TYPES", "MAX_PATH_POINTS", "MAX_BLEND",
]

#: Controller address.
SERVER_IP = "127.0.0.1"
#: Controller command port (UDP).
SERVER_PORT = 5001
#: Local UDP port the acknowledgement listener binds (the controller sends acks there).
ACK_PORT = 5002
#: Seconds a query waits for its reply.
QUERY_TIMEOUT = 2.0

# The words of the protocol.  This module may not import the rest of parolkit, so these are
# copies of the parolkit.moves / parolkit.protocol.commands enums and tables;
# tests/unit/test_vocabulary.py asserts that each copy agrees with its original.

#: Acknowledgement statuses after which a command is finished (protocol ``AckStatus``).
TERMINAL_STATUSES = frozenset({"COMPLETED", "FAILED", "CANCELLED", "INVALID"})
#: Cartesian jog axes (``CartAxis``).
CARTESIAN_AXES = ("X+", "X-", "Y+", "Y-", "Z+", "Z-", "RX+", "RX-", "RY+", "RY-", "RZ+", "RZ-")
#: Reference frames (``Frame``).
FRAMES = ("WRF", "TRF")
#: Circle planes (``Plane``).
PLANES = ("XY", "XZ", "YZ")
#: Velocity profiles (``Profile``).
PROFILES = ("poly", "trap", "ruckig", "toppra")
#: Tracking modes (``Tracking``).
TRACKING_MODES = ("position", "speed")
#: How a smooth path is timed: a duration in s or a path speed in % (``Timing``).
TIMING_MODES = ("DURATION", "SPEED")
#: SMOOTH_BLEND segment types (protocol ``BLEND_SEGMENT_KINDS``).
SEGMENT_TYPES = ("LINE", "CIRCLE", "ARC", "SPLINE")
#: Most points one MOVEJOINTPATH carries (``parolkit.moves.MAX_PATH_POINTS``).
MAX_PATH_POINTS = 200
#: The largest blend radius ``blend`` (the ``r=`` field): mm on MOVECART, deg on MOVEJOINT and
#: MOVEPOSE (``parolkit.moves.MAX_BLEND``).
MAX_BLEND = 100.0

#: Gripper ranges accepted by the SSG-48 as the controller drives it.
GRIPPER_POSITION_RANGE = (0, 255)
GRIPPER_SPEED_RANGE = (0, 255)
GRIPPER_CURRENT_RANGE_MA = (0, 1300)  # the seed: "0 - 1300 mA"


class Settings(TypedDict):
    """What :func:`configure` returns: the settings in effect."""

    host: str
    port: int
    ack_port: int


class AckPortBusyError(OSError):
    """The acknowledgement port could not be bound (another program listens on it)."""


def configure(host: Optional[str] = None, port: Optional[int] = None,
              ack_port: Optional[int] = None) -> Settings:
    """Point the API at a controller; returns the settings now in effect.

    ``host``: controller address; ``port``: its UDP command port (1..65535);
    ``ack_port``: the local port acknowledgements arrive on (0..65535; 0 = any free port,
    only useful when the controller sends acks back to the sender's port).
    Arguments left at ``None`` keep their value.
    """
    global SERVER_IP, SERVER_PORT, ACK_PORT
    if host is not None:
        if not isinstance(host, str) or not host.strip():
            raise ValueError(f"host must be a non-empty host name or address, got {host!r}")
        SERVER_IP = host.strip()
    if port is not None:
        SERVER_PORT = _int(port, "port", 1, 65535)
    if ack_port is not None:
        new = _int(ack_port, "ack_port", 0, 65535)
        if new != ACK_PORT:
            ACK_PORT = new
            _stop_tracker()  # re-bound lazily on the next tracked command
    return {"host": SERVER_IP, "port": SERVER_PORT, "ack_port": ACK_PORT}


# =============================================================================================
# validation (raises ValueError naming the argument and the allowed range)
# =============================================================================================


def _number(value: Any, name: str, low: Optional[float] = None, high: Optional[float] = None,
            *, low_open: bool = False) -> float:
    if isinstance(value, bool) or value is None:
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    too_low = low is not None and (v <= low if low_open else v < low)
    if too_low or (high is not None and v > high):
        if high is None:
            rng = f"{'>' if low_open else '>='} {low:g}"
        elif low is None:
            rng = f"<= {high:g}"
        else:
            rng = f"in {low:g}..{high:g}" + (f" (excluding {low:g})" if low_open else "")
        raise ValueError(f"{name} must be {rng}, got {value!r}")
    if isinstance(value, int) or (hasattr(value, "__index__") and not isinstance(value, float)):
        return int(value.__index__())  # integers keep their text form ("90", not "90.0")
    return v


def _int(value: Any, name: str, low: int, high: int) -> int:
    if isinstance(value, bool):
        raise ValueError(f"{name} must be an integer in {low}..{high}, got {value!r}")
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    try:
        v: int = value.__index__()
    except (AttributeError, TypeError):
        raise ValueError(f"{name} must be an integer in {low}..{high}, got {value!r}") from None
    if not low <= v <= high:
        raise ValueError(f"{name} must be in {low}..{high}, got {v}")
    return v


def _numbers(values: Any, count: int, name: str, what: str = "") -> List[float]:
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name} must be a list of {count} numbers{what}, got {values!r}")
    seq = list(values)
    if len(seq) != count:
        raise ValueError(f"{name} must have {count} values{what}, got {len(seq)}")
    return [_number(v, f"{name}[{i}]") for i, v in enumerate(seq)]


def _pose(values: Any, name: str) -> List[float]:
    return _numbers(values, 6, name, " (x, y, z in mm; A, B, C in deg)")


def _percent(value: Any, name: str) -> float:
    """A speed/acceleration percentage: 0 < value <= 100 (0 % would never move)."""
    return _number(value, name, 0.0, 100.0, low_open=True)


def _positive(value: Any, name: str) -> float:
    v = _number(value, name)
    if v <= 0:
        raise ValueError(f"{name} must be > 0 s, got {value!r}" if "duration" in name or "time" in name
                         else f"{name} must be > 0, got {value!r}")
    return v


def _choice(value: Any, name: str, choices: Sequence[str], *, upper: bool = True) -> str:
    if not isinstance(value, str):
        raise ValueError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
    v = value.strip().upper() if upper else value.strip().lower()
    if v not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
    return v


def _zero_is_none(value: Any) -> Any:
    """An explicit 0 duration / speed / acceleration means "not given" (the seed's signature
    ``MoveJoint(j1, ..., v=0, a=0, t=0)``)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value == 0:
        return None
    return value


def _word(value: Any, name: str, choices: Sequence[str], *, upper: bool = True) -> str:
    """A word checked against ``choices`` without regard to case and sent as the caller wrote
    it (``wrf``, ``x+``), as the original client did (the controller reads it in any case).
    An enum member is sent as its value (``Frame.WRF`` -> ``WRF``)."""
    value = getattr(value, "value", value)
    _choice(value, name, choices, upper=upper)
    return str(value).strip()


def _one_timing(duration: Any, speed_percentage: Any) -> Tuple[Optional[float], Optional[float]]:
    duration, speed_percentage = _zero_is_none(duration), _zero_is_none(speed_percentage)
    if duration is None and speed_percentage is None:
        raise ValueError("give either duration (s, > 0) or speed_percentage (0..100), got neither")
    if duration is not None and speed_percentage is not None:
        raise ValueError("give either duration or speed_percentage, not both")
    d = _positive(duration, "duration") if duration is not None else None
    s = _percent(speed_percentage, "speed_percentage") if speed_percentage is not None else None
    return d, s


def _blend(value: Any, unit: str) -> Optional[float]:
    """A move's blend radius in 0..MAX_BLEND ``unit``; None for None or 0 (no blending)."""
    if value is None:
        return None
    r = _number(value, "blend")
    if not 0 <= r <= MAX_BLEND:
        raise ValueError(f"blend must be in 0..{MAX_BLEND:g} {unit}, got {value!r}")
    return r or None


def _opt_choice(value: Any, name: str, choices: Sequence[str]) -> Optional[str]:
    if value is None:
        return None
    value = getattr(value, "value", value)  # accept enums whose value is the wire word
    return _choice(value, name, choices, upper=False)


# =============================================================================================
# formatting
# =============================================================================================


def format_value(value: Any) -> str:
    """One wire field: ``None`` -> ``None``; ints as ints; floats in shortest round-trip form."""
    if value is None:
        return "None"
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)  # shortest round-trip text, e.g. "90.0", "0.1"
    return str(value)


def _csv(values: Sequence[Any]) -> str:
    return ",".join(format_value(v) for v in values)


def _join(*fields: Any) -> str:
    return "|".join(f if isinstance(f, str) else format_value(f) for f in fields)


def _float_text(value: float) -> str:
    """A number written with a decimal point (``2.0``): the original client's ``str(float(v))``."""
    return repr(float(value))


def _start_field(start_pose: Any) -> str:
    """``CURRENT`` for no start pose (None or an empty list, as the original), else the pose."""
    if start_pose is None or (hasattr(start_pose, "__len__") and len(start_pose) == 0):
        return "CURRENT"
    return _csv(_pose(start_pose, "start_pose"))


def _timing_fields(duration: Any, speed_percentage: Any) -> str:
    d, s = _one_timing(duration, speed_percentage)
    by_duration, by_speed = TIMING_MODES
    return f"{by_duration}|{format_value(d)}" if d is not None else f"{by_speed}|{format_value(s)}"


# =============================================================================================
# datagram builders (one command body each, without the ID)
# =============================================================================================


def _blend_field(blend: Optional[float]) -> List[str]:
    """The optional last field ``r=<radius>`` of a blended move (none without blending)."""
    return [] if blend is None else [f"r={format_value(blend)}"]


def _move_fields(values: List[float], duration: Any, speed_percentage: Any,
                 accel_percentage: Any = None, profile: Any = None, tracking: Any = None,
                 *, with_accel: bool = True, blend: Optional[float] = None) -> str:
    d, s = _one_timing(duration, speed_percentage)
    parts: List[Union[float, str, None]] = [*values, d, s]
    accel_percentage = _zero_is_none(accel_percentage)
    a = _percent(accel_percentage, "accel_percentage") if accel_percentage is not None else None
    p = _opt_choice(profile, "profile", PROFILES)
    t = _opt_choice(tracking, "tracking", TRACKING_MODES)
    ext = [a, p, t] if with_accel else [p, t]
    if any(x is not None for x in ext):
        parts += ext
    return _join(*parts, *_blend_field(blend))


def build_move_joint(angles: Any, duration: Any = None, speed_percentage: Any = None,
                     accel_percentage: Any = None, profile: Any = None, tracking: Any = None,
                     blend: Any = None) -> str:
    """``MOVEJOINT|j1..j6|duration|speed%[|accel%|profile|tracking][|r=blend]`` (deg, s, %;
    ``blend`` in deg, 0..100: round the corner into the next queued joint-space move)."""
    a = _numbers(angles, 6, "angles", " (J1..J6 in deg)")
    r = _blend(blend, "deg")
    return "MOVEJOINT|" + _move_fields(a, duration, speed_percentage, accel_percentage, profile, tracking,
                                       blend=r)


def build_move_pose(pose: Any, duration: Any = None, speed_percentage: Any = None,
                    accel_percentage: Any = None, profile: Any = None, tracking: Any = None,
                    blend: Any = None) -> str:
    """``MOVEPOSE|x|y|z|A|B|C|duration|speed%[|accel%|profile|tracking][|r=blend]`` (mm, deg;
    ``blend`` in deg, 0..100, as MOVEJOINT's)."""
    p = _pose(pose, "pose")
    r = _blend(blend, "deg")
    return "MOVEPOSE|" + _move_fields(p, duration, speed_percentage, accel_percentage, profile, tracking,
                                      blend=r)


def build_move_cart(pose: Any, duration: Any = None, speed_percentage: Any = None,
                    profile: Any = None, tracking: Any = None, blend: Any = None) -> str:
    """``MOVECART|x|y|z|A|B|C|duration|speed%[|profile|tracking][|r=blend]`` straight line (mm,
    deg; ``blend`` in mm, 0..100: round the corner into the next queued MOVECART).

    As the original client: the field not given is ``NONE`` and the speed is written as a
    float (``MOVECART|...|NONE|50.0``)."""
    p = _pose(pose, "pose")
    d, s = _one_timing(duration, speed_percentage)
    parts: List[str] = [format_value(v) for v in p]
    parts += [format_value(d) if d is not None else "NONE",
              _float_text(s) if s is not None else "NONE"]
    pr = _opt_choice(profile, "profile", PROFILES)
    t = _opt_choice(tracking, "tracking", TRACKING_MODES)
    r = _blend(blend, "mm")
    if pr is not None or t is not None:
        parts += [format_value(pr), format_value(t)]
    return "MOVECART|" + "|".join(parts + _blend_field(r))


def build_move_cart_rel_trf(delta: Any, duration: Any = None, speed_percentage: Any = None,
                            profile: Any = None, tracking: Any = None) -> str:
    """``MOVECARTRELTRF|dx|dy|dz|dA|dB|dC|duration|speed%[|profile|tracking]`` (tool frame)."""
    p = _pose(delta, "delta")
    return "MOVECARTRELTRF|" + _move_fields(p, duration, speed_percentage, None, profile, tracking,
                                            with_accel=False)


def build_jog(joint_index: Any, speed_percentage: Any, duration: Any = None,
              distance_deg: Any = None) -> str:
    """``JOG|index|speed%|duration|distance_deg``; index 0-5 = J1-J6 positive, 6-11 negative
    (the duration written as a float, as the original client)."""
    i = _int(joint_index, "joint_index", 0, 11)
    s = _percent(speed_percentage, "speed_percentage")
    if duration is None and distance_deg is None:
        raise ValueError("give duration (s, > 0) and/or distance_deg (> 0), got neither")
    d = _float_text(_positive(duration, "duration")) if duration is not None else None
    dist = _positive(distance_deg, "distance_deg") if distance_deg is not None else None
    return _join("JOG", i, s, d, dist)


def build_multijog(joints: Any, speeds: Any, duration: Any) -> str:
    """``MULTIJOG|i,i,...|s,s,...|duration`` (same index rule as JOG)."""
    if isinstance(joints, (str, bytes)) or not hasattr(joints, "__iter__"):
        raise ValueError(f"joints must be a list of joint indices 0..11, got {joints!r}")
    if isinstance(speeds, (str, bytes)) or not hasattr(speeds, "__iter__"):
        raise ValueError(f"speeds must be a list of percentages 0..100, got {speeds!r}")
    js = [_int(j, f"joints[{k}]", 0, 11) for k, j in enumerate(joints)]
    ss = [_percent(s, f"speeds[{k}]") for k, s in enumerate(speeds)]
    if not js:
        raise ValueError("joints must name at least one joint (0..11)")
    if len(js) != len(ss):
        raise ValueError(f"joints and speeds must have the same length, got {len(js)} and {len(ss)}")
    seen: Dict[int, int] = {}
    for j in js:
        joint = j % 6
        if joint in seen:
            what = "twice" if seen[joint] == j else "in both directions"
            raise ValueError(f"joints: J{joint + 1} is given {what} (indices {seen[joint]} and {j})")
        seen[joint] = j
    d = _positive(duration, "duration")
    return _join("MULTIJOG", _csv(js), _csv(ss), d)


def build_cartjog(frame: Any, axis: Any, speed_percentage: Any, duration: Any) -> str:
    """``CARTJOG|WRF|TRF|axis|speed%|duration`` (frame and axis as the caller wrote them, the
    duration as a float: the original client's form)."""
    f = _word(frame, "frame", FRAMES)
    a = _word(axis, "axis", CARTESIAN_AXES)
    s = _percent(speed_percentage, "speed_percentage")
    d = _positive(duration, "duration")
    return _join("CARTJOG", f, a, s, _float_text(d))


def build_pneumatic_gripper(action: Any, port: Any) -> str:
    """``PNEUMATICGRIPPER|open|close|port`` (port 1 = OUT1, 2 = OUT2)."""
    a = _word(action, "action", ("open", "close"), upper=False)
    p = _int(port, "port", 1, 2)
    return _join("PNEUMATICGRIPPER", a, p)


def build_electric_gripper(action: Any, position: Any = 255, speed: Any = 150,
                           current: Any = 500) -> str:
    """``ELECTRICGRIPPER|move|calibrate|clear_error|None|position|speed|current``.

    position 0..255 (0 open, 255 closed), speed 0..255, current 0..1300 mA; ``None`` (as
    the original allowed) sends ``None`` and the controller uses 255 / 150 / 500.
    """
    if action is None:
        a = "None"
    else:
        a = _choice(action, "action", ("move", "calibrate", "clear_error", "none"), upper=False)
        a = "None" if a == "none" else a
    pos = None if position is None else _int(position, "position", *GRIPPER_POSITION_RANGE)
    spd = None if speed is None else _int(speed, "speed", *GRIPPER_SPEED_RANGE)
    cur = None if current is None else _int(current, "current", *GRIPPER_CURRENT_RANGE_MA)
    return _join("ELECTRICGRIPPER", a, pos, spd, cur)


def build_delay(duration: Any) -> str:
    """``DELAY|seconds`` (> 0)."""
    return _join("DELAY", _positive(duration, "duration"))


def build_home() -> str:
    """``HOME``."""
    return "HOME"


#: a checkpoint label: 1..64 characters of [A-Za-z0-9_.:-]
_LABEL_RE = re.compile(r"^[A-Za-z0-9_.:-]{1,64}$", re.ASCII)


def build_checkpoint(label: Any) -> str:
    """**(ext)** ``CHECKPOINT|label``: 1..64 characters of ``[A-Za-z0-9_.:-]``."""
    if not isinstance(label, str) or not _LABEL_RE.match(label):
        raise ValueError(f"label must be 1..64 characters of [A-Za-z0-9_.:-], got {label!r}")
    return _join("CHECKPOINT", label)


def build_servo_j(angles: Any) -> str:
    """**(ext)** ``SERVOJ|j1|..|j6``: a servo target, joint angles in deg (the controller checks
    the joint ranges)."""
    return _join("SERVOJ", *_numbers(angles, 6, "angles", " (J1..J6 in deg)"))


def build_servo_l(pose: Any, frame: Any = "WRF") -> str:
    """**(ext)** ``SERVOL|x|y|z|A|B|C|frame``: a servo target pose (mm, deg) in the world
    frame (WRF) or relative to the TCP pose where the stream started (TRF)."""
    return _join("SERVOL", *_pose(pose, "pose"), _choice(frame, "frame", FRAMES))


def build_speed(percent: Any) -> str:
    """**(ext)** ``SPEED|pct``: the speed override, 1..100 %."""
    return _join("SPEED", _number(percent, "percent", 1.0, 100.0))


def build_speed_joint(speeds_deg_s: Any, duration: Any) -> str:
    """**(ext)** ``SPEEDJOINT|s1..s6|duration``: constant joint speeds (deg/s) for duration s."""
    s = _numbers(speeds_deg_s, 6, "speeds_deg_s", " (J1..J6 in deg/s)")
    return _join("SPEEDJOINT", *s, _positive(duration, "duration"))


def _path_list(values: Any, name: str, n: int, what: str) -> List[Any]:
    """``values`` as a list of ``n`` entries (one per path point), or ValueError naming ``name``."""
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name} must be a list of {what}, got {values!r}")
    seq = list(values)
    if len(seq) != n:
        raise ValueError(f"{name} must have one entry per point ({n}), got {len(seq)}")
    return seq


def build_move_joint_path(points: Any, times: Any, velocities: Any = None) -> str:
    """**(ext)** ``MOVEJOINTPATH|n|t|j1..j6|...`` (7 fields per point) or, with ``velocities``,
    ``MOVEJOINTPATH|n|t|j1..j6|v1..v6|...`` (13 fields per point): pass through ``points``
    (J1..J6 in deg) at ``times`` (s from the start of the move, > 0 and increasing) as one
    trajectory, at rest at both ends; ``velocities`` (deg/s, one 6-vector per point, the last
    all zeros) or None for a smooth spline chosen by the controller."""
    if isinstance(points, (str, bytes)) or not hasattr(points, "__iter__"):
        raise ValueError(f"points must be a list of joint positions (6 numbers each, deg), got {points!r}")
    pts = list(points)
    if not 1 <= len(pts) <= MAX_PATH_POINTS:
        raise ValueError(f"points must hold 1..{MAX_PATH_POINTS} points, got {len(pts)}")
    n = len(pts)
    ps = [_numbers(p, 6, f"points[{k}]", " (J1..J6 in deg)") for k, p in enumerate(pts)]
    ts = [_positive(t, f"times[{k}]") for k, t in enumerate(_path_list(times, "times", n, "times (s)"))]
    for k in range(1, n):
        if ts[k] <= ts[k - 1]:
            raise ValueError(f"times[{k}] = {ts[k]!r} s must be greater than times[{k - 1}] = {ts[k - 1]!r} s "
                             "(times strictly increasing)")
    vs: List[List[float]] = []
    if velocities is not None:
        raw = _path_list(velocities, "velocities", n, "joint velocities (6 numbers each, deg/s)")
        vs = [_numbers(v, 6, f"velocities[{k}]", " (J1..J6 in deg/s)") for k, v in enumerate(raw)]
        moving = [j for j, v in enumerate(vs[-1]) if v != 0]
        if moving:
            raise ValueError(f"velocities[{n - 1}][{moving[0]}] must be 0 (the path ends at rest on its last "
                             f"point), got {vs[-1][moving[0]]!r}")
    fields: List[Any] = ["MOVEJOINTPATH", n]
    for k in range(n):
        fields += [ts[k], *ps[k], *(vs[k] if vs else [])]
    return _join(*fields)


def build_wait_input(input_number: Any, state: Any, timeout: Any = None) -> str:
    """**(ext)** ``WAIT_INPUT|1|2|0|1|timeout_s or None``."""
    n = _int(input_number, "input", 1, 2)
    st = _int(1 if state is True else 0 if state is False else state, "state", 0, 1)
    t = _positive(timeout, "timeout") if timeout is not None else None
    return _join("WAIT_INPUT", n, st, t)


def build_smooth_circle(center: Any, radius: Any, plane: Any = "XY", frame: Any = "WRF",
                        start_pose: Any = None, duration: Any = None,
                        speed_percentage: Any = None, clockwise: bool = False) -> str:
    """``SMOOTH_CIRCLE|cx,cy,cz|radius|plane|frame|start|DURATION|SPEED|value|cw``."""
    c = _numbers(center, 3, "center", " (x, y, z in mm)")
    r = _number(radius, "radius", 0.0, low_open=True)
    return _join("SMOOTH_CIRCLE", _csv(c), r, _word(plane, "plane", PLANES),
                 _word(frame, "frame", FRAMES), _start_field(start_pose),
                 _timing_fields(duration, speed_percentage), "1" if clockwise else "0")


def build_smooth_arc_center(end_pose: Any, center: Any, frame: Any = "WRF", start_pose: Any = None,
                            duration: Any = None, speed_percentage: Any = None,
                            clockwise: bool = False) -> str:
    """``SMOOTH_ARC_CENTER|end pose|cx,cy,cz|frame|start|timing|value|cw``."""
    e = _pose(end_pose, "end_pose")
    c = _numbers(center, 3, "center", " (x, y, z in mm)")
    return _join("SMOOTH_ARC_CENTER", _csv(e), _csv(c), _word(frame, "frame", FRAMES),
                 _start_field(start_pose), _timing_fields(duration, speed_percentage),
                 "1" if clockwise else "0")


def build_smooth_arc_param(end_pose: Any, radius: Any, arc_angle: Any, frame: Any = "WRF",
                           start_pose: Any = None, duration: Any = None,
                           speed_percentage: Any = None, clockwise: bool = False) -> str:
    """``SMOOTH_ARC_PARAM|end pose|radius|angle deg|frame|start|timing|value|cw``."""
    e = _pose(end_pose, "end_pose")
    r = _number(radius, "radius", 0.0, low_open=True)
    ang = _number(arc_angle, "arc_angle")
    if ang == 0:
        raise ValueError("arc_angle must be non-zero (deg)")
    return _join("SMOOTH_ARC_PARAM", _csv(e), r, ang, _word(frame, "frame", FRAMES),
                 _start_field(start_pose), _timing_fields(duration, speed_percentage),
                 "1" if clockwise else "0")


def build_smooth_spline(waypoints: Any, frame: Any = "WRF", start_pose: Any = None,
                        duration: Any = None, speed_percentage: Any = None) -> str:
    """``SMOOTH_SPLINE|n|frame|start|timing|value|x|y|z|A|B|C|x|y|...``: six fields per
    waypoint, the original client's form (the controller also reads one ``x,y,z,A,B,C`` field
    per waypoint)."""
    if isinstance(waypoints, (str, bytes)) or not hasattr(waypoints, "__iter__"):
        raise ValueError(f"waypoints must be a list of poses [x, y, z, A, B, C], got {waypoints!r}")
    wps = [_pose(w, f"waypoints[{i}]") for i, w in enumerate(waypoints)]
    if len(wps) < 2:
        raise ValueError(f"waypoints must hold at least 2 poses, got {len(wps)}")
    return _join("SMOOTH_SPLINE", len(wps), _word(frame, "frame", FRAMES), _start_field(start_pose),
                 _timing_fields(duration, speed_percentage), *(v for w in wps for v in w))


def build_smooth_helix(center: Any, radius: Any, pitch: Any, height: Any, frame: Any = "WRF",
                       start_pose: Any = None, duration: Any = None,
                       speed_percentage: Any = None, clockwise: bool = False) -> str:
    """``SMOOTH_HELIX|cx,cy,cz|radius|pitch|height|frame|start|timing|value|cw`` (mm)."""
    c = _numbers(center, 3, "center", " (x, y, z in mm)")
    r = _number(radius, "radius", 0.0, low_open=True)
    p = _number(pitch, "pitch", 0.0, low_open=True)
    h = _number(height, "height")
    if h == 0:
        raise ValueError("height must be non-zero (mm)")
    return _join("SMOOTH_HELIX", _csv(c), r, p, h, _word(frame, "frame", FRAMES),
                 _start_field(start_pose), _timing_fields(duration, speed_percentage),
                 "1" if clockwise else "0")


def _segment(seg: Any, i: int) -> str:
    name = f"segments[{i}]"
    if not isinstance(seg, dict):
        raise ValueError(f"{name} must be a dict with a 'type' of {', '.join(SEGMENT_TYPES)}, got {seg!r}")
    kind = _choice(seg.get("type"), f"{name}['type']", SEGMENT_TYPES)
    cw = "1" if seg.get("clockwise", False) else "0"

    def need(key: str) -> Any:
        if key not in seg:
            raise ValueError(f"{name} ({kind}) needs the key {key!r}")
        return seg[key]

    if kind == "LINE":
        end = _pose(need("end"), f"{name}['end']")
        dur = _positive(seg.get("duration", 2.0), f"{name}['duration']")
        return _join("LINE", _csv(end), dur)
    if kind == "CIRCLE":
        c = _numbers(need("center"), 3, f"{name}['center']")
        r = _number(need("radius"), f"{name}['radius']", 0.0, low_open=True)
        plane = _word(seg.get("plane", "XY"), f"{name}['plane']", PLANES)
        dur = _positive(seg.get("duration", 3.0), f"{name}['duration']")
        return _join("CIRCLE", _csv(c), r, plane, dur, cw)
    if kind == "ARC":
        end = _pose(need("end"), f"{name}['end']")
        c = _numbers(need("center"), 3, f"{name}['center']")
        dur = _positive(seg.get("duration", 2.0), f"{name}['duration']")
        return _join("ARC", _csv(end), _csv(c), dur, cw)
    wps = need("waypoints")
    if isinstance(wps, (str, bytes)) or not hasattr(wps, "__iter__"):
        raise ValueError(f"{name}['waypoints'] must be a list of poses")
    poses = [_pose(w, f"{name}['waypoints'][{k}]") for k, w in enumerate(wps)]
    if len(poses) < 2:
        raise ValueError(f"{name}['waypoints'] must hold at least 2 poses, got {len(poses)}")
    dur = _positive(seg.get("duration", 3.0), f"{name}['duration']")
    return _join("SPLINE", len(poses), ";".join(_csv(p) for p in poses), dur)


def build_smooth_blend(segments: Any, blend_time: Any = 0.5, frame: Any = "WRF",
                       start_pose: Any = None, duration: Any = None,
                       speed_percentage: Any = None) -> str:
    """``SMOOTH_BLEND|n|blend_time|frame|start|DURATION|SPEED|value|seg||seg...``.

    Segments are dicts: ``{'type': 'LINE', 'end': pose, 'duration': s}``,
    ``{'type': 'CIRCLE', 'center': xyz, 'radius': mm, 'plane': 'XY', 'duration': s,
    'clockwise': bool}``, ``{'type': 'ARC', 'end': pose, 'center': xyz, 'duration': s,
    'clockwise': bool}``, ``{'type': 'SPLINE', 'waypoints': [pose, ...], 'duration': s}``.
    Without duration/speed_percentage the segments keep their own durations (``DEFAULT``, no
    value field).  Segment wire forms (the original client's): ``LINE|pose|s``,
    ``CIRCLE|xyz|r|plane|s|cw``, ``ARC|pose|xyz|s|cw``, ``SPLINE|n|pose;pose;...|s``.
    """
    if isinstance(segments, (str, bytes, dict)) or not hasattr(segments, "__iter__"):
        raise ValueError(f"segments must be a list of segment dicts, got {segments!r}")
    segs = [_segment(s, i) for i, s in enumerate(segments)]
    if not segs:
        raise ValueError("segments must hold at least 1 segment")
    bt = _number(blend_time, "blend_time", 0.0)
    if duration is None and speed_percentage is None:
        timing = "DEFAULT"
    else:
        timing = _timing_fields(duration, speed_percentage)
    return _join("SMOOTH_BLEND", len(segs), bt, _word(frame, "frame", FRAMES),
                 _start_field(start_pose), timing) + "|" + "||".join(segs)


def build_stream(on: Any) -> str:
    """``STREAM|ON`` / ``STREAM|OFF``."""
    if isinstance(on, str):
        on = _choice(on, "stream", ("ON", "OFF")) == "ON"
    if not isinstance(on, bool):
        raise ValueError(f"stream must be True/False or 'ON'/'OFF', got {on!r}")
    return "STREAM|ON" if on else "STREAM|OFF"


def build_set_tool(name: Any) -> str:
    """**(ext)** ``SET_TOOL|name``."""
    if not isinstance(name, str) or not name.strip() or "|" in name:
        raise ValueError(f"tool name must be a non-empty string without '|', got {name!r}")
    return f"SET_TOOL|{name.strip()}"


def build_set_port(name: Any) -> str:
    """``SET_PORT|name`` (serial device of the board)."""
    if not isinstance(name, str) or not name.strip() or "|" in name:
        raise ValueError(f"port must be a non-empty device name without '|', got {name!r}")
    return f"SET_PORT|{name.strip()}"


def build_subscribe(port: Any, every_n: Any = 1, cookie: Optional[str] = None) -> str:
    """**(ext)** ``SUBSCRIBE|port|every_n_ticks[|cookie]``: ``cookie`` is the text of the
    controller's last ``COOKIE|`` answer on that socket (see :func:`parse_cookie`); the stream
    starts only once the socket echoes it."""
    fields: List[Any] = [_int(port, "port", 1, 65535), _int(every_n, "every_n", 1, 1_000_000)]
    if cookie is not None:
        if not isinstance(cookie, str) or not cookie.isascii() or not cookie.isprintable() or "|" in cookie:
            raise ValueError(f"cookie must be the printable ASCII text of a COOKIE reply, got {cookie!r}")
        fields.append(cookie)
    return _join("SUBSCRIBE", *fields)


def build_control(action: str, force: bool = False, secret: Optional[str] = None) -> str:
    """**(ext)** ``CONTROL|TAKE[|FORCE][|secret]`` or ``CONTROL|RELEASE`` (the control lease)."""
    act = str(action).strip().upper()
    if act == "RELEASE":
        return "CONTROL|RELEASE"
    if act != "TAKE":
        raise ValueError(f"action must be 'take' or 'release', got {action!r}")
    parts = ["CONTROL", "TAKE"] + (["FORCE"] if force else [])
    if secret is not None:
        if not isinstance(secret, str) or not secret or "|" in secret or not secret.isascii():
            raise ValueError("secret must be non-empty ASCII text without '|'")
        parts.append(secret)
    return "|".join(parts)


def build_unsubscribe(port: Any) -> str:
    """**(ext)** ``UNSUBSCRIBE|port``."""
    return _join("UNSUBSCRIBE", _int(port, "port", 1, 65535))


# =============================================================================================
# parsing
# =============================================================================================


_ID_ALPHABET = string.ascii_letters + string.digits
#: lower-case command names of 8 letters, which the controller reads as names, not IDs
_NAME_LIKE_IDS = frozenset({"movepose", "movecart", "multijog"})


def new_command_id() -> str:
    """A fresh, unguessable 8-character command ID: letters and digits from the operating
    system's random source (62**8, about 2**47 values), never all upper-case (the protocol reads
    an all-upper-case first field as a command name)."""
    while True:
        cid = "".join(secrets.choice(_ID_ALPHABET) for _ in range(8))
        if not cid.isupper() and cid.lower() not in _NAME_LIKE_IDS:
            return cid


def parse_reply(text: str, tag: str) -> str:
    """The payload of a ``TAG|payload`` reply (``""`` for a bare ``TAG`` such as ``PONG``);
    ``ValueError`` if the tag differs or on ``ERROR|``."""
    head, _, payload = text.partition("|")
    if head == tag:
        return payload
    if head == "ERROR":
        raise ValueError(f"controller answered ERROR: {payload}")
    raise ValueError(f"expected a {tag}|... reply, got {text[:80]!r}")


def parse_numbers(payload: str, count: Optional[int], what: str) -> List[float]:
    """Comma-separated numbers; ``count`` (if given) is checked."""
    try:
        values = [float(v) for v in payload.split(",")] if payload.strip() else []
    except ValueError:
        raise ValueError(f"{what}: not a list of numbers: {payload[:80]!r}") from None
    if count is not None and len(values) != count:
        raise ValueError(f"{what}: expected {count} values, got {len(values)}")
    return values


def parse_ack(text: str) -> Optional[Tuple[str, str, str]]:
    """``ACK|ID|STATUS|details`` -> (id, status, details); ``None`` if not an ack."""
    parts = text.split("|", 3)
    if len(parts) < 3 or parts[0] != "ACK":
        return None
    return parts[1], parts[2].strip().upper(), parts[3] if len(parts) > 3 else ""


def parse_cookie(text: str) -> Optional[str]:
    """The cookie of a ``COOKIE|c`` answer to SUBSCRIBE (send SUBSCRIBE again with it, from the
    same socket), or ``None`` when ``text`` is something else."""
    head, sep, cookie = text.partition("|")
    return cookie.strip() if head == "COOKIE" and sep and cookie.strip() else None


def parse_status_fields(payload: str) -> Dict[str, str]:
    """``KEY=value|KEY=value...`` of a GET_STATUS reply -> dict (values as text)."""
    out: Dict[str, str] = {}
    for part in payload.split("|"):
        key, sep, value = part.partition("=")
        if sep:
            out[key.strip().upper()] = value
    return out


class ControlInfo(TypedDict):
    """**(ext)** The ``GET_CONTROL`` answer: ``holder`` ("address:port", None when nobody holds
    the lease), ``held_s`` / ``idle_s`` (None when free), ``timeout_s``, ``secret_required``,
    ``refused`` (commands refused to non-holders), ``taken_over`` (forced take-overs)."""

    holder: Optional[str]
    held_s: Optional[float]
    idle_s: Optional[float]
    timeout_s: float
    secret_required: bool
    refused: int
    taken_over: int


def parse_control(payload: str) -> ControlInfo:
    """The JSON object of a ``CONTROL|{...}`` reply as a :class:`ControlInfo`; ``ValueError``
    naming a missing or mistyped field."""
    try:
        obj = json.loads(payload)
    except ValueError:
        raise ValueError(f"CONTROL: not JSON: {payload[:80]!r}") from None
    if not isinstance(obj, dict):
        raise ValueError(f"CONTROL: not a JSON object: {payload[:80]!r}")

    def field(key: str, kinds: Tuple[type, ...], optional: bool = False) -> Any:
        if key not in obj:
            raise ValueError(f"CONTROL: field {key!r} is missing")
        value = obj[key]
        if (value is None and optional) or (isinstance(value, kinds) and not (
                isinstance(value, bool) and bool not in kinds)):
            return value
        raise ValueError(f"CONTROL: {key} must be {' or '.join(k.__name__ for k in kinds)}"
                         f"{' or null' if optional else ''}, got {value!r}")

    def seconds(key: str, optional: bool = False) -> Optional[float]:
        value = field(key, (int, float), optional)
        return None if value is None else float(value)

    return ControlInfo(holder=field("holder", (str,), optional=True),
                       held_s=seconds("held_s", optional=True), idle_s=seconds("idle_s", optional=True),
                       timeout_s=float(field("timeout_s", (int, float))),
                       secret_required=field("secret_required", (bool,)),
                       refused=field("refused", (int,)), taken_over=field("taken_over", (int,)))


def matrix_to_pose(matrix: Sequence[Any]) -> List[float]:
    """4x4 tool pose (16 row-major numbers or 4 rows, translation in METRES) -> [x, y, z, A, B, C].

    x, y, z in mm; A, B, C in degrees with R = Rx(C) * Ry(B) * Rz(A), the convention of the
    original software (spatialmath ``T.rpy('deg', 'xyz')``, including its choice at the
    B = +-90 deg singularity: A = 0).
    """
    flat = [float(v) for row in matrix for v in (row if hasattr(row, "__iter__") else [row])]
    if len(flat) != 16:
        raise ValueError(f"a pose matrix needs 16 numbers, got {len(flat)}")
    r = [flat[0:3], flat[4:7], flat[8:11]]
    x, y, z = flat[3] * 1000.0, flat[7] * 1000.0, flat[11] * 1000.0
    eps = 20 * sys.float_info.epsilon
    if abs(abs(r[0][2]) - 1.0) < eps:
        a = 0.0
        if r[0][2] > 0:
            c = math.atan2(r[2][1], r[1][1])
        else:
            c = -math.atan2(r[1][0], r[2][0])
        b = math.asin(max(-1.0, min(1.0, r[0][2])))
    else:
        a = -math.atan2(r[0][1], r[0][0])
        c = -math.atan2(r[1][2], r[2][2])
        cands = [abs(r[0][0]), abs(r[0][1]), abs(r[1][2]), abs(r[2][2])]
        k = cands.index(max(cands))
        if k == 0:
            b = math.atan(r[0][2] * math.cos(a) / r[0][0])
        elif k == 1:
            b = -math.atan(r[0][2] * math.sin(a) / r[0][1])
        elif k == 2:
            b = -math.atan(r[0][2] * math.sin(c) / r[1][2])
        else:
            b = math.atan(r[0][2] * math.cos(c) / r[2][2])
    return [v + 0.0 for v in (x, y, z, math.degrees(a), math.degrees(b), math.degrees(c))]


# =============================================================================================
# sending and acknowledgements
# =============================================================================================


def send_robot_command(command_string: str) -> str:
    """Send one datagram to the controller without tracking.

    Once the acknowledgement listener runs (the first tracked command or
    :func:`take_control` starts it) the datagram goes out from its socket, as tracked commands
    do: the controller knows a client by its socket, so the process is then one client, and
    the control lease it took covers these commands too.  Before that, from a new socket, as
    the original client (no thread, no socket kept).

    Returns ``"Successfully sent command: '...'"``, or ``"Error sending command: ..."`` when the
    operating system refused to send it (the original's strings)."""
    tracker = _command_tracker
    try:
        if tracker is not None and tracker.is_active():
            tracker.send(command_string)
        else:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
                sock.sendto(command_string.encode("utf-8"), (SERVER_IP, SERVER_PORT))
    except OSError as exc:
        return f"Error sending command: {exc}"
    return f"Successfully sent command: '{command_string[:50]}...'"


def _from_controller(addr: Any) -> bool:
    """True when ``addr`` (a datagram's sender) is the controller's command socket: acks and
    replies come from it, so anything else (another process on the machine) is ignored."""
    key = (SERVER_IP, SERVER_PORT)
    known = _resolved.get(key)
    if known is None:
        known = _resolved[key] = _controller_addresses(*key)
    return (addr[0], addr[1]) in known


def _controller_addresses(host: str, port: int) -> FrozenSet[Tuple[str, int]]:
    try:
        infos = socket.getaddrinfo(host, port, socket.AF_INET, socket.SOCK_DGRAM)
    except OSError:
        return frozenset()
    return frozenset((str(info[4][0]), port) for info in infos)


_resolved: Dict[Tuple[str, int], FrozenSet[Tuple[str, int]]] = {}


class CommandRecord(TypedDict, total=False):
    """The original's record of a tracked command (what ``wait_for_ack=True`` returns): every
    key is there once the command was tracked; the record of a wait before tracking started
    holds only ``status`` (``NO_TRACKING``), ``details`` and ``completed``, and ``last_status``
    is there only in a ``TIMEOUT`` record."""

    command: Optional[str]
    sent_time: Optional[datetime]
    status: str
    details: str
    completed: bool
    ack_time: Optional[datetime]
    history: List[str]
    command_id: str
    last_status: str


class TrackingStats(TypedDict):
    """:func:`get_tracking_stats`: the original's keys, and ``ack_port``, ``pending``, ``foreign``."""

    active: bool
    commands_tracked: int
    memory_bytes: int
    thread_active: bool
    ack_port: Optional[int]
    pending: int
    foreign: int


#: what a wait returns when the tracker never started (the original's answer)
_NO_TRACKING = CommandRecord(status="NO_TRACKING", details="Tracker not initialized", completed=True)


class LazyCommandTracker:
    """The acknowledgement listener: a socket on ``listen_port`` and a daemon thread, both
    created on the first :meth:`track_command` (nothing runs before), as in the original.

    Acknowledgements are taken only from the controller's address (:data:`SERVER_IP`,
    :data:`SERVER_PORT`: anyone on the machine can send to this port) and only for IDs this
    tracker issued; IDs come from the operating system's random source
    (:func:`new_command_id`).  The first terminal status of a command is final.

    ``history_size``: completed commands kept for :meth:`get_status` (older completed ones are
    dropped first; commands still waiting for their terminal ack are kept).
    """

    def __init__(self, listen_port: int = 5002, history_size: int = 100) -> None:
        self.listen_port = _int(listen_port, "listen_port", 0, 65535)
        self.history_size = _int(history_size, "history_size", 1, 1_000_000)
        #: command id -> its record (see :meth:`get_status`), oldest first
        self.command_history: "OrderedDict[str, CommandRecord]" = OrderedDict()
        self.lock = threading.Condition()
        self._socket: Optional[socket.socket] = None
        self._thread: Optional[threading.Thread] = None
        self._initialized = False
        #: ack-shaped datagrams ignored because they did not come from the controller
        self.foreign = 0

    # ---- lifecycle

    def _lazy_init(self) -> None:
        """Bind the socket and start the thread (once); :class:`AckPortBusyError` when the port
        is taken."""
        with self.lock:
            if self._initialized:
                return
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                sock.bind(("", self.listen_port))
            except OSError as exc:
                sock.close()
                raise AckPortBusyError(
                    exc.errno,
                    f"cannot listen for acknowledgements on UDP port {self.listen_port}: {exc.strerror}. "
                    "Another program (another robot_api script, or a controller on this machine "
                    "using that port) holds it; call robot_api.configure(ack_port=N) with the port "
                    "the controller sends acks to (its --ack-port), or stop the other program.",
                ) from None
            sock.settimeout(0.2)
            self._socket = sock
            self._thread = threading.Thread(target=self._listen_loop, args=(sock,),
                                            name="robot_api-acks", daemon=True)
            self._initialized = True
            self._thread.start()

    def close(self) -> None:
        """Stop the thread and close the socket (a later :meth:`track_command` starts again)."""
        with self.lock:
            sock, thread = self._socket, self._thread
            self._socket = self._thread = None
            self._initialized = False
        if sock is not None:
            sock.close()
        if thread is not None and thread is not threading.current_thread():
            thread.join(1.0)

    def is_active(self) -> bool:
        """True once the listener runs."""
        return self._initialized and self._thread is not None and self._thread.is_alive()

    # ---- receiving

    def _listen_loop(self, sock: socket.socket) -> None:
        while True:
            try:
                data, addr = sock.recvfrom(65535)
            except socket.timeout:
                if self._socket is not sock:
                    return
                continue
            except OSError:
                if self._socket is not sock:
                    return  # closed by close()
                time.sleep(0.01)  # e.g. an ICMP error reported on the socket: keep listening
                continue
            ack = parse_ack(data.decode("utf-8", "replace"))
            if ack is None:
                continue
            if not _from_controller(addr):
                self.foreign += 1  # not the controller: not an ack
                continue
            self._record(*ack)

    def _record(self, cmd_id: str, status: str, details: str) -> None:
        with self.lock:
            rec = self.command_history.get(cmd_id)
            if rec is None or rec["completed"]:
                return  # not a command of ours, or already final
            rec["status"], rec["details"], rec["ack_time"] = status, details, datetime.now()
            rec["completed"] = status in TERMINAL_STATUSES
            rec["history"].append(status)
            self._prune()
            self.lock.notify_all()

    def _prune(self) -> None:
        done = [k for k, r in self.command_history.items() if r["completed"]]
        for k in done[: max(0, len(self.command_history) - self.history_size)]:
            del self.command_history[k]
        # never more than this many, pending or not (a controller that never answers)
        while len(self.command_history) > 10 * self.history_size + 1000:
            self.command_history.popitem(last=False)

    # ---- the original's methods

    def track_command(self, command: str) -> Tuple[str, str]:
        """Start the listener if needed and register ``command`` under a fresh ID; returns
        ``(tracked_command, cmd_id)`` where ``tracked_command`` is ``"ID|command"`` to send."""
        self._lazy_init()
        cmd_id = new_command_id()
        with self.lock:
            self.command_history[cmd_id] = {
                "command": command, "sent_time": datetime.now(), "status": "SENT", "details": "",
                "completed": False, "ack_time": None, "history": [],
            }
            self._prune()
        return f"{cmd_id}|{command}", cmd_id

    def get_status(self, cmd_id: str) -> Optional[CommandRecord]:
        """A copy of the record of ``cmd_id``: ``command``, ``sent_time`` / ``ack_time``
        (``datetime``; ack_time None before the first ack), ``status`` (SENT, QUEUED,
        EXECUTING or a terminal status), ``details``, ``completed``, ``history`` (every status
        received, in order), ``command_id``; None if unknown or never started."""
        if not self._initialized:
            return None
        with self.lock:
            rec = self.command_history.get(cmd_id)
            if rec is None:
                return None
            out = rec.copy()
            out["history"], out["command_id"] = list(rec["history"]), cmd_id
            return out

    def wait_for_completion(self, cmd_id: str, timeout: float = 5.0) -> CommandRecord:
        """Wait up to ``timeout`` s for the terminal ack of ``cmd_id``; returns its record (as
        :meth:`get_status`).  Without one in time: ``status`` ``'TIMEOUT'``, ``completed``
        False, ``last_status`` the last status received (the command may still run)."""
        t = _number(timeout, "timeout", 0.0)
        if not self._initialized:
            return _NO_TRACKING.copy()
        deadline = time.monotonic() + t
        with self.lock:
            while True:
                rec = self.get_status(cmd_id)
                if rec is not None and rec["completed"]:
                    return rec
                left = deadline - time.monotonic()
                if left <= 0:
                    last = rec["status"] if rec else "SENT"
                    out = rec if rec is not None else CommandRecord(
                        command=None, sent_time=None, ack_time=None, history=[], command_id=cmd_id)
                    out["status"], out["completed"], out["last_status"] = "TIMEOUT", False, last
                    out["details"] = (f"no terminal acknowledgement within {t:g} s (last status: "
                                      f"{last}); the command may still run")
                    return out
                self.lock.wait(left)

    # ---- parolkit additions

    def send(self, text: str) -> None:
        """Send ``text`` to the controller from the listening socket, so a controller that
        acks the sender's port reaches us even on port 0."""
        with self.lock:
            sock = self._socket
        if sock is None:
            raise OSError("the acknowledgement listener is not running")
        sock.sendto(text.encode("utf-8"), (SERVER_IP, SERVER_PORT))

    def stats(self) -> TrackingStats:
        """``active``, ``commands_tracked``, ``memory_bytes``, ``thread_active`` (the
        original's keys) and ``ack_port`` (the port bound), ``pending``, ``foreign``."""
        with self.lock:
            sock = self._socket
            return TrackingStats(
                active=self.is_active(),
                commands_tracked=len(self.command_history),
                memory_bytes=len(str(self.command_history)),
                thread_active=self._thread is not None and self._thread.is_alive(),
                ack_port=sock.getsockname()[1] if sock is not None else None,
                pending=sum(1 for r in self.command_history.values() if not r["completed"]),
                foreign=self.foreign,
            )


#: the module's tracker (created on the first tracked command, on :data:`ACK_PORT`)
_command_tracker: Optional[LazyCommandTracker] = None
_tracker_lock = threading.Lock()


def _get_tracker() -> LazyCommandTracker:
    """The module's tracker on :data:`ACK_PORT` (a new one after the port changed)."""
    global _command_tracker
    with _tracker_lock:
        tracker = _command_tracker
        if tracker is None or tracker.listen_port != ACK_PORT:
            if tracker is not None:
                tracker.close()
            tracker = _command_tracker = LazyCommandTracker(ACK_PORT)
        return tracker


def _stop_tracker() -> None:
    global _command_tracker
    with _tracker_lock:
        old, _command_tracker = _command_tracker, None
    if old is not None:
        old.close()


def send_robot_command_tracked(command_string: str) -> Tuple[str, Optional[str]]:
    """Send with a fresh ID (starting the ack listener if needed); returns (message, id)."""
    tracker = _get_tracker()
    tracked, cmd_id = tracker.track_command(command_string)
    tracker.send(tracked)
    return f"Command sent with tracking (ID: {cmd_id})", cmd_id


@overload
def send_and_wait(command_string: str, timeout: float = 2.0,
                  non_blocking: Literal[False] = False) -> CommandRecord: ...
@overload
def send_and_wait(command_string: str, timeout: float = 2.0, *,
                  non_blocking: Literal[True]) -> Optional[str]: ...
@overload
def send_and_wait(command_string: str, timeout: float = 2.0,
                  non_blocking: bool = False) -> Union[CommandRecord, str, None]: ...
def send_and_wait(command_string: str, timeout: float = 2.0,
                  non_blocking: bool = False) -> Union[CommandRecord, str, None]:
    """Send with an ID; return the command ID at once (``non_blocking``) or the record of
    its terminal acknowledgement: ``{'command', 'sent_time', 'status', 'details', 'completed',
    'ack_time', 'command_id', ...}`` (times are ``datetime``); status ``'TIMEOUT'`` when none
    came within ``timeout`` s (see :meth:`LazyCommandTracker.wait_for_completion`)."""
    t = _number(timeout, "timeout", 0.0)
    _, cmd_id = send_robot_command_tracked(command_string)
    if non_blocking:
        return cmd_id
    assert cmd_id is not None
    return _get_tracker().wait_for_completion(cmd_id, t)


#: What a motion/action function returns: the confirmation string (fire and forget), the
#: :class:`CommandRecord` (``wait_for_ack=True``) or the command ID (``non_blocking=True``).
Result = Union[CommandRecord, str, None]


def _dispatch(command: str, wait_for_ack: bool, timeout: float, non_blocking: bool) -> Result:
    if wait_for_ack:
        return send_and_wait(command, timeout, non_blocking)
    return send_robot_command(command)


def check_command_status(command_id: str) -> Optional[CommandRecord]:
    """The latest known record of a tracked command (see :meth:`LazyCommandTracker.get_status`),
    or None if unknown or tracking never started."""
    tracker = _command_tracker
    if tracker is None or not tracker.is_active():
        return None
    return tracker.get_status(command_id)


def is_tracking_active() -> bool:
    """True once the acknowledgement listener runs (False if tracking was never used)."""
    tracker = _command_tracker
    return tracker is not None and tracker.is_active()


def get_tracking_stats() -> TrackingStats:
    """``{'active', 'commands_tracked', 'memory_bytes', 'thread_active'}`` as the original,
    plus ``ack_port`` (the port bound), ``pending`` and ``foreign`` (ignored datagrams)."""
    tracker = _command_tracker
    if tracker is None:
        return TrackingStats(active=False, commands_tracked=0, memory_bytes=0, thread_active=False,
                             ack_port=None, pending=0, foreign=0)
    return tracker.stats()


# =============================================================================================
# motion and action functions (original names, arguments and defaults)
# =============================================================================================


def move_robot_joints(joint_angles: List[float], duration: Optional[float] = None,
                      speed_percentage: Optional[float] = None, wait_for_ack: bool = False,
                      timeout: float = 2.0, non_blocking: bool = False, *,
                      blend: Optional[float] = None) -> Result:
    """Joint-space move to ``joint_angles`` (J1..J6, deg) in ``duration`` s or at
    ``speed_percentage``.  **(ext)** ``blend`` (deg, 0..100): round the corner into the next
    queued joint-space move within that distance, so the arm does not stop at the target."""
    return _dispatch(build_move_joint(joint_angles, duration, speed_percentage, blend=blend), wait_for_ack,
                     timeout, non_blocking)


def move_robot_pose(pose: List[float], duration: Optional[float] = None,
                    speed_percentage: Optional[float] = None, wait_for_ack: bool = False,
                    timeout: float = 2.0, non_blocking: bool = False, *,
                    blend: Optional[float] = None) -> Result:
    """Move to ``pose`` [x, y, z, A, B, C] (mm, deg) via IK, joint-space path.  **(ext)**
    ``blend`` (deg, 0..100) as :func:`move_robot_joints`'s."""
    return _dispatch(build_move_pose(pose, duration, speed_percentage, blend=blend), wait_for_ack, timeout,
                     non_blocking)


def move_robot_cartesian(pose: List[float], duration: Optional[float] = None,
                         speed_percentage: Optional[float] = None, wait_for_ack: bool = False,
                         timeout: float = 2.0, non_blocking: bool = False, *,
                         blend: Optional[float] = None) -> Result:
    """Straight-line move to ``pose`` [x, y, z, A, B, C] (mm, deg).  **(ext)** ``blend`` (mm,
    0..100): round the corner into the next queued straight-line move within that distance of
    the target, so the arm does not stop there."""
    return _dispatch(build_move_cart(pose, duration, speed_percentage, blend=blend), wait_for_ack, timeout,
                     non_blocking)


def move_robot_cartesian_rel_trf(delta: List[float], duration: Optional[float] = None,
                                 speed_percentage: Optional[float] = None,
                                 wait_for_ack: bool = False, timeout: float = 2.0,
                                 non_blocking: bool = False) -> Result:
    """Relative straight-line move in the tool frame: [dx, dy, dz, dA, dB, dC] (mm, deg)."""
    return _dispatch(build_move_cart_rel_trf(delta, duration, speed_percentage), wait_for_ack,
                     timeout, non_blocking)


def jog_robot_joint(joint_index: int, speed_percentage: float, duration: Optional[float] = None,
                    distance_deg: Optional[float] = None, wait_for_ack: bool = False,
                    timeout: float = 2.0, non_blocking: bool = False) -> Result:
    """Jog one joint: index 0-5 = J1-J6 positive, 6-11 = J1-J6 negative; for ``duration`` s
    and/or ``distance_deg`` degrees at ``speed_percentage`` of its jog speed."""
    return _dispatch(build_jog(joint_index, speed_percentage, duration, distance_deg),
                     wait_for_ack, timeout, non_blocking)


def jog_multiple_joints(joints: List[int], speeds: List[float], duration: float,
                        wait_for_ack: bool = False, timeout: float = 2.0,
                        non_blocking: bool = False) -> Result:
    """Jog several joints at once (indices as :func:`jog_robot_joint`, speeds in %)."""
    return _dispatch(build_multijog(joints, speeds, duration), wait_for_ack, timeout, non_blocking)


def jog_cartesian(frame: str, axis: str, speed_percentage: float, duration: float,
                  wait_for_ack: bool = False, timeout: float = 2.0,
                  non_blocking: bool = False) -> Result:
    """Cartesian jog in ``frame`` ('WRF'/'TRF') along/about ``axis`` ('X+' ... 'RZ-')."""
    return _dispatch(build_cartjog(frame, axis, speed_percentage, duration), wait_for_ack, timeout,
                     non_blocking)


def control_pneumatic_gripper(action: str, port: int, wait_for_ack: bool = False,
                              timeout: float = 2.0, non_blocking: bool = False) -> Result:
    """Open/close the pneumatic gripper on output ``port`` (1 or 2)."""
    return _dispatch(build_pneumatic_gripper(action, port), wait_for_ack, timeout, non_blocking)


def control_electric_gripper(action: str, position: Optional[int] = 255,
                             speed: Optional[int] = 150, current: Optional[int] = 500,
                             wait_for_ack: bool = False, timeout: float = 2.0,
                             non_blocking: bool = False) -> Result:
    """SSG-48 gripper: ``action`` 'move' or 'calibrate' (or 'clear_error');
    position 0..255, speed 0..255, current 0..1300 mA."""
    return _dispatch(build_electric_gripper(action, position, speed, current), wait_for_ack,
                     timeout, non_blocking)


def delay_robot(duration: float, wait_for_ack: bool = False, timeout: float = 2.0,
                non_blocking: bool = False) -> Result:
    """Queue a pause of ``duration`` seconds."""
    return _dispatch(build_delay(duration), wait_for_ack, timeout, non_blocking)


def home_robot(wait_for_ack: bool = False, timeout: float = 30.0,
               non_blocking: bool = False) -> Result:
    """Run the board's homing sequence."""
    return _dispatch(build_home(), wait_for_ack, timeout, non_blocking)


def take_control(force: bool = False, secret: Optional[str] = None, timeout: float = 2.0
                 ) -> CommandRecord:
    """**(ext)** Take the control lease: only its holder may move the robot (while nobody holds
    it, any script may).  From the call on, every command of this process goes out from the
    acknowledgement listener's socket, the client that holds the lease.  ``force`` takes it from
    another client and cancels that client's commands.  Returns the terminal ack dict."""
    return send_and_wait(build_control("TAKE", force, secret), timeout)


def release_control(timeout: float = 2.0) -> CommandRecord:
    """**(ext)** Give the control lease back (another client may then command the robot)."""
    return send_and_wait(build_control("RELEASE"), timeout)


def get_control() -> Optional[ControlInfo]:
    """**(ext)** Who holds the control lease: ``{'holder', 'held_s', 'idle_s', 'timeout_s',
    'secret_required', 'refused', 'taken_over'}`` (holder None when free), or None (message on
    stderr) without a reply or for a malformed one."""
    payload = _query("GET_CONTROL", "CONTROL")
    if payload is None:
        return None
    try:
        return parse_control(payload)
    except ValueError as exc:
        print(f"robot_api: GET_CONTROL: {exc}", file=sys.stderr)
        return None


def set_speed_override(percent: float, wait_for_ack: bool = False, timeout: float = 2.0,
                       non_blocking: bool = False) -> Result:
    """**(ext)** The speed override, 1..100 % of every planned speed: the running move slows
    down or speeds up on its own path within the acceleration limits, and every move after it
    runs so, until changed."""
    return _dispatch(build_speed(percent), wait_for_ack, timeout, non_blocking)


def servo_joints(angles: List[float]) -> str:
    """**(ext)** Stream a servo target (deg): the latest wins, an online jerk-limited generator
    moves the joints toward it within their limits from the controller's next frame.  Send
    targets at the control rate or faster; without one for 0.05 s (``servo.timeout_s``) the arm
    makes a controlled stop and the stream ends.  Fire and forget (no acknowledgement: at
    100-250 targets a second a lost one is replaced by the next); returns the send result."""
    return send_robot_command(build_servo_j(angles))


def servo_pose(pose: List[float], frame: str = "WRF") -> str:
    """**(ext)** Stream a servo target pose [x, y, z mm, A, B, C deg] of the TCP, in the world
    frame or (``frame="TRF"``) relative to the TCP pose where the stream started; as
    :func:`servo_joints`."""
    return send_robot_command(build_servo_l(pose, frame))


def pause_robot(wait_for_ack: bool = False, timeout: float = 2.0, non_blocking: bool = False,
                queue_only: bool = False) -> Result:
    """**(ext)** The running move slows down on its own path and holds; nothing queued starts
    until :func:`resume_robot` (STOP cancels it all).  ``queue_only``: the running command goes
    on to its end, only the queue waits (``PAUSE|QUEUE``)."""
    return _dispatch("PAUSE|QUEUE" if queue_only else "PAUSE", wait_for_ack, timeout, non_blocking)


def resume_robot(wait_for_ack: bool = False, timeout: float = 2.0, non_blocking: bool = False,
                 one: bool = False) -> Result:
    """**(ext)** A paused move continues on the same path to the same target; the queue runs again.
    ``one`` (``RESUME|ONE``): the move goes on, but the queue is held (as by
    ``pause_robot(queue_only=True)``) and lets one more command start."""
    return _dispatch("RESUME|ONE" if one else "RESUME", wait_for_ack, timeout, non_blocking)


#: label -> command ID of the checkpoints this process queued (newest per label)
_checkpoints: Dict[str, str] = {}
_checkpoints_lock = threading.Lock()


def checkpoint(label: str) -> Optional[str]:
    """**(ext)** Queue a checkpoint: the controller acknowledges it COMPLETED when the queue
    reaches it (everything sent before it has ended).  Returns its command ID; wait for it with
    :func:`wait_checkpoint` (by label or ID)."""
    text = build_checkpoint(label)
    _, cmd_id = send_robot_command_tracked(text)
    if cmd_id is not None:
        with _checkpoints_lock:
            _checkpoints[label] = cmd_id
    return cmd_id


def wait_checkpoint(label: str, timeout: float = 60.0) -> CommandRecord:
    """**(ext)** Wait up to ``timeout`` s until the checkpoint ``label`` (the newest one queued
    with :func:`checkpoint` under that label) is reached: its record, ``status`` COMPLETED when
    reached, FAILED / CANCELLED when the queue ended before it (a STOP, an E-stop), ``TIMEOUT``
    when not yet.  ValueError for a label this process never queued."""
    t = _number(timeout, "timeout", 0.0)
    with _checkpoints_lock:
        cmd_id = _checkpoints.get(label)
    if cmd_id is None:
        raise ValueError(f"no checkpoint {label!r} was queued by this process (call checkpoint({label!r}) first)")
    return _get_tracker().wait_for_completion(cmd_id, t)


def stop_robot_movement(wait_for_ack: bool = False, timeout: float = 2.0,
                        non_blocking: bool = False) -> Result:
    """Cancel the active command and clear the queue: a planned move slows down on its own path
    within the acceleration limits and ends CANCELLED there (a jog stops at once); the robot
    then holds position."""
    return _dispatch("STOP", wait_for_ack, timeout, non_blocking)


def smooth_circle(center: List[float], radius: float, plane: str = "XY", frame: str = "WRF",
                  start_pose: Optional[List[float]] = None, duration: Optional[float] = None,
                  speed_percentage: Optional[float] = None, clockwise: bool = False,
                  wait_for_ack: bool = False, timeout: float = 10.0,
                  non_blocking: bool = False) -> Result:
    """Full circle of ``radius`` mm about ``center`` [x, y, z] mm in ``plane``."""
    return _dispatch(build_smooth_circle(center, radius, plane, frame, start_pose, duration,
                                         speed_percentage, clockwise),
                     wait_for_ack, timeout, non_blocking)


def smooth_arc_center(end_pose: List[float], center: List[float], frame: str = "WRF",
                      start_pose: Optional[List[float]] = None, duration: Optional[float] = None,
                      speed_percentage: Optional[float] = None, clockwise: bool = False,
                      wait_for_ack: bool = False, timeout: float = 10.0,
                      non_blocking: bool = False) -> Result:
    """Arc to ``end_pose`` about ``center`` [x, y, z] mm."""
    return _dispatch(build_smooth_arc_center(end_pose, center, frame, start_pose, duration,
                                             speed_percentage, clockwise),
                     wait_for_ack, timeout, non_blocking)


def smooth_arc_parametric(end_pose: List[float], radius: float, arc_angle: float,
                          frame: str = "WRF", start_pose: Optional[List[float]] = None,
                          duration: Optional[float] = None,
                          speed_percentage: Optional[float] = None, clockwise: bool = False,
                          wait_for_ack: bool = False, timeout: float = 10.0,
                          non_blocking: bool = False) -> Result:
    """Arc to ``end_pose`` with ``radius`` mm and ``arc_angle`` degrees."""
    return _dispatch(build_smooth_arc_param(end_pose, radius, arc_angle, frame, start_pose,
                                            duration, speed_percentage, clockwise),
                     wait_for_ack, timeout, non_blocking)


def smooth_spline(waypoints: List[List[float]], frame: str = "WRF",
                  start_pose: Optional[List[float]] = None, duration: Optional[float] = None,
                  speed_percentage: Optional[float] = None, wait_for_ack: bool = False,
                  timeout: float = 10.0, non_blocking: bool = False) -> Result:
    """Cubic spline through ``waypoints`` (poses [x, y, z, A, B, C] in mm/deg)."""
    return _dispatch(build_smooth_spline(waypoints, frame, start_pose, duration, speed_percentage),
                     wait_for_ack, timeout, non_blocking)


def smooth_helix(center: List[float], radius: float, pitch: float, height: float,
                 frame: str = "WRF", start_pose: Optional[List[float]] = None,
                 duration: Optional[float] = None, speed_percentage: Optional[float] = None,
                 clockwise: bool = False, wait_for_ack: bool = False, timeout: float = 10.0,
                 non_blocking: bool = False) -> Result:
    """Helix about ``center`` (mm): ``radius``, ``pitch`` per turn and total ``height`` in mm."""
    return _dispatch(build_smooth_helix(center, radius, pitch, height, frame, start_pose, duration,
                                        speed_percentage, clockwise),
                     wait_for_ack, timeout, non_blocking)


def smooth_blend(segments: List[Dict[str, Any]], blend_time: float = 0.5, frame: str = "WRF",
                 start_pose: Optional[List[float]] = None, duration: Optional[float] = None,
                 speed_percentage: Optional[float] = None, wait_for_ack: bool = False,
                 timeout: float = 15.0, non_blocking: bool = False) -> Result:
    """Blend LINE/CIRCLE/ARC/SPLINE segments into one path (see :func:`build_smooth_blend`)."""
    return _dispatch(build_smooth_blend(segments, blend_time, frame, start_pose, duration,
                                        speed_percentage),
                     wait_for_ack, timeout, non_blocking)


# ---- the original's convenience functions ----

#: chain_smooth_motions types -> (builder, the key holding where the motion ends or None)
_CHAIN_TYPES: Dict[str, Tuple[Callable[..., str], Optional[str]]] = {
    "circle": (build_smooth_circle, None),
    "arc": (build_smooth_arc_center, "end_pose"),
    "arc_center": (build_smooth_arc_center, "end_pose"),
    "arc_param": (build_smooth_arc_param, "end_pose"),
    "arc_parametric": (build_smooth_arc_param, "end_pose"),
    "spline": (build_smooth_spline, "waypoints"),
    "helix": (build_smooth_helix, None),
}

#: statuses after which a sequence of tracked moves goes no further
_SEQUENCE_ENDS = ("FAILED", "INVALID", "CANCELLED")


def _ended(result: Result) -> bool:
    return isinstance(result, dict) and result.get("status") in _SEQUENCE_ENDS


def chain_smooth_motions(motions: List[Dict[str, Any]], ensure_continuity: bool = True,
                         frame: str = "WRF", wait_for_ack: bool = True,
                         timeout: float = 30.0) -> List[Result]:
    """Send several smooth motions one after another; returns the list of their results.

    Each item is a dict with ``'type'`` (``circle``, ``arc`` / ``arc_center``, ``arc_param`` /
    ``arc_parametric``, ``spline``, ``helix``) and that function's keyword parameters, e.g.
    ``{'type': 'circle', 'center': [0, 250, 200], 'radius': 30, 'duration': 4}``; ``frame``
    applies to all.  With ``ensure_continuity`` each motion after the first starts at the
    previous one's end pose (an arc's ``end_pose``, a spline's last waypoint; after a circle or
    a helix the next one starts where the robot is).  With ``wait_for_ack`` (default) each is
    sent once the previous one is finished (``timeout`` s each) and the chain stops at the
    first FAILED (and, unlike the original, also at INVALID or CANCELLED: a STOP ends it).

    Every motion is checked before the first one is sent (``ValueError`` naming the item); the
    caller's dicts are not changed.
    """
    if isinstance(motions, (str, bytes, dict)) or not hasattr(motions, "__iter__"):
        raise ValueError(f"motions must be a list of motion dicts, got {motions!r}")
    commands: List[str] = []
    last_end: Any = None
    for i, motion in enumerate(motions):
        if not isinstance(motion, dict):
            raise ValueError(f"motions[{i}] must be a dict with a 'type', got {motion!r}")
        kind = str(motion.get("type", "")).strip().lower()
        entry = _CHAIN_TYPES.get(kind)
        if entry is None:
            raise ValueError(f"motions[{i}]['type'] must be one of {', '.join(_CHAIN_TYPES)}, "
                             f"got {motion.get('type')!r}")
        builder, end_key = entry
        params = {k: v for k, v in motion.items() if k != "type"}
        params["frame"] = frame
        if ensure_continuity and last_end is not None and i > 0:
            params["start_pose"] = last_end
        try:
            commands.append(builder(**params))
        except TypeError as exc:  # a key the function does not take
            raise ValueError(f"motions[{i}] ({kind}): {exc}") from None
        except ValueError as exc:
            raise ValueError(f"motions[{i}] ({kind}): {exc}") from None
        if end_key == "waypoints":
            wps = list(motion.get("waypoints") or [])
            last_end = wps[-1] if wps else None
        else:
            last_end = motion.get(end_key) if end_key else None
    return _send_in_turn(commands, wait_for_ack, timeout)


def _send_in_turn(commands: List[str], wait_for_ack: bool, timeout: float) -> List[Result]:
    """Send ``commands`` one after the other; with ``wait_for_ack`` each waits for its result
    and the first one that did not complete (FAILED, INVALID, CANCELLED, TIMEOUT) ends the
    sequence.  The list of results."""
    results: List[Result] = []
    for command in commands:
        result = _dispatch(command, wait_for_ack, timeout, False)
        results.append(result)
        if wait_for_ack and _ended(result):
            break
    return results


def execute_trajectory(trajectory: List[List[float]], timing_mode: str = "duration",
                       timing_value: float = 5.0, motion_type: str = "spline", frame: str = "WRF",
                       wait_for_ack: bool = True, timeout: float = 30.0) -> Union[Result, List[Result]]:
    """Move through the poses of ``trajectory`` ([x, y, z, A, B, C] mm/deg each).

    ``motion_type='spline'``: one :func:`smooth_spline` timed by ``timing_mode`` ``'duration'``
    (``timing_value`` s in total) or ``'speed'`` (``timing_value`` %); returns its result.
    ``motion_type='linear'``: one :func:`move_robot_cartesian` per pose (the duration split
    evenly, or every move at the speed %), stopping at the first FAILED (also INVALID or
    CANCELLED); returns the list of results.  Linear moves are world-frame MOVECARTs: ``frame``
    must then be ``'WRF'`` (the original ignored a ``'TRF'`` there; this refuses it).
    Every pose is checked before anything is sent.
    """
    mode = _choice(timing_mode, "timing_mode", ("duration", "speed"), upper=False)
    kind = _choice(motion_type, "motion_type", ("spline", "linear"), upper=False)
    if isinstance(trajectory, (str, bytes)) or not hasattr(trajectory, "__iter__"):
        raise ValueError(f"trajectory must be a list of poses [x, y, z, A, B, C], got {trajectory!r}")
    poses = list(trajectory)
    timing = {"duration": timing_value} if mode == "duration" else {"speed_percentage": timing_value}
    if kind == "spline":
        return _dispatch(build_smooth_spline(poses, frame, None, **timing), wait_for_ack, timeout, False)
    if _choice(frame, "frame", FRAMES) != "WRF":
        raise ValueError("linear trajectories are world-frame MOVECART moves: give frame='WRF' "
                         "(or motion_type='spline' for a tool-frame path)")
    if not poses:
        raise ValueError("trajectory must hold at least 1 pose")
    if mode == "duration":
        timing = {"duration": _positive(timing_value, "timing_value") / len(poses)}
    commands = [build_move_cart(_pose(p, f"trajectory[{i}]"), **timing) for i, p in enumerate(poses)]
    return _send_in_turn(commands, wait_for_ack, timeout)


def safe_move_with_retry(move_func: Callable[..., Result], *args: Any, max_retries: int = 3,
                         retry_delay: float = 1.0,
                         **kwargs: Any) -> Result:
    """Call ``move_func(*args, **kwargs, wait_for_ack=True)`` until it is accepted.

    A COMPLETED, QUEUED or EXECUTING result is returned at once; FAILED, TIMEOUT or CANCELLED is
    tried again after ``retry_delay`` s, at most ``max_retries`` attempts in all, and the last
    result is returned.  Two cases are returned at once instead of being sent again: INVALID
    (the same datagram would be refused again) and a TIMEOUT whose last status was QUEUED or
    EXECUTING (the controller has the command and is running it: a retry would run it twice).
    A result that is not a dict (a function without tracking) is returned as it is.
    """
    tries = _int(max_retries, "max_retries", 1, 1_000_000)
    delay = _number(retry_delay, "retry_delay", 0.0)
    kwargs["wait_for_ack"] = True
    result: Result = None
    for attempt in range(tries):
        result = move_func(*args, **kwargs)
        if not isinstance(result, dict):
            return result
        status = result.get("status")
        if status in ("COMPLETED", "QUEUED", "EXECUTING"):
            return result
        if status == "TIMEOUT" and result.get("last_status") in ("QUEUED", "EXECUTING"):
            return result
        if status not in ("FAILED", "TIMEOUT", "CANCELLED"):
            return result
        if attempt < tries - 1:
            print(f"robot_api: attempt {attempt + 1} of {tries} ended {status}: "
                  f"{result.get('details', '')}; retrying in {delay:g} s", file=sys.stderr)
            time.sleep(delay)
    return result


# ---- extensions (parolkit controller) ----


def enable_robot(wait_for_ack: bool = False, timeout: float = 2.0,
                 non_blocking: bool = False) -> Result:
    """ENABLE: enable the robot; clears a released E-stop latch and a latched error."""
    return _dispatch("ENABLE", wait_for_ack, timeout, non_blocking)


def disable_robot(wait_for_ack: bool = False, timeout: float = 2.0,
                  non_blocking: bool = False) -> Result:
    """DISABLE the robot (no steps generated)."""
    return _dispatch("DISABLE", wait_for_ack, timeout, non_blocking)


def clear_robot_error(wait_for_ack: bool = False, timeout: float = 2.0,
                      non_blocking: bool = False) -> Result:
    """CLEAR_ERROR: clear a latched error."""
    return _dispatch("CLEAR_ERROR", wait_for_ack, timeout, non_blocking)


def estop_robot(wait_for_ack: bool = False, timeout: float = 2.0,
                non_blocking: bool = False) -> Result:
    """**(ext)** software E-stop (latched until :func:`enable_robot`)."""
    return _dispatch("ESTOP", wait_for_ack, timeout, non_blocking)


def speed_robot_joints(speeds_deg_s: List[float], duration: float, wait_for_ack: bool = False,
                       timeout: float = 2.0, non_blocking: bool = False) -> Result:
    """**(ext)** constant joint speeds (deg/s, J1..J6) for ``duration`` s."""
    return _dispatch(build_speed_joint(speeds_deg_s, duration), wait_for_ack, timeout, non_blocking)


def wait_robot_input(input_number: int, state: int, input_timeout: Optional[float] = None,
                     wait_for_ack: bool = False, timeout: float = 2.0,
                     non_blocking: bool = False) -> Result:
    """**(ext)** queue a wait until IN``input_number`` equals ``state`` (FAILED after
    ``input_timeout`` s)."""
    return _dispatch(build_wait_input(input_number, state, input_timeout), wait_for_ack, timeout,
                     non_blocking)


def set_robot_tool(name: str, wait_for_ack: bool = False, timeout: float = 2.0,
                   non_blocking: bool = False) -> Result:
    """**(ext)** select a tool by name ('default', 'flange' or one from the config)."""
    return _dispatch(build_set_tool(name), wait_for_ack, timeout, non_blocking)


def set_stream_mode(on: bool, wait_for_ack: bool = False, timeout: float = 2.0,
                    non_blocking: bool = False) -> Result:
    """Streaming jog mode on/off (newest jog replaces the previous one)."""
    return _dispatch(build_stream(on), wait_for_ack, timeout, non_blocking)


# =============================================================================================
# queries
# =============================================================================================


def _query(request: str, tag: str) -> Optional[str]:
    """Send a query and return its payload, or None (message on stderr) on timeout/error."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.settimeout(QUERY_TIMEOUT)
            # connected: only the controller's reply can arrive (no forged answers)
            sock.connect((SERVER_IP, SERVER_PORT))
            sock.send(request.encode("utf-8"))
            deadline = time.monotonic() + QUERY_TIMEOUT
            while True:
                data, _ = sock.recvfrom(65535)
                text = data.decode("utf-8", "replace")
                head = text.partition("|")[0]
                if head in (tag, "ERROR"):
                    return parse_reply(text, tag)
                left = deadline - time.monotonic()  # a stray datagram: keep waiting
                if left <= 0:
                    raise socket.timeout()
                sock.settimeout(left)
    except socket.timeout:
        print(f"robot_api: no {tag} reply from {SERVER_IP}:{SERVER_PORT} within "
              f"{QUERY_TIMEOUT:g} s (is the controller running?)", file=sys.stderr)
    except (OSError, ValueError) as exc:
        print(f"robot_api: {request} failed: {exc}", file=sys.stderr)
    return None


@overload
def _query_values(request: str, tag: str, count: int,
                  as_int: Literal[False] = False) -> Optional[List[float]]: ...
@overload
def _query_values(request: str, tag: str, count: int, as_int: Literal[True]) -> Optional[List[int]]: ...
def _query_values(request: str, tag: str, count: int,
                  as_int: bool = False) -> Union[List[float], List[int], None]:
    """Query and parse ``count`` comma-separated numbers; None (message on stderr) when there
    is no reply or the reply is malformed."""
    payload = _query(request, tag)
    if payload is None:
        return None
    try:
        return _ints(payload, count, tag) if as_int else parse_numbers(payload, count, tag)
    except ValueError as exc:
        print(f"robot_api: {exc}", file=sys.stderr)
        return None


def _pose_rows() -> Optional[List[List[float]]]:
    m = _query_values("GET_POSE", "POSE", 16)
    return None if m is None else [m[0:4], m[4:8], m[8:12], m[12:16]]


def get_robot_pose_matrix() -> Any:
    """The 4x4 tool pose (translation in METRES), or None: a numpy array of shape (4, 4) as the
    original returned, or a list of 4 rows where numpy is not installed (numpy is imported only
    here, so the module itself needs only the standard library)."""
    rows = _pose_rows()
    if rows is None:
        return None
    try:
        import numpy
    except ImportError:
        return rows
    return numpy.array(rows, dtype=float)


def get_robot_pose() -> Optional[List[float]]:
    """[x, y, z, A, B, C] in mm / deg (R = Rx(C) Ry(B) Rz(A)), or None."""
    m = _pose_rows()
    return None if m is None else matrix_to_pose(m)


def get_robot_joint_angles() -> Optional[List[float]]:
    """[J1..J6] in degrees, or None."""
    return _query_values("GET_ANGLES", "ANGLES", 6)


def get_robot_joint_speeds() -> Optional[List[float]]:
    """[J1..J6] joint speeds in steps/s, or None."""
    return _query_values("GET_SPEEDS", "SPEEDS", 6)


def _ints(payload: str, count: int, what: str) -> List[int]:
    values = parse_numbers(payload, count, what)
    return [int(v) for v in values]


def get_robot_io(verbose: bool = False) -> Optional[List[int]]:
    """[IN1, IN2, OUT1, OUT2, ESTOP] as 0/1 (ESTOP 0 = pressed), or None; ``verbose`` prints."""
    io = _query_values("GET_IO", "IO", 5, as_int=True)
    if io is None:
        return None
    if verbose:
        print("--- I/O status ---")
        for name, v in zip(("IN1", "IN2", "OUT1", "OUT2"), io):
            print(f"  {name:<5} {v} | {'ON' if v else 'OFF'}")
        print(f"  ESTOP {io[4]} | {'PRESSED' if io[4] == 0 else 'released (OK)'}")
    return io


def get_electric_gripper_status(verbose: bool = False) -> Optional[List[int]]:
    """[id, position, speed, current, status_byte, object_detection], or None.

    Status byte bits: 0x80 activated, 0x40 action, 0x20/0x10 object code (0 moving,
    1 object while closing, 2 object while opening, 3 at position), 0x08 temperature error,
    0x04 timeout error, 0x02 E-stop/error, 0x01 calibrated.  ``verbose`` prints them.
    """
    g = _query_values("GET_GRIPPER", "GRIPPER", 6, as_int=True)
    if g is None:
        return None
    if verbose:
        s = g[4]
        code = ((s >> 5) & 1) << 1 | ((s >> 4) & 1)
        code_text = ("moving", "object found while closing", "object found while opening",
                     "at position")[code]
        print("--- Electric gripper status ---")
        print(f"  ID: {g[0]}  position: {g[1]}  speed: {g[2]}  current: {g[3]} mA")
        print(f"  status byte: 0x{s:02X}  activated={bool(s & 0x80)} calibrated={bool(s & 0x01)} "
              f"error={bool(s & 0x02)}  object: {code_text}")
    return g


def is_robot_stopped(threshold_speed: float = 2.0) -> bool:
    """True when every joint speed is below ``threshold_speed`` steps/s (False if no reply)."""
    speeds = get_robot_joint_speeds()
    if not speeds:
        return False
    return max(abs(s) for s in speeds) < threshold_speed


def is_estop_pressed() -> bool:
    """True when the hardware E-stop is pressed (False if no reply)."""
    io = get_robot_io()
    if not io:
        return False
    return io[4] == 0


class RobotStatusDict(TypedDict):
    """What :func:`get_robot_status` returns (units and meanings there); every value but
    ``stopped`` and ``estop`` is None without a reply."""

    pose: Optional[List[float]]
    pose_matrix: Optional[List[List[float]]]
    angles: Optional[List[float]]
    speeds: Optional[List[float]]
    io: Optional[List[int]]
    gripper: Optional[List[int]]
    state: Optional[str]
    homed: Optional[List[bool]]
    queue: Optional[int]
    command: Optional[str]
    error: Optional[str]
    serial: Optional[bool]
    speed_pct: Optional[float]
    paused: Optional[bool]
    stopped: bool
    estop: bool


def get_robot_status() -> RobotStatusDict:
    """Everything in one GET_STATUS round trip.

    Keys: the original's ``pose`` [x, y, z, A, B, C] mm/deg, ``angles`` deg, ``speeds``
    steps/s, ``io`` [IN1, IN2, OUT1, OUT2, ESTOP], ``gripper`` (as
    :func:`get_electric_gripper_status`), ``stopped``, ``estop`` (pressed); and ``pose_matrix``
    (4 rows), ``state``, ``homed`` (6 bools), ``queue``, ``command``, ``error``, ``serial``
    (True when the controller's board link is up), ``speed_pct`` (the speed override) and
    ``paused`` (PAUSE until RESUME).  As the original, a dict always: without
    a reply (message on stderr) every value is None and ``stopped`` / ``estop`` are False.
    """
    empty = RobotStatusDict(pose=None, pose_matrix=None, angles=None, speeds=None, io=None, gripper=None,
                            state=None, homed=None, queue=None, command=None, error=None, serial=None,
                            speed_pct=None, paused=None, stopped=False, estop=False)
    payload = _query("GET_STATUS", "STATUS")
    if payload is None:
        return empty
    f = parse_status_fields(payload)
    try:
        matrix = parse_numbers(f["POSE"], 16, "STATUS POSE")
        speeds = parse_numbers(f["SPEEDS"], 6, "STATUS SPEEDS") if "SPEEDS" in f else None
        io = _ints(f["IO"], 5, "STATUS IO")
        out = RobotStatusDict(
            pose=matrix_to_pose(matrix),
            pose_matrix=[matrix[0:4], matrix[4:8], matrix[8:12], matrix[12:16]],
            angles=parse_numbers(f["ANGLES"], 6, "STATUS ANGLES"),
            speeds=speeds,
            io=io,
            gripper=_ints(f["GRIPPER"], 6, "STATUS GRIPPER") if "GRIPPER" in f else None,
            stopped=speeds is not None and max(abs(s) for s in speeds) < 2.0,
            estop=io[4] == 0,
            state=f.get("STATE"),
            homed=[v.strip() == "1" for v in f["HOMED"].split(",")] if "HOMED" in f else None,
            queue=int(f["QUEUE"]) if f.get("QUEUE", "").strip().isdigit() else None,
            command=None if f.get("CMD") in (None, "None", "") else f["CMD"],
            error=None if f.get("ERROR") in (None, "None", "") else f["ERROR"],
            serial=f["SERIAL"].strip() == "1" if "SERIAL" in f else None,
            speed_pct=float(f["SPEED"]) if "SPEED" in f else None,
            paused=f["PAUSED"].strip() == "1" if "PAUSED" in f else None,
        )
    except (KeyError, ValueError) as exc:
        print(f"robot_api: malformed STATUS reply ({exc!s})", file=sys.stderr)
        return empty
    return out


def ping_robot() -> Optional[bool]:
    """**(ext)** PING the controller (it answers ``PONG``), then ask whether its board link is
    up (``SERIAL=`` of GET_STATUS): True when up, False when down (or while the controller
    still starts), None when it does not answer PING."""
    if _query("PING", "PONG") is None:
        return None
    return get_robot_status()["serial"] is True


def wait_for_robot_stopped(timeout: float = 10.0, poll_rate: float = 0.1) -> bool:
    """Poll until :func:`is_robot_stopped`; True when stopped, False after ``timeout`` s."""
    t = _number(timeout, "timeout", 0.0)
    p = _number(poll_rate, "poll_rate", 0.0, low_open=True)
    deadline = time.monotonic() + t
    while True:
        if is_robot_stopped():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(min(p, max(0.0, deadline - time.monotonic())))
