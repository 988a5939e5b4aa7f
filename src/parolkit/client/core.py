"""The protocol core shared by :class:`~parolkit.client.robot.Robot` (sync) and
:class:`~parolkit.client.async_robot.AsyncRobot` (asyncio): no sockets in here.

httpx-style: everything about the wire (datagram building, ack matching, reply parsing, typed
results, errors) lives here once; the two clients only move datagrams and wait.

* Datagrams are built by the ``build_*`` functions of :mod:`parolkit.client.robot_api` (one
  formatting implementation for both APIs).
* :class:`AckBook` matches ``ACK|ID|STATUS|details`` datagrams to the commands we sent.
* :class:`Queries` holds each query (:class:`QuerySpec`): its request, reply tag and the parser
  of the payload into a typed value (loosely typed JSON becomes frozen dataclasses here, once).
* :class:`RobotCommands` defines every public command/query method once.  Each method builds
  its datagram and hands it to ``self._run`` / ``self._start`` / ``self._query``: the sync
  client returns results, the async client coroutines of the same results.  It is generic in
  what those are, so every method has a precise type on both clients (see its docstring).

Units: deg, mm, %, s at this API (as on the wire); joint speeds from the board in steps/s.
"""

from __future__ import annotations

import json
import math
import re
import time
from collections import OrderedDict
from collections.abc import Callable, Coroutine, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Final, Generic, Literal, NamedTuple, TypeAlias, TypeVar, final, overload

from parolkit.client import robot_api as wire
from parolkit.client.errors import (
    CommandCancelled,
    CommandFailed,
    CommandInvalid,
    ReplyError,
)
from parolkit.client.robot_api import ControlInfo
from parolkit.errors import ParolkitValueError

__all__ = [
    "AckStatus",
    "RobotState",
    "CommandResult",
    "Pose",
    "IOState",
    "GripperState",
    "LoopStats",
    "BoardInfo",
    "ErrorInfo",
    "ActiveCommand",
    "RobotStatus",
    "PlanInfo",
    "QueueInfo",
    "ToolInfo",
    "ZoneInfo",
    "HeldInfo",
    "ToolShapeInfo",
    "ZonesInfo",
    "ControlInfo",
    "AckRecord",
    "AckBook",
    "QuerySpec",
    "Queries",
    "RobotCommands",
    "AsyncResult",
    "OnOff",
    "command_name",
    "result_or_raise",
    "parse_query_reply",
    "DEFAULT_TIMEOUT_S",
    "SUBSCRIBE_RENEW_S",
]

#: Seconds to wait for a query reply or for the first acknowledgement of a command.
DEFAULT_TIMEOUT_S = 2.0
#: The controller drops a subscription after 10 s; clients renew it this often (s).
SUBSCRIBE_RENEW_S = 3.0

_T = TypeVar("_T")
#: what a waited command gives (CommandResult, or a coroutine of it) and what ``wait=False``
#: gives (a handle, or a coroutine of one): see :class:`RobotCommands`
_Result = TypeVar("_Result", covariant=True)
_Handle = TypeVar("_Handle", covariant=True)

#: What every command and query of :class:`~parolkit.client.async_robot.AsyncRobot` returns: a
#: coroutine (``await`` it, or hand it to ``asyncio.create_task``/``gather``) giving a ``_T``.
AsyncResult: TypeAlias = Coroutine[object, None, _T]


def bind_address(host: str) -> str:
    """Local address for a client socket talking to ``host``: loopback for a local
    controller, every interface otherwise."""
    return "127.0.0.1" if host in ("127.0.0.1", "localhost") else "0.0.0.0"


def check_port(port: object, name: str, low: int) -> int:
    """``port`` if it is an int in ``low``..65535, else ParolkitValueError naming ``name``."""
    if isinstance(port, bool) or not isinstance(port, int) or not low <= port <= 65535:
        raise ParolkitValueError(f"{name} must be an integer in {low}..65535, got {port!r}")
    return port


class AckStatus(str, Enum):
    """Acknowledgement status of a command (``ACK|ID|STATUS|details``)."""

    QUEUED = "QUEUED"
    EXECUTING = "EXECUTING"
    COMPLETED = "COMPLETED"
    FAILED = "FAILED"
    CANCELLED = "CANCELLED"
    INVALID = "INVALID"

    @property
    def terminal(self) -> bool:
        """True for COMPLETED, FAILED, CANCELLED and INVALID (exactly one per command)."""
        return self in (AckStatus.COMPLETED, AckStatus.FAILED, AckStatus.CANCELLED,
                        AckStatus.INVALID)


@final
@dataclass(frozen=True)
class CommandResult:
    """What the controller said about one command: ``id``, ``command`` (name),
    ``status`` and ``details`` (e.g. ``Position 2 in queue``)."""

    id: str
    command: str
    status: AckStatus
    details: str = ""

    @property
    def ok(self) -> bool:
        return self.status is AckStatus.COMPLETED

    @property
    def done(self) -> bool:
        return self.status.terminal


class RobotState(str, Enum):
    """What the controller is doing (the status ``state`` field).

    A ``str`` enum: ``status.state == "IDLE"`` and ``str(status.state) == "IDLE"`` both hold,
    so code comparing with the plain strings keeps working."""

    IDLE = "IDLE"
    MOVING = "MOVING"
    HOMING = "HOMING"
    DISABLED = "DISABLED"
    ESTOP = "ESTOP"
    ERROR = "ERROR"
    DISCONNECTED = "DISCONNECTED"

    def __str__(self) -> str:
        return self.value


class Pose(NamedTuple):
    """Tool pose: x, y, z in mm; a, b, c in degrees with R = Rx(c) * Ry(b) * Rz(a)."""

    x: float
    y: float
    z: float
    a: float
    b: float
    c: float


class IOState(NamedTuple):
    """Digital IO.  ``estop_pressed`` is True when the hardware E-stop is pressed."""

    in1: bool
    in2: bool
    out1: bool
    out2: bool
    estop_pressed: bool


@dataclass(frozen=True)
class GripperState:
    """SSG-48 electric gripper telemetry.  position/speed 0..255, current in mA."""

    id: int = 0
    position: int = 0
    speed: int = 0
    current: int = 0
    status_byte: int = 0
    object_detection: int = 0

    @property
    def activated(self) -> bool:
        return bool(self.status_byte & 0x80)

    @property
    def calibrated(self) -> bool:
        return bool(self.status_byte & 0x01)

    @property
    def error(self) -> bool:
        """E-stop/error bit (0x02) of the status byte."""
        return bool(self.status_byte & 0x02)

    @property
    def object_code(self) -> int:
        """0 moving, 1 object found while closing, 2 while opening, 3 at position."""
        return ((self.status_byte >> 5) & 1) << 1 | ((self.status_byte >> 4) & 1)

    @property
    def object_detected(self) -> bool:
        return self.object_code in (1, 2)

    @property
    def temperature_error(self) -> bool:
        """Over-temperature bit (0x08) of the status byte."""
        return bool(self.status_byte & 0x08)

    @property
    def timeout_error(self) -> bool:
        """Timeout bit (0x04) of the status byte."""
        return bool(self.status_byte & 0x04)

    @property
    def any_error(self) -> bool:
        """Any of the E-stop (0x02), timeout (0x04) or temperature (0x08) bits: the
        controller's ``gripper.error`` status field."""
        return bool(self.status_byte & 0x0E)

    @property
    def status_text(self) -> str:
        """One-word summary for a readout: 'error' (:attr:`any_error`), 'calibrated',
        'active' or 'idle'."""
        if self.any_error:
            return "error"
        if self.calibrated:
            return "calibrated"
        if self.activated:
            return "active"
        return "idle"


# =============================================================================================
# from the decoded JSON of a reply to typed values (once, here; ReplyError names a bad field)
# =============================================================================================


def _number(value: object, name: str) -> float:
    # bool is an int: True/False read as 1/0, as float() always did here
    if isinstance(value, (int, float)):
        return float(value)
    raise ReplyError(f"{name} must be a number, got {value!r}")


def _f(d: Mapping[str, object], key: str, default: float = 0.0) -> float:
    v = d.get(key)
    return default if v is None else _number(v, key)


def _i(d: Mapping[str, object], key: str, default: int = 0) -> int:
    v = d.get(key)
    return default if v is None else int(_number(v, key))


def _opt_str(d: Mapping[str, object], key: str) -> str | None:
    """``d[key]`` as text; None when it is absent, null or empty."""
    v = d.get(key)
    return str(v) if v not in (None, "") else None


def _object(value: object, name: str) -> dict[str, object]:
    if not isinstance(value, dict):
        raise ReplyError(f"{name} must be a JSON object, got {value!r}")
    return value


def _sub(d: Mapping[str, object], key: str) -> dict[str, object]:
    """The JSON object ``d[key]`` ({} when absent or null)."""
    v = d.get(key)
    return {} if not v else _object(v, key)


def _list(value: object, name: str) -> list[object] | tuple[object, ...]:
    if not isinstance(value, (list, tuple)):
        raise ReplyError(f"{name} must be a list, got {value!r}")
    return value


@dataclass(frozen=True)
class LoopStats:
    """Control-loop statistics (periods and round trips in ms)."""

    rate_hz: float = 0.0
    ticks: int = 0
    period_p50_ms: float = 0.0
    period_p99_ms: float = 0.0
    period_max_ms: float = 0.0
    overruns: int = 0
    rtt_p50_ms: float = 0.0
    rtt_p99_ms: float = 0.0
    frames_sent: int = 0
    frames_received: int = 0
    bytes_dropped: int = 0
    #: the decoded JSON object (fields the controller did not report are absent)
    raw: dict[str, object] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> LoopStats:
        return cls(rate_hz=_f(d, "rate_hz"), ticks=_i(d, "ticks"),
                   period_p50_ms=_f(d, "period_p50_ms"), period_p99_ms=_f(d, "period_p99_ms"),
                   period_max_ms=_f(d, "period_max_ms"), overruns=_i(d, "overruns"),
                   rtt_p50_ms=_f(d, "rtt_p50_ms"), rtt_p99_ms=_f(d, "rtt_p99_ms"),
                   frames_sent=_i(d, "frames_sent"), frames_received=_i(d, "frames_received"),
                   bytes_dropped=_i(d, "bytes_dropped"), raw=dict(d))


@dataclass(frozen=True)
class BoardInfo:
    """The board link: ``timing_ms`` is the board's measured time between our last two frames."""

    connected: bool = False
    simulated: bool = False
    port: str = ""
    timing_ticks: int = 0
    timing_ms: float = 0.0
    xtr: int = 0

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> BoardInfo:
        return cls(connected=bool(d.get("connected", False)), simulated=bool(d.get("simulated", False)),
                   port=str(d.get("port") or ""), timing_ticks=_i(d, "timing_ticks"),
                   timing_ms=_f(d, "timing_ms"), xtr=_i(d, "xtr"))


@dataclass(frozen=True)
class ErrorInfo:
    """Error bits per joint and the latched error text (``message``; None when clear)."""

    temperature: tuple[bool, ...] = (False,) * 6
    position: tuple[bool, ...] = (False,) * 6
    timeout_error: int = 0
    message: str | None = None

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> ErrorInfo:
        return cls(temperature=tuple(bool(x) for x in _list(d.get("temperature", (False,) * 6), "temperature")),
                   position=tuple(bool(x) for x in _list(d.get("position", (False,) * 6), "position")),
                   timeout_error=_i(d, "timeout_error"), message=_opt_str(d, "message"))

    @property
    def any(self) -> bool:
        """True when any temperature/position bit is set or an error message is latched."""
        return any(self.temperature) or any(self.position) or bool(self.message)


@dataclass(frozen=True)
class ActiveCommand:
    """The command being executed: ``progress`` 0..1 where the controller reports it; for a
    servo stream, ``target``: the ID of the newest target the controller has taken (which of a
    client's targets it follows at that tick; None for other commands)."""

    id: str | None
    name: str
    progress: float | None = None
    target: str | None = None

    @classmethod
    def from_dict(cls, d: object) -> ActiveCommand | None:
        """None for null (no command); else the command object of a status or GET_QUEUE reply."""
        if not d:
            return None
        obj = _object(d, "command")
        p = obj.get("progress")
        return cls(id=_opt_str(obj, "id"), name=str(obj.get("name", "")),
                   progress=None if p is None else _number(p, "progress"), target=_opt_str(obj, "target"))


def _gripper_from_dict(d: Mapping[str, object]) -> GripperState:
    return GripperState(id=_i(d, "id"), position=_i(d, "position"), speed=_i(d, "speed"),
                        current=_i(d, "current"), status_byte=_i(d, "status"),
                        object_detection=_i(d, "object_detection"))


def _io_from_dict(d: Mapping[str, object]) -> IOState:
    return IOState(bool(d.get("in1", 0)), bool(d.get("in2", 0)), bool(d.get("out1", 0)),
                   bool(d.get("out2", 0)), not bool(d.get("estop", 1)))


@dataclass(frozen=True)
class RobotStatus:
    """One status snapshot (``GET_STATUS_JSON`` or the SUBSCRIBE stream).

    Angles in deg, pose in mm/deg, ``speeds`` in steps/s and ``speeds_deg_s`` in deg/s,
    ``time`` in s since the controller started.  ``raw`` is the decoded JSON object.
    """

    seq: int
    time: float
    state: RobotState
    enabled: bool
    homed: tuple[bool, ...]
    all_homed: bool
    estop_pressed: bool
    estop_latched: bool
    angles: tuple[float, ...]
    pose: Pose
    speeds: tuple[float, ...]
    speeds_deg_s: tuple[float, ...]
    io: IOState
    gripper: GripperState
    errors: ErrorInfo
    board: BoardInfo
    loop: LoopStats
    command: ActiveCommand | None
    queue: int
    stream_mode: bool
    tool: str
    plan_seq: int
    #: the speed override (%, SPEED) and whether motion is paused (PAUSE until RESUME)
    speed_pct: float = 100.0
    paused: bool = False
    #: PAUSE|QUEUE: nothing queued starts until RESUME (what runs goes on)
    queue_held: bool = False
    raw: dict[str, object] = field(default_factory=dict, repr=False, compare=False)

    @property
    def moving(self) -> bool:
        """True while a command runs or any joint speed is non-zero."""
        return self.command is not None or any(abs(s) > 0 for s in self.speeds)

    @property
    def can_move(self) -> bool:
        """True when motion commands can run: enabled, all joints homed, no E-stop (pressed
        or latched) and the state is not ERROR, ESTOP or DISCONNECTED."""
        return (self.enabled and self.all_homed and not self.estop_latched
                and not self.estop_pressed
                and self.state not in (RobotState.ERROR, RobotState.DISCONNECTED, RobotState.ESTOP))

    @classmethod
    def from_json(cls, obj: object) -> RobotStatus:
        """Build from the decoded status object; ``ReplyError`` names a missing or bad field
        (e.g. ``status: angles must be a list of 6 finite numbers, got [1, 2]``)."""
        if not isinstance(obj, dict):
            raise ReplyError(f"status: expected a JSON object, got {type(obj).__name__}")
        try:
            raw_state = obj["state"]
            try:
                state = RobotState(str(raw_state).upper())
            except ValueError:
                allowed = ", ".join(s.value for s in RobotState)
                raise ReplyError(f"state must be one of {allowed}, got {raw_state!r}") from None
            homed = _flags(obj.get("homed", (False,) * 6), "homed")
            return cls(
                seq=_i(obj, "seq"), time=_f(obj, "time"), state=state,
                enabled=bool(obj.get("enabled", False)), homed=homed,
                all_homed=bool(obj.get("all_homed", all(homed))),
                estop_pressed=bool(obj.get("estop_pressed", False)),
                estop_latched=bool(obj.get("estop_latched", False)),
                angles=_vector(obj["angles"], "angles"),
                pose=Pose(*_vector(obj.get("pose") or [0.0] * 6, "pose")),
                speeds=_vector(obj.get("speeds", (0.0,) * 6), "speeds"),
                speeds_deg_s=_vector(obj.get("speeds_deg_s", (0.0,) * 6), "speeds_deg_s"),
                io=_io_from_dict(_sub(obj, "io")),
                gripper=_gripper_from_dict(_sub(obj, "gripper")),
                errors=ErrorInfo.from_dict(_sub(obj, "errors")),
                board=BoardInfo.from_dict(_sub(obj, "board")),
                loop=LoopStats.from_dict(_sub(obj, "loop")),
                command=ActiveCommand.from_dict(obj.get("command")),
                queue=_i(obj, "queue"), stream_mode=bool(obj.get("stream_mode", False)),
                tool=str(obj.get("tool", "")), plan_seq=_i(obj, "plan_seq"),
                speed_pct=_f(obj, "speed_pct", 100.0),
                paused=bool(obj.get("paused", False)), queue_held=bool(obj.get("queue_held", False)), raw=obj,
            )
        except KeyError as exc:
            raise ReplyError(f"status: field {exc.args[0]!r} is missing") from None
        except ReplyError as exc:
            raise ReplyError(f"status: {exc}") from None
        except (TypeError, ValueError, AttributeError) as exc:
            raise ReplyError(f"status: malformed field ({exc})") from None


def _vector(value: object, name: str, n: int = 6) -> tuple[float, ...]:
    """``value`` as a tuple of ``n`` finite floats, else ReplyError naming ``name``."""
    if not (isinstance(value, (list, tuple)) and len(value) == n and all(
            not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) for v in value)):
        raise ReplyError(f"{name} must be a list of {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in value)


def _flags(value: object, name: str, n: int = 6) -> tuple[bool, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ReplyError(f"{name} must be a list of {n} booleans, got {value!r}")
    return tuple(bool(v) for v in value)


@dataclass(frozen=True)
class PlanInfo:
    """The active motion's plan: ``target_angles`` (deg) and ``tcp_path`` ([x, y, z] mm)."""

    seq: int
    command: str | None
    target_angles: tuple[float, ...] | None
    tcp_path: tuple[tuple[float, ...], ...]  # points [x, y, z] mm

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> PlanInfo:
        ta = d.get("target_angles")
        path = _list(d.get("tcp_path") or (), "tcp_path")
        return cls(seq=_i(d, "seq"), command=_opt_str(d, "command"),
                   target_angles=None if ta is None else tuple(
                       _number(a, "target_angles") for a in _list(ta, "target_angles")),
                   tcp_path=tuple(tuple(_number(v, "tcp_path") for v in _list(p, "tcp_path"))
                                  for p in path))


@dataclass(frozen=True)
class QueueInfo:
    """``active`` command and the ``queued`` ones as (id, name) pairs, oldest first."""

    active: ActiveCommand | None
    queued: tuple[tuple[str | None, str], ...]

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> QueueInfo:
        queued = [_object(q, "queued") for q in _list(d.get("queued") or (), "queued")]
        return cls(active=ActiveCommand.from_dict(d.get("active")),
                   queued=tuple((_opt_str(q, "id"), str(q.get("name", ""))) for q in queued))


@dataclass(frozen=True)
class ToolInfo:
    """The selected tool: name and TCP pose in the flange frame (mm / deg)."""

    name: str
    pose: tuple[float, ...]


def _point(value: object, name: str) -> tuple[float, float, float]:
    v = _vector(value, name, 3)
    return (v[0], v[1], v[2])


@dataclass(frozen=True)
class ZoneInfo:
    """A keep-out zone (GET_ZONES), base frame, mm / deg: ``kind`` "box" (``center``, ``size``
    edge lengths, ``rpy``), "plane" (``point``, ``normal`` out of the forbidden side) or
    "cylinder" (``center`` of its axis, ``axis``, ``radius``, ``height``); ``margin`` mm.
    The fields a kind does not have are None."""

    name: str
    kind: str
    margin: float
    center: tuple[float, float, float] | None = None
    size: tuple[float, float, float] | None = None
    rpy: tuple[float, float, float] | None = None
    point: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None
    axis: tuple[float, float, float] | None = None
    radius: float | None = None
    height: float | None = None

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> ZoneInfo:
        kind = str(d.get("kind", ""))
        keys = {"box": ("center", "size", "rpy"), "plane": ("point", "normal"),
                "cylinder": ("center", "axis")}.get(kind)
        if keys is None:
            raise ReplyError(f"zone kind must be box, plane or cylinder, got {kind!r}")
        vals: dict[str, object] = {k: _point(d.get(k), k) for k in keys}
        if kind == "cylinder":
            vals["radius"], vals["height"] = _number(d.get("radius"), "radius"), _number(d.get("height"), "height")
        return cls(name=str(d.get("name", "")), kind=kind, margin=_number(d.get("margin"), "margin"),
                   **vals)  # type: ignore[arg-type]


@dataclass(frozen=True)
class HeldInfo:
    """An object held at the flange (ATTACH), flange frame, mm: ``kind`` "sphere" (``start``
    = ``end`` = its centre) or "capsule" (its axis from ``start`` to ``end``); ``radius`` mm."""

    name: str
    kind: str
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float

    @property
    def center(self) -> tuple[float, float, float]:
        """A sphere's centre; a capsule's midpoint."""
        return (0.5 * (self.start[0] + self.end[0]), 0.5 * (self.start[1] + self.end[1]),
                0.5 * (self.start[2] + self.end[2]))

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> HeldInfo:
        kind = str(d.get("kind", ""))
        if kind == "sphere":
            c = _point(d.get("center"), "center")
            return cls(str(d.get("name", "")), kind, c, c, _number(d.get("radius"), "radius"))
        if kind == "capsule":
            return cls(str(d.get("name", "")), kind, _point(d.get("start"), "start"), _point(d.get("end"), "end"),
                       _number(d.get("radius"), "radius"))
        raise ReplyError(f"held object kind must be sphere or capsule, got {kind!r}")


@dataclass(frozen=True)
class ToolShapeInfo:
    """The tool's body: a capsule from ``start`` to ``end`` (mm, flange frame), ``radius`` mm."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float


@dataclass(frozen=True)
class ZonesInfo:
    """The controller's collision world (GET_ZONES, docs/protocol.md): the ``zones`` (base
    frame), the ``tool`` (its name) and its ``tool_shape`` (None: no body), the ``held``
    objects (flange frame), ``self_margin`` mm; ``seq`` changes whenever the world does (the
    status's ``collision.seq``), ``ready``: its collision check is ready."""

    seq: int
    ready: bool
    zones: tuple[ZoneInfo, ...]
    tool: str
    tool_shape: ToolShapeInfo | None
    held: tuple[HeldInfo, ...]
    self_margin: float = 0.0

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> ZonesInfo:
        tool = _object(d.get("tool"), "tool")
        shape = tool.get("shape")
        ts = None
        if shape is not None:
            sd = _object(shape, "tool shape")
            ts = ToolShapeInfo(_point(sd.get("start"), "start"), _point(sd.get("end"), "end"),
                               _number(sd.get("radius"), "radius"))
        try:
            zones = tuple(ZoneInfo.from_dict(_object(z, "zone")) for z in _list(d.get("zones") or (), "zones"))
            held = tuple(HeldInfo.from_dict(_object(h, "held")) for h in _list(d.get("held") or (), "held"))
            return cls(seq=_i(d, "seq"), ready=bool(d.get("ready", False)), zones=zones,
                       tool=str(tool.get("name", "")), tool_shape=ts, held=held, self_margin=_f(d, "self_margin"))
        except ReplyError as exc:
            raise ReplyError(f"ZONES: {exc}") from None


# =============================================================================================
# queries: request, reply tag and the parser of the reply's payload
# =============================================================================================


def _numbers(payload: str, count: int, what: str) -> tuple[float, ...]:
    try:
        return tuple(wire.parse_numbers(payload, count, what))
    except ValueError as exc:
        raise ReplyError(str(exc)) from None


def _json(payload: str, what: str) -> object:
    try:
        value: object = json.loads(payload)
    except ValueError as exc:
        raise ReplyError(f"{what}: invalid JSON ({exc})") from None
    return value


def _parse_angles(payload: str) -> tuple[float, ...]:
    return _numbers(payload, 6, "ANGLES")


def _parse_speeds(payload: str) -> tuple[float, ...]:
    return _numbers(payload, 6, "SPEEDS")


def _parse_pose_matrix(payload: str) -> tuple[tuple[float, ...], ...]:
    m = _numbers(payload, 16, "POSE")
    return (m[0:4], m[4:8], m[8:12], m[12:16])


def _parse_pose(payload: str) -> Pose:
    return Pose(*wire.matrix_to_pose(_numbers(payload, 16, "POSE")))


def _parse_io(payload: str) -> IOState:
    v = _numbers(payload, 5, "IO")
    return IOState(bool(v[0]), bool(v[1]), bool(v[2]), bool(v[3]), v[4] == 0)


def _parse_gripper(payload: str) -> GripperState:
    v = [int(x) for x in _numbers(payload, 6, "GRIPPER")]
    return GripperState(*v)


def _parse_status(payload: str) -> RobotStatus:
    return RobotStatus.from_json(_json(payload, "STATUS_JSON"))


def _parse_loop_stats(payload: str) -> LoopStats:
    return LoopStats.from_dict(_object(_json(payload, "LOOP_STATS"), "LOOP_STATS"))


def _parse_plan(payload: str) -> PlanInfo:
    return PlanInfo.from_dict(_object(_json(payload, "PLAN"), "PLAN"))


def _parse_queue(payload: str) -> QueueInfo:
    return QueueInfo.from_dict(_object(_json(payload, "QUEUE"), "QUEUE"))


def _parse_control(payload: str) -> ControlInfo:
    try:
        return wire.parse_control(payload)
    except ValueError as exc:
        raise ReplyError(str(exc)) from None


def _parse_tool(payload: str) -> ToolInfo:
    name, _, pose = payload.partition("|")
    return ToolInfo(name=name, pose=_numbers(pose, 6, "TOOL") if pose else (0.0,) * 6)


def _parse_zones(payload: str) -> ZonesInfo:
    return ZonesInfo.from_dict(_object(_json(payload, "ZONES"), "ZONES"))


def _parse_pong(payload: str) -> bool:
    return True


def _parse_link(payload: str) -> bool:
    """``SERIAL=`` of a GET_STATUS reply: True when the board link is up."""
    return wire.parse_status_fields(payload).get("SERIAL", "0").strip() == "1"


@dataclass(frozen=True)
class QuerySpec(Generic[_T]):
    """One query: its ``request`` datagram, the ``tag`` of its reply and the ``parse``r of the
    reply's payload into a ``_T``."""

    request: str
    tag: str
    parse: Callable[[str], _T]


class Queries:
    """Every query of the object API (``parse_query_reply(Queries.pose, text)`` is a Pose)."""

    angles: Final = QuerySpec("GET_ANGLES", "ANGLES", _parse_angles)
    pose: Final = QuerySpec("GET_POSE", "POSE", _parse_pose)
    pose_matrix: Final = QuerySpec("GET_POSE", "POSE", _parse_pose_matrix)
    io: Final = QuerySpec("GET_IO", "IO", _parse_io)
    gripper: Final = QuerySpec("GET_GRIPPER", "GRIPPER", _parse_gripper)
    speeds: Final = QuerySpec("GET_SPEEDS", "SPEEDS", _parse_speeds)
    status: Final = QuerySpec("GET_STATUS_JSON", "STATUS_JSON", _parse_status)
    loop_stats: Final = QuerySpec("GET_LOOP_STATS", "LOOP_STATS", _parse_loop_stats)
    plan_info: Final = QuerySpec("GET_PLAN", "PLAN", _parse_plan)
    queue: Final = QuerySpec("GET_QUEUE", "QUEUE", _parse_queue)
    control: Final = QuerySpec("GET_CONTROL", "CONTROL", _parse_control)
    tool: Final = QuerySpec("GET_TOOL", "TOOL", _parse_tool)
    zones: Final = QuerySpec("GET_ZONES", "ZONES", _parse_zones)
    # PING is answered with the bare word PONG (as the original controller did)
    ping: Final = QuerySpec("PING", "PONG", _parse_pong)
    link: Final = QuerySpec("GET_STATUS", "STATUS", _parse_link)


def parse_query_reply(query: QuerySpec[_T], text: str) -> _T:
    """Parse the reply to ``query``; ``ReplyError`` for ``ERROR|...`` or a malformed reply."""
    head, _, payload = text.partition("|")
    if head == "ERROR":
        raise ReplyError(f"{query.request}: controller answered ERROR: {payload}")
    if head != query.tag:
        raise ReplyError(f"{query.request}: expected a {query.tag}|... reply, got {text[:80]!r}")
    return query.parse(payload)

# =============================================================================================
# acknowledgements
# =============================================================================================


def command_name(body: str) -> str:
    """The command word of a datagram body (``MOVEJOINT|...`` -> ``MOVEJOINT``)."""
    return body.partition("|")[0].upper()


_ERRORS = {
    AckStatus.FAILED: CommandFailed,
    AckStatus.INVALID: CommandInvalid,
    AckStatus.CANCELLED: CommandCancelled,
}


def result_or_raise(cmd_id: str, command: str, status: AckStatus, details: str) -> CommandResult:
    """A :class:`CommandResult` for COMPLETED/QUEUED/EXECUTING; raise the matching
    :class:`~parolkit.client.errors.CommandNotCompleted` for FAILED, INVALID and CANCELLED."""
    exc = _ERRORS.get(status)
    if exc is not None:
        raise exc(cmd_id, command, status.value, details)
    return CommandResult(cmd_id, command, status, details)


@dataclass
class AckRecord:
    """Everything received for one command we sent."""

    id: str
    command: str
    sent_at: float
    history: list[tuple[AckStatus, str]] = field(default_factory=list)  # [(AckStatus, details), ...]
    #: the datagram's body as sent (without the ID)
    body: str = ""
    first_at: float | None = None
    terminal: tuple[AckStatus, str] | None = None

    @property
    def latest(self) -> tuple[AckStatus, str] | None:
        return self.history[-1] if self.history else None

    def result(self) -> CommandResult:
        """Result (terminal, or latest intermediate); raises the CommandNotCompleted subclass for failures."""
        status, details = self.terminal or self.latest or (AckStatus.QUEUED, "")
        return result_or_raise(self.id, self.command, status, details)


class AckBook:
    """Matches acks to the commands we sent (bounded history; not thread-safe by itself)."""

    def __init__(self, history: int = 2000) -> None:
        self._records: OrderedDict[str, AckRecord] = OrderedDict()
        self._history = history
        self.unmatched = 0

    def new(self, body: str) -> tuple[AckRecord, str]:
        """Register a command body; returns (record, datagram text with a fresh ID)."""
        cmd_id = wire.new_command_id()
        while cmd_id in self._records:
            cmd_id = wire.new_command_id()
        rec = AckRecord(cmd_id, command_name(body), time.monotonic(), body=body)
        self._records[cmd_id] = rec
        while len(self._records) > self._history:
            self._records.popitem(last=False)
        return rec, f"{cmd_id}|{body}"

    def get(self, cmd_id: str) -> AckRecord | None:
        return self._records.get(cmd_id)

    def newest(self, body: str) -> AckRecord | None:
        """The record of the newest command sent with exactly ``body``, or None."""
        for rec in reversed(list(self._records.values())):
            if rec.body == body:
                return rec
        return None

    def on_datagram(self, text: str) -> AckRecord | None:
        """Feed a received datagram; returns the record it added an ack to, or None (not an
        ack, somebody else's command, or a repeat after the command's terminal ack)."""
        ack = wire.parse_ack(text)
        if ack is None:
            return None
        cmd_id, status_text, details = ack
        rec = self._records.get(cmd_id)
        if rec is None:
            self.unmatched += 1
            return None
        try:
            status = AckStatus(status_text)
        except ValueError:
            status, details = AckStatus.FAILED, f"unknown ack status {status_text!r}: {details}"
        if rec.terminal is not None:
            return None  # exactly one terminal ack counts
        if rec.first_at is None:
            rec.first_at = time.monotonic()
        rec.history.append((status, details))
        if status.terminal:
            rec.terminal = (status, details)
        return rec


# =============================================================================================
# the method set shared by Robot and AsyncRobot
# =============================================================================================


def _check(build: Callable[..., str], *args: object) -> str:
    """Run a datagram builder, turning its ValueError into ParolkitValueError."""
    try:
        return build(*args)
    except ParolkitValueError:
        raise
    except ValueError as exc:
        raise ParolkitValueError(str(exc)) from None


#: a held object's name: as the controller's (1..64 characters: letters, digits, spaces, _ - .,
#: starting with a letter or digit)
_HELD_NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _.\-]{0,63}")


def _held_name(name: object) -> str:
    if not isinstance(name, str) or not _HELD_NAME_RE.fullmatch(name):
        raise ParolkitValueError(f"name must be 1..64 characters: letters, digits, spaces, '_', '-' or '.', "
                                 f"starting with a letter or digit, got {name!r}")
    return name


def _flange_point(value: object, name: str) -> str:
    """``x,y,z`` (mm, flange frame) for the wire; each within +-1000 mm."""
    try:
        v = wire._numbers(value, 3, name, " (x, y, z in mm, flange frame)")
    except ValueError as exc:
        raise ParolkitValueError(str(exc)) from None
    for axis, c in zip("xyz", v):
        if abs(c) > 1000.0:
            raise ParolkitValueError(f"{name}: {axis} = {c:g} mm is out of range [-1000, 1000] mm")
    return ",".join(wire.format_value(float(c)) for c in v)


def _held_radius(radius: object) -> str:
    try:
        r = wire._number(radius, "radius")
    except ValueError as exc:
        raise ParolkitValueError(str(exc)) from None
    if not 0.0 < r <= 500.0:
        raise ParolkitValueError(f"radius = {r:g} mm is out of range (0, 500] mm")
    return wire.format_value(float(r))


def _opt_timeout(timeout: float | None) -> float | None:
    if timeout is None:
        return None
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or \
            not math.isfinite(timeout) or timeout <= 0:
        raise ParolkitValueError(f"timeout must be a number of seconds > 0, got {timeout!r}")
    return float(timeout)


#: an on/off argument: True/False, 0/1, or the words on/off, high/low (any case)
OnOff: TypeAlias = bool | Literal[0, 1] | str


def _flag(value: object, name: str) -> bool:
    if isinstance(value, bool):
        return value
    if value in (0, 1):
        return bool(value)
    if isinstance(value, str) and value.strip().upper() in ("ON", "OFF", "HIGH", "LOW"):
        return value.strip().upper() in ("ON", "HIGH")
    raise ParolkitValueError(f"{name} must be True/False, 0/1, 'on'/'off' or 'high'/'low', got {value!r}")


class RobotCommands(Generic[_Result, _Handle]):
    """Every command and query of the object API, written once.

    ``_Result`` is what a waited command gives and ``_Handle`` what ``wait=False`` gives:
    :class:`~parolkit.client.robot.Robot` is ``RobotCommands[CommandResult, CommandHandle]``,
    :class:`~parolkit.client.async_robot.AsyncRobot` is
    ``RobotCommands[AsyncResult[CommandResult], AsyncResult[AsyncCommandHandle]]`` (each
    method is awaited there).  Subclasses implement ``_run`` (send, wait for the terminal ack),
    ``_start`` (send, wait for the first ack, return a handle) and ``_query``.

    ``wait=True`` (default for motion): return the :class:`CommandResult` once the command
    COMPLETED; raise :class:`~parolkit.client.errors.CommandFailed` / ``CommandInvalid`` /
    ``CommandCancelled`` with the controller's reason, or ``CommandTimeout`` after
    ``timeout`` s (``None``: no limit while the controller keeps answering).
    ``wait=False``: return a handle as soon as the controller accepted the command (its
    first ack); ``CommandInvalid`` is still raised at once for a refused command.  A literal
    ``wait=True``/``wait=False`` selects the return type for type checkers; a ``bool``
    variable gives the union.
    """

    def _run(self, body: str, timeout: float | None) -> _Result:  # pragma: no cover
        raise NotImplementedError

    def _start(self, body: str, timeout: float | None) -> _Handle:  # pragma: no cover
        raise NotImplementedError

    def _query(self, query: QuerySpec[_T]) -> _T | AsyncResult[_T]:  # pragma: no cover
        raise NotImplementedError

    def _command(self, body: str, wait: bool, timeout: float | None) -> _Result | _Handle:
        t = _opt_timeout(timeout)
        return self._run(body, t) if wait else self._start(body, t)

    # ---- motion ----
    @overload
    def move_joints(self, angles: Sequence[float], duration: float | None = None,
                    speed: float | None = None, accel: float | None = None,
                    profile: str | None = None, tracking: str | None = None,
                    wait: Literal[True] = True, timeout: float | None = None, *,
                    blend: float | None = None) -> _Result: ...
    @overload
    def move_joints(self, angles: Sequence[float], duration: float | None = None,
                    speed: float | None = None, accel: float | None = None,
                    profile: str | None = None, tracking: str | None = None, *,
                    wait: Literal[False], timeout: float | None = None,
                    blend: float | None = None) -> _Handle: ...
    @overload
    def move_joints(self, angles: Sequence[float], duration: float | None = None,
                    speed: float | None = None, accel: float | None = None,
                    profile: str | None = None, tracking: str | None = None, wait: bool = True,
                    timeout: float | None = None, *, blend: float | None = None) -> _Result | _Handle: ...

    def move_joints(self, angles: Sequence[float], duration: float | None = None,
                    speed: float | None = None, accel: float | None = None,
                    profile: str | None = None, tracking: str | None = None, wait: bool = True,
                    timeout: float | None = None, *, blend: float | None = None) -> _Result | _Handle:
        """Joint-space move to ``angles`` (deg) in ``duration`` s or at ``speed`` % (one of the
        two); ``accel`` %, ``profile`` poly|trap|ruckig|toppra, ``tracking`` position|speed;
        ``blend`` (deg, 0..100): round the corner into the next queued joint-space move within
        that distance, so the arm does not stop at ``angles`` (None or 0: it stops there)."""
        body = _check(wire.build_move_joint, angles, duration, speed, accel, profile, tracking, blend)
        return self._command(body, wait, timeout)

    @overload
    def move_pose(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, accel: float | None = None,
                  profile: str | None = None, tracking: str | None = None,
                  wait: Literal[True] = True, timeout: float | None = None, *,
                  blend: float | None = None) -> _Result: ...
    @overload
    def move_pose(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, accel: float | None = None,
                  profile: str | None = None, tracking: str | None = None, *, wait: Literal[False],
                  timeout: float | None = None, blend: float | None = None) -> _Handle: ...
    @overload
    def move_pose(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, accel: float | None = None,
                  profile: str | None = None, tracking: str | None = None, wait: bool = True,
                  timeout: float | None = None, *, blend: float | None = None) -> _Result | _Handle: ...

    def move_pose(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, accel: float | None = None,
                  profile: str | None = None, tracking: str | None = None, wait: bool = True,
                  timeout: float | None = None, *, blend: float | None = None) -> _Result | _Handle:
        """Move to ``pose`` [x, y, z, A, B, C] (mm, deg) via IK along a joint-space path;
        ``blend`` (deg, 0..100) as :meth:`move_joints`'s."""
        body = _check(wire.build_move_pose, pose, duration, speed, accel, profile, tracking, blend)
        return self._command(body, wait, timeout)

    @overload
    def move_cart(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, profile: str | None = None,
                  tracking: str | None = None, wait: Literal[True] = True,
                  timeout: float | None = None, *, blend: float | None = None) -> _Result: ...
    @overload
    def move_cart(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, profile: str | None = None,
                  tracking: str | None = None, *, wait: Literal[False],
                  timeout: float | None = None, blend: float | None = None) -> _Handle: ...
    @overload
    def move_cart(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, profile: str | None = None,
                  tracking: str | None = None, wait: bool = True,
                  timeout: float | None = None, *, blend: float | None = None) -> _Result | _Handle: ...

    def move_cart(self, pose: Sequence[float], duration: float | None = None,
                  speed: float | None = None, profile: str | None = None,
                  tracking: str | None = None, wait: bool = True,
                  timeout: float | None = None, *, blend: float | None = None) -> _Result | _Handle:
        """Straight-line move to ``pose`` [x, y, z, A, B, C] (mm, deg); ``blend`` (mm, 0..100):
        round the corner into the next queued straight-line move within that distance of
        ``pose``, so the arm does not stop there (None or 0: it stops there)."""
        body = _check(wire.build_move_cart, pose, duration, speed, profile, tracking, blend)
        return self._command(body, wait, timeout)

    @overload
    def move_cart_rel_trf(self, delta: Sequence[float], duration: float | None = None,
                          speed: float | None = None, profile: str | None = None,
                          tracking: str | None = None, wait: Literal[True] = True,
                          timeout: float | None = None) -> _Result: ...
    @overload
    def move_cart_rel_trf(self, delta: Sequence[float], duration: float | None = None,
                          speed: float | None = None, profile: str | None = None,
                          tracking: str | None = None, *, wait: Literal[False],
                          timeout: float | None = None) -> _Handle: ...
    @overload
    def move_cart_rel_trf(self, delta: Sequence[float], duration: float | None = None,
                          speed: float | None = None, profile: str | None = None,
                          tracking: str | None = None, wait: bool = True,
                          timeout: float | None = None) -> _Result | _Handle: ...

    def move_cart_rel_trf(self, delta: Sequence[float], duration: float | None = None,
                          speed: float | None = None, profile: str | None = None,
                          tracking: str | None = None, wait: bool = True,
                          timeout: float | None = None) -> _Result | _Handle:
        """Relative straight-line move in the tool frame [dx, dy, dz, dA, dB, dC] (mm, deg)."""
        body = _check(wire.build_move_cart_rel_trf, delta, duration, speed, profile, tracking)
        return self._command(body, wait, timeout)

    @overload
    def jog_joint(self, joint: int, speed: float, duration: float | None = None,
                  distance: float | None = None, wait: Literal[False] = False,
                  timeout: float | None = None) -> _Handle: ...
    @overload
    def jog_joint(self, joint: int, speed: float, duration: float | None = None,
                  distance: float | None = None, *, wait: Literal[True],
                  timeout: float | None = None) -> _Result: ...
    @overload
    def jog_joint(self, joint: int, speed: float, duration: float | None = None,
                  distance: float | None = None, wait: bool = False,
                  timeout: float | None = None) -> _Result | _Handle: ...

    def jog_joint(self, joint: int, speed: float, duration: float | None = None,
                  distance: float | None = None, wait: bool = False,
                  timeout: float | None = None) -> _Result | _Handle:
        """Jog joint ``joint`` (1..6; negative -1..-6 for the negative direction) at ``speed``
        % of its jog speed for ``duration`` s and/or ``distance`` deg."""
        body = _check(wire.build_jog, _jog_index(joint), speed, duration, distance)
        return self._command(body, wait, timeout)

    @overload
    def jog_multiple(self, joints: Sequence[int], speeds: Sequence[float], duration: float,
                     wait: Literal[False] = False, timeout: float | None = None) -> _Handle: ...
    @overload
    def jog_multiple(self, joints: Sequence[int], speeds: Sequence[float], duration: float,
                     wait: Literal[True], timeout: float | None = None) -> _Result: ...
    @overload
    def jog_multiple(self, joints: Sequence[int], speeds: Sequence[float], duration: float,
                     wait: bool = False, timeout: float | None = None) -> _Result | _Handle: ...

    def jog_multiple(self, joints: Sequence[int], speeds: Sequence[float], duration: float,
                     wait: bool = False, timeout: float | None = None) -> _Result | _Handle:
        """Jog several joints (1..6 positive, -1..-6 negative) at ``speeds`` % for ``duration`` s."""
        body = _check(wire.build_multijog, _jog_indices(joints), speeds, duration)
        return self._command(body, wait, timeout)

    @overload
    def jog_cartesian(self, frame: str, axis: str, speed: float, duration: float,
                      wait: Literal[False] = False, timeout: float | None = None) -> _Handle: ...
    @overload
    def jog_cartesian(self, frame: str, axis: str, speed: float, duration: float,
                      wait: Literal[True], timeout: float | None = None) -> _Result: ...
    @overload
    def jog_cartesian(self, frame: str, axis: str, speed: float, duration: float,
                      wait: bool = False, timeout: float | None = None) -> _Result | _Handle: ...

    def jog_cartesian(self, frame: str, axis: str, speed: float, duration: float,
                      wait: bool = False, timeout: float | None = None) -> _Result | _Handle:
        """Cartesian jog in ``frame`` WRF|TRF along/about ``axis`` X+ ... RZ- at ``speed`` %."""
        body = _check(wire.build_cartjog, frame, axis, speed, duration)
        return self._command(body, wait, timeout)

    @overload
    def speed_joint(self, speeds_deg_s: Sequence[float], duration: float,
                    wait: Literal[True] = True, timeout: float | None = None) -> _Result: ...
    @overload
    def speed_joint(self, speeds_deg_s: Sequence[float], duration: float, wait: Literal[False],
                    timeout: float | None = None) -> _Handle: ...
    @overload
    def speed_joint(self, speeds_deg_s: Sequence[float], duration: float, wait: bool = True,
                    timeout: float | None = None) -> _Result | _Handle: ...

    def speed_joint(self, speeds_deg_s: Sequence[float], duration: float, wait: bool = True,
                    timeout: float | None = None) -> _Result | _Handle:
        """Run the joints at constant ``speeds_deg_s`` (deg/s) for ``duration`` s."""
        body = _check(wire.build_speed_joint, speeds_deg_s, duration)
        return self._command(body, wait, timeout)

    @overload
    def move_joint_path(self, points: Sequence[Sequence[float]], times: Sequence[float],
                        velocities: Sequence[Sequence[float]] | None = None,
                        wait: Literal[True] = True, timeout: float | None = None) -> _Result: ...
    @overload
    def move_joint_path(self, points: Sequence[Sequence[float]], times: Sequence[float],
                        velocities: Sequence[Sequence[float]] | None = None, *,
                        wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def move_joint_path(self, points: Sequence[Sequence[float]], times: Sequence[float],
                        velocities: Sequence[Sequence[float]] | None = None, wait: bool = True,
                        timeout: float | None = None) -> _Result | _Handle: ...

    def move_joint_path(self, points: Sequence[Sequence[float]], times: Sequence[float],
                        velocities: Sequence[Sequence[float]] | None = None, wait: bool = True,
                        timeout: float | None = None) -> _Result | _Handle:
        """Pass through ``points`` (each J1..J6 in deg) at ``times`` (s from the start, > 0 and
        increasing) as ONE trajectory from where the previous command ends, at rest at both
        ends; ``velocities`` (deg/s per point, the last zeros) or None for the controller's C2
        spline.  Each point is commanded on tick ``round(time * rate)`` (``MOVEJOINTPATH``)."""
        body = _check(wire.build_move_joint_path, points, times, velocities)
        return self._command(body, wait, timeout)

    @overload
    def home(self, wait: Literal[True] = True, timeout: float | None = None) -> _Result: ...
    @overload
    def home(self, wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def home(self, wait: bool = True, timeout: float | None = None) -> _Result | _Handle: ...

    def home(self, wait: bool = True, timeout: float | None = None) -> _Result | _Handle:
        """Run the board's homing sequence (completes when every joint is homed)."""
        return self._command(wire.build_home(), wait, timeout)

    @overload
    def delay(self, seconds: float, wait: Literal[True] = True,
              timeout: float | None = None) -> _Result: ...
    @overload
    def delay(self, seconds: float, wait: Literal[False],
              timeout: float | None = None) -> _Handle: ...
    @overload
    def delay(self, seconds: float, wait: bool = True,
              timeout: float | None = None) -> _Result | _Handle: ...

    def delay(self, seconds: float, wait: bool = True,
              timeout: float | None = None) -> _Result | _Handle:
        """Queue a pause of ``seconds``."""
        body = _check(wire.build_delay, seconds)
        return self._command(body, wait, timeout)

    @overload
    def wait_input(self, input_number: int, state: OnOff, input_timeout: float | None = None,
                   wait: Literal[True] = True, timeout: float | None = None) -> _Result: ...
    @overload
    def wait_input(self, input_number: int, state: OnOff, input_timeout: float | None = None, *,
                   wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def wait_input(self, input_number: int, state: OnOff, input_timeout: float | None = None,
                   wait: bool = True, timeout: float | None = None) -> _Result | _Handle: ...

    def wait_input(self, input_number: int, state: OnOff, input_timeout: float | None = None,
                   wait: bool = True, timeout: float | None = None) -> _Result | _Handle:
        """Queue a wait until IN``input_number`` (1|2) equals ``state``; the command FAILS
        (``CommandFailed``) when ``input_timeout`` s pass first."""
        body = _check(wire.build_wait_input, input_number, 1 if _flag(state, "state") else 0,
                      input_timeout)
        return self._command(body, wait, timeout)

    @overload
    def set_output(self, output: int, state: OnOff, wait: Literal[True] = True,
                   timeout: float | None = None) -> _Result: ...
    @overload
    def set_output(self, output: int, state: OnOff, wait: Literal[False],
                   timeout: float | None = None) -> _Handle: ...
    @overload
    def set_output(self, output: int, state: OnOff, wait: bool = True,
                   timeout: float | None = None) -> _Result | _Handle: ...

    def set_output(self, output: int, state: OnOff, wait: bool = True,
                   timeout: float | None = None) -> _Result | _Handle:
        """Set OUT1/OUT2 (``output`` 1|2) high (True) or low (False); queued like a move."""
        body = _check(wire.build_pneumatic_gripper, "open" if _flag(state, "state") else "close",
                      output)
        return self._command(body, wait, timeout)

    @overload
    def pneumatic(self, action: str, port: int, wait: Literal[True] = True,
                  timeout: float | None = None) -> _Result: ...
    @overload
    def pneumatic(self, action: str, port: int, wait: Literal[False],
                  timeout: float | None = None) -> _Handle: ...
    @overload
    def pneumatic(self, action: str, port: int, wait: bool = True,
                  timeout: float | None = None) -> _Result | _Handle: ...

    def pneumatic(self, action: str, port: int, wait: bool = True,
                  timeout: float | None = None) -> _Result | _Handle:
        """Pneumatic gripper ``action`` open|close on output ``port`` 1|2."""
        body = _check(wire.build_pneumatic_gripper, action, port)
        return self._command(body, wait, timeout)

    @overload
    def gripper_move(self, position: int, speed: int = 150, current: int = 500,
                     wait: Literal[True] = True, timeout: float | None = None) -> _Result: ...
    @overload
    def gripper_move(self, position: int, speed: int = 150, current: int = 500, *,
                     wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def gripper_move(self, position: int, speed: int = 150, current: int = 500, wait: bool = True,
                     timeout: float | None = None) -> _Result | _Handle: ...

    def gripper_move(self, position: int, speed: int = 150, current: int = 500, wait: bool = True,
                     timeout: float | None = None) -> _Result | _Handle:
        """SSG-48: move to ``position`` 0..255 at ``speed`` 0..255 with ``current`` 0..1300 mA."""
        body = _check(wire.build_electric_gripper, "move", position, speed, current)
        return self._command(body, wait, timeout)

    @overload
    def gripper_calibrate(self, wait: Literal[True] = True,
                          timeout: float | None = None) -> _Result: ...
    @overload
    def gripper_calibrate(self, wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def gripper_calibrate(self, wait: bool = True,
                          timeout: float | None = None) -> _Result | _Handle: ...

    def gripper_calibrate(self, wait: bool = True,
                          timeout: float | None = None) -> _Result | _Handle:
        """SSG-48: calibrate and activate."""
        body = _check(wire.build_electric_gripper, "calibrate")
        return self._command(body, wait, timeout)

    @overload
    def gripper_clear_error(self, wait: Literal[True] = True,
                            timeout: float | None = None) -> _Result: ...
    @overload
    def gripper_clear_error(self, wait: Literal[False],
                            timeout: float | None = None) -> _Handle: ...
    @overload
    def gripper_clear_error(self, wait: bool = True,
                            timeout: float | None = None) -> _Result | _Handle: ...

    def gripper_clear_error(self, wait: bool = True,
                            timeout: float | None = None) -> _Result | _Handle:
        """SSG-48: clear a gripper error."""
        body = _check(wire.build_electric_gripper, "clear_error")
        return self._command(body, wait, timeout)

    @overload
    def smooth_circle(self, center: Sequence[float], radius: float, plane: str = "XY",
                      frame: str = "WRF", start_pose: Sequence[float] | None = None,
                      duration: float | None = None, speed: float | None = None,
                      clockwise: bool = False, wait: Literal[True] = True,
                      timeout: float | None = None) -> _Result: ...
    @overload
    def smooth_circle(self, center: Sequence[float], radius: float, plane: str = "XY",
                      frame: str = "WRF", start_pose: Sequence[float] | None = None,
                      duration: float | None = None, speed: float | None = None,
                      clockwise: bool = False, *, wait: Literal[False],
                      timeout: float | None = None) -> _Handle: ...
    @overload
    def smooth_circle(self, center: Sequence[float], radius: float, plane: str = "XY",
                      frame: str = "WRF", start_pose: Sequence[float] | None = None,
                      duration: float | None = None, speed: float | None = None,
                      clockwise: bool = False, wait: bool = True,
                      timeout: float | None = None) -> _Result | _Handle: ...

    def smooth_circle(self, center: Sequence[float], radius: float, plane: str = "XY",
                      frame: str = "WRF", start_pose: Sequence[float] | None = None,
                      duration: float | None = None, speed: float | None = None,
                      clockwise: bool = False, wait: bool = True,
                      timeout: float | None = None) -> _Result | _Handle:
        """Full circle of ``radius`` mm about ``center`` [x, y, z] mm in ``plane``."""
        body = _check(wire.build_smooth_circle, center, radius, plane, frame, start_pose, duration,
                      speed, clockwise)
        return self._command(body, wait, timeout)

    @overload
    def smooth_arc_center(self, end_pose: Sequence[float], center: Sequence[float],
                          frame: str = "WRF", start_pose: Sequence[float] | None = None,
                          duration: float | None = None, speed: float | None = None,
                          clockwise: bool = False, wait: Literal[True] = True,
                          timeout: float | None = None) -> _Result: ...
    @overload
    def smooth_arc_center(self, end_pose: Sequence[float], center: Sequence[float],
                          frame: str = "WRF", start_pose: Sequence[float] | None = None,
                          duration: float | None = None, speed: float | None = None,
                          clockwise: bool = False, *, wait: Literal[False],
                          timeout: float | None = None) -> _Handle: ...
    @overload
    def smooth_arc_center(self, end_pose: Sequence[float], center: Sequence[float],
                          frame: str = "WRF", start_pose: Sequence[float] | None = None,
                          duration: float | None = None, speed: float | None = None,
                          clockwise: bool = False, wait: bool = True,
                          timeout: float | None = None) -> _Result | _Handle: ...

    def smooth_arc_center(self, end_pose: Sequence[float], center: Sequence[float],
                          frame: str = "WRF", start_pose: Sequence[float] | None = None,
                          duration: float | None = None, speed: float | None = None,
                          clockwise: bool = False, wait: bool = True,
                          timeout: float | None = None) -> _Result | _Handle:
        """Arc to ``end_pose`` about ``center``."""
        body = _check(wire.build_smooth_arc_center, end_pose, center, frame, start_pose, duration,
                      speed, clockwise)
        return self._command(body, wait, timeout)

    @overload
    def smooth_arc_param(self, end_pose: Sequence[float], radius: float, arc_angle: float,
                         frame: str = "WRF", start_pose: Sequence[float] | None = None,
                         duration: float | None = None, speed: float | None = None,
                         clockwise: bool = False, wait: Literal[True] = True,
                         timeout: float | None = None) -> _Result: ...
    @overload
    def smooth_arc_param(self, end_pose: Sequence[float], radius: float, arc_angle: float,
                         frame: str = "WRF", start_pose: Sequence[float] | None = None,
                         duration: float | None = None, speed: float | None = None,
                         clockwise: bool = False, *, wait: Literal[False],
                         timeout: float | None = None) -> _Handle: ...
    @overload
    def smooth_arc_param(self, end_pose: Sequence[float], radius: float, arc_angle: float,
                         frame: str = "WRF", start_pose: Sequence[float] | None = None,
                         duration: float | None = None, speed: float | None = None,
                         clockwise: bool = False, wait: bool = True,
                         timeout: float | None = None) -> _Result | _Handle: ...

    def smooth_arc_param(self, end_pose: Sequence[float], radius: float, arc_angle: float,
                         frame: str = "WRF", start_pose: Sequence[float] | None = None,
                         duration: float | None = None, speed: float | None = None,
                         clockwise: bool = False, wait: bool = True,
                         timeout: float | None = None) -> _Result | _Handle:
        """Arc to ``end_pose`` with ``radius`` mm over ``arc_angle`` deg."""
        body = _check(wire.build_smooth_arc_param, end_pose, radius, arc_angle, frame, start_pose,
                      duration, speed, clockwise)
        return self._command(body, wait, timeout)

    @overload
    def smooth_spline(self, waypoints: Sequence[Sequence[float]], frame: str = "WRF",
                      start_pose: Sequence[float] | None = None, duration: float | None = None,
                      speed: float | None = None, wait: Literal[True] = True,
                      timeout: float | None = None) -> _Result: ...
    @overload
    def smooth_spline(self, waypoints: Sequence[Sequence[float]], frame: str = "WRF",
                      start_pose: Sequence[float] | None = None, duration: float | None = None,
                      speed: float | None = None, *, wait: Literal[False],
                      timeout: float | None = None) -> _Handle: ...
    @overload
    def smooth_spline(self, waypoints: Sequence[Sequence[float]], frame: str = "WRF",
                      start_pose: Sequence[float] | None = None, duration: float | None = None,
                      speed: float | None = None, wait: bool = True,
                      timeout: float | None = None) -> _Result | _Handle: ...

    def smooth_spline(self, waypoints: Sequence[Sequence[float]], frame: str = "WRF",
                      start_pose: Sequence[float] | None = None, duration: float | None = None,
                      speed: float | None = None, wait: bool = True,
                      timeout: float | None = None) -> _Result | _Handle:
        """Cubic spline through ``waypoints`` (poses)."""
        body = _check(wire.build_smooth_spline, waypoints, frame, start_pose, duration, speed)
        return self._command(body, wait, timeout)

    @overload
    def smooth_helix(self, center: Sequence[float], radius: float, pitch: float, height: float,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None,
                     clockwise: bool = False, wait: Literal[True] = True,
                     timeout: float | None = None) -> _Result: ...
    @overload
    def smooth_helix(self, center: Sequence[float], radius: float, pitch: float, height: float,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None,
                     clockwise: bool = False, *, wait: Literal[False],
                     timeout: float | None = None) -> _Handle: ...
    @overload
    def smooth_helix(self, center: Sequence[float], radius: float, pitch: float, height: float,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None,
                     clockwise: bool = False, wait: bool = True,
                     timeout: float | None = None) -> _Result | _Handle: ...

    def smooth_helix(self, center: Sequence[float], radius: float, pitch: float, height: float,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None,
                     clockwise: bool = False, wait: bool = True,
                     timeout: float | None = None) -> _Result | _Handle:
        """Helix about ``center``: ``radius``, ``pitch`` per turn, total ``height`` (mm)."""
        body = _check(wire.build_smooth_helix, center, radius, pitch, height, frame, start_pose,
                      duration, speed, clockwise)
        return self._command(body, wait, timeout)

    @overload
    def smooth_blend(self, segments: Sequence[Mapping[str, object]], blend_time: float = 0.5,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None,
                     wait: Literal[True] = True, timeout: float | None = None) -> _Result: ...
    @overload
    def smooth_blend(self, segments: Sequence[Mapping[str, object]], blend_time: float = 0.5,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None, *,
                     wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def smooth_blend(self, segments: Sequence[Mapping[str, object]], blend_time: float = 0.5,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None, wait: bool = True,
                     timeout: float | None = None) -> _Result | _Handle: ...

    def smooth_blend(self, segments: Sequence[Mapping[str, object]], blend_time: float = 0.5,
                     frame: str = "WRF", start_pose: Sequence[float] | None = None,
                     duration: float | None = None, speed: float | None = None, wait: bool = True,
                     timeout: float | None = None) -> _Result | _Handle:
        """Blend LINE/CIRCLE/ARC/SPLINE segment dicts into one path (see robot_api)."""
        body = _check(wire.build_smooth_blend, segments, blend_time, frame, start_pose, duration,
                      speed)
        return self._command(body, wait, timeout)

    @overload
    def checkpoint(self, label: str, wait: Literal[True] = True,
                   timeout: float | None = None) -> _Result: ...
    @overload
    def checkpoint(self, label: str, wait: Literal[False],
                   timeout: float | None = None) -> _Handle: ...
    @overload
    def checkpoint(self, label: str, wait: bool = True,
                   timeout: float | None = None) -> _Result | _Handle: ...

    def checkpoint(self, label: str, wait: bool = True,
                   timeout: float | None = None) -> _Result | _Handle:
        """Queue a checkpoint ``label`` (1..64 characters of ``[A-Za-z0-9_.:-]``): it completes
        when the queue reaches it, i.e. when everything sent before it has ended.  With
        ``wait=False`` continue at once and wait later with :meth:`wait_checkpoint`."""
        body = _check(wire.build_checkpoint, label)
        return self._command(body, wait, timeout)

    # ---- the collision world: what the arm holds ----
    @overload
    def attach_sphere(self, name: str, center: Sequence[float], radius: float, wait: Literal[True] = True,
                      timeout: float | None = None) -> _Result: ...
    @overload
    def attach_sphere(self, name: str, center: Sequence[float], radius: float, wait: Literal[False],
                      timeout: float | None = None) -> _Handle: ...
    @overload
    def attach_sphere(self, name: str, center: Sequence[float], radius: float, wait: bool = True,
                      timeout: float | None = None) -> _Result | _Handle: ...

    def attach_sphere(self, name: str, center: Sequence[float], radius: float, wait: bool = True,
                      timeout: float | None = None) -> _Result | _Handle:
        """The arm holds a ball of ``radius`` mm centred at ``center`` [x, y, z] mm of the flange
        frame (``ATTACH|name|SPHERE|...``): from when the queue reaches it, every motion is
        checked for collisions with it (against the zones and the arm).  One of the same
        ``name`` is replaced.  Queued in order with the moves; see docs/collision.md."""
        body = f"ATTACH|{_held_name(name)}|SPHERE|{_flange_point(center, 'center')}|{_held_radius(radius)}"
        return self._command(body, wait, timeout)

    @overload
    def attach_capsule(self, name: str, start: Sequence[float], end: Sequence[float], radius: float,
                       wait: Literal[True] = True, timeout: float | None = None) -> _Result: ...
    @overload
    def attach_capsule(self, name: str, start: Sequence[float], end: Sequence[float], radius: float,
                       wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def attach_capsule(self, name: str, start: Sequence[float], end: Sequence[float], radius: float,
                       wait: bool = True, timeout: float | None = None) -> _Result | _Handle: ...

    def attach_capsule(self, name: str, start: Sequence[float], end: Sequence[float], radius: float,
                       wait: bool = True, timeout: float | None = None) -> _Result | _Handle:
        """The arm holds a capsule of ``radius`` mm around the segment ``start`` -> ``end``
        ([x, y, z] mm of the flange frame; ``ATTACH|name|CAPSULE|...``), as
        :meth:`attach_sphere`.  A box-shaped part: the capsule that encloses it."""
        body = (f"ATTACH|{_held_name(name)}|CAPSULE|{_flange_point(start, 'start')}|{_flange_point(end, 'end')}|"
                f"{_held_radius(radius)}")
        return self._command(body, wait, timeout)

    @overload
    def detach(self, name: str | None = None, wait: Literal[True] = True,
               timeout: float | None = None) -> _Result: ...
    @overload
    def detach(self, name: str | None, wait: Literal[False], timeout: float | None = None) -> _Handle: ...
    @overload
    def detach(self, name: str | None = None, wait: bool = True,
               timeout: float | None = None) -> _Result | _Handle: ...

    def detach(self, name: str | None = None, wait: bool = True,
               timeout: float | None = None) -> _Result | _Handle:
        """The arm lets go of the held object ``name`` (None: of every one; ``DETACH``), in order
        with the moves; CommandFailed when nothing of that name is held then."""
        body = "DETACH" if name is None else f"DETACH|{_held_name(name)}"
        return self._command(body, wait, timeout)

    # ---- servo streams: fire and forget ----
    def _send(self, text: str) -> None:  # pragma: no cover
        raise NotImplementedError

    def servo_j(self, angles: Sequence[float]) -> None:
        """Stream a servo target, joint angles in deg (``SERVOJ``): the latest wins; an online
        jerk-limited generator moves the joints toward it within their limits from the
        controller's next frame.  Send targets at the control rate or faster: without one for
        ``servo.timeout_s`` (0.05 s) the arm makes a controlled stop and the stream ends.  Fire
        and forget (no ack; a stream that cannot start, not homed or busy, shows in
        :meth:`status`: no command runs)."""
        self._send(_check(wire.build_servo_j, angles))

    def servo_l(self, pose: Sequence[float], frame: str = "WRF") -> None:
        """Stream a servo target pose ``[x, y, z mm, A, B, C deg]`` of the TCP (``SERVOL``), in
        the world frame, or with ``frame="TRF"`` relative to the TCP pose where the stream
        started (offsets in its tool frame); as :meth:`servo_j`."""
        self._send(_check(wire.build_servo_l, pose, frame))

    # ---- immediate control ----
    def set_speed(self, percent: float, timeout: float | None = None) -> _Result:
        """The speed override, 1..100 % of every planned speed: the running move slows down or
        speeds up on its own path within the acceleration limits, and every later move runs so,
        until changed (``SPEED``)."""
        return self._run(_check(wire.build_speed, percent), _opt_timeout(timeout))

    def pause(self, timeout: float | None = None, *, queue_only: bool = False) -> _Result:
        """The running move slows down on its own path (within the acceleration limits) and
        holds; nothing queued starts until :meth:`resume`.  :meth:`stop` cancels it all.
        ``queue_only``: the running command goes on to its end, only the queue waits
        (``PAUSE|QUEUE``)."""
        return self._run("PAUSE|QUEUE" if _flag(queue_only, "queue_only") else "PAUSE", _opt_timeout(timeout))

    def resume(self, timeout: float | None = None, *, one: bool = False) -> _Result:
        """A paused move continues on the same path to the same target; the queue runs again.
        ``one`` (``RESUME|ONE``): the move goes on, but the queue is held (as by
        ``pause(queue_only=True)``) and lets one more command start."""
        return self._run("RESUME|ONE" if _flag(one, "one") else "RESUME", _opt_timeout(timeout))

    def stop(self, timeout: float | None = None) -> _Result:
        """Cancel the active command and the queue (they end CANCELLED): a planned move slows
        down on its own path within the acceleration limits first (a jog stops at once); then
        hold position."""
        return self._run("STOP", _opt_timeout(timeout))

    def enable(self, timeout: float | None = None) -> _Result:
        """Enable the robot (clears a released E-stop latch and a latched error)."""
        return self._run("ENABLE", _opt_timeout(timeout))

    def disable(self, timeout: float | None = None) -> _Result:
        """Disable the robot."""
        return self._run("DISABLE", _opt_timeout(timeout))

    def clear_error(self, timeout: float | None = None) -> _Result:
        """Clear a latched error."""
        return self._run("CLEAR_ERROR", _opt_timeout(timeout))

    def estop(self, timeout: float | None = None) -> _Result:
        """Software E-stop: cancel everything, latched until :meth:`enable`."""
        return self._run("ESTOP", _opt_timeout(timeout))

    def stream(self, on: OnOff, timeout: float | None = None) -> _Result:
        """Streaming jog mode on/off (newest jog replaces the previous one)."""
        return self._run(_check(wire.build_stream, _flag(on, "on")), _opt_timeout(timeout))

    def set_tool(self, name: str, timeout: float | None = None) -> _Result:
        """Select the tool ``name`` (default, flange or one from the config)."""
        return self._run(_check(wire.build_set_tool, name), _opt_timeout(timeout))

    def take_control(self, force: bool = False, secret: str | None = None,
                     timeout: float | None = None) -> _Result:
        """Take the control lease (docs/protocol.md): only its holder may move the robot. A free
        lease is also taken by the first motion command; ``force`` takes it from another client
        and cancels that client's commands; ``secret`` when the controller has one."""
        return self._run(_check(wire.build_control, "TAKE", _flag(force, "force"), secret),
                         _opt_timeout(timeout))

    def release_control(self, timeout: float | None = None) -> _Result:
        """Give the control lease back."""
        return self._run("CONTROL|RELEASE", _opt_timeout(timeout))

    def set_port(self, name: str, timeout: float | None = None) -> _Result:
        """Switch the controller's serial port to ``name``."""
        return self._run(_check(wire.build_set_port, name), _opt_timeout(timeout))

    # ---- queries: a value on Robot, a coroutine of that value on AsyncRobot ----
    @overload
    def angles(self: _Sync) -> tuple[float, ...]: ...
    @overload
    def angles(self: _Async) -> AsyncResult[tuple[float, ...]]: ...

    def angles(self) -> tuple[float, ...] | AsyncResult[tuple[float, ...]]:
        """Joint angles J1..J6 in deg."""
        return self._query(Queries.angles)

    @overload
    def pose(self: _Sync) -> Pose: ...
    @overload
    def pose(self: _Async) -> AsyncResult[Pose]: ...

    def pose(self) -> Pose | AsyncResult[Pose]:
        """Tool :class:`Pose` (mm, deg)."""
        return self._query(Queries.pose)

    @overload
    def pose_matrix(self: _Sync) -> tuple[tuple[float, ...], ...]: ...
    @overload
    def pose_matrix(self: _Async) -> AsyncResult[tuple[tuple[float, ...], ...]]: ...

    def pose_matrix(self) -> tuple[tuple[float, ...], ...] | AsyncResult[tuple[tuple[float, ...], ...]]:
        """4x4 tool pose as 4 row tuples, translation in METRES."""
        return self._query(Queries.pose_matrix)

    @overload
    def io(self: _Sync) -> IOState: ...
    @overload
    def io(self: _Async) -> AsyncResult[IOState]: ...

    def io(self) -> IOState | AsyncResult[IOState]:
        """:class:`IOState`."""
        return self._query(Queries.io)

    @overload
    def gripper(self: _Sync) -> GripperState: ...
    @overload
    def gripper(self: _Async) -> AsyncResult[GripperState]: ...

    def gripper(self) -> GripperState | AsyncResult[GripperState]:
        """:class:`GripperState`."""
        return self._query(Queries.gripper)

    @overload
    def speeds(self: _Sync) -> tuple[float, ...]: ...
    @overload
    def speeds(self: _Async) -> AsyncResult[tuple[float, ...]]: ...

    def speeds(self) -> tuple[float, ...] | AsyncResult[tuple[float, ...]]:
        """Joint speeds J1..J6 in steps/s."""
        return self._query(Queries.speeds)

    @overload
    def status(self: _Sync) -> RobotStatus: ...
    @overload
    def status(self: _Async) -> AsyncResult[RobotStatus]: ...

    def status(self) -> RobotStatus | AsyncResult[RobotStatus]:
        """Full :class:`RobotStatus` (GET_STATUS_JSON)."""
        return self._query(Queries.status)

    @overload
    def loop_stats(self: _Sync) -> LoopStats: ...
    @overload
    def loop_stats(self: _Async) -> AsyncResult[LoopStats]: ...

    def loop_stats(self) -> LoopStats | AsyncResult[LoopStats]:
        """:class:`LoopStats` of the controller's loop."""
        return self._query(Queries.loop_stats)

    @overload
    def plan_info(self: _Sync) -> PlanInfo: ...
    @overload
    def plan_info(self: _Async) -> AsyncResult[PlanInfo]: ...

    def plan_info(self) -> PlanInfo | AsyncResult[PlanInfo]:
        """:class:`PlanInfo` of the active motion."""
        return self._query(Queries.plan_info)

    @overload
    def queue(self: _Sync) -> QueueInfo: ...
    @overload
    def queue(self: _Async) -> AsyncResult[QueueInfo]: ...

    def queue(self) -> QueueInfo | AsyncResult[QueueInfo]:
        """:class:`QueueInfo`: active and queued commands (IDs only of this client's own)."""
        return self._query(Queries.queue)

    @overload
    def control(self: _Sync) -> ControlInfo: ...
    @overload
    def control(self: _Async) -> AsyncResult[ControlInfo]: ...

    def control(self) -> ControlInfo | AsyncResult[ControlInfo]:
        """Who holds the control lease (:class:`ControlInfo`, a dict: ``holder``, ``held_s``,
        ``idle_s``, ``timeout_s``, ``secret_required``, ``refused``, ``taken_over``)."""
        return self._query(Queries.control)

    @overload
    def tool(self: _Sync) -> ToolInfo: ...
    @overload
    def tool(self: _Async) -> AsyncResult[ToolInfo]: ...

    def tool(self) -> ToolInfo | AsyncResult[ToolInfo]:
        """:class:`ToolInfo`: the selected tool."""
        return self._query(Queries.tool)

    @overload
    def zones(self: _Sync) -> ZonesInfo: ...
    @overload
    def zones(self: _Async) -> AsyncResult[ZonesInfo]: ...

    def zones(self) -> ZonesInfo | AsyncResult[ZonesInfo]:
        """:class:`ZonesInfo`: the collision world the controller checks motion in (its
        keep-out zones, the tool's shape, the objects held: GET_ZONES)."""
        return self._query(Queries.zones)

    @overload
    def ping(self: _Sync) -> bool: ...
    @overload
    def ping(self: _Async) -> AsyncResult[bool]: ...

    def ping(self) -> bool | AsyncResult[bool]:
        """True when the controller answers PING (``ControllerUnreachable`` when it does not);
        :meth:`link_up` says whether its board link is up."""
        return self._query(Queries.ping)

    @overload
    def link_up(self: _Sync) -> bool: ...
    @overload
    def link_up(self: _Async) -> AsyncResult[bool]: ...

    def link_up(self) -> bool | AsyncResult[bool]:
        """True when the controller's board link is up (False: controller up, board down)."""
        return self._query(Queries.link)


#: the ``self`` of the queries' overloads: Robot answers with values, AsyncRobot with coroutines
_Sync: TypeAlias = RobotCommands[CommandResult, object]
_Async: TypeAlias = RobotCommands[AsyncResult[CommandResult], object]


def _jog_index(joint: object) -> int:
    """Joint 1..6 -> index 0..5 (positive); -1..-6 -> 6..11 (negative)."""
    if isinstance(joint, bool) or not isinstance(joint, int) or joint == 0 or not -6 <= joint <= 6:
        raise ParolkitValueError(
            f"joint must be 1..6 (positive direction) or -1..-6 (negative direction), got {joint!r}")
    return joint - 1 if joint > 0 else 6 + (-joint - 1)


def _jog_indices(joints: Sequence[int]) -> Sequence[int]:
    """Signed joint numbers -> jog indices (a string is left to the builder's error)."""
    return joints if isinstance(joints, (str, bytes)) else [_jog_index(j) for j in joints]
