"""Motion planning: move requests -> validated per-tick trajectories (steps, steps/s, command).

One entry point, :func:`plan`; see docs/motion.md for the rules (the seed's) and numbers.
Heavy libraries (ruckig, toppra, matplotlib, the kinematics) load only when first needed.

The move value objects and the words they use (``Profile``, ``Tracking``, ``Frame``, ...) are
defined once in :mod:`parolkit.moves` (shared with the protocol, RBTscript and the GUI) and
re-exported here, so ``from parolkit.motion import JointMove, plan`` keeps working.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from parolkit.motion.errors import PlanningError
from parolkit.motion.planner import plan
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import (
    ArcCenterMove,
    ArcParamMove,
    BlendMove,
    CartAxis,
    CartJog,
    CartMove,
    CartRelTRFMove,
    CircleMove,
    Frame,
    HelixMove,
    JointJog,
    JointMove,
    JointPathMove,
    LineSegment,
    Move,
    Plane,
    PoseMove,
    Profile,
    SpeedJointMove,
    SplineMove,
    Tracking,
)

if TYPE_CHECKING:
    from collections.abc import Sequence
    from pathlib import Path

__all__ = [
    "plan",
    "Trajectory",
    "PlanningError",
    "Profile",
    "Tracking",
    "Frame",
    "Plane",
    "CartAxis",
    "JointMove",
    "JointPathMove",
    "PoseMove",
    "CartMove",
    "CartRelTRFMove",
    "SpeedJointMove",
    "JointJog",
    "CartJog",
    "CircleMove",
    "ArcCenterMove",
    "ArcParamMove",
    "HelixMove",
    "SplineMove",
    "LineSegment",
    "BlendMove",
    "Move",
    "plot_trajectory",
]


def plot_trajectory(
    traj_or_list: Trajectory | Sequence[Trajectory], path_png: str | Path, *, title: str | None = None,
    dpi: int = 100,
) -> Path:
    """Draw position and speed per joint to ``path_png`` (see :mod:`parolkit.motion.plot`)."""
    from parolkit.motion.plot import plot_trajectory as _plot  # (matplotlib: imported when first needed)

    return _plot(traj_or_list, path_png, title=title, dpi=dpi)
