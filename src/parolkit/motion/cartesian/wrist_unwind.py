"""A Cartesian path that starts exactly on the wrist singularity (J5 = 0, the standby pose after
homing): J4/J6 turn out of it first, the tool standing still.

Used before a time-optimal (TOPP-RA) timing, which times the exact joint path and so cannot
follow the singular-area policy (:mod:`parolkit.motion.singular`) that the other timings use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion.cartesian.ik_along_path import solve_ik
from parolkit.motion.errors import PlanningError
from parolkit.motion.joint import MOVEJOINT_DEFAULT_PCT, plan_joint_target
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import JointMove

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool
    from parolkit.motion.cartesian.geometry import Path
    from parolkit.motion.cartesian.path_of_move import CartesianMove
    from parolkit.moves import Tracking
    from parolkit.robot import RobotModel

__all__ = ["WRIST_SINGULAR_START_DEG", "unwind_wrist", "planned_end"]


#: |J5| (deg) at or below which the start counts as exactly on the wrist singularity.
WRIST_SINGULAR_START_DEG = 0.01


def unwind_wrist(
    move: CartesianMove, path: Path, start: NDArray[np.float64], model: RobotModel,
    tool: str | Tool | None, rate_hz: float, tracking: Tracking,
) -> Trajectory | None:
    """A path starting exactly on the wrist singularity (J5 = 0, e.g. the standby pose after
    homing) may need J4 at another angle from the first tick on.  Axes 4 and 6 are aligned
    there, so J4 + d and J6 - d is the same pose: turn J4/J6 that way first (a joint move
    that leaves the tool where it is, at MoveJoint's default speed), then follow the path.
    None when not needed."""
    if abs(float(start[4])) > WRIST_SINGULAR_START_DEG:
        return None
    pos, rots = path.evaluate(np.array([1e-4]))
    try:
        q_eps = solve_ik(move.name, pos, rots, start, tool, np.array([0.0]))[0]
    except PlanningError:
        return None
    d = float(q_eps[3] - start[3])
    if abs(d) < 1e-3:
        return None
    target = np.array(start, dtype=float)
    target[3] += d
    target[5] -= d

    lim = model.safe_limits_deg
    if not lim[5, 0] <= target[5] <= lim[5, 1]:
        alt = target[5] + (360.0 if target[5] < lim[5, 0] else -360.0)
        if lim[5, 0] <= alt <= lim[5, 1]:
            target[5] = alt
    jm = JointMove(target.tolist(), tracking=tracking)
    try:
        tr = plan_joint_target(jm, np.asarray(start, dtype=float), target, model, rate_hz,
                                MOVEJOINT_DEFAULT_PCT)
    except PlanningError as exc:
        raise PlanningError(move.name, f"the path starts on the wrist singularity and J4/J6 cannot "
                            f"turn out of it: {exc.reason}", joint=exc.joint, value=exc.value) from exc
    note = (f"start on the wrist singularity (J5 = 0): J4 turned {d:+.1f} deg and J6 {-d:+.1f} deg "
            f"first ({tr.duration:.2f} s, the tool does not move)")
    return Trajectory(t=tr.t, positions=tr.positions, speeds=tr.speeds, commands=tr.commands,
                      rate_hz=tr.rate_hz, move=move, notes=(note,), start_deg=tr.start_deg,
                      model=model, planned_deg=tr.planned_deg)


def planned_end(tr: Trajectory) -> NDArray[np.float64]:
    """The joint angles (deg) the planner computed for the last sample of ``tr`` (every
    trajectory :mod:`parolkit.motion.joint` builds records them)."""
    if tr.planned_deg is None:
        raise ValueError(f"{tr.name}: a planned trajectory without planned_deg (a planner bug)")
    end: NDArray[np.float64] = tr.planned_deg[-1]
    return end
