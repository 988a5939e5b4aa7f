"""Stepper-motor model of one PAROL6 joint as the board drives it.

The stock firmware polls its steppers in a free-running loop and emits at most one microstep
per motor per pass.  Python cannot run a loop at tens of kHz, so the emulator integrates the
same behaviour at a fixed simulated pass rate (``pass_hz``, >= 1 kHz): each pass adds
``speed * dt`` to a fractional accumulator and moves the integer step counter by the whole
steps in it.  Over any interval ``steps moved = speed x time`` to within one step, which is
what the real board achieves (its only error is the sub-step phase).

Two positions exist:

* ``counter``: the open-loop step counter the board reports (reset by homing),
* ``physical``: where the joint really is, in the post-homing count frame (standby =
  ``[10240, -32000, 57905, 0, 0, 32000]``).  ``physical = counter + offset``.  The limit
  switches sit at fixed physical positions; homing finds them and so makes counter and
  physical agree.
"""

from __future__ import annotations

from parolkit.robot import FIRMWARE_SPEED_CLAMP_STEPS_S as SPEED_CLAMP_STEPS_S

__all__ = ["Stepper", "SPEED_CLAMP_STEPS_S"]


def clamp_speed(v: float) -> int:
    """Firmware speed clamp (the board does clamp; this is stock behaviour, not ours)."""
    v = int(v)
    if v > SPEED_CLAMP_STEPS_S:
        return SPEED_CLAMP_STEPS_S
    if v < -SPEED_CLAMP_STEPS_S:
        return -SPEED_CLAMP_STEPS_S
    return v


class Stepper:
    """One joint's stepper: integer counter, last set speed (steps/s), sub-step phase."""

    __slots__ = ("counter", "speed", "offset", "_acc")

    def __init__(self, physical: int = 0) -> None:
        #: open-loop step counter reported to the PC, steps
        self.counter: int = 0
        #: last speed set on the stepper, steps/s (what the board reports)
        self.speed: int = 0
        #: physical - counter, steps
        self.offset: int = int(physical)
        self._acc: float = 0.0

    @property
    def physical(self) -> int:
        """True joint position in the post-homing count frame, steps."""
        return self.counter + self.offset

    def run(self, speed: float, dt: float) -> int:
        """Step at ``speed`` (steps/s) for ``dt`` seconds; returns the whole steps moved."""
        acc = self._acc + speed * dt
        n = int(acc)
        self._acc = acc - n
        self.counter += n
        return n

    def run_toward(self, speed: float, dt: float, target_counter: int) -> bool:
        """Step at ``speed`` for ``dt`` but never past ``target_counter``; True once there."""
        if self.counter == target_counter:
            self._acc = 0.0
            return True
        acc = self._acc + speed * dt
        n = int(acc)
        rem = target_counter - self.counter
        if (rem > 0 and n >= rem) or (rem < 0 and n <= rem):
            self.counter = target_counter
            self._acc = 0.0
            return True
        self._acc = acc - n
        self.counter += n
        return False

    def set_counter(self, value: int) -> None:
        """Overwrite the counter without moving the joint (homing zero / standby counts)."""
        self.offset += self.counter - int(value)
        self.counter = int(value)
        self._acc = 0.0

    def stop_phase(self) -> None:
        """Forget the sub-step phase (a stopped motor)."""
        self._acc = 0.0
