"""Scalar time-scaling profiles s(t): 0 -> 1 over a duration, with s'(t) and s''(t).

A synchronised joint-space move is ``q(t) = q0 + (q1 - q0) * s(t)``; a Cartesian path is
``pose(s(t))`` with ``s`` proportional to path length.  All functions are vectorised over the
sample times (no per-sample Python loop) and return ``(s, sd, sdd)`` in 1, 1/s, 1/s^2.

Peak factors (for a unit distance over duration T), used to check limits analytically:

=========  ===================  =====================
profile    peak speed           peak acceleration
=========  ===================  =====================
POLY       15/8 / T = 1.875/T   10/sqrt(3) / T^2 = 5.7735/T^2
TRAP 1/3   3/2 / T              9/2 / T^2
=========  ===================  =====================
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = [
    "POLY_PEAK_SPEED",
    "POLY_PEAK_ACCEL",
    "TRAP3_PEAK_SPEED",
    "TRAP3_PEAK_ACCEL",
    "ScalarProfile",
    "quintic",
    "trapezoid",
    "trapezoid_for_limits",
    "ruckig_unit_profile",
    "sampled_basis",
]

#: Quintic peak speed x T / distance.
POLY_PEAK_SPEED = 15.0 / 8.0
#: Quintic peak |acceleration| x T^2 / distance.
POLY_PEAK_ACCEL = 10.0 / math.sqrt(3.0)
#: 1/3-1/3-1/3 trapezoid peak speed x T / distance.
TRAP3_PEAK_SPEED = 1.5
#: 1/3-1/3-1/3 trapezoid acceleration x T^2 / distance.
TRAP3_PEAK_ACCEL = 4.5


@dataclass(frozen=True)
class ScalarProfile:
    """A unit profile: ``kind`` ("poly", "trap", "ruckig"), duration ``T`` (s) and, for a
    trapezoid, the acceleration time ``ta`` (s); for Ruckig the piecewise-jerk tables."""

    kind: str
    T: float
    ta: float = 0.0
    # ruckig: phase start times (8,), jerk (7,), and a, v, p at each phase start (8,)
    phase_t: tuple[float, ...] = ()
    jerk: tuple[float, ...] = ()
    acc: tuple[float, ...] = ()
    vel: tuple[float, ...] = ()
    pos: tuple[float, ...] = ()

    @property
    def peak_speed(self) -> float:
        """Peak s' (1/s)."""
        if self.T <= 0:
            return 0.0
        if self.kind == "poly":
            return POLY_PEAK_SPEED / self.T
        if self.kind == "trap":
            return 1.0 / (self.T - self.ta)
        return float(max(abs(v) for v in self.vel)) if self.vel else 0.0

    @property
    def peak_accel(self) -> float:
        """Peak |s''| (1/s^2)."""
        if self.T <= 0:
            return 0.0
        if self.kind == "poly":
            return POLY_PEAK_ACCEL / self.T**2
        if self.kind == "trap":
            return self.peak_speed / self.ta if self.ta > 0 else math.inf
        return float(max(abs(a) for a in self.acc)) if self.acc else 0.0

    def __call__(self, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Evaluate at times ``t`` (s); times outside [0, T] are held at the ends."""
        t = np.minimum(np.maximum(t, 0.0), self.T)
        if self.T <= 0:
            one = np.ones_like(t)
            return one, np.zeros_like(t), np.zeros_like(t)
        if self.kind == "poly":
            return quintic(t, self.T)
        if self.kind == "trap":
            return trapezoid(t, self.T, self.ta)
        return _eval_piecewise_jerk(t, self)


#: Moves with at most this many samples have their sampled basis cached (bounded memory:
#: 64 entries of at most 4 x 8 bytes x 2000 samples).
BASIS_CACHE_MAX_SAMPLES = 2000


def sampled_basis(
    kind: str, T: float, ta: float, rate_hz: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Tick times and the unit profile sampled at them, cached and read-only.

    ``kind`` "poly" or "trap" (``ta``: the trapezoid's acceleration time, s), duration ``T``
    (s), control rate ``rate_hz`` (Hz).  Returns ``(t, basis, speed)``:

    * ``t`` (N,): the tick times 1/rate, 2/rate, ... up to the first tick at or after ``T``
      (s; the planner's ``sample_times``);
    * ``basis`` (N, 2): columns ``1`` and ``s(t)`` (1), so that a synchronised joint move is
      one matrix product ``basis @ [q0; q1 - q0]``;
    * ``speed`` (N, 1): ``s'(t)`` (1/s) with the LAST value set to exactly 0 (a
      point-to-point move ends at rest on its target): ``speed @ [q1 - q0]`` gives the speeds.

    (A (N, 2) @ (2, 6) product is several times faster than broadcasting an (N,) column
    against a (6,) row: numpy's broadcast inner loop would run only 6 elements long.)
    Cached for up to :data:`BASIS_CACHE_MAX_SAMPLES` samples.
    """
    if T * rate_hz <= BASIS_CACHE_MAX_SAMPLES:
        return _cached_basis(kind, T, ta, rate_hz)
    return _compute_basis(kind, T, ta, rate_hz)


@lru_cache(maxsize=64)
def _cached_basis(
    kind: str, T: float, ta: float, rate_hz: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    return _compute_basis(kind, T, ta, rate_hz)


def _compute_basis(
    kind: str, T: float, ta: float, rate_hz: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    n = max(1, int(math.ceil(T * rate_hz - 1e-6)))
    t = np.arange(1, n + 1, dtype=float) / rate_hz
    s, sd, _ = ScalarProfile(kind, T, ta)(t)
    basis = np.empty((n, 2))
    basis[:, 0] = 1.0
    basis[:, 1] = s
    speed = np.array(sd, dtype=float).reshape(n, 1)
    speed[-1] = 0.0
    for a in (t, basis, speed):
        a.setflags(write=False)
    return t, basis, speed


def quintic(t: NDArray[np.float64], T: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Quintic 10 tau^3 - 15 tau^4 + 6 tau^5 (tau = t / T): zero speed and acceleration at
    both ends.  ``t`` in s, clipped to [0, T]."""
    tau = np.minimum(np.maximum(np.asarray(t, dtype=float) * (1.0 / T), 0.0), 1.0)
    t2 = tau * tau
    s = t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2)
    sd = (30.0 / T) * t2 * (1.0 - 2.0 * tau + t2)
    sdd = (60.0 / (T * T)) * tau * (1.0 - 3.0 * tau + 2.0 * t2)
    return s, sd, sdd


def trapezoid(
    t: NDArray[np.float64], T: float, ta: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Unit trapezoid over ``T`` s with acceleration time ``ta`` (0 < ta <= T/2), equal
    braking time.  Cruise speed 1 / (T - ta), acceleration 1 / (ta (T - ta))."""
    t = np.clip(np.asarray(t, dtype=float), 0.0, T)
    vc = 1.0 / (T - ta)
    a = vc / ta
    td = T - ta
    acc_phase = t < ta
    dec_phase = t > td
    s = np.where(acc_phase, 0.5 * a * t * t, vc * (t - 0.5 * ta))
    sd = np.where(acc_phase, a * t, vc)
    sdd = np.where(acc_phase, a, 0.0)
    r = T - t
    s = np.where(dec_phase, 1.0 - 0.5 * a * r * r, s)
    sd = np.where(dec_phase, a * r, sd)
    sdd = np.where(dec_phase, -a, sdd)
    return s, sd, sdd


def trapezoid_for_limits(distance: float, v: float, a: float) -> tuple[float, float]:
    """Duration ``T`` and acceleration time ``ta`` (s) of the fastest trapezoid covering
    ``distance`` (> 0) with cruise speed <= ``v`` and acceleration ``a`` (same length unit).

    When the distance is too short to reach ``v`` the profile is a triangle (ta = T / 2).
    """
    if distance <= 0:
        return 0.0, 0.0
    if distance * a <= v * v:
        ta = math.sqrt(distance / a)
        return 2.0 * ta, ta
    ta = v / a
    return distance / v + ta, ta


def ruckig_unit_profile(
    v_max: float, a_max: float, j_max: float, min_duration: float | None = None
) -> ScalarProfile:
    """Jerk-limited 0 -> 1 profile computed by Ruckig (imported here, lazily).

    Limits in 1/s, 1/s^2, 1/s^3 of the unit path; ``min_duration`` (s) stretches it to at
    least that long (Ruckig then lowers the peaks).  The result is tabulated so evaluation is
    vectorised.
    """
    import ruckig  # lazy: only this profile needs it

    otg = ruckig.Ruckig(1)
    inp = ruckig.InputParameter(1)
    inp.current_position = [0.0]
    inp.current_velocity = [0.0]
    inp.current_acceleration = [0.0]
    inp.target_position = [1.0]
    inp.target_velocity = [0.0]
    inp.target_acceleration = [0.0]
    inp.max_velocity = [float(v_max)]
    inp.max_acceleration = [float(a_max)]
    inp.max_jerk = [float(j_max)]
    if min_duration is not None:
        inp.minimum_duration = float(min_duration)
    traj = ruckig.Trajectory(1)
    result = otg.calculate(inp, traj)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise RuntimeError(f"Ruckig could not compute a profile: {result}")
    prof = traj.profiles[0][0]
    starts = np.concatenate([[0.0], np.cumsum(prof.t)])
    return ScalarProfile(
        kind="ruckig", T=float(traj.duration), phase_t=tuple(float(x) for x in starts),
        jerk=tuple(float(x) for x in prof.j), acc=tuple(float(x) for x in prof.a),
        vel=tuple(float(x) for x in prof.v), pos=tuple(float(x) for x in prof.p),
    )


def _eval_piecewise_jerk(
    t: NDArray[np.float64], p: ScalarProfile,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    starts = np.asarray(p.phase_t)
    k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(p.jerk) - 1)
    dt = t - starts[k]
    j = np.asarray(p.jerk)[k]
    a0 = np.asarray(p.acc)[k]
    v0 = np.asarray(p.vel)[k]
    p0 = np.asarray(p.pos)[k]
    s = p0 + v0 * dt + a0 * dt * dt / 2.0 + j * dt**3 / 6.0
    sd = v0 + a0 * dt + j * dt * dt / 2.0
    sdd = a0 + j * dt
    end = t >= p.T
    s = np.where(end, 1.0, s)
    sd = np.where(end, 0.0, sd)
    sdd = np.where(end, 0.0, sdd)
    return s, sd, sdd
