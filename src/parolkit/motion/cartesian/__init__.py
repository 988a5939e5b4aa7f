"""Cartesian moves: MoveCart, MoveCartRelTRF, Cartesian jogs and the smooth paths.

Pipeline, one module per stage:

* :mod:`.path_of_move`: the path the move describes, built from :mod:`.geometry` (lines,
  arcs/circles/helices, splines, blended corners; mm, exact), plus approach lines;
* :mod:`.timing`: the time-scaling ``s(t)`` of the path progress (poly / trap / ruckig /
  TOPP-RA) -> the tool pose of every tick, stretched until the joints can follow;
* :mod:`.ik_along_path`: IK along the path (``kinematics.ik_batch``, branch-continuous, seeded
  with the start joints; the singular-area policy near J5 = 0) -> joint speeds by
  differentiation -> the same sample checks as every move;
* :mod:`.wrist_unwind`: a TOPP-RA path from the wrist singularity turns J4/J6 out of it first;
* :mod:`.jog`: Cartesian jogs (:func:`plan_cart_jog`).

:func:`plan_cartesian` (here) plays a move's approach lines and its path as one trajectory.

Timing:

* ``duration_s``: exactly that long (default POLY); a joint over its position-tracking
  maximum but within its maximum speed -> stretched, with a warning (the seed's speed rule);
  over its maximum speed -> refused.
* ``speed_pct`` (or the default :data:`DEFAULT_CART_SPEED_PCT` = 50 %): the move lasts
  path length / mapped speed (2..60 mm/s linear, 0.7..25 deg/s angular, the slower governs),
  as the original; default profile TRAP (1/3 accelerate, 1/3 cruise, 1/3 brake: the cruise
  speed is 1.5x the mapped mean speed).  When a joint
  cannot follow (speed or acceleration), the duration is stretched and a note says so.

Joint speeds: position-tracked paths (board command 156, the default) keep every joint within
:meth:`RobotModel.max_tracked_speed_steps_s` (the board's GO TO loop starts every tick 1.27x
faster than the stream moves at 100 Hz), checked on every sample's speed and on every tick's
step from the start on; speed-tracked paths (123) within the maximum speed.

A path through a singularity shows up as a joint needing an unbounded speed; beyond
:data:`MAX_STRETCH` times the requested duration the move is refused and the message names
the nearest singularity.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion.cartesian.geometry import Line, Path
from parolkit.motion.cartesian.jog import CartJogTrajectory, JogStart, plan_cart_jog
from parolkit.motion.cartesian.path_of_move import (
    DEFAULT_CART_SPEED_PCT,
    ON_PATH_TOL_MM,
    CartesianMove,
    build_path,
    far_apart,
    frame_pose,
)
from parolkit.motion.cartesian.timing import CART_ACCEL_TIME_S, MAX_STRETCH, time_and_solve
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import Frame

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool
    from parolkit.robot import RobotModel

__all__ = [
    "plan_cartesian", "plan_cart_jog", "DEFAULT_CART_SPEED_PCT", "MAX_STRETCH",
    "CART_ACCEL_TIME_S", "ON_PATH_TOL_MM", "CartesianMove", "JogStart", "CartJogTrajectory",
]


def plan_cartesian(
    move: CartesianMove, start: NDArray[np.float64], *, model: RobotModel, tool: str | Tool | None,
    rate_hz: float,
) -> Trajectory:
    """Plan any Cartesian move or smooth path (see module docstring)."""
    from parolkit import kinematics as kin  # (imported when first needed)

    t0 = np.asarray(kin.fk_matrix(start, tool), dtype=float)
    p0, r0 = t0[:3, 3] * 1e3, t0[:3, :3]
    parts: list[Trajectory] = []
    notes: list[str] = []
    cur_q = start
    start_pose = getattr(move, "start_pose", None)
    if start_pose is not None:
        ts = frame_pose(getattr(move, "frame", Frame.WRF), t0, start_pose)
        if far_apart(p0, r0, ts[:3, 3] * 1e3, ts[:3, :3]):
            approach = Path([Line(p0, ts[:3, 3] * 1e3, r0, ts[:3, :3])])
            parts.append(time_and_solve(move, approach, cur_q, model, tool, rate_hz, approach=True))
            notes.append("approach: straight line to start_pose first")
            cur_q = parts[-1].final_deg
        p0, r0 = ts[:3, 3] * 1e3, ts[:3, :3]
        t0 = ts
    path, pre = build_path(move, t0, p0, r0, model)
    for seg_path, note in pre:  # approach segments played as separate, resting moves
        parts.append(time_and_solve(move, seg_path, cur_q, model, tool, rate_hz, approach=True))
        notes.append(note)
        cur_q = parts[-1].final_deg
    parts.append(time_and_solve(move, path, cur_q, model, tool, rate_hz))
    if len(parts) == 1:
        return parts[0]
    return Trajectory.concatenate(parts, move, notes)
