"""Open a board link from a URL, as pyserial's ``serial_for_url``.

::

    open_transport("sim://?speedup=20")                       # the emulated board
    open_transport("/dev/ttyACM0")                            # a real board
    open_transport("serial:///dev/ttyACM0?baud=3000000")      # the same, spelled out
    open_transport("faulty+sim://?drop=0.01&flip=0.001&seed=7")
    open_transport("spy+/dev/ttyACM0?log=frames.log")         # every frame both ways, decoded
    open_transport("spy+faulty+sim://?log=-&delay=0.02")

The URL grammar and which option goes to which layer: :mod:`parolkit.transport.url`; the
schemes and their options: :mod:`parolkit.transport.schemes`; docs/transport.md.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from parolkit.transport.base import Transport
from parolkit.transport.options import TransportURLError
from parolkit.transport.url import TransportURL, parse_transport_url

__all__ = ["open_transport", "transport_for_url", "resolve_url", "SIM_URL"]

#: what ``None`` stands for: the emulated board in this process
SIM_URL = "sim://"


def transport_for_url(url: str | TransportURL | None, *,
                      defaults: Mapping[str, object] | None = None,
                      allowed_schemes: Iterable[str] | None = None,
                      **overrides: Any) -> Transport:
    """Build the transport ``url`` names, NOT opened yet (call ``open()`` or use ``with``).

    * ``url``: URL text, an already parsed :class:`TransportURL`, or None for ``sim://``.
    * ``overrides``: options as keywords (URL names such as ``speedup=20``, ``baud=...``; the
      old keywords ``homing_speedup`` and ``write_timeout_s`` too).  They replace what the URL
      says; one for a scheme the URL does not use is an error.  None values are ignored.
    * ``defaults``: options used only where the URL and ``overrides`` say nothing, silently
      skipped for schemes the URL does not use (e.g. ``{"baud": 3_000_000, "speedup": 20}``
      from a config file, whatever link the URL names).
    * ``allowed_schemes``: if given, the scheme names this caller accepts (e.g.
      ``{"serial"}`` for a port chosen by a remote client); any other raises.

    Raises :class:`~parolkit.transport.TransportURLError` (a ``TransportError`` and a
    ``ParolkitValueError``) for a bad URL, option or value.
    """
    parsed = resolve_url(url, allowed_schemes=allowed_schemes, defaults=defaults, **overrides)
    transport: Transport | None = None
    for layer in reversed(parsed.layers):
        cls = layer.scheme.load()
        kw = layer.keywords()
        if layer.scheme.wrapper:
            assert transport is not None
            transport = cls(transport, **kw)
        elif layer.scheme.takes_device:
            transport = cls(parsed.device, **kw)
        else:
            transport = cls(**kw)
    assert isinstance(transport, Transport)
    return transport


def open_transport(url: str | TransportURL | None, *,
                   defaults: Mapping[str, object] | None = None,
                   allowed_schemes: Iterable[str] | None = None,
                   **overrides: Any) -> Transport:
    """:func:`transport_for_url`, then ``open()``: the returned link is open.

    ``open_transport(None)`` is the emulated board (``sim://``); the old call forms
    ``open_transport(None, homing_speedup=20)``, ``open_transport("/dev/ttyACM0")`` and
    ``open_transport(port, baud=3_000_000)`` keep working.  Raises ``TransportError`` naming
    the link when it cannot be opened.
    """
    transport = transport_for_url(url, defaults=defaults, allowed_schemes=allowed_schemes,
                                  **overrides)
    transport.open()
    return transport


def resolve_url(url: str | TransportURL | None, *,
                defaults: Mapping[str, object] | None = None,
                allowed_schemes: Iterable[str] | None = None,
                **overrides: Any) -> TransportURL:
    """The checked URL :func:`transport_for_url` builds from (same arguments), without
    building anything: e.g. to refuse a link a remote client asked for before it is used."""
    if url is None:
        url = SIM_URL
    parsed = url if isinstance(url, TransportURL) else parse_transport_url(url)
    if allowed_schemes is not None:
        allowed = {str(s).lower() for s in allowed_schemes}
        refused = [s for s in parsed.schemes if s not in allowed]
        if refused:
            raise TransportURLError(
                f"{parsed.text!r} uses {', '.join(refused)}, which is not allowed here "
                f"(allowed: {', '.join(sorted(allowed)) or 'nothing'})")
    if overrides or defaults:
        parsed = parsed.with_options(overrides, defaults)
    return parsed
