"""A fault-injecting wrapper around any transport (PC-side view of a bad link)."""

from __future__ import annotations

import time

from parolkit.board.faults import ByteFaultInjector, LinkFaults, faults_from_options
from parolkit.errors import ParolkitValueError
from parolkit.transport.base import Transport, TransportError

__all__ = ["FaultyTransport"]


class FaultyTransport(Transport):
    """Wraps ``inner`` and damages the bytes crossing it, in both directions.

    Keywords are :class:`parolkit.board.faults.LinkFaults` fields: ``drop_rate`` and
    ``corrupt_rate`` (probability per byte, 0..1), ``delay_s`` (0..10 s, wall clock),
    ``silent`` (every byte read is swallowed: the far end "stops answering"), plus ``seed``.
    Change them at run time with :meth:`set_faults`.  ``counters`` says what was done.
    """

    def __init__(self, inner: Transport, *, seed: int | None = None, **faults: object) -> None:
        if not isinstance(inner, Transport):
            raise ParolkitValueError(f"inner must be a Transport, got {type(inner).__name__}")
        self.inner = inner
        self.simulated = inner.simulated
        self.virtual_clock = inner.virtual_clock
        self.step_s = inner.step_s
        lf = faults_from_options(faults)
        self._tx = ByteFaultInjector(lf, seed=seed)
        self._rx = ByteFaultInjector(lf, seed=None if seed is None else seed + 1)

    def set_faults(self, faults: LinkFaults | None = None, **kw: object) -> None:
        """Replace the faults (a ``LinkFaults`` or its fields as keywords)."""
        if faults is None:
            faults = faults_from_options(kw)
        elif kw:
            raise ParolkitValueError("pass either a LinkFaults or keyword fields, not both")
        self._tx.set_faults(faults)
        self._rx.set_faults(faults)

    @property
    def faults(self) -> LinkFaults:
        return self._tx.faults

    @property
    def counters(self) -> dict[str, int]:
        return {
            "tx_dropped": self._tx.counters.dropped,
            "tx_corrupted": self._tx.counters.corrupted,
            "rx_dropped": self._rx.counters.dropped,
            "rx_corrupted": self._rx.counters.corrupted,
        }

    @property
    def description(self) -> str:
        return f"faulty+{self.inner.description}"

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def fileno(self) -> int | None:
        return self.inner.fileno()

    def open(self) -> None:
        self._tx.clear()
        self._rx.clear()
        self.inner.open()

    def close(self) -> None:
        self.inner.close()

    def _check_open(self) -> None:
        # checked here, not left to the inner link: with a delay or drop_rate=1 no byte may
        # reach it, and a closed link must still refuse the call
        if not self.inner.is_open:
            raise TransportError(f"{self.description}: the link is not open (call open())")

    def write(self, data: bytes) -> None:
        self._check_open()
        now = time.monotonic()
        self._tx.push(bytes(data), now)
        out = self._tx.pop(now)
        if out:  # with a delay nothing is due yet: read() flushes it later
            self.inner.write(out)

    def read(self) -> bytes:
        self._check_open()
        now = time.monotonic()
        # flush delayed outgoing bytes that became due
        out = self._tx.pop(now)
        if out:
            self.inner.write(out)
        data = self.inner.read()
        if self._rx.faults.silent:
            return b""
        if data:
            self._rx.push(data, now)
        return self._rx.pop(now)
