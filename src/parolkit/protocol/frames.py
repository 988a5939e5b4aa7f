"""PAROL6 board link: byte-exact codec for the two frame types.

Frame layout (both directions)::

    FF FF FF | LEN | payload (LEN bytes; the last three are CRC, 0x01, 0x02)

* PC -> board: :class:`CommandFrame`, LEN 52, 56 bytes in all, CRC byte constant 228.
* board -> PC: :class:`StatusFrame`, LEN 56, 60 bytes in all, CRC byte constant 212.

No checksum is computed by either side; the "CRC" byte is a constant and is carried as a field
so that a frame round-trips byte for byte.

Encodings: 24-bit big-endian two's complement for joint positions (microsteps) and speeds
(microsteps/s), 16-bit big-endian two's complement for gripper values, unsigned 16-bit
big-endian for ``timing``; bitfield bytes are MSB first (flag 0 is 0x80).

Validation: :meth:`CommandFrame.encode` / :meth:`StatusFrame.encode` refuse values that do
not fit the wire field (``ParolkitValueError`` naming the field and the allowed range).  The
codec never clamps or wraps.  The only wrap-around that exists is the board's own ``timing``
field, which the FIRMWARE reports modulo 2**16 (a gap longer than 93.2 ms wraps); decoding
returns the wire value unchanged.
"""

from __future__ import annotations

import operator
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, fields
from enum import IntEnum, IntFlag
from typing import SupportsIndex, TypeVar, cast

from parolkit._frozen import quick_init
from parolkit.errors import ParolkitValueError

__all__ = [
    "START",
    "END",
    "COMMAND_LEN",
    "STATUS_LEN",
    "COMMAND_FRAME_SIZE",
    "STATUS_FRAME_SIZE",
    "PC_CRC",
    "BOARD_CRC",
    "TIMER_HZ",
    "BoardCommand",
    "IOBits",
    "GripperCommandBits",
    "GripperMode",
    "GripperStatus",
    "CommandFrame",
    "StatusFrame",
    "FrameError",
    "bits_to_byte",
    "byte_to_bits",
]

START = b"\xff\xff\xff"
END = b"\x01\x02"
#: LEN byte of a PC -> board frame (bytes after LEN).
COMMAND_LEN = 52
#: LEN byte of a board -> PC frame.
STATUS_LEN = 56
COMMAND_FRAME_SIZE = 4 + COMMAND_LEN
STATUS_FRAME_SIZE = 4 + STATUS_LEN
#: Constant "CRC" byte the PC sends.
PC_CRC = 228
#: Constant "CRC" byte the board sends.
BOARD_CRC = 212
#: Board timer rate for the ``timing`` field: 90 MHz / 128 = 703125 ticks per second.
TIMER_HZ = 703_125

_I24 = (-(1 << 23), (1 << 23) - 1)
_I16 = (-(1 << 15), (1 << 15) - 1)
_U16 = (0, (1 << 16) - 1)
_U8 = (0, 255)


class FrameError(ParolkitValueError):
    """Bytes that are not a valid frame (wrong start, LEN, size or end bytes)."""


class BoardCommand(IntEnum):
    """Active command codes (decimal on the wire; old comments write them as "0x123")."""

    HOME = 100
    ENABLE = 101
    DISABLE = 102
    CLEAR_ERROR = 103
    JOG = 123
    GOTO = 156
    IDLE = 255


_COMMANDS = {int(c): c for c in BoardCommand}


class IOBits(IntFlag):
    """The IO byte. PC->board only OUT1/OUT2 matter; board->PC reports all and 0x07 are 1.

    ``ESTOP`` set means the E-stop is RELEASED (0 = pressed), as the board reports it.
    """

    NONE = 0
    IN1 = 0x80
    IN2 = 0x40
    OUT1 = 0x20
    OUT2 = 0x10
    ESTOP = 0x08
    SPARE5 = 0x04
    SPARE6 = 0x02
    SPARE7 = 0x01


class GripperCommandBits(IntFlag):
    """Gripper command byte (PC -> board). Typical 0xD0 (activate|move|release-dir)."""

    NONE = 0
    ACTIVATE = 0x80
    MOVE = 0x40
    ESTOP = 0x20
    RELEASE_DIR = 0x10


class GripperMode(IntEnum):
    """Gripper mode byte. CALIBRATE and CLEAR_ERROR are one-shot (exactly one frame)."""

    OPERATE = 0
    CALIBRATE = 1
    CLEAR_ERROR = 2


@quick_init
@dataclass(frozen=True)
class GripperStatus:
    """Decoded SSG-48 status byte (board -> PC offset 51)."""

    activated: bool
    action: bool
    #: 0 moving, 1 object found while closing, 2 object found while opening, 3 at position.
    object_code: int
    temperature_error: bool
    timeout_error: bool
    estop_error: bool
    calibrated: bool

    @classmethod
    def from_byte(cls, value: int) -> GripperStatus:
        v = _check_int(value, "gripper_status", _U8)
        return cls(
            activated=bool(v & 0x80),
            action=bool(v & 0x40),
            object_code=((v >> 5) & 1) << 1 | ((v >> 4) & 1),
            temperature_error=bool(v & 0x08),
            timeout_error=bool(v & 0x04),
            estop_error=bool(v & 0x02),
            calibrated=bool(v & 0x01),
        )

    def to_byte(self) -> int:
        if not 0 <= self.object_code <= 3:
            raise ParolkitValueError(f"object_code must be 0..3, got {self.object_code}")
        return (
            (0x80 if self.activated else 0)
            | (0x40 if self.action else 0)
            | ((self.object_code >> 1) & 1) << 5
            | (self.object_code & 1) << 4
            | (0x08 if self.temperature_error else 0)
            | (0x04 if self.timeout_error else 0)
            | (0x02 if self.estop_error else 0)
            | (0x01 if self.calibrated else 0)
        )

    @property
    def object_detected(self) -> bool:
        """True when the jaws stopped on an object (closing or opening)."""
        return self.object_code in (1, 2)


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------


# (the checks are typed as the fields declare; at run time they refuse whatever else comes in)
def _check_int(value: SupportsIndex, name: str, bounds: tuple[int, int]) -> int:
    if type(value) is int and bounds[0] <= value <= bounds[1]:  # the common case, fast
        return value
    if isinstance(value, bool):
        raise ParolkitValueError(f"{name} must be an integer, got a bool ({value!r})")
    try:
        v = operator.index(value)  # ints and numpy integers; floats are refused (no truncation)
    except TypeError:
        raise ParolkitValueError(
            f"{name} must be an integer in {bounds[0]}..{bounds[1]}, got {value!r}"
        ) from None
    if not bounds[0] <= v <= bounds[1]:
        raise ParolkitValueError(f"{name} = {v} is out of range {bounds[0]}..{bounds[1]}")
    return v


def _check_six(values: Iterable[SupportsIndex], name: str, bounds: tuple[int, int]) -> tuple[int, ...]:
    if type(values) is tuple and len(values) == 6:  # the common case, fast: 6 plain in-range ints
        lo, hi = bounds
        a, b, c, d, e, f = values
        if (type(a) is int and type(b) is int and type(c) is int and type(d) is int and type(e) is int
                and type(f) is int and lo <= a <= hi and lo <= b <= hi and lo <= c <= hi and lo <= d <= hi
                and lo <= e <= hi and lo <= f <= hi):
            return values  # type: ignore[return-value]  # (6 plain ints: no call to cast them)
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__"):
        raise ParolkitValueError(f"{name} must be a sequence of 6 integers, got {values!r}")
    seq = tuple(values)
    if len(seq) != 6:
        raise ParolkitValueError(f"{name} must have 6 values (J1..J6), got {len(seq)}")
    lo, hi = bounds
    for v in seq:
        if type(v) is not int or not lo <= v <= hi:
            break
    else:
        return cast("tuple[int, ...]", seq)  # all plain in-range ints: no per-element work
    return tuple(_check_int(v, f"{name}[J{i + 1}]", bounds) for i, v in enumerate(seq))


def bits_to_byte(bits: Sequence[object]) -> int:
    """8 flags, MSB first (flag 0 -> 0x80), to a byte."""
    if len(bits) != 8:
        raise ParolkitValueError(f"a bitfield needs 8 flags, got {len(bits)}")
    out = 0
    for i, b in enumerate(bits):
        if b not in (0, 1, True, False):
            raise ParolkitValueError(f"bit {i} must be 0/1 or a bool, got {b!r}")
        if b:
            out |= 0x80 >> i
    return out


#: every byte's 8 flags, MSB first
_BITS = tuple(tuple(bool(v & (0x80 >> i)) for i in range(8)) for v in range(256))


def byte_to_bits(value: int) -> tuple[bool, ...]:
    """A byte to 8 flags, MSB first."""
    return _BITS[_check_int(value, "bitfield byte", _U8)]


_M24 = 0xFFFFFF
_S24 = 0x800000


def _pack24(positions: tuple[int, ...], speeds: tuple[int, ...]) -> bytes:
    """The six positions then the six speeds as 24-bit two's complement big-endian values: 36
    bytes (as one integer: one conversion instead of twelve)."""
    a, b, c, d, e, f = positions
    g, h, i, j, k, m = speeds
    M = _M24
    return ((a & M) << 264 | (b & M) << 240 | (c & M) << 216 | (d & M) << 192 | (e & M) << 168
            | (f & M) << 144 | (g & M) << 120 | (h & M) << 96 | (i & M) << 72 | (j & M) << 48
            | (k & M) << 24 | (m & M)).to_bytes(36, "big")


def _unpack24(payload: bytes) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(positions, speeds): the twelve 24-bit two's complement big-endian values of
    ``payload[0:36]`` (``(x ^ 0x800000) - 0x800000`` sign-extends a 24-bit ``x``)."""
    n = int.from_bytes(payload[0:36], "big")
    M, S = _M24, _S24
    return (((n >> 264 & M ^ S) - S, (n >> 240 & M ^ S) - S, (n >> 216 & M ^ S) - S,
             (n >> 192 & M ^ S) - S, (n >> 168 & M ^ S) - S, (n >> 144 & M ^ S) - S),
            ((n >> 120 & M ^ S) - S, (n >> 96 & M ^ S) - S, (n >> 72 & M ^ S) - S,
             (n >> 48 & M ^ S) - S, (n >> 24 & M ^ S) - S, (n & M ^ S) - S))


#: a frame's bytes after the 36 bytes of positions and speeds, up to the end bytes (the
#: 16-bit gripper fields are signed, as the fields are checked)
_COMMAND_TAIL = struct.Struct(">4B3h4B")
_STATUS_TAIL = struct.Struct(">4BH3B3h3B")
_COMMAND_HEAD = START + bytes((COMMAND_LEN,))
_STATUS_HEAD = START + bytes((STATUS_LEN,))


#: a frame's scalar fields and their ranges, in the order they are checked
_COMMAND_FIELDS: tuple[tuple[str, tuple[int, int]], ...] = (
    *((n, _U8) for n in ("command", "affected", "io", "timeout", "gripper_command", "gripper_mode", "gripper_id",
                         "crc")),
    *((n, _I16) for n in ("gripper_position", "gripper_speed", "gripper_current")),
)
_STATUS_FIELDS: tuple[tuple[str, tuple[int, int]], ...] = (
    *((n, _U8) for n in ("homed", "io", "temperature_error", "position_error", "timeout_error", "xtr",
                         "gripper_id", "gripper_status", "object_detection", "crc")),
    ("timing", _U16),
    *((n, _I16) for n in ("gripper_position", "gripper_speed", "gripper_current")),
)


def _check_fields(frame: CommandFrame | StatusFrame, scalars: tuple[tuple[str, tuple[int, int]], ...]) -> None:
    """Check (and normalise to plain ints) a new frame's fields: the six positions and speeds,
    then ``scalars`` in order; the first bad one raises.  (Written into the instance's dict,
    as ``object.__setattr__`` on a frozen dataclass would.)"""
    d = frame.__dict__
    d["positions"] = _check_six(d["positions"], "positions", _I24)
    d["speeds"] = _check_six(d["speeds"], "speeds", _I24)
    for name, bounds in scalars:
        v = d[name]
        if (type(v) is not int or not bounds[0] <= v <= bounds[1]) and type(v) is not BoardCommand:
            d[name] = _check_int(v, name, bounds)  # (a BoardCommand is a byte: it stays as it is)


_Frame = TypeVar("_Frame", "CommandFrame", "StatusFrame")


def _trusted(cls: type[_Frame], values: dict[str, object]) -> _Frame:
    """Build a frame from values decoded off the wire (in range by construction)."""
    obj = object.__new__(cls)
    obj.__dict__.update(values)
    return obj


def _check_envelope(data: bytes, length: int, crc_expected: int | None, what: str) -> None:
    size = 4 + length
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise FrameError(f"{what}: expected bytes, got {type(data).__name__}")
    if len(data) != size:
        raise FrameError(f"{what}: expected {size} bytes, got {len(data)}")
    if data[:3] != START:
        raise FrameError(f"{what}: start bytes are {bytes(data[:3]).hex(' ')}, expected ff ff ff")
    if data[3] != length:
        raise FrameError(f"{what}: LEN byte is {data[3]}, expected {length}")
    if data[-2:] != END:
        raise FrameError(f"{what}: end bytes are {bytes(data[-2:]).hex(' ')}, expected 01 02")
    if crc_expected is not None and data[-3] != crc_expected:
        raise FrameError(f"{what}: CRC byte is {data[-3]}, expected the constant {crc_expected}")


# ---------------------------------------------------------------------------------------------
# PC -> board
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, init=False)
class CommandFrame:
    """One PC -> board frame.

    ``positions`` (microsteps) and ``speeds`` (microsteps/s) are 6 ints each (24-bit signed).
    ``command`` is a :class:`BoardCommand` or any byte (the board idles on unknown codes and
    still replies).  ``io`` is the in/out byte (only OUT1/OUT2 matter to the board).
    Gripper setpoints are 16-bit signed on the wire (position/speed 0..255, current in mA are
    what the gripper uses; the codec checks only what fits the wire).
    """

    positions: tuple[int, ...]
    speeds: tuple[int, ...]
    command: int
    affected: int
    io: int
    timeout: int
    gripper_position: int
    gripper_speed: int
    gripper_current: int
    gripper_command: int
    gripper_mode: int
    gripper_id: int
    crc: int

    # (written out rather than generated: a frozen dataclass's own __init__ sets each field
    # with object.__setattr__, which made building a frame cost more than encoding it)
    def __init__(self, positions: tuple[int, ...] = (0, 0, 0, 0, 0, 0),
                 speeds: tuple[int, ...] = (0, 0, 0, 0, 0, 0), command: int = BoardCommand.IDLE,
                 affected: int = 0xFF, io: int = 0, timeout: int = 0, gripper_position: int = 0,
                 gripper_speed: int = 0, gripper_current: int = 0, gripper_command: int = 0,
                 gripper_mode: int = GripperMode.OPERATE, gripper_id: int = 0, crc: int = PC_CRC) -> None:
        self.__dict__.update(
            positions=positions, speeds=speeds, command=command, affected=affected, io=io, timeout=timeout,
            gripper_position=gripper_position, gripper_speed=gripper_speed, gripper_current=gripper_current,
            gripper_command=gripper_command, gripper_mode=gripper_mode, gripper_id=gripper_id, crc=crc)
        _check_fields(self, _COMMAND_FIELDS)
        # an unknown code is legal on the wire: the board idles and replies
        cmd = self.command
        self.__dict__["command"] = _COMMANDS.get(cmd, cmd)

    @property
    def outputs(self) -> tuple[bool, bool]:
        """(OUT1, OUT2) as sent."""
        return bool(self.io & IOBits.OUT1), bool(self.io & IOBits.OUT2)

    def encode(self) -> bytes:
        """The 56 bytes of this frame."""
        return (_COMMAND_HEAD + _pack24(self.positions, self.speeds)
                + _COMMAND_TAIL.pack(self.command, self.affected, self.io, self.timeout, self.gripper_position,
                                     self.gripper_speed, self.gripper_current, self.gripper_command,
                                     self.gripper_mode, self.gripper_id, self.crc)
                + END)

    @classmethod
    def decode(cls, data: bytes, *, check_crc: bool = False) -> CommandFrame:
        """Parse exactly one 56-byte frame.  Raises :class:`FrameError` on a bad envelope.

        ``check_crc`` is off by default because the board never checks it.
        """
        _check_envelope(data, COMMAND_LEN, PC_CRC if check_crc else None, "command frame")
        p = bytes(data[4:])
        positions, speeds = _unpack24(p)
        cmd, affected, io, timeout, g_pos, g_speed, g_current, g_cmd, g_mode, g_id, crc = \
            _COMMAND_TAIL.unpack_from(p, 36)
        return _trusted(cls, dict(
            positions=positions, speeds=speeds, command=_COMMANDS.get(cmd, cmd), affected=affected, io=io,
            timeout=timeout, gripper_position=g_pos, gripper_speed=g_speed, gripper_current=g_current,
            gripper_command=g_cmd, gripper_mode=g_mode, gripper_id=g_id, crc=crc))


# ---------------------------------------------------------------------------------------------
# board -> PC
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, init=False)
class StatusFrame:
    """One board -> PC frame (telemetry).

    ``homed``, ``temperature_error``, ``position_error`` are bitfield bytes [J1..J6, 1, 1]
    (J1 = 0x80).  ``io`` is [IN1, IN2, OUT1, OUT2, ESTOP, 1, 1, 1]; ESTOP bit set = released.
    ``timing`` is in board timer ticks (1/703125 s), low 16 bits.
    """

    positions: tuple[int, ...]
    speeds: tuple[int, ...]
    homed: int
    io: int
    temperature_error: int
    position_error: int
    timing: int
    timeout_error: int
    xtr: int
    gripper_id: int
    gripper_position: int
    gripper_speed: int
    gripper_current: int
    gripper_status: int
    object_detection: int
    crc: int

    # (written out rather than generated, as CommandFrame's)
    def __init__(self, positions: tuple[int, ...] = (0, 0, 0, 0, 0, 0),
                 speeds: tuple[int, ...] = (0, 0, 0, 0, 0, 0), homed: int = 0x03, io: int = 0x0F,
                 temperature_error: int = 0x03, position_error: int = 0x03, timing: int = 0,
                 timeout_error: int = 100, xtr: int = 255, gripper_id: int = 0, gripper_position: int = 0,
                 gripper_speed: int = 1, gripper_current: int = 0, gripper_status: int = 0,
                 object_detection: int = 1, crc: int = BOARD_CRC) -> None:
        self.__dict__.update(
            positions=positions, speeds=speeds, homed=homed, io=io, temperature_error=temperature_error,
            position_error=position_error, timing=timing, timeout_error=timeout_error, xtr=xtr,
            gripper_id=gripper_id, gripper_position=gripper_position, gripper_speed=gripper_speed,
            gripper_current=gripper_current, gripper_status=gripper_status, object_detection=object_detection,
            crc=crc)
        _check_fields(self, _STATUS_FIELDS)

    # ---- convenience views ----
    @property
    def homed_joints(self) -> tuple[bool, ...]:
        """Homed flag of J1..J6."""
        return byte_to_bits(self.homed)[:6]

    @property
    def all_homed(self) -> bool:
        return self.homed & 0xFC == 0xFC  # J1..J6 are the six high bits

    @property
    def estop_pressed(self) -> bool:
        """True when the hardware E-stop is pressed (IO bit 0x08 is 0)."""
        return not (self.io & IOBits.ESTOP)

    @property
    def inputs(self) -> tuple[bool, bool]:
        return bool(self.io & IOBits.IN1), bool(self.io & IOBits.IN2)

    @property
    def outputs(self) -> tuple[bool, bool]:
        return bool(self.io & IOBits.OUT1), bool(self.io & IOBits.OUT2)

    @property
    def timing_s(self) -> float:
        """``timing`` in seconds."""
        return self.timing / TIMER_HZ

    @property
    def gripper(self) -> GripperStatus:
        return GripperStatus.from_byte(self.gripper_status)

    def encode(self) -> bytes:
        """The 60 bytes of this frame."""
        return (_STATUS_HEAD + _pack24(self.positions, self.speeds)
                + _STATUS_TAIL.pack(self.homed, self.io, self.temperature_error, self.position_error, self.timing,
                                    self.timeout_error, self.xtr, self.gripper_id, self.gripper_position,
                                    self.gripper_speed, self.gripper_current, self.gripper_status,
                                    self.object_detection, self.crc)
                + END)

    @classmethod
    def decode(cls, data: bytes, *, check_crc: bool = False) -> StatusFrame:
        """Parse exactly one 60-byte frame.  Raises :class:`FrameError` on a bad envelope."""
        _check_envelope(data, STATUS_LEN, BOARD_CRC if check_crc else None, "status frame")
        p = bytes(data[4:])
        positions, speeds = _unpack24(p)
        (homed, io, temperature_error, position_error, timing, timeout_error, xtr, g_id, g_pos, g_speed, g_current,
         g_status, object_detection, crc) = _STATUS_TAIL.unpack_from(p, 36)
        return _trusted(cls, dict(
            positions=positions, speeds=speeds, homed=homed, io=io, temperature_error=temperature_error,
            position_error=position_error, timing=timing, timeout_error=timeout_error, xtr=xtr, gripper_id=g_id,
            gripper_position=g_pos, gripper_speed=g_speed, gripper_current=g_current, gripper_status=g_status,
            object_detection=object_detection, crc=crc))


def frame_fields(frame: CommandFrame | StatusFrame) -> dict[str, object]:
    """The frame's fields as a plain dict (for logs and JSON)."""
    return {f.name: getattr(frame, f.name) for f in fields(frame)}
