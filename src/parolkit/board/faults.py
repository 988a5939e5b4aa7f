"""Opt-in byte-level fault injection for a board link.

:class:`LinkFaults` describes what goes wrong; :class:`ByteFaultInjector` applies it to a
stream of bytes (one instance per direction).  Both the emulated board
(:class:`parolkit.board.BoardEmulator`) and :class:`parolkit.transport.FaultyTransport` use
it, so a test can damage the link on either end with the same knobs.

Rates are probabilities PER BYTE in ``0 .. 1``; ``delay_s`` holds every byte back for that
many seconds (emulator or wall time, whichever clock the owner uses).  Randomness comes from a
seeded :class:`random.Random` so a failing test can be replayed.
"""

from __future__ import annotations

import math
import random
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass

from parolkit.errors import ParolkitValueError

__all__ = ["LinkFaults", "ByteFaultInjector", "FaultCounters", "faults_from_options"]


def _check_rate(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParolkitValueError(f"{name} must be a number in 0..1, got {value!r}")
    v = float(value)
    if not 0.0 <= v <= 1.0 or math.isnan(v):
        raise ParolkitValueError(f"{name} = {value!r} is out of range 0..1 (a probability per byte)")
    return v


def _check_delay(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParolkitValueError(f"{name} must be a number of seconds in 0..10, got {value!r}")
    v = float(value)
    if not 0.0 <= v <= 10.0 or math.isnan(v):
        raise ParolkitValueError(f"{name} = {value!r} s is out of range 0..10 s")
    return v


def _check_silent(value: object) -> bool:
    if not isinstance(value, bool):
        raise ParolkitValueError(f"silent must be a bool, got {value!r}")
    return value


@dataclass(frozen=True)
class LinkFaults:
    """What goes wrong on a link.  The default (all zero) is a perfect link.

    * ``drop_rate``: probability that a byte is lost (0..1).
    * ``corrupt_rate``: probability that a byte is replaced by a different random byte (0..1).
    * ``delay_s``: every byte arrives this many seconds late (0..10 s).
    * ``silent``: the far end stops answering (the emulated board ignores every byte it
      receives; a :class:`~parolkit.transport.FaultyTransport` swallows every byte read).
    """

    drop_rate: float = 0.0
    corrupt_rate: float = 0.0
    delay_s: float = 0.0
    silent: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "drop_rate", _check_rate(self.drop_rate, "drop_rate"))
        object.__setattr__(self, "corrupt_rate", _check_rate(self.corrupt_rate, "corrupt_rate"))
        object.__setattr__(self, "delay_s", _check_delay(self.delay_s, "delay_s"))
        _check_silent(self.silent)

    @property
    def active(self) -> bool:
        """True when any fault is switched on."""
        return bool(self.drop_rate or self.corrupt_rate or self.delay_s or self.silent)


_FIELDS = ("drop_rate", "corrupt_rate", "delay_s", "silent")


def faults_from_options(options: Mapping[str, object]) -> LinkFaults:
    """``LinkFaults(**options)`` with a clear error for an unknown option name.

    The values are checked here (as :class:`LinkFaults` checks them, in the same order), so
    they reach it typed as its fields.
    """
    unknown = sorted(set(options) - set(_FIELDS))
    if unknown:
        raise ParolkitValueError(
            f"unknown fault option(s) {', '.join(unknown)}; allowed: {', '.join(_FIELDS)}")
    return LinkFaults(
        drop_rate=_check_rate(options.get("drop_rate", 0.0), "drop_rate"),
        corrupt_rate=_check_rate(options.get("corrupt_rate", 0.0), "corrupt_rate"),
        delay_s=_check_delay(options.get("delay_s", 0.0), "delay_s"),
        silent=_check_silent(options.get("silent", False)),
    )


@dataclass
class FaultCounters:
    """What an injector did so far (monotonic)."""

    bytes_in: int = 0
    dropped: int = 0
    corrupted: int = 0
    delayed: int = 0


class ByteFaultInjector:
    """Applies :class:`LinkFaults` to one direction of a byte stream.

    Call :meth:`push` with bytes and the current time (seconds, any monotonic clock), then
    :meth:`pop` with the current time to get the bytes that are due.  With no delay,
    ``pop`` returns everything pushed (minus dropped bytes) at once.
    """

    def __init__(self, faults: LinkFaults | None = None, *, seed: int | None = None) -> None:
        self.faults = faults or LinkFaults()
        self._rng = random.Random(seed)
        self._queue: deque[tuple[float, bytes]] = deque()
        self.counters = FaultCounters()

    def set_faults(self, faults: LinkFaults) -> None:
        if not isinstance(faults, LinkFaults):
            raise ParolkitValueError(f"faults must be a LinkFaults, got {type(faults).__name__}")
        self.faults = faults

    def clear(self) -> None:
        """Forget bytes still held back by a delay."""
        self._queue.clear()

    def push(self, data: bytes, now: float) -> None:
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise ParolkitValueError(f"data must be bytes, got {type(data).__name__}")
        f = self.faults
        self.counters.bytes_in += len(data)
        if f.drop_rate or f.corrupt_rate:
            out = bytearray()
            rnd = self._rng.random
            for b in data:
                if f.drop_rate and rnd() < f.drop_rate:
                    self.counters.dropped += 1
                    continue
                if f.corrupt_rate and rnd() < f.corrupt_rate:
                    b = (b + self._rng.randrange(1, 256)) & 0xFF  # always a different byte
                    self.counters.corrupted += 1
                out.append(b)
            data = bytes(out)
        if not data:
            return
        if f.delay_s:
            self.counters.delayed += len(data)
        self._queue.append((now + f.delay_s, bytes(data)))

    def pop(self, now: float) -> bytes:
        if not self._queue:
            return b""
        out = bytearray()
        while self._queue and self._queue[0][0] <= now:
            out += self._queue.popleft()[1]
        return bytes(out)

    @property
    def next_due(self) -> float | None:
        """When the next held-back chunk is due (None when nothing is held)."""
        return self._queue[0][0] if self._queue else None
