"""Accepted commands (:class:`Job`) and what they do tick by tick (activities).

An activity's :meth:`Activity.step` is called once per tick by the loop thread and must be
small and bounded: it indexes precomputed arrays or compares a few numbers.  It returns a
:class:`Step`: the board command and values for this tick and, when the job ends with this
frame, its terminal status.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from parolkit.protocol.commands import AckStatus, Command
from parolkit.protocol.frames import BoardCommand, GripperMode, StatusFrame
from parolkit.robot import JOINT_NAMES

__all__ = [
    "Job", "PlanAhead", "Step", "TickContext", "Activity", "TrajectoryActivity", "SpeedActivity",
    "HomeActivity", "DelayActivity", "OneShotActivity", "WaitInputActivity", "GripperCalibrateActivity",
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
    terminal: AckStatus | None = None
    #: the plan made ahead for this job before it was queued, until used
    ahead: PlanAhead | None = None
    #: who sent it (see Submission.client)
    client: str = ""

    @property
    def name(self) -> str:
        return self.command.name


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

    def step(self, ctx: TickContext) -> Step:  # pragma: no cover - abstract
        raise NotImplementedError

    def touch(self, now: float) -> None:
        """A streaming update arrived (resets the watchdog)."""


class TrajectoryActivity(Activity):
    """Play a planned trajectory one sample per tick, then settle on the target (156)."""

    def __init__(self, samples: Samples, *, settle_ticks: int, settle_tol_steps: int = 4,
                 streamed: bool = False, started: float = 0.0) -> None:
        self.positions, self.speeds, self.commands = samples
        self.n = len(self.positions)
        self.i = 0
        self.settle_left = settle_ticks
        self.settle_tol = settle_tol_steps
        self.streamed = streamed
        self.last_update = started
        self.streams_speed = bool(self.n) and any(c == BoardCommand.JOG for c in self.commands)

    def touch(self, now: float) -> None:
        self.last_update = now

    def commanded(self) -> tuple[int, ...] | None:
        """Position (steps) of the last sample sent to the board; None before the first."""
        if self.i == 0 or self.n == 0:
            return None
        return tuple(self.positions[min(self.i, self.n) - 1])

    def skip(self, k: int) -> None:
        """Start ``k`` samples in (at most at the last one): a streamed jog planned from
        another's commanded position ``k`` ticks before it took over continues where that
        one would be now, instead of stepping back by ``k`` ticks."""
        self.i = max(0, min(int(k), self.n - 1))

    def step(self, ctx: TickContext) -> Step:
        if self.streamed and ctx.stream_mode and ctx.now - self.last_update > ctx.watchdog_s:
            pos = ctx.status.positions if ctx.status else None
            zero = BoardCommand.JOG if self.streams_speed else BoardCommand.IDLE
            return Step(zero, pos, _ZERO6, done=AckStatus.COMPLETED,
                        details="stream watchdog: no update, jog stopped")
        if self.i < self.n:
            i = self.i
            self.i += 1
            self.progress = self.i / self.n
            cmd = self.commands[i]
            last = self.i == self.n
            if last and cmd == BoardCommand.JOG:
                return Step(cmd, tuple(self.positions[i]), tuple(self.speeds[i]), done=AckStatus.COMPLETED)
            return Step(cmd, tuple(self.positions[i]), tuple(self.speeds[i]))
        if self.n == 0:
            return Step(BoardCommand.IDLE, None, done=AckStatus.COMPLETED, details="nothing to do")
        # settle on the final target with zero feed-forward
        target = tuple(self.positions[-1])
        self.settle_left -= 1
        st = ctx.status
        close = st is not None and all(abs(a - b) <= self.settle_tol for a, b in zip(st.positions, target))
        if close or self.settle_left <= 0:
            return Step(BoardCommand.GOTO, target, _ZERO6, done=AckStatus.COMPLETED)
        return Step(BoardCommand.GOTO, target, _ZERO6)


class SpeedActivity(Activity):
    """Constant joint speeds (board 123) for a number of ticks; JOG, MULTIJOG, SPEEDJOINT.

    The board keeps a speed until the next frame, so the distance moved is speed x the TIME
    the stream lasts: it ends after ``ticks`` ticks or, when ticks come late (a stalled
    machine), as soon as ``ticks / rate`` seconds have passed since it started, whichever
    is first.  Stops early (COMPLETED, details say why) when a joint would reach its limit
    within ``stop_lookahead_ticks`` (homed robots only) or, in stream mode, when updates
    stop.  Always ends with a zero-speed frame.
    """

    streams_speed = True

    def __init__(self, speeds_steps_s: Sequence[int], ticks: int, *, streamed: bool = False,
                 started: float = 0.0, stop_lookahead_ticks: float = 4.0) -> None:
        self.speeds = tuple(int(v) for v in speeds_steps_s)
        self.ticks = max(1, int(ticks))
        self.i = 0
        self.streamed = streamed
        self.started = started
        self.last_update = started
        self.lookahead = stop_lookahead_ticks

    def touch(self, now: float) -> None:
        self.last_update = now

    def replace(self, speeds_steps_s: Sequence[int], ticks: int, now: float) -> None:
        self.speeds = tuple(int(v) for v in speeds_steps_s)
        self.ticks = max(1, int(ticks))
        self.i = 0
        self.started = now
        self.last_update = now

    def _stop(self, ctx: TickContext, details: str) -> Step:
        pos = ctx.status.positions if ctx.status else None
        return Step(BoardCommand.JOG, pos, _ZERO6, done=AckStatus.COMPLETED, details=details)

    def step(self, ctx: TickContext) -> Step:
        if self.streamed and ctx.stream_mode and ctx.now - self.last_update > ctx.watchdog_s:
            return self._stop(ctx, "stream watchdog: no update, jog stopped")
        if self.i >= self.ticks or (self.i and ctx.now - self.started >= (self.ticks - 0.5) / ctx.rate_hz):
            return self._stop(ctx, "")
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
        self.i += 1
        self.progress = self.i / self.ticks
        return Step(BoardCommand.JOG, st.positions if st else None, self.speeds)


class HomeActivity(Activity):
    """Send HOME (100) once, then IDLE until the board reports every joint homed at standby."""

    def __init__(self, standby_steps: Sequence[int], timeout_ticks: int, min_ticks: int = 5) -> None:
        self.standby = tuple(standby_steps)
        self.sent = False
        self.ticks = 0
        self.timeout_ticks = timeout_ticks
        self.min_ticks = min_ticks
        self.saw_unhomed = False

    def step(self, ctx: TickContext) -> Step:
        if not self.sent:
            self.sent = True
            return Step(BoardCommand.HOME)
        self.ticks += 1
        st = ctx.status
        if st is not None:
            homed = st.all_homed
            if not homed:
                self.saw_unhomed = True
            self.progress = min(0.99, sum(st.homed_joints) / 6.0)
            if (
                homed and self.ticks >= self.min_ticks and not any(st.speeds)
                and tuple(st.positions) == self.standby
            ):
                self.progress = 1.0
                return Step(BoardCommand.IDLE, done=AckStatus.COMPLETED)
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
    """One frame (optionally with a one-shot gripper mode), then COMPLETED."""

    def __init__(self, gripper_mode: int = GripperMode.OPERATE) -> None:
        self.mode = gripper_mode

    def step(self, ctx: TickContext) -> Step:
        self.progress = 1.0
        return Step(BoardCommand.IDLE, gripper_mode=self.mode, done=AckStatus.COMPLETED)


class OutputActivity(Activity):
    """Drive OUT1/OUT2 (the frame already carries the new level) and complete when the board's
    status reports that level, so a GET_IO after COMPLETED reads what was asked. FAILED after
    ``timeout_ticks`` without that report (a board that does not echo its outputs, or a link
    dropping every reply)."""

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


class GripperCalibrateActivity(Activity):
    """Send the one-shot CALIBRATE mode in exactly one frame, then wait until the gripper
    reports "calibrated" (FAILED after ``timeout_ticks``: no gripper, or it did not answer)."""

    def __init__(self, timeout_ticks: int, min_ticks: int = 2) -> None:
        self.sent = False
        self.i = 0
        self.timeout_ticks = timeout_ticks
        self.min_ticks = min_ticks

    def step(self, ctx: TickContext) -> Step:
        if not self.sent:
            self.sent = True
            return Step(BoardCommand.IDLE, gripper_mode=GripperMode.CALIBRATE)
        self.i += 1
        self.progress = min(0.99, self.i / max(1, self.timeout_ticks))
        st = ctx.status
        if st is not None and self.i >= self.min_ticks and st.gripper.calibrated:
            self.progress = 1.0
            return Step(BoardCommand.IDLE, done=AckStatus.COMPLETED)
        if self.i >= self.timeout_ticks:
            return Step(BoardCommand.IDLE, done=AckStatus.FAILED,
                        details=f"the gripper did not report calibrated within "
                                f"{self.timeout_ticks / ctx.rate_hz:g} s (is an SSG-48 connected?)")
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
