"""In-process link to an emulated PAROL6 board (the simulated robot)."""

from __future__ import annotations

from typing import Any

from parolkit.board.emulator import BoardEmulator, ClockMode
from parolkit.errors import ParolkitValueError
from parolkit.transport.base import LinkLostError, Transport, TransportError

__all__ = ["EmulatorTransport"]


class EmulatorTransport(Transport):
    """A :class:`Transport` whose far end is a :class:`BoardEmulator` in this process.

    ``EmulatorTransport()`` creates an emulator with ``emulator_options`` (keywords of
    :class:`BoardEmulator`, e.g. ``homing_speedup=20``); or pass an existing ``emulator``.
    :meth:`open` starts the emulator's real-time loop (unless it uses the virtual clock, in
    which case the test advances it).  :attr:`emulator` is the board, for control: press the
    E-stop, unplug, inject faults.  Bytes go through the same codec as a serial link.

    ``step_s`` (with ``clock="virtual"``): every frame written advances the board by exactly
    this much simulated time (the controller's period): a board in lockstep with the frames,
    whose motion depends on the frames alone and not on when the PC's ticks happened to run.
    Deterministic: the same frames give the same status frames, step for step (what a replay
    compared tick by tick with its recording needs; a real board runs on its own clock).

    While the emulator is unplugged, :meth:`read` and :meth:`write` raise
    :class:`LinkLostError`; after ``emulator.replug()`` call :meth:`open` (or
    :meth:`reconnect`) again, exactly as with a real port.
    """

    simulated = True

    def __init__(self, emulator: BoardEmulator | None = None, *, step_s: float | None = None,
                 **emulator_options: Any) -> None:
        if emulator is not None and emulator_options:
            raise ParolkitValueError(
                "pass either an existing emulator or emulator options, not both "
                f"(got options {sorted(emulator_options)})")
        if emulator is not None and not isinstance(emulator, BoardEmulator):
            raise ParolkitValueError(
                f"emulator must be a BoardEmulator, got {type(emulator).__name__}")
        self.emulator = emulator if emulator is not None else BoardEmulator(**emulator_options)
        if step_s is not None:
            if isinstance(step_s, bool) or not isinstance(step_s, (int, float)) or not 1e-4 <= step_s <= 1.0:
                raise ParolkitValueError(f"step must be a number of seconds in 0.0001..1, got {step_s!r}")
            if self.emulator.clock is not ClockMode.VIRTUAL:
                raise ParolkitValueError(
                    "step (simulated seconds per frame) needs clock=virtual: a real-time board "
                    "follows the wall clock, not the frames")
        self.step_s = step_s
        self.virtual_clock = self.emulator.clock is ClockMode.VIRTUAL
        self._open = False
        self._owns_loop = False

    @property
    def description(self) -> str:
        return "emulated board"

    @property
    def is_open(self) -> bool:
        return self._open

    def open(self) -> None:
        if not self.emulator.plugged:
            raise TransportError("cannot open the emulated board: it is unplugged")
        if self.emulator.clock is ClockMode.REALTIME and not self.emulator.running:
            self.emulator.start()
            self._owns_loop = True
        self._open = True

    def close(self) -> None:
        self._open = False
        if self._owns_loop:
            self.emulator.stop()
            self._owns_loop = False

    def _check(self) -> None:
        if not self._open:
            raise TransportError("emulated board link is not open (call open())")
        if not self.emulator.plugged:
            self._open = False
            raise LinkLostError("emulated board was unplugged")

    def write(self, data: bytes) -> None:
        self._check()
        try:
            self.emulator.write(data)
            if self.step_s is not None:
                self.emulator.advance(self.step_s)
        except LinkLostError:
            self._open = False
            raise

    def read(self) -> bytes:
        self._check()
        try:
            return self.emulator.read()
        except LinkLostError:
            self._open = False
            raise
