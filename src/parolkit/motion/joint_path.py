"""Timed joint-space paths (MoveJointPath): pass through points at given times as ONE trajectory.

Why one trajectory: a chain of rest-to-rest MoveJoints stops at every point and each one
settles on its target before the next starts, so a path of n points ends up to 2(n-1) ticks
late.  Here the whole path is planned at once and played sample by sample like any other
position-tracked move (board command 156, feed-forward speeds).

Timing: the path starts at the current joints at time 0, at rest.  Point k (0-based, as in
:attr:`JointPathMove.points_deg`) is commanded exactly on tick ``round(times_s[k] * rate)``
after the start: its sample's position is the point (rounded to steps) and its feed-forward
speed the point's velocity.  Two points on the same tick (or a first point on tick 0) are
refused.  The path ends at rest on the last point (``positions[-1]`` is exactly its steps).

Interpolation: one cubic Hermite polynomial per joint between consecutive points, with the
velocities at the points either given (``velocities_deg_s``) or those of the C2 cubic spline
through the points with zero velocity at both ends (a clamped spline: continuous speed AND
acceleration at every interior point; solved with numpy, one small linear system for all six
joints).  The ticks of the points, not the raw times, are the spline's knots, so every point
falls exactly on its tick.

Checks (the same helpers as every other planner, on every sample): the points inside the joint
ranges, every sample inside the joint limits (a spline can overshoot between points), every
feed-forward speed within the position-tracking maximum, every acceleration (finite differences
from rest) within the joint's limit.  A path whose speeds are within every joint's maximum
speed but above the position-tracking maximum runs STRETCHED (the seed's speed rule, issue 24):
every time and given velocity scaled by one factor (the points and the path's shape kept; the
accelerations fall with the square), with a warning naming the joint, the speed and the
stretched time.  Over a joint's maximum speed, over an acceleration limit or out of range, a
path is REFUSED, naming the joint, the segment or point, the value, the limit and by how much
to slow the path down.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion import validate
from parolkit.motion.errors import PlanningError
from parolkit.motion.joint import build_trajectory, check_target
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import JointPathMove, Tracking
from parolkit.robot import RobotModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = ["plan_joint_path", "point_ticks", "spline_velocities", "hermite"]


def point_ticks(move: JointPathMove, rate: float) -> list[int]:
    """The tick of each point, ``round(times_s[k] * rate)``; a PlanningError naming the point
    when it falls on the tick of the point before it (or, for the first, on the start's)."""
    ticks: list[int] = []
    prev = 0
    for k, t in enumerate(move.times_s):
        tick = int(round(t * rate))
        if tick <= prev:
            before = "the start (tick 0)" if k == 0 else f"point {k - 1} (t={move.times_s[k - 1]:.3f} s, tick {prev})"
            raise PlanningError(
                move.name,
                f"point {k} (t={t:.3f} s) falls on tick {tick}, not after {before}: points must be at least "
                f"one control tick ({1.0 / rate:.3f} s) apart",
                time_s=t, value=t, point=k,
            )
        ticks.append(tick)
        prev = tick
    return ticks


def spline_velocities(knot_s: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Velocities at the knots (per unit of ``q`` per s) of the C2 cubic spline through ``q``
    ((n+1, joints) at the times ``knot_s`` (n+1,)) with zero velocity at both ends.

    The slope form of C2 continuity at each interior knot i (h_i = knot_s[i+1] - knot_s[i],
    d_i = (q[i+1] - q[i]) / h_i):  h_i m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_{i-1} m_{i+1}
    = 3 (h_i d_{i-1} + h_{i-1} d_i), with m_0 = m_n = 0: one (n-1)-square system, every joint a
    column of the right-hand side."""
    n = len(knot_s) - 1
    m = np.zeros_like(q, dtype=float)
    if n < 2:
        return m
    h = np.diff(knot_s)
    d = np.diff(q, axis=0) / h[:, None]
    a = np.zeros((n - 1, n - 1))
    rows = np.arange(n - 1)
    a[rows, rows] = 2.0 * (h[:-1] + h[1:])
    a[rows[1:], rows[:-1]] = h[2:]  # m_{i-1}: coefficient h_i (i = 2..n-1)
    a[rows[:-1], rows[1:]] = h[:-2]  # m_{i+1}: coefficient h_{i-1} (i = 1..n-2)
    rhs = 3.0 * (h[1:, None] * d[:-1] + h[:-1, None] * d[1:])
    m[1:-1] = np.linalg.solve(a, rhs)
    return m


def hermite(
    s: NDArray[np.float64], h: NDArray[np.float64], q0: NDArray[np.float64], q1: NDArray[np.float64],
    v0: NDArray[np.float64], v1: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position and velocity of cubic Hermite segments at the fractions ``s`` (N,) of segments
    lasting ``h`` (N,) s, from ``q0`` to ``q1`` (N, joints) with velocities ``v0``, ``v1`` (per
    s).  At s = 1 the position is exactly ``q1`` (every other basis term is an exact 0)."""
    s = s[:, None]
    hh = h[:, None]
    s2 = s * s
    s3 = s2 * s
    q = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * hh * v0 + (3 * s2 - 2 * s3) * q1 + (s3 - s2) * hh * v1
    qd = ((6 * s2 - 6 * s) * (q0 - q1) / hh + (3 * s2 - 4 * s + 1) * v0 + (3 * s2 - 2 * s) * v1)
    return q, qd


#: A path over the position-tracking maximum is re-timed this many times at most (each a little
#: slower: the points' ticks are rounded) before its refusal stands.
_STRETCH_TRIES = 6


def plan_joint_path(move: JointPathMove, start: NDArray[np.float64], model: RobotModel, rate: float) -> Trajectory:
    """MoveJointPath from ``start`` (deg): see the module docstring.  A path whose speeds are
    within every joint's maximum speed but above the position-tracking maximum runs stretched:
    every time (and given velocity) scaled by the same factor, the points and the path's shape
    kept, with a warning in its notes (the seed's speed rule: such a move runs, it is not
    refused)."""
    try:
        return _plan(move, start, model, rate)
    except PlanningError as exc:
        refusal = exc
    limits = validate.speed_limits(model, rate, position_tracked=True)
    peak = _peak_speeds(move, start, model, rate)
    if refusal.joint is None or not str(refusal.reason).startswith("too fast") or np.any(peak > limits.full):
        raise refusal
    j = int(np.argmax(peak / limits.array))
    factor = float(np.max(peak / limits.array))
    for _ in range(_STRETCH_TRIES):
        factor *= 1.002
        vel = move.velocities_deg_s
        stretched = JointPathMove(move.points_deg, tuple(t * factor for t in move.times_s),
                                  None if vel is None else tuple(tuple(v / factor for v in p) for p in vel))
        try:
            traj = _plan(stretched, start, model, rate)
        except PlanningError as exc:
            if not str(exc.reason).startswith("too fast"):
                raise
            continue
        warning = validate.stretch_warning(limits, j, float(peak[j]), "to pass the points at the times given",
                                           stretched.times_s[-1], from_s=move.times_s[-1])
        return traj.with_notes((*traj.notes, warning))
    raise refusal


def _peak_speeds(move: JointPathMove, start: NDArray[np.float64], model: RobotModel,
                 rate: float) -> NDArray[np.float64]:
    """Each joint's fastest speed (steps/s) on the path as timed, the velocities given at the
    points included."""
    spd = validate.model_arrays(model).steps_per_deg
    _, _, qd, _, _ = _samples(move, start, rate)
    peak: NDArray[np.float64] = np.abs(qd * spd).max(axis=0)
    if move.velocities_deg_s is not None:
        peak = np.maximum(peak, np.abs(np.asarray(move.velocities_deg_s, dtype=float) * spd).max(axis=0))
    return peak


def _samples(move: JointPathMove, start: NDArray[np.float64], rate: float) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """The path's samples: times, positions and speeds (deg, deg/s), the segment of each
    sample and the points' ticks (0 first: the start)."""
    points = np.asarray(move.points_deg, dtype=float)
    ticks = np.array([0, *point_ticks(move, rate)])
    knots = np.vstack([start[None, :], points])  # deg, knot 0 = the start
    knot_s = ticks / rate
    given = move.velocities_deg_s is not None
    vel = (np.vstack([np.zeros((1, 6)), np.asarray(move.velocities_deg_s, dtype=float)]) if given
           else spline_velocities(knot_s, knots))
    n_samples = int(ticks[-1])
    tick = np.arange(1, n_samples + 1)
    seg = np.searchsorted(ticks, tick, side="left") - 1  # sample at `tick` lies in (ticks[seg], ticks[seg + 1]]
    s = (tick - ticks[seg]) / (ticks[seg + 1] - ticks[seg])
    q, qd = hermite(s, knot_s[seg + 1] - knot_s[seg], knots[seg], knots[seg + 1], vel[seg], vel[seg + 1])
    t: NDArray[np.float64] = tick / rate
    return t, q, qd, seg, ticks


def _plan(move: JointPathMove, start: NDArray[np.float64], model: RobotModel, rate: float) -> Trajectory:
    name = move.name
    points = np.asarray(move.points_deg, dtype=float)
    for k, p in enumerate(points):
        check_target(name, p, model, what=f"point {k} (t={move.times_s[k]:.3f} s):", point=k)
    given = move.velocities_deg_s is not None
    t, q, qd, seg, ticks = _samples(move, start, rate)
    n_samples = int(ticks[-1])
    vel = (np.vstack([np.zeros((1, 6)), np.asarray(move.velocities_deg_s, dtype=float)]) if given else None)
    _check_samples(move, t, q, qd, seg, ticks, model, rate, vel)
    notes = (f"{len(points)} point(s) over {t[-1]:.3f} s ({n_samples} ticks), velocities at the points "
             + ("as given" if given else "of a C2 cubic spline (at rest at both ends)"),)
    # every sample was checked above (positions, speeds, accelerations, with messages naming the
    # segment): build_trajectory only rounds, pins the last sample to the last point and wraps
    return build_trajectory(move, t, q, qd, start=start, model=model, rate=rate, tracking=Tracking.POSITION,
                            notes=notes, target_deg=points[-1], proven=True)


def _check_samples(
    move: JointPathMove, t: NDArray[np.float64], q: NDArray[np.float64], qd: NDArray[np.float64],
    seg: NDArray[np.int64], ticks: NDArray[np.int64], model: RobotModel, rate: float,
    given: NDArray[np.float64] | None,
) -> None:
    """The validate checks on every sample; a refusal is re-raised naming the segment or point
    and, for speed and acceleration, how much slower the path must be.  ``given``: the
    velocities given at the knots (deg/s, the start's 0 first), checked first so that one over
    a limit is named at its point rather than at the first sample on the way to it."""
    spd = validate.model_arrays(model).steps_per_deg
    steps = np.rint(q * spd).astype(np.int64)
    sp_f = qd * spd
    limits = validate.speed_limits(model, rate, position_tracked=True)
    scaled = "the times (and the velocities divided)" if given is not None else "the times"
    if given is not None:
        try:
            validate.check_speeds(move.name, ticks[1:] / rate, given[1:] * spd, model, limits=limits)
        except PlanningError as exc:
            ratio = float(np.max(np.abs(given * spd).max(axis=0) / limits.array))
            raise _at_segment(move, exc, t, seg, ticks, "too fast", _slower(move, ratio, scaled)) from None
    try:
        validate.check_positions(move.name, t, steps, model)
    except PlanningError as exc:
        raise _at_segment(move, exc, t, seg, ticks, "the path leaves the joint range",
                          "the cubic overshoots between the points: add a point there, keep the points "
                          "further from the limit or give velocities") from None
    try:
        validate.check_speeds(move.name, t, sp_f, model, limits=limits)
    except PlanningError as exc:
        ratio = float(np.max(np.abs(sp_f).max(axis=0) / limits.array))
        raise _at_segment(move, exc, t, seg, ticks, "too fast", _slower(move, ratio, scaled)) from None
    try:
        validate.check_accels(move.name, t, sp_f, model, rate)
    except PlanningError as exc:
        ratio = math.sqrt(float(np.max(validate.peak_accels(sp_f, rate) / validate.model_arrays(model).amax)))
        raise _at_segment(move, exc, t, seg, ticks, "too abrupt", _slower(move, ratio, scaled)) from None


def _slower(move: JointPathMove, ratio: float, scaled: str) -> str:
    """What to do about a path ``ratio`` times over a speed (or sqrt of an acceleration) limit."""
    last = validate.min_duration_for_speed(move.times_s[-1], ratio)
    factor = math.ceil(ratio * 100.0 - 1e-6) / 100.0  # rounded up: 1.001 is "at least 1.01", not 1.00
    return f"multiply {scaled} by at least {factor:.2f} (the last point at t >= {last:.2f} s)"


def _at_segment(
    move: JointPathMove, exc: PlanningError, t: NDArray[np.float64], seg: NDArray[np.int64],
    ticks: NDArray[np.int64], what: str, hint: str,
) -> PlanningError:
    """``exc`` (from a validate check, naming the sample time, joint, value and limit) again,
    naming where on the path: at point k when the sample is a point's, else between the two
    points around it (point k is the one that ends the segment)."""
    i = int(np.argmin(np.abs(t - (exc.time_s or 0.0))))
    k = int(seg[i])  # the segment from knot k (0 = the start) to knot k + 1 (= point k)
    times = move.times_s
    if i + 1 == ticks[k + 1]:
        where = f"at point {k} (t={times[k]:.3f} s)"
    else:
        frm = "the start" if k == 0 else f"point {k - 1} (t={times[k - 1]:.3f} s)"
        where = f"between {frm} and point {k} (t={times[k]:.3f} s)"
    return PlanningError(move.name, f"{what} {where}: {exc.reason}; {hint}", time_s=exc.time_s,
                         joint=exc.joint, value=exc.value, point=k)
