"""Timing a Cartesian path: the time-scaling ``s(t)`` of its progress, stretched until every
joint can follow, and the joints solved at every tick.

A stage of the Cartesian pipeline (:mod:`parolkit.motion.cartesian`, whose docstring states
the timing rules): a unit profile (poly / trap / ruckig) at the move's duration or path speed
-> the tool pose of every tick -> the joints (:mod:`.ik_along_path`) -> speeds and
accelerations checked on every sample; over a limit, the duration stretches.  A duration given
that needs more than a joint's position-tracking maximum but no more than its maximum speed
stretches too, with :func:`parolkit.motion.validate.stretch_warning` (the seed's speed rule: a
move within every joint's maximum speed runs); over a joint's maximum speed it is refused,
naming the shortest duration accepted.  TOPP-RA times the joint path itself (time-optimal
within the joint limits).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion import singular, validate
from parolkit.motion.cartesian.geometry import Path
from parolkit.motion.cartesian.ik_along_path import (
    check_jumps,
    derivative,
    deviation_error,
    near_singularity,
    refuse_singular,
    solve_ik,
    solve_path,
)
from parolkit.motion.cartesian.path_of_move import DEFAULT_CART_SPEED_PCT, path_speed_pct
from parolkit.motion.cartesian.wrist_unwind import planned_end, unwind_wrist
from parolkit.motion.errors import PlanningError
from parolkit.motion.joint import build_trajectory, hold, sample_times
from parolkit.motion.profiles import ScalarProfile, ruckig_unit_profile
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import Profile, Tracking
from parolkit.robot import JOINT_NAMES

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool
    from parolkit.motion.cartesian.path_of_move import CartesianMove
    from parolkit.motion.topp import ToppResult
    from parolkit.robot import RobotModel

__all__ = [
    "time_and_solve", "MAX_STRETCH", "CART_ACCEL_TIME_S", "FINE_CHECK_TICKS", "FINE_CHECK_POINTS",
    "LEAST_DURATION_SEARCH_S",
]

#: A path needing more than this stretch of its duration is refused (singularity).
MAX_STRETCH = 8.0
#: Ruckig on a Cartesian path: reach the path speed within this time (s).
CART_ACCEL_TIME_S = 0.25


def time_and_solve(move: CartesianMove, path: Path, start: NDArray[np.float64], model: RobotModel,
                   tool: str | Tool | None, rate_hz: float, *, approach: bool = False) -> Trajectory:
    """Time ``path`` from the joints ``start`` (rest to rest) and solve its joints: the
    profile at the move's duration or path speed, stretched while a joint cannot follow (see
    the package docstring); ``approach``: a line played before the move's own path (timed at
    the path speed even when the move gives a duration; never TOPP-RA)."""
    name = move.name
    tracking = getattr(move, "tracking", Tracking.POSITION)
    duration = None if approach else move.duration_s
    pct = path_speed_pct(move)
    v_lin = model.cart_linear_speed_from_percent(pct)  # mm/s
    w_ang = model.cart_angular_speed_from_percent(pct)  # deg/s
    mm_per_rad = v_lin / math.radians(w_ang)
    path = Path.weighted(path.segments, mm_per_rad)
    # duration at the mapped speeds: path length / speed, the slower of linear and angular
    base = max(path.length / v_lin, math.degrees(path.angle) / w_ang)
    notes: list[str] = []
    if base < 1e-9:
        return hold(move, start, np.asarray(start, dtype=float), model, rate_hz, tracking)
    profile = move.profile or (Profile.POLY if duration is not None else Profile.TRAP)
    if approach and profile is Profile.TOPPRA:
        profile = Profile.TRAP
    if profile is Profile.TOPPRA:
        # TOPP-RA times the exact joint path: from the wrist singularity J4/J6 turn first
        unwind = unwind_wrist(move, path, start, model, tool, rate_hz, tracking)
        if unwind is not None:
            main = time_and_solve(move, path, planned_end(unwind), model, tool, rate_hz,
                                  approach=approach)
            return Trajectory.concatenate([unwind, main], move)
        return _toppra_path(move, path, start, model, tool, rate_hz, duration, base, tracking)
    if duration is None:
        if move.speed_pct is None and not approach:
            notes.append(f"no duration or speed given: path speed {DEFAULT_CART_SPEED_PCT:g} % "
                         f"({v_lin:g} mm/s, {w_ang:g} deg/s)")
    limits = validate.speed_limits(model, rate_hz, tracking is Tracking.POSITION)
    # each joint's maximum speed itself: a duration given that needs more than ``limits`` but
    # no more than this runs stretched (the seed's speed rule); over it, it is refused
    full = validate.speed_limits(model, rate_hz, False)
    vmax = limits.array

    def timed(prof: ScalarProfile) -> _TimedPath:
        # a duration given: only the speed limits refuse it (the acceleration ones warn)
        return _TimedPath(name, prof, path, start, model, tool, rate_hz, limits,
                          accel_hard=duration is None)

    given = duration
    at_given: _TimedPath | None = None  # the path at the duration given, when that is stretched
    stretch = 1.0
    wrist_bound = False  # a stretch made for the singular area's bounds
    for _attempt in range(4):
        tm = timed(_path_profile(profile, base, duration, stretch))
        if tm.fits:
            break
        factor = tm.factor
        wrist_bound = wrist_bound or tm.r_dev >= max(tm.r_v, math.sqrt(tm.r_a))
        if factor > MAX_STRETCH and near_singularity(tm.q, tm.v_steps, vmax):
            refuse_singular(name, tm.t, tm.q, tm.v_steps, vmax, tool)
        if duration is not None:
            if not (limits.position_tracked and tm.within(full)):
                tm.refuse(_refusal_hint(tm, profile, base, timed, limits, full), full)
            # within every joint's maximum speed: stretched, as little as the tracking allows
            at_given = at_given or tm
            duration = max(validate.round_up_duration(duration * factor), duration + 0.01)
            continue
        stretch *= factor * 1.02
    else:
        # stretching does not help: a kink (a sharp corner, or a singularity grazed)
        tm.refuse("the path has a sharp corner or grazes a singularity here: round the corners "
                  "(blend radius) or change the path")
        raise PlanningError(name, "no feasible timing found within the joint limits after stretching")
    t, q, qd, T = tm.t, tm.q, tm.qd, tm.T
    if stretch > 1.0:
        j = int(np.argmax(np.max(np.abs(tm.v_steps) / vmax, axis=0)))
        why = (f"J4/J6 turning out of the wrist singularity (orientation within "
               f"{singular.MAX_DEVIATION_DEG:g} deg, exact at the end)" if wrist_bound else
               f"joint speed/acceleration limits ({JOINT_NAMES[j]} the busiest)")
        notes.append(f"duration stretched from {_nominal(profile, base):.2f} s to {T:.2f} s: {why}")
    if at_given is not None and given is not None:
        peak = at_given.peak_steps_s
        j = int(np.argmax(peak / vmax))
        notes.append(validate.stretch_warning(limits, j, float(peak[j]), f"to finish in the t={given:g} s given", T))
    if tm.area is not None:
        notes.append(tm.area.note())
    if duration is not None:
        warning = validate.accel_warning(np.max(np.abs(tm.acc), axis=0), model, duration, given)
        if warning is not None:
            notes.append(warning)
    check_jumps(name, t, np.vstack([start[None, :], q]), model, rate_hz, tool)
    # speeds and accelerations were checked sample by sample in the loop above (proven)
    return build_trajectory(move, t, q, qd, start=start, model=model, rate=rate_hz, tracking=tracking,
                            notes=notes, target_deg=q[-1], proven=True)


#: A path lasting at most this many ticks is also checked on a finer grid than the ticks
#: (:class:`_TimedPath`): its samples may not resolve it (a whole circle in one tick is one sample,
#: back at the start).
FINE_CHECK_TICKS = 20
#: Points of that finer grid (at least; 4 per tick for longer ones).
FINE_CHECK_POINTS = 32


class _TimedPath:
    """A path timed by ``prof`` and sampled at the ticks: joint angles, speeds, and how far
    they are over the limits (``r_v``, ``r_a``: 1 = at the limit).

    Speeds are checked three ways: the samples' speeds (central differences), what each tick
    asks the board to cover, from the start on (a move shorter than a tick is one sample of
    speed 0 that hid a jump of up to 2x the maximum speed), and, for short paths, the joints'
    speeds along the path itself on a finer grid than the ticks."""

    def __init__(self, name: str, prof: ScalarProfile, path: Path, start: NDArray[np.float64], model: RobotModel,
                 tool: str | Tool | None, rate_hz: float, limits: validate.SpeedLimits, *,
                 accel_hard: bool = True) -> None:
        self.name, self.model, self.rate_hz, self.limits = name, model, rate_hz, limits
        #: False for a duration given: the acceleration limits then do not count in ``fits``
        self.accel_hard = accel_hard
        T = self.T = prof.T
        t = self.t = sample_times(T, rate_hz)
        s, _, _ = prof(t)
        pos, rots = path.evaluate(s)
        spd = model.steps_per_deg
        vmax = limits.array
        q, self.area = solve_path(name, pos, rots, start, tool, t, model, vmax / spd)
        self.q = q
        qd = self.qd = derivative(q, start, rate_hz, t, T)
        amax = validate.model_arrays(model).amax  # per joint, steps/s^2
        v_steps = self.v_steps = qd * spd
        self.acc: NDArray[np.float64] = np.diff(np.vstack([np.zeros((1, 6)), v_steps]), axis=0) * rate_hz
        v_tick: NDArray[np.float64] = np.diff(np.vstack([start[None, :], q]), axis=0) * (rate_hz * spd)
        self.v_chk: NDArray[np.float64] = np.where(np.abs(v_tick) > np.abs(v_steps), v_tick, v_steps)
        #: per joint, the fastest speed the path asks for (samples, tick steps, finer grid), steps/s
        self.peak_steps_s: NDArray[np.float64] = np.abs(self.v_chk).max(axis=0)
        self.fine: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        #: how far over the singular-area orientation bound (1 = at it)
        self.r_dev = 0.0 if self.area is None else self.area.overload()
        if len(t) <= FINE_CHECK_TICKS:
            n = max(FINE_CHECK_POINTS, 4 * len(t))
            tf = np.linspace(0.0, T, n + 1)[1:]
            sf, _, _ = prof(tf)
            posf, rotsf = path.evaluate(sf)
            qf, area_f = solve_path(name, posf, rotsf, start, tool, tf, model, vmax / spd)
            if area_f is not None:
                self.r_dev = max(self.r_dev, area_f.overload())
            vf: NDArray[np.float64] = np.diff(np.vstack([start[None, :], qf]), axis=0) * (spd * n / T)
            self.fine = (tf, vf)
            self.peak_steps_s = np.maximum(self.peak_steps_s, np.abs(vf).max(axis=0))
        self.r_v = self.overload(limits)
        self.r_a = float(np.max(np.max(np.abs(self.acc), axis=0) / (amax * (1 + validate.ACCEL_TOLERANCE))))

    def overload(self, limits: validate.SpeedLimits) -> float:
        """How far over ``limits`` the path's joint speeds are (1 = at the limit)."""
        return float(np.max(self.peak_steps_s / limits.array))

    def within(self, full: validate.SpeedLimits) -> bool:
        """What :attr:`fits` says with ``full`` (each joint's maximum speed itself) for the speed
        limits: a path with a duration that is within it runs, stretched if it does not fit."""
        return self.overload(full) <= 1.0 and (self.r_a <= 1.0 or not self.accel_hard) and self.r_dev <= 1.0

    @property
    def fits(self) -> bool:
        return self.r_v <= 1.0 and (self.r_a <= 1.0 or not self.accel_hard) and self.r_dev <= 1.0

    @property
    def factor(self) -> float:
        """How much longer the path must take to fit (speeds scale with 1 / time,
        accelerations with 1 / time^2; the singular-area deviation roughly with 1 / time)."""
        return max(self.r_v, math.sqrt(self.r_a) if self.accel_hard else 1.0, self.r_dev, 1.0)

    def refuse(self, hint: str, limits: validate.SpeedLimits | None = None) -> None:
        """Raise the PlanningError of the first limit exceeded (joint, time, value, limit), with
        ``hint``; return when nothing is exceeded.  ``limits``: the speed limits to name
        (default the path's own)."""
        lim = self.limits if limits is None else limits
        validate.check_speeds(self.name, self.t, self.v_chk, self.model, hint=hint, limits=lim)
        if self.fine is not None:
            tf, vf = self.fine
            validate.check_speeds(self.name, tf, vf, self.model, hint=hint, limits=lim)
        if self.accel_hard:
            validate.check_accels(self.name, self.t, self.v_steps, self.model, self.rate_hz, hint=hint)
        if self.r_dev > 1.0 and self.area is not None:
            raise deviation_error(self.name, self.area, hint)


#: The refusal of a duration names the shortest one that fits, searched up to this long (s).
LEAST_DURATION_SEARCH_S = 600.0


def _refusal_hint(tm: _TimedPath, profile: Profile, base: float, timed: Callable[[ScalarProfile], _TimedPath],
                  limits: validate.SpeedLimits, full: validate.SpeedLimits) -> str:
    """What the refusal of ``tm``'s duration says would do: ``"give a duration of at least X
    s"``, the shortest duration accepted (within every joint's maximum speed, ``full``), and,
    for a position-tracked path, ``" (a duration below Y s runs stretched to Y s, within the
    position-tracking maxima)"``; ``"no duration up to 600 s fits"`` when none does."""
    def accepted(trial: _TimedPath) -> bool:
        return trial.within(full) if limits.position_tracked else trial.fits

    least = _least_duration(tm, profile, base, timed, accepted)
    if least is None:
        return f"no duration up to {LEAST_DURATION_SEARCH_S:g} s fits"
    hint = f"give a duration of at least {least:.2f} s"
    if limits.position_tracked:
        tracked = _least_duration(tm, profile, base, timed, lambda trial: trial.fits)
        if tracked is not None and tracked > least + 1e-9:
            hint += (f" (a duration below {tracked:.2f} s runs stretched to {tracked:.2f} s, within the "
                     f"position-tracking maxima)")
    return hint


def _least_duration(tm: _TimedPath, profile: Profile, base: float, timed: Callable[[ScalarProfile], _TimedPath],
                    fits_at: Callable[[_TimedPath], bool]) -> float | None:
    """The shortest duration (s, to 0.01 s) at which the path of ``tm`` fits (``timed``: the
    path at a profile; ``fits_at``: whether it fits); None when none up to
    :data:`LEAST_DURATION_SEARCH_S` does.  Searched, not scaled: a move of less than a tick
    does not scale like a longer one (its one sample hid the path).  Grows the duration (by
    the overload, at most 4x a step) until it fits, then halves the interval down to 0.01 s; a
    dozen plans of the path at most, on refusals only."""

    def fits(T: float) -> tuple[bool, float]:
        try:
            trial = timed(_path_profile(profile, base, T, 1.0))
        except PlanningError:
            return False, 2.0
        return fits_at(trial), trial.factor

    lo = tm.T
    hi = max(math.ceil(max(tm.T, 1.0 / tm.rate_hz) * 100 - 1e-6) / 100, 0.01)
    factor = tm.factor
    ok = hi > lo and fits(hi)[0]
    while not ok:
        lo = hi
        hi = math.ceil(hi * min(max(factor * 1.02, 1.1), 4.0) * 100) / 100
        if hi > LEAST_DURATION_SEARCH_S:
            return None
        ok, factor = fits(hi)
    while hi - lo > 0.0101:
        mid = math.ceil((lo + hi) / 2 * 100 - 1e-6) / 100
        if mid >= hi:
            break
        if fits(mid)[0]:
            hi = mid
        else:
            lo = mid
    return hi


def _nominal(profile: Profile, base: float) -> float:
    return _path_profile(profile, base, None, 1.0).T


def _path_profile(profile: Profile, base: float, duration: float | None, stretch: float) -> ScalarProfile:
    """Unit profile: with ``duration`` exactly that long; otherwise ``base`` (s, path length /
    mapped speed) times ``stretch`` for poly and trap (the mapped speed is the MEAN speed, as
    in the original), and for Ruckig the mapped speed is the speed limit."""
    if duration is not None:
        T = duration
        if profile is Profile.TRAP:
            return ScalarProfile("trap", T, T / 3.0)
        if profile is Profile.RUCKIG:
            # scale-free limits (peak speed <= 2x the mean; the fastest such profile takes
            # ~0.7 T), Ruckig then fits the jerk-limited profile to exactly T
            return ruckig_unit_profile(2.0 / T, 16.0 / T**2, 256.0 / T**3, min_duration=T)
        return ScalarProfile("poly", T)
    if profile is Profile.TRAP:
        T = base * stretch
        return ScalarProfile("trap", T, T / 3.0)
    if profile is Profile.POLY:
        return ScalarProfile("poly", base * stretch)
    v_s = 1.0 / (base * stretch)
    a_s = v_s / (CART_ACCEL_TIME_S * stretch)
    return ruckig_unit_profile(v_s, a_s, a_s / 0.1 / stretch)


def _toppra_path(
    move: CartesianMove, path: Path, start: NDArray[np.float64], model: RobotModel, tool: str | Tool | None,
    rate_hz: float, duration: float | None, base: float, tracking: Tracking,
) -> Trajectory:
    """TOPP-RA on the joint path (dense IK), then the exact geometry at the optimal s(t).

    Without a duration the mapped Cartesian speed (``1 / base`` of the path per second) is a
    path speed limit besides the joint speed and acceleration limits."""
    from parolkit.motion.topp import toppra_parameterize

    name = move.name
    m = int(min(400, max(30, path.length / 2.0, math.degrees(path.angle) / 2.0)))
    s_grid = np.linspace(0.0, 1.0, m)
    pos, rots = path.evaluate(s_grid)
    q_grid = solve_ik(name, pos, rots, start, tool, s_grid)
    spd = model.steps_per_deg
    limits = validate.speed_limits(model, rate_hz, tracking is Tracking.POSITION)
    vmax = limits.array / spd
    amax = validate.model_arrays(model).amax / spd
    # a 7th coordinate = s itself (unconstrained) recovers s(t) from the joint-space result
    aug = np.hstack([q_grid, s_grid[:, None]])
    s_vmax = 1e6 if duration is not None else 1.0 / base

    def in_time(r: ToppResult | None, d: float) -> bool:
        return r is not None and r.duration <= d * (1 + 1e-6)

    def topp(v: NDArray[np.float64], d: float | None) -> ToppResult | None:
        r = toppra_parameterize(s_grid, aug, np.append(v, s_vmax), np.append(amax, 1e9), duration=d)
        if d is not None and not in_time(r, d):
            # a duration given: the acceleration limits give way (a warning), the speed ones hold
            r = toppra_parameterize(s_grid, aug, np.append(v, s_vmax), np.append(amax * 1e3, 1e9), duration=d)
        return r

    given = duration
    res = topp(vmax, duration)
    if res is None:
        raise PlanningError(name, "TOPP-RA finds no feasible timing within the joint limits")
    notes: list[str] = []
    if duration is not None and not in_time(res, duration):
        # over a position-tracking maximum: within every joint's maximum speed the move runs
        # stretched (the seed's speed rule); over a joint's maximum speed it is refused
        stretched = validate.round_up_duration(res.duration)
        at_full = topp(limits.full / spd, duration) if limits.position_tracked else res
        if not limits.position_tracked or not in_time(at_full, duration):
            least = "" if at_full is None else (
                f" within the joints' maximum speeds; give t >= {validate.round_up_duration(at_full.duration):.2f} s"
                + (f" (a t below {stretched:.2f} s runs stretched to {stretched:.2f} s, within the "
                   f"position-tracking maxima)" if limits.position_tracked else ""))
            need = res.duration if at_full is None else at_full.duration
            raise PlanningError(name, f"too fast for t={duration:g} s: TOPP-RA needs at least {need:.3f} s{least}")
        assert at_full is not None
        slow = topp(vmax, stretched)
        if slow is None or not in_time(slow, stretched):  # (the optimum itself, a hair longer)
            slow, stretched = res, res.duration
        peak = np.abs(at_full.evaluate(np.linspace(0.0, duration, 401))[1][:, :6]).max(axis=0) * spd
        j = int(np.argmax(peak / limits.array))
        notes.append(validate.stretch_warning(limits, j, float(peak[j]), f"to finish in the t={duration:g} s given",
                                              stretched))
        res, duration = slow, stretched
    T = res.duration
    t = sample_times(T, rate_hz)
    s = np.clip(res.evaluate(t)[0][:, 6], 0.0, 1.0)
    s = np.maximum.accumulate(s)
    s[t >= T - 1e-9] = 1.0
    pos, rots = path.evaluate(s)
    q = solve_ik(name, pos, rots, start, tool, t)
    qd = derivative(q, start, rate_hz, t, T)
    check_jumps(name, t, np.vstack([start[None, :], q]), model, rate_hz, tool)
    return build_trajectory(move, t, q, qd, start=start, model=model, rate=rate_hz, tracking=tracking,
                            notes=[f"TOPP-RA time-optimal: {res.optimal_duration:.2f} s"
                                   + (f", slowed uniformly to {T:.2f} s" if T > res.optimal_duration * 1.001 else ""),
                                   *notes],
                            target_deg=q[-1], timed_s=duration, given_s=given,
                            hint="the time-optimal timing exceeds a limit after sampling")

