"""The robot's safety state as a value: E-stop, enable, faults, the board link's and the stop
supervisor's losses.

:class:`SafetyState` is frozen; every event is a method that returns the next state (pure
transitions, one owner: the controller core, which also carries out what an event implies for
the running commands, e.g. cancelling them).  What the state asks of this tick's frame is
:meth:`SafetyState.frame_code`: a DISABLE still owed (it goes out before anything else, even
when an ENABLE arrived in the same tick), an ENABLE / CLEAR_ERROR waiting for the running
command to end, or DISABLE every tick while disabled.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from parolkit.protocol.frames import BoardCommand, IOBits, StatusFrame

__all__ = ["SafetyState"]


@dataclass(frozen=True, slots=True)
class SafetyState:
    """See the module docstring.  ``error`` is the latched error (GET_STATUS ``ERROR=``);
    ``disabled_reason`` why the robot is disabled when it was not the user's DISABLE."""

    estop_latched: bool = False
    #: the hardware E-stop as debounced from the status frames (see :meth:`hardware_estop`)
    estop_pressed: bool = False
    enabled: bool = True
    error: str | None = None
    disabled_reason: str | None = None
    #: a DISABLE not yet written; and the tick whose frame paid it (a safety command that
    #: arrives while that tick's frame is made recomposes it: it must stay DISABLE)
    disable_owed: bool = False
    disable_paid: int = -1
    #: ENABLE (101) / CLEAR_ERROR (103) waiting for the running command to end (sent mid-move,
    #: the board zeroes every speed at once, and 103 aborts a homing)
    pending_code: int | None = None
    #: the stop supervisor is gone (how): motion is refused until a new one is ready
    supervisor_missing: str | None = None
    #: the E-stop bit of the previous new status frame, raw, and its IO byte
    estop_raw_prev: bool = False
    io_prev: int | None = None

    # ------------------------------------------------------------------ events

    def estop(self) -> SafetyState:
        """ESTOP or the hardware E-stop: DISABLE every tick, latched until released + ENABLE."""
        return replace(self, estop_latched=True, disable_owed=True, pending_code=self._no_enable())

    def enable(self) -> SafetyState:
        """ENABLE (the hardware E-stop released): the board gets 101 once the running command ends."""
        return replace(self, estop_latched=False, enabled=True, error=None, disabled_reason=None,
                       pending_code=int(BoardCommand.ENABLE))

    def disable(self) -> SafetyState:
        """DISABLE (the user's)."""
        return replace(self, enabled=False, disable_owed=True, pending_code=self._no_enable())

    def fault(self, error: str, disabled_reason: str) -> SafetyState:
        """Motion nobody commanded: disabled with the reason, ENABLE required."""
        return replace(self, enabled=False, disable_owed=True, error=error, disabled_reason=disabled_reason,
                       pending_code=self._no_enable())

    def supervisor_stopped(self, text: str) -> SafetyState:
        """The stop supervisor disabled the board on its own (the controller stood still)."""
        return replace(self.disable(), error=text)

    def board_found_disabled(self, reason: str) -> SafetyState:
        """The start-up probe found the board disabled (no frame owed: it is disabled already)."""
        return replace(self, enabled=False, error=reason, disabled_reason=reason)

    def clear_error(self) -> SafetyState:
        return replace(self, error=None, pending_code=int(BoardCommand.CLEAR_ERROR))

    def link_lost(self, reason: str) -> SafetyState:
        return replace(self, error=reason)

    def supervisor_lost(self, what: str) -> SafetyState:
        return replace(self, supervisor_missing=what,
                       error=f"{what}: motion stopped, refused until a new stop supervisor is ready")

    def supervisor_ready(self) -> SafetyState:
        """A new stop supervisor is ready: motion is accepted again; the error of the loss stays
        latched, saying a new one took over, until cleared."""
        what = self.supervisor_missing
        error = self.error
        if what is not None and error is not None and error.startswith(what):
            error = f"{what}: motion was stopped; a new stop supervisor is ready"
        return replace(self, supervisor_missing=None, error=error)

    def _no_enable(self) -> int | None:
        """An ENABLE still waiting is void once the robot is disabled or E-stopped again."""
        return None if self.pending_code == BoardCommand.ENABLE else self.pending_code

    # ------------------------------------------------------------------ the hardware E-stop

    def hardware_estop(self, status: StatusFrame, outputs_io: int) -> tuple[SafetyState, bool]:
        """The E-stop input of a new status frame (IO bit 0x08, 0 = pressed); returns the next
        state and whether it was pressed just now (the caller latches the E-stop).

        The link has no checksum, so a frame showing "pressed" may be a corrupted IO byte.
        Pressed counts at once (the next frame written is DISABLE) when the IO byte equals the
        previous frame's with only the E-stop bit cleared and the outputs echo what was
        commanded (``outputs_io``: the OUT1/OUT2 bits): a press changes exactly that bit, while
        a corrupted byte is a random other value (1 in 255 corrupted IO bytes looks like a
        press and latches: the safe side).  Any other "pressed" byte needs a second frame in a
        row.  Release always needs two frames in a row (a corrupted byte must not let an
        ENABLE through)."""
        raw = status.estop_pressed
        if raw:
            prev = self.io_prev
            quick = (prev is not None and bool(prev & IOBits.ESTOP) and status.io == (prev & ~IOBits.ESTOP)
                     and (status.io & (IOBits.OUT1 | IOBits.OUT2)) == outputs_io)
            pressed = self.estop_pressed or quick or self.estop_raw_prev
        else:
            pressed = self.estop_pressed and self.estop_raw_prev
        now_pressed = pressed and not self.estop_pressed
        if pressed == self.estop_pressed and raw == self.estop_raw_prev and status.io == self.io_prev:
            return self, now_pressed  # (nothing changed: most frames)
        return replace(self, estop_pressed=pressed, estop_raw_prev=raw, io_prev=status.io), now_pressed

    # ------------------------------------------------------------------ this tick's frame

    def frame_code(self, tick: int, *, idle: bool) -> tuple[SafetyState, int | None]:
        """What the safety state asks of tick ``tick``'s frame: DISABLE (E-stop, a DISABLE owed
        or already paid by this tick, or disabled), a waiting ENABLE / CLEAR_ERROR once nothing
        runs (``idle``), or None: the running command decides."""
        if self.estop_latched or self.disable_owed or self.disable_paid == tick:
            nxt = replace(self, disable_owed=False, disable_paid=tick) if self.disable_owed else self
            return nxt, int(BoardCommand.DISABLE)
        if self.pending_code is not None and idle:
            return replace(self, pending_code=None), self.pending_code
        if not self.enabled:
            return self, int(BoardCommand.DISABLE)
        return self, None

    # ------------------------------------------------------------------ admission

    @property
    def blocked(self) -> bool:
        """E-stop latched or pressed: DISABLE every tick."""
        return self.estop_latched or self.estop_pressed

    def refusal(self, *, motion: bool) -> str | None:
        """Why a command must be refused now (``motion``: it moves the robot or homes it);
        None: the safety state lets it in."""
        if self.estop_latched:
            return "E-stop latched: release it and send ENABLE"
        if not self.enabled:
            return self.disabled_reason or "robot is disabled: send ENABLE first"
        if motion and self.supervisor_missing is not None:
            return f"motion refused: {self.supervisor_missing}; a new one is starting"
        return None
