"""THE safety guard: every command frame the controller sends passes :meth:`SafetyGuard.check`.

The board enforces nothing (no limits, no watchdog, no E-stop action), so this is the only
place where a bad frame can be stopped.  The guard never clamps or edits a motion value: a
frame that breaks a rule is REPLACED by a safe frame (hold still, zero speed or DISABLE) and
the violation is returned so the executor can fail the command that produced it.

Rules, in order:

1. E-stop pressed or latched: DISABLE (102) every tick, whatever was asked.
2. Only known board codes are sent (100, 101, 102, 103, 123, 156, 255).
3. HOME (100) is never sent twice in a row (the board would restart homing).
4. GO TO (156): only when homed; every target inside the published step limits; every
   feed-forward speed within the maximum joint speed; the target may not lie further from the
   measured position than ``max_lead_ticks`` ticks of travel at maximum speed (the board's
   P loop would otherwise race there at up to 50,000 steps/s; the allowance grows by one tick
   for every tick the newest status frame is old), and no target may move more than two ticks
   of maximum-speed travel from the previous 156 target.
5. JOG (123): every |speed| within the maximum joint speed (the maximum JOG speed while not
   homed); when homed, no joint may reach its limit within ``lookahead_ticks`` ticks at the
   commanded speed.
6. A speed stream (123 with a non-zero speed) is always ended by a zero-speed 123 frame: if
   anything other than 123 or DISABLE follows it, that frame is replaced by the zero-speed
   frame for one tick.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from parolkit.protocol.frames import BoardCommand, CommandFrame, GripperCommandBits, StatusFrame
from parolkit.robot import JOINT_NAMES, RobotModel

__all__ = ["GuardResult", "SafetyGuard"]

_KNOWN = {int(c) for c in BoardCommand}
_ZERO6 = (0, 0, 0, 0, 0, 0)


@dataclass(frozen=True)
class GuardResult:
    """The frame to send and, when the asked frame was replaced, why."""

    frame: CommandFrame
    violation: str | None = None
    #: True when the asked frame was replaced (violation or E-stop / zero-speed substitution)
    replaced: bool = False


class SafetyGuard:
    """Checks and, if needed, replaces outgoing frames.  Owned by the loop thread."""

    def __init__(
        self,
        model: RobotModel,
        rate_hz: float,
        *,
        lookahead_ticks: float = 3.0,
        max_lead_ticks: float = 10.0,
    ) -> None:
        self.model = model
        self.period_s = 1.0 / rate_hz
        self._lo = tuple(int(lo) for lo, _ in model.limits_steps)
        self._hi = tuple(int(hi) for _, hi in model.limits_steps)
        self._vmax = tuple(float(v) for v in model.max_speed_steps_s)
        self._vjog = tuple(float(v) for v in model.max_jog_speed_steps_s)
        self.lookahead_ticks = lookahead_ticks
        self.max_lead_ticks = max_lead_ticks
        self._last: CommandFrame | None = None
        #: counters (read by tests and the status object)
        self.replaced_frames = 0
        self.violations = 0
        self.last_violation: str | None = None

    # ---- safe frames ----

    @staticmethod
    def disable_frame(base: CommandFrame, status: StatusFrame | None) -> CommandFrame:
        pos = status.positions if status is not None else base.positions
        return replace(
            base, positions=pos, speeds=_ZERO6, command=BoardCommand.DISABLE,
            gripper_command=base.gripper_command | GripperCommandBits.ESTOP,
            gripper_mode=0,
        )

    @staticmethod
    def hold_frame(base: CommandFrame, status: StatusFrame | None) -> CommandFrame:
        pos = status.positions if status is not None else base.positions
        return replace(base, positions=pos, speeds=_ZERO6, command=BoardCommand.IDLE, gripper_mode=0)

    @staticmethod
    def zero_speed_frame(base: CommandFrame, status: StatusFrame | None) -> CommandFrame:
        pos = status.positions if status is not None else base.positions
        return replace(base, positions=pos, speeds=_ZERO6, command=BoardCommand.JOG, gripper_mode=0)

    # ---- the check ----

    def _violation(self, f: CommandFrame, status: StatusFrame | None, homed: bool,
                   status_age_ticks: int) -> str | None:
        code = int(f.command)
        if code not in _KNOWN:
            return f"board command {code} is not one the controller may send"
        if code == BoardCommand.HOME and self._last is not None and self._last.command == BoardCommand.HOME:
            return "HOME (100) may be sent in one frame only (the board would restart homing)"
        if code == BoardCommand.GOTO:
            if not homed:
                return "position commands (156) are refused until the robot is homed"
            for j in range(6):
                p = f.positions[j]
                if not self._lo[j] <= p <= self._hi[j]:
                    return (
                        f"{JOINT_NAMES[j]} target {p} steps is outside the limits "
                        f"{self._lo[j]}..{self._hi[j]} steps"
                    )
                v = f.speeds[j]
                if abs(v) > self._vmax[j]:
                    return (
                        f"{JOINT_NAMES[j]} speed {v} steps/s exceeds the maximum "
                        f"{self._vmax[j]:g} steps/s"
                    )
            last = self._last
            if last is not None and last.command == BoardCommand.GOTO:
                for j in range(6):
                    step = abs(f.positions[j] - last.positions[j])
                    allowed = self._vmax[j] * self.period_s * 2.0 + 2
                    if step > allowed:
                        return (
                            f"{JOINT_NAMES[j]} target moves {step} steps in one tick (at most "
                            f"{allowed:.0f} steps = 2 ticks at maximum speed): the board would jump"
                        )
            if status is not None:
                ticks = self.max_lead_ticks + max(0, status_age_ticks)
                for j in range(6):
                    lead = abs(f.positions[j] - status.positions[j])
                    allowed = self._vmax[j] * self.period_s * ticks
                    if lead > allowed:
                        return (
                            f"{JOINT_NAMES[j]} target is {lead} steps from the measured position "
                            f"(at most {allowed:.0f} steps = {ticks:g} ticks at maximum speed): "
                            f"the board would jump"
                        )
        elif code == BoardCommand.JOG:
            vlim = self._vmax if homed else self._vjog
            for j in range(6):
                v = f.speeds[j]
                if abs(v) > vlim[j]:
                    kind = "maximum" if homed else "maximum jog (not homed)"
                    return f"{JOINT_NAMES[j]} speed {v} steps/s exceeds the {kind} {vlim[j]:g} steps/s"
            if homed and status is not None:
                horizon = self.period_s * self.lookahead_ticks
                for j in range(6):
                    v = f.speeds[j]
                    if v == 0:
                        continue
                    ahead = status.positions[j] + v * horizon
                    if (v > 0 and ahead > self._hi[j]) or (v < 0 and ahead < self._lo[j]):
                        side = "upper" if v > 0 else "lower"
                        bound = self._hi[j] if v > 0 else self._lo[j]
                        return (
                            f"{JOINT_NAMES[j]} at {status.positions[j]} steps moving {v} steps/s "
                            f"would pass its {side} limit {bound} steps"
                        )
        return None

    def check(
        self,
        frame: CommandFrame,
        status: StatusFrame | None,
        *,
        estop: bool,
        homed: bool,
        status_age_ticks: int = 0,
    ) -> GuardResult:
        """The frame to send this tick.  ``status`` is the latest status frame (or None),
        received ``status_age_ticks`` ticks ago (a late link widens the lead allowance)."""
        if estop:
            out = self.disable_frame(frame, status)
            res = GuardResult(out, None, replaced=frame.command != BoardCommand.DISABLE)
        else:
            last = self._last
            if (
                last is not None
                and last.command == BoardCommand.JOG
                and any(last.speeds)
                and frame.command not in (BoardCommand.JOG, BoardCommand.DISABLE)
            ):
                res = GuardResult(self.zero_speed_frame(frame, status), None, replaced=True)
            else:
                why = self._violation(frame, status, homed, status_age_ticks)
                if why is None:
                    res = GuardResult(frame)
                else:
                    self.violations += 1
                    self.last_violation = why
                    if frame.command == BoardCommand.JOG:
                        safe = self.zero_speed_frame(frame, status)
                    else:
                        safe = self.hold_frame(frame, status)
                    res = GuardResult(safe, why, replaced=True)
        if res.replaced:
            self.replaced_frames += 1
        self._last = res.frame
        return res
