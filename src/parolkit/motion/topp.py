"""Time-optimal path parameterisation with TOPP-RA (imported lazily: ~1.3 s cold import)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = ["ToppResult", "toppra_parameterize"]


@dataclass(frozen=True)
class ToppResult:
    """A joint path timed by TOPP-RA: ``duration`` (s) and ``evaluate(t) -> (q, qd, qdd)``
    in the units of the waypoints (deg, deg/s, deg/s^2), times clipped to [0, duration]."""

    duration: float
    evaluate: Callable[[NDArray[np.float64]], tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]
    #: the time-optimal duration before any uniform slow-down to a requested duration (s)
    optimal_duration: float = 0.0


#: TOPP-RA gets limits reduced by this factor: its output spline may overshoot them slightly.
TOPP_MARGIN = 0.97


def toppra_parameterize(
    s: NDArray[np.float64], q_deg: NDArray[np.float64], vmax_deg_s: NDArray[np.float64],
    amax_deg_s2: NDArray[np.float64], *, duration: float | None = None,
) -> ToppResult | None:
    """Time-optimal timing of the joint path through ``q_deg`` (M, 6) at path parameters
    ``s`` (M,) (strictly increasing), within per-joint speed and acceleration limits.

    With ``duration`` (s) >= the optimum, the optimal timing is slowed uniformly to last
    exactly ``duration`` (speeds scale by k, accelerations by k^2, k <= 1, so it stays
    feasible).  Returns None when TOPP-RA finds no feasible parameterisation.
    """
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    logging.getLogger("toppra").setLevel(logging.WARNING)
    v = np.asarray(vmax_deg_s, dtype=float) * TOPP_MARGIN
    a = np.asarray(amax_deg_s2, dtype=float) * TOPP_MARGIN
    path = ta.SplineInterpolator(np.asarray(s, dtype=float), np.asarray(q_deg, dtype=float))
    cons = [
        constraint.JointVelocityConstraint(np.stack([-v, v], axis=1)),
        constraint.JointAccelerationConstraint(np.stack([-a, a], axis=1)),
    ]
    n_grid = int(min(400, max(50, 4 * len(s))))
    gridpoints = np.linspace(float(s[0]), float(s[-1]), n_grid)
    inst = algo.TOPPRA(cons, path, gridpoints=gridpoints, parametrizer="ParametrizeConstAccel")
    traj = inst.compute_trajectory(0.0, 0.0)
    if traj is None:
        return None
    t_opt = float(traj.duration)
    k = 1.0 if duration is None or duration <= t_opt else t_opt / duration
    total = t_opt / k

    def evaluate(t: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        tau = np.clip(np.asarray(t, dtype=float) * k, 0.0, t_opt)
        return (
            np.asarray(traj(tau)), np.asarray(traj(tau, 1)) * k, np.asarray(traj(tau, 2)) * k * k,
        )

    return ToppResult(duration=total, evaluate=evaluate, optimal_duration=t_opt)
