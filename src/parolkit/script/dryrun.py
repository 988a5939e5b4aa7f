"""Dry run: plan a whole RBTscript program with the motion layer, without a robot.

Every move is planned from the PREDICTED start state (the robot's joints before the program,
or the standby pose [90, -90, 180, 0, 0, 180] deg without a robot; each move starts where the
one before ended; ``Home()`` ends in the standby pose).  A target that cannot be reached, a
path that leaves the joint limits, passes a singularity or needs more than a joint's maximum
speed is reported as an error at the program line, before anything moves.

Every planned move is also checked for collisions (:func:`parolkit.collision.check_trajectory`:
its samples and every pose between them) with the keep-out zones (the config's ``[[zones]]``;
the table plane under the base by default), the arm's own links and the tool's body
(``[tools.NAME] shape``).  A collision is an error at the line, naming the pair and the time
into the move (as the move will run, at the speed override a ``Speed()`` line set):
``MoveJoint would collide: J5 link vs zone 'monitor' at 0.84 s into the move (enters its 10 mm
margin; deepest 26.0 mm overlap at 1.31 s)``.  The run goes on from the move's planned end, so
every line that collides is reported at once (a move that starts where a colliding one ended,
inside a zone, is reported at 0.00 s).

For ``Loop()`` programs the default is two iterations, so that the path from the end of the
program back to its first move is checked too; pass ``loops`` to plan a given number.  Any
number costs at most a few passes: planning depends only on the joints a pass starts from, so
once a pass starts from the joints an earlier pass started from, every pass after it repeats
the passes in between; they are counted (time, final joints) but not planned again.  A program
that never comes back to where a pass started (relative moves that drift) is planned for at
most :data:`MAX_DRY_RUN_PASSES` passes, and the report's warning says how many were not.

The result, :class:`DryRunReport`, holds one row per executed command (start/end time,
duration, joints at the end), the errors and warnings, and the planned trajectories (for
``--plot``).  Times are seconds from the program start; the waits of ``Home()`` and
``Input()`` depend on the robot and count as 0 s (their rows say so).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from parolkit.errors import ParolkitError
from parolkit.moves import JointMove, Move, PoseMove
from parolkit.robot import NUM_JOINTS, PAROL6, RobotModel, check_joint_limits_steps
from parolkit.script.program import (
    Begin,
    Command,
    Delay,
    End,
    Gripper,
    GripperCalibrate,
    Home,
    Input,
    Loop,
    MoveCart,
    MoveCartRelTRF,
    MoveJoint,
    MovePose,
    Output,
    Program,
    ScriptError,
    Severity,
    Speed,
    SpeedJoint,
    format_number,
)

if TYPE_CHECKING:  # parolkit.motion, the kinematics and the collision check: when the first move is planned
    from parolkit.collision import Scene, ToolShape, Zone
    from parolkit.config import ToolSettings
    from parolkit.kinematics.tools import Tool
    from parolkit.motion import Trajectory

__all__ = ["DryRunRow", "DryRunReport", "dry_run", "motion_move", "default_loops", "MoveTiming",
           "effective_timing", "MAX_DRY_RUN_PASSES", "repeated_passes"]

#: Most passes of a Loop() program a dry run plans when the program does not repeat itself (no
#: pass starts from the joints an earlier one started from); one pass of a few Cartesian moves
#: takes ~0.1 s to plan, so this bounds a check to seconds.  A repeating program (the usual
#: case: absolute moves) is checked in full for any number of passes.
MAX_DRY_RUN_PASSES = 100


@dataclass(frozen=True)
class DryRunRow:
    """One executed command in the dry run.

    ``start_s``/``end_s``/``duration_s``: seconds from the program start; ``target_deg``: joints
    (deg) at the end of a motion command (None for other commands); ``exact`` False when the
    real duration depends on the robot (Home, Input); ``iteration``: 1-based loop pass.
    """

    line: int
    col: int
    command: str
    iteration: int
    start_s: float
    duration_s: float
    target_deg: tuple[float, ...] | None = None
    note: str = ""
    exact: bool = True
    failed: bool = False

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s


@dataclass(frozen=True)
class DryRunReport:
    """The outcome of :func:`dry_run`.

    ``ok`` is True when there is no error.  ``segments`` are ``(start_s, trajectory)`` pairs of
    every planned motion, in order (for plots); ``final_deg`` is the predicted end state.
    ``iterations`` passes were asked for; ``rows`` and ``segments`` cover the first
    ``planned_iterations`` of them; ``repeats`` is ``(k, p)`` when pass k started from the joints
    pass p started from (so passes k..iterations repeat passes p..k-1 and were not planned
    again), else None.  ``total_s`` counts every pass.
    """

    program: Program
    rows: tuple[DryRunRow, ...]
    errors: tuple[ScriptError, ...]
    warnings: tuple[ScriptError, ...]
    start_deg: tuple[float, ...]
    final_deg: tuple[float, ...]
    iterations: int
    segments: tuple[tuple[float, Trajectory], ...] = field(default=(), repr=False)
    #: duration of every pass (s), when it differs from the end of the last row (passes repeated)
    total_time_s: float | None = None
    planned_iterations: int | None = None
    repeats: tuple[int, int] | None = None

    @property
    def ok(self) -> bool:
        return not self.errors

    @property
    def planned_s(self) -> float:
        """End of the planned rows (s): :attr:`total_s` unless passes were repeated."""
        return self.rows[-1].end_s if self.rows else 0.0

    @property
    def total_s(self) -> float:
        """Planned duration of the whole run (s), every pass, waits of Home/Input not included."""
        return self.planned_s if self.total_time_s is None else self.total_time_s

    @property
    def counted_iterations(self) -> int:
        """Passes :attr:`total_s` covers: all of them, unless a program that does not repeat
        itself was cut at :data:`MAX_DRY_RUN_PASSES` (a warning says so)."""
        if self.repeats is not None or self.planned_iterations is None:
            return self.iterations
        return self.planned_iterations

    @property
    def repeat_note(self) -> str:
        """``passes 3..1000000000 repeat pass 2 (...)``, or "" when every pass was planned."""
        if self.repeats is None:
            return ""
        k, p = self.repeats
        earlier = f"pass {p}" if k - p == 1 else f"passes {p}..{k - 1}"
        later = f"pass {k}" if k == self.iterations else f"passes {k}..{self.iterations}"
        return (f"{later} repeat {earlier} (pass {k} starts from the joints pass {p} started from): "
                "planned once, counted in the total")

    @property
    def has_waits(self) -> bool:
        return any(not r.exact for r in self.rows)

    def duration_of_line(self, line: int) -> float:
        """Planned duration (s) of the first execution of source line ``line``."""
        for r in self.rows:
            if r.line == line:
                return r.duration_s
        raise KeyError(f"line {line} is not a command of the program")

    def table(self) -> str:
        """The per-line table: line, iteration, start, end, duration, joints at the end, command."""
        head = f"{'line':>4} {'it':>2} {'start s':>8} {'end s':>8} {'dur s':>7}  {'joints at end (deg)':<53} command"
        out = [head, "-" * len(head)]
        for r in self.rows:
            joints = (
                " ".join(f"{v:8.2f}" for v in r.target_deg) if r.target_deg is not None else ""
            )
            dur = f"{r.duration_s:7.2f}" + ("+" if not r.exact else " ")
            cmd = r.command + (f"   [{r.note}]" if r.note else "")
            mark = "!" if r.failed else " "
            out.append(
                f"{r.line:>4}{mark}{r.iteration:>2} {r.start_s:8.2f} {r.end_s:8.2f} {dur} {joints:<53} {cmd}"
            )
        total = f"total {self.total_s:.2f} s"
        if self.counted_iterations < self.iterations:
            total += f" for the first {self.counted_iterations} of {self.iterations} loop iterations (see the warning)"
        elif self.iterations > 1:
            total += f" for {self.iterations} loop iterations"
        if self.has_waits:
            total += " + waits (Home/Input, marked '+')"
        out.append(total)
        if self.repeat_note:
            out.append(self.repeat_note)
        return "\n".join(out)

    def series(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t, positions_deg, speeds_deg_s) over the whole run: (N,), (N, 6), (N, 6).

        Between moves the joints hold still (zero speed)."""
        ts: list[np.ndarray] = []
        qs: list[np.ndarray] = []
        vs: list[np.ndarray] = []
        state = np.asarray(self.start_deg, dtype=float)
        t_now = 0.0
        for start_s, traj in self.segments:
            if start_s > t_now or not ts:
                ts.append(np.array([t_now, start_s]))
                qs.append(np.vstack([state, state]))
                vs.append(np.zeros((2, NUM_JOINTS)))
            ts.append(start_s + np.asarray(traj.t, dtype=float))
            qs.append(np.asarray(traj.positions_deg(), dtype=float))
            vs.append(np.asarray(traj.speeds_deg_s(), dtype=float))
            state = np.asarray(traj.final_deg, dtype=float)
            t_now = start_s + traj.duration
        end = max(self.planned_s, t_now)
        ts.append(np.array([t_now, end]))
        qs.append(np.vstack([state, state]))
        vs.append(np.zeros((2, NUM_JOINTS)))
        return np.concatenate(ts), np.vstack(qs), np.vstack(vs)

    def plot(self, path: str) -> None:
        """Draw joint positions (deg) and speeds (deg/s) over the whole run into ``path``."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        t, q, v = self.series()
        fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(11, 7))
        for j in range(NUM_JOINTS):
            ax1.plot(t, q[:, j], label=f"J{j + 1}")
            ax2.plot(t, v[:, j], label=f"J{j + 1}")
        for r in self.rows:
            if r.target_deg is not None and r.duration_s > 0:
                ax1.axvline(r.start_s, color="0.85", lw=0.8, zorder=0)
                ax1.annotate(f"L{r.line}", (r.start_s, 1.0), xycoords=("data", "axes fraction"),
                             fontsize=7, color="0.4", va="bottom")
        ax1.set_ylabel("joint position (deg)")
        ax2.set_ylabel("joint speed (deg/s)")
        ax2.set_xlabel("time since program start (s)")
        ax1.legend(loc="upper right", ncol=6, fontsize=8)
        ax1.grid(alpha=0.3)
        ax2.grid(alpha=0.3)
        name = self.program.source_name
        fig.suptitle(f"{name}: planned run, {self.total_s:.2f} s")
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)


@dataclass(frozen=True)
class MoveTiming:
    """The timing a move is sent and planned with: exactly one of ``duration_s`` (s) and
    ``speed_pct`` (%), and ``accel_pct`` (%, joint-space moves with a speed only).

    (Not :class:`parolkit.moves.Timing`, the wire's DURATION/SPEED word of smooth paths.)"""

    duration_s: float | None
    speed_pct: float | None
    accel_pct: float | None


def effective_timing(cmd: MoveJoint | MovePose | MoveCart | MoveCartRelTRF) -> MoveTiming:
    """Resolve the language's defaults for a move, the ONE place both the dry run and the
    interpreter take them from (so the controller plans exactly what the dry run planned).

    * ``t`` given: the duration; ``v``/``a`` are ignored (t overrides them);
    * otherwise ``v`` (default: MoveJoint 45 %, MovePose 50 %, Cartesian moves the motion
      layer's ``DEFAULT_CART_SPEED_PCT``, 50 %: a path speed instead of the original's fixed
      3.6 s) and for joint-space moves ``a`` (default: MoveJoint 27 %, MovePose 30 %).
    """
    from parolkit.motion.cartesian import DEFAULT_CART_SPEED_PCT
    from parolkit.motion.joint import MOVEJOINT_DEFAULT_PCT, MOVEPOSE_DEFAULT_PCT

    move = cmd.move
    if move.duration_s is not None:
        return MoveTiming(move.duration_s, None, None)
    if isinstance(move, (JointMove, PoseMove)):
        v_def, a_def = MOVEJOINT_DEFAULT_PCT if isinstance(move, JointMove) else MOVEPOSE_DEFAULT_PCT
        return MoveTiming(
            None,
            move.speed_pct if move.speed_pct is not None else v_def,
            move.accel_pct if move.accel_pct is not None else a_def,
        )
    return MoveTiming(None, move.speed_pct if move.speed_pct is not None else DEFAULT_CART_SPEED_PCT, None)


def motion_move(cmd: Command) -> Move | None:
    """The :mod:`parolkit.moves` move a motion command is planned with (None for other
    commands): the statement's move with the language's timing defaults resolved.

    ``t`` overrides ``v``/``a`` (the seed's rule), so a move with a duration carries no
    speed or acceleration."""
    if isinstance(cmd, SpeedJoint):
        return cmd.move
    if not isinstance(cmd, (MoveJoint, MovePose, MoveCart, MoveCartRelTRF)):
        return None
    timing = effective_timing(cmd)
    move = cmd.move
    if isinstance(move, (JointMove, PoseMove)):
        return replace(move, duration_s=timing.duration_s, speed_pct=timing.speed_pct,
                       accel_pct=timing.accel_pct)
    return replace(move, duration_s=timing.duration_s, speed_pct=timing.speed_pct)


def default_loops(program: Program) -> int:
    """Iterations a dry run plans by default: 2 for Loop() programs (checks the wrap-around), else 1."""
    return 2 if program.loops else 1


def _fmt_joints(q: Iterable[float]) -> str:
    return "[" + ", ".join(f"{v:.2f}" for v in q) + "]"


def _planning_message(cmd: Command, state: np.ndarray, exc: Exception) -> str:
    """``MoveCart cannot be planned from [..] deg (at t=1.20 s into the move): reason``."""
    from parolkit.motion import PlanningError

    head = f"{cmd.keyword} cannot be planned from {_fmt_joints(state)} deg"
    if isinstance(exc, PlanningError):
        when = f" (at t={exc.time_s:.2f} s into the move)" if exc.time_s is not None else ""
        return f"{head}{when}: {exc.reason.rstrip('.')}"
    return f"{head}: {str(exc).rstrip('.')}"


def _collision_scene(zones: Iterable[Zone] | None, tool_shape: ToolShape | ToolSettings | None) -> Scene:
    """The compiled collision scene a dry run checks every move in (built once per run)."""
    from parolkit.collision import Scene
    from parolkit.config import default_zones

    return Scene(zones=default_zones() if zones is None else zones, tool=tool_shape)


def _collision(scene: Scene, traj: Trajectory, start: np.ndarray, override: float) -> str:
    """The collision message of a planned move ("" when it is clear), its time into the move
    as it will run: at the speed override a Speed() line set."""
    from parolkit.collision import check_trajectory, collision_message

    if not len(traj):
        return ""
    verdict = check_trajectory(traj.positions_deg(), traj.rate_hz, scene, start_deg=start)
    if verdict.clear or verdict.pair is None:
        return ""
    scale = 100.0 / override
    deepest_s = None if verdict.deepest_time_s is None else verdict.deepest_time_s * scale
    return collision_message(verdict.pair, None if verdict.time_s is None else verdict.time_s * scale,
                             verdict.deepest, deepest_s)


def repeated_passes(iterations: int, repeats: tuple[int, int], pass_times: Sequence[float]) -> tuple[float, int]:
    """Pass ``k`` of ``iterations`` starts from the joints pass ``p`` started from
    (``repeats = (k, p)``), so passes k, k+1, ... go round passes p..k-1 again and again.
    ``pass_times[i]`` is the start time of pass i+1 (s) for the planned passes 1..k-1, then the
    time pass k starts.  Returns the end time of pass ``iterations`` and the planned pass it
    repeats (its end joints are the run's)."""
    k, p = repeats
    full, part = divmod(iterations - k + 1, k - p)
    t_p, t_k = pass_times[p - 1], pass_times[k - 1]
    total = t_k + full * (t_k - t_p) + (pass_times[p - 1 + part] - t_p)
    return total, (p + part - 1 if part else k - 1)


def dry_run(
    program: Program,
    start_deg: Sequence[float] | None = None,
    *,
    loops: int | None = None,
    model: RobotModel | None = None,
    tool: str | Tool | None = None,
    rate_hz: float = 100.0,
    zones: Iterable[Zone] | None = None,
    tool_shape: ToolShape | ToolSettings | None = None,
) -> DryRunReport:
    """Plan every command of ``program`` and return a :class:`DryRunReport`.

    ``start_deg``: joints (deg) before the program (default: the standby pose);
    ``loops``: iterations for a Loop() program (default 2; ignored for End() programs);
    ``model``/``tool``/``rate_hz``: as for :func:`parolkit.motion.plan`;
    ``zones``: the keep-out zones every move is checked against (``Config.zones``; None: the
    default ones, the table plane under the base; ``()``: none, only self-collision);
    ``tool_shape``: the tool's body (its :class:`parolkit.collision.ToolShape` or config entry;
    None: the tool has no shape).
    Never raises for a planning problem or a collision: each one is an error at its program
    line.  (A bad ``zones`` list, e.g. two zones of one name, raises ParolkitValueError when
    the first move is checked.)
    """
    from parolkit.motion import plan

    m = model or PAROL6
    state = np.asarray(m.standby_deg if start_deg is None else start_deg, dtype=float)
    if state.shape != (NUM_JOINTS,):
        raise ValueError(f"start_deg must be 6 joint angles in degrees, got shape {state.shape}")
    start = tuple(float(v) for v in state)
    if loops is not None and (isinstance(loops, bool) or int(loops) != loops or loops < 1):
        raise ValueError(f"loops must be a whole number >= 1, got {loops!r}")
    iterations = (int(loops) if loops is not None else default_loops(program)) if program.loops else 1

    scene: Scene | None = None  # compiled when the first move is checked
    rows: list[DryRunRow] = []
    errors: list[ScriptError] = []
    warnings: list[ScriptError] = list(program.warnings)
    segments: list[tuple[float, Trajectory]] = []
    seen_errors: set[tuple[int, str]] = set()
    t = 0.0

    def add_error(cmd: Command, message: str, iteration: int) -> None:
        key = (cmd.line, message)
        if key in seen_errors:
            return
        seen_errors.add(key)
        if iteration > 1:
            message += f" (loop iteration {iteration})"
        errors.append(ScriptError(cmd.line, cmd.col, message, cmd.text, Severity.ERROR, program.source_name))

    #: the speed override a Speed() line set (the controller's at 100 % when the run starts):
    #: the moves after it take 100 / pct times their planned time (their plans are the same)
    override = 100.0
    pass_starts: dict[tuple[float, ...], int] = {}  # joints and override a pass started from -> that pass
    pass_times: list[float] = []  # start time of each planned pass, then the end of the last
    pass_ends: list[np.ndarray] = []  # joints at the end of each planned pass
    repeats: tuple[int, int] | None = None
    planned = 0
    for iteration in range(1, iterations + 1):
        key = (*(float(v) for v in state), override)
        if key in pass_starts:  # this pass and every later one repeat passes already planned
            repeats = (iteration, pass_starts[key])
            break
        if iteration > MAX_DRY_RUN_PASSES:
            warnings.append(ScriptError(
                program.commands[-1].line, program.commands[-1].col,
                f"passes 1..{MAX_DRY_RUN_PASSES} were planned, passes {iteration}..{iterations} were not: "
                "the program does not come back to the joints a pass started from (its moves drift), and a "
                f"dry run plans at most {MAX_DRY_RUN_PASSES} passes of such a program",
                program.commands[-1].text, Severity.WARNING, program.source_name))
            break
        pass_starts[key] = iteration
        pass_times.append(t)
        planned = iteration
        for cmd in program.commands:
            text = cmd.to_source()
            if isinstance(cmd, (Begin, End, Loop)):
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0))
                continue
            if isinstance(cmd, Delay):
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, cmd.seconds))
                t += cmd.seconds
                continue
            if isinstance(cmd, Speed):
                override = cmd.percent
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0,
                                      note=f"speed override {format_number(cmd.percent)} %: the moves after it "
                                           f"take {format_number(round(100.0 / cmd.percent, 3))}x their planned time"))
                continue
            if isinstance(cmd, Output):
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0,
                                      note=f"OUT{cmd.port} {'HIGH' if cmd.state else 'LOW'}"))
                continue
            if isinstance(cmd, Input):
                limit = f", at most {format_number(cmd.timeout_s)} s" if cmd.timeout_s else ", no timeout"
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0,
                                      note=f"waits for IN{cmd.port} {'HIGH' if cmd.state else 'LOW'}{limit}",
                                      exact=False))
                continue
            if isinstance(cmd, (Gripper, GripperCalibrate)):
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0,
                                      note="gripper works in the background"))
                continue
            if isinstance(cmd, Home):
                state = np.asarray(m.standby_deg, dtype=float)
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0,
                                      target_deg=tuple(float(v) for v in state),
                                      note="homing time depends on the robot", exact=False))
                continue
            move = None
            try:
                move = motion_move(cmd)
                traj = plan(move, state, model=m, tool=tool, rate_hz=rate_hz)
                if len(traj):
                    check_joint_limits_steps(traj.positions, m, what=f"{cmd.keyword} path")
            except ParolkitError as exc:
                add_error(cmd, _planning_message(cmd, state, exc), iteration)
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0, failed=True,
                                      note="refused"))
                if isinstance(cmd, MoveJoint):
                    state = np.asarray(cmd.move.target_deg, dtype=float)
                continue
            except Exception as exc:  # a planner bug must not hide the other lines' results
                add_error(cmd, f"{cmd.keyword}: the planner failed: {type(exc).__name__}: {exc}", iteration)
                rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, 0.0, failed=True, note="refused"))
                continue
            segments.append((t, traj))
            notes = list(getattr(traj, "notes", ()) or ())
            if scene is None:
                scene = _collision_scene(zones, tool_shape)
            collision = _collision(scene, traj, state, override)
            if collision:
                add_error(cmd, f"{cmd.keyword} would collide: {collision}", iteration)
                notes.insert(0, "collides")
            state = np.asarray(traj.final_deg, dtype=float)
            duration = traj.duration * 100.0 / override
            if override != 100.0:
                notes.append(f"at the {format_number(override)} % speed override: planned {traj.duration:.2f} s")
            rows.append(DryRunRow(cmd.line, cmd.col, text, iteration, t, duration,
                                  target_deg=tuple(float(v) for v in state), note="; ".join(notes),
                                  failed=bool(collision)))
            t += duration
        pass_ends.append(state)

    total_time_s = None
    if repeats is not None:
        total_time_s, last = repeated_passes(iterations, repeats, [*pass_times, t])
        state = pass_ends[last - 1]
    return DryRunReport(
        program=program,
        rows=tuple(rows),
        errors=tuple(sorted(errors, key=lambda e: (e.line, e.col))),
        warnings=tuple(warnings),
        start_deg=start,
        final_deg=tuple(float(v) for v in state),
        iterations=iterations,
        segments=tuple(segments),
        total_time_s=total_time_s,
        planned_iterations=planned,
        repeats=repeats,
    )
