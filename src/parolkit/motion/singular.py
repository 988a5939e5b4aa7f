"""The wrist's singular area: Cartesian paths through, near and from J5 = 0.

Every session starts at the standby pose, on the wrist singularity (J5 = 0: axes 4 and 6
aligned).  There the exact IK of a Cartesian path asks J4 and J6 to turn by up to 90 deg
(in opposite directions) within one tick: the tool must tilt (J5) in a direction J4 does
not point in yet.  No joint can do that, and the previous answer (turn J4/J6 first, tool
still, then follow the path) made every Cartesian move from standby late and every jog look
dead for 1.5 s.

The policy (an industrial "singular area" policy, cf. ABB ``SingArea \\Wrist``): inside the
area the TCP position stays exactly on its path, at exactly its time, and the orientation may
deviate by a small, bounded and reported amount while J4 turns:

1. the path is solved exactly (:func:`parolkit.kinematics.ik_batch`, branch-continuous);
   where that needs no J4/J6 speed beyond their limits, it is used as it is (no deviation);
2. otherwise J4 follows the exact solution's J4 (modulo 180 deg: J4 + 180, -J5, J6 + 180 is
   the same wrist) with a speed- and acceleration-limited tracker: it turns as fast as J4
   and J6 may (J6 turns the other way, keeping J4 + J6, the tool's twist) towards where the
   exact J4 will be once the tilt is significant (|J5| >= :data:`LOCK_DEG`; while the tilt
   is smaller its direction is undefined or noise), starting from the current J4 speed (a
   streamed jog update continues the turn instead of restarting it);
3. with that J4 the other joints are solved by :func:`parolkit.kinematics.wrist.solve_with_j4`:
   the TCP position exactly, J5/J6 the closest orientation.  The orientation error is at most
   the exact solution's |J5| where J4 lags (the tilt J4 does not point at yet) and vanishes
   once J4 has caught up (typically 0.5-1.5 s after the start of the path);
4. the deviation is measured on every sample (the angle between the wanted and the reached
   tool orientation) and reported in the plan's notes (the ack's details); beyond
   :data:`MAX_DEVIATION_DEG` the path is refused like any other limit (a timed move with the
   shortest duration that fits, a jog stops there with the reason).

Figures (default tool, standby, 100 Hz): MoveCart t=2 of 127 mm down: 2.00 s, orientation
within 0.3 deg during the first 0.6 s; a 50 % X+ jog: moves from the first tick, deviation
peaks near 4 deg and is gone after ~1.5 s.  ``docs/motion.md`` (singular area) has the table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from parolkit.robot import RobotModel

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool

__all__ = [
    "WRIST_AREA_DEG", "LOCK_DEG", "MAX_DEVIATION_DEG", "REPORT_DEVIATION_DEG", "END_DEVIATION_DEG", "WristArea",
    "needs_policy", "follow", "wrist_limits",
]

#: |J5| (deg, exact solution) below which the policy may replace the exact wrist.
WRIST_AREA_DEG = 15.0
#: J4's target is the exact solution's J4 only where |J5| is at least this (deg).
LOCK_DEG = 0.5
#: Largest orientation deviation (deg) the policy accepts; more is refused / stops a jog.
MAX_DEVIATION_DEG = 10.0
#: Deviations below this (deg) are not reported (numerical noise).
REPORT_DEVIATION_DEG = 0.01
#: A move (not a jog) must end with at most this deviation (deg): it ends on its target pose.
END_DEVIATION_DEG = 0.01
#: Share of J4 / J6 speed and acceleration limits the tracker uses (the rest: rounding to
#: steps, the exact path's own J6 motion, the board's tracking).
SPEED_SHARE = 0.8
ACCEL_SHARE = 0.85
#: J4 target changes branch (J4 +- 180) only when the other one is this much closer (deg).
_HYSTERESIS_DEG = 10.0


@dataclass(frozen=True)
class WristArea:
    """The result of the policy for one sampled path.

    Attributes:
        q_deg: (N, 6) joint angles (deg) for the path's samples.
        deviation_deg: (N,) orientation deviation per sample (deg).
        t: (N,) sample times (s).
    """

    q_deg: NDArray[np.float64]
    deviation_deg: NDArray[np.float64]
    t: NDArray[np.float64]

    @property
    def max_deviation_deg(self) -> float:
        return float(self.deviation_deg.max()) if len(self.deviation_deg) else 0.0

    @property
    def end_deviation_deg(self) -> float:
        return float(self.deviation_deg[-1]) if len(self.deviation_deg) else 0.0

    def overload(self) -> float:
        """How far a move is over the policy's bounds (1 = at them): its largest deviation
        against :data:`MAX_DEVIATION_DEG`; a move ending more than :data:`END_DEVIATION_DEG`
        off its target orientation is always over (J4 had no time to turn)."""
        r = self.max_deviation_deg / MAX_DEVIATION_DEG
        if self.end_deviation_deg > END_DEVIATION_DEG:
            r = max(r, 2.0)  # (the turn needs time: double the duration per try)
        return r

    def first_over(self, limit_deg: float) -> int | None:
        """Index of the first sample deviating more than ``limit_deg``; None if none."""
        over = np.nonzero(self.deviation_deg > limit_deg)[0]
        return int(over[0]) if len(over) else None

    def note(self) -> str:
        """What the plan's notes say: J4's turn, the largest deviation, when."""
        dev = self.deviation_deg
        on = np.nonzero(dev > REPORT_DEVIATION_DEG)[0]
        turn = float(self.q_deg[-1, 3] - self.q_deg[0, 3]) if len(self.q_deg) else 0.0
        text = (f"wrist singular area (J5 near 0): TCP position exact, J4/J6 turning "
                f"({turn:+.1f} deg J4 over the move)")
        if len(on):
            k = int(np.argmax(dev))
            text += (f"; orientation deviates up to {dev[k]:.2f} deg (at {self.t[k]:.2f} s, "
                     f"from {self.t[on[0]]:.2f} s to {self.t[on[-1]]:.2f} s)")
        else:
            text += "; orientation exact"
        return text


def wrist_limits(model: RobotModel, v_limits_deg_s: NDArray[np.float64]) -> tuple[
        NDArray[np.float64], NDArray[np.float64]]:
    """(speed (6,) deg/s, acceleration (6,) deg/s^2) the tracker may use: ``v_limits_deg_s``
    (the limits the path is checked against) and the model's joint accelerations, each times
    its share."""
    acc = _accel_limits_deg_s2(model)
    return np.asarray(v_limits_deg_s, dtype=float) * SPEED_SHARE, acc * ACCEL_SHARE


def _accel_limits_deg_s2(model: RobotModel) -> NDArray[np.float64]:
    """Per-joint acceleration limit (deg/s^2): the model's per-joint limit when it has one,
    else the top of its acceleration range."""
    per_joint = getattr(model, "max_accel_steps_s2", None)
    if per_joint is not None:
        out: NDArray[np.float64] = np.asarray(per_joint, dtype=float) / model.steps_per_deg
        return out
    return np.asarray(model.max_accel_deg_s2, dtype=float) * np.ones(6)


def needs_policy(q_full: NDArray[np.float64], tt: NDArray[np.float64], v_lim: NDArray[np.float64]) -> bool:
    """Does the exact joint path ``q_full`` ((N+1, 6) deg, the start first; times ``tt``)
    ask J4 or J6 for more than ``v_lim`` (deg/s) inside the singular area?"""
    if len(q_full) < 2:
        return False
    dt = np.diff(tt)
    dt[dt <= 0] = 1e-9
    sp = np.abs(np.diff(q_full[:, (3, 5)], axis=0)) / dt[:, None]
    area = np.minimum(np.abs(q_full[1:, 4]), np.abs(q_full[:-1, 4])) < WRIST_AREA_DEG
    fast = (sp[:, 0] > v_lim[3]) | (sp[:, 1] > v_lim[5])
    return bool(np.any(area & fast))


def _targets(q_full: NDArray[np.float64]) -> NDArray[np.float64]:
    """J4 target per sample: the exact J4 where the tilt is significant, else the next such
    value (the last one after the last; the start J4 when there is none)."""
    j4 = q_full[:, 3]
    locked = np.abs(q_full[:, 4]) >= LOCK_DEG
    n = len(j4)
    if not locked.any():
        return np.full(n, j4[0])
    idx = np.where(locked, np.arange(n), n)
    nxt = np.minimum.accumulate(idx[::-1])[::-1]  # next locked index (n: none)
    prv = np.maximum.accumulate(np.where(locked, np.arange(n), -1))
    src = np.where(nxt < n, nxt, prv)
    return j4[src]


def _track(q_full: NDArray[np.float64], tt: NDArray[np.float64], v0: float, v_lim: NDArray[np.float64],
           a_lim: NDArray[np.float64], j4_range: tuple[float, float], stop_at_end: bool) -> NDArray[np.float64]:
    """J4 (deg) per sample (the start first): chases the targets within the speed limits of
    J4 and of J6 (which turns the other way) and the smaller acceleration limit; with
    ``stop_at_end`` slow enough to be at rest at the last sample."""
    tgt = _targets(q_full)
    sig = q_full[:, 3] + q_full[:, 5]
    n = len(tgt)
    x = np.empty(n)
    x[0] = q_full[0, 3]
    v = float(v0)
    a = float(min(a_lim[3], a_lim[5]))
    v4, v6 = float(v_lim[3]), float(v_lim[5])
    lo_r, hi_r = j4_range
    shift = 0.0  # the target's branch: +- 180 deg
    xk = float(x[0])
    for k in range(1, n):
        dt = float(tt[k] - tt[k - 1])
        if dt <= 0.0:
            x[k] = xk
            continue
        g0 = float(tgt[k])
        g = g0 + shift
        best = None
        for cand in (g0 - 360.0, g0 - 180.0, g0, g0 + 180.0, g0 + 360.0):
            if lo_r <= cand <= hi_r and (best is None or abs(cand - xk) < abs(best - xk)):
                best = cand
        if best is not None and (not lo_r <= g <= hi_r or abs(best - xk) < abs(g - xk) - _HYSTERESIS_DEG):
            shift = best - g0
            g = best
        sdot = float(sig[k] - sig[k - 1]) / dt
        lo = max(-v4, sdot - v6)
        hi = min(v4, sdot + v6)
        e = g - xk
        gd = float(tgt[k] - tgt[k - 1]) / dt if k > 1 else 0.0
        if abs(gd) > v4:  # the target jumped (a new lookahead value), it does not move
            gd = 0.0
        v_exact = e / dt
        vb = math.sqrt(2.0 * a * abs(e))
        v_des = v_exact if abs(v_exact - gd) <= vb else gd + math.copysign(vb, e)
        v_new = min(max(v_des, v - a * dt), v + a * dt)
        v_new = min(max(v_new, lo), hi)
        if stop_at_end:
            cap = a * float(tt[-1] - tt[k])
            v_new = min(max(v_new, -cap), cap)
        xk += 0.5 * (v + v_new) * dt  # (the speeds the planner's central differences see)
        v = v_new
        x[k] = xk
    return x


def follow(
    pos_mm: NDArray[np.float64], rots: NDArray[np.float64], q_exact: NDArray[np.float64],
    start: NDArray[np.float64], t: NDArray[np.float64], *, model: RobotModel, tool: str | Tool | None,
    v_limits_deg_s: NDArray[np.float64], start_speed_deg_s: NDArray[np.float64] | None = None,
    stop_at_end: bool = True,
) -> WristArea:
    """The policy for the sampled path (``pos_mm`` (N, 3), ``rots`` (N, 3, 3), times ``t``
    (N,) s after the start ``start`` (6,) deg), given its exact IK ``q_exact`` (N, 6) deg.

    ``v_limits_deg_s``: the joint speed limits the path is checked against (deg/s);
    ``start_speed_deg_s``: joint speeds at the start (a streamed jog's update), default 0;
    ``stop_at_end``: J4 comes to rest by the last sample (a move; a jog just stops).
    Raises :class:`~parolkit.kinematics.IKError` (``.sample``) where the wrist centre leaves
    the arm's reach."""
    from parolkit.kinematics.wrist import solve_with_j4

    q_full = np.vstack([np.asarray(start, dtype=float)[None, :], q_exact])
    tt = np.concatenate(([0.0], np.asarray(t, dtype=float)))
    v_lim, a_lim = wrist_limits(model, v_limits_deg_s)
    lim = model.safe_limits_deg
    v0 = 0.0 if start_speed_deg_s is None else float(start_speed_deg_s[3])
    x = _track(q_full, tt, v0, v_lim, a_lim, (float(lim[3, 0]), float(lim[3, 1])), stop_at_end)
    sol = solve_with_j4(pos_mm, rots, x[1:], q_exact, tool)
    q = sol.q_deg
    # J6 continuous from the start's value (not only nearest the exact first sample)
    d6 = q[0, 5] - start[5]
    q[:, 5] -= 360.0 * math.floor(d6 / 360.0 + 0.5)
    if sol.position_error_mm > 1e-4:  # pragma: no cover - the fixed point always converges here
        raise RuntimeError(f"singular-area IK missed the TCP by {sol.position_error_mm:.2g} mm")
    return WristArea(q, sol.deviation_deg, np.asarray(t, dtype=float))
