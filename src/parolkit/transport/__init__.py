"""Byte transports to a PAROL6 board: real serial port, in-process emulator, fault injection.

All implement :class:`parolkit.transport.base.Transport` and move the same codec bytes.

* :class:`SerialTransport` (``port``, ``baud=3_000_000``): pyserial, non-blocking reads, a
  write timeout, :class:`LinkLostError` when the device vanishes, reconnect with ``open()``.
* :class:`EmulatorTransport` (``emulator=None, **emulator_options``): the in-process
  :class:`parolkit.board.BoardEmulator`; ``.emulator`` gives tests and the simulator control.
* :class:`FaultyTransport` (``inner, drop_rate=, corrupt_rate=, delay_s=, silent=, seed=``).
* :class:`SpyTransport` (``inner, log="-", raw=False``): logs every frame both ways, decoded.
* :func:`open_transport` (``port: str | None, **kw``): ``None`` -> emulator, else serial.

Names are resolved lazily so that importing :mod:`parolkit.transport.base` stays cheap and
free of import cycles with :mod:`parolkit.board`.
"""

from __future__ import annotations

import importlib
from typing import Any

from parolkit.transport.base import LinkLostError, Transport, TransportError

__all__ = [
    "Transport",
    "TransportError",
    "LinkLostError",
    "SerialTransport",
    "EmulatorTransport",
    "FaultyTransport",
    "SpyTransport",
    "open_transport",
]

_LAZY = {
    "SerialTransport": "parolkit.transport.serial_port",
    "EmulatorTransport": "parolkit.transport.emulated",
    "FaultyTransport": "parolkit.transport.faulty",
    "SpyTransport": "parolkit.transport.spy",
    "open_transport": "parolkit.transport.factory",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'parolkit.transport' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
