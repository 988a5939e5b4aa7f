"""Turn the bytes of a board link into a readable, timestamped log: one line per frame.

:class:`StreamSplitter` cuts one direction's byte stream into whole frames and runs of bytes
that are not a frame, in the order they crossed, using the protocol's own stream parser (so
the log shows exactly what the controller's parser accepts and drops).  :class:`SpyLog`
writes the lines.

Line format (fields separated by one space)::

    2025-06-01T10:00:00.123456+02:00 812.123456 PC>BOARD CommandFrame command=ENABLE ...
    2025-06-01T10:00:00.124101+02:00 812.124101 BOARD>PC StatusFrame positions=... xtr=101 ...
    2025-06-01T10:00:00.131002+02:00 812.131002 BOARD>PC undecoded 3 bytes: 00 13 7f
    2025-06-01T10:00:00.200000+02:00 812.200000 -- close

wall-clock time (local, ISO 8601, microseconds), monotonic time (s, ``time.monotonic()``),
direction (``PC>BOARD`` / ``BOARD>PC``, or ``--`` for events), then the content.  A frame's
time is when the bytes completing it crossed the link (``write`` called / ``read``
returned); bytes are reported "undecoded" when the parser gives up on them, which can be one
read later.  Bitfield bytes are shown in binary, J1 first (``homed=0b11111111``).
"""

from __future__ import annotations

from datetime import datetime
from enum import Enum, IntEnum
from typing import TextIO

from parolkit.protocol.frames import (
    COMMAND_FRAME_SIZE,
    STATUS_FRAME_SIZE,
    CommandFrame,
    StatusFrame,
    frame_fields,
)
from parolkit.protocol.stream import CommandParser, FrameParser, StatusParser

__all__ = ["SpyDirection", "Piece", "StreamSplitter", "SpyLog", "format_frame"]

_BITFIELDS = frozenset({"affected", "io", "homed", "temperature_error", "position_error",
                        "gripper_status"})


class SpyDirection(str, Enum):
    """Which way bytes crossed the link, as shown in the log."""

    TO_BOARD = "PC>BOARD"
    FROM_BOARD = "BOARD>PC"


class Piece:
    """A run of bytes from one direction: a decoded ``frame``, or None for undecoded bytes."""

    __slots__ = ("raw", "frame")

    def __init__(self, raw: bytes, frame: CommandFrame | StatusFrame | None) -> None:
        self.raw = raw
        self.frame = frame


class StreamSplitter:
    """Splits one direction's byte stream into frames and undecoded runs, in order.

    ``StreamSplitter(SpyDirection.TO_BOARD)`` parses command frames (the board's rules: CRC byte
    not checked); ``SpyDirection.FROM_BOARD`` status frames (the controller's rules: CRC byte
    checked).  It mirrors the parser's buffer: every byte fed comes out exactly once, in a
    frame, in an undecoded run, or from :meth:`pending` (a frame still incomplete).
    """

    def __init__(self, direction: SpyDirection) -> None:
        self.direction = direction
        self._parser: FrameParser[CommandFrame] | FrameParser[StatusFrame]
        if direction is SpyDirection.TO_BOARD:
            self._parser = CommandParser()
            self._size = COMMAND_FRAME_SIZE
        else:
            self._parser = StatusParser()
            self._size = STATUS_FRAME_SIZE
        self._held = bytearray()  # the bytes the parser holds, in the same order

    def feed(self, data: bytes) -> list[Piece]:
        """Add bytes; return the frames and undecoded runs they settle, in stream order."""
        held = self._held
        held += data
        stats = self._parser.stats
        dropped = stats.bytes_dropped
        out: list[Piece] = []
        for frame in self._parser.iter_feed(data):
            dropped = self._take_dropped(out, dropped)
            out.append(Piece(bytes(held[: self._size]), frame))
            del held[: self._size]
        self._take_dropped(out, dropped)
        if len(held) != self._parser.pending:  # cannot happen while the parser keeps its contract
            out.append(Piece(bytes(held), None))
            held.clear()
            self._parser.reset()
        return out

    def _take_dropped(self, out: list[Piece], before: int) -> int:
        now = self._parser.stats.bytes_dropped
        if now > before:
            n = now - before
            out.append(Piece(bytes(self._held[:n]), None))
            del self._held[:n]
        return now

    def pending(self) -> bytes:
        """Bytes of a frame not yet complete (they may still become one)."""
        return bytes(self._held)


def _value(name: str, value: object) -> str:
    if isinstance(value, tuple):
        return ",".join(str(v) for v in value)
    if isinstance(value, IntEnum):
        return value.name
    if name in _BITFIELDS and isinstance(value, int):
        return f"0b{value:08b}"
    return str(value)


def format_frame(frame: CommandFrame | StatusFrame) -> str:
    """``CommandFrame command=ENABLE positions=0,0,0,0,0,0 ...``: every field, wire order."""
    fields = " ".join(f"{k}={_value(k, v)}" for k, v in frame_fields(frame).items())
    return f"{type(frame).__name__} {fields}"


class SpyLog:
    """Writes log lines for both directions of one link to ``stream``.

    ``raw=True`` adds each frame's bytes in hex (``raw=ffffff34...``).  Counters
    (``frames``, ``undecoded_bytes``, per direction) grow over the log's life.
    """

    def __init__(self, stream: TextIO, *, raw: bool = False) -> None:
        self.stream = stream
        self.raw = raw
        self._splitters = {d: StreamSplitter(d) for d in SpyDirection}
        self.frames = {d: 0 for d in SpyDirection}
        self.undecoded_bytes = {d: 0 for d in SpyDirection}

    @staticmethod
    def _stamp(mono_s: float, wall_s: float) -> str:
        wall = datetime.fromtimestamp(wall_s).astimezone().isoformat(timespec="microseconds")
        return f"{wall} {mono_s:.6f}"

    def data(self, direction: SpyDirection, data: bytes, mono_s: float, wall_s: float) -> None:
        """Log the bytes that crossed at ``mono_s`` (``time.monotonic()``) / ``wall_s``
        (``time.time()``): one line per frame or undecoded run they complete."""
        stamp = self._stamp(mono_s, wall_s)
        lines = []
        for piece in self._splitters[direction].feed(data):
            if piece.frame is None:
                self.undecoded_bytes[direction] += len(piece.raw)
                lines.append(f"{stamp} {direction.value} undecoded {len(piece.raw)} bytes: "
                             f"{piece.raw.hex(' ')}")
            else:
                self.frames[direction] += 1
                raw = f" raw={piece.raw.hex()}" if self.raw else ""
                lines.append(f"{stamp} {direction.value} {format_frame(piece.frame)}{raw}")
        if lines:
            self.stream.write("\n".join(lines) + "\n")

    def event(self, text: str, mono_s: float, wall_s: float) -> None:
        """Log something that is not bytes (open, close, an error), direction ``--``."""
        self.stream.write(f"{self._stamp(mono_s, wall_s)} -- {text}\n")

    def finish(self, mono_s: float, wall_s: float) -> None:
        """Log the bytes of frames left incomplete (at close), so no byte goes unreported."""
        stamp = self._stamp(mono_s, wall_s)
        for direction, splitter in self._splitters.items():
            rest = splitter.pending()
            if rest:
                self.undecoded_bytes[direction] += len(rest)
                self.stream.write(f"{stamp} {direction.value} incomplete {len(rest)} bytes at "
                                  f"close: {rest.hex(' ')}\n")
        self.stream.flush()
