"""The controller's status object (docs/protocol.md) as typed values, and readout formatting.

:func:`RobotStatus.from_json` turns one ``STATUS_JSON`` payload into a frozen dataclass;
a malformed payload raises :class:`ParolkitValueError` naming the field.  The ``format_*``
functions produce the strings the readouts show (units: deg, mm, deg/s, ms).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Mapping, Sequence

from parolkit.errors import ParolkitValueError

__all__ = [
    "RobotState",
    "IOState",
    "GripperState",
    "ErrorBits",
    "BoardInfo",
    "LoopStats",
    "ActiveCommand",
    "RobotStatus",
    "parse_status_datagram",
    "format_angles",
    "format_pose",
    "format_speeds",
    "format_bits",
    "format_loop",
    "state_badge",
]

POSE_LABELS = ("X", "Y", "Z", "A", "B", "C")
POSE_UNITS = ("mm", "mm", "mm", "°", "°", "°")


class RobotState(str, Enum):
    """Controller states (``state`` field)."""

    IDLE = "IDLE"
    MOVING = "MOVING"
    HOMING = "HOMING"
    DISABLED = "DISABLED"
    ESTOP = "ESTOP"
    ERROR = "ERROR"
    DISCONNECTED = "DISCONNECTED"


def _get(obj: Mapping[str, Any], key: str, path: str) -> Any:
    if not isinstance(obj, Mapping):
        raise ParolkitValueError(f"status.{path} must be an object, got {type(obj).__name__}")
    if key not in obj:
        raise ParolkitValueError(f"status.{path}{'.' if path else ''}{key} is missing")
    return obj[key]


def _num(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParolkitValueError(f"status.{name} must be a finite number, got {value!r}")
    return float(value)


def _nums(value: Any, name: str, n: int = 6) -> tuple[float, ...]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != n:
        raise ParolkitValueError(f"status.{name} must be a list of {n} numbers, got {value!r}")
    return tuple(_num(v, f"{name}[{i}]") for i, v in enumerate(value))


def _bools(value: Any, name: str, n: int = 6) -> tuple[bool, ...]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != n:
        raise ParolkitValueError(f"status.{name} must be a list of {n} booleans, got {value!r}")
    return tuple(bool(v) for v in value)


def _bit(value: Any, name: str) -> int:
    if value not in (0, 1, True, False):
        raise ParolkitValueError(f"status.{name} must be 0 or 1, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class IOState:
    """Digital IO: inputs, outputs and the E-stop input (1 = released, 0 = pressed)."""

    in1: int = 0
    in2: int = 0
    out1: int = 0
    out2: int = 0
    estop: int = 1

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> "IOState":
        return cls(**{k: _bit(_get(obj, k, "io"), f"io.{k}") for k in ("in1", "in2", "out1", "out2", "estop")})


@dataclass(frozen=True)
class GripperState:
    """SSG-48 electric gripper feedback. position/speed 0..255, current in mA."""

    id: int = 0
    position: int = 0
    speed: int = 0
    current: int = 0
    status: int = 0
    object_detection: int = 0
    activated: bool = False
    calibrated: bool = False
    object_detected: bool = False
    error: bool = False

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> "GripperState":
        ints = {k: int(_num(_get(obj, k, "gripper"), f"gripper.{k}"))
                for k in ("id", "position", "speed", "current", "status", "object_detection")}
        flags = {k: bool(obj.get(k, False)) for k in ("activated", "calibrated", "object_detected", "error")}
        return cls(**ints, **flags)

    @property
    def status_text(self) -> str:
        """Human summary: 'error', 'calibrated', 'active' or 'idle'."""
        if self.error:
            return "error"
        if self.calibrated:
            return "calibrated"
        if self.activated:
            return "active"
        return "idle"


@dataclass(frozen=True)
class ErrorBits:
    """Per-joint temperature and position error bits and the latched error message."""

    temperature: tuple[bool, ...] = (False,) * 6
    position: tuple[bool, ...] = (False,) * 6
    message: str | None = None

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> "ErrorBits":
        msg = obj.get("message")
        return cls(
            temperature=_bools(_get(obj, "temperature", "errors"), "errors.temperature"),
            position=_bools(_get(obj, "position", "errors"), "errors.position"),
            message=str(msg) if msg else None,
        )

    @property
    def any(self) -> bool:
        return any(self.temperature) or any(self.position) or bool(self.message)


@dataclass(frozen=True)
class BoardInfo:
    """The board link: connected, simulated, port name and the board's loop timing in ms."""

    connected: bool = False
    simulated: bool = False
    port: str = ""
    timing_ms: float | None = None

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> "BoardInfo":
        t = obj.get("timing_ms")
        return cls(
            connected=bool(_get(obj, "connected", "board")),
            simulated=bool(obj.get("simulated", False)),
            port=str(obj.get("port") or ""),
            timing_ms=None if t is None else _num(t, "board.timing_ms"),
        )


@dataclass(frozen=True)
class LoopStats:
    """Controller loop statistics (ms, counts); unknown fields are ignored."""

    rate_hz: float | None = None
    period_p50_ms: float | None = None
    period_p99_ms: float | None = None
    period_max_ms: float | None = None
    overruns: int | None = None
    frames_sent: int | None = None
    frames_received: int | None = None

    @classmethod
    def from_json(cls, obj: Mapping[str, Any] | None) -> "LoopStats":
        if not obj:
            return cls()
        out: dict[str, Any] = {}
        for name in ("rate_hz", "period_p50_ms", "period_p99_ms", "period_max_ms"):
            if obj.get(name) is not None:
                out[name] = _num(obj[name], f"loop.{name}")
        for name in ("overruns", "frames_sent", "frames_received"):
            if obj.get(name) is not None:
                out[name] = int(_num(obj[name], f"loop.{name}"))
        return cls(**out)


@dataclass(frozen=True)
class ActiveCommand:
    """The command being executed: ID (may be empty), name and progress 0..1 (None if unknown)."""

    name: str
    id: str = ""
    progress: float | None = None

    @classmethod
    def from_json(cls, obj: Mapping[str, Any] | None) -> "ActiveCommand | None":
        if not obj:
            return None
        p = obj.get("progress")
        return cls(name=str(_get(obj, "name", "command")), id=str(obj.get("id") or ""),
                   progress=None if p is None else _num(p, "command.progress"))


@dataclass(frozen=True)
class RobotStatus:
    """One status snapshot. Angles in deg, pose in mm/deg, speeds in steps/s and deg/s."""

    seq: int
    time: float
    state: RobotState
    enabled: bool
    homed: tuple[bool, ...]
    estop_pressed: bool
    estop_latched: bool
    angles: tuple[float, ...]
    pose: tuple[float, ...]
    speeds: tuple[float, ...]
    speeds_deg_s: tuple[float, ...]
    io: IOState = field(default_factory=IOState)
    gripper: GripperState = field(default_factory=GripperState)
    errors: ErrorBits = field(default_factory=ErrorBits)
    board: BoardInfo = field(default_factory=BoardInfo)
    loop: LoopStats = field(default_factory=LoopStats)
    command: ActiveCommand | None = None
    queue: int = 0
    stream_mode: bool = False
    tool: str = "default"
    plan_seq: int = 0

    @property
    def all_homed(self) -> bool:
        return all(self.homed)

    @property
    def moving(self) -> bool:
        return self.state in (RobotState.MOVING, RobotState.HOMING)

    @property
    def can_move(self) -> bool:
        """True when motion commands can run: enabled, homed, no E-stop, no error state."""
        return (self.enabled and self.all_homed and not self.estop_latched and not self.estop_pressed
                and self.state not in (RobotState.ERROR, RobotState.DISCONNECTED, RobotState.ESTOP))

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> "RobotStatus":
        """Validate and convert one status object; raises ParolkitValueError naming the field."""
        if not isinstance(obj, Mapping):
            raise ParolkitValueError(f"status must be a JSON object, got {type(obj).__name__}")
        raw_state = _get(obj, "state", "")
        try:
            state = RobotState(str(raw_state).upper())
        except ValueError:
            allowed = ", ".join(s.value for s in RobotState)
            raise ParolkitValueError(f"status.state must be one of {allowed}, got {raw_state!r}") from None
        speeds = _nums(_get(obj, "speeds", ""), "speeds")
        sdeg = obj.get("speeds_deg_s")
        return cls(
            seq=int(_num(_get(obj, "seq", ""), "seq")),
            time=_num(obj.get("time", 0.0), "time"),
            state=state,
            enabled=bool(_get(obj, "enabled", "")),
            homed=_bools(_get(obj, "homed", ""), "homed"),
            estop_pressed=bool(obj.get("estop_pressed", False)),
            estop_latched=bool(obj.get("estop_latched", False)),
            angles=_nums(_get(obj, "angles", ""), "angles"),
            pose=_nums(_get(obj, "pose", ""), "pose"),
            speeds=speeds,
            speeds_deg_s=_nums(sdeg, "speeds_deg_s") if sdeg is not None else (0.0,) * 6,
            io=IOState.from_json(_get(obj, "io", "")),
            gripper=GripperState.from_json(obj["gripper"]) if obj.get("gripper") else GripperState(),
            errors=ErrorBits.from_json(obj["errors"]) if obj.get("errors") else ErrorBits(),
            board=BoardInfo.from_json(obj["board"]) if obj.get("board") else BoardInfo(),
            loop=LoopStats.from_json(obj.get("loop")),
            command=ActiveCommand.from_json(obj.get("command")),
            queue=int(_num(obj.get("queue", 0), "queue")),
            stream_mode=bool(obj.get("stream_mode", False)),
            tool=str(obj.get("tool") or "default"),
            plan_seq=int(_num(obj.get("plan_seq", 0), "plan_seq")),
        )


def parse_status_datagram(text: str) -> RobotStatus:
    """Parse ``STATUS_JSON|{...}`` (a stream datagram or a GET_STATUS_JSON reply)."""
    head, sep, payload = text.partition("|")
    if head.strip().upper() != "STATUS_JSON" or not sep:
        raise ParolkitValueError(f"expected a 'STATUS_JSON|{{...}}' datagram, got {text[:40]!r}")
    try:
        obj = json.loads(payload)
    except json.JSONDecodeError as exc:
        raise ParolkitValueError(f"STATUS_JSON payload is not valid JSON: {exc}") from None
    return RobotStatus.from_json(obj)


# ------------------------------------------------------------------------------------------
# readout formatting
# ------------------------------------------------------------------------------------------


def format_angles(angles: Sequence[float]) -> list[str]:
    """Joint angles as 'J1  90.000°' style strings (3 decimals, degrees)."""
    return [f"{a:+.3f}°" for a in angles]


def format_pose(pose: Sequence[float]) -> list[str]:
    """TCP pose as six strings: x, y, z in mm (2 decimals), A, B, C in degrees (3 decimals)."""
    return [f"{v:+.2f} mm" if i < 3 else f"{v:+.3f}°" for i, v in enumerate(pose)]


def format_speeds(speeds_deg_s: Sequence[float]) -> list[str]:
    """Joint speeds in deg/s, one decimal."""
    return [f"{v:+.1f} °/s" for v in speeds_deg_s]


def format_bits(bits: Sequence[bool], on: str = "1", off: str = "0") -> str:
    """A bit vector as a compact string, e.g. '1 1 0 1 1 1'."""
    return " ".join(on if b else off for b in bits)


def format_loop(loop: LoopStats) -> str:
    """One line of loop statistics, e.g. '100 Hz · p50 10.00 ms · p99 10.40 ms · 0 overruns'."""
    parts: list[str] = []
    if loop.rate_hz is not None:
        parts.append(f"{loop.rate_hz:.0f} Hz")
    if loop.period_p50_ms is not None:
        parts.append(f"p50 {loop.period_p50_ms:.2f} ms")
    if loop.period_p99_ms is not None:
        parts.append(f"p99 {loop.period_p99_ms:.2f} ms")
    if loop.period_max_ms is not None:
        parts.append(f"max {loop.period_max_ms:.2f} ms")
    if loop.overruns is not None:
        parts.append(f"{loop.overruns} overruns")
    return " · ".join(parts) if parts else "n/a"


def state_badge(status: RobotStatus | None, link_up: bool) -> tuple[str, str]:
    """(text, colour) for the state badge: colour is one of 'positive', 'warning', 'negative', 'grey'."""
    if not link_up or status is None:
        return "NO LINK", "grey"
    if status.estop_latched or status.estop_pressed or status.state is RobotState.ESTOP:
        return "E-STOP", "negative"
    if status.state is RobotState.ERROR or status.errors.message:
        return "ERROR", "negative"
    if status.state is RobotState.DISCONNECTED:
        return "BOARD LOST", "negative"
    if not status.enabled or status.state is RobotState.DISABLED:
        return "DISABLED", "warning"
    if status.state is RobotState.HOMING:
        return "HOMING", "warning"
    if not status.all_homed:
        return "NOT HOMED", "warning"
    if status.state is RobotState.MOVING:
        return "MOVING", "info"
    return "READY", "positive"
