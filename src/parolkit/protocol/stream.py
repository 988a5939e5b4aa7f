"""Incremental frame parser: feed arbitrary chunks of bytes, get whole frames out.

The parser hunts for ``FF FF FF``, reads LEN and accepts a candidate only when

* LEN is the expected value (56 for status frames, 52 for command frames),
* the two last bytes are ``01 02``, and
* (``check_crc=True``, the default for status frames) the constant CRC byte is right.

A rejected candidate is dropped ONE byte at a time (never LEN bytes at once), so a real frame
that starts inside a damaged one is still found.  Every discarded byte and every rejected
candidate is counted in :class:`ParserStats`.

Limits (the link has no checksum, so no receiver can do better): a byte changed in place
inside a payload is accepted as sent, and a loss of exactly one frame's worth of bytes that
straddles a frame boundary splices the head of one frame onto the tail of the next.  The
controller guards against the consequences (every target passes the safety guard, and the
``xtr`` echo is compared with the command sent).

The buffer is bounded: it never holds more than one frame's worth of bytes beyond what is
needed to decide, so a stream of garbage cannot grow memory.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Generic, TypeVar

from parolkit.protocol.frames import (
    BOARD_CRC,
    COMMAND_LEN,
    END,
    PC_CRC,
    START,
    STATUS_LEN,
    CommandFrame,
    StatusFrame,
)

__all__ = ["ParserStats", "FrameParser", "StatusParser", "CommandParser"]

F = TypeVar("F", CommandFrame, StatusFrame)


@dataclass
class ParserStats:
    """Counters of one parser.  All monotonically increasing."""

    bytes_in: int = 0
    frames_ok: int = 0
    #: bytes discarded while hunting or after a rejected candidate
    bytes_dropped: int = 0
    #: candidates with a wrong LEN byte
    bad_len: int = 0
    #: candidates whose end bytes were not 01 02
    bad_end: int = 0
    #: candidates whose constant CRC byte was wrong (only when checked)
    bad_crc: int = 0

    @property
    def frames_rejected(self) -> int:
        return self.bad_len + self.bad_end + self.bad_crc

    def as_dict(self) -> dict[str, int]:
        return {
            "bytes_in": self.bytes_in,
            "frames_ok": self.frames_ok,
            "bytes_dropped": self.bytes_dropped,
            "bad_len": self.bad_len,
            "bad_end": self.bad_end,
            "bad_crc": self.bad_crc,
        }


class FrameParser(Generic[F]):
    """Generic stream parser; use :class:`StatusParser` or :class:`CommandParser`."""

    def __init__(self, frame_type: type[F], length: int, crc: int | None) -> None:
        self._type: type[F] = frame_type
        self._len = length
        self._size = 4 + length
        self._crc = crc
        self._buf = bytearray()
        self.stats = ParserStats()

    def reset(self) -> None:
        """Forget any partial frame (counters are kept)."""
        self.stats.bytes_dropped += len(self._buf)
        self._buf.clear()

    @property
    def pending(self) -> int:
        """Bytes buffered but not yet decided."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[F]:
        """Add bytes; return every whole, valid frame they complete (possibly none)."""
        return list(self.iter_feed(data))

    def iter_feed(self, data: bytes) -> Iterator[F]:
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"feed() needs bytes, got {type(data).__name__}")
        self.stats.bytes_in += len(data)
        buf = self._buf
        size = self._size
        if (not buf and len(data) == size and data[:3] == START and data[3] == self._len
                and data[size - 2:] == END and (self._crc is None or data[size - 3] == self._crc)):
            # the common case, fast: exactly one whole valid frame and nothing buffered
            self.stats.frames_ok += 1
            yield self._type.decode(bytes(data))
            return
        buf += data
        while True:
            start = buf.find(START)
            if start < 0:
                # keep a trailing FF or FF FF: it may be the beginning of a start sequence
                keep = 0
                if buf.endswith(b"\xff\xff"):
                    keep = 2
                elif buf.endswith(b"\xff"):
                    keep = 1
                drop = len(buf) - keep
                if drop:
                    self.stats.bytes_dropped += drop
                    del buf[:drop]
                return
            if start:
                self.stats.bytes_dropped += start
                del buf[:start]
            if len(buf) < 4:
                return
            if buf[3] != self._len:
                self.stats.bad_len += 1
                self._drop_one()
                continue
            if len(buf) < self._size:
                return
            if buf[self._size - 2 : self._size] != END:
                self.stats.bad_end += 1
                self._drop_one()
                continue
            if self._crc is not None and buf[self._size - 3] != self._crc:
                self.stats.bad_crc += 1
                self._drop_one()
                continue
            raw = bytes(buf[: self._size])
            del buf[: self._size]
            self.stats.frames_ok += 1
            yield self._type.decode(raw)

    def _drop_one(self) -> None:
        self.stats.bytes_dropped += 1
        del self._buf[:1]


class StatusParser(FrameParser[StatusFrame]):
    """PC-side parser of board -> PC frames (LEN 56; CRC byte 212 checked by default)."""

    def __init__(self, *, check_crc: bool = True) -> None:
        super().__init__(StatusFrame, STATUS_LEN, BOARD_CRC if check_crc else None)


class CommandParser(FrameParser[CommandFrame]):
    """Board-side parser of PC -> board frames (LEN 52).

    Like the stock firmware it does not check the CRC byte by default; unlike the firmware it
    also refuses a LEN other than 52 (the firmware would read a short frame at fixed offsets).
    """

    def __init__(self, *, check_crc: bool = False) -> None:
        super().__init__(CommandFrame, COMMAND_LEN, PC_CRC if check_crc else None)
