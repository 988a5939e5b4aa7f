"""THE safety guard: every command frame the controller sends passes :meth:`SafetyGuard.check`.

The board enforces nothing (no limits, no watchdog, no E-stop action), so this is the only
place where a bad frame can be stopped.  The guard never clamps or edits a motion value: a
frame that breaks a rule is REPLACED by a safe frame (hold still, zero speed or DISABLE) and
the violation is returned so the executor can fail the command that produced it.

What the board does with a GO TO (156) frame (docs/board-emulator.md, as the firmware): on every
pass of its main loop it sets ``v = 0.5 v_ff + 50 (target - position)`` steps/s
(:data:`~parolkit.robot.GOTO_FF_GAIN`, :data:`~parolkit.robot.GOTO_GAIN_PER_S`).  The fastest
it runs during a frame is therefore the speed it STARTS the frame at (:func:`goto_start_speed`
from the position it has when the frame arrives); after that the speed decays as
``exp(-50 t)`` toward the frame's goal (:func:`goto_position_after`).  A target stepping
``v x period`` every tick makes the board start each tick at 1.27 v (at 100 Hz), which is why
the planners keep position-tracked streams at :func:`parolkit.robot.goto_tracking_factor` of
the maximum speed.

Where the board is when a frame arrives is predicted from the frames the guard let through
and the time between them (the firmware's P loop, exactly), anchored on the status frames:
a status frame answers a frame and carries the board's position as that frame arrived, so it
is matched to the sent frame whose predicted arrival position it is closest to (a late or
lost reply does not shift the anchor), and the prediction is re-run from it whenever the
board was not running a GO TO before that frame (at rest, jogging: exact).  Within a GO TO
stream the replies only confirm it: where the board gets to depends on when the frames
reach it, and the guard judges every frame as delivered on schedule (see Time), so that its
verdict depends on the frames and the loop's timing alone, not on the link's delivery jitter.
When two replies in a row match no sent frame (the board did not follow: disabled behind the
controller's back, a lost frame, start-up; one such reply is a corrupted one and is ignored),
the prediction is uncertain and both "it followed the last frame" and "it has not moved since
the reply" are checked; the worse one decides.  The board's enable state (101 / 102) and
homing (100, until a reply shows every joint homed and still) are part of the prediction.

Time: ``now`` (s, the loop's clock) tells the guard how long the previous frame has been
running.  The interval counts as at least one period: the loop writes one frame per tick,
and a frame written early because the one before was late is judged as if it came on time
(the planners leave :data:`~parolkit.robot.GOTO_ARRIVAL_JITTER_S` of margin for that).  A
frame written later than one period after the previous one is judged with the real interval:
the board has had longer to close the gap, so a late frame may step further (rule 6), but
only as far as the board can follow within the maximum speed (rule 7).  An activity that
catches up after a late tick asks :meth:`SafetyGuard.accepts_goto`, so its frames are the
ones the guard passes.

Rules, in order:

1. E-stop pressed or latched: DISABLE (102) every tick, whatever was asked.
2. Only known board codes are sent (100, 101, 102, 103, 123, 156, 255).
3. HOME (100) is never sent twice in a row (the board would restart homing).
4. Every speed field within the joint's maximum speed (JOG while not homed: the maximum jog
   speed).
5. GO TO (156): only when homed and while the board's position can be predicted; every target
   inside the published step limits.
6. GO TO step: a target may move from the previous GO TO target by at most the maximum speed x
   the time between the two frames (at least one period); the first GO TO after any other
   frame may lie at most one period of maximum-speed travel from where the board is.
7. GO TO start speed: the speed the board will start this frame at,
   ``|0.5 v_ff + 50 (target - position on arrival)|``, within the maximum speed.
   Rules 6 and 7 allow one step of rounding (``ROUNDING_STEPS``; in rule 7 one step is 50
   steps/s): targets are whole steps, so a stream at exactly the tracking factor rounds above
   it by up to that much.
8. JOG (123): when homed, no joint may reach its limit within ``lookahead_ticks`` ticks at
   the commanded speed.
9. A speed stream (123 with a non-zero speed) is always ended by a zero-speed 123 frame: if
   anything other than 123 or DISABLE follows it, that frame is replaced by the zero-speed
   frame for one tick.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, replace

from parolkit.protocol.frames import BoardCommand, CommandFrame, GripperCommandBits, StatusFrame
from parolkit.robot import GOTO_FF_GAIN, GOTO_GAIN_PER_S, JOINT_NAMES, RobotModel

__all__ = [
    "GuardResult", "SafetyGuard", "goto_start_speed", "goto_position_after", "max_goto_step",
    "ROUNDING_STEPS",
]

_KNOWN = {int(c) for c in BoardCommand}
_ZERO6 = (0, 0, 0, 0, 0, 0)
#: Rules 6 and 7 allow this much rounding (steps): targets are whole steps (in rule 7 one step
#: of target is GOTO_GAIN_PER_S = 50 steps/s of start speed).
ROUNDING_STEPS = 1.0
#: A status frame is matched to the sent frame whose predicted arrival position is within
#: this many ticks of maximum-speed travel on every joint (the closest one wins).
_MATCH_TICKS = 0.5
#: Sent frames remembered for matching replies (a reply later than this many frames counts
#: as unmatched).
_HISTORY = 8


def goto_start_speed(target: float, feed_forward: float, position: float) -> float:
    """The speed (steps/s, signed) at which the board starts a GO TO frame with ``target``
    (steps) and ``feed_forward`` (steps/s) when the joint is at ``position`` (steps) as the
    frame arrives; the fastest it runs until the next frame."""
    return GOTO_FF_GAIN * feed_forward + GOTO_GAIN_PER_S * (target - position)


def goto_position_after(position: float, target: float, feed_forward: float, dt_s: float) -> float:
    """Where (steps) a joint that was at ``position`` when a GO TO frame (``target`` steps,
    ``feed_forward`` steps/s) arrived is ``dt_s`` seconds later: it closes on the frame's goal
    ``target + feed_forward x GOTO_FF_GAIN / GOTO_GAIN_PER_S`` as ``exp(-GOTO_GAIN_PER_S t)``."""
    goal = target + feed_forward * (GOTO_FF_GAIN / GOTO_GAIN_PER_S)
    return goal - (goal - position) * math.exp(-GOTO_GAIN_PER_S * dt_s)


def max_goto_step(lag: float, dt_s: float, max_speed: float) -> float:
    """How far (steps, in the direction of ``lag``) the next GO TO goal may move from the
    previous one so that the board starts the next frame within ``max_speed`` (steps/s).

    ``lag`` (steps, signed) is how far the joint trailed the previous frame's goal (target +
    feed-forward x GOTO_FF_GAIN / GOTO_GAIN_PER_S) as that frame arrived, e.g. that goal minus
    the position in the status frame answering it; ``dt_s`` is the time between the two
    frames.  The board then starts at ``GOTO_GAIN_PER_S x (lag exp(-GOTO_GAIN_PER_S dt) +
    step)``.  An activity that catches up after a late tick may send the sample for the real
    time only when this allows its step (and the guard's rule 6 allows ``max_speed x dt``);
    otherwise it must not skip samples.  May be negative: the board is still too far behind to
    step on at all."""
    left = lag * math.exp(-GOTO_GAIN_PER_S * max(0.0, dt_s))
    sign = 1.0 if lag >= 0 else -1.0
    return max_speed / GOTO_GAIN_PER_S - sign * left


@dataclass(frozen=True)
class GuardResult:
    """The frame to send and, when the asked frame was replaced, why."""

    frame: CommandFrame
    violation: str | None = None
    #: True when the asked frame was replaced (violation or E-stop / zero-speed substitution)
    replaced: bool = False


#: board codes that stop a running homing (board-firmware.md); every other code lets it go on
_ABORTS_HOMING = frozenset({BoardCommand.ENABLE, BoardCommand.DISABLE, BoardCommand.CLEAR_ERROR,
                            BoardCommand.JOG, BoardCommand.GOTO})


class _Sent:
    """A frame the guard let through and what the board does while it is in effect: where
    the board was predicted to be as it arrived (steps; None when unknown: nothing known yet,
    or homing), whether the board is enabled and whether it may be homing, and how long the
    frame ran (s, set when the next frame is checked)."""

    __slots__ = ("frame", "arrival", "dt", "t", "seq", "enabled", "homing")

    def __init__(self, frame: CommandFrame, arrival: list[float] | None, t: float | None, seq: int,
                 before: _Sent | None) -> None:
        self.frame = frame
        self.arrival = arrival
        self.dt: float | None = None
        self.t = t
        self.seq = seq
        code = frame.command
        # the firmware powers up enabled; 102 disables, 101 enables (103 does not)
        enabled: bool = before.enabled if before is not None else True
        if code == BoardCommand.DISABLE:
            enabled = False
        elif code == BoardCommand.ENABLE:
            enabled = True
        self.enabled: bool = enabled
        self.homing: bool
        if code == BoardCommand.HOME:
            self.homing = enabled  # (100 does nothing while disabled)
        elif code in _ABORTS_HOMING:
            self.homing = False
        else:
            self.homing = before.homing if before is not None else False

    def after(self, dt: float) -> list[float] | None:
        """Where the board is ``dt`` s after this frame arrived (None when unknown)."""
        p = self.arrival
        if p is None or self.homing:
            return None  # (homing moves the joints on its own)
        f = self.frame
        code = f.command
        if not self.enabled:
            return list(p)  # 100 / 123 / 156 do nothing while disabled
        if code == BoardCommand.GOTO:
            return [goto_position_after(a, t, v, dt) for a, t, v in zip(p, f.positions, f.speeds)]
        if code == BoardCommand.JOG:
            return [a + v * dt for a, v in zip(p, f.speeds)]
        return list(p)  # IDLE, 101-103, unknown codes: still


class SafetyGuard:
    """Checks and, if needed, replaces outgoing frames.  Owned by the loop thread."""

    def __init__(self, model: RobotModel, rate_hz: float, *, lookahead_ticks: float = 3.0) -> None:
        self.model = model
        self.period_s = 1.0 / rate_hz
        self._lo = tuple(int(lo) for lo, _ in model.limits_steps)
        self._hi = tuple(int(hi) for _, hi in model.limits_steps)
        self._vmax = tuple(float(v) for v in model.max_speed_steps_s)
        self._vjog = tuple(float(v) for v in model.max_jog_speed_steps_s)
        self._tick_travel = tuple(v * self.period_s for v in self._vmax)
        self.lookahead_ticks = lookahead_ticks
        self._sent: deque[_Sent] = deque(maxlen=_HISTORY)
        self._seen: StatusFrame | None = None
        self._seq = 0
        #: the sent frame the newest status answers (replies come in order, one per frame)
        self._answered = 0
        #: new statuses in a row that matched no prediction
        self._unmatched = 0
        #: the newest status matched no sent frame: the board may not have followed them
        self._uncertain = True
        #: counters (read by tests and the status object)
        self.replaced_frames = 0
        self.violations = 0
        self.last_violation: str | None = None

    @property
    def _last(self) -> CommandFrame | None:
        return self._sent[-1].frame if self._sent else None

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

    # ---- where the board is ----

    def _sync(self, status: StatusFrame | None) -> None:
        """Anchor the prediction on ``status`` when it is new (see the module docstring).

        The board answers every frame, in order, with its position as the frame arrived, so a
        new status answers a frame sent after the one the previous status answered: the
        closest such prediction (within half a tick of maximum-speed travel on every joint)
        is the one it answers.  The prediction is re-run from the status unless the frame
        before the one it answers was a GO TO: then where the board got to depends on when the
        two frames reached it, and the guard judges frames as delivered on schedule (module
        docstring), so the status only says which frame it answers.  When no prediction is
        that close, twice in a row, the board has not done what was predicted: the status is
        taken as the answer to the next frame in order, the prediction is re-run from it and
        is uncertain until a status matches again.  Once is a corrupted reply (the link has no
        checksum; one flipped bit moves a joint by a power of two): ignored."""
        if status is None or status is self._seen:
            return
        self._seen = status
        sent = self._sent
        if not sent:
            return
        ps = status.positions
        scale = self._tick_travel
        best, best_score = -1, _MATCH_TICKS
        first = -1  # the next frame in order after the one the previous status answered
        predicted = False  # is there a prediction to match at all?
        for i in range(len(sent) - 1, -1, -1):  # newest first: a tie goes to the newest
            e = sent[i]
            if e.seq <= self._answered:
                break
            first = i
            arr = e.arrival
            if arr is None:
                continue
            predicted = True
            score = max(abs(p - a) / s for p, a, s in zip(ps, arr, scale))
            if score < best_score or (best < 0 and score <= best_score):
                best, best_score = i, score
        if best < 0:  # the board did not do what was predicted: start again from what it says
            self._unmatched += 1
            if self._unmatched < 2 and predicted:
                return
            best = first if first >= 0 else len(sent) - 1
            self._uncertain = True
            anchor = True
        else:
            self._unmatched = 0
            self._uncertain = False
            before = sent[best - 1].frame if best > 0 else sent[best].frame
            anchor = before.command != BoardCommand.GOTO
        e = sent[best]
        self._answered = e.seq
        # homing is over when a status taken while it may have been running (the answer to a
        # frame sent after HOME) shows every joint homed and still
        was_homing = sent[best - 1].homing if best > 0 else e.homing and e.frame.command != BoardCommand.HOME
        if was_homing and status.all_homed and not any(status.speeds):
            for i in range(best, len(sent)):
                if sent[i].frame.command == BoardCommand.HOME:
                    break
                sent[i].homing = False
        if not anchor:
            return
        e.arrival = [float(p) for p in ps]
        for i in range(best + 1, len(sent)):
            prev = sent[i - 1]
            sent[i].arrival = prev.after(prev.dt if prev.dt is not None else self.period_s)

    def _arrivals(self, dt: float, status: StatusFrame | None) -> list[list[float]]:
        """The board's possible positions (steps) as a frame sent ``dt`` s after the last one
        arrives: one, or two when uncertain; none when nothing is known."""
        if not self._sent:  # (nothing sent yet: the board is where it says)
            return [[float(v) for v in status.positions]] if status is not None else []
        p = self._sent[-1].after(dt)
        if p is None:
            return []  # homing, or it moved on its own and has not answered since
        out = [p]
        if self._uncertain and status is not None:
            out.append([float(v) for v in status.positions])
        return out

    # ---- the check ----

    def _goto_violation(self, f: CommandFrame, arrivals: list[list[float]], dt: float) -> str | None:
        for j in range(6):
            p = f.positions[j]
            if not self._lo[j] <= p <= self._hi[j]:
                return (
                    f"{JOINT_NAMES[j]} target {p} steps is outside the limits "
                    f"{self._lo[j]}..{self._hi[j]} steps"
                )
        if not arrivals:
            if self._sent and self._sent[-1].homing:
                return ("position commands (156) are refused while the board may be homing (until a "
                        "status frame shows every joint homed and still)")
            return ("position commands (156) are refused while the board's position is unknown (no "
                    "status frame since it last moved on its own)")
        last = self._last
        if last is not None and last.command == BoardCommand.GOTO:
            for j in range(6):
                step = abs(f.positions[j] - last.positions[j])
                allowed = self._vmax[j] * dt + ROUNDING_STEPS
                if step > allowed:
                    return (
                        f"{JOINT_NAMES[j]} target moves {step} steps from the previous one in "
                        f"{dt * 1e3:.1f} ms: the maximum speed {self._vmax[j]:g} steps/s allows "
                        f"{allowed:.0f} steps (the board would jump)"
                    )
        else:
            for pos in arrivals:
                for j in range(6):
                    lead = abs(f.positions[j] - pos[j])
                    allowed = self._tick_travel[j] + ROUNDING_STEPS
                    if lead > allowed:
                        return (
                            f"{JOINT_NAMES[j]} target is {lead:.0f} steps from where the board is "
                            f"({pos[j]:.0f} steps): one period at the maximum speed "
                            f"{self._vmax[j]:g} steps/s allows {allowed:.0f} steps (the board would jump)"
                        )
        tol = GOTO_GAIN_PER_S * ROUNDING_STEPS
        for pos in arrivals:
            for j in range(6):
                u = goto_start_speed(f.positions[j], f.speeds[j], pos[j])
                if abs(u) > self._vmax[j] + tol:
                    return (
                        f"{JOINT_NAMES[j]} would start this frame at {abs(u):.0f} steps/s, above its "
                        f"maximum {self._vmax[j]:g} steps/s (target {f.positions[j]} steps, "
                        f"{f.positions[j] - pos[j]:+.0f} steps from where the board will be, "
                        f"feed-forward {f.speeds[j]} steps/s)"
                    )
        return None

    def _violation(self, f: CommandFrame, status: StatusFrame | None, homed: bool, dt: float) -> str | None:
        code = int(f.command)
        if code not in _KNOWN:
            return f"board command {code} is not one the controller may send"
        last = self._last
        if code == BoardCommand.HOME and last is not None and last.command == BoardCommand.HOME:
            return "HOME (100) may be sent in one frame only (the board would restart homing)"
        jog_unhomed = code == BoardCommand.JOG and not homed
        vlim = self._vjog if jog_unhomed else self._vmax
        for j in range(6):
            v = f.speeds[j]
            if abs(v) > vlim[j]:
                kind = "maximum jog speed (not homed)" if jog_unhomed else "maximum"
                return f"{JOINT_NAMES[j]} speed {v} steps/s exceeds the {kind} {vlim[j]:g} steps/s"
        if code == BoardCommand.GOTO:
            if not homed:
                return "position commands (156) are refused until the robot is homed"
            return self._goto_violation(f, self._arrivals(dt, status), dt)
        if code == BoardCommand.JOG and homed and status is not None:
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
        now: float | None = None,
    ) -> GuardResult:
        """The frame to send this tick.

        ``status`` is the newest status frame (or None); ``now`` the loop's time (s) as the
        frame is written: the interval since the previous checked frame (at least one period;
        one period when ``now`` is None) is how long that frame ran.  A second check at the
        same ``now`` replaces the first (the loop writes only the second: a safety command
        that arrived while the first frame was made)."""
        sent = self._sent
        if now is not None and sent and sent[-1].t == now:
            sent.pop()  # never written
        prev = sent[-1] if sent else None
        dt = self._ran(prev, now)
        if prev is not None:
            prev.dt = dt
        self._sync(status)
        res = self._decide(frame, status, estop, homed, dt)
        if res.replaced:
            self.replaced_frames += 1
        arrival = prev.after(dt) if prev is not None else (
            [float(v) for v in status.positions] if status is not None else None)
        self._seq += 1
        sent.append(_Sent(res.frame, arrival, now, self._seq, prev))
        return res

    def _ran(self, prev: _Sent | None, now: float | None) -> float:
        """How long the frame ``prev`` runs when the next one is written at ``now``: at least
        one period (module docstring, *Time*); one period when either time is unknown."""
        if now is None or prev is None or prev.t is None:
            return self.period_s
        return max(self.period_s, now - prev.t)

    def accepts_goto(self, positions: Sequence[int], speeds: Sequence[int], status: StatusFrame | None,
                     now: float) -> bool:
        """Would :meth:`check` at ``now`` (with ``status``) pass a 156 frame with these targets and
        feed-forwards, the robot homed and no E-stop?  The same rules and the same prediction of
        where the board will be (anchored on ``status``; both hypotheses when uncertain; the
        previous frame counted as running at least one period): an activity that catches up
        after a late tick asks this, so its frame is never one the guard refuses (the pacing
        module's own estimate disagreed under load: an early tick, an uncertain prediction,
        and the move FAILED on a guard refusal)."""
        prev = self._sent[-1] if self._sent else None
        dt = self._ran(prev, now)
        self._sync(status)
        frame = CommandFrame(command=BoardCommand.GOTO, positions=tuple(int(p) for p in positions),
                             speeds=tuple(int(v) for v in speeds))
        return self._goto_violation(frame, self._arrivals(dt, status), dt) is None

    def _decide(self, frame: CommandFrame, status: StatusFrame | None, estop: bool, homed: bool,
                dt: float) -> GuardResult:
        if estop:
            out = self.disable_frame(frame, status)
            return GuardResult(out, None, replaced=frame.command != BoardCommand.DISABLE)
        last = self._last
        if (
            last is not None
            and last.command == BoardCommand.JOG
            and any(last.speeds)
            and frame.command not in (BoardCommand.JOG, BoardCommand.DISABLE)
        ):
            return GuardResult(self.zero_speed_frame(frame, status), None, replaced=True)
        why = self._violation(frame, status, homed, dt)
        if why is None:
            return GuardResult(frame)
        self.violations += 1
        self.last_violation = why
        if frame.command == BoardCommand.JOG:
            safe = self.zero_speed_frame(frame, status)
        else:
            safe = self.hold_frame(frame, status)
        return GuardResult(safe, why, replaced=True)

    def predicted_arrival(self, now: float | None = None) -> Sequence[float] | None:
        """Where (steps) the guard expects the board to be when a frame checked at ``now``
        arrives (the first hypothesis when uncertain); None when unknown.  For tests and
        diagnostics."""
        if not self._sent:
            return None
        last = self._sent[-1]
        return last.after(self._ran(last, now))
