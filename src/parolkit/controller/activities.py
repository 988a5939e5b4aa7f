"""What accepted commands do tick by tick: one activity per running job.

An activity's :meth:`Activity.step` is called once per tick by the controller core and must be
small and bounded: it indexes precomputed arrays or compares a few numbers.  It returns a
:class:`FrameRequest`: the board command and values this tick's frame should carry (the core
adds the setpoints and passes it through the safety guard) and, when the job ends with this
frame, its terminal status.  Motion goes out as GO TO frames whose goal lies inside the box the
guard allows (:attr:`TickContext.box`): every frame a bounded commitment.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

from parolkit._frozen import quick_init
from parolkit.protocol.commands import AckStatus
from parolkit.protocol.frames import BoardCommand, GripperMode, StatusFrame
from parolkit.robot import GOTO_FF_GAIN, GOTO_GAIN_PER_S, JOINT_NAMES, goto_goal

__all__ = [
    "FrameRequest", "TickContext", "Activity", "TrajectoryActivity", "SpeedActivity", "HomeActivity",
    "DelayActivity", "CheckpointActivity", "OneShotActivity", "GripperCalibrateActivity", "WaitInputActivity",
    "OutputActivity", "ServoActivity", "GuardStopActivity", "DoneActivity",
    "Samples", "WARNING_PREFIX", "speed_samples", "ticks_for",
]

_ZERO6 = (0, 0, 0, 0, 0, 0)
#: one feed-forward step/s moves a GO TO goal by this much (steps)
_FF_STEP = GOTO_FF_GAIN / GOTO_GAIN_PER_S

#: a trajectory's samples as Python lists: per-tick positions and speeds (steps, 6 joints
#: each) and board command codes
Samples = tuple[list[list[int]], list[list[int]], list[int]]

#: a plan's notes that start so are warnings (``parolkit.motion.validate.WARNING_PREFIX``, not
#: imported here: the controller loads the planners only when first needed)
WARNING_PREFIX = "warning: "


@quick_init
@dataclass(frozen=True)
class TickContext:
    """What an activity may look at: tick number, time (s), rate, latest status frame, and the
    goals the safety guard allows for this tick's GO TO frame."""

    tick: int
    now: float
    rate_hz: float
    status: StatusFrame | None
    homed: bool
    stream_mode: bool
    watchdog_s: float
    limits_steps: tuple[tuple[int, int], ...]
    #: per joint, the goals (steps) a GO TO frame written this tick may carry (the guard's rule
    #: 6: a bounded commitment); None: no GO TO may be sent now (where the board is is not known)
    box: Sequence[tuple[float, float]] | None = None
    #: where a new motion starts from (steps): the goal of the last GO TO frame written, or the
    #: measured positions; None: not known
    origin: Sequence[float] | None = None
    #: the link record's own account that the board homes since HOME was written (its frames
    #: during a homing faster than expected are not the truth, see integrity)
    homing_seen: bool = False
    #: the time trajectories are scheduled on (s): ``now``, or, with a board in lockstep with
    #: the frames (each frame runs it exactly one period: a simulated board with a frame
    #: clock), ``tick / rate_hz``: that board's own time, which a late tick does not advance
    clock_s: float | None = None
    #: the path speed moves should run at, a fraction of the plan's: the SPEED override
    #: (0.01..1), 0 while paused (a trajectory ramps to it within the acceleration limits)
    speed_scale: float = 1.0
    #: per joint, the acceleration limit a change of the path speed keeps to (steps/s^2);
    #: None: no limit (the change takes one tick)
    accel_steps_s2: Sequence[float] | None = None

    @property
    def schedule_s(self) -> float:
        """:attr:`clock_s`, or ``now`` when it is not set."""
        return self.now if self.clock_s is None else self.clock_s


@quick_init
@dataclass(frozen=True)
class FrameRequest:
    """The frame content an activity asks for this tick, and whether the job ends with it."""

    command: int = BoardCommand.IDLE
    positions: tuple[int, ...] | None = None
    speeds: tuple[int, ...] = _ZERO6
    gripper_mode: int = GripperMode.OPERATE
    done: AckStatus | None = None
    details: str = ""


class Activity:
    """Base class: one job's per-tick behaviour."""

    #: progress 0..1 for the status object
    progress: float = 0.0
    #: True when its frames move the robot
    moves: bool = False
    #: True when the step that ends it needs no frame of its own (it ends on what the board
    #: reported): the executor lets the next queued job take that tick
    frameless_end: bool = False
    #: warnings for the job's acks (``warning: ...``), added when it ends
    warnings: tuple[str, ...] = ()

    def step(self, ctx: TickContext) -> FrameRequest:  # pragma: no cover - abstract
        raise NotImplementedError

    def touch(self, now: float) -> None:
        """A streaming update arrived (resets the watchdog)."""


def _boundary(ok: Callable[[float], bool], *, good: float, bad: float, steps: int = 12) -> float:
    """The sample coordinate nearest ``bad`` that ``ok`` still passes, between ``good`` (passes)
    and ``bad`` (does not), by bisection to 1/2**steps of the span (1/4000 by default)."""
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        if ok(mid):
            good = mid
        else:
            bad = mid
    return good


def _slope_now(ts: Sequence[float], xs: Sequence[float]) -> float:
    """The rate of change of ``xs`` at time 0 (the newest sample's), by least squares: a
    parabola through four samples or more (a curving stream's speed now, not its mean over the
    window), else a line; exactly 0 for samples that are all the same (a held target)."""
    n = len(ts)
    if max(xs) - min(xs) < 1e-9:
        return 0.0
    if n >= 4:
        # x = c + v t + w t^2: the normal equations, solved by Cramer's rule
        s1, s2, s3, s4 = (sum(t ** k for t in ts) for k in (1, 2, 3, 4))
        y0, y1, y2 = sum(xs), sum(x * t for x, t in zip(xs, ts)), sum(x * t * t for x, t in zip(xs, ts))
        m = ((n, s1, s2), (s1, s2, s3), (s2, s3, s4))
        det = _det3(m)
        if abs(det) > 1e-18:
            return _det3(((n, y0, s2), (s1, y1, s3), (s2, y2, s4))) / det
    tm = sum(ts) / n
    xm = sum(xs) / n
    return sum((t - tm) * (x - xm) for t, x in zip(ts, xs)) / sum((t - tm) ** 2 for t in ts)


def _accel_weights(ts: Sequence[float]) -> list[float]:
    """Weights ``w`` such that ``sum(w[i] * xs[i])`` is how fast the rate of change of samples
    ``xs`` taken at times ``ts`` changes at time 0 (the newest sample's), by least squares: a
    cubic through six samples or more (the acceleration now: a parabola's is its mean over the
    window, half a window late on a curve whose acceleration changes), a parabola through four
    or five; all 0 for fewer (no acceleration).  The same for every joint: solved once."""
    n = len(ts)
    if n < 4:
        return [0.0] * n
    m = 4 if n >= 6 else 3
    # x = c0 + c1 t + c2 t^2 (+ c3 t^3): c2 = z . (X^T x) with A z = e2, A = X^T X (symmetric),
    # so the weights are X z; A z = e2 by Gaussian elimination with partial pivoting
    a = [[sum(t ** (i + k) for t in ts) for k in range(m)] + [1.0 if i == 2 else 0.0] for i in range(m)]
    for c in range(m):
        piv = max(range(c, m), key=lambda r: abs(a[r][c]))
        if abs(a[piv][c]) < 1e-300:
            return [0.0] * n
        a[c], a[piv] = a[piv], a[c]
        for r in range(c + 1, m):
            f = a[r][c] / a[c][c]
            a[r] = [x - f * y for x, y in zip(a[r], a[c])]
    z = [0.0] * m
    for i in reversed(range(m)):
        z[i] = (a[i][m] - sum(a[i][k] * z[k] for k in range(i + 1, m))) / a[i][i]
    return [2.0 * sum(zk * t ** k for k, zk in enumerate(z)) for t in ts]


def _det3(m: Sequence[Sequence[float]]) -> float:
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))


def _in_box(pos: Sequence[int], ff: Sequence[int], box: Sequence[tuple[float, float]]) -> bool:
    for g, (lo, hi) in zip(goto_goal(pos, ff), box):
        if not lo <= g <= hi:
            return False
    return True


def _towards(goal: Sequence[float],
             box: Sequence[tuple[float, float]]) -> tuple[tuple[int, ...], tuple[int, ...]] | None:
    """A GO TO frame (targets, feed-forwards) whose goal is the point of ``box`` nearest
    ``goal``, joint by joint (the goal carries hundredths of a step in the feed-forward); None
    when the box is empty on a joint (no GO TO is safe: hold still instead)."""
    pos, ff = [], []
    for g, (lo, hi) in zip(goal, box):
        if lo > hi:
            return None
        x = min(max(g, lo), hi)
        t = int(round(x))
        v = int(round((x - t) / _FF_STEP))
        if not lo <= t + v * _FF_STEP <= hi:  # rounded out of a very narrow box
            v = int(math.ceil((lo - t) / _FF_STEP)) if t + v * _FF_STEP < lo else int(math.floor((hi - t) / _FF_STEP))
        pos.append(t)
        ff.append(v)
    return tuple(pos), tuple(ff)


class TrajectoryActivity(Activity):
    """Play planned samples as GO TO (156) frames, each a bounded commitment, then settle on
    the target.

    Sample ``i`` is due ``i`` periods after the first frame (its positions are where the joints
    should be one period later, its speeds the feed-forward).  A tick plays what is due at the
    time it runs (interpolated between samples), so a late tick does not push the rest of the
    move back, but never further than the guard allows: the frame's goal must lie in
    ``ctx.box``, the goals that keep the board within its maximum speed wherever it may be
    (:meth:`parolkit.controller.guard.SafetyGuard.goal_box`).  When the plan asks for more
    (replies came late, so where the board is is known only roughly; or the plan is faster
    than the board can follow) the target advances only as far as the box allows and the move
    runs stretched: slower, on its own path, never refused.  When not even the previous target
    fits (the box moved away from it), the frame goes to the box's nearest point and the plan
    waits.  After the last sample the target is sent with zero feed-forward every tick until a
    status frame shows the board exactly on it and at rest: then COMPLETED (the seed: "with
    speed + position the robot reaches exactly the commanded position"); FAILED, naming the
    joints that are off, if that takes more than ``settle_ticks``.  Plans for speed tracking
    (board 123 in the samples) are played the same way: every motion frame is a GO TO.
    """

    moves = True

    def __init__(self, samples: Samples, *, settle_ticks: int, settle_tol_steps: int = 4,
                 streamed: bool = False, started: float = 0.0, schedule_start: float | None = None) -> None:
        self._load(samples)
        self.settle_ticks = settle_ticks
        self.settle_left = settle_ticks
        self.settle_tol = settle_tol_steps
        self.streamed = streamed
        self.last_update = started
        #: time of the first frame (sample 0 is due then); ``skip`` moves the schedule on
        self.t0 = started if schedule_start is None else schedule_start
        self._offset = 0
        #: where in the samples the last frame's target was (fractional); None before the first
        self._s: float | None = None
        #: ticks waited before the first frame (no box yet)
        self._start_waits = 0
        self._last_target: tuple[int, ...] | None = None
        #: ticks the box held the target back behind the plan
        self.held_ticks = 0
        #: the path speed, a fraction of the plan's (the SPEED override, 0 while paused; see
        #: :meth:`_ramp`), and the plan's time (s) reached at schedule time ``t0``
        self.k = 1.0
        self._tau = 0.0
        #: a STOP on the path: the path speed goes to 0 (as for PAUSE), then the job ends
        #: CANCELLED with this reason (None: no stop asked)
        self.stop_reason: str | None = None

    def _load(self, samples: Samples) -> None:
        positions, speeds, commands = samples
        self.positions, self.speeds, self.commands = positions, speeds, commands
        self.n = len(positions)
        #: the next whole sample to play (``n``: all played, settling)
        self.i = 0

    def touch(self, now: float) -> None:
        self.last_update = now

    def commanded(self) -> tuple[int, ...] | None:
        """Position (steps) of the last target sent to the board; None before the first."""
        return self._last_target

    def wait_start(self, ctx: TickContext) -> None:
        """Not started yet and held back this tick (its collision check is not ready): its
        first sample is due a tick later, so it starts from rest when it may."""
        if self._s is None:
            self.t0 = ctx.schedule_s + 1.0 / ctx.rate_hz
            self._offset = self.i
            self._tau = 0.0

    @property
    def sample_position(self) -> float | None:
        """Where in the samples the last frame's target was (fractional sample coordinate);
        None before the first frame."""
        return self._s

    def skip(self, k: int) -> None:
        """Start ``k`` samples in (at most at the last one): a streamed jog planned from
        another's commanded position ``k`` ticks before it took over continues where that
        one would be now, instead of stepping back by ``k`` ticks."""
        self.i = max(0, min(int(k), self.n - 1))
        self._offset = self.i
        self._tau = 0.0

    def _elapsed_samples(self, t: float, rate_hz: float) -> float:
        """The (fractional) sample due at schedule time ``t``.  Within 1e-6 of a whole sample
        it is that sample: on a board in lockstep the times are tick x period, products that
        are not exact (0.01 x 457 - 0.01 x 456 is not 0.01), and 2.9999999 samples would play
        as sample 2, a tick behind, and end the move a tick late on some start ticks only."""
        s = (self._tau + self.k * (t - self.t0)) * rate_hz + self._offset
        whole = round(s)
        return float(whole) if abs(s - whole) < 1e-6 else s

    def _ask(self, pos: Sequence[int], spd: Sequence[int], done: AckStatus | None = None,
             details: str = "") -> FrameRequest:
        target = tuple(int(p) for p in pos)
        self._last_target = target
        return FrameRequest(BoardCommand.GOTO, target, tuple(int(v) for v in spd), done=done, details=details)

    def _at(self, s: float) -> tuple[list[int], list[int]]:
        """Target and feed-forward at sample coordinate ``s``, linear between samples (the
        feed-forward x the path speed :attr:`k`)."""
        k = int(s)
        f = s - k
        c = self.k
        if f <= 1e-9 or k + 1 >= self.n:
            if c == 1.0:
                return self.positions[k], self.speeds[k]
            return self.positions[k], [int(round(v * c)) for v in self.speeds[k]]
        p0, p1, v0, v1 = self.positions[k], self.positions[k + 1], self.speeds[k], self.speeds[k + 1]
        return ([int(round(a + f * (b - a))) for a, b in zip(p0, p1)],
                [int(round(c * (a + f * (b - a)))) for a, b in zip(v0, v1)])

    def _ramp(self, target: float, ctx: TickContext) -> None:
        """Move the path speed :attr:`k` towards ``target`` (the SPEED override, or 0: PAUSE)
        from this tick on, as fast as every joint's acceleration limit allows on this part of
        the path: a joint's acceleration is ``k^2 a + k' v`` (``v``, ``a`` the plan's speed and
        acceleration here at full speed), so ``k'`` keeps within ``+-ctx.accel_steps_s2`` on
        every joint that moves.  The joints stay on the planned path (joint or Cartesian) while
        they slow down, stop or speed up again: only the time along it changes."""
        t = ctx.schedule_s
        period = 1.0 / ctx.rate_hz
        # the plan's time so far, at the old speed; from here on at the new one
        self._tau += self.k * (t - self.t0)
        self.t0 = t
        k = self.k
        lo, hi = -math.inf, math.inf
        acc = ctx.accel_steps_s2
        if acc is not None and self._s is not None and self.n:
            i = min(int(self._s), self.n - 1)
            v0, v1 = self.speeds[i], self.speeds[min(i + 1, self.n - 1)]
            for vj, wj, amax in zip(v0, v1, acc):
                if abs(vj) < 1.0:
                    continue
                aj = (wj - vj) * ctx.rate_hz
                b1, b2 = (-amax - k * k * aj) / vj, (amax - k * k * aj) / vj
                lo, hi = max(lo, min(b1, b2)), min(hi, max(b1, b2))
        rate = (target - k) / period
        if lo <= hi:
            rate = min(max(rate, lo), hi)
        else:  # the plan itself is at a joint's limit here: the path speed holds this tick
            rate = 0.0
        new = k + rate * period
        new = min(new, target) if target >= k else max(new, target)
        self.k = min(1.0, max(0.0, new))

    def _fits(self, s: float, box: Sequence[tuple[float, float]]) -> bool:
        pos, ff = self._at(s)
        return _in_box(pos, ff, box)

    def _hold(self, s: float, box: Sequence[tuple[float, float]]) -> FrameRequest:
        """Not even the target at ``s`` fits the box: the box's point nearest its goal (or IDLE
        when no goal is safe on some joint)."""
        pos, ff = self._at(s)
        frame = _towards(goto_goal(pos, ff), box)
        if frame is None:
            return FrameRequest(BoardCommand.IDLE)
        return self._ask(*frame)

    def _play(self, ctx: TickContext) -> FrameRequest:
        box = ctx.box
        period = 1.0 / ctx.rate_hz
        scale = 0.0 if self.stop_reason is not None else ctx.speed_scale
        if self._s is None:
            self.k = scale  # from rest: the first frame runs at the path speed asked
        elif self.k != scale:
            self._ramp(scale, ctx)
        if box is None:
            # where the board is is not known (no trusted reply yet, a homing): no GO TO may
            # go out; before the first frame the schedule waits, later the board stands at
            # the last goal (a bounded commitment) while the plan's clock runs on
            if self._s is None:
                self._start_waits += 1
                self.t0 = ctx.schedule_s + period
                self._offset = self.i
                self._tau = 0.0
                if self._start_waits > self.settle_ticks:
                    return FrameRequest(BoardCommand.IDLE, done=AckStatus.FAILED,
                                details=f"the board's position was not known for {self.settle_ticks * period:.2f} s: "
                                        "the move could not start")
            self.held_ticks += 1
            return FrameRequest(BoardCommand.IDLE)
        last = self.n - 1.0
        first = self._s is None
        low = float(self.i) if first else self._s
        assert low is not None
        want = min(max(self._elapsed_samples(ctx.schedule_s, ctx.rate_hz), low), last)
        if self._fits(want, box):
            s = want
        elif self._fits(low, box):
            s = _boundary(lambda x: self._fits(x, box), good=low, bad=want)
            self.held_ticks += 1
        else:
            self.held_ticks += 1
            if first:  # the board is not yet where the plan starts: start a tick later
                self.t0 = ctx.schedule_s + period
                self._offset = self.i
                self._tau = 0.0
            return self._hold(low, box)
        self._s = s
        self.i = self.n if s >= last else int(s) + 1
        self.progress = self.i / self.n
        pos, ff = self._at(s)
        if self.stop_reason is not None and self.k == 0.0:
            # stopped on the path: this frame holds there (no feed-forward), and the job ends
            return self._ask(pos, ff, AckStatus.CANCELLED, self.stop_reason)
        return self._ask(pos, ff)

    def stop_on_path(self, reason: str) -> bool:
        """STOP: slow down along the path within the acceleration limits (as PAUSE does), then
        end CANCELLED with ``reason`` where it stands.  False when the move is not on its way
        (not started, or settling on its target): nothing to slow down, the caller cancels it
        at once."""
        if self._s is None or self.i >= self.n:
            return False
        self.stop_reason = reason
        return True

    def step(self, ctx: TickContext) -> FrameRequest:
        if self.streamed and ctx.stream_mode and ctx.now - self.last_update > ctx.watchdog_s:
            # a bounded goal: the board stops within 20 ms of travel of where it is
            return FrameRequest(BoardCommand.IDLE, None, done=AckStatus.COMPLETED,
                        details="stream watchdog: no update, jog stopped")
        if self.n == 0:
            return FrameRequest(BoardCommand.IDLE, None, done=AckStatus.COMPLETED, details="nothing to do")
        if self.i < self.n:
            return self._play(ctx)
        # settle: the final target with zero feed-forward, every tick, until the board reports
        # it exactly and at rest (the GO TO law v = 50 x error closes the last steps in a few
        # ticks and cannot overshoot without feed-forward); FAILED if it does not in time
        target = self.positions[-1]
        self.settle_left -= 1
        st = ctx.status
        box = ctx.box
        if box is not None and not _in_box(target, _ZERO6, box):
            return self._hold(self.n - 1.0, box)  # the last sample's goal is still on its way
        if st is not None and all(a == b for a, b in zip(st.positions, target)) and not any(st.speeds):
            self.progress = 1.0
            self._note_stretch(ctx)
            return self._ask(target, _ZERO6, AckStatus.COMPLETED)
        if self.settle_left <= 0:
            return self._ask(target, _ZERO6, AckStatus.FAILED,
                             details=self._missed_target(st, target, ctx.rate_hz))
        if box is None:
            return FrameRequest(BoardCommand.IDLE)
        return self._ask(target, _ZERO6)

    def _note_stretch(self, ctx: TickContext) -> None:
        """A move the box held back for a noticeable time says so in its COMPLETED ack."""
        if self.held_ticks <= 2:
            return
        held = self.held_ticks / ctx.rate_hz
        self.warnings = (*self.warnings, f"{WARNING_PREFIX}ran stretched: for {held:.2f} s the board could not "
                         "be asked for more without risking its maximum speed (late replies, or a plan "
                         "faster than the bounded frames can follow)")

    def _missed_target(self, st: StatusFrame | None, target: Sequence[int], rate_hz: float) -> str:
        """The FAILED details of a move whose board did not report its target (at rest) within
        the settle time: which joints are how far off."""
        waited = f"{self.settle_ticks / rate_hz:.2f} s"
        if st is None:
            return f"the board did not report its position within {waited} of the move's end"
        off = [f"{JOINT_NAMES[j]} at {p} steps, {t - p:+d} from the target {t}"
               for j, (p, t) in enumerate(zip(st.positions, target)) if p != t]
        moving = [JOINT_NAMES[j] for j, v in enumerate(st.speeds) if v]
        what = "; ".join(off) if off else "every joint on target but still moving (" + ", ".join(moving) + ")"
        return f"the board did not reach the exact target within {waited} of the move's end: {what}"


def speed_samples(origin: Sequence[float], speeds_steps_s: Sequence[int], duration_s: float,
                  rate_hz: float) -> Samples:
    """The samples of constant joint speeds for ``duration_s`` from ``origin`` (steps): sample
    ``i`` is where the joints should be one period after it is due, ``origin + v (i + 1) T``,
    with the speed as feed-forward; the last is exactly ``origin + v x duration`` (rounded to
    steps) at rest, so the distance is speed x duration whatever the rate."""
    period = 1.0 / rate_hz
    n = max(1, int(math.ceil(duration_s * rate_hz - 1e-9)))
    pos: list[list[int]] = []
    spd: list[list[int]] = []
    v = [int(x) for x in speeds_steps_s]
    for i in range(n - 1):
        t = (i + 1) * period
        pos.append([int(round(o + vj * t)) for o, vj in zip(origin, v)])
        spd.append(list(v))
    pos.append([int(round(o + vj * duration_s)) for o, vj in zip(origin, v)])
    spd.append([0] * 6)
    return pos, spd, [int(BoardCommand.GOTO)] * n


class SpeedActivity(TrajectoryActivity):
    """Constant joint speeds for ``duration_s``: JOG, MULTIJOG, SPEEDJOINT, as GO TO frames.

    The joints follow ``origin + speed x t`` (``t`` up to ``duration_s``; the origin is where
    the last GO TO frame's goal left them, or where they stand) like any planned move
    (:class:`TrajectoryActivity`): each frame a bounded commitment, the distance exactly speed x
    duration, the end settled on the exact steps.  Homed, a joint that would pass its limit
    stops short of it (COMPLETED, the details say so).  A streamed jog's update
    (:meth:`replace`) continues from the target the stream has reached."""

    def __init__(self, speeds_steps_s: Sequence[int], duration_s: float, *, rate_hz: float, settle_ticks: int,
                 streamed: bool = False, started: float = 0.0, schedule_start: float | None = None) -> None:
        super().__init__(([], [], []), settle_ticks=settle_ticks, streamed=streamed, started=started,
                         schedule_start=schedule_start)
        self.rate_hz = rate_hz
        self._pending: tuple[tuple[int, ...], float] | None = None
        self.replace(speeds_steps_s, duration_s, started, schedule_start)

    def replace(self, speeds_steps_s: Sequence[int], duration_s: float, now: float,
                schedule_s: float | None = None) -> None:
        """New speeds and duration from ``now`` on (a streamed jog's update): the reference
        starts again from the target the stream has reached (its samples are built at the next
        step, where that is known)."""
        if not duration_s > 0.0:
            raise ValueError(f"a speed stream needs a duration > 0 s, got {duration_s!r}")
        self.speeds_steps_s = tuple(int(v) for v in speeds_steps_s)
        self.duration = float(duration_s)
        self._pending = (self.speeds_steps_s, self.duration)
        self.last_update = now
        self.t0 = now if schedule_s is None else schedule_s
        self._offset = 0
        self._tau = 0.0
        self.limit_note = ""

    def _build(self, ctx: TickContext) -> FrameRequest | None:
        assert self._pending is not None
        speeds, duration = self._pending
        here = self._last_target if self._last_target is not None else ctx.origin
        if here is None:
            return FrameRequest(BoardCommand.IDLE)  # nothing known yet: wait (the box is None too)
        self._pending = None
        if ctx.homed:
            for j, v in enumerate(speeds):
                if v == 0:
                    continue
                lo, hi = ctx.limits_steps[j]
                room = (hi - here[j]) / v if v > 0 else (lo - here[j]) / v
                if room < duration:
                    duration = max(0.0, room)
                    self.limit_note = f"stopped at the {'upper' if v > 0 else 'lower'} limit of {JOINT_NAMES[j]}"
        if duration <= 0.0:
            return self._ask([int(round(x)) for x in here], _ZERO6, AckStatus.COMPLETED, self.limit_note)
        self._load(speed_samples(here, speeds, duration, self.rate_hz))
        self._s = None
        self.settle_left = self.settle_ticks
        self.t0 = ctx.schedule_s
        self._tau = 0.0
        return None

    def step(self, ctx: TickContext) -> FrameRequest:
        if self._pending is not None and not (self.streamed and ctx.stream_mode
                                              and ctx.now - self.last_update > ctx.watchdog_s):
            early = self._build(ctx)
            if early is not None:
                return early
        out = super().step(ctx)
        if out.done is AckStatus.COMPLETED and self.limit_note and not out.details:
            return replace(out, details=self.limit_note)
        return out


#: how fast a servo stream closes the distance to a moving target, 1/s (its speed is followed
#: besides)
SERVO_GAIN_PER_S = 20.0
#: the share of a joint's speed and acceleration limits a streamed curve's own speed and
#: acceleration are taken to use at most (the rest is the follower's, to run back onto the
#: curve after it fell behind)
_CURVE_SHARE = 0.9
#: the servo follower's generator (ruckig) computes in this many steps: in steps, "error in
#: step 1" came for about one in seven random states relative to a curve, in hundreds of
#: steps none in 3,000
_UNIT = 100.0
#: a joint that runs back onto the curve is on it again once no further from it than this many
#: steps plus a tick's travel at the curve's speed (and able to stop relative to it within that)
_ON_CURVE_STEPS = 5.0
#: A servo target's speed is a least-squares fit over the targets of this many ticks (100 ms at
#: 100 Hz): datagrams that arrive a tick late, two in the next tick, move it by a fraction
SERVO_SPEED_WINDOW_TICKS = 10


class ServoActivity(Activity):
    """A servo stream (SERVOJ / SERVOL): the latest target wins, an online jerk-limited
    generator (ruckig) moves toward it within every joint's position-tracking speed,
    acceleration limit and jerk, one tick at a time, and each tick's frame is a GO TO frame
    (a bounded commitment) to where the generator is one period on.

    A target takes effect in the frame of the tick that takes it in (:meth:`set_target`); its
    speed is estimated from the ones before it (so a streamed curve is followed, not chased
    from rest to rest; a dropped or late target moves the estimate by a fraction).  When the
    guard's box holds the frame back (late replies), the speed changes only as the box and
    the acceleration limit allow (:meth:`_held_back`), and once the box opens (or targets come
    again after a silence or a pause) the generator runs back onto the curve as fast as the
    limits allow (:meth:`_follow`).  With no target for ``timeout_ticks``, or :meth:`finish` (a
    queued command, STOP), or a pause, the generator brings the joints to rest at the
    acceleration limit (ruckig's velocity interface, target 0): a controlled stop; the job
    ends there (a pause holds instead, and the stream goes on after RESUME).  Targets are
    kept inside the joint limits; the generator aims at rest at a target that is at a limit."""

    moves = True

    def __init__(self, target_steps: Sequence[float], tick: int, *, rate_hz: float, max_speed_steps_s: Sequence[float],
                 max_accel_steps_s2: Sequence[float], jerk_time_s: float, timeout_ticks: int,
                 limits_steps: Sequence[tuple[float, float]]) -> None:
        from ruckig import ControlInterface, InputParameter, OutputParameter, Ruckig, RuckigError, Synchronization

        self._interface = ControlInterface
        self._error = RuckigError
        self.rate_hz = rate_hz
        self.period = 1.0 / rate_hz
        self._otg = Ruckig(6, self.period)
        self._in = InputParameter(6)
        self._out = OutputParameter(6)
        self.vmax = [float(v) for v in max_speed_steps_s]
        self.amax = [float(a) for a in max_accel_steps_s2]
        self._jerk_time = float(jerk_time_s)
        # every joint on its own (a servo target is followed joint by joint, not as a
        # synchronised move: the slowest joint must not slow the others down)
        self._in.synchronization = Synchronization.No
        self.timeout_ticks = timeout_ticks
        #: SERVOL in the wrist's singular area: when J4's target last turned (core time, s)
        #: and how fast it turns (deg/s)
        self.wrist_t: float | None = None
        self.wrist_v = 0.0
        self.limits = [(float(lo), float(hi)) for lo, hi in limits_steps]
        self.target = self._inside(target_steps)
        self.target_tick = tick
        self.target_v = [0.0] * 6
        self.target_a = [0.0] * 6
        #: per joint, the way the stream's last two targets went (+1, -1; 0: the same, a held
        #: target): the generator never moves a joint against it (:meth:`_never_back`)
        self.heading = [0] * 6
        #: the latest targets and their ticks (the speed estimate's window)
        self._history: deque[tuple[int, list[float]]] = deque([(tick, self.target)], maxlen=16)
        self.targets = 1
        #: the generator's state (steps, steps/s, steps/s^2); None before the first frame
        self._p: list[float] | None = None
        self._v = [0.0] * 6
        self._a = [0.0] * 6
        #: (status, details) the job ends with once at rest (finish); None: streaming
        self.ending: tuple[AckStatus, str] | None = None
        #: the ending is the silence's (a new target resumes the stream: :meth:`resume`)
        self._silenced = False
        #: ticks the guard's box held the generator back (late replies), and those of them that
        #: stopped a joint harder than its acceleration limit allows (the box comes first)
        self.held_ticks = 0
        self.box_stops = 0
        #: per joint: running back onto the curve (after the box held it back, a silence or a
        #: pause) until on it again, time-optimally; else following it with a proportional term
        self._rejoin = [True] * 6
        #: SERVOL in TRF: the TCP pose (4x4, m) the stream's offsets are relative to
        self.anchor: object | None = None
        #: the ID of the newest target taken (the status shows it: which target is followed)
        self.target_id: str | None = None

    def _inside(self, target: Sequence[float]) -> list[float]:
        return [min(max(float(t), lo), hi) for t, (lo, hi) in zip(target, self.limits)]

    @property
    def motion_state(self) -> tuple[list[float], list[float]] | None:
        """The generator's position (steps) and speed (steps/s) after the last frame; None
        before the first."""
        return None if self._p is None else (self._p, self._v)

    def set_target(self, target_steps: Sequence[float], tick: int) -> None:
        """A new target (steps), taken in at tick ``tick``: the latest wins.  Its speed is
        fitted to the targets of the last :data:`SERVO_SPEED_WINDOW_TICKS` ticks (:func:`_slope_now`;
        within the speed limits; 0 at a joint limit): a datagram one tick late (two targets in
        the next tick) moves it by a fraction, and the generator does not brake and back up for
        it.  So is its acceleration (:func:`_accel_weights`), which only running back onto the curve
        uses (:meth:`_follow`)."""
        target = self._inside(target_steps)
        hist = self._history
        # the window's targets, the latest of each tick, and this one: their least-squares
        # slope (one target that came a tick late or early moves it by a fraction, not by a
        # quarter of the speed)
        last: dict[int, list[float]] = {tk: x for tk, x in hist if 0 < tick - tk <= SERVO_SPEED_WINDOW_TICKS}
        if not last and hist and tick > hist[-1][0]:
            last = {hist[-1][0]: hist[-1][1]}  # (a pause in the stream longer than the window: the last one)
        if last:
            last[tick] = target
            pts = sorted(last.items())
            ts = [(tk - tick) * self.period for tk, _ in pts]
            v = [max(-vm, min(vm, _slope_now(ts, [x[j] for _, x in pts]))) for j, vm in enumerate(self.vmax)]
            # a joint whose target came again unchanged is held there (a client holding its
            # device still): at rest now, not once the whole window has the same target
            still = [abs(t - o) < 1e-9 for t, o in zip(target, hist[-1][1])]
            self.target_v = [0.0 if h else x for h, x in zip(still, v)]
            w = _accel_weights(ts)
            self.target_a = [0.0 if h else max(-am, min(am, sum(wi * x[j] for wi, (_, x) in zip(w, pts))))
                             for j, (h, am) in enumerate(zip(still, self.amax))]
        self.heading = [(t > o) - (t < o) for t, o in zip(target, hist[-1][1])]
        hist.append((tick, target))
        for j, (lo, hi) in enumerate(self.limits):
            if target[j] <= lo or target[j] >= hi:
                self.target_v[j] = self.target_a[j] = 0.0
        self.target, self.target_tick = target, tick
        self.targets += 1

    def finish(self, status: AckStatus, details: str) -> None:
        """End the stream with a controlled stop (then ``status`` / ``details``)."""
        if self.ending is None:
            self.ending = (status, details)
            self._silenced = False

    def resume(self) -> bool:
        """A target came while the stream slows down for a silence (not yet at rest: a
        client's datagrams held up for more than ``servo.timeout_s``): the stream goes on from
        where the slow-down got to.  False when it ends for another reason (STOP, a queued
        command): then it ends."""
        if self.ending is None or not self._silenced:
            return False
        self.ending, self._silenced = None, False
        return True

    def _constant_accel(self, want: Sequence[float],
                        vmax: Sequence[float]) -> tuple[list[float], list[float], list[float]]:
        """One period from the generator's state toward speeds ``want`` at the acceleration limit."""
        assert self._p is not None
        dt = self.period
        p, v, a = [], [], []
        for x0, v0, w, am, vm in zip(self._p, self._v, want, self.amax, vmax):
            v1 = v0 + max(-am * dt, min(am * dt, max(-vm, min(vm, w)) - v0))
            p.append(x0 + 0.5 * (v0 + v1) * dt)
            v.append(v1)
            a.append((v1 - v0) / dt)
        return p, v, a

    def _closing(self, gap: float, amax: float) -> float:
        """The speed (steps/s, relative to the target's) that closes ``gap`` (steps): the
        proportional term, no faster than the gap can still be braked away at half the
        acceleration limit with the jerk limit's ramp."""
        a = 0.5 * amax
        tj = self._jerk_time
        brake = -a * tj + math.sqrt((a * tj) ** 2 + 2.0 * a * abs(gap))
        return math.copysign(min(SERVO_GAIN_PER_S * abs(gap), brake), gap)

    def _update(self) -> bool:
        """One step of the generator; False when it cannot take this input."""
        try:
            return int(self._otg.update(self._in, self._out)) >= 0
        except self._error:
            return False

    def _generate(self, frame: Sequence[tuple[float, float, float]], vmax: Sequence[float],
                  modes: Sequence[object], speeds: Sequence[float]) -> tuple[list[float], list[float], list[float]]:
        """One step of the generator in a frame that moves with a curve (per joint: where it is
        at the start of this period, its speed and its acceleration, taken as constant): the
        generator's state relative to it, limited to what the joint's speed and acceleration
        limits leave beside the curve's own, toward 0 per joint in ``modes`` (ruckig's position
        interface: on the curve, at its speed) or toward the relative speed in ``speeds``
        (velocity interface); the state one period on, back in the joint's own terms.  (Ruckig
        computes in hundreds of steps: see :data:`_UNIT`.)"""
        assert self._p is not None
        inp, out, u, dt = self._in, self._out, _UNIT, self.period
        inp.per_dof_control_interface = list(modes)
        inp.max_velocity = [(vm - w) / u for vm, (_, w, _) in zip(vmax, frame)]
        inp.min_velocity = [(-vm - w) / u for vm, (_, w, _) in zip(vmax, frame)]
        inp.max_acceleration = [(am - b) / u for am, (_, _, b) in zip(self.amax, frame)]
        inp.min_acceleration = [(-am - b) / u for am, (_, _, b) in zip(self.amax, frame)]
        inp.max_jerk = [am / self._jerk_time / u for am in self.amax]
        inp.current_position = [(p - x) / u for p, (x, _, _) in zip(self._p, frame)]
        inp.current_velocity = [(v - w) / u for v, (_, w, _) in zip(self._v, frame)]
        inp.current_acceleration = [(a - b) / u for a, (_, _, b) in zip(self._a, frame)]
        inp.target_position = [0.0] * 6
        inp.target_velocity = [max(lo, min(hi, x / u)) for x, lo, hi in zip(speeds, inp.min_velocity, inp.max_velocity)]
        inp.target_acceleration = [0.0] * 6
        if not self._update():
            # refused (ruckig's velocity interface failed on some states, "error in step 1";
            # its output is last tick's, which repeated froze the stream with its
            # feed-forward): change the speed toward the curve's at the acceleration limit
            # instead (jerk unlimited for this tick)
            return self._constant_accel([w + x for (_, w, _), x in zip(frame, speeds)], vmax)
        p, v, a = [], [], []
        for (x, w, b), vm, dp, dv, da in zip(frame, vmax, out.new_position, out.new_velocity, out.new_acceleration):
            p.append(x + w * dt + 0.5 * b * dt * dt + dp * u)
            v.append(max(-vm, min(vm, w + b * dt + dv * u)))
            a.append(b + da * u)
        return p, v, a

    def _slow_down(self, vmax: Sequence[float]) -> tuple[list[float], list[float], list[float]]:
        """One period of the controlled stop: toward rest at the acceleration limit (in a frame
        at rest), and then back onto the curve once targets come again (:meth:`_follow`)."""
        self._rejoin = [True] * 6
        return self._generate([(0.0, 0.0, 0.0)] * 6, vmax, [self._interface.Velocity] * 6, [0.0] * 6)

    def _follow(self, tick: int, vmax: Sequence[float]) -> tuple[list[float], list[float], list[float]]:
        """One period of following the streamed curve: the latest target moved on by its speed
        to this tick.  A target at rest is reached exactly, at rest (ruckig's position
        interface).  A moving one is followed at its speed, and the distance to it closed
        with a proportional term (no faster than it can be braked away): a target that came a
        tick late or was dropped moves the frames by a fraction.  A joint that fell behind
        (the guard's box held it back, or it slowed down for a silence or a pause) runs back
        onto the curve time-optimally instead: relative to the curve moving on at its speed and
        acceleration, to on it at its speed, within what the joint's limits leave beside the
        curve's own; once there (within a tick's travel at the curve's speed) it follows as
        before.  So it keeps what speed it has and joins the curve within the limits, without
        starting from rest or running past it."""
        assert self._p is not None
        dt = self.period
        off = (tick - self.target_tick) * dt
        moving = any(self.target_v)
        frame, modes, speeds = [], [], []
        position, velocity = self._interface.Position, self._interface.Velocity
        for j in range(6):
            vm, am = vmax[j] * _CURVE_SHARE, self.amax[j] * _CURVE_SHARE
            lo, hi = self.limits[j]
            w = max(-vm, min(vm, self.target_v[j]))
            x = self.target[j] + w * off
            if not moving or not lo < x < hi:  # (a target at rest, or at a joint limit: at rest there)
                frame.append((min(max(x, lo), hi), 0.0, 0.0))
                modes.append(position)
                speeds.append(0.0)
                continue
            if self._rejoin[j]:
                b = max(-am, min(am, self.target_a[j]))
                xr = min(max(x + 0.5 * b * off * off, lo), hi)
                wr = max(-vm, min(vm, w + b * off))
                # on the curve again: within a tick's travel at its speed, and able to stop
                # relative to it within that too
                far = abs(self._p[j] - xr) + (self._v[j] - wr) ** 2 / (2.0 * self.amax[j])
                self._rejoin[j] = far > dt * abs(wr) + _ON_CURVE_STEPS
                if self._rejoin[j]:
                    frame.append((xr, wr, b))
                    modes.append(position)
                    speeds.append(0.0)
                    continue
            # the distance to the curve closed with the proportional term, relative to its
            # speed (the frame moves on with the curve over the period)
            frame.append((x, w, 0.0))
            modes.append(velocity)
            speeds.append(self._closing(x - self._p[j], self.amax[j]))
        return self._generate(frame, vmax, modes, speeds)

    def _never_back(self, p: list[float], v: list[float], a: list[float]) -> None:
        """No joint runs against the way the stream's last two targets went: a joint the
        generator would turn back (or start back from rest) stops there instead (within this
        period: its speed was within a period's acceleration of 0), and waits for the targets
        to pass it.  A target taken in late (a busy machine held the datagram up) lies behind
        where the follower's estimate of the stream's speed carried the arm meanwhile, and the
        target's speed, fitted by the tick it was taken in, is too low: the curve then lay
        behind the arm, which ran back at up to 965 steps/s.  A target the client sends again (held still)
        is reached, back if need be: that is where the client wants the arm."""
        assert self._p is not None
        for j, d in enumerate(self.heading):
            # (one still moving the other way, the stream having turned, brakes as before)
            if d and v[j] * d < 0.0 <= self._v[j] * d:
                p[j] = self._p[j] + 0.5 * self._v[j] * self.period
                v[j] = a[j] = 0.0

    def _held_back(self, p: Sequence[float], v: Sequence[float], a: Sequence[float], box: Sequence[tuple[float, float]]
                   ) -> tuple[list[float], list[float], list[float], tuple[int, ...], tuple[int, ...]] | None:
        """The generator's state ``p``, ``v``, ``a`` held back into the guard's box (late
        replies: where the board may be is uncertain), and its frame (targets, feed-forwards).
        Per joint whose goal lies outside: the speed nearest the generator's that keeps the
        goal inside, changed from the last frame's by no more than the acceleration limit
        allows (so a joint the box holds back a little keeps most of its speed, and one it
        holds back longer slows down within the limit, not to rest at once); where that is not
        enough the goal is put on the box's nearest point (the box comes first) and the speed
        kept as it is, for when the box opens again.  Those joints then run back onto the
        curve (:meth:`_follow`).  None when the box is empty on a joint (hold still instead)."""
        assert self._p is not None
        dt, c = self.period, _FF_STEP
        p1, v1, a1 = list(p), list(v), list(a)
        pos, ff = [], []
        stopped = False
        for j, (lo, hi) in enumerate(box):
            if lo > hi:
                return None
            x, w = p1[j], v1[j]
            t, f = int(round(x)), int(round(w))
            if lo <= t + f * c <= hi:
                pos.append(t)
                ff.append(f)
                continue
            self._rejoin[j] = True
            x0, w0, am = self._p[j], self._v[j], self.amax[j]
            # the goal after a speed u this period, x0 + (w0 + u) dt / 2 + u c, rises with u
            base, k = x0 + 0.5 * w0 * dt, 0.5 * dt + c
            u = min(max(w, (lo + 0.5 - base) / k), (hi - 0.5 - base) / k)
            u = min(max(u, w0 - am * dt, -self.vmax[j]), w0 + am * dt, self.vmax[j])
            x = base + 0.5 * u * dt
            f = int(round(u))
            if not lo <= x + u * c <= hi:
                # stopped harder than the acceleration limit allows: the goal on the box
                stopped = True
                x = min(max(x + u * c, lo), hi) - u * c
            # whole steps: the nearest that keep the goal inside (the feed-forward carries the
            # rest); in a box narrower than a step, the box's point in hundredths
            t = int(round(x))
            if t + f * c > hi:
                t = int(math.floor(hi - f * c))
            elif t + f * c < lo:
                t = int(math.ceil(lo - f * c))
            if not lo <= t + f * c <= hi:
                one = _towards([x + u * c], [(lo, hi)])
                assert one is not None
                t, f = one[0][0], one[1][0]
                stopped = True
            # (the state: the frame's goal at speed u; no acceleration carried on: the box's
            # braking is not the generator's, and the jerk limit would take its time to undo it)
            p1[j], v1[j], a1[j] = t + f * c - u * c, u, 0.0
            pos.append(t)
            ff.append(f)
        self.held_ticks += 1
        if stopped:
            self.box_stops += 1
        return p1, v1, a1, tuple(pos), tuple(ff)

    def step(self, ctx: TickContext) -> FrameRequest:
        box = ctx.box
        if self._p is None:
            if ctx.origin is None or box is None:
                self.target_tick = ctx.tick  # nothing known yet: the silence counts from the start
                return FrameRequest(BoardCommand.IDLE)
            self._p = [float(x) for x in ctx.origin]
        silent = ctx.tick - self.target_tick > self.timeout_ticks
        if silent and self.ending is None:
            self.ending = (AckStatus.COMPLETED, f"servo stream ended: no target for "
                                                f"{self.timeout_ticks / self.rate_hz:g} s, stopped under control")
            self._silenced = True
        scale = ctx.speed_scale
        stopping = self.ending is not None or scale <= 0.0
        vmax = [max(v * scale, 1.0) for v in self.vmax]
        if stopping:
            p, v, a = self._slow_down(vmax)
        else:
            p, v, a = self._follow(ctx.tick, vmax)
            self._never_back(p, v, a)
        pos = tuple(int(round(x)) for x in p)
        ff = tuple(int(round(x)) for x in v)
        if box is not None and not _in_box(pos, ff, box):
            held = self._held_back(p, v, a, box)
            if held is None:
                return FrameRequest(BoardCommand.IDLE)
            p, v, a, pos, ff = held
        self._p, self._v, self._a = p, v, a
        self.progress = 0.0
        if stopping and all(abs(x) < 1.0 for x in v):
            if self.ending is None:  # paused: hold here, the stream goes on after RESUME
                self.target_tick = ctx.tick
                return FrameRequest(BoardCommand.GOTO, pos, _ZERO6)
            status, details = self.ending
            self.progress = 1.0
            return FrameRequest(BoardCommand.GOTO, pos, _ZERO6, done=status, details=details)
        return FrameRequest(BoardCommand.GOTO, pos, ff)


class GuardStopActivity(TrajectoryActivity):
    """The stop the collision check chose for a jog or a servo stream (the controller's
    :mod:`~parolkit.controller.world`): its samples played as a trajectory (every frame a
    bounded commitment, settled on its last target), at their own speed whatever the speed
    override or a pause (it is a stop); the job then ends with ``status`` and ``details`` (the
    pair and why)."""

    def __init__(self, samples: Samples, *, settle_ticks: int, started: float, status: AckStatus,
                 details: str) -> None:
        super().__init__(samples, settle_ticks=settle_ticks, started=started, schedule_start=started)
        self.outcome = (status, details)

    def step(self, ctx: TickContext) -> FrameRequest:
        out = super().step(replace(ctx, speed_scale=1.0))
        if out.done is AckStatus.COMPLETED:
            return replace(out, done=self.outcome[0], details=self.outcome[1])
        if out.done is not None:
            return replace(out, done=self.outcome[0], details=f"{self.outcome[1]}; {out.details}")
        return out


class DoneActivity(Activity):
    """A command whose work was done when it started (ATTACH, DETACH): COMPLETED with
    ``details`` in the tick it runs, without a frame of its own (``frameless_end``: the next
    queued command takes that tick)."""

    frameless_end = True

    def __init__(self, details: str) -> None:
        self.details = details

    def step(self, ctx: TickContext) -> FrameRequest:
        self.progress = 1.0
        return FrameRequest(BoardCommand.IDLE, done=AckStatus.COMPLETED, details=self.details)


class HomeActivity(Activity):
    """Send HOME (100) once, then IDLE until the board has been SEEN homing and then reports
    every joint homed at standby, at rest.

    Seen homing: a status frame after HOME shows the homed bits lower than before, a speed
    (the controller sends only zero speeds meanwhile: any speed is the board's homing) or a
    position that changed; or ``seen()`` says so (two raw frames in a row showed it).
    Without that, a board that was homed at standby already looks finished at once; a
    disabled board ignores HOME and would look the same.  FAILED when the
    board shows no homing within ``start_timeout_ticks`` (it is disabled, or HOME was lost) or
    does not finish within ``timeout_ticks``.
    """

    def __init__(self, standby_steps: Sequence[int], timeout_ticks: int, min_ticks: int = 5,
                 start_timeout_ticks: int = 50) -> None:
        self.standby = tuple(standby_steps)
        self.sent = False
        self.ticks = 0
        self.timeout_ticks = timeout_ticks
        self.min_ticks = min_ticks
        self.start_timeout_ticks = start_timeout_ticks
        #: the status when HOME was sent (None: none yet) and whether homing was seen since
        self.before: StatusFrame | None = None
        self.started = False
        self.started_with: StatusFrame | None = None

    def _homing_seen(self, st: StatusFrame) -> bool:
        b = self.before
        if any(st.speeds):
            return True
        if b is None:
            return False
        return (st.homed & b.homed) != b.homed or tuple(st.positions) != tuple(b.positions)

    def step(self, ctx: TickContext) -> FrameRequest:
        if not self.sent:
            self.sent = True
            self.before = ctx.status
            return FrameRequest(BoardCommand.HOME)
        self.ticks += 1
        st = ctx.status
        if st is not None:
            if not self.started and (self._homing_seen(st) or ctx.homing_seen):
                self.started = True
                # the frame that was the status then says nothing about the end: during a
                # homing faster than expected the status may stay the one from before it
                self.started_with = st
            self.progress = min(0.99, sum(st.homed_joints) / 6.0) if self.started else 0.0
            if (
                self.started and st is not self.started_with and st.all_homed and self.ticks >= self.min_ticks
                and not any(st.speeds) and tuple(st.positions) == self.standby
            ):
                self.progress = 1.0
                return FrameRequest(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if not self.started and self.ticks >= self.start_timeout_ticks:
            return FrameRequest(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"the board did not start homing within {self.start_timeout_ticks / ctx.rate_hz:g} s: "
                                f"is it disabled? send ENABLE, then HOME")
        if self.ticks >= self.timeout_ticks:
            return FrameRequest(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"homing did not finish within {self.timeout_ticks / ctx.rate_hz:.0f} s")
        return FrameRequest(BoardCommand.IDLE)


class DelayActivity(Activity):
    """Hold still for a number of ticks: its frames are exactly ``ticks`` frames, and it ends
    (COMPLETED) in the tick after the last, without a frame of its own (``frameless_end``: the
    next queued command takes that tick).  So the ack comes once the whole time has passed,
    and what follows starts exactly ``ticks`` periods after the delay's first frame."""

    frameless_end = True

    def __init__(self, ticks: int) -> None:
        self.ticks = max(0, int(ticks))
        self.i = 0

    def step(self, ctx: TickContext) -> FrameRequest:
        self.i += 1
        self.progress = min(1.0, self.i / max(1, self.ticks))
        if self.i > self.ticks:
            return FrameRequest(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        return FrameRequest(BoardCommand.IDLE)


class CheckpointActivity(Activity):
    """A CHECKPOINT: COMPLETED (details ``checkpoint LABEL``) as soon as it runs, i.e. when
    everything queued before it has ended.  Its end needs no frame (``frameless_end``): the
    next queued command takes that tick."""

    frameless_end = True

    def __init__(self, label: str) -> None:
        self.label = label

    def step(self, ctx: TickContext) -> FrameRequest:
        self.progress = 1.0
        return FrameRequest(BoardCommand.IDLE, done=AckStatus.COMPLETED, details=f"checkpoint {self.label}")


class OneShotActivity(Activity):
    """One frame (optionally with a one-shot gripper mode), COMPLETED with it."""

    def __init__(self, gripper_mode: int = GripperMode.OPERATE) -> None:
        self.mode = gripper_mode

    def step(self, ctx: TickContext) -> FrameRequest:
        self.progress = 1.0
        return FrameRequest(BoardCommand.IDLE, gripper_mode=self.mode, done=AckStatus.COMPLETED)


class GripperCalibrateActivity(Activity):
    """Calibrate the SSG-48: one frame with the one-shot CALIBRATE mode, then IDLE frames until
    the gripper's status shows the calibration ran and ended: the "calibrated" bit (0x01)
    clear, and after that set.  COMPLETED then.

    The gripper ignores moves while it calibrates (a move sent then was lost for good), so the
    queue waits here: whatever follows reaches a calibrated gripper.  A gripper that was
    calibrated before reports the bit set until it takes the calibrate message, which is not
    the end: the bit must be seen clear first.  Each of the two needs two new status frames in
    a row (the link has no checksum: one corrupted status byte is not the gripper's word).
    FAILED after ``timeout_ticks`` without that.  Its end needs no frame (``frameless_end``):
    the next queued command takes that tick."""

    frameless_end = True

    def __init__(self, timeout_ticks: int) -> None:
        self.timeout_ticks = timeout_ticks
        self.i = 0
        #: two status frames in a row showed the calibrated bit clear since the calibrate frame
        self.calibrating = False
        #: the newest status frame counted, and how many new ones in a row showed what it shows
        self._last: StatusFrame | None = None
        self._run = 0

    def step(self, ctx: TickContext) -> FrameRequest:
        self.i += 1
        if self.i == 1:
            return FrameRequest(BoardCommand.IDLE, gripper_mode=GripperMode.CALIBRATE)
        st = ctx.status
        if st is not None and st is not self._last:
            same = self._last is not None and self._last.gripper.calibrated == st.gripper.calibrated
            self._run = self._run + 1 if same else 1
            self._last = st
            if self._run >= 2 and not st.gripper.calibrated:
                self.calibrating = True
                self.progress = 0.5
            elif self._run >= 2 and self.calibrating:
                self.progress = 1.0
                return FrameRequest(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if self.i > self.timeout_ticks:
            status = "none" if st is None else f"0x{st.gripper_status:02X}"
            why = ("bit 0x01 clear): is an SSG-48 connected?" if self.calibrating else
                   "bit 0x01 never cleared: the gripper did not start calibrating)")
            return FrameRequest(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"the gripper did not report calibrated within {self.timeout_ticks / ctx.rate_hz:g} s "
                                f"of the calibrate (GET_GRIPPER status {status}, {why}")
        return FrameRequest(BoardCommand.IDLE)


class OutputActivity(Activity):
    """Drive OUT1/OUT2 (the frame already carries the new level) and complete when the board's
    status reports that level, so a GET_IO after COMPLETED reads what was asked. FAILED after
    ``timeout_ticks`` without that report (a board that does not echo its outputs, or a link
    dropping every reply).  Its end needs no frame (``frameless_end``): the next queued command
    takes that tick, so an Output() holds the queue for one tick, as in the original."""

    frameless_end = True

    def __init__(self, port: int, on: bool, timeout_ticks: int) -> None:
        self.port = port
        self.on = on
        self.timeout_ticks = timeout_ticks
        self.i = 0

    def step(self, ctx: TickContext) -> FrameRequest:
        self.i += 1
        st = ctx.status
        # the status read before this tick answers the frame sent in an earlier tick, which
        # already carried the new level; the first tick has not sent it yet
        if self.i >= 2 and st is not None and st.outputs[self.port - 1] == self.on:
            self.progress = 1.0
            return FrameRequest(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if self.i > self.timeout_ticks:
            return FrameRequest(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"the board did not report OUT{self.port} = {int(self.on)} within "
                                f"{self.timeout_ticks / ctx.rate_hz:g} s")
        self.progress = min(0.99, self.i / max(1, self.timeout_ticks))
        return FrameRequest(BoardCommand.IDLE)


class WaitInputActivity(Activity):
    """Hold still until digital input ``number`` (1|2) reads ``state``; FAILED after a timeout."""

    def __init__(self, number: int, state: bool, timeout_ticks: int | None) -> None:
        self.number = number
        self.state = state
        self.timeout_ticks = timeout_ticks
        self.i = 0
        self.matches = 0

    def step(self, ctx: TickContext) -> FrameRequest:
        self.i += 1
        st = ctx.status
        # two ticks in a row: one corrupted IO byte (no checksum on the link) is not an input
        self.matches = self.matches + 1 if st is not None and st.inputs[self.number - 1] == self.state else 0
        if self.matches >= 2:
            self.progress = 1.0
            return FrameRequest(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if self.timeout_ticks is not None:
            self.progress = min(1.0, self.i / max(1, self.timeout_ticks))
            if self.i >= self.timeout_ticks:
                return FrameRequest(BoardCommand.IDLE, done=AckStatus.FAILED,
                            details=f"IN{self.number} did not become {int(self.state)} within "
                                    f"{self.timeout_ticks / ctx.rate_hz:g} s")
        return FrameRequest(BoardCommand.IDLE)


def ticks_for(seconds: float, rate_hz: float) -> int:
    """Whole ticks covering ``seconds`` (at least 1)."""
    return max(1, int(math.ceil(seconds * rate_hz - 1e-9)))
