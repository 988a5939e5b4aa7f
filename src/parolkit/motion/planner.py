"""``plan(move, start_deg) -> Trajectory``: the one planning entry point.

Joint-space moves (MoveJoint, MovePose, SpeedJoint, joint jogs) are planned in
:mod:`parolkit.motion.joint`, timed joint paths (MoveJointPath) in
:mod:`parolkit.motion.joint_path`; Cartesian moves and smooth paths in
:mod:`parolkit.motion.cartesian` (imported when first needed: it needs the kinematics).
The timing rules are in those modules' docstrings and in docs/motion.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from parolkit.errors import ParolkitValueError
from parolkit.motion.errors import PlanningError
from parolkit.motion.joint import (
    MOVEJOINT_DEFAULT_PCT,
    MOVEPOSE_DEFAULT_PCT,
    RUCKIG_JERK_TIME_S,
    SPEED_ONLY_ACCEL_PCT,
    plan_joint_jog,
    plan_joint_move,
    plan_pose_move,
    plan_speed_joint,
)
from parolkit.motion.joint_path import plan_joint_path
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import (
    ArcCenterMove,
    ArcParamMove,
    BlendMove,
    CartJog,
    CartMove,
    CartRelTRFMove,
    CircleMove,
    HelixMove,
    JointJog,
    JointMove,
    JointPathMove,
    PoseMove,
    SpeedJointMove,
    SplineMove,
)
from parolkit.robot import PAROL6, RobotModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool

__all__ = [
    "plan",
    # the joint-space defaults, defined in parolkit.motion.joint
    "MOVEJOINT_DEFAULT_PCT",
    "MOVEPOSE_DEFAULT_PCT",
    "SPEED_ONLY_ACCEL_PCT",
    "RUCKIG_JERK_TIME_S",
]

def _rate(rate_hz: float) -> float:
    try:
        r = float(rate_hz)
    except (TypeError, ValueError, OverflowError):
        raise ParolkitValueError(f"rate_hz must be a number in 1..1000 Hz, got {rate_hz!r}") from None
    if not math.isfinite(r) or not 1.0 <= r <= 1000.0:
        raise ParolkitValueError(f"rate_hz must be in 1..1000 Hz, got {rate_hz!r}")
    return r


def plan(
    move: object,
    start_deg: Sequence[float] | NDArray[np.float64],
    *,
    model: RobotModel = PAROL6,
    tool: str | Tool | None = None,
    rate_hz: float = 100.0,
    jog_start: object = None,
) -> Trajectory:
    """Plan ``move`` from the joint angles ``start_deg`` (deg, J1..J6).

    Returns a validated :class:`Trajectory` (every sample inside the joint limits, speeds and
    accelerations inside the model's maxima) or raises :class:`PlanningError` naming the
    move, the sample time, the joint and the value.  ``tool`` is passed to the kinematics for
    pose-based moves (None = the default tool).  ``rate_hz``: control loop rate (Hz).
    ``jog_start``: for a :class:`CartJog` that continues a running (streamed) Cartesian jog,
    the :class:`~parolkit.motion.cartesian.JogStart` of the sample it continues from (that
    jog's path orientation and joint speeds there); None otherwise.
    """
    rate = _rate(rate_hz)
    try:
        start = np.array(start_deg, dtype=float)
    except (TypeError, ValueError, OverflowError):
        start = np.zeros(0)
    if start.shape != (6,) or not all(map(math.isfinite, start.tolist())):
        raise ParolkitValueError(f"start_deg must be 6 finite joint angles (deg), got {start_deg!r}")
    try:
        return _dispatch(move, start, model, tool, rate, jog_start)
    except RuntimeError as exc:  # a profile library that gave up (Ruckig / TOPP-RA)
        name = getattr(move, "name", type(move).__name__)
        raise PlanningError(name, f"the profile could not be computed: {exc}") from exc


def _dispatch(
    move: object, start: NDArray[np.float64], model: RobotModel, tool: str | Tool | None, rate: float,
    jog_start: object = None,
) -> Trajectory:
    if isinstance(move, JointMove):
        return plan_joint_move(move, start, model, rate)
    if isinstance(move, JointPathMove):
        return plan_joint_path(move, start, model, rate)
    if isinstance(move, PoseMove):
        return plan_pose_move(move, start, model, tool, rate)
    if isinstance(move, SpeedJointMove):
        return plan_speed_joint(move, start, model, rate)
    if isinstance(move, JointJog):
        return plan_joint_jog(move, start, model, rate)
    if not isinstance(move, _CARTESIAN_MOVES):
        kinds = (JointMove, JointPathMove, PoseMove, SpeedJointMove, JointJog) + _CARTESIAN_MOVES
        raise ParolkitValueError(
            f"move must be one of {', '.join(c.__name__ for c in kinds)}, got {type(move).__name__}"
        )
    from parolkit.motion import cartesian  # lazy: needs kinematics

    if isinstance(move, CartJog):
        if jog_start is not None and not isinstance(jog_start, cartesian.JogStart):
            raise ParolkitValueError(f"jog_start must be a JogStart or None, got {type(jog_start).__name__}")
        return cartesian.plan_cart_jog(move, start, model=model, tool=tool, rate_hz=rate, jog_start=jog_start)
    return cartesian.plan_cartesian(move, start, model=model, tool=tool, rate_hz=rate)


_CARTESIAN_MOVES = (
    CartMove, CartRelTRFMove, CartJog, CircleMove, ArcCenterMove, ArcParamMove, HelixMove,
    SplineMove, BlendMove,
)
