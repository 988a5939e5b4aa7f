"""The table of transport URL schemes: what each is, its options, and the class it builds.

Two kinds of scheme:

* a **base** ends the URL and is the link itself: ``sim://`` (the in-process emulator) and
  ``serial://DEVICE`` (a plain device path such as ``/dev/ttyACM0`` means the same);
* a **wrapper** is written ``name+`` in front of another URL and wraps that link:
  ``faulty+`` (fault injection) and ``spy+`` (frame log).

Every option name belongs to exactly one scheme (checked when this module is imported), so a
URL's single query string is unambiguous: each ``name=value`` goes to the scheme that owns
``name``.  Classes are named as ``"module:Class"`` and imported only when a link is built, so
this module (and URL checking in :mod:`parolkit.config`) costs no more than the stdlib.

Constructor convention: a base is called ``Class(**options)`` (``sim``) or
``Class(device, **options)`` (``serial``); a wrapper ``Class(inner, **options)``, with each
option passed under its :attr:`Option.keyword`.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from parolkit.transport.options import Option, OptionKind

__all__ = ["Scheme", "SCHEMES", "DEVICE_SCHEME", "owner_of", "base_schemes", "wrapper_schemes"]


@dataclass(frozen=True)
class Scheme:
    """One URL scheme: ``name``, whether it wraps another link, the options it takes."""

    name: str
    wrapper: bool
    summary: str
    target: str
    options: tuple[Option, ...]
    takes_device: bool = False

    @property
    def prefix(self) -> str:
        """How the scheme is written in a URL: ``faulty+`` or ``sim://``."""
        return f"{self.name}+" if self.wrapper else f"{self.name}://"

    def option(self, name: str) -> Option | None:
        """The option called ``name`` (URL name or keyword alias), or None."""
        for opt in self.options:
            if name == opt.name or name in opt.aliases:
                return opt
        return None

    @property
    def option_names(self) -> tuple[str, ...]:
        return tuple(opt.name for opt in self.options)

    def load(self) -> type:
        """Import and return the transport class (the only import of heavy modules)."""
        module, _, cls = self.target.partition(":")
        value = getattr(importlib.import_module(module), cls)
        assert isinstance(value, type)
        return value


_F, _I, _B, _C, _P = (OptionKind.FLOAT, OptionKind.INT, OptionKind.BOOL, OptionKind.CHOICE,
                      OptionKind.PATH)

SCHEMES: dict[str, Scheme] = {
    s.name: s
    for s in (
        Scheme(
            "sim", False, "the emulated board in this process",
            "parolkit.transport.emulated:EmulatorTransport",
            (
                Option("speedup", "homing_speedup", _F, "time scale of the homing sequence",
                       low=1.0, high=1000.0, aliases=("homing_speedup",)),
                Option("clock", "clock", _C, "realtime follows the wall clock; virtual stands "
                       "still until the owner calls emulator.advance()",
                       choices=("realtime", "virtual")),
                Option("step", "step_s", _F, "with clock=virtual: simulated seconds each frame "
                       "written advances the board (the controller's period: a board in lockstep "
                       "with the frames, deterministic)", low=0.0001, high=1.0, unit=" s"),
                Option("homed", "start_homed", _B,
                       "power up as if homing had just finished (not stock behaviour)"),
                Option("pass_hz", "pass_hz", _I, "simulated firmware main-loop passes per second",
                       low=1000, high=20000, unit=" Hz"),
            ),
        ),
        Scheme(
            "serial", False, "a serial device opened with pyserial",
            "parolkit.transport.serial_port:SerialTransport",
            (
                Option("baud", "baud", _I, "baud rate (nominal over USB CDC)",
                       low=300, high=12_000_000),
                Option("write_timeout", "write_timeout_s", _F,
                       "a write that takes longer fails", low=0.001, high=10.0, unit=" s",
                       aliases=("write_timeout_s",)),
                Option("exclusive", "exclusive", _B,
                       "lock the device so no other program opens it"),
            ),
            takes_device=True,
        ),
        Scheme(
            "faulty", True, "fault injection on the bytes both ways",
            "parolkit.transport.faulty:FaultyTransport",
            (
                Option("drop", "drop_rate", _F, "probability per byte that it is lost",
                       low=0.0, high=1.0),
                Option("flip", "corrupt_rate", _F,
                       "probability per byte that it arrives changed (one or more bits flipped)",
                       low=0.0, high=1.0),
                Option("delay", "delay_s", _F, "every byte arrives this much later",
                       low=0.0, high=10.0, unit=" s"),
                Option("silent", "silent", _B, "every byte from the board is swallowed"),
                Option("seed", "seed", _I, "seed of the random faults, to replay a run",
                       low=0, high=2**32 - 1),
            ),
        ),
        Scheme(
            "spy", True, "a decoded log of every frame both ways",
            "parolkit.transport.spy:SpyTransport",
            (
                Option("log", "log", _P, "where the frame log goes (a file is appended to)"),
                Option("raw", "raw", _B, "also show the bytes of every frame in hex"),
            ),
        ),
    )
}

#: the scheme a plain device path (``/dev/ttyACM0``, ``COM3``) stands for
DEVICE_SCHEME = "serial"


def base_schemes() -> list[Scheme]:
    return [s for s in SCHEMES.values() if not s.wrapper]


def wrapper_schemes() -> list[Scheme]:
    return [s for s in SCHEMES.values() if s.wrapper]


def owner_of(name: str) -> Scheme | None:
    """The scheme that owns option ``name`` (URL name or keyword alias), or None."""
    for scheme in SCHEMES.values():
        if scheme.option(name) is not None:
            return scheme
    return None


def _check_names_are_unique() -> None:
    seen: dict[str, str] = {}
    for scheme in SCHEMES.values():
        for opt in scheme.options:
            for name in (opt.name, *opt.aliases):
                if name in seen:
                    raise RuntimeError(f"option name {name!r} is used by both {seen[name]} and "
                                       f"{scheme.name}: URL options would be ambiguous")
                seen[name] = scheme.name


_check_names_are_unique()
