"""THE safety guard: every command frame the controller sends passes :meth:`SafetyGuard.check`.

The board enforces nothing (no limits, no watchdog, no E-stop action) and runs its last command
forever, so this is the only place where a bad frame can be stopped.  The guard never clamps or
edits a motion value: a frame that breaks a rule is REPLACED by a safe frame (hold still or
DISABLE) and the violation is returned so the controller can fail the command that produced it.

Every frame is a bounded commitment.  Motion goes out as GO TO (156) frames only.  The firmware
runs a GO TO as ``v = 0.5 v_ff + 50 (target - x)`` = ``50 (goal - x)`` with ``goal = target +
v_ff / 100`` (:func:`parolkit.robot.goto_goal`): the speed is proportional to the distance to
the goal and the joint never passes it.  A frame whose goal lies within ``vmax / 50`` (20 ms of
travel at the maximum speed, :func:`parolkit.robot.goto_reach_steps`) of every position the
joint may have when the frame arrives therefore (a) never makes the board run a joint faster
than its maximum, however late or early the frame arrives, and (b) leaves the joint within 20 ms
of travel of where it stands if no frame follows (the PC frozen, the controller and its stop
supervisor killed, the cable pulled).  Where the joint may be is the link record's
:meth:`~parolkit.controller.link.LinkHistory.window`: from the newest trusted reply and the
frames written since, by the order of events only (no timing assumption).  A JOG (123) frame
runs at its speed until the next frame, without bound: the controller sends JOG only with zero
speeds, and the start-up probe's one frame of +-1 step/s on one joint
(:class:`~parolkit.controller.integrity.BoardProbe`), always followed by a zero-speed one.

Rules, in order:

1. E-stop pressed or latched: DISABLE (102) every tick, whatever was asked.
2. Only known board codes are sent (100, 101, 102, 103, 123, 156, 255).
3. HOME (100) is never sent twice in a row (the board would restart homing).
4. JOG (123): every speed zero, except the probe's single +-1 step/s on one joint.
5. GO TO (156): only while where the board is can be known (a trusted reply in this link
   session, no homing running, no speed frame since); when homed, every target inside the
   published step limits.
6. GO TO bounded commitment: every joint's goal within its reach (``vmax / 50`` steps, plus
   :data:`ROUNDING_STEPS`) of both ends of the window the joint may be in.
7. A speed frame (123 with a non-zero speed) is always followed by a zero-speed 123 frame: if
   anything other than 123 or DISABLE follows it, that frame is replaced by the zero-speed
   frame for one tick.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from parolkit._frozen import quick_init
from parolkit.controller.link import LinkHistory
from parolkit.protocol.frames import BoardCommand, CommandFrame, GripperCommandBits, StatusFrame
from parolkit.robot import GOTO_GAIN_PER_S, JOINT_NAMES, RobotModel, goto_goal, goto_reach_steps

__all__ = ["GuardResult", "SafetyGuard", "ROUNDING_STEPS", "PROBE_SPEED_STEPS_S"]

_KNOWN = {int(c) for c in BoardCommand}
_ZERO6 = (0, 0, 0, 0, 0, 0)
#: Rule 6 allows this much (steps) beyond the reach: the firmware truncates ``50 (goal - x)``
#: towards zero, and goals are whole steps plus hundredths from the feed-forward.
ROUNDING_STEPS = 0.01
#: The one speed a JOG frame may carry: the start-up probe's (rule 4).
PROBE_SPEED_STEPS_S = 1


@quick_init
@dataclass(frozen=True)
class GuardResult:
    """The frame to send and, when the asked frame was replaced, why."""

    frame: CommandFrame
    violation: str | None = None
    #: True when the asked frame was replaced (violation or E-stop / zero-speed substitution)
    replaced: bool = False


class SafetyGuard:
    """Checks and, if needed, replaces outgoing frames.  Owned by the tick (no locking)."""

    def __init__(self, model: RobotModel, rate_hz: float) -> None:
        self.model = model
        self.period_s = 1.0 / rate_hz
        self._lo = tuple(int(lo) for lo, _ in model.limits_steps)
        self._hi = tuple(int(hi) for _, hi in model.limits_steps)
        self._vmax = tuple(float(v) for v in model.max_speed_steps_s)
        #: how far (steps) a goal may lie from the joint: vmax / 50
        self.reach = goto_reach_steps(self._vmax)
        #: counters (read by tests and the status object)
        self.replaced_frames = 0
        self.violations = 0
        self.last_violation: str | None = None
        #: the last goal_box: the link's box it was made from, and the result
        self._box_from: tuple[tuple[float, float], ...] | None = None
        self._box: tuple[tuple[float, float], ...] = ()

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

    def goal_box(self, link: LinkHistory, t_write: float) -> tuple[tuple[float, float], ...] | None:
        """Per joint, the goals (steps) rule 6 allows for a GO TO frame written at ``t_write``
        (s, the link record's clock); None when rule 5 refuses every GO TO now.  The motion
        activities choose their goals inside it, so their frames are the ones the guard passes."""
        box = link.goal_box(t_write, self.reach)
        if box is None:
            return None
        if box is not self._box_from:  # (the same box: the same answer, asked twice a tick)
            self._box = tuple((lo - ROUNDING_STEPS, hi + ROUNDING_STEPS) for lo, hi in box)
            self._box_from = box
        return self._box

    def _goto_violation(self, f: CommandFrame, link: LinkHistory, homed: bool, t_write: float) -> str | None:
        if homed:
            for j in range(6):
                p = f.positions[j]
                if not self._lo[j] <= p <= self._hi[j]:
                    return (f"{JOINT_NAMES[j]} target {p} steps is outside the limits "
                            f"{self._lo[j]}..{self._hi[j]} steps")
        box = self.goal_box(link, t_write)
        if box is None:
            if link.homing:
                return ("position commands (156) are refused while the board may be homing (until a "
                        "status frame shows every joint homed and still)")
            return ("position commands (156) are refused while the board's position is unknown (no "
                    "trusted status frame since it last moved on its own)")
        win = link.window(t_write)
        assert win is not None
        for j, g in enumerate(goto_goal(f.positions, f.speeds)):
            lo, hi = box[j]
            if not lo <= g <= hi:
                wlo, whi = win[j]
                far = max(abs(g - wlo), abs(g - whi))
                return (f"{JOINT_NAMES[j]} goal {g:.2f} steps (target {f.positions[j]}, feed-forward "
                        f"{f.speeds[j]} steps/s) is {far:.1f} steps from where the board may be "
                        f"({wlo:.1f}..{whi:.1f} steps): the board would start it at "
                        f"{far * GOTO_GAIN_PER_S:.0f} steps/s, above its maximum {self._vmax[j]:g} "
                        f"(a goal may lie {self.reach[j]:.1f} steps away)")
        return None

    def _violation(self, f: CommandFrame, link: LinkHistory, homed: bool, t_write: float) -> str | None:
        code = int(f.command)
        if code not in _KNOWN:
            return f"board command {code} is not one the controller may send"
        last = link.last
        if code == BoardCommand.HOME and last is not None and last.command == BoardCommand.HOME:
            return "HOME (100) may be sent in one frame only (the board would restart homing)"
        if code == BoardCommand.JOG:
            moving = [j for j in range(6) if f.speeds[j]]
            if moving and not (len(moving) == 1 and abs(f.speeds[moving[0]]) == PROBE_SPEED_STEPS_S):
                j = moving[0]
                return (f"{JOINT_NAMES[j]} speed {f.speeds[j]} steps/s in a JOG (123) frame: a JOG runs "
                        "without bound until the next frame, so motion goes out as GO TO (156) frames")
            return None
        if code == BoardCommand.GOTO:
            return self._goto_violation(f, link, homed, t_write)
        return None

    def check(self, frame: CommandFrame, link: LinkHistory, status: StatusFrame | None, *, estop: bool,
              homed: bool, t_write: float) -> GuardResult:
        """The frame to send this tick, given the link record ``link`` (the frames written so far
        and the trusted replies), the newest status frame (for the positions of a safe frame),
        the E-stop and homed state and ``t_write``, the time (link record's clock) the frame is
        written at.  Pure: the caller records the frame it writes (``link.sent``)."""
        res = self._decide(frame, link, status, estop, homed, t_write)
        if res.replaced:
            self.replaced_frames += 1
        return res

    def _decide(self, frame: CommandFrame, link: LinkHistory, status: StatusFrame | None, estop: bool,
                homed: bool, t_write: float) -> GuardResult:
        if estop:
            out = self.disable_frame(frame, status)
            return GuardResult(out, None, replaced=frame.command != BoardCommand.DISABLE)
        last = link.last
        if (
            last is not None
            and last.command == BoardCommand.JOG
            and any(last.speeds)
            and frame.command not in (BoardCommand.JOG, BoardCommand.DISABLE)
        ):
            return GuardResult(self.zero_speed_frame(frame, status), None, replaced=True)
        why = self._violation(frame, link, homed, t_write)
        if why is None:
            return GuardResult(frame)
        self.violations += 1
        self.last_violation = why
        if frame.command == BoardCommand.JOG:
            safe = self.zero_speed_frame(frame, status)
        else:
            safe = self.hold_frame(frame, status)
        return GuardResult(safe, why, replaced=True)

    def accepts_goto(self, positions: Sequence[int], speeds: Sequence[int], link: LinkHistory, *, homed: bool,
                     t_write: float) -> bool:
        """Would :meth:`check` pass this GO TO frame now (no E-stop)?"""
        frame = CommandFrame(command=BoardCommand.GOTO, positions=tuple(int(p) for p in positions),
                             speeds=tuple(int(v) for v in speeds))
        last = link.last
        if last is not None and last.command == BoardCommand.JOG and any(last.speeds):
            return False
        return self._goto_violation(frame, link, homed, t_write) is None
