"""A ROS 2 JointTrajectory -> the controller's MoveJoint segments, checked before anything moves.

Pure planning (no DDS, no sockets): :func:`plan_joint_trajectory` turns the points of a
``trajectory_msgs/msg/JointTrajectory`` (radians, ``time_from_start`` in s) into one timed
MoveJoint per point (degrees, whole control ticks), and plans every segment with
:func:`parolkit.motion.plan` (the controller's own planner and limits: joint limits, speed
limits of position tracking, ...).  Any problem refuses the WHOLE trajectory with a
:class:`TrajectoryRefused` naming the point and the reason, before the first segment is sent,
so a refused trajectory moves nothing.  The controller plans each segment again when it runs
it (its guard checks every frame): this pre-check is what makes a refusal all-or-nothing.

Timing: point ``k`` is due at ``round(time_from_start_k * rate)`` ticks after the start; each
segment lasts the whole number of ticks between its point and the previous one (so the last
point is due within half a tick of its ``time_from_start``).  Each segment is a rest-to-rest
MoveJoint (POLY profile): the positions and times of the points are followed, the velocities
and accelerations of intermediate points are not (a point is passed at rest).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from parolkit.errors import ParolkitError
from parolkit.moves import JointMove
from parolkit.robot import NUM_JOINTS, RobotModel
from parolkit.ros2.urdf import ROS_JOINT_NAMES

__all__ = ["TrajectoryRefused", "TrajectoryPoint", "TrajectorySegment", "plan_joint_trajectory", "START_TOLERANCE_RAD"]

#: A first point at time_from_start 0 must be this close to the current position (rad); it is
#: then only the start and no segment goes to it (0.001 rad = 0.057 deg, a few microsteps).
START_TOLERANCE_RAD = 1e-3
#: At most this many points (each is one queued MoveJoint).
MAX_POINTS = 200


class TrajectoryRefused(ParolkitError):
    """A JointTrajectory that cannot be followed; nothing was sent to the controller."""


@dataclass(frozen=True)
class TrajectoryPoint:
    """One point: joint names as in the message, positions in rad, ``time_s`` from the start."""

    positions_rad: Sequence[float]
    time_s: float


@dataclass(frozen=True)
class TrajectorySegment:
    """One MoveJoint of a trajectory: target (deg, J1..J6), duration (s, whole ticks)."""

    target_deg: tuple[float, ...]
    duration_s: float
    ticks: int


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
) -> list[TrajectorySegment]:
    """The MoveJoint segments of a trajectory starting at ``start_deg`` (deg), each planned with
    the controller's planner at ``rate_hz``; raises :class:`TrajectoryRefused` with the reason."""
    from parolkit.motion import plan
    from parolkit.motion.errors import PlanningError

    if not points:
        raise TrajectoryRefused("the trajectory has no points")
    if len(points) > MAX_POINTS:
        raise TrajectoryRefused(f"the trajectory has {len(points)} points; at most {MAX_POINTS} are accepted")
    order = _order(joint_names)
    prev_deg = np.array(start_deg, dtype=float)
    prev_tick = 0
    segments: list[TrajectorySegment] = []
    for k, p in enumerate(points):
        pos = list(p.positions_rad)
        if len(pos) != NUM_JOINTS:
            raise TrajectoryRefused(f"point {k}: {len(pos)} positions for {NUM_JOINTS} joints")
        if not all(math.isfinite(v) for v in pos) or not math.isfinite(p.time_s):
            raise TrajectoryRefused(f"point {k}: positions and time_from_start must be finite")
        rad = np.array([pos[i] for i in order])
        deg = np.degrees(rad)
        tick = round(p.time_s * rate_hz)
        if k == 0 and p.time_s == 0.0:
            off = np.abs(np.radians(prev_deg) - rad)
            if float(off.max()) > START_TOLERANCE_RAD:
                j = int(off.argmax())
                raise TrajectoryRefused(
                    f"point 0 is at time_from_start 0 but {ROS_JOINT_NAMES[j]} is {off[j]:.4f} rad away from the "
                    f"current position (tolerance {START_TOLERANCE_RAD} rad); give the first point a time > 0")
            continue
        if tick <= prev_tick:
            raise TrajectoryRefused(
                f"point {k}: time_from_start {p.time_s:.4f} s is not at least one control tick "
                f"({1 / rate_hz:.4f} s) after the previous point")
        ticks = tick - prev_tick
        move = JointMove(target_deg=tuple(float(v) for v in deg), duration_s=ticks / rate_hz)
        try:
            plan(move, prev_deg, model=model, rate_hz=rate_hz)
        except PlanningError as exc:
            raise TrajectoryRefused(f"point {k} (t = {p.time_s:.3f} s): {exc}") from None
        except ParolkitError as exc:
            raise TrajectoryRefused(f"point {k} (t = {p.time_s:.3f} s): {exc}") from None
        segments.append(TrajectorySegment(tuple(float(v) for v in deg), ticks / rate_hz, ticks))
        prev_deg, prev_tick = deg, tick
    if not segments:
        raise TrajectoryRefused("the trajectory has no point after time_from_start 0: nothing to do")
    return segments
