"""Simulate first (issue 26 item 3): the logic behind the Program tab's Simulate, run speed and
"go to start pose", without NiceGUI (tested in tests/unit/test_gui_simulate.py).

* :class:`SimTimeline`: the program's planned run (the dry run Check makes, from the current
  joints) as joint positions over time, line by line: ``at(t)`` gives the ghost arm's joints,
  the program line that runs and whether that line collides.  Moves play their planned samples
  (at the speed override a ``Speed()`` line set), a ``Delay`` holds the pose, ``Home()`` jumps to
  the standby pose (its time depends on the robot), a line that cannot be planned is skipped;
  a ``Loop()`` program plays the passes the dry run checks (two).
* :class:`Simulation`: plays a timeline on the server's clock at 1x, 2x or 5x
  (:data:`SIM_SPEEDS`); pure arithmetic on the ``now`` it is given.  One frame advances it by
  at most :data:`MAX_FRAME_STEP_S` of wall time: a server held up (a loaded machine) slows the
  playback down instead of skipping lines.
* The run speed (:data:`RUN_SPEED_MIN_PCT`..100 %): a real run at N % sets the controller's
  speed override to N % and each ``Speed(p)`` line to p x N / 100 % (:class:`RunSpeedRobot`,
  :func:`scaled_override`); every move takes 100 / N times its planned time.
* :class:`StartPose`: the program's first pose, the target of its first absolute move, and the
  one planned move that takes the arm there (hold-to-move: the commander sends it while the
  button is held and STOP when it is let go).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from parolkit.client.core import CommandResult
from parolkit.client.robot import Robot
from parolkit.errors import ParolkitValueError

if TYPE_CHECKING:
    from parolkit.script.dryrun import DryRunReport, DryRunRow
    from parolkit.script.program import Command, Program, ScriptError

__all__ = [
    "SIM_SPEEDS", "RUN_SPEED_MIN_PCT", "RUN_SPEED_MAX_PCT", "START_POSE_SPEED_PCT", "START_POSE_ACCEL_PCT",
    "AT_START_DEG", "AT_START_MM", "MAX_FRAME_STEP_S", "sim_speed", "run_speed_pct", "scaled_override",
    "run_speed_errors", "duration_factor", "SimStep", "SimFrame", "SimTimeline", "Simulation", "StartPose",
    "start_pose", "RunSpeedRobot",
]

#: the simulation's playback speeds: real time, twice and five times as fast
SIM_SPEEDS = (1.0, 2.0, 5.0)
#: the most wall time one frame of the simulation advances it by, s (x its speed)
MAX_FRAME_STEP_S = 0.1
#: the run speed's range, % of the planned speed
RUN_SPEED_MIN_PCT = 10.0
RUN_SPEED_MAX_PCT = 100.0
#: the planned move "go to start pose" sends (MOVEJOINT / MOVEPOSE speed and acceleration, %)
START_POSE_SPEED_PCT = 25.0
START_POSE_ACCEL_PCT = 25.0
#: the arm counts as at the start pose within this many degrees on every joint ...
AT_START_DEG = 0.1
#: ... or, for a pose target, this far from the position (mm) and AT_START_DEG from the orientation
AT_START_MM = 0.5


def _number(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParolkitValueError(f"{name} must be a number, got {value!r}")
    return float(value)


def sim_speed(value: object) -> float:
    """The simulation's playback speed ``value`` (1, 2 or 5: times real time), checked."""
    speed = _number(value, "simulation speed")
    if speed not in SIM_SPEEDS:
        allowed = ", ".join(f"{s:g}x" for s in SIM_SPEEDS)
        raise ParolkitValueError(f"simulation speed must be one of {allowed}, got {speed:g}x")
    return speed


def run_speed_pct(value: object) -> float:
    """The run speed ``value`` (% of the planned speed, 10..100), checked."""
    pct = _number(value, "run speed")
    if not RUN_SPEED_MIN_PCT <= pct <= RUN_SPEED_MAX_PCT:
        raise ParolkitValueError(f"run speed must be {RUN_SPEED_MIN_PCT:g}..{RUN_SPEED_MAX_PCT:g} %, "
                                 f"got {pct:g} %")
    return pct


def duration_factor(run_pct: float) -> float:
    """How many times its planned time a move takes at the run speed ``run_pct`` (%)."""
    return 100.0 / run_speed_pct(run_pct)


def scaled_override(line_pct: float, run_pct: float) -> float:
    """The controller's speed override for a ``Speed(line_pct)`` line of a program run at
    ``run_pct`` %: ``line_pct x run_pct / 100``; below the controller's 1 % it is an error (the
    message names the line's value, the run speed and the smallest run speed that works)."""
    pct = _number(line_pct, "Speed()") * run_speed_pct(run_pct) / 100.0
    if pct < 1.0:
        least = min(RUN_SPEED_MAX_PCT, math.ceil(100.0 / float(line_pct)))
        raise ParolkitValueError(
            f"Speed({line_pct:g}) at the {run_pct:g} % run speed would be {pct:g} %: the speed override is "
            f"1..100 %; run at {least:g} % or more, or raise the Speed() value")
    return round(pct, 6)


def run_speed_errors(program: Program, run_pct: float) -> list[ScriptError]:
    """The program's ``Speed()`` lines whose override at the run speed ``run_pct`` would fall
    below 1 %, as errors at their lines (nothing runs then)."""
    from parolkit.script.program import ScriptError, Severity, Speed

    out: list[ScriptError] = []
    for cmd in program.commands:
        if not isinstance(cmd, Speed):
            continue
        try:
            scaled_override(cmd.percent, run_pct)
        except ParolkitValueError as exc:
            out.append(ScriptError(cmd.line, cmd.col, str(exc), cmd.text, Severity.ERROR, program.source_name))
    return out


# ---- the timeline ----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SimStep:
    """One line of the planned run: from ``start_s`` for ``duration_s`` (s of the program's
    time), the joints ``rows_deg`` (n, 6) at ``times_s`` (n,) from the step's start (the first
    at 0: where the step starts); ``collides``: the dry run found a collision on this line;
    ``iteration``: the loop pass."""

    line: int
    start_s: float
    duration_s: float
    times_s: NDArray[np.float64]
    rows_deg: NDArray[np.float64]
    collides: bool = False
    iteration: int = 1

    def joints_at(self, tau: float) -> NDArray[np.float64]:
        """The joints ``tau`` s into the step (linear between samples, held after the last)."""
        times, rows = self.times_s, self.rows_deg
        if tau <= times[0]:
            return np.asarray(rows[0], dtype=float)
        k = int(np.searchsorted(times, tau, side="right"))
        if k >= len(times):
            return np.asarray(rows[-1], dtype=float)
        t0, t1 = times[k - 1], times[k]
        w = 0.0 if t1 <= t0 else (tau - t0) / (t1 - t0)
        return np.asarray(rows[k - 1] + w * (rows[k] - rows[k - 1]), dtype=float)

    def shifted(self, dt: float, iteration: int) -> SimStep:
        return SimStep(self.line, self.start_s + dt, self.duration_s, self.times_s, self.rows_deg, self.collides,
                       iteration)


@dataclass(frozen=True)
class SimFrame:
    """What the simulation shows at ``time_s``: the ghost's joints (deg), the line that runs
    (None before the first), whether that line collides, and whether the run has ended."""

    time_s: float
    joints_deg: tuple[float, ...]
    line: int | None
    collides: bool
    done: bool


def _planned_by_motion(row: DryRunRow, commands: dict[int, Command]) -> bool:
    """The dry run planned a trajectory for this row: a motion command (``commands`` by line)
    it did not refuse."""
    from parolkit.script.dryrun import motion_move

    cmd = commands.get(row.line)
    return cmd is not None and motion_move(cmd) is not None and not (row.failed and row.note == "refused")


@dataclass(frozen=True)
class SimTimeline:
    """The planned run as joints over time (:meth:`from_report`); :meth:`at` samples it."""

    start_deg: tuple[float, ...]
    steps: tuple[SimStep, ...]
    duration_s: float
    _starts: tuple[float, ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        starts = tuple(s.start_s for s in self.steps)
        if any(b < a for a, b in zip(starts, starts[1:])):
            raise ValueError("a timeline's steps must be in the order they start")
        object.__setattr__(self, "_starts", starts)

    @classmethod
    def from_report(cls, report: DryRunReport) -> SimTimeline:
        """The dry run's rows and planned moves as a timeline (see the module's words)."""
        q = np.asarray(report.start_deg, dtype=float)
        segments = iter(report.segments)
        commands = {c.line: c for c in report.program.commands}
        steps: list[SimStep] = []
        for row in report.rows:
            if _planned_by_motion(row, commands):
                try:
                    _, traj = next(segments)
                except StopIteration:
                    raise ValueError("the dry run report has fewer planned moves than motion rows") from None
                pos = np.asarray(traj.positions_deg(), dtype=float)
                if not len(pos):
                    continue
                scale = row.duration_s / traj.duration if traj.duration > 0 else 1.0
                start = np.asarray(traj.start_deg, dtype=float)
                times = np.concatenate([[0.0], np.asarray(traj.t, dtype=float) * scale])
                steps.append(SimStep(row.line, row.start_s, row.duration_s, times, np.vstack([start, pos]),
                                     row.failed, row.iteration))
                q = pos[-1]
            elif row.target_deg is not None:  # Home(): at the standby pose (its time depends on the robot)
                q = np.asarray(row.target_deg, dtype=float)
                steps.append(SimStep(row.line, row.start_s, row.duration_s, np.array([0.0]), q[None, :],
                                     False, row.iteration))
            elif row.duration_s > 0:  # Delay(): the pose holds
                steps.append(SimStep(row.line, row.start_s, row.duration_s, np.array([0.0, row.duration_s]),
                                     np.vstack([q, q]), False, row.iteration))
        steps, end = _repeat_passes(report, steps)
        return cls(tuple(float(v) for v in report.start_deg), tuple(steps), end)

    def at(self, t: float) -> SimFrame:
        """The frame ``t`` s into the run (clamped to 0..duration)."""
        t = min(max(float(t), 0.0), self.duration_s)
        done = t >= self.duration_s
        i = bisect.bisect_right(self._starts, t) - 1
        if i < 0:
            return SimFrame(t, self.start_deg, None, False, done)
        step = self.steps[i]
        q = step.joints_at(t - step.start_s)
        return SimFrame(t, tuple(float(v) for v in q), step.line, step.collides, done)

    @property
    def lines(self) -> tuple[int, ...]:
        """The program lines the run plays, in order (a line once per pass)."""
        return tuple(s.line for s in self.steps)


def _repeat_passes(report: DryRunReport, steps: list[SimStep]) -> tuple[list[SimStep], float]:
    """The passes of a Loop() program the dry run counted but did not plan (they repeat earlier
    ones: ``report.repeats``) appended as copies shifted in time; the timeline's end (s)."""
    end = report.planned_s
    if report.repeats is None:
        return steps, end
    k, p = report.repeats
    pass_start: dict[int, float] = {}
    for row in report.rows:
        pass_start.setdefault(row.iteration, row.start_s)
    pass_start[k] = end
    out = list(steps)
    for n in range(k, report.iterations + 1):
        src = p + (n - k) % (k - p)
        shift = end - pass_start[src]
        out.extend(s.shifted(shift, n) for s in steps if s.iteration == src)
        end += pass_start[src + 1] - pass_start[src]
    return out, end


class Simulation:
    """A timeline played on a clock: :meth:`start` at ``now`` (s, any monotonic clock), then
    :meth:`frame` ``(now)`` for each frame shown.  Each call advances the program's time by
    the wall time since the last one, at most :data:`MAX_FRAME_STEP_S`, times the speed: at
    real speed (or 2x, 5x) while frames come often, slower when they do not (a line is never
    skipped because the server was held up).  :meth:`set_speed` changes the speed from ``now`` on."""

    def __init__(self, timeline: SimTimeline, speed: float = 1.0) -> None:
        self.timeline = timeline
        self.speed = sim_speed(speed)
        self._last: float | None = None
        self._t = 0.0
        self.stopped = False

    @property
    def started(self) -> bool:
        return self._last is not None

    def start(self, now: float) -> None:
        self._last, self._t = float(now), 0.0
        self.stopped = False

    def advance(self, now: float) -> float:
        """The program's time (s) the simulation shows at ``now``, advanced to it."""
        if self._last is None or self.stopped:
            return self._t
        dt = float(now) - self._last
        if dt > 0:
            self._t = min(self.timeline.duration_s, self._t + min(dt, MAX_FRAME_STEP_S) * self.speed)
            self._last = float(now)
        return self._t

    def set_speed(self, speed: float, now: float) -> None:
        speed = sim_speed(speed)
        self.advance(now)
        self.speed = speed

    def frame(self, now: float) -> SimFrame:
        return self.timeline.at(self.advance(now))

    def playing(self, now: float) -> bool:
        return self.started and not self.stopped and self.advance(now) < self.timeline.duration_s

    def stop(self) -> None:
        self.stopped = True


# ---- the start pose ----------------------------------------------------------------------------


@dataclass(frozen=True)
class StartPose:
    """The target of the program's first absolute move (``line``, ``keyword``): joints (deg)
    for a MoveJoint, else a TCP pose [x, y, z mm, A, B, C deg] of the current tool."""

    line: int
    keyword: str
    joints_deg: tuple[float, ...] | None = None
    pose: tuple[float, ...] | None = None

    def command(self, speed_pct: float = START_POSE_SPEED_PCT, accel_pct: float = START_POSE_ACCEL_PCT) -> str:
        """The planned move to it: ``MOVEJOINT`` to the joints, ``MOVEPOSE`` to a pose (the
        controller solves it with its tool, nearest the arm's joints)."""
        if self.joints_deg is not None:
            return "MOVEJOINT|" + "|".join(f"{v:.4f}" for v in self.joints_deg) + f"|None|{speed_pct:g}|{accel_pct:g}"
        if self.pose is None:
            raise ValueError("a start pose has joints or a pose")
        return "MOVEPOSE|" + "|".join(f"{v:.4f}" for v in self.pose) + f"|None|{speed_pct:g}|{accel_pct:g}"

    def reached(self, joints_deg: Sequence[float], pose: Sequence[float]) -> bool:
        """The arm (``joints_deg``, TCP ``pose``) is at the start pose: every joint within
        :data:`AT_START_DEG`, or for a pose the TCP within :data:`AT_START_MM` and its
        orientation within :data:`AT_START_DEG`."""
        if self.joints_deg is not None:
            return all(abs(a - b) <= AT_START_DEG for a, b in zip(joints_deg, self.joints_deg, strict=True))
        if self.pose is None:
            return False
        from parolkit.kinematics import pose_to_matrix

        a, b = pose_to_matrix(list(pose)), pose_to_matrix(list(self.pose))
        if float(np.linalg.norm(a[:3, 3] - b[:3, 3])) * 1000.0 > AT_START_MM:
            return False
        cos = (float(np.trace(a[:3, :3].T @ b[:3, :3])) - 1.0) / 2.0
        return math.degrees(math.acos(min(1.0, max(-1.0, cos)))) <= AT_START_DEG

    def describe(self) -> str:
        return f"line {self.line}'s {self.keyword} target"

    def target_text(self) -> str:
        """The target's numbers as the program writes them: ``(120, -100, 190, 0, -20, 180)``."""
        values = self.joints_deg if self.joints_deg is not None else self.pose
        return "(" + ", ".join(f"{v:g}" for v in values or ()) + ")"


def start_pose(program: Program) -> StartPose | str:
    """The program's start pose: the target of its first MoveJoint, MovePose or MoveCart; or,
    as a sentence, why it has none (no move, or a relative move comes first)."""
    from parolkit.script.program import MoveCart, MoveCartRelTRF, MoveJoint, MovePose, SpeedJoint

    for cmd in program.commands:
        if isinstance(cmd, MoveJoint):
            return StartPose(cmd.line, cmd.keyword, joints_deg=tuple(float(v) for v in cmd.move.target_deg))
        if isinstance(cmd, (MovePose, MoveCart)):
            return StartPose(cmd.line, cmd.keyword, pose=tuple(float(v) for v in cmd.move.pose))
        if isinstance(cmd, (MoveCartRelTRF, SpeedJoint)):
            return (f"the first move ({cmd.keyword} at line {cmd.line}) is relative to where the arm is: "
                    "the program has no fixed start pose")
    return "the program has no move"


# ---- the run speed's client --------------------------------------------------------------------


class RunSpeedRobot(Robot):
    """The program runner's client for a run at ``run_pct`` %: the program's ``Speed(p)``
    lines (the interpreter's :meth:`set_speed`) set the controller's override to p x run speed /
    100 (:func:`scaled_override`); :meth:`set_override` sets it as given (the run's start and
    end, the commander's override slider while the program runs)."""

    def __init__(self, host: str, port: int, *, run_pct: float = RUN_SPEED_MAX_PCT, ack_port: int = 0) -> None:
        self.run_speed_pct = run_speed_pct(run_pct)
        super().__init__(host=host, port=port, ack_port=ack_port)

    def set_speed(self, percent: float, timeout: float | None = None) -> CommandResult:
        return super().set_speed(scaled_override(percent, self.run_speed_pct), timeout)

    def set_override(self, percent: float, timeout: float | None = None) -> CommandResult:
        return super().set_speed(percent, timeout)
