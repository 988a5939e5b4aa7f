"""A ROS 2 JointTrajectory -> ONE MoveJointPath for the controller, checked before anything moves.

Pure planning (no DDS, no sockets): :func:`plan_joint_trajectory` turns the points of a
``trajectory_msgs/msg/JointTrajectory`` (radians, ``time_from_start`` in s) into one
:class:`~parolkit.moves.JointPathMove` (degrees, seconds) and plans it with
:func:`parolkit.motion.plan` (the controller's own planner and limits: joint limits, speed
limits of position tracking, acceleration limits, ...).  Any problem refuses the WHOLE
trajectory with a :class:`TrajectoryRefused` naming the point (the message's index) and the
reason, before anything is sent.  The controller plans the path again when it runs it (its
guard checks every frame); the pre-check is what lets the bridge answer "refused" at once.

Timing: point ``k`` is commanded on tick ``round(time_from_start_k * rate)`` after the start
(:mod:`parolkit.motion.joint_path`), so the last point is due within half a tick of its
``time_from_start`` and nothing waits at the points: the path is one trajectory, at rest only
at its start and its end.  The points' velocities are followed when every point has them
(they shape the cubic between the points); otherwise the controller uses a C2 spline.
Accelerations of the message are not used.

What MoveIt sends is taken as it is:

* a first point at ``time_from_start`` 0 is the start: it must be within
  ``start_tolerance_rad`` (config ``[ros2] start_tolerance_rad``, default 0.01 rad as MoveIt's)
  of the current position on every joint, and is not a point of the path;
* a LAST point on the same control tick as the point before it (MoveIt's time
  parameterisation ends a trajectory wherever it ends, often a few ms after its last resampled
  point) is merged with that point: the point before it is dropped and the last point kept on
  its own tick, when the two are no further apart than one tick of motion at the URDF's
  velocity limit (what any trajectory within the limits can move in less than a tick);
  otherwise the trajectory is refused;
* the path must run on time: one the planner would stretch (a speed over the URDF's velocity
  limit, :func:`parolkit.ros2.urdf.trajectory_velocity_limits_rad_s`, but within the joint's
  maximum) is refused with the factor to slow it down by, as one over the maximum is.

Joint values are in a :class:`~parolkit.ros2.convention.JointConvention` (``convention``):
converted to parolkit's before anything else, so every check and message below is in
parolkit's joint angles.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from parolkit.errors import ParolkitError
from parolkit.moves import MAX_PATH_POINTS, JointPathMove
from parolkit.robot import NUM_JOINTS, RobotModel
from parolkit.ros2.convention import PAROLKIT, JointConvention
from parolkit.ros2.urdf import ROS_JOINT_NAMES, trajectory_velocity_limits_rad_s

if TYPE_CHECKING:
    from numpy.typing import NDArray

    _Row = tuple[NDArray[np.float64], float, NDArray[np.float64] | None]

__all__ = ["TrajectoryRefused", "TrajectoryPoint", "TrajectoryPath", "plan_joint_trajectory"]

#: At most this many points: the points of one MOVEJOINTPATH, plus a start point at time 0.
MAX_POINTS = MAX_PATH_POINTS + 1


class TrajectoryRefused(ParolkitError):
    """A JointTrajectory that cannot be followed; nothing was sent to the controller."""


@dataclass(frozen=True)
class TrajectoryPoint:
    """One point as in the message: positions (rad) and velocities (rad/s, empty or None =
    not given) in the message's joint order, ``time_s`` from the start."""

    positions_rad: Sequence[float]
    time_s: float
    velocities_rad_s: Sequence[float] | None = None


@dataclass(frozen=True)
class TrajectoryPath:
    """The MoveJointPath of a trajectory: ``move`` (deg, s), the tick of its last point, the
    message's index of the path's first point (1 when the message's point 0 at
    time_from_start 0 was only the start), and the message's index of a point merged into the
    last one (None: none was)."""

    move: JointPathMove
    ticks: int
    first_index: int
    merged: int | None = None

    @property
    def notes(self) -> tuple[str, ...]:
        """What was done to the message's points, in words (for the ``accepted`` event)."""
        if self.merged is None:
            return ()
        return (f"point {self.merged} merged into the last point (on the same control tick)",)

    @property
    def points(self) -> int:
        return len(self.move.points_deg)


def _order(joint_names: Sequence[str]) -> list[int]:
    """Index in the message of L1..L6, or TrajectoryRefused naming what is wrong."""
    names = list(joint_names)
    unknown = [n for n in names if n not in ROS_JOINT_NAMES]
    missing = [n for n in ROS_JOINT_NAMES if n not in names]
    dup = sorted({n for n in names if names.count(n) > 1})
    if unknown or missing or dup:
        parts = []
        if unknown:
            parts.append(f"unknown joints {unknown}")
        if missing:
            parts.append(f"missing joints {missing}")
        if dup:
            parts.append(f"repeated joints {dup}")
        raise TrajectoryRefused(f"joint_names must name each of {list(ROS_JOINT_NAMES)} once: {'; '.join(parts)}")
    return [names.index(n) for n in ROS_JOINT_NAMES]


def plan_joint_trajectory(
    joint_names: Sequence[str], points: Sequence[TrajectoryPoint], start_deg: Sequence[float],
    model: RobotModel, rate_hz: float, *, start_tolerance_rad: float | None = None,
    convention: JointConvention = PAROLKIT,
) -> TrajectoryPath:
    """The MoveJointPath of a trajectory starting at ``start_deg`` (deg, parolkit's), planned
    with the controller's planner at ``rate_hz``; raises :class:`TrajectoryRefused` with the
    reason.  ``start_tolerance_rad``: how far a first point at time_from_start 0 may be from
    ``start_deg`` (None: the config's default, ``Ros2Settings().start_tolerance_rad``);
    ``convention``: the joint convention of the message's values (module docstring)."""
    from parolkit.config import Ros2Settings
    from parolkit.motion import plan
    from parolkit.motion.errors import PlanningError

    tolerance = Ros2Settings().start_tolerance_rad if start_tolerance_rad is None else start_tolerance_rad
    if not points:
        raise TrajectoryRefused("the trajectory has no points")
    if len(points) > MAX_POINTS:
        raise TrajectoryRefused(f"the trajectory has {len(points)} points; at most {MAX_POINTS} are accepted")
    order = _order(joint_names)
    start_rad = np.radians(np.array(start_deg, dtype=float))
    first = 0
    prev_tick = 0
    merged: int | None = None
    rows: list[_Row] = []  # (deg, s, deg/s or None) per point of the path
    index: list[int] = []  # the message's index of each point of the path
    for k, p in enumerate(points):
        rad, vel = _point(k, p, order, convention)
        if k == 0 and p.time_s == 0.0:
            off = np.abs(start_rad - rad)
            if float(off.max()) > tolerance:
                j = int(off.argmax())
                raise TrajectoryRefused(
                    f"point 0 is at time_from_start 0 but {ROS_JOINT_NAMES[j]} is {off[j]:.4f} rad away from the "
                    f"current position (tolerance {tolerance:g} rad, [ros2] start_tolerance_rad); give the first "
                    f"point a time > 0")
            first = 1
            continue
        tick = round(p.time_s * rate_hz)
        row = (np.degrees(rad), p.time_s, None if vel is None else np.degrees(vel))
        if tick <= prev_tick:
            if k != len(points) - 1 or not rows:
                raise TrajectoryRefused(
                    f"point {k}: time_from_start {p.time_s:.4f} s is not at least one control tick "
                    f"({1 / rate_hz:.4f} s) after the previous point")
            _check_merge(k, rows[-1][0], row[0], model, rate_hz)
            rows[-1], index[-1] = row, k  # the last point, on the tick of the point before it
            merged = k - 1
            continue
        rows.append(row)
        index.append(k)
        prev_tick = tick
    if not rows:
        raise TrajectoryRefused("the trajectory has no point after time_from_start 0: nothing to do")
    if len(rows) > MAX_PATH_POINTS:
        raise TrajectoryRefused(f"the trajectory has {len(rows)} points after its start; at most "
                                f"{MAX_PATH_POINTS} are accepted")
    velocities = _velocities(rows, first)
    try:
        move = JointPathMove(tuple(tuple(float(v) for v in r[0]) for r in rows), tuple(r[1] for r in rows),
                             velocities)
        traj = plan(move, start_deg, model=model, rate_hz=rate_hz)
    except PlanningError as exc:
        if exc.point is None:
            raise TrajectoryRefused(str(exc)) from None
        k = index[exc.point]
        renumbered = (f" (the planner counts the path's points from the message's point {index[0]} as 0"
                      + (f", without the message's point {merged}, merged into the last" if merged is not None else "")
                      + ")") if k != exc.point else ""
        raise TrajectoryRefused(f"point {k} (t = {points[k].time_s:.3f} s): {exc}{renumbered}") from None
    except ParolkitError as exc:
        raise TrajectoryRefused(str(exc)) from None
    if len(traj.t) != prev_tick:
        raise TrajectoryRefused(_late(traj.notes, len(points) - 1, points[-1].time_s, len(traj.t) / rate_hz))
    return TrajectoryPath(move, prev_tick, first, merged)


def _check_merge(k: int, before_deg: NDArray[np.float64], last_deg: NDArray[np.float64], model: RobotModel,
                 rate_hz: float) -> None:
    """The last point ``k`` (deg) may replace the point before it (deg), on that point's tick,
    when no joint is further from it than one tick of motion at the URDF's velocity limit."""
    reach = np.degrees(trajectory_velocity_limits_rad_s(model, rate_hz)) / rate_hz
    gap = np.abs(last_deg - before_deg)
    over = np.nonzero(gap > reach * (1.0 + 1e-9))[0]
    if len(over):
        j = int(over[0])
        raise TrajectoryRefused(
            f"point {k}: on the same control tick as point {k - 1} (a tick is {1 / rate_hz:.4f} s) but "
            f"{ROS_JOINT_NAMES[j]} is {math.radians(gap[j]):.4g} rad away from it, more than one tick of motion at "
            f"its velocity limit ({math.radians(reach[j]):.4g} rad): give the last point a later time_from_start")


def _late(notes: Sequence[str], k: int, asked_s: float, runs_s: float) -> str:
    """The refusal of a path the planner would stretch (its speeds over the URDF's velocity
    limits): the planner's warning names the joint, the speed and the limit."""
    from parolkit.motion.validate import WARNING_PREFIX

    why = next((n.removeprefix(WARNING_PREFIX) for n in notes if n.startswith(WARNING_PREFIX)), "")
    return (f"point {k} (t = {asked_s:.3f} s): the path cannot run on time (it would end at {runs_s:.3f} s): "
            f"{why}; multiply the times (and divide the velocities) by at least {runs_s / asked_s:.3f}, or plan "
            f"within the URDF's velocity limits")


def _point(k: int, p: TrajectoryPoint, order: list[int],
           convention: JointConvention) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Point ``k``'s positions (rad) and velocities (rad/s, None when not given) in L1..L6
    order and parolkit's joint convention, or TrajectoryRefused naming what is wrong."""
    pos = list(p.positions_rad)
    if len(pos) != NUM_JOINTS:
        raise TrajectoryRefused(f"point {k}: {len(pos)} positions for {NUM_JOINTS} joints")
    if not all(math.isfinite(v) for v in pos) or not math.isfinite(p.time_s):
        raise TrajectoryRefused(f"point {k}: positions and time_from_start must be finite")
    vel = list(p.velocities_rad_s or ())
    if vel and len(vel) != NUM_JOINTS:
        raise TrajectoryRefused(f"point {k}: {len(vel)} velocities for {NUM_JOINTS} joints (give 6 or none)")
    if not all(math.isfinite(v) for v in vel):
        raise TrajectoryRefused(f"point {k}: velocities must be finite")
    rad = convention.from_ros_rad([pos[i] for i in order])
    return rad, (convention.rate_from_ros([vel[i] for i in order]) if vel else None)


def _velocities(
    rows: list[_Row], first: int,
) -> tuple[tuple[float, ...], ...] | None:
    """The path's velocities (deg/s) when every point of the path has them, else None (the
    controller's spline).  The last must be zero: the trajectory ends at rest."""
    if any(r[2] is None for r in rows):
        return None
    last = rows[-1][2]
    assert last is not None
    moving = np.nonzero(last)[0]
    if len(moving):
        j = int(moving[0])
        raise TrajectoryRefused(
            f"point {len(rows) - 1 + first}: the last point's velocities must be 0 (the trajectory ends at rest), "
            f"{ROS_JOINT_NAMES[j]} has {np.radians(last[j]):.4g} rad/s")
    return tuple(tuple(float(v) for v in r[2]) for r in rows if r[2] is not None)
