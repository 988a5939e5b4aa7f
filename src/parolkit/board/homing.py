"""The stock firmware's homing sequence as a state machine (one step per loop pass).

Sequence (speeds in steps/s, sign = direction; targets are step counters after the zero):

1. J1, J2, J3 together: search at -2050 / -2550 / -2550 to the switch, zero; back off to
   +850 / +1050 / +1050 at 2050; approach at -750 to the switch, zero (the reference).
2. J1 -> 13500 (accel 4500), J2 -> 19588 (accel 3000), J3 -> 23020 (accel 5000): homed J1-J3.
3. J4: search +5550, zero; back off to -1550 at 4050; approach +4050, zero; -> -10200
   (accel 5500): homed J4.
4. J6: search -9550, zero; back off to +1550 at 4050; approach -8050, zero; -> +15900
   (accel 10500) to clear J5.
5. J5: search -5050, zero; back off to +1550 at 4050; approach -4050, zero.
6. J5 -> 8900 (pneumatic-gripper offset; 8035 for the SSG-48) and J6 -> 0 (accel 5500):
   homed J5, J6.
7. Every counter is overwritten with the standby counts; homed = 0xFF.

Limit switches sit at fixed physical positions (post-homing count frame):
J1 -3260, J2 -51588, J3 34885, J4 10200, J5 -8900, J6 32000 steps
(= -28.65, -145.09, +108.44, +143.44, -125.16, +180 degrees).  A switch reads "pressed"
everywhere beyond it in the search direction, so a search always ends.

The accelerated moves are trapezoids with the spec's acceleration; the firmware source does
not fix their cruise speed, the emulator uses each joint's stock maximum speed
(``RobotModel.max_speed_steps_s``).  ``speedup`` scales homing time only (motion during
homing runs ``speedup`` times faster; reported speeds are the real-time values).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

from parolkit.board.steppers import Stepper
from parolkit.errors import ParolkitValueError

__all__ = [
    "HomingSequence",
    "HomingPhase",
    "SWITCH_POSITIONS_STEPS",
    "HOMED_OFFSETS_STEPS",
    "SEARCH_SPEEDS_STEPS_S",
    "J5_OFFSET_PNEUMATIC",
    "J5_OFFSET_SSG48",
]

#: Standby counts written at the end of homing.
STANDBY_STEPS = (10240, -32000, 57905, 0, 0, 32000)
#: Search speeds, steps/s (sign = direction toward the switch).
SEARCH_SPEEDS_STEPS_S = (-2050, -2550, -2550, 5550, -5050, -9550)
#: J5 move after its reference: pneumatic gripper (stock default) and SSG-48.
J5_OFFSET_PNEUMATIC = 8900
J5_OFFSET_SSG48 = 8035
#: Counter value each joint sits at, relative to its switch, just before the standby overwrite.
HOMED_OFFSETS_STEPS = (13500, 19588, 23020, -10200, J5_OFFSET_PNEUMATIC, 0)
#: Physical switch positions (post-homing count frame) = standby - homed offset.
SWITCH_POSITIONS_STEPS = tuple(s - o for s, o in zip(STANDBY_STEPS, HOMED_OFFSETS_STEPS))


class HomingPhase(Enum):
    """Where the sequence is (for status displays and tests)."""

    IDLE = "idle"
    J123_REFERENCE = "J1-J3 search/back-off/approach"
    J123_MOVE = "J1-J3 move to offset"
    J4 = "J4"
    J6_CLEAR = "J6 reference and clearance move"
    J5_REFERENCE = "J5 reference"
    J56_MOVE = "J5/J6 final move"
    DONE = "done"


@dataclass
class _Seg:
    kind: str  # "search", "to", "accel"
    value: int  # speed (search), target counter (to, accel)
    speed: int = 0  # |speed| for "to"
    accel: float = 0.0  # for "accel"


def _s(speed: int) -> _Seg:
    return _Seg("search", speed)


def _t(target: int, speed: int) -> _Seg:
    return _Seg("to", target, speed)


def _a(target: int, accel: float) -> _Seg:
    return _Seg("accel", target, 0, accel)


class HomingSequence:
    """Runs the homing sequence on six :class:`Stepper` objects, one :meth:`step` per pass."""

    def __init__(
        self,
        steppers: Sequence[Stepper],
        *,
        max_speeds_steps_s: Sequence[float],
        j5_offset_steps: int = J5_OFFSET_PNEUMATIC,
    ) -> None:
        if len(steppers) != 6 or not all(isinstance(st, Stepper) for st in steppers):
            raise ParolkitValueError("steppers must be 6 Stepper objects (J1..J6)")
        if len(max_speeds_steps_s) != 6 or not all(v > 0 for v in max_speeds_steps_s):
            raise ParolkitValueError(
                f"max_speeds_steps_s must be 6 positive speeds, got {max_speeds_steps_s!r}")
        self._st = steppers
        self._vmax = tuple(float(v) for v in max_speeds_steps_s)
        self._j5_offset = int(j5_offset_steps)
        self.phase = HomingPhase.IDLE
        self._stages: list[tuple[HomingPhase, dict[int, list[_Seg]], int]] = []
        self._queues: dict[int, list[_Seg]] = {}
        self._after_mask = 0
        self.active = False

    # -------------------------------------------------------------------------------------
    def start(self) -> None:
        """(Re)start from the beginning."""
        self._stages = [
            (HomingPhase.J123_REFERENCE, {
                0: [_s(-2050), _t(850, 2050), _s(-750)],
                1: [_s(-2550), _t(1050, 2050), _s(-750)],
                2: [_s(-2550), _t(1050, 2050), _s(-750)],
            }, 0),
            (HomingPhase.J123_MOVE, {0: [_a(13500, 4500)], 1: [_a(19588, 3000)],
                                     2: [_a(23020, 5000)]}, 0xE0),
            (HomingPhase.J4, {3: [_s(5550), _t(-1550, 4050), _s(4050), _a(-10200, 5500)]}, 0x10),
            (HomingPhase.J6_CLEAR, {5: [_s(-9550), _t(1550, 4050), _s(-8050),
                                        _a(15900, 10500)]}, 0),
            (HomingPhase.J5_REFERENCE, {4: [_s(-5050), _t(1550, 4050), _s(-4050)]}, 0),
            (HomingPhase.J56_MOVE, {4: [_a(self._j5_offset, 5500)], 5: [_a(0, 5500)]}, 0x0C),
        ]
        self._next_stage()
        self.active = True
        for st in self._st:
            st.speed = 0
            st.stop_phase()

    def abort(self) -> None:
        """Stop homing and reset the state machine (motors stop where they are)."""
        was_active = self.active
        self.active = False
        self.phase = HomingPhase.IDLE
        self._stages = []
        self._queues = {}
        if was_active:
            for st in self._st:
                st.speed = 0
                st.stop_phase()

    def _next_stage(self) -> bool:
        if not self._stages:
            return False
        phase, queues, mask = self._stages.pop(0)
        self.phase = phase
        self._queues = {j: list(q) for j, q in queues.items()}
        self._after_mask = mask
        return True

    # -------------------------------------------------------------------------------------
    def step(self, dt: float) -> int:
        """One state-machine step covering ``dt`` seconds of (already time-scaled) motion.

        Returns homed bits to set (J1 = 0x80 ... J6 = 0x04; 0xFF when the sequence
        finished and the counters were overwritten with the standby counts).
        """
        if not self.active:
            return 0
        done_all = True
        for j, queue in self._queues.items():
            if not queue:
                continue
            if self._run_segment(j, queue[0], dt):
                queue.pop(0)
                self._st[j].speed = 0
            if queue:
                done_all = False
        if not done_all:
            return 0
        bits = self._after_mask
        if self._next_stage():
            return bits
        # sequence complete: standby counts, homed 0xFF
        for st, c in zip(self._st, STANDBY_STEPS):
            st.set_counter(c)
            st.speed = 0
        self.active = False
        self.phase = HomingPhase.DONE
        return 0xFF

    def _run_segment(self, j: int, seg: _Seg, dt: float) -> bool:
        st = self._st[j]
        if seg.kind == "search":
            switch = SWITCH_POSITIONS_STEPS[j]
            pressed = st.physical <= switch if seg.value < 0 else st.physical >= switch
            if pressed:
                st.set_counter(0)
                return True
            st.speed = seg.value
            st.run_toward(seg.value, dt, switch - st.offset)
            return False
        if seg.kind == "to":
            rem = seg.value - st.counter
            if rem == 0:
                return True
            v = seg.speed if rem > 0 else -seg.speed
            st.speed = v
            return st.run_toward(v, dt, seg.value)
        # accelerated move (trapezoid): speed limited by accel, cruise and stopping distance
        rem = seg.value - st.counter
        if rem == 0:
            return True
        direction = 1 if rem > 0 else -1
        v_now = abs(st.speed) if st.speed * direction > 0 else 0.0
        vel = min(self._vmax[j], v_now + seg.accel * dt, math.sqrt(2.0 * seg.accel * abs(rem)))
        vel = max(vel, 100.0)  # a stepper never creeps below its minimum speed
        st.speed = int(direction * vel)
        return st.run_toward(direction * vel, dt, seg.value)
