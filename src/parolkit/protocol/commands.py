"""Controller text commands: parse one UDP datagram into a typed command, format replies.

The wire format (``docs/protocol.md``)::

    [ID|]NAME|arg1|arg2|...

* ``ID``: exactly 8 characters of ``[A-Za-z0-9-]``, not all upper-case (clients use the first
  8 characters of a uuid4).  A command name is all upper-case, so the two never collide.
* ``NAME`` is case-insensitive; ``None``/``NONE``/empty means "not given".
* Numbers: decimal, optional sign and exponent; ``nan``/``inf`` are refused.
* Units on the wire: degrees, millimetres, percent, seconds.  The command objects keep those
  edge units (names say which); the controller converts to SI / steps further in.

:func:`parse_datagram` returns a :class:`Parsed` (the optional ID and the command object) or
raises :class:`CommandError` whose message names the field and the allowed range, and which
carries the ID when one was recognised (so the controller can send an INVALID ack).

Nothing here clamps, wraps or guesses: a value outside its range is an error.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from enum import Enum
from typing import Callable, ClassVar, Sequence

from parolkit.errors import ParolkitValueError
from parolkit.robot import JOINT_NAMES, PAROL6, RobotModel

__all__ = [
    "MAX_DATAGRAM_BYTES",
    "MAX_DURATION_S",
    "CommandError",
    "CommandKind",
    "AckStatus",
    "Profile",
    "Tracking",
    "Frame",
    "Plane",
    "Timing",
    "Command",
    "Query",
    "Stop",
    "Enable",
    "Disable",
    "ClearError",
    "EStop",
    "StreamMode",
    "SetPort",
    "SetTool",
    "Subscribe",
    "Unsubscribe",
    "MoveJoint",
    "MovePose",
    "MoveCart",
    "MoveCartRelTRF",
    "Jog",
    "MultiJog",
    "CartJog",
    "Home",
    "Delay",
    "PneumaticGripper",
    "ElectricGripper",
    "SpeedJoint",
    "WaitInput",
    "SmoothCircle",
    "SmoothArcCenter",
    "SmoothArcParam",
    "SmoothSpline",
    "SmoothHelix",
    "BlendSegment",
    "SmoothBlend",
    "Parsed",
    "QUERY_NAMES",
    "is_command_id",
    "parse_datagram",
    "format_ack",
    "format_error",
    "format_floats",
    "dumps",
    "COMMAND_NAMES",
]

#: Largest datagram accepted, bytes.
MAX_DATAGRAM_BYTES = 65_000
#: Longest duration any timed command may ask for, s.
MAX_DURATION_S = 3600.0
#: Largest Cartesian coordinate accepted on the wire, mm (reachability is checked by IK later).
MAX_COORD_MM = 10_000.0
#: Most waypoints a spline may carry.
MAX_WAYPOINTS = 500

_ID_RE = re.compile(r"^[A-Za-z0-9-]{8}$")
_NUM_RE = re.compile(r"^[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?$")
_INT_RE = re.compile(r"^[+-]?\d+$")


class CommandError(ParolkitValueError):
    """A datagram that is not a valid command.  ``str(exc)`` names the field and the range.

    ``command_id`` is the datagram's ID when one was recognised (INVALID ack goes there),
    ``name`` the command name when known.
    """

    def __init__(self, message: str, *, command_id: str | None = None, name: str | None = None):
        super().__init__(message)
        self.message = message
        self.command_id = command_id
        self.name = name


class CommandKind(Enum):
    """How the controller handles a command."""

    #: answered at once from the latest status snapshot
    QUERY = "query"
    #: acted on at once by the server thread (STOP, ENABLE, ...)
    IMMEDIATE = "immediate"
    #: queued and executed in order by the control loop (motion, gripper, delay, ...)
    QUEUED = "queued"


class AckStatus(str, Enum):
    """The STATUS field of ``ACK|ID|STATUS|details``."""

    QUEUED = "QUEUED"
    EXECUTING = "EXECUTING"
    COMPLETED = "COMPLETED"
    FAILED = "FAILED"
    CANCELLED = "CANCELLED"
    INVALID = "INVALID"

    @property
    def terminal(self) -> bool:
        return self in (AckStatus.COMPLETED, AckStatus.FAILED, AckStatus.CANCELLED, AckStatus.INVALID)


class Profile(str, Enum):
    """Velocity profile requested for a move (None on the wire = the planner's default)."""

    POLY = "poly"
    TRAP = "trap"
    RUCKIG = "ruckig"
    TOPPRA = "toppra"


class Tracking(str, Enum):
    """How a trajectory is streamed to the board: positions (156) or speeds (123)."""

    POSITION = "position"
    SPEED = "speed"


class Frame(str, Enum):
    """Reference frame of Cartesian jogs and smooth paths."""

    WRF = "WRF"
    TRF = "TRF"


class Plane(str, Enum):
    """Plane of a circle."""

    XY = "XY"
    XZ = "XZ"
    YZ = "YZ"


class Timing(str, Enum):
    """Timing mode of smooth paths: a total duration (s) or a speed percentage."""

    DURATION = "DURATION"
    SPEED = "SPEED"


# ---------------------------------------------------------------------------------------------
# field parsing helpers (each raises CommandError naming the field)
# ---------------------------------------------------------------------------------------------


def _given(text: str) -> bool:
    return text.strip().upper() not in ("", "NONE")


def _number(text: str, fname: str) -> float:
    s = text.strip()
    if not _NUM_RE.match(s):
        raise CommandError(f"{fname} must be a decimal number, got {text!r}")
    v = float(s)
    if not math.isfinite(v):
        raise CommandError(f"{fname} must be a finite number, got {text!r}")
    return v


def _ranged(text: str, fname: str, lo: float, hi: float, *, lo_open: bool = False, unit: str = "") -> float:
    v = _number(text, fname)
    bad = v < lo or v > hi or (lo_open and v == lo)
    if bad:
        lb = "(" if lo_open else "["
        u = f" {unit}" if unit else ""
        raise CommandError(f"{fname} = {v:g}{u} is out of range {lb}{lo:g}, {hi:g}]{u}")
    return v


def _opt_ranged(text: str, fname: str, lo: float, hi: float, **kw) -> float | None:
    return _ranged(text, fname, lo, hi, **kw) if _given(text) else None


def _integer(text: str, fname: str, lo: int, hi: int) -> int:
    s = text.strip()
    if not _INT_RE.match(s):
        raise CommandError(f"{fname} must be an integer in {lo}..{hi}, got {text!r}")
    v = int(s)
    if not lo <= v <= hi:
        raise CommandError(f"{fname} = {v} is out of range {lo}..{hi}")
    return v


def _choice(text: str, fname: str, enum: type[Enum], *, upper: bool = True) -> Enum:
    s = text.strip()
    s = s.upper() if upper else s.lower()
    for member in enum:
        if member.value == s:
            return member
    allowed = "|".join(m.value for m in enum)
    raise CommandError(f"{fname} must be one of {allowed}, got {text!r}")


def _opt_choice(text: str, fname: str, enum: type[Enum], **kw) -> Enum | None:
    return _choice(text, fname, enum, **kw) if _given(text) else None


def _flag01(text: str, fname: str) -> bool:
    s = text.strip().upper()
    if s in ("1", "TRUE"):
        return True
    if s in ("0", "FALSE"):
        return False
    raise CommandError(f"{fname} must be 0 or 1, got {text!r}")


def _numbers(text: str, fname: str, count: int) -> tuple[float, ...]:
    parts = text.split(",")
    if len(parts) != count:
        raise CommandError(f"{fname} must be {count} comma-separated numbers, got {len(parts)}")
    return tuple(_number(p, f"{fname}[{i}]") for i, p in enumerate(parts))


_POSE_NAMES = ("x", "y", "z", "A", "B", "C")


def _check_pose(values: Sequence[float], fname: str, *, relative: bool = False) -> tuple[float, ...]:
    for i, v in enumerate(values):
        if i < 3:
            if abs(v) > MAX_COORD_MM:
                raise CommandError(
                    f"{fname}: {_POSE_NAMES[i]} = {v:g} mm is out of range "
                    f"[{-MAX_COORD_MM:g}, {MAX_COORD_MM:g}] mm"
                )
        elif abs(v) > 360.0:
            raise CommandError(f"{fname}: {_POSE_NAMES[i]} = {v:g} deg is out of range [-360, 360] deg")
    return tuple(values)


def _pose_field(text: str, fname: str) -> tuple[float, ...]:
    return _check_pose(_numbers(text, fname, 6), fname)


def _point_field(text: str, fname: str) -> tuple[float, ...]:
    return _check_pose(_numbers(text, fname, 3), fname)


def _pose_args(args: Sequence[str], fname: str) -> tuple[float, ...]:
    vals = tuple(_number(a, f"{fname} {_POSE_NAMES[i]}") for i, a in enumerate(args[:6]))
    return _check_pose(vals, fname)


def _start_field(text: str) -> tuple[float, ...] | None:
    s = text.strip().upper()
    if s in ("", "NONE", "CURRENT"):
        return None
    return _pose_field(text, "start")


def _duration(text: str, fname: str = "duration") -> float:
    return _ranged(text, fname, 0.0, MAX_DURATION_S, lo_open=True, unit="s")


def _opt_duration(text: str, fname: str = "duration") -> float | None:
    return _duration(text, fname) if _given(text) else None


def _pct(text: str, fname: str = "speed%", *, lo_open: bool = False) -> float:
    return _ranged(text, fname, 0.0, 100.0, lo_open=lo_open, unit="%")


def _opt_pct(text: str, fname: str = "speed%", **kw) -> float | None:
    return _pct(text, fname, **kw) if _given(text) else None


def _duration_xor_speed(duration: float | None, speed: float | None) -> None:
    if duration is None and speed is None:
        raise CommandError("give exactly one of duration (s) and speed% (0..100): neither was given")
    if duration is not None and speed is not None:
        raise CommandError("give exactly one of duration (s) and speed% (0..100): both were given")


def _timing_value(timing: Timing, text: str) -> float:
    if timing is Timing.DURATION:
        return _duration(text, "timing value (DURATION)")
    return _pct(text, "timing value (SPEED %)", lo_open=True)


def _nargs(args: Sequence[str], name: str, lo: int, hi: int | None = None) -> None:
    hi = lo if hi is None else hi
    n = len(args)
    if not lo <= n <= hi:
        want = f"{lo}" if lo == hi else f"{lo}..{hi}"
        raise CommandError(f"{name} takes {want} arguments, got {n}")


# ---------------------------------------------------------------------------------------------
# command objects
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """Base of every command.  ``NAME`` is the wire name, ``KIND`` how it is handled."""

    NAME: ClassVar[str] = ""
    KIND: ClassVar[CommandKind] = CommandKind.QUEUED

    @property
    def name(self) -> str:
        return self.NAME

    @property
    def is_motion(self) -> bool:
        """True for commands that move joints (refused until homed, except jogs)."""
        return False


QUERY_NAMES = (
    "GET_POSE", "GET_ANGLES", "GET_IO", "GET_GRIPPER", "GET_SPEEDS", "PING", "GET_STATUS",
    "GET_STATUS_JSON", "GET_LOOP_STATS", "GET_PLAN", "GET_TOOL", "GET_QUEUE",
)


@dataclass(frozen=True)
class Query(Command):
    """A query answered at once; ``query`` is one of :data:`QUERY_NAMES`."""

    query: str = "PING"
    KIND: ClassVar[CommandKind] = CommandKind.QUERY

    @property
    def name(self) -> str:
        return self.query


@dataclass(frozen=True)
class Stop(Command):
    """Cancel the active and every queued command (CANCELLED acks); hold position."""

    NAME: ClassVar[str] = "STOP"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class AckHere(Command):
    """(ext) Acks of commands sent from this socket also go back to this socket (besides the
    ack port), so a client listening where it sends from needs no fixed ack port."""

    NAME: ClassVar[str] = "ACK_HERE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class Enable(Command):
    """Enable the robot (board 101); clears a released E-stop latch and a latched error."""

    NAME: ClassVar[str] = "ENABLE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class Disable(Command):
    """Disable the robot (board 102); cancels motion."""

    NAME: ClassVar[str] = "DISABLE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class ClearError(Command):
    """Clear a latched error (board 103)."""

    NAME: ClassVar[str] = "CLEAR_ERROR"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class EStop(Command):
    """Software E-stop: cancel everything, DISABLE every tick, latched until ENABLE."""

    NAME: ClassVar[str] = "ESTOP"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class StreamMode(Command):
    """``STREAM|ON/OFF``: the newest jog replaces the previous one; watchdog armed."""

    on: bool = False
    NAME: ClassVar[str] = "STREAM"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class SetPort(Command):
    """``SET_PORT|name``: switch the serial port (device path)."""

    port: str = ""
    NAME: ClassVar[str] = "SET_PORT"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class SetTool(Command):
    """``SET_TOOL|name``: select a tool by name."""

    tool: str = "default"
    NAME: ClassVar[str] = "SET_TOOL"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class Subscribe(Command):
    """``SUBSCRIBE|port|every_n_ticks``: status stream to (sender address, port)."""

    port: int = 0
    every_n_ticks: int = 1
    NAME: ClassVar[str] = "SUBSCRIBE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class Unsubscribe(Command):
    """``UNSUBSCRIBE|port``."""

    port: int = 0
    NAME: ClassVar[str] = "UNSUBSCRIBE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class _Motion(Command):
    @property
    def is_motion(self) -> bool:
        return True


@dataclass(frozen=True)
class MoveJoint(_Motion):
    """Joint-space move to ``angles_deg``; exactly one of ``duration_s`` / ``speed_pct``."""

    angles_deg: tuple[float, ...] = ()
    duration_s: float | None = None
    speed_pct: float | None = None
    accel_pct: float | None = None
    profile: Profile | None = None
    tracking: Tracking = Tracking.POSITION
    NAME: ClassVar[str] = "MOVEJOINT"


@dataclass(frozen=True)
class MovePose(_Motion):
    """IK at the target pose (mm, deg), joint-space path."""

    pose: tuple[float, ...] = ()
    duration_s: float | None = None
    speed_pct: float | None = None
    accel_pct: float | None = None
    profile: Profile | None = None
    tracking: Tracking = Tracking.POSITION
    NAME: ClassVar[str] = "MOVEPOSE"


@dataclass(frozen=True)
class MoveCart(_Motion):
    """Straight line in Cartesian space to ``pose`` (mm, deg)."""

    pose: tuple[float, ...] = ()
    duration_s: float | None = None
    speed_pct: float | None = None
    profile: Profile | None = None
    tracking: Tracking = Tracking.POSITION
    NAME: ClassVar[str] = "MOVECART"


@dataclass(frozen=True)
class MoveCartRelTRF(_Motion):
    """Relative straight line in the tool frame: ``delta`` (mm, deg)."""

    delta: tuple[float, ...] = ()
    duration_s: float | None = None
    speed_pct: float | None = None
    profile: Profile | None = None
    tracking: Tracking = Tracking.POSITION
    NAME: ClassVar[str] = "MOVECARTRELTRF"


@dataclass(frozen=True)
class Jog(_Motion):
    """Jog one joint: ``joint`` 0..5, ``direction`` +1/-1, for a duration and/or a distance."""

    joint: int = 0
    direction: int = 1
    speed_pct: float = 0.0
    duration_s: float | None = None
    distance_deg: float | None = None
    NAME: ClassVar[str] = "JOG"


@dataclass(frozen=True)
class MultiJog(_Motion):
    """Jog several joints at once: ``joints`` ((joint, direction), ...), one speed % each."""

    joints: tuple[tuple[int, int], ...] = ()
    speeds_pct: tuple[float, ...] = ()
    duration_s: float = 0.0
    NAME: ClassVar[str] = "MULTIJOG"


_CART_AXES = ("X+", "X-", "Y+", "Y-", "Z+", "Z-", "RX+", "RX-", "RY+", "RY-", "RZ+", "RZ-")


@dataclass(frozen=True)
class CartJog(_Motion):
    """Cartesian jog along/about one axis of WRF or TRF (axis like ``X+`` or ``RZ-``)."""

    frame: Frame = Frame.WRF
    axis: str = "X+"
    speed_pct: float = 0.0
    duration_s: float = 0.0
    NAME: ClassVar[str] = "CARTJOG"


@dataclass(frozen=True)
class Home(Command):
    """Board homing; completes when every homed bit is set."""

    NAME: ClassVar[str] = "HOME"


@dataclass(frozen=True)
class Delay(Command):
    """Wait ``seconds`` in the queue."""

    seconds: float = 0.0
    NAME: ClassVar[str] = "DELAY"


@dataclass(frozen=True)
class PneumaticGripper(Command):
    """Drive OUT1/OUT2 like the original controller: ``open`` = output on, ``close`` = off."""

    action: str = "open"
    port: int = 1
    NAME: ClassVar[str] = "PNEUMATICGRIPPER"


@dataclass(frozen=True)
class ElectricGripper(Command):
    """SSG-48: ``action`` move|calibrate|clear_error; position/speed 0..255, current mA."""

    action: str = "move"
    position: int = 255
    speed: int = 150
    current_ma: int = 500
    NAME: ClassVar[str] = "ELECTRICGRIPPER"


@dataclass(frozen=True)
class SpeedJoint(_Motion):
    """(ext) Constant joint speeds in deg/s for ``duration_s``, then zero speed."""

    speeds_deg_s: tuple[float, ...] = ()
    duration_s: float = 0.0
    NAME: ClassVar[str] = "SPEEDJOINT"


@dataclass(frozen=True)
class WaitInput(Command):
    """(ext) Complete when digital input ``input_no`` (1|2) equals ``state``; FAILED on timeout."""

    input_no: int = 1
    state: bool = True
    timeout_s: float | None = None
    NAME: ClassVar[str] = "WAIT_INPUT"


@dataclass(frozen=True)
class _Smooth(_Motion):
    frame: Frame = Frame.WRF
    start: tuple[float, ...] | None = None
    timing: Timing = Timing.DURATION
    #: seconds for DURATION, percent for SPEED
    timing_value: float = 1.0


@dataclass(frozen=True)
class SmoothCircle(_Smooth):
    center: tuple[float, ...] = (0.0, 0.0, 0.0)
    radius_mm: float = 1.0
    plane: Plane = Plane.XY
    clockwise: bool = False
    NAME: ClassVar[str] = "SMOOTH_CIRCLE"


@dataclass(frozen=True)
class SmoothArcCenter(_Smooth):
    end_pose: tuple[float, ...] = ()
    center: tuple[float, ...] = (0.0, 0.0, 0.0)
    clockwise: bool = False
    NAME: ClassVar[str] = "SMOOTH_ARC_CENTER"


@dataclass(frozen=True)
class SmoothArcParam(_Smooth):
    end_pose: tuple[float, ...] = ()
    radius_mm: float = 1.0
    angle_deg: float = 90.0
    clockwise: bool = False
    NAME: ClassVar[str] = "SMOOTH_ARC_PARAM"


@dataclass(frozen=True)
class SmoothSpline(_Smooth):
    waypoints: tuple[tuple[float, ...], ...] = ()
    NAME: ClassVar[str] = "SMOOTH_SPLINE"


@dataclass(frozen=True)
class SmoothHelix(_Smooth):
    center: tuple[float, ...] = (0.0, 0.0, 0.0)
    radius_mm: float = 1.0
    pitch_mm: float = 1.0
    height_mm: float = 1.0
    clockwise: bool = False
    NAME: ClassVar[str] = "SMOOTH_HELIX"


@dataclass(frozen=True)
class BlendSegment:
    """One segment of SMOOTH_BLEND.  ``kind`` LINE|CIRCLE|ARC|SPLINE; fields by kind (mm, deg, s)."""

    kind: str
    duration_s: float
    end_pose: tuple[float, ...] | None = None
    center: tuple[float, ...] | None = None
    radius_mm: float | None = None
    plane: Plane | None = None
    clockwise: bool = False
    waypoints: tuple[tuple[float, ...], ...] = ()


@dataclass(frozen=True)
class SmoothBlend(_Smooth):
    segments: tuple[BlendSegment, ...] = ()
    blend_time_s: float = 0.5
    NAME: ClassVar[str] = "SMOOTH_BLEND"


@dataclass(frozen=True)
class Parsed:
    """One parsed datagram: the optional command ID and the command."""

    command_id: str | None
    command: Command

    @property
    def kind(self) -> CommandKind:
        return self.command.KIND


# ---------------------------------------------------------------------------------------------
# per-command parsers
# ---------------------------------------------------------------------------------------------


def _joint_angles(args: Sequence[str], model: RobotModel) -> tuple[float, ...]:
    vals = tuple(_number(a, f"{JOINT_NAMES[i]} angle (deg)") for i, a in enumerate(args[:6]))
    lim = model.safe_limits_deg
    for i, v in enumerate(vals):
        lo, hi = float(lim[i, 0]), float(lim[i, 1])
        if not lo <= v <= hi:
            raise CommandError(
                f"{JOINT_NAMES[i]} angle = {v:g} deg is out of range [{lo:.4f}, {hi:.4f}] deg"
            )
    return vals


def _move_tail(args: Sequence[str], *, with_accel: bool):
    """duration|speed% then optional (ext) accel%|profile|tracking (accel only for joint moves)."""
    duration = _opt_duration(args[0])
    speed = _opt_pct(args[1], lo_open=True)
    _duration_xor_speed(duration, speed)
    rest = list(args[2:])
    accel = None
    if with_accel:
        accel = _opt_pct(rest.pop(0), "accel%", lo_open=True) if rest else None
    profile = _opt_choice(rest.pop(0), "profile", Profile, upper=False) if rest else None
    tracking = (_opt_choice(rest.pop(0), "tracking", Tracking, upper=False) if rest else None)
    return duration, speed, accel, profile, tracking or Tracking.POSITION


def _p_movejoint(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "MOVEJOINT", 8, 11)
    duration, speed, accel, profile, tracking = _move_tail(a[6:], with_accel=True)
    return MoveJoint(_joint_angles(a, m), duration, speed, accel, profile, tracking)


def _p_movepose(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "MOVEPOSE", 8, 11)
    duration, speed, accel, profile, tracking = _move_tail(a[6:], with_accel=True)
    return MovePose(_pose_args(a, "pose"), duration, speed, accel, profile, tracking)


def _p_movecart(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "MOVECART", 8, 10)
    duration, speed, _, profile, tracking = _move_tail(a[6:], with_accel=False)
    return MoveCart(_pose_args(a, "pose"), duration, speed, profile, tracking)


def _p_movecartrel(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "MOVECARTRELTRF", 8, 10)
    duration, speed, _, profile, tracking = _move_tail(a[6:], with_accel=False)
    return MoveCartRelTRF(_pose_args(a, "delta"), duration, speed, profile, tracking)


def _jog_index(text: str, fname: str) -> tuple[int, int]:
    idx = _integer(text, fname, 0, 11)
    return (idx, 1) if idx < 6 else (idx - 6, -1)


def _p_jog(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "JOG", 4)
    joint, direction = _jog_index(a[0], "joint_index")
    speed = _pct(a[1], lo_open=True)
    duration = _opt_duration(a[2])
    distance = _opt_ranged(a[3], "distance_deg", 0.0, 720.0, lo_open=True, unit="deg")
    if duration is None and distance is None:
        raise CommandError("JOG needs a duration (s) and/or a distance_deg: neither was given")
    return Jog(joint, direction, speed, duration, distance)


def _p_multijog(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "MULTIJOG", 3)
    idx_parts = a[0].split(",")
    spd_parts = a[1].split(",")
    if not 1 <= len(idx_parts) <= 6:
        raise CommandError(f"joint indices must be 1..6 comma-separated values, got {len(idx_parts)}")
    if len(spd_parts) != len(idx_parts):
        raise CommandError(
            f"speeds must have one value per joint index ({len(idx_parts)}), got {len(spd_parts)}"
        )
    joints = tuple(_jog_index(p, f"joint index[{i}]") for i, p in enumerate(idx_parts))
    seen: dict[int, int] = {}
    for j, d in joints:
        if j in seen:
            what = "both + and -" if seen[j] != d else "twice"
            raise CommandError(f"joint {JOINT_NAMES[j]} is given {what} in one MULTIJOG")
        seen[j] = d
    speeds = tuple(_pct(p, f"speed%[{i}]", lo_open=True) for i, p in enumerate(spd_parts))
    return MultiJog(joints, speeds, _duration(a[2]))


def _p_cartjog(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "CARTJOG", 4)
    frame = _choice(a[0], "frame", Frame)
    axis = a[1].strip().upper()
    if axis not in _CART_AXES:
        raise CommandError(f"axis must be one of {' '.join(_CART_AXES)}, got {a[1]!r}")
    return CartJog(frame, axis, _pct(a[2], lo_open=True), _duration(a[3]))


def _p_home(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "HOME", 0)
    return Home()


def _p_delay(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "DELAY", 1)
    return Delay(_ranged(a[0], "seconds", 0.0, MAX_DURATION_S, unit="s"))


def _p_pneumatic(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "PNEUMATICGRIPPER", 2)
    action = a[0].strip().lower()
    if action not in ("open", "close"):
        raise CommandError(f"action must be open|close, got {a[0]!r}")
    return PneumaticGripper(action, _integer(a[1], "port", 1, 2))


def _p_electric(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "ELECTRICGRIPPER", 1, 4)
    raw = a[0].strip().lower()
    action = "move" if raw in ("", "none") else raw
    if action not in ("move", "calibrate", "clear_error"):
        raise CommandError(f"action must be move|calibrate|clear_error|None, got {a[0]!r}")
    rest = list(a[1:]) + ["None"] * (4 - len(a))
    pos = _integer(rest[0], "position", 0, 255) if _given(rest[0]) else 255
    speed = _integer(rest[1], "speed", 0, 255) if _given(rest[1]) else 150
    current = _integer(rest[2], "current (mA)", 100, 1000) if _given(rest[2]) else 500
    return ElectricGripper(action, pos, speed, current)


def _p_speedjoint(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SPEEDJOINT", 7)
    mx = m.max_speed_deg_s
    speeds = []
    for i in range(6):
        hi = float(mx[i])
        speeds.append(_ranged(a[i], f"{JOINT_NAMES[i]} speed (deg/s)", -hi, hi, unit="deg/s"))
    return SpeedJoint(tuple(speeds), _duration(a[6]))


def _p_waitinput(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "WAIT_INPUT", 2, 3)
    inp = _integer(a[0], "input", 1, 2)
    state = _flag01(a[1], "state")
    timeout = _opt_duration(a[2], "timeout_s") if len(a) > 2 else None
    return WaitInput(inp, state, timeout)


def _smooth_common(args: Sequence[str]) -> dict:
    """frame|start|timing|value (4 fields)."""
    frame = _choice(args[0], "frame", Frame)
    start = _start_field(args[1])
    timing = _choice(args[2], "timing", Timing)
    return {"frame": frame, "start": start, "timing": timing, "timing_value": _timing_value(timing, args[3])}


def _radius(text: str, fname: str = "radius (mm)") -> float:
    return _ranged(text, fname, 0.0, 2000.0, lo_open=True, unit="mm")


def _p_circle(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_CIRCLE", 8)
    return SmoothCircle(
        center=_point_field(a[0], "center"), radius_mm=_radius(a[1]),
        plane=_choice(a[2], "plane", Plane), clockwise=_flag01(a[7], "clockwise"),
        **_smooth_common(a[3:7]),
    )


def _p_arc_center(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_ARC_CENTER", 7)
    return SmoothArcCenter(
        end_pose=_pose_field(a[0], "end pose"), center=_point_field(a[1], "center"),
        clockwise=_flag01(a[6], "clockwise"), **_smooth_common(a[2:6]),
    )


def _p_arc_param(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_ARC_PARAM", 8)
    return SmoothArcParam(
        end_pose=_pose_field(a[0], "end pose"), radius_mm=_radius(a[1]),
        angle_deg=_ranged(a[2], "angle (deg)", -720.0, 720.0, unit="deg"),
        clockwise=_flag01(a[7], "clockwise"), **_smooth_common(a[3:7]),
    )


def _p_spline(a: Sequence[str], m: RobotModel) -> Command:
    if len(a) < 5:
        raise CommandError(f"SMOOTH_SPLINE takes n|frame|start|timing|value|pose x n, got {len(a)} arguments")
    n = _integer(a[0], "n (waypoints)", 2, MAX_WAYPOINTS)
    fields = list(a[5:])
    if len(fields) == 6 * n and n > 1 and not any("," in f for f in fields):
        # also accepted: every waypoint as six separate fields x|y|z|A|B|C
        fields = [",".join(fields[6 * i : 6 * i + 6]) for i in range(n)]
    if len(fields) != n:
        raise CommandError(
            f"SMOOTH_SPLINE: n = {n} waypoints announced, {len(a) - 5} fields given "
            f"(expected {n} poses x,y,z,A,B,C or {6 * n} single numbers)")
    wps = tuple(_pose_field(p, f"waypoint {i + 1}") for i, p in enumerate(fields))
    return SmoothSpline(waypoints=wps, **_smooth_common(a[1:5]))


def _p_helix(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_HELIX", 9)
    return SmoothHelix(
        center=_point_field(a[0], "center"), radius_mm=_radius(a[1]),
        pitch_mm=_ranged(a[2], "pitch (mm)", 0.0, 1000.0, lo_open=True, unit="mm"),
        height_mm=_ranged(a[3], "height (mm)", -2000.0, 2000.0, unit="mm"),
        clockwise=_flag01(a[8], "clockwise"), **_smooth_common(a[4:8]),
    )


def _blend_segment(fields: Sequence[str], k: int) -> BlendSegment:
    where = f"segment {k + 1}"
    if not fields:
        raise CommandError(f"{where} is empty")
    kind = fields[0].strip().upper()
    f = list(fields[1:])
    try:
        if kind == "LINE":
            _nargs(f, f"{where} LINE (end pose|duration)", 2)
            return BlendSegment("LINE", _duration(f[1], f"{where} duration"), end_pose=_pose_field(f[0], f"{where} end pose"))
        if kind == "CIRCLE":
            _nargs(f, f"{where} CIRCLE (center|radius|plane|duration|clockwise)", 5)
            return BlendSegment(
                "CIRCLE", _duration(f[3], f"{where} duration"), center=_point_field(f[0], f"{where} center"),
                radius_mm=_radius(f[1], f"{where} radius (mm)"), plane=_choice(f[2], f"{where} plane", Plane),
                clockwise=_flag01(f[4], f"{where} clockwise"),
            )
        if kind == "ARC":
            _nargs(f, f"{where} ARC (end pose|center|duration|clockwise)", 4)
            return BlendSegment(
                "ARC", _duration(f[2], f"{where} duration"), end_pose=_pose_field(f[0], f"{where} end pose"),
                center=_point_field(f[1], f"{where} center"), clockwise=_flag01(f[3], f"{where} clockwise"),
            )
        if kind == "SPLINE":
            if len(f) < 2:
                raise CommandError(f"{where} SPLINE takes duration|pose|pose|..., got {len(f)} fields")
            wps = tuple(_pose_field(p, f"{where} waypoint {i + 1}") for i, p in enumerate(f[1:]))
            if len(wps) < 2:
                raise CommandError(f"{where} SPLINE needs at least 2 waypoints, got {len(wps)}")
            return BlendSegment("SPLINE", _duration(f[0], f"{where} duration"), waypoints=wps)
    except CommandError:
        raise
    raise CommandError(f"{where} type must be LINE|CIRCLE|ARC|SPLINE, got {fields[0]!r}")


def _p_blend(a: Sequence[str], m: RobotModel) -> Command:
    if len(a) < 7:
        raise CommandError(
            f"SMOOTH_BLEND takes n|blend_time|frame|start|timing|value|segments, got {len(a)} arguments"
        )
    n = _integer(a[0], "n (segments)", 1, 100)
    blend = _ranged(a[1], "blend time (s)", 0.0, 10.0, unit="s")
    frame = _choice(a[2], "frame", Frame)
    start = _start_field(a[3])
    timing = _choice(a[4], "timing", Timing)
    value = _timing_value(timing, a[5]) if _given(a[5]) else 0.0
    if timing is Timing.SPEED and value == 0.0:
        raise CommandError("timing value (SPEED %) must be given for SPEED timing")
    segs_raw: list[list[str]] = [[]]
    for fld in a[6:]:
        if fld == "":
            segs_raw.append([])
        else:
            segs_raw[-1].append(fld)
    segs_raw = [s for s in segs_raw if s]
    if len(segs_raw) != n:
        raise CommandError(f"SMOOTH_BLEND: n = {n} segments announced, {len(segs_raw)} given (separate them with ||)")
    segments = tuple(_blend_segment(s, k) for k, s in enumerate(segs_raw))
    return SmoothBlend(segments=segments, blend_time_s=blend, frame=frame, start=start, timing=timing,
                       timing_value=value if value else sum(s.duration_s for s in segments))


def _p_stream(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "STREAM", 1)
    s = a[0].strip().upper()
    if s not in ("ON", "OFF", "1", "0"):
        raise CommandError(f"STREAM takes ON|OFF, got {a[0]!r}")
    return StreamMode(s in ("ON", "1"))


def _p_setport(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SET_PORT", 1)
    port = a[0].strip()
    if not port or any(ord(c) < 32 for c in port):
        raise CommandError(f"SET_PORT needs a device name such as /dev/ttyACM0, got {a[0]!r}")
    return SetPort(port)


def _p_settool(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SET_TOOL", 1)
    name = a[0].strip()
    if not re.match(r"^[A-Za-z0-9_.-]{1,64}$", name):
        raise CommandError(f"tool name must be 1..64 characters of [A-Za-z0-9_.-], got {a[0]!r}")
    return SetTool(name)


def _p_subscribe(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SUBSCRIBE", 1, 2)
    port = _integer(a[0], "port", 1, 65535)
    every = _integer(a[1], "every_n_ticks", 1, 1_000_000) if len(a) > 1 and _given(a[1]) else 1
    return Subscribe(port, every)


def _p_unsubscribe(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "UNSUBSCRIBE", 1)
    return Unsubscribe(_integer(a[0], "port", 1, 65535))


def _no_args(cls: type[Command]) -> Callable[[Sequence[str], RobotModel], Command]:
    def parse(a: Sequence[str], m: RobotModel) -> Command:
        _nargs(a, cls.NAME, 0)
        return cls()

    return parse


_PARSERS: dict[str, Callable[[Sequence[str], RobotModel], Command]] = {
    "MOVEJOINT": _p_movejoint,
    "MOVEPOSE": _p_movepose,
    "MOVECART": _p_movecart,
    "MOVECARTRELTRF": _p_movecartrel,
    "JOG": _p_jog,
    "MULTIJOG": _p_multijog,
    "CARTJOG": _p_cartjog,
    "HOME": _p_home,
    "DELAY": _p_delay,
    "PNEUMATICGRIPPER": _p_pneumatic,
    "ELECTRICGRIPPER": _p_electric,
    "SPEEDJOINT": _p_speedjoint,
    "WAIT_INPUT": _p_waitinput,
    "SMOOTH_CIRCLE": _p_circle,
    "SMOOTH_ARC_CENTER": _p_arc_center,
    "SMOOTH_ARC_PARAM": _p_arc_param,
    "SMOOTH_SPLINE": _p_spline,
    "SMOOTH_HELIX": _p_helix,
    "SMOOTH_BLEND": _p_blend,
    "STOP": _no_args(Stop),
    "ACK_HERE": _no_args(AckHere),
    "ENABLE": _no_args(Enable),
    "DISABLE": _no_args(Disable),
    "CLEAR_ERROR": _no_args(ClearError),
    "ESTOP": _no_args(EStop),
    "STREAM": _p_stream,
    "SET_PORT": _p_setport,
    "SET_TOOL": _p_settool,
    "SUBSCRIBE": _p_subscribe,
    "UNSUBSCRIBE": _p_unsubscribe,
}

#: Every command name the controller understands.
COMMAND_NAMES = tuple(sorted(set(_PARSERS) | set(QUERY_NAMES)))


def is_command_id(text: str) -> bool:
    """True when ``text`` is a command ID: 8 chars of [A-Za-z0-9-], not all upper-case."""
    return bool(_ID_RE.match(text)) and not text.isupper()


def parse_datagram(data: bytes | str, model: RobotModel | None = None) -> Parsed:
    """Parse one datagram.  Raises :class:`CommandError` (with ``command_id`` when known)."""
    m = model or PAROL6
    if isinstance(data, (bytes, bytearray, memoryview)):
        if len(data) > MAX_DATAGRAM_BYTES:
            raise CommandError(f"datagram is {len(data)} bytes, at most {MAX_DATAGRAM_BYTES} allowed")
        try:
            text = bytes(data).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise CommandError(f"datagram is not UTF-8 text (byte {exc.start})") from None
    else:
        text = data
    text = text.strip("\r\n\x00 ")
    if not text:
        raise CommandError("empty datagram: expected [ID|]NAME|args")
    parts = text.split("|")
    command_id: str | None = None
    if is_command_id(parts[0].strip()):
        command_id = parts[0].strip()
        parts = parts[1:]
        if not parts:
            raise CommandError("datagram has an ID but no command name", command_id=command_id)
    raw_name = parts[0].strip()
    name = raw_name.upper()
    args = parts[1:]
    # trailing empty field from a trailing "|" is tolerated (clients sometimes add one)
    if args and args[-1].strip() == "" and name != "SMOOTH_BLEND":
        args = args[:-1]
    try:
        if name in QUERY_NAMES:
            if args:
                raise CommandError(f"{name} takes no arguments, got {len(args)}")
            return Parsed(command_id, Query(name))
        parser = _PARSERS.get(name)
        if parser is None:
            shown = raw_name if len(raw_name) <= 40 else raw_name[:40] + "..."
            if not name:
                raise CommandError("missing command name: expected [ID|]NAME|args")
            raise CommandError(f"unknown command {shown!r}")
        return Parsed(command_id, parser(args, m))
    except CommandError as exc:
        known = name in _PARSERS or name in QUERY_NAMES
        msg = exc.message if (not known or exc.message.startswith(name)) else f"{name}: {exc.message}"
        raise CommandError(msg, command_id=command_id, name=name if known else None) from None
    except ParolkitValueError as exc:  # e.g. a percent mapping of the robot model
        raise CommandError(f"{name}: {exc}", command_id=command_id, name=name) from None


# ---------------------------------------------------------------------------------------------
# replies
# ---------------------------------------------------------------------------------------------


def _clean(text: str) -> str:
    """Details may not contain the field separator or line breaks."""
    return text.replace("|", "/").replace("\n", " ").replace("\r", " ")


def format_ack(command_id: str, status: AckStatus | str, details: str = "") -> str:
    """``ACK|ID|STATUS|details``."""
    st = status.value if isinstance(status, AckStatus) else str(status)
    return f"ACK|{command_id}|{st}|{_clean(details)}"


def format_error(details: str) -> str:
    """(ext) ``ERROR|details`` for an invalid datagram without an ID."""
    return f"ERROR|{_clean(details)}"


def format_floats(values: Sequence[float], digits: int = 4) -> str:
    """Comma-separated numbers with a fixed number of decimals (``-0.0`` printed as ``0.0``)."""
    out = []
    for v in values:
        s = f"{float(v):.{digits}f}"
        if s.startswith("-") and float(s) == 0.0:
            s = s[1:]
        out.append(s)
    return ",".join(out)


def dumps(obj: object) -> str:
    """Compact JSON used in (ext) replies."""
    return json.dumps(obj, separators=(",", ":"), allow_nan=False)
