"""``open_transport``: one call that gives the controller its board link."""

from __future__ import annotations

from typing import Any

from parolkit.errors import ParolkitValueError
from parolkit.transport.base import Transport

__all__ = ["open_transport"]


def open_transport(port: str | None, **kw: Any) -> Transport:
    """Open a link: ``port=None`` -> in-process emulator (``kw`` = emulator options, e.g.
    ``homing_speedup``), otherwise a serial port (``kw``: ``baud``, ``write_timeout_s``).

    The returned transport is already open.  Raises ``TransportError`` when the port cannot
    be opened, ``ParolkitValueError`` for bad arguments.
    """
    if port is None:
        from parolkit.transport.emulated import EmulatorTransport

        t: Transport = EmulatorTransport(**kw)
    else:
        if not isinstance(port, str) or not port:
            raise ParolkitValueError(f"port must be a device path string or None, got {port!r}")
        from parolkit.transport.serial_port import SerialTransport

        t = SerialTransport(port, **kw)
    t.open()
    return t
