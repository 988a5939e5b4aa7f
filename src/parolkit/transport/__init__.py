"""Byte transports to a PAROL6 board: real serial port, in-process emulator, fault injection,
frame log; opened by URL.

All implement :class:`parolkit.transport.base.Transport` and move the same codec bytes.

* :func:`open_transport` (``url, *, defaults=None, allowed_schemes=None, **overrides``):
  ``"sim://?speedup=20"``, ``"/dev/ttyACM0"``, ``"serial:///dev/ttyACM0?baud=3000000"``,
  ``"faulty+sim://?drop=0.01&flip=0.001"``, ``"spy+/dev/ttyACM0?log=frames.log"``;
  ``None`` means ``sim://``.  Returns an open link.  :func:`transport_for_url` builds it
  without opening; :func:`parse_transport_url` only checks the URL (stdlib only).

* :class:`SerialTransport` (``port``, ``baud=3_000_000``): pyserial, non-blocking reads, a
  write timeout, :class:`LinkLostError` when the device vanishes, reconnect with ``open()``.
* :class:`EmulatorTransport` (``emulator=None, **emulator_options``): the in-process
  :class:`parolkit.board.BoardEmulator`; ``.emulator`` gives tests and the simulator control.
* :class:`FaultyTransport` (``inner, drop_rate=, corrupt_rate=, delay_s=, silent=, seed=``).
* :class:`SpyTransport` (``inner, log="-", raw=False``): logs every frame both ways, decoded.

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
    "TransportURLError",
    "TransportURL",
    "SerialTransport",
    "EmulatorTransport",
    "FaultyTransport",
    "SpyTransport",
    "open_transport",
    "transport_for_url",
    "resolve_url",
    "parse_transport_url",
]

_LAZY = {
    "SerialTransport": "parolkit.transport.serial_port",
    "EmulatorTransport": "parolkit.transport.emulated",
    "FaultyTransport": "parolkit.transport.faulty",
    "SpyTransport": "parolkit.transport.spy",
    "TransportURLError": "parolkit.transport.options",
    "TransportURL": "parolkit.transport.url",
    "parse_transport_url": "parolkit.transport.url",
    "open_transport": "parolkit.transport.factory",
    "transport_for_url": "parolkit.transport.factory",
    "resolve_url": "parolkit.transport.factory",
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
