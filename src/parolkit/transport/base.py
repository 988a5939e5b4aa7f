"""The byte-transport interface every board link implements.

Shaped like python-can's bus: one abstract class, concrete links (a real serial port, the
in-process emulator, a fault-injecting wrapper), all moving the same codec bytes.

Contract:

* :meth:`write` never blocks for long (a real port uses a write timeout) and sends all bytes
  or raises :class:`TransportError`.
* :meth:`read` is non-blocking: it returns every byte received so far (``b""`` when none).
* A lost link (cable pulled, emulator "unplugged", port vanished) raises
  :class:`LinkLostError` from :meth:`read` / :meth:`write`; the owner may call :meth:`open`
  again to reconnect (``reconnect()`` does close + open).
* Transports are context managers.
"""

from __future__ import annotations

import abc

from parolkit.errors import ParolkitError

__all__ = ["Transport", "TransportError", "LinkLostError"]


class TransportError(ParolkitError):
    """A transport could not be opened or used; the message says which port and why."""


class LinkLostError(TransportError):
    """The link went away while in use (unplugged cable, closed pty, vanished device)."""


class Transport(abc.ABC):
    """Abstract byte link to a PAROL6 board (real or emulated)."""

    #: True for links to an emulated board
    simulated: bool = False
    #: True when the far end is a board on a virtual clock (its time stands still between the
    #: caller's steps: a reply read in a tick was produced in that tick's time)
    virtual_clock: bool = False
    #: simulated seconds each frame written runs the board (a simulated board in lockstep with
    #: the frames, ``sim://?clock=virtual&step=...``; the controller then schedules trajectories
    #: on its ticks); None for a board on its own clock.  Wrappers pass on their inner link's.
    step_s: float | None = None

    @property
    @abc.abstractmethod
    def description(self) -> str:
        """Human-readable name, e.g. ``/dev/ttyACM0 @ 3000000`` or ``emulated board``."""

    @property
    @abc.abstractmethod
    def is_open(self) -> bool: ...

    @abc.abstractmethod
    def open(self) -> None:
        """Open (or re-open) the link. Raises :class:`TransportError` with the reason."""

    @abc.abstractmethod
    def close(self) -> None:
        """Close the link; safe to call twice."""

    @abc.abstractmethod
    def write(self, data: bytes) -> None:
        """Send bytes. Raises :class:`LinkLostError` when the link is gone."""

    @abc.abstractmethod
    def read(self) -> bytes:
        """Every byte received so far, without blocking (``b""`` if none)."""

    def fileno(self) -> int | None:
        """The operating-system file descriptor of the open link, or None when it has none
        (the in-process emulator) or is closed.  The controller hands a duplicate to its stop
        supervisor (:mod:`parolkit.controller.supervisor`), which writes the stop frame if the
        controller dies."""
        return None

    def reconnect(self) -> None:
        self.close()
        self.open()

    def __enter__(self) -> Transport:
        if not self.is_open:
            self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
