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
from parolkit.ros2.urdf import ROS_JOINT_NAMES

if TYPE_CHECKING:
    from numpy.typing import NDArray

    _Row = tuple[NDArray[np.float64], float, NDArray[np.float64] | None]

__all__ = ["TrajectoryRefused", "TrajectoryPoint", "TrajectoryPath", "plan_joint_trajectory", "START_TOLERANCE_RAD"]

#: A first point at time_from_start 0 must be this close to the current position (rad); it is
#: then only the start and not a point of the path (0.001 rad = 0.057 deg, a few microsteps).
START_TOLERANCE_RAD = 1e-3
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
    """The MoveJointPath of a trajectory: ``move`` (deg, s), the tick of its last point, and
    the message's index of the path's first point (1 when the message's point 0 at
    time_from_start 0 was only the start)."""

    move: JointPathMove
    ticks: int
    first_index: int

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
    model: RobotModel, rate_hz: float,
) -> TrajectoryPath:
    """The MoveJointPath of a trajectory starting at ``start_deg`` (deg), planned with the
    controller's planner at ``rate_hz``; raises :class:`TrajectoryRefused` with the reason."""
    from parolkit.motion import plan
    from parolkit.motion.errors import PlanningError

    if not points:
        raise TrajectoryRefused("the trajectory has no points")
    if len(points) > MAX_POINTS:
        raise TrajectoryRefused(f"the trajectory has {len(points)} points; at most {MAX_POINTS} are accepted")
    order = _order(joint_names)
    start_rad = np.radians(np.array(start_deg, dtype=float))
    first = 0
    prev_tick = 0
    rows: list[_Row] = []  # (deg, s, deg/s or None) per point of the path
    for k, p in enumerate(points):
        rad, vel = _point(k, p, order)
        if k == 0 and p.time_s == 0.0:
            off = np.abs(start_rad - rad)
            if float(off.max()) > START_TOLERANCE_RAD:
                j = int(off.argmax())
                raise TrajectoryRefused(
                    f"point 0 is at time_from_start 0 but {ROS_JOINT_NAMES[j]} is {off[j]:.4f} rad away from the "
                    f"current position (tolerance {START_TOLERANCE_RAD} rad); give the first point a time > 0")
            first = 1
            continue
        tick = round(p.time_s * rate_hz)
        if tick <= prev_tick:
            raise TrajectoryRefused(
                f"point {k}: time_from_start {p.time_s:.4f} s is not at least one control tick "
                f"({1 / rate_hz:.4f} s) after the previous point")
        rows.append((np.degrees(rad), p.time_s, None if vel is None else np.degrees(vel)))
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
        plan(move, start_deg, model=model, rate_hz=rate_hz)
    except PlanningError as exc:
        if exc.point is None:
            raise TrajectoryRefused(str(exc)) from None
        k = exc.point + first
        renumbered = " (the planner counts the path's points from the message's point 1 as 0)" if first else ""
        raise TrajectoryRefused(f"point {k} (t = {points[k].time_s:.3f} s): {exc}{renumbered}") from None
    except ParolkitError as exc:
        raise TrajectoryRefused(str(exc)) from None
    return TrajectoryPath(move, prev_tick, first)


def _point(k: int, p: TrajectoryPoint, order: list[int]) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Point ``k``'s positions (rad) and velocities (rad/s, None when not given) in L1..L6
    order, or TrajectoryRefused naming what is wrong."""
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
    return np.array([pos[i] for i in order]), (np.array([vel[i] for i in order]) if vel else None)


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
