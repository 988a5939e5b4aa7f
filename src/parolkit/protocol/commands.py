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
raises :class:`DatagramError` whose message names the field and the allowed range, and which
carries the ID when one was recognised (so the controller can send an INVALID ack).

A motion command carries its move as a :mod:`parolkit.moves` value object (``MOVEJOINT`` ->
``MoveJoint(move=JointMove(...))``): the planner gets ``command.move`` as it is.  The words of
the wire (``Profile``, ``Tracking``, ``Frame``, ``Plane``, ``Timing``, ``CartAxis``) are the
enums of :mod:`parolkit.moves`, re-exported here.  The wire ranges are checked first (their
messages name the wire field); the move's own checks then apply as well.

Nothing here clamps, wraps or guesses: a value outside its range is an error.
"""

from __future__ import annotations

import json
import re
import unicodedata
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any, ClassVar, TypeVar

from parolkit.errors import ParolkitValueError
from parolkit.moves import (
    MAX_BLEND,
    MAX_DURATION_S,
    MAX_PATH_POINTS,
    MIN_DURATION_S,
    ArcCenterMove,
    ArcParamMove,
    BlendMove,
    BlendSegment,
    CartAxis,
    CartJog,
    CartMove,
    CartRelTRFMove,
    CircleMove,
    Frame,
    HelixMove,
    JointJog,
    JointMove,
    JointPathMove,
    LineSegment,
    Plane,
    PoseMove,
    Profile,
    SpeedJointMove,
    SplineMove,
    Timing,
    Tracking,
)
from parolkit.number_syntax import parse_integer, parse_number
from parolkit.number_syntax import shown as _show
from parolkit.robot import JOINT_NAMES, PAROL6, RobotModel

__all__ = [
    "MAX_DATAGRAM_BYTES",
    "MAX_DURATION_S",
    "DatagramError",
    "CommandKind",
    "Execution",
    "CollisionCheck",
    "AckStatus",
    "Profile",
    "Tracking",
    "Frame",
    "Plane",
    "Timing",
    "CartAxis",
    "BLEND_SEGMENT_KINDS",
    "Command",
    "Query",
    "Stop",
    "Enable",
    "Disable",
    "ClearError",
    "EStop",
    "StreamMode",
    "SpeedCommand",
    "ServoJ",
    "ServoL",
    "Pause",
    "Resume",
    "Checkpoint",
    "Attach",
    "Detach",
    "SetPort",
    "SetTool",
    "Subscribe",
    "Unsubscribe",
    "MoveJoint",
    "MoveJointPath",
    "MovePose",
    "MoveCart",
    "MoveCartRelTRF",
    "Jog",
    "MultiJog",
    "CartJogCommand",
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
    "SmoothBlend",
    "Parsed",
    "QUERY_NAMES",
    "is_command_id",
    "parse_datagram",
    "format_ack",
    "format_error",
    "format_cookie",
    "format_floats",
    "dumps",
    "COMMAND_NAMES",
]

#: Largest datagram accepted, bytes.
MAX_DATAGRAM_BYTES = 65_000
#: Largest Cartesian coordinate accepted on the wire, mm (reachability is checked by IK later).
MAX_COORD_MM = 10_000.0
#: Most waypoints a spline may carry.
MAX_WAYPOINTS = 500
#: SSG-48 gripper current a command may ask for, mA (the seed: "0 - 1300 mA"; below 150 mA the
#: gripper usually does not move, above 700 mA at high speed it may damage itself or the object)
GRIPPER_CURRENT_RANGE_MA = (0, 1300)

#: Longest error message (details of an INVALID ack or an ERROR reply), characters
MAX_MESSAGE_CHARS = 400

_ID_RE = re.compile(r"^[A-Za-z0-9-]{8}$", re.ASCII)
_RAW_ID_RE = re.compile(rb"^[ \t]*([A-Za-z0-9-]{8})[ \t]*\|")


_E = TypeVar("_E", bound=Enum)


class DatagramError(ParolkitValueError):
    """A datagram that is not a valid command.  ``str(exc)`` names the field and the range.

    ``command_id`` is the datagram's ID when one was recognised (the controller sends the
    INVALID ack there; without an ID it answers ``ERROR|message``), ``name`` the command name
    when known.  The sender fixes the datagram (see docs/protocol.md) and sends it again.
    """

    def __init__(self, message: str, *, command_id: str | None = None, name: str | None = None) -> None:
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


class Execution(Enum):
    """What the control loop does with a queued command: how it runs (declared on each command
    class as ``EXECUTION``, so the controller never dispatches on the class itself)."""

    #: not run by the loop (queries; immediate commands act when applied)
    NONE = "none"
    #: a trajectory planned whole before it runs (moves, paths, Cartesian jogs)
    PLANNED = "planned"
    #: constant joint speeds for a time (JOG, MULTIJOG, SPEEDJOINT)
    SPEED = "speed"
    #: the board's homing
    HOME = "home"
    #: hold still for a time
    DELAY = "delay"
    #: switch a digital output (pneumatic gripper)
    OUTPUT = "output"
    #: the electric gripper's setpoints or one-shot modes
    GRIPPER = "gripper"
    #: wait for a digital input
    WAIT_INPUT = "wait_input"
    #: a mark in the queue, acked COMPLETED when the queue reaches it
    CHECKPOINT = "checkpoint"
    #: attach or detach an object held at the flange: the collision world changes in order
    #: with the moves queued before and after it
    HELD = "held"


class CollisionCheck(Enum):
    """How the controller checks a command's motion against its collision world (declared on
    each command class as ``COLLISION``; docs/collision.md, "What is checked where")."""

    #: it moves nothing the controller can check (not motion; HOME: the board homes by itself)
    NONE = "none"
    #: its planned trajectory is checked whole, swept, before it is admitted
    PLAN = "plan"
    #: every tick: a controlled stop from the next tick must end clear (jogs, servo streams)
    TICK = "tick"


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
        """True for COMPLETED, FAILED, CANCELLED and INVALID (exactly one per command)."""
        return self in (AckStatus.COMPLETED, AckStatus.FAILED, AckStatus.CANCELLED, AckStatus.INVALID)


# ---------------------------------------------------------------------------------------------
# field parsing helpers (each raises DatagramError naming the field)
# ---------------------------------------------------------------------------------------------


def _given(text: str) -> bool:
    return text.strip().upper() not in ("", "NONE")


def _number(text: str, fname: str) -> float:
    """A number field (spaces around it are ignored; what a number is: :mod:`parolkit.number_syntax`)."""
    try:
        return parse_number(text.strip(" "), fname)
    except ParolkitValueError as exc:
        raise DatagramError(str(exc)) from None


def _ranged(text: str, fname: str, lo: float, hi: float, *, lo_open: bool = False, unit: str = "") -> float:
    v = _number(text, fname)
    bad = v < lo or v > hi or (lo_open and v == lo)
    if bad:
        lb = "(" if lo_open else "["
        u = f" {unit}" if unit else ""
        raise DatagramError(f"{fname} = {v:g}{u} is out of range {lb}{lo:g}, {hi:g}]{u}")
    return v


def _opt_ranged(text: str, fname: str, lo: float, hi: float, *, lo_open: bool = False,
                unit: str = "") -> float | None:
    return _ranged(text, fname, lo, hi, lo_open=lo_open, unit=unit) if _given(text) else None


def _integer(text: str, fname: str, lo: int, hi: int) -> int:
    try:
        return parse_integer(text.strip(" "), fname, lo, hi)
    except ParolkitValueError as exc:
        raise DatagramError(str(exc)) from None


def _choice(text: str, fname: str, enum: type[_E], *, upper: bool = True) -> _E:
    s = text.strip()
    s = s.upper() if upper else s.lower()
    for member in enum:
        if member.value == s:
            return member
    allowed = "|".join(m.value for m in enum)
    raise DatagramError(f"{fname} must be one of {allowed}, got {_show(text)}")


def _opt_choice(text: str, fname: str, enum: type[_E], *, upper: bool = True) -> _E | None:
    return _choice(text, fname, enum, upper=upper) if _given(text) else None


def _flag01(text: str, fname: str) -> bool:
    s = text.strip().upper()
    if s in ("1", "TRUE"):
        return True
    if s in ("0", "FALSE"):
        return False
    raise DatagramError(f"{fname} must be 0 or 1, got {_show(text)}")


def _numbers(text: str, fname: str, count: int) -> tuple[float, ...]:
    parts = text.split(",")
    if len(parts) != count:
        raise DatagramError(f"{fname} must be {count} comma-separated numbers, got {len(parts)}")
    return tuple(_number(p, f"{fname}[{i}]") for i, p in enumerate(parts))


_POSE_NAMES = ("x", "y", "z", "A", "B", "C")


def _check_pose(values: Sequence[float], fname: str, *, relative: bool = False) -> tuple[float, ...]:
    for i, v in enumerate(values):
        if i < 3:
            if abs(v) > MAX_COORD_MM:
                raise DatagramError(
                    f"{fname}: {_POSE_NAMES[i]} = {v:g} mm is out of range "
                    f"[{-MAX_COORD_MM:g}, {MAX_COORD_MM:g}] mm"
                )
        elif abs(v) > 360.0:
            raise DatagramError(f"{fname}: {_POSE_NAMES[i]} = {v:g} deg is out of range [-360, 360] deg")
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
    return _ranged(text, fname, MIN_DURATION_S, MAX_DURATION_S, unit="s")


def _opt_duration(text: str, fname: str = "duration") -> float | None:
    return _duration(text, fname) if _given(text) else None


def _pct(text: str, fname: str = "speed%", *, lo_open: bool = False) -> float:
    return _ranged(text, fname, 0.0, 100.0, lo_open=lo_open, unit="%")


def _opt_pct(text: str, fname: str = "speed%", *, lo_open: bool = False) -> float | None:
    return _pct(text, fname, lo_open=lo_open) if _given(text) else None


def _duration_xor_speed(duration: float | None, speed: float | None) -> None:
    if duration is None and speed is None:
        raise DatagramError("give exactly one of duration (s) and speed% (0..100): neither was given")
    if duration is not None and speed is not None:
        raise DatagramError("give exactly one of duration (s) and speed% (0..100): both were given")


def _timing_value(timing: Timing, text: str) -> float:
    """The value of a smooth path's timing field: a duration (s) or a speed (%)."""
    if timing is Timing.DURATION:
        return _duration(text, "timing value (DURATION)")
    return _pct(text, "timing value (SPEED %)", lo_open=True)


def _nargs(args: Sequence[str], name: str, lo: int, hi: int | None = None) -> None:
    hi = lo if hi is None else hi
    n = len(args)
    if not lo <= n <= hi:
        want = f"{lo}" if lo == hi else f"{lo}..{hi}"
        raise DatagramError(f"{name} takes {want} arguments, got {n}")


# ---------------------------------------------------------------------------------------------
# command objects
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """Base of every command.  ``NAME`` is the wire name, ``KIND`` how it is handled."""

    NAME: ClassVar[str] = ""
    KIND: ClassVar[CommandKind] = CommandKind.QUEUED
    #: what the loop does with it when it runs
    EXECUTION: ClassVar[Execution] = Execution.NONE
    #: accepted from any client; False: only from the holder of the control lease
    #: (docs/protocol.md, "Who may move the robot")
    OPEN: ClassVar[bool] = False
    #: ESTOP / STOP / DISABLE: never waits behind other traffic (the safety lane)
    SAFETY: ClassVar[bool] = False
    #: in stream mode the newest one replaces the running one instead of queueing (jogs)
    STREAMABLE: ClassVar[bool] = False
    #: how its motion is checked for collisions
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.NONE

    @property
    def name(self) -> str:
        return self.NAME

    @property
    def is_motion(self) -> bool:
        """True for commands that move joints (refused until homed, except jogs)."""
        return False


QUERY_NAMES = (
    "GET_POSE", "GET_ANGLES", "GET_IO", "GET_GRIPPER", "GET_SPEEDS", "PING", "GET_STATUS",
    "GET_STATUS_JSON", "GET_LOOP_STATS", "GET_PLAN", "GET_TOOL", "GET_QUEUE", "GET_CONTROL", "GET_ZONES",
)


@dataclass(frozen=True)
class Query(Command):
    """A query answered at once; ``query`` is one of :data:`QUERY_NAMES`."""

    query: str = "PING"
    KIND: ClassVar[CommandKind] = CommandKind.QUERY
    OPEN: ClassVar[bool] = True

    @property
    def name(self) -> str:
        return self.query


@dataclass(frozen=True)
class Stop(Command):
    """Cancel the active and every queued command (CANCELLED acks); hold position."""

    NAME: ClassVar[str] = "STOP"
    SAFETY: ClassVar[bool] = True
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True

    #: why, when the controller stops on its own (never parsed from a datagram): the
    #: CANCELLED acks of the commands it stops carry it
    reason: str | None = None


@dataclass(frozen=True)
class AckHere(Command):
    """(ext) Acks of commands sent from this socket also go back to this socket (besides the
    ack port), so a client listening where it sends from needs no fixed ack port."""

    NAME: ClassVar[str] = "ACK_HERE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True


@dataclass(frozen=True)
class Enable(Command):
    """Enable the robot (board 101); clears a released E-stop latch and a latched error."""

    NAME: ClassVar[str] = "ENABLE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class Disable(Command):
    """Disable the robot (board 102); cancels motion."""

    NAME: ClassVar[str] = "DISABLE"
    SAFETY: ClassVar[bool] = True
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True


@dataclass(frozen=True)
class ClearError(Command):
    """Clear a latched error (board 103)."""

    NAME: ClassVar[str] = "CLEAR_ERROR"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class EStop(Command):
    """Software E-stop: cancel everything, DISABLE every tick, latched until ENABLE."""

    NAME: ClassVar[str] = "ESTOP"
    SAFETY: ClassVar[bool] = True
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True


@dataclass(frozen=True)
class StreamMode(Command):
    """``STREAM|ON/OFF``: the newest jog replaces the previous one; watchdog armed."""

    on: bool = False
    NAME: ClassVar[str] = "STREAM"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class SpeedCommand(Command):
    """``SPEED|pct``: the speed override, 1..100 % of every planned speed, for the running move
    (from the next tick, ramped within each joint's acceleration limit along the move's own
    path) and every move after it, until changed."""

    percent: float = 100.0
    NAME: ClassVar[str] = "SPEED"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE


@dataclass(frozen=True)
class ServoJ(Command):
    """``SERVOJ|j1|..|j6`` (deg): a servo target.  The latest target wins: an online
    jerk-limited generator moves every joint toward it within its speed and acceleration
    limits, from the next frame on.  The first target starts a stream (when nothing else runs;
    its ack is EXECUTING, then COMPLETED when the stream ends); later ones update it (acked
    COMPLETED at once).  No target for ``servo.timeout_s`` (0.05 s): a controlled stop."""

    target_deg: tuple[float, ...] = ()
    NAME: ClassVar[str] = "SERVOJ"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.TICK

    @property
    def is_motion(self) -> bool:
        return True


@dataclass(frozen=True)
class ServoL(Command):
    """``SERVOL|x|y|z|A|B|C[|WRF|TRF]`` (mm / deg): a servo target pose of the TCP, in the
    world frame (WRF, the default) or relative to the TCP pose where the stream started
    (TRF: the offset in that pose's tool frame); solved to joints nearest the stream's, then
    as SERVOJ."""

    pose: tuple[float, ...] = ()
    frame: Frame = Frame.WRF
    NAME: ClassVar[str] = "SERVOL"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.TICK

    @property
    def is_motion(self) -> bool:
        return True


@dataclass(frozen=True)
class Pause(Command):
    """``PAUSE``: the running move decelerates along its own path within each joint's
    acceleration limit and holds there; nothing queued starts until RESUME.  ``PAUSE|QUEUE``
    (``queue_only``): the running command goes on to its end, nothing queued starts until
    RESUME (a program paused between two lines).  From any client (like STOP: it only ever
    slows the robot)."""

    queue_only: bool = False
    NAME: ClassVar[str] = "PAUSE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True


@dataclass(frozen=True)
class Resume(Command):
    """``RESUME``: a paused move continues on the same path to the same target (ramped up
    within the acceleration limits); the queue runs again.  ``RESUME|ONE`` (``one``): a paused
    move goes on as for RESUME, but the queue is held (as by ``PAUSE|QUEUE``) and lets one more
    command start (a program stepped one line with the lines after it queued ahead)."""

    one: bool = False
    NAME: ClassVar[str] = "RESUME"
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
    """``SUBSCRIBE|port|every_n_ticks|cookie``: status stream to (sender address, port), once
    the sender echoes the cookie the controller answers a SUBSCRIBE without it with
    (``COOKIE|c``, docs/protocol.md "Status stream")."""

    port: int = 0
    every_n_ticks: int = 1
    cookie: str | None = None
    NAME: ClassVar[str] = "SUBSCRIBE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True


@dataclass(frozen=True)
class Control(Command):
    """``CONTROL|TAKE[|FORCE][|secret]`` / ``CONTROL|RELEASE``: take or give back the control
    lease (docs/protocol.md).  ``force`` takes it from another client (whose queued and running
    commands are then cancelled); ``secret`` is the controller's shared secret when it has one."""

    action: str = "TAKE"
    force: bool = False
    secret: str | None = None
    NAME: ClassVar[str] = "CONTROL"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True


@dataclass(frozen=True)
class Unsubscribe(Command):
    """``UNSUBSCRIBE|port``."""

    port: int = 0
    NAME: ClassVar[str] = "UNSUBSCRIBE"
    KIND: ClassVar[CommandKind] = CommandKind.IMMEDIATE
    OPEN: ClassVar[bool] = True


@dataclass(frozen=True)
class _Motion(Command):
    """A command that moves joints; ``move`` (each subclass's field) is its value object."""

    @property
    def is_motion(self) -> bool:
        return True


@dataclass(frozen=True)
class MoveJoint(_Motion):
    """``MOVEJOINT``: joint-space move to ``move.target_deg``; exactly one of duration / speed."""

    move: JointMove
    NAME: ClassVar[str] = "MOVEJOINT"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class MoveJointPath(_Motion):
    """(ext) ``MOVEJOINTPATH``: pass through ``move.points_deg`` at ``move.times_s`` (optionally
    with ``move.velocities_deg_s``) as ONE planned trajectory, from where the previous command
    ends; see :mod:`parolkit.motion.joint_path`."""

    move: JointPathMove
    NAME: ClassVar[str] = "MOVEJOINTPATH"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class MovePose(_Motion):
    """``MOVEPOSE``: IK at the target pose (mm, deg), joint-space path."""

    move: PoseMove
    NAME: ClassVar[str] = "MOVEPOSE"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class MoveCart(_Motion):
    """``MOVECART``: straight line in Cartesian space to ``move.pose`` (mm, deg)."""

    move: CartMove
    NAME: ClassVar[str] = "MOVECART"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class MoveCartRelTRF(_Motion):
    """``MOVECARTRELTRF``: relative straight line in the tool frame by ``move.delta`` (mm, deg)."""

    move: CartRelTRFMove
    NAME: ClassVar[str] = "MOVECARTRELTRF"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class Jog(_Motion):
    """``JOG``: jog one joint (``move.joints`` has one entry) for a duration and/or a distance."""

    move: JointJog
    NAME: ClassVar[str] = "JOG"
    STREAMABLE: ClassVar[bool] = True
    EXECUTION: ClassVar[Execution] = Execution.SPEED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.TICK


@dataclass(frozen=True)
class MultiJog(_Motion):
    """``MULTIJOG``: jog several joints at once for ``move.duration_s``, one speed % each."""

    move: JointJog
    NAME: ClassVar[str] = "MULTIJOG"
    STREAMABLE: ClassVar[bool] = True
    EXECUTION: ClassVar[Execution] = Execution.SPEED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.TICK


@dataclass(frozen=True)
class CartJogCommand(_Motion):
    """``CARTJOG``: Cartesian jog along/about one axis of WRF or TRF (the :class:`CartJog`
    value object it carries says which, how fast and how long)."""

    move: CartJog
    NAME: ClassVar[str] = "CARTJOG"
    STREAMABLE: ClassVar[bool] = True
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.TICK


@dataclass(frozen=True)
class Home(Command):
    """Board homing; completes when every homed bit is set."""

    NAME: ClassVar[str] = "HOME"
    EXECUTION: ClassVar[Execution] = Execution.HOME


@dataclass(frozen=True)
class Delay(Command):
    """Wait ``seconds`` in the queue."""

    seconds: float = 0.0
    NAME: ClassVar[str] = "DELAY"
    EXECUTION: ClassVar[Execution] = Execution.DELAY


@dataclass(frozen=True)
class Checkpoint(Command):
    """``CHECKPOINT|label``: acked COMPLETED (details ``checkpoint LABEL``) when the queue
    reaches it: everything queued before it has ended.  It takes no tick of its own."""

    label: str = ""
    NAME: ClassVar[str] = "CHECKPOINT"
    EXECUTION: ClassVar[Execution] = Execution.CHECKPOINT


@dataclass(frozen=True)
class Attach(Command):
    """``ATTACH|NAME|SPHERE|x,y,z|radius`` / ``ATTACH|NAME|CAPSULE|x1,y1,z1|x2,y2,z2|radius``:
    an object held at the flange from when the queue reaches it, checked for collisions as the
    tool is.  Points in mm, flange frame (``end_mm`` equals ``start_mm`` for a sphere, the
    centre); ``radius_mm`` mm.  An object of the same name is replaced."""

    object_name: str = ""
    shape: str = "sphere"
    start_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    end_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius_mm: float = 1.0
    NAME: ClassVar[str] = "ATTACH"
    EXECUTION: ClassVar[Execution] = Execution.HELD


@dataclass(frozen=True)
class Detach(Command):
    """``DETACH|NAME`` (one held object) or ``DETACH`` (``object_name`` None: all of them),
    when the queue reaches it."""

    object_name: str | None = None
    NAME: ClassVar[str] = "DETACH"
    EXECUTION: ClassVar[Execution] = Execution.HELD


@dataclass(frozen=True)
class PneumaticGripper(Command):
    """Drive OUT1/OUT2 like the original controller: ``open`` = output on, ``close`` = off."""

    action: str = "open"
    port: int = 1
    NAME: ClassVar[str] = "PNEUMATICGRIPPER"
    EXECUTION: ClassVar[Execution] = Execution.OUTPUT


@dataclass(frozen=True)
class ElectricGripper(Command):
    """SSG-48: ``action`` move|calibrate|clear_error; position/speed 0..255, current mA."""

    action: str = "move"
    position: int = 255
    speed: int = 150
    current_ma: int = 500
    NAME: ClassVar[str] = "ELECTRICGRIPPER"
    EXECUTION: ClassVar[Execution] = Execution.GRIPPER


@dataclass(frozen=True)
class SpeedJoint(_Motion):
    """(ext) ``SPEEDJOINT``: constant joint speeds (deg/s) for ``move.duration_s``, then zero."""

    move: SpeedJointMove
    NAME: ClassVar[str] = "SPEEDJOINT"
    EXECUTION: ClassVar[Execution] = Execution.SPEED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.TICK


@dataclass(frozen=True)
class WaitInput(Command):
    """(ext) Complete when digital input ``input_no`` (1|2) equals ``state``; FAILED on timeout."""

    input_no: int = 1
    state: bool = True
    timeout_s: float | None = None
    NAME: ClassVar[str] = "WAIT_INPUT"
    EXECUTION: ClassVar[Execution] = Execution.WAIT_INPUT


@dataclass(frozen=True)
class SmoothCircle(_Motion):
    """``SMOOTH_CIRCLE``: a full circle (the wire's timing is ``move.duration_s`` / ``speed_pct``)."""

    move: CircleMove
    NAME: ClassVar[str] = "SMOOTH_CIRCLE"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class SmoothArcCenter(_Motion):
    """``SMOOTH_ARC_CENTER``: an arc to an end pose around a centre."""

    move: ArcCenterMove
    NAME: ClassVar[str] = "SMOOTH_ARC_CENTER"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class SmoothArcParam(_Motion):
    """``SMOOTH_ARC_PARAM``: an arc to an end pose of a given radius and angle."""

    move: ArcParamMove
    NAME: ClassVar[str] = "SMOOTH_ARC_PARAM"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class SmoothSpline(_Motion):
    """``SMOOTH_SPLINE``: a cubic spline through the waypoints."""

    move: SplineMove
    NAME: ClassVar[str] = "SMOOTH_SPLINE"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


@dataclass(frozen=True)
class SmoothHelix(_Motion):
    """``SMOOTH_HELIX``: a helix around a vertical (frame Z) axis."""

    move: HelixMove
    NAME: ClassVar[str] = "SMOOTH_HELIX"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


#: SMOOTH_BLEND segment words and the segment each becomes (in the blend's frame).
BLEND_SEGMENT_KINDS: dict[str, type[BlendSegment]] = {
    "LINE": LineSegment, "CIRCLE": CircleMove, "ARC": ArcCenterMove, "SPLINE": SplineMove,
}


@dataclass(frozen=True)
class SmoothBlend(_Motion):
    """``SMOOTH_BLEND``: segments joined with rounded corners, timed as one move."""

    move: BlendMove
    NAME: ClassVar[str] = "SMOOTH_BLEND"
    EXECUTION: ClassVar[Execution] = Execution.PLANNED
    COLLISION: ClassVar[CollisionCheck] = CollisionCheck.PLAN


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


def _joint_angles(args: Sequence[str], model: RobotModel, where: str = "") -> tuple[float, ...]:
    """Six joint angles (deg) inside the joint ranges; ``where`` prefixes the field names
    (``"point 2 "``)."""
    vals = tuple(_number(a, f"{where}{JOINT_NAMES[i]} angle (deg)") for i, a in enumerate(args[:6]))
    lim = model.safe_limits_deg
    for i, v in enumerate(vals):
        lo, hi = float(lim[i, 0]), float(lim[i, 1])
        if not lo <= v <= hi:
            raise DatagramError(
                f"{where}{JOINT_NAMES[i]} angle = {v:g} deg is out of range [{lo:.4f}, {hi:.4f}] deg"
            )
    return vals


def _joint_speeds(args: Sequence[str], model: RobotModel, where: str = "", what: str = "speed") -> tuple[float, ...]:
    """Six joint speeds (deg/s), each within +- the joint's maximum speed; the fields are named
    ``f"{where}{joint} {what} (deg/s)"`` (``"J1 speed (deg/s)"``, ``"point 2 J1 velocity (deg/s)"``)."""
    mx = model.max_speed_deg_s
    return tuple(_ranged(a, f"{where}{JOINT_NAMES[i]} {what} (deg/s)", -float(mx[i]), float(mx[i]), unit="deg/s")
                 for i, a in enumerate(args[:6]))


def _zero_is_none(text: str) -> str:
    """A move's duration / speed% / accel% field: an explicit 0 means "not given", as in the
    seed's signature ``MoveJoint(j1, ..., v=0, a=0, t=0)`` (``"None"`` for a numeric zero)."""
    try:
        zero = _given(text) and _number(text, "") == 0.0
    except DatagramError:  # not a number: the field's own check names it
        return text
    return "None" if zero else text


def _move_tail(
    args: Sequence[str], *, with_accel: bool,
) -> tuple[float | None, float | None, float | None, Profile | None, Tracking]:
    """duration|speed% then optional (ext) accel%|profile|tracking (accel only for joint moves).
    A 0 in duration, speed% or accel% means "not given"."""
    duration = _opt_duration(_zero_is_none(args[0]))
    speed = _opt_pct(_zero_is_none(args[1]), lo_open=True)
    if duration is None and speed is None and (_given(args[0]) or _given(args[1])):
        raise DatagramError("give exactly one of duration (s) and speed% (0..100): neither was given "
                            "(0 means not given)")
    _duration_xor_speed(duration, speed)
    rest = list(args[2:])
    accel = None
    if with_accel:
        accel = _opt_pct(_zero_is_none(rest.pop(0)), "accel%", lo_open=True) if rest else None
    profile = _opt_choice(rest.pop(0), "profile", Profile, upper=False) if rest else None
    tracking = (_opt_choice(rest.pop(0), "tracking", Tracking, upper=False) if rest else None)
    return duration, speed, accel, profile, tracking or Tracking.POSITION


def _is_blend_field(text: str) -> bool:
    """True for an ``r=<radius>`` field (the key in any case, spaces around it allowed)."""
    key, eq, _ = text.partition("=")
    return bool(eq) and key.strip().upper() == "R"


def _blend_tail(args: Sequence[str], name: str, lo: int, hi: int, unit: str) -> tuple[Sequence[str], float | None]:
    """Split a move's optional LAST field ``r=<radius>`` (the blend radius, 0..MAX_BLEND
    ``unit``; 0 means no blending) off its fields and check how many fields are left:
    (the fields before it, the radius or None)."""
    at = [i for i, f in enumerate(args) if _is_blend_field(f)]
    if len(at) > 1:
        raise DatagramError(f"r= (blend radius) is given {len(at)} times (fields {at[0] + 1} and {at[1] + 1}): "
                            "give it once, as the last field")
    if not at:
        _nargs(args, name, lo, hi)
        return args, None
    i = at[0]
    if i != len(args) - 1:
        raise DatagramError(f"r= (blend radius) must be the last field, but it is field {i + 1} of {len(args)}: "
                            f"{name}|...|duration|speed%[|...]|r=<0..{MAX_BLEND:g} {unit}>")
    rest = args[:i]
    if not lo <= len(rest) <= hi:
        raise DatagramError(f"{name} takes {lo}..{hi} arguments before r=, got {len(rest)}")
    text = args[i].partition("=")[2]
    rng = f"0..{MAX_BLEND:g} {unit}"
    if not text.strip():
        raise DatagramError(f"r= (blend radius) needs a number in {rng}, got nothing (0 means no blending)")
    v = _number(text, f"r (blend radius, {rng})")
    if not 0.0 <= v <= MAX_BLEND:
        raise DatagramError(f"r (blend radius) = {v:g} {unit} is out of range [0, {MAX_BLEND:g}] {unit} "
                            "(0 means no blending)")
    return rest, v or None


def _no_blend(args: Sequence[str], name: str) -> None:
    """A move that does not blend refuses an ``r=`` field naming the moves that do."""
    if any(_is_blend_field(f) for f in args):
        raise DatagramError(f"{name} takes no r= (blend radius): only MOVEJOINT, MOVEPOSE and MOVECART blend")


def _p_movejoint(a: Sequence[str], m: RobotModel) -> Command:
    a, blend = _blend_tail(a, "MOVEJOINT", 8, 11, "deg")
    duration, speed, accel, profile, tracking = _move_tail(a[6:], with_accel=True)
    return MoveJoint(JointMove(_joint_angles(a, m), duration, speed, accel, profile, tracking, blend=blend))


#: MOVEJOINTPATH fields per point: time|j1..j6, or time|j1..j6|v1..v6 with velocities
_PATH_FIELDS = (7, 13)


def _p_movejointpath(a: Sequence[str], m: RobotModel) -> Command:
    """``n|time|j1..j6|...`` (7 fields per point) or ``n|time|j1..j6|v1..v6|...`` (13 fields per
    point, velocities at every point); points numbered from 0 in messages, as in the move."""
    if not a:
        raise DatagramError(f"MOVEJOINTPATH takes n|time|j1..j6[|v1..v6]|... (n = 1..{MAX_PATH_POINTS} points), "
                            "got no arguments")
    n = _integer(a[0], "n (points)", 1, MAX_PATH_POINTS)
    fields = a[1:]
    per = next((w for w in _PATH_FIELDS if len(fields) == w * n), None)
    if per is None:
        raise DatagramError(
            f"n = {n} points announced, {len(fields)} fields given (expected {7 * n}: time|j1..j6 per point, "
            f"or {13 * n}: time|j1..j6|v1..v6 per point)")
    times, points, velocities = [], [], []
    for k in range(n):
        f = fields[per * k: per * (k + 1)]
        times.append(_duration(f[0], f"point {k} time (s)"))
        points.append(_joint_angles(f[1:7], m, f"point {k} "))
        if per == 13:
            velocities.append(_joint_speeds(f[7:13], m, f"point {k} ", "velocity"))
    return MoveJointPath(JointPathMove(tuple(points), tuple(times), tuple(velocities) if per == 13 else None))


def _p_movepose(a: Sequence[str], m: RobotModel) -> Command:
    a, blend = _blend_tail(a, "MOVEPOSE", 8, 11, "deg")
    duration, speed, accel, profile, tracking = _move_tail(a[6:], with_accel=True)
    return MovePose(PoseMove(_pose_args(a, "pose"), duration, speed, accel, profile, tracking, blend=blend))


def _p_movecart(a: Sequence[str], m: RobotModel) -> Command:
    a, blend = _blend_tail(a, "MOVECART", 8, 10, "mm")
    duration, speed, _, profile, tracking = _move_tail(a[6:], with_accel=False)
    return MoveCart(CartMove(_pose_args(a, "pose"), duration, speed, profile, tracking, blend=blend))


def _p_movecartrel(a: Sequence[str], m: RobotModel) -> Command:
    _no_blend(a, "MOVECARTRELTRF")
    _nargs(a, "MOVECARTRELTRF", 8, 10)
    duration, speed, _, profile, tracking = _move_tail(a[6:], with_accel=False)
    return MoveCartRelTRF(CartRelTRFMove(_pose_args(a, "delta"), duration, speed, profile, tracking))


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
        raise DatagramError("JOG needs a duration (s) and/or a distance_deg: neither was given")
    return Jog(JointJog.single(joint, direction, speed, duration_s=duration, distance_deg=distance))


def _p_multijog(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "MULTIJOG", 3)
    idx_parts = a[0].split(",")
    spd_parts = a[1].split(",")
    if not 1 <= len(idx_parts) <= 6:
        raise DatagramError(f"joint indices must be 1..6 comma-separated values, got {len(idx_parts)}")
    if len(spd_parts) != len(idx_parts):
        raise DatagramError(
            f"speeds must have one value per joint index ({len(idx_parts)}), got {len(spd_parts)}"
        )
    joints = tuple(_jog_index(p, f"joint index[{i}]") for i, p in enumerate(idx_parts))
    seen: dict[int, int] = {}
    for j, d in joints:
        if j in seen:
            what = "both + and -" if seen[j] != d else "twice"
            raise DatagramError(f"joint {JOINT_NAMES[j]} is given {what} in one MULTIJOG")
        seen[j] = d
    speeds = tuple(_pct(p, f"speed%[{i}]", lo_open=True) for i, p in enumerate(spd_parts))
    return MultiJog(JointJog(tuple(j for j, _ in joints), tuple(d for _, d in joints), speeds,
                             duration_s=_duration(a[2])))


def _p_cartjog(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "CARTJOG", 4)
    frame = _choice(a[0], "frame", Frame)
    word = a[1].strip().upper()
    axis = next((ax for ax in CartAxis if ax.value == word), None)
    if axis is None:
        raise DatagramError(f"axis must be one of {' '.join(ax.value for ax in CartAxis)}, got {_show(a[1])}")
    return CartJogCommand(CartJog(frame, axis, _pct(a[2], lo_open=True), _duration(a[3])))


def _p_home(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "HOME", 0)
    return Home()


def _p_delay(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "DELAY", 1)
    return Delay(_ranged(a[0], "seconds", 0.0, MAX_DURATION_S, unit="s"))


#: a checkpoint label: 1..64 characters of [A-Za-z0-9_.:-]
_LABEL_RE = re.compile(r"^[A-Za-z0-9_.:-]{1,64}$", re.ASCII)


def _p_checkpoint(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "CHECKPOINT", 1)
    label = a[0].strip()
    if not _LABEL_RE.match(label):
        raise DatagramError(f"label must be 1..64 characters of [A-Za-z0-9_.:-], got {_show(a[0])}")
    return Checkpoint(label)


#: the shapes ATTACH takes, and their fields after NAME|SHAPE
_HELD_FIELDS = {"SPHERE": ("x,y,z", "radius"), "CAPSULE": ("x1,y1,z1", "x2,y2,z2", "radius")}


def _flange_point(text: str, fname: str) -> tuple[float, float, float]:
    """A point of the flange frame, ``x,y,z`` mm, each within +-MAX_TOOL_POINT_MM."""
    from parolkit.collision.shapes import MAX_TOOL_POINT_MM

    v = _numbers(text, fname, 3)
    for axis, c in zip("xyz", v):
        if abs(c) > MAX_TOOL_POINT_MM:
            raise DatagramError(f"{fname}: {axis} = {c:g} mm is out of range "
                                f"[{-MAX_TOOL_POINT_MM:g}, {MAX_TOOL_POINT_MM:g}] mm")
    return (v[0], v[1], v[2])


def _p_attach(a: Sequence[str], m: RobotModel) -> Command:
    from parolkit.collision.shapes import MAX_SHAPE_LENGTH_MM, MAX_SHAPE_RADIUS_MM, _check_name

    if len(a) < 2:
        raise DatagramError("ATTACH takes NAME|SPHERE|x,y,z|radius or NAME|CAPSULE|x1,y1,z1|x2,y2,z2|radius, "
                            f"got {len(a)} field{'s' if len(a) != 1 else ''}")
    try:
        name = _check_name(a[0].strip(), "object")
    except ParolkitValueError as exc:
        raise DatagramError(str(exc)) from None
    kind = a[1].strip().upper()
    fields = _HELD_FIELDS.get(kind)
    if fields is None:
        raise DatagramError(f"shape must be one of {'|'.join(_HELD_FIELDS)}, got {_show(a[1])}")
    if len(a) != 2 + len(fields):
        raise DatagramError(f"a {kind} takes NAME|{kind}|{'|'.join(fields)} ({2 + len(fields)} fields), "
                            f"got {len(a)}")
    radius = _ranged(a[-1], "radius", 0.0, MAX_SHAPE_RADIUS_MM, lo_open=True, unit="mm")
    if kind == "SPHERE":
        c = _flange_point(a[2], "center")
        return Attach(name, "sphere", c, c, radius)
    p, q = _flange_point(a[2], "start"), _flange_point(a[3], "end")
    length = sum((u - v) ** 2 for u, v in zip(p, q)) ** 0.5
    if length > MAX_SHAPE_LENGTH_MM:
        raise DatagramError(f"the capsule's length (start to end) = {length:g} mm is out of range "
                            f"[0, {MAX_SHAPE_LENGTH_MM:g}] mm")
    return Attach(name, "capsule", p, q, radius)


def _p_detach(a: Sequence[str], m: RobotModel) -> Command:
    from parolkit.collision.shapes import _check_name

    _nargs(a, "DETACH", 0, 1)
    if not a:
        return Detach(None)
    try:
        return Detach(_check_name(a[0].strip(), "object"))
    except ParolkitValueError as exc:
        raise DatagramError(str(exc)) from None


def _p_pause(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "PAUSE", 0, 1)
    if a and a[0].strip().upper() != "QUEUE":
        raise DatagramError(f"PAUSE takes nothing or QUEUE, got {_show(a[0])}")
    return Pause(queue_only=bool(a))


def _p_resume(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "RESUME", 0, 1)
    if a and a[0].strip().upper() != "ONE":
        raise DatagramError(f"RESUME takes nothing or ONE, got {_show(a[0])}")
    return Resume(one=bool(a))


def _p_servoj(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SERVOJ", 6)
    return ServoJ(_joint_angles(a, m))


def _p_servol(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SERVOL", 6, 7)
    frame = _choice(a[6], "frame", Frame) if len(a) == 7 else Frame.WRF
    return ServoL(_pose_args(a, "pose"), frame)


def _p_speed(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SPEED", 1)
    return SpeedCommand(_ranged(a[0], "speed override (%)", 1.0, 100.0, unit="%"))


def _p_pneumatic(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "PNEUMATICGRIPPER", 2)
    action = a[0].strip().lower()
    if action not in ("open", "close"):
        raise DatagramError(f"action must be open|close, got {_show(a[0])}")
    return PneumaticGripper(action, _integer(a[1], "port", 1, 2))


def _p_electric(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "ELECTRICGRIPPER", 1, 4)
    raw = a[0].strip().lower()
    action = "move" if raw in ("", "none") else raw
    if action not in ("move", "calibrate", "clear_error"):
        raise DatagramError(f"action must be move|calibrate|clear_error|None, got {_show(a[0])}")
    rest = list(a[1:]) + ["None"] * (4 - len(a))
    pos = _integer(rest[0], "position", 0, 255) if _given(rest[0]) else 255
    speed = _integer(rest[1], "speed", 0, 255) if _given(rest[1]) else 150
    current = _integer(rest[2], "current (mA)", *GRIPPER_CURRENT_RANGE_MA) if _given(rest[2]) else 500
    return ElectricGripper(action, pos, speed, current)


def _p_speedjoint(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SPEEDJOINT", 7)
    return SpeedJoint(SpeedJointMove(_joint_speeds(a, m), _duration(a[6])))


def _p_waitinput(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "WAIT_INPUT", 2, 3)
    inp = _integer(a[0], "input", 1, 2)
    state = _flag01(a[1], "state")
    timeout = _opt_duration(a[2], "timeout_s") if len(a) > 2 else None
    return WaitInput(inp, state, timeout)


def _smooth_common(args: Sequence[str]) -> dict[str, Any]:
    """frame|start|timing|value (4 fields) as the move's keyword arguments."""
    frame = _choice(args[0], "frame", Frame)
    start = _start_field(args[1])
    timing = _choice(args[2], "timing", Timing)
    duration_s, speed_pct = timing.fields(_timing_value(timing, args[3]))
    return {"frame": frame, "start_pose": start, "duration_s": duration_s, "speed_pct": speed_pct}


def _radius(text: str, fname: str = "radius (mm)") -> float:
    return _ranged(text, fname, 0.0, 2000.0, lo_open=True, unit="mm")


def _p_circle(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_CIRCLE", 8)
    return SmoothCircle(CircleMove(
        center_mm=_point_field(a[0], "center"), radius_mm=_radius(a[1]),
        plane=_choice(a[2], "plane", Plane), clockwise=_flag01(a[7], "clockwise"),
        **_smooth_common(a[3:7]),
    ))


def _p_arc_center(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_ARC_CENTER", 7)
    return SmoothArcCenter(ArcCenterMove(
        end_pose=_pose_field(a[0], "end pose"), center_mm=_point_field(a[1], "center"),
        clockwise=_flag01(a[6], "clockwise"), **_smooth_common(a[2:6]),
    ))


def _p_arc_param(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_ARC_PARAM", 8)
    angle = _number(a[2], "angle (deg)")
    if not 0.0 < angle < 360.0:  # the sweep; the direction is the clockwise flag
        raise DatagramError(f"angle (deg) = {angle:g} deg is out of range (0, 360) deg")
    return SmoothArcParam(ArcParamMove(
        end_pose=_pose_field(a[0], "end pose"), radius_mm=_radius(a[1]), angle_deg=angle,
        clockwise=_flag01(a[7], "clockwise"), **_smooth_common(a[3:7]),
    ))


def _p_spline(a: Sequence[str], m: RobotModel) -> Command:
    if len(a) < 5:
        raise DatagramError(f"SMOOTH_SPLINE takes n|frame|start|timing|value|pose x n, got {len(a)} arguments")
    n = _integer(a[0], "n (waypoints)", 2, MAX_WAYPOINTS)
    fields = list(a[5:])
    if len(fields) == 6 * n and n > 1 and not any("," in f for f in fields):
        # also accepted: every waypoint as six separate fields x|y|z|A|B|C
        fields = [",".join(fields[6 * i : 6 * i + 6]) for i in range(n)]
    if len(fields) != n:
        raise DatagramError(
            f"SMOOTH_SPLINE: n = {n} waypoints announced, {len(a) - 5} fields given "
            f"(expected {n} poses x,y,z,A,B,C or {6 * n} single numbers)")
    wps = tuple(_pose_field(p, f"waypoint {i + 1}") for i, p in enumerate(fields))
    return SmoothSpline(SplineMove(waypoints=wps, **_smooth_common(a[1:5])))


def _p_helix(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SMOOTH_HELIX", 9)
    return SmoothHelix(HelixMove(
        center_mm=_point_field(a[0], "center"), radius_mm=_radius(a[1]),
        pitch_mm=_ranged(a[2], "pitch (mm)", 0.0, 1000.0, lo_open=True, unit="mm"),
        height_mm=_ranged(a[3], "height (mm)", -2000.0, 2000.0, unit="mm"),
        clockwise=_flag01(a[8], "clockwise"), **_smooth_common(a[4:8]),
    ))


def _blend_segment(fields: Sequence[str], k: int, frame: Frame) -> tuple[BlendSegment, float]:
    """One SMOOTH_BLEND segment (in the blend's ``frame``) and its duration (s, which only
    counts towards the default total duration)."""
    where = f"segment {k + 1}"
    if not fields:
        raise DatagramError(f"{where} is empty")
    kind = fields[0].strip().upper()
    f = list(fields[1:])
    if kind == "LINE":
        _nargs(f, f"{where} LINE (end pose|duration)", 2)
        return (LineSegment(_pose_field(f[0], f"{where} end pose")),
                _duration(f[1], f"{where} duration"))
    if kind == "CIRCLE":
        _nargs(f, f"{where} CIRCLE (center|radius|plane|duration|clockwise)", 5)
        duration = _duration(f[3], f"{where} duration")
        return CircleMove(
            _point_field(f[0], f"{where} center"), _radius(f[1], f"{where} radius (mm)"),
            _choice(f[2], f"{where} plane", Plane), frame=frame, duration_s=duration,
            clockwise=_flag01(f[4], f"{where} clockwise"),
        ), duration
    if kind == "ARC":
        _nargs(f, f"{where} ARC (end pose|center|duration|clockwise)", 4)
        duration = _duration(f[2], f"{where} duration")
        return ArcCenterMove(
            _pose_field(f[0], f"{where} end pose"), _point_field(f[1], f"{where} center"),
            frame=frame, duration_s=duration, clockwise=_flag01(f[3], f"{where} clockwise"),
        ), duration
    if kind == "SPLINE":
        if len(f) == 3 and "," not in f[2]:
            # the original client's form: n|x,y,z,A,B,C;x,y,z,A,B,C;...|duration
            n = _integer(f[0], f"{where} SPLINE n (waypoints)", 2, MAX_WAYPOINTS)
            poses = f[1].split(";")
            if len(poses) != n:
                raise DatagramError(f"{where} SPLINE: n = {n} waypoints announced, {len(poses)} given "
                                    "(separated by ';')")
            duration_text = f[2]
        elif len(f) >= 2:
            poses, duration_text = f[1:], f[0]
        else:
            raise DatagramError(f"{where} SPLINE takes duration|pose|pose|... or n|pose;pose;...|duration, "
                                f"got {len(f)} fields")
        wps = tuple(_pose_field(p, f"{where} waypoint {i + 1}") for i, p in enumerate(poses))
        if len(wps) < 2:
            raise DatagramError(f"{where} SPLINE needs at least 2 waypoints, got {len(wps)}")
        duration = _duration(duration_text, f"{where} duration")
        return SplineMove(wps, frame=frame, duration_s=duration), duration
    raise DatagramError(f"{where} type must be {'|'.join(BLEND_SEGMENT_KINDS)}, got {_show(fields[0])}")


def _p_blend(a: Sequence[str], m: RobotModel) -> Command:
    default = len(a) > 4 and a[4].strip().upper() == "DEFAULT"
    if len(a) < (6 if default else 7):
        raise DatagramError(
            f"SMOOTH_BLEND takes n|blend_time|frame|start|timing|value|segments (or DEFAULT timing without "
            f"a value), got {len(a)} arguments"
        )
    n = _integer(a[0], "n (segments)", 1, 100)
    blend = _ranged(a[1], "blend time (s)", 0.0, 10.0, unit="s")
    frame = _choice(a[2], "frame", Frame)
    start = _start_field(a[3])
    if default:
        # the original client's form: DEFAULT (no value field) = the segments' own durations
        timing, value, first_segment = Timing.DURATION, 0.0, 5
    else:
        word = a[4].strip().upper()
        found = next((t for t in Timing if t.value == word), None)
        if found is None:
            raise DatagramError(f"timing must be one of {'|'.join(t.value for t in Timing)}|DEFAULT, "
                                f"got {_show(a[4])}")
        timing = found
        value = _timing_value(timing, a[5]) if _given(a[5]) else 0.0
        first_segment = 6
    if timing is Timing.SPEED and value == 0.0:
        raise DatagramError("timing value (SPEED %) must be given for SPEED timing")
    segs_raw: list[list[str]] = [[]]
    for fld in a[first_segment:]:
        if fld == "":
            segs_raw.append([])
        else:
            segs_raw[-1].append(fld)
    segs_raw = [s for s in segs_raw if s]
    if len(segs_raw) != n:
        raise DatagramError(f"SMOOTH_BLEND: n = {n} segments announced, {len(segs_raw)} given (separate them with ||)")
    parsed = [_blend_segment(s, k, frame) for k, s in enumerate(segs_raw)]
    # value None with DURATION timing: the sum of the segment durations
    duration_s, speed_pct = timing.fields(value if value else sum(d for _, d in parsed))
    return SmoothBlend(BlendMove(
        segments=tuple(seg for seg, _ in parsed), blend_time_s=blend, frame=frame,
        start_pose=start, duration_s=duration_s, speed_pct=speed_pct,
    ))


def _p_stream(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "STREAM", 1)
    s = a[0].strip().upper()
    if s not in ("ON", "OFF", "1", "0"):
        raise DatagramError(f"STREAM takes ON|OFF, got {_show(a[0])}")
    return StreamMode(s in ("ON", "1"))


def _p_setport(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SET_PORT", 1)
    port = a[0].strip()
    if not port or any(ord(c) < 32 for c in port):
        raise DatagramError(f"SET_PORT needs a device name such as /dev/ttyACM0, got {_show(a[0])}")
    return SetPort(port)


def _p_settool(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SET_TOOL", 1)
    name = a[0].strip()
    if not re.match(r"^[A-Za-z0-9_.-]{1,64}$", name):
        raise DatagramError(f"tool name must be 1..64 characters of [A-Za-z0-9_.-], got {_show(a[0])}")
    return SetTool(name)


#: a shared secret on the wire: printable ASCII without the separator, 1..128 characters
_SECRET_RE = re.compile(r"^[!-{}~]{1,128}$", re.ASCII)


def _p_control(a: Sequence[str], m: RobotModel) -> Command:
    if not a:
        raise DatagramError("CONTROL needs TAKE or RELEASE: CONTROL|TAKE[|FORCE][|secret] or CONTROL|RELEASE")
    action = a[0].strip().upper()
    if action == "RELEASE":
        _nargs(a, "CONTROL|RELEASE", 1)
        return Control("RELEASE")
    if action != "TAKE":
        raise DatagramError(f"CONTROL takes TAKE or RELEASE, got {_show(a[0])}")
    rest = [f.strip() for f in a[1:]]
    force = bool(rest) and rest[0].upper() == "FORCE"
    if force:
        rest = rest[1:]
    if len(rest) > 1:
        raise DatagramError("CONTROL|TAKE takes at most FORCE and a secret: CONTROL|TAKE[|FORCE][|secret]")
    secret = rest[0] if rest else None
    if secret is not None and not _SECRET_RE.match(secret):
        raise DatagramError("the secret must be 1..128 printable ASCII characters without '|' or spaces")
    return Control("TAKE", force, secret)


def _p_subscribe(a: Sequence[str], m: RobotModel) -> Command:
    _nargs(a, "SUBSCRIBE", 1, 3)
    port = _integer(a[0], "port", 1, 65535)
    every = _integer(a[1], "every_n_ticks", 1, 1_000_000) if len(a) > 1 and _given(a[1]) else 1
    cookie = a[2].strip() if len(a) > 2 and _given(a[2]) else None
    return Subscribe(port, every, cookie)


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
    "MOVEJOINTPATH": _p_movejointpath,
    "MOVEPOSE": _p_movepose,
    "MOVECART": _p_movecart,
    "MOVECARTRELTRF": _p_movecartrel,
    "JOG": _p_jog,
    "MULTIJOG": _p_multijog,
    "CARTJOG": _p_cartjog,
    "HOME": _p_home,
    "DELAY": _p_delay,
    "CHECKPOINT": _p_checkpoint,
    "ATTACH": _p_attach,
    "DETACH": _p_detach,
    "SPEED": _p_speed,
    "SERVOJ": _p_servoj,
    "SERVOL": _p_servol,
    "PAUSE": _p_pause,
    "RESUME": _p_resume,
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
    "CONTROL": _p_control,
    "UNSUBSCRIBE": _p_unsubscribe,
}
#: every command and query name (upper case)
_NAMES = frozenset(_PARSERS) | frozenset(QUERY_NAMES)

#: Every command name the controller understands.
COMMAND_NAMES = tuple(sorted(set(_PARSERS) | set(QUERY_NAMES)))


def is_command_id(text: str) -> bool:
    """True when ``text`` is a command ID: 8 chars of [A-Za-z0-9-], not all upper-case, and not
    a command name written in lower case (``movecart|...`` is the command, not an ID)."""
    return bool(_ID_RE.match(text)) and not text.isupper() and text.upper() not in _NAMES


def _non_ascii(text: str) -> str | None:
    """Why ``text`` is not protocol text (printable ASCII, 0x20-0x7E: no tab, line end or NUL
    either), naming the first character that is not; None when it is."""
    if text.isascii() and text.isprintable():
        return None
    for i, ch in enumerate(text):
        if not ch.isascii():
            name = unicodedata.name(ch, "unnamed character")
            return (f"character {ch!r} (U+{ord(ch):04X} {name}) at position {i} is not ASCII: the protocol "
                    f"is plain ASCII, so look-alike letters and digits are refused")
        if not ch.isprintable():
            return (f"control character U+{ord(ch):04X} at position {i}: the protocol is printable ASCII "
                    "(no NUL, tab or line end, not even at the ends)")
    return None


def _only_look_alike_digits(text: str) -> bool:
    """True when every character of ``text`` outside printable ASCII is a decimal digit of
    another script (``٣``, ``９``, ``𝟖``): the datagram is then parsed field by field so that the
    number field holding one refuses it naming itself (and refused anyway if none does)."""
    return all((ch.isascii() and ch.isprintable()) or unicodedata.category(ch) == "Nd" for ch in text)


def _raw_command_id(data: bytes) -> str | None:
    """The command ID at the start of a datagram's bytes, found before the text is decoded (so a
    datagram that is not valid text still gets its INVALID ack)."""
    m = _RAW_ID_RE.match(data[:16])
    if m is None:
        return None
    cid = m.group(1).decode("ascii")
    return cid if is_command_id(cid) else None


def _capped(message: str) -> str:
    if len(message) <= MAX_MESSAGE_CHARS:
        return message
    return message[:MAX_MESSAGE_CHARS - 3] + "..."


def parse_datagram(data: bytes | str, model: RobotModel | None = None) -> Parsed:
    """Parse one datagram.  Raises :class:`DatagramError` (with ``command_id`` when known).

    A field outside its wire range is reported with the wire field's name; a motion command's
    move then validates itself (e.g. a helix of more than 100 turns), its message prefixed
    with the command name.  Only printable ASCII is accepted (a look-alike digit or letter is
    refused, naming the character); numeric fields are length-capped before conversion; no
    message is longer than MAX_MESSAGE_CHARS.  The ID is taken from the raw bytes first, so
    every datagram that starts with one gets it back in the error."""
    try:
        return _parse(data, model or PAROL6)
    except DatagramError as exc:
        if len(exc.message) > MAX_MESSAGE_CHARS:
            raise DatagramError(_capped(exc.message), command_id=exc.command_id, name=exc.name) from None
        raise


def _parse(data: bytes | str, m: RobotModel) -> Parsed:
    if isinstance(data, (bytes, bytearray, memoryview)):
        raw = bytes(data)
        raw_id = _raw_command_id(raw)
        if len(raw) > MAX_DATAGRAM_BYTES:
            raise DatagramError(f"datagram is {len(raw)} bytes, at most {MAX_DATAGRAM_BYTES} allowed",
                                command_id=raw_id)
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise DatagramError(f"datagram is not ASCII text (byte 0x{raw[exc.start]:02X} at position "
                                f"{exc.start})", command_id=raw_id) from None
    else:
        text = data
        raw_id = _raw_command_id(text[:16].encode("utf-8", "replace"))
    text = text.strip(" ")
    why = _non_ascii(text)
    if why is None:
        return _parse_text(text, m)
    if not _only_look_alike_digits(text):
        raise DatagramError(why, command_id=raw_id)
    parsed = _parse_text(text, m)  # a number field names itself when it refuses the digit
    raise DatagramError(why, command_id=parsed.command_id)  # in a name or word: refused all the same


def _parse_text(text: str, m: RobotModel) -> Parsed:
    if not text:
        raise DatagramError("empty datagram: expected [ID|]NAME|args")
    parts = text.split("|")
    command_id: str | None = None
    if is_command_id(parts[0].strip()):
        command_id = parts[0].strip()
        parts = parts[1:]
        if not parts:
            raise DatagramError("datagram has an ID but no command name", command_id=command_id)
    raw_name = parts[0].strip()
    name = raw_name.upper()
    args = parts[1:]
    # trailing empty field from a trailing "|" is tolerated (clients sometimes add one)
    if args and args[-1].strip() == "" and name != "SMOOTH_BLEND":
        args = args[:-1]
    try:
        if name in QUERY_NAMES:
            if args:
                raise DatagramError(f"{name} takes no arguments, got {len(args)}")
            return Parsed(command_id, Query(name))
        parser = _PARSERS.get(name)
        if parser is None:
            if not name:
                raise DatagramError("missing command name: expected [ID|]NAME|args")
            raise DatagramError(f"unknown command {_show(raw_name)}")
        return Parsed(command_id, parser(args, m))
    except DatagramError as exc:
        known = name in _PARSERS or name in QUERY_NAMES
        msg = exc.message if (not known or exc.message.startswith(name)) else f"{name}: {exc.message}"
        raise DatagramError(msg, command_id=command_id, name=name if known else None) from None
    except ParolkitValueError as exc:  # a move's own checks, a percent mapping of the model
        raise DatagramError(f"{name}: {exc}", command_id=command_id, name=name) from None
    except (ValueError, ArithmeticError) as exc:  # a check that should have caught it did not
        raise DatagramError(f"{name}: invalid value ({exc})", command_id=command_id,
                            name=name if name in _PARSERS else None) from None


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


def format_cookie(cookie: str) -> str:
    """(ext) ``COOKIE|c``: the answer to a SUBSCRIBE that did not echo its cookie."""
    return f"COOKIE|{cookie}"


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
