"""Accepted commands (:class:`Job`) and what they do tick by tick (activities).

An activity's :meth:`Activity.step` is called once per tick by the loop thread and must be
small and bounded: it indexes precomputed arrays or compares a few numbers.  It returns a
:class:`Step`: the board command and values for this tick and, when the job ends with this
frame, its terminal status.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from parolkit.controller.pacing import GotoFits, SentLog, goto_fits, tracking_speed
from parolkit.protocol.commands import AckStatus, Command
from parolkit.protocol.frames import BoardCommand, GripperMode, StatusFrame
from parolkit.robot import JOINT_NAMES

__all__ = [
    "Job", "PlanAhead", "Step", "TickContext", "Activity", "TrajectoryActivity", "SpeedActivity",
    "HomeActivity", "DelayActivity", "OneShotActivity", "GripperCalibrateActivity", "WaitInputActivity",
    "OutputActivity",
]

_ZERO6 = (0, 0, 0, 0, 0, 0)

#: a trajectory's samples as Python lists: per-tick positions and speeds (steps, 6 joints
#: each) and board command codes
Samples = tuple[list[list[int]], list[list[int]], list[int]]


class PlanAhead:
    """A plan started when the server parsed a motion command, before the tick takes it in.

    Only while the robot is idle (nothing active, queued or streaming): the plan starts from the
    measured joints, so the job it belongs to can start at the very tick that takes it in
    instead of waiting a tick for the planner.  If anything changed meanwhile (the robot moved,
    another command got ahead of it, the tool changed), the plan is not used and the job is
    planned as usual.  Fields are written under the executor lock."""

    __slots__ = ("command", "start", "tool_name", "trajectory", "error", "done", "job")

    def __init__(self, command: Command, start: tuple[float, ...], tool_name: str) -> None:
        self.command = command
        self.start = start
        self.tool_name = tool_name
        self.trajectory: object | None = None
        self.error: str | None = None
        self.done = False
        self.job: Job | None = None


#: a plan's notes that start so are warnings (``parolkit.motion.validate.WARNING_PREFIX``, not
#: imported here: the controller loads the planners only when first needed)
WARNING_PREFIX = "warning: "


@dataclass
class Job:
    """One accepted command, from QUEUED to its terminal ack.

    Planning fields are written by the planner thread under the executor lock.
    """

    seq: int
    command: Command
    command_id: str | None
    #: (host, port) acks go to; None for internal jobs (start-up homing)
    #: where acks go: one or more (host, port) pairs, or None without a command ID
    ack_addr: tuple[tuple[str, int], ...] | None
    accepted_at: float
    #: set by the planner: start/final joint angles (deg) the plan assumes, or None
    start_deg: tuple[float, ...] | None = None
    final_deg: tuple[float, ...] | None = None
    planned: bool = False
    plan_error: str | None = None
    trajectory: object | None = None
    #: trajectory samples as Python lists (positions, speeds, commands), built off the tick
    samples: Samples | None = None
    notes: tuple[str, ...] = ()
    #: streaming jog (replaces the previous one instead of queueing)
    streamed: bool = False
    #: streamed Cartesian jog planned from where the running streamed jog was commanded:
    #: (that jog's activity, its sample index then), to line the two up when it takes over
    stream_anchor: tuple[object, int] | None = None
    #: streamed Cartesian jog: where the running jog's plan was when this one was planned
    #: from its commanded position (a ``parolkit.motion.cartesian.JogStart``: its path's
    #: orientation and joint speeds there), so the update continues it; None otherwise
    jog_start: object | None = None
    terminal: AckStatus | None = None
    #: the plan made ahead for this job before it was queued, until used
    ahead: PlanAhead | None = None
    #: who sent it (see Submission.client)
    client: str = ""
    @property
    def name(self) -> str:
        return self.command.name

    @property
    def warnings(self) -> tuple[str, ...]:
        """The plan's notes that are warnings (``warning: ...``, e.g. a move with t that needs
        more than a joint's acceleration limit): added to the details of this job's EXECUTING
        and COMPLETED acks (see :meth:`ack_details`)."""
        return tuple(n for n in self.notes if n.startswith(WARNING_PREFIX))

    @property
    def label(self) -> str:
        """The command in ack details: its class name (``MoveJoint``, ``SmoothCircle``, ``CartJog``)."""
        return type(self.command).__name__.removesuffix("Command")

    def ack_details(self, status: AckStatus, details: str) -> str:
        """The details text of this job's ack with ``status``, built here only.

        COMPLETED says ``details`` or, when the activity gave none, ``<label> finished
        successfully`` (the original controller's "MoveJointCommand finished successfully");
        EXECUTING and COMPLETED then carry :attr:`warnings`, joined with ``"; "`` (a text
        already in ``details`` is not repeated).  Other statuses keep ``details`` as they are."""
        if status is AckStatus.COMPLETED and not details:
            details = f"{self.label} finished successfully"
        if status not in (AckStatus.EXECUTING, AckStatus.COMPLETED) or not self.warnings:
            return details
        parts = [details] if details else []
        parts += [w for w in self.warnings if w and w not in details]
        return "; ".join(parts)


@dataclass(frozen=True)
class TickContext:
    """What an activity may look at: tick number, time (s), rate, latest status frame."""

    tick: int
    now: float
    rate_hz: float
    status: StatusFrame | None
    homed: bool
    stream_mode: bool
    watchdog_s: float
    limits_steps: tuple[tuple[int, int], ...]
    #: ``goto_check(targets, feed_forwards, status, now)``: would the safety guard pass this 156
    #: frame now (``SafetyGuard.accepts_goto``)?  None: judge with the pacing model alone
    goto_check: Callable[[Sequence[int], Sequence[int], StatusFrame | None, float], bool] | None = None
    #: the time trajectories are scheduled on (s): ``now``, or, with a board in lockstep with
    #: the frames (each frame runs it exactly one period: a simulated board with a frame
    #: clock), ``tick / rate_hz``: that board's own time, which a late tick does not advance
    clock_s: float | None = None

    @property
    def schedule_s(self) -> float:
        """:attr:`clock_s`, or ``now`` when it is not set."""
        return self.now if self.clock_s is None else self.clock_s


@dataclass(frozen=True)
class Step:
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
    #: True while the activity streams speeds (123)
    streams_speed: bool = False
    #: True when its frames move the robot (a paused one gets stop frames, see :meth:`held`)
    moves: bool = False
    #: True when the step that ends it needs no frame of its own (it ends on what the board
    #: reported): the executor lets the next queued job take that tick
    frameless_end: bool = False

    def step(self, ctx: TickContext) -> Step:  # pragma: no cover - abstract
        raise NotImplementedError

    def touch(self, now: float) -> None:
        """A streaming update arrived (resets the watchdog)."""

    def held(self, now: float, stop: Step) -> None:
        """The loop sent the stop frame ``stop`` at ``now`` instead of asking this activity
        (replies went missing); it is stepped again once they come back."""


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


class TrajectoryActivity(Activity):
    """Play a planned trajectory against real time, then settle on the target.

    Sample ``i`` is due ``i`` periods after the first frame (its positions are where the joints
    should be one period later).  A tick plays what is due at the time it actually runs, so a
    late tick does not push the rest of the move back (a timed move keeps its wall-clock
    duration):

    * position tracking (156): the target is the plan at the elapsed time (interpolated between
      samples), but a late tick advances it only as far as the board can follow within its
      maximum speed (``fits``, by default :func:`~parolkit.controller.pacing.goto_fits`: the
      target's step since the previous frame and the board's speed right after it); a move
      that fell further behind catches up over the next ticks, and never goes back.  After
      the last sample the target is sent with zero feed-forward every tick until a status frame
      shows the board exactly on it and at rest: then COMPLETED (the seed: "with speed +
      position the robot reaches exactly the commanded position"); FAILED, naming the joints
      that are off, if that takes more than ``settle_ticks``;
    * speed tracking (123): the distance a speed covers is speed x the time it actually ran,
      so each frame's speed is the one that takes every joint from where the board model
      estimates it now to the position the plan has for the next deadline, over at least one
      period (:func:`~parolkit.controller.pacing.tracking_speed`; counting on a shorter time
      would overshoot whenever the next tick comes late), within the maximum speed; after the
      last sample the remaining error is corrected the same way, then zero-speed frames until a
      status frame shows the board stopped where planned (else one more correction), so the
      move ends where it was planned.
    """

    def __init__(self, samples: Samples, *, settle_ticks: int, max_speed_steps_s: Sequence[float],
                 settle_tol_steps: int = 4, streamed: bool = False, started: float = 0.0,
                 fits: GotoFits = goto_fits, schedule_start: float | None = None) -> None:
        self.positions, self.speeds, self.commands = samples
        self.n = len(self.positions)
        #: the next whole sample to play (``n``: all played, settling)
        self.i = 0
        self.settle_left = settle_ticks
        self.settle_ticks = settle_ticks
        self.settle_tol = settle_tol_steps
        self.streamed = streamed
        self.last_update = started
        self.streams_speed = bool(self.n) and any(c == BoardCommand.JOG for c in self.commands)
        self.moves = True
        self.vmax = tuple(float(v) for v in max_speed_steps_s)
        self.fits = fits
        #: time of the first frame (sample 0 is due then); ``skip`` moves the schedule on
        self.t0 = started if schedule_start is None else schedule_start
        self._offset = 0
        self.log = SentLog()
        #: where in the samples the last 156 frame was (fractional), its target and time
        self._s: float | None = None
        self._prev_goto: tuple[Sequence[int], float] | None = None
        #: ticks waited before the first frame (see :meth:`_waits_to_start`)
        self._start_waits = 0
        self._last_target: tuple[int, ...] | None = None
        #: speed tracking's end: the status frame when the zero-speed frames began (see
        #: :meth:`_speed_step`; False: none then)
        self._stop_mark: StatusFrame | bool | None = None

    def touch(self, now: float) -> None:
        self.last_update = now

    def held(self, now: float, stop: Step) -> None:
        """Paused by the loop (``stop`` sent): the board model knows it stopped; the schedule
        runs on, so once replies are back the move catches up as after a late tick."""
        self.log.record(now, stop.command, stop.positions or _ZERO6, stop.speeds)
        if stop.command == BoardCommand.GOTO and stop.positions is not None:
            # the guard judges the next target's step from this frame (its time), not from
            # the activity's last own one before the pause
            self._prev_goto = (tuple(stop.positions), now)

    def commanded(self) -> tuple[int, ...] | None:
        """Position (steps) of the last target sent to the board; None before the first."""
        return self._last_target

    def skip(self, k: int) -> None:
        """Start ``k`` samples in (at most at the last one): a streamed jog planned from
        another's commanded position ``k`` ticks before it took over continues where that
        one would be now, instead of stepping back by ``k`` ticks."""
        self.i = max(0, min(int(k), self.n - 1))
        self._offset = self.i

    def _elapsed_samples(self, now: float, rate_hz: float) -> float:
        """The (fractional) sample due at ``now``."""
        return (now - self.t0) * rate_hz + self._offset

    def _ask(self, now: float, cmd: int, pos: Sequence[int], spd: Sequence[int], done: AckStatus | None = None,
             details: str = "") -> Step:
        self.log.record(now, cmd, pos, spd)
        target = tuple(pos)
        if cmd == BoardCommand.GOTO:
            self._prev_goto = (target, now)
        self._last_target = target
        return Step(cmd, target, tuple(spd), done=done, details=details)

    def _at(self, s: float) -> tuple[list[int], list[int]]:
        """Target and feed-forward at sample coordinate ``s``, linear between samples."""
        k = int(s)
        f = s - k
        if f <= 1e-9 or k + 1 >= self.n or self.commands[k + 1] != self.commands[k]:
            return self.positions[k], self.speeds[k]
        p0, p1, v0, v1 = self.positions[k], self.positions[k + 1], self.speeds[k], self.speeds[k + 1]
        return ([int(round(a + f * (b - a))) for a, b in zip(p0, p1)],
                [int(round(a + f * (b - a))) for a, b in zip(v0, v1)])

    #: how many ticks a position-tracked move waits for the board to slow down before its first
    #: frame (then it is sent all the same, and the guard's refusal says why)
    START_WAIT_TICKS = 50

    def _waits_to_start(self, ctx: TickContext) -> bool:
        """Before the first 156 frame: True (send IDLE, start the schedule later) while even
        the first sample is one the guard would refuse -- the board still running from what came
        before (a STOP's hold, a move cancelled at speed): the IDLE frame stops it, and the move
        starts a tick later on its full time instead of FAILing on a refusal."""
        if ctx.goto_check is None or self._prev_goto is not None or self._s is not None:
            return False
        if self._start_waits >= self.START_WAIT_TICKS or self._guard_passes(ctx, float(self.i)):
            return False
        self._start_waits += 1
        self.t0 = ctx.schedule_s + 1.0 / ctx.rate_hz  # sample i is due at the next tick
        self._offset = self.i
        return True

    def _guard_passes(self, ctx: TickContext, s: float) -> bool:
        """The guard's verdict on the 156 frame for sample coordinate ``s`` now
        (``ctx.goto_check`` must be set)."""
        assert ctx.goto_check is not None
        pos, ff = self._at(s)
        return ctx.goto_check(pos, ff, ctx.status, ctx.schedule_s)

    def _goto_sample(self, ctx: TickContext) -> float:
        """Where in the samples the next 156 target is: what is due now, but no further than
        the board can follow from where it is (back along the plan only when even the previous
        target would ask the board for more than its maximum).  With the guard's own
        judgement at hand (``ctx.goto_check``) every target is one it passes (else the
        furthest such one from the previous target on); without it, the pacing model
        judges catch-ups of more than one sample."""
        want = min(max(self._elapsed_samples(ctx.schedule_s, ctx.rate_hz), float(self.i)), self.n - 1.0)
        prev, s_prev = self._prev_goto, self._s
        check = ctx.goto_check

        def passes(s: float) -> bool:
            return self._guard_passes(ctx, s)

        if prev is None or s_prev is None:
            # the first target: normally the first sample; after a pause that began before it
            # (replies missing, stop frames sent) the schedule ran on, but the board is still
            # where it rested: the furthest target the guard passes from it
            first = float(self.i)
            if check is None or want <= first or passes(want):
                return want
            return _boundary(passes, good=first, bad=want) if passes(first) else first
        want = max(want, s_prev)
        target, t_prev = prev
        if check is not None:
            ok = passes
        else:
            x = self.log.estimate(ctx.status, ctx.now)
            if x is None or want - s_prev <= 1.0:
                return want  # the plan's own pace (at most one sample per period: the planner's bound)
            dt = ctx.now - t_prev

            def ok(s: float) -> bool:
                pos, ff = self._at(s)
                return self.fits(pos, ff, target, dt, x, self.vmax)

        if ok(want):
            return want
        pace = min(s_prev + 1.0, self.n - 1.0)
        if check is not None and want < pace and ok(pace):
            # the board is further on than "due now" says (the previous frame ran longer than
            # planned for): the nearest target ahead that the guard passes
            return _boundary(ok, good=pace, bad=want)
        step1 = min(s_prev + 1.0, want)
        if ok(step1):
            return _boundary(ok, good=step1, bad=want)
        if check is None or ok(s_prev):
            return _boundary(ok, good=s_prev, bad=step1)
        # even the previous target would ask the board for more than its maximum (the guard
        # sees it further behind than that target allows): a target a little back along the
        # plan, still ahead of the board, keeps its start speed within the maximum; the plan's
        # clock runs on and the next ticks catch up
        back = max(0.0, s_prev - 2.0)
        return _boundary(ok, good=back, bad=s_prev) if ok(back) else s_prev

    def _speed_step(self, ctx: TickContext, k: int) -> Step:
        """A speed-tracked sample ``k``: the speed that reaches its position by the next
        deadline; on the last sample, the correction of what is left, then zero speed."""
        now = ctx.now
        last = k == self.n - 1
        target = self.positions[k]
        x = self.log.estimate(ctx.status, now)
        if x is None:
            speeds: Sequence[int] = self.speeds[k]
        else:
            period = 1.0 / ctx.rate_hz
            due_at = self.t0 + (k + 1 - self._offset) * period
            interval = max(due_at - ctx.schedule_s, period)
            if last:  # the end: over no less than the last tick gap (should the next be as late)
                prev = self.log.last_time()
                interval = max(interval, now - prev if prev is not None else period)
            vm = self.vmax
            speeds = [tracking_speed(target[j], x[j], interval, -vm[j], vm[j]) for j in range(6)]
        if last:
            self.settle_left -= 1
            close = x is None or all(abs(target[j] - x[j]) <= self.settle_tol for j in range(6))
            st = ctx.status
            if self.settle_left < 0 or x is None:
                self.i = self.n
                self.progress = 1.0
                return self._ask(now, BoardCommand.JOG, target, _ZERO6, AckStatus.COMPLETED)
            if close or not any(speeds):
                # stop, and end once a status frame shows the board stopped where planned (the
                # reply to the frame after the stop: a stop that reached it late let it run on)
                if self._stop_mark is None:
                    self._stop_mark = st if st is not None else False
                elif st is not None and st is not self._stop_mark and not any(st.speeds):
                    if all(abs(target[j] - st.positions[j]) <= self.settle_tol for j in range(6)):
                        self.i = self.n
                        self.progress = 1.0
                        return self._ask(now, BoardCommand.JOG, target, _ZERO6, AckStatus.COMPLETED)
                    self._stop_mark = None
                    vm = self.vmax
                    speeds = [tracking_speed(target[j], st.positions[j], interval, -vm[j], vm[j])
                              for j in range(6)]
                    self.i = k
                    self.progress = self.i / self.n
                    return self._ask(now, BoardCommand.JOG, target, speeds)
                speeds = _ZERO6
            self.i = k
        else:
            self.i = k + 1
        self.progress = self.i / self.n
        return self._ask(now, BoardCommand.JOG, target, speeds)

    def step(self, ctx: TickContext) -> Step:
        if self.streamed and ctx.stream_mode and ctx.now - self.last_update > ctx.watchdog_s:
            pos = ctx.status.positions if ctx.status else None
            zero = BoardCommand.JOG if self.streams_speed else BoardCommand.IDLE
            return Step(zero, pos, _ZERO6, done=AckStatus.COMPLETED,
                        details="stream watchdog: no update, jog stopped")
        if self.n == 0:
            return Step(BoardCommand.IDLE, None, done=AckStatus.COMPLETED, details="nothing to do")
        now = ctx.now
        if self.i < self.n:
            k = self.i
            if self.commands[k] == BoardCommand.JOG:
                due = int(self._elapsed_samples(ctx.schedule_s, ctx.rate_hz) + 0.5)
                return self._speed_step(ctx, min(max(k, due), self.n - 1))
            if self._waits_to_start(ctx):
                return Step(BoardCommand.IDLE)
            s = self._goto_sample(ctx)
            self._s = s
            self.i = self.n if s >= self.n - 1 else int(s) + 1
            self.progress = self.i / self.n
            tgt, ff = self._at(s)
            return self._ask(now, self.commands[int(s)], tgt, ff)
        # settle: the final target with zero feed-forward, every tick, until the board reports
        # it exactly and at rest (the GO TO law v = 50 x error closes the last steps in a few
        # ticks and cannot overshoot without feed-forward); FAILED if it does not in time
        target = self.positions[-1]
        self.settle_left -= 1
        st = ctx.status
        if st is not None and all(a == b for a, b in zip(st.positions, target)) and not any(st.speeds):
            self.progress = 1.0
            return self._ask(now, BoardCommand.GOTO, target, _ZERO6, AckStatus.COMPLETED)
        if self.settle_left <= 0:
            return self._ask(now, BoardCommand.GOTO, target, _ZERO6, AckStatus.FAILED,
                             details=self._missed_target(st, target, ctx.rate_hz))
        return self._ask(now, BoardCommand.GOTO, target, _ZERO6)

    def _missed_target(self, st: StatusFrame | None, target: Sequence[int], rate_hz: float) -> str:
        """The FAILED details of a position-tracked move whose board did not report its target
        within the settle time: which joints are how far off."""
        waited = f"{self.settle_ticks / rate_hz:.2f} s"
        if st is None:
            return f"the board did not report its position within {waited} of the move's end"
        off = [f"{JOINT_NAMES[j]} at {p} steps, {t - p:+d} from the target {t}"
               for j, (p, t) in enumerate(zip(st.positions, target)) if p != t]
        moving = [JOINT_NAMES[j] for j, v in enumerate(st.speeds) if v]
        what = "; ".join(off) if off else "every joint on target but still moving (" + ", ".join(moving) + ")"
        return f"the board did not reach the exact target within {waited} of the move's end: {what}"


class SpeedActivity(Activity):
    """Constant joint speeds (board 123) for ``duration_s``; JOG, MULTIJOG, SPEEDJOINT.

    The board keeps a speed until the next frame, so the distance moved is speed x the TIME
    each frame actually ran.  The stream tracks the planned position ``start + speed x t``
    (``t`` at most ``duration_s``): every frame asks for the speed that takes each moving joint
    from where the board model estimates it now to the planned position at the next deadline,
    over at least one period (:func:`~parolkit.controller.pacing.tracking_speed`), never
    faster than the commanded speed and never backwards.  When the planned distance is covered
    (within ``tol_steps``) zero-speed frames follow, and the stream ends -- COMPLETED -- once a
    status frame shows the board stopped within ``land_tol_steps`` of the plan (one correction
    frame first, in either direction and within the commanded speed, when a stop that reached
    the board late let it run on), so a JOG with a distance stops where it should: what is left
    when the time is up is sent as a slower last frame instead of being cut off or overrun.
    If the board does not follow (the estimate never gets there), the stream ends
    ``overrun_s`` after its time anyway, saying so.  Stops early (COMPLETED, details say why)
    when a joint would reach its limit within ``stop_lookahead_ticks`` (homed robots only) or,
    in stream mode, when updates stop.  Always ends with a zero-speed frame.
    """

    streams_speed = True
    moves = True

    def __init__(self, speeds_steps_s: Sequence[int], duration_s: float, *, streamed: bool = False,
                 started: float = 0.0, stop_lookahead_ticks: float = 4.0, tol_steps: float = 1.0,
                 land_tol_steps: float = 4.0, overrun_s: float = 0.25) -> None:
        self.streamed = streamed
        self.lookahead = stop_lookahead_ticks
        self.tol = tol_steps
        self.land_tol = land_tol_steps
        self.overrun = overrun_s
        self.log = SentLog()
        self.replace(speeds_steps_s, duration_s, started)

    def touch(self, now: float) -> None:
        self.last_update = now

    def replace(self, speeds_steps_s: Sequence[int], duration_s: float, now: float) -> None:
        """New speeds and duration from ``now`` on (a streamed jog's update); the planned
        position starts again from where the joints are then."""
        if not duration_s > 0.0:
            raise ValueError(f"a speed stream needs a duration > 0 s, got {duration_s!r}")
        self.speeds = tuple(int(v) for v in speeds_steps_s)
        self.duration = float(duration_s)
        self.i = 0
        self.started = now
        self.last_update = now
        self.x0: list[float] | None = None
        #: the status frame when the zero-speed frames began (None: not stopping; False: no
        #: status then); a newer one showing the joints stopped ends the stream
        self._stop_mark: StatusFrame | bool | None = None
        #: time the loop held it paused (stop frames instead of its own), s
        self.paused = 0.0
        self._paused_at: float | None = None

    def held(self, now: float, stop: Step) -> None:
        """Paused by the loop (``stop`` sent): the board model knows it stopped, and the time
        the pause lasts is added to the time the stream may take to cover its distance."""
        self.log.record(now, stop.command, stop.positions or _ZERO6, stop.speeds)
        if self._paused_at is None:
            self._paused_at = now

    def _land(self, ctx: TickContext, x0: Sequence[float], end: float) -> Step | None:
        """The planned distance is covered by the estimate: zero-speed frames until a status
        frame shows the board stopped (its speeds 0: the reply to the frame after the stop),
        then COMPLETED if its counters are within ``land_tol_steps`` of the plan, else a
        correction frame (either way, within the commanded speed: a stop frame that reached the
        board late let it run on).  None: send the zero-speed frame and wait."""
        st = ctx.status
        if self._stop_mark is None:
            self._stop_mark = st if st is not None else False
            return None
        moving = [j for j, v in enumerate(self.speeds) if v]
        if st is None or st is self._stop_mark or any(st.speeds[j] for j in moving):
            return None
        want = [x0[j] + self.speeds[j] * end for j in range(6)]
        if all(abs(want[j] - st.positions[j]) <= self.land_tol for j in moving):
            return self._stop(ctx, "")
        self._stop_mark = None
        gap = self._gap(ctx.now, 1.0 / ctx.rate_hz)
        corr = [tracking_speed(want[j], st.positions[j], gap, -abs(v), abs(v)) if v else 0
                for j, v in enumerate(self.speeds)]
        self.log.record(ctx.now, BoardCommand.JOG, st.positions, corr)
        return Step(BoardCommand.JOG, st.positions, tuple(corr))

    def _gap(self, now: float, period: float) -> float:
        """The time since this stream's previous frame, at least a period (s)."""
        last = self.log.last_time()
        return period if last is None else max(period, now - last)

    def _stop(self, ctx: TickContext, details: str) -> Step:
        pos = ctx.status.positions if ctx.status else None
        self.log.record(ctx.now, BoardCommand.JOG, pos or _ZERO6, _ZERO6)
        return Step(BoardCommand.JOG, pos, _ZERO6, done=AckStatus.COMPLETED, details=details)

    def step(self, ctx: TickContext) -> Step:
        if self.streamed and ctx.stream_mode and ctx.now - self.last_update > ctx.watchdog_s:
            return self._stop(ctx, "stream watchdog: no update, jog stopped")
        st = ctx.status
        if ctx.homed and st is not None:
            horizon = self.lookahead / ctx.rate_hz
            for j, v in enumerate(self.speeds):
                if v == 0:
                    continue
                lo, hi = ctx.limits_steps[j]
                ahead = st.positions[j] + v * horizon
                if (v > 0 and ahead > hi) or (v < 0 and ahead < lo):
                    return self._stop(ctx, f"stopped at the {'upper' if v > 0 else 'lower'} limit of {JOINT_NAMES[j]}")
        now = ctx.now
        if self._paused_at is not None:
            self.paused += now - self._paused_at
            self._paused_at = None
        period = 1.0 / ctx.rate_hz
        e = now - self.started
        end = self.duration
        x = self.log.estimate(st, now)
        if x is None:  # no status frame yet: by time alone
            if self.i and e >= end - 0.5 * period:
                return self._stop(ctx, "")
            speeds: Sequence[int] = self.speeds
        else:
            if self.x0 is None:
                self.x0 = x
            if e >= end + self.paused + self.overrun:
                return self._stop(ctx, f"ended {self.overrun:g} s after its time: the board did not "
                                       f"cover the planned distance")
            e_next = (int(e * ctx.rate_hz + 0.5) + 1) * period
            h = min(e_next, end)
            interval = max(e_next - e, period)
            if h >= end:
                # the last of the distance: over no less than the last tick gap (should the next
                # tick be as late, the joints still stop where planned instead of running past)
                interval = max(interval, self._gap(now, period))
            x0 = self.x0
            out = []
            for j, v in enumerate(self.speeds):
                if v == 0:
                    out.append(0)
                    continue
                if h >= end and abs(x0[j] + v * end - x[j]) <= self.tol:
                    out.append(0)
                    continue
                out.append(tracking_speed(x0[j] + v * h, x[j], interval, min(0, v), max(0, v)))
            if h >= end and not any(out):
                landed = self._land(ctx, x0, end)
                if landed is not None:
                    return landed
            speeds = out
        self.i += 1
        self.progress = min(1.0, e / end)
        pos = st.positions if st else None
        self.log.record(now, BoardCommand.JOG, pos or _ZERO6, speeds)
        return Step(BoardCommand.JOG, pos, tuple(speeds))


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
                 start_timeout_ticks: int = 50, seen: Callable[[], bool] | None = None) -> None:
        self.standby = tuple(standby_steps)
        #: the board link's own account that the board homes since HOME was written (its
        #: frames during a homing faster than expected are not the truth, see integrity)
        self.seen = seen
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

    def step(self, ctx: TickContext) -> Step:
        if not self.sent:
            self.sent = True
            self.before = ctx.status
            return Step(BoardCommand.HOME)
        self.ticks += 1
        st = ctx.status
        if st is not None:
            if not self.started and (self._homing_seen(st) or (self.seen is not None and self.seen())):
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
                return Step(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if not self.started and self.ticks >= self.start_timeout_ticks:
            return Step(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"the board did not start homing within {self.start_timeout_ticks / ctx.rate_hz:g} s: "
                                f"is it disabled? send ENABLE, then HOME")
        if self.ticks >= self.timeout_ticks:
            return Step(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"homing did not finish within {self.timeout_ticks / ctx.rate_hz:.0f} s")
        return Step(BoardCommand.IDLE)


class DelayActivity(Activity):
    """Hold still for a number of ticks."""

    def __init__(self, ticks: int) -> None:
        self.ticks = max(0, int(ticks))
        self.i = 0

    def step(self, ctx: TickContext) -> Step:
        self.i += 1
        self.progress = min(1.0, self.i / max(1, self.ticks))
        if self.i >= self.ticks:
            return Step(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        return Step(BoardCommand.IDLE)


class OneShotActivity(Activity):
    """One frame (optionally with a one-shot gripper mode), COMPLETED with it."""

    def __init__(self, gripper_mode: int = GripperMode.OPERATE) -> None:
        self.mode = gripper_mode

    def step(self, ctx: TickContext) -> Step:
        self.progress = 1.0
        return Step(BoardCommand.IDLE, gripper_mode=self.mode, done=AckStatus.COMPLETED)


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

    def step(self, ctx: TickContext) -> Step:
        self.i += 1
        if self.i == 1:
            return Step(BoardCommand.IDLE, gripper_mode=GripperMode.CALIBRATE)
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
                return Step(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if self.i > self.timeout_ticks:
            status = "none" if st is None else f"0x{st.gripper_status:02X}"
            why = ("bit 0x01 clear): is an SSG-48 connected?" if self.calibrating else
                   "bit 0x01 never cleared: the gripper did not start calibrating)")
            return Step(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"the gripper did not report calibrated within {self.timeout_ticks / ctx.rate_hz:g} s "
                                f"of the calibrate (GET_GRIPPER status {status}, {why}")
        return Step(BoardCommand.IDLE)


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

    def step(self, ctx: TickContext) -> Step:
        self.i += 1
        st = ctx.status
        # the status read before this tick answers the frame sent in an earlier tick, which
        # already carried the new level; the first tick has not sent it yet
        if self.i >= 2 and st is not None and st.outputs[self.port - 1] == self.on:
            self.progress = 1.0
            return Step(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if self.i > self.timeout_ticks:
            return Step(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"the board did not report OUT{self.port} = {int(self.on)} within "
                                f"{self.timeout_ticks / ctx.rate_hz:g} s")
        self.progress = min(0.99, self.i / max(1, self.timeout_ticks))
        return Step(BoardCommand.IDLE)


class WaitInputActivity(Activity):
    """Hold still until digital input ``number`` (1|2) reads ``state``; FAILED after a timeout."""

    def __init__(self, number: int, state: bool, timeout_ticks: int | None) -> None:
        self.number = number
        self.state = state
        self.timeout_ticks = timeout_ticks
        self.i = 0
        self.matches = 0

    def step(self, ctx: TickContext) -> Step:
        self.i += 1
        st = ctx.status
        # two ticks in a row: one corrupted IO byte (no checksum on the link) is not an input
        self.matches = self.matches + 1 if st is not None and st.inputs[self.number - 1] == self.state else 0
        if self.matches >= 2:
            self.progress = 1.0
            return Step(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if self.timeout_ticks is not None:
            self.progress = min(1.0, self.i / max(1, self.timeout_ticks))
            if self.i >= self.timeout_ticks:
                return Step(BoardCommand.IDLE, done=AckStatus.FAILED,
                            details=f"IN{self.number} did not become {int(self.state)} within "
                                    f"{self.timeout_ticks / ctx.rate_hz:g} s")
        return Step(BoardCommand.IDLE)


def ticks_for(seconds: float, rate_hz: float) -> int:
    """Whole ticks covering ``seconds`` (at least 1)."""
    return max(1, int(math.ceil(seconds * rate_hz - 1e-9)))
