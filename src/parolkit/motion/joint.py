"""Joint-space planning: MoveJoint, MovePose, SpeedJoint and joint jogs, and the building
blocks every planner shares (sample times, building and checking a :class:`Trajectory`, holding
a target).

:func:`parolkit.motion.plan` dispatches here; :mod:`parolkit.motion.cartesian` uses the shared
blocks and :func:`plan_joint_target` (a wrist unwind before a path is a joint move).  This
module imports neither of them, so the three form no import cycle.

Timing rules (the seed's, see docs/motion.md):

* Speed limits: a position-tracked move (board command 156) keeps every joint within
  :meth:`RobotModel.max_tracked_speed_steps_s` (75-76 % of the maximum at 100 Hz: the board's
  GO TO loop starts every tick 1.27x faster than the stream moves, see
  :func:`parolkit.robot.goto_tracking_factor`), a speed-tracked one (123) within the maximum.
  The seed's rule is the maximum: a move within every joint's maximum speed runs, so one that
  needs more than the position-tracking maximum runs STRETCHED (the shortest duration within
  it, rounded up to 0.01 s) with a ``"warning: ..."`` naming the joint, the speed it needed,
  the position-tracking maximum and the stretched duration (:func:`validate.stretch_warning`);
  only a move over a joint's maximum speed is refused.

* ``duration_s`` given: exactly that long (rounded UP to whole ticks; the profile itself lasts
  exactly ``duration_s``), default POLY ("t overrides a and v").  If a joint would exceed its
  maximum speed the move is REFUSED (the message names the joint and gives the shortest
  duration accepted); between the position-tracking maximum and the maximum it runs
  stretched, with the warning above; if it only needs more than a joint's acceleration limit
  (:attr:`RobotModel.accel_limit_steps_s2`, default 3x its maximum speed per second) it runs
  in ``duration_s`` and its notes carry a ``"warning: ..."`` naming the joint, the
  acceleration needed and the limit (the controller puts it into the move's ack and log).
* ``speed_pct`` / ``accel_pct``: trapezoid on the leading joint (the one with the most steps
  to go), all joints synchronised; when another joint could not follow (maximum speed or
  acceleration limit), the leading joint is slowed and a note says so; when the speed asked
  is over a joint's position-tracking maximum, the move runs stretched with the warning.
* neither: MoveJoint v=45 %, a=27 %; MovePose v=50 %, a=30 % (trapezoid).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import TYPE_CHECKING, NoReturn

import numpy as np

from parolkit import _native
from parolkit.errors import ParolkitValueError
from parolkit.motion import validate
from parolkit.motion.errors import PlanningError
from parolkit.motion.profiles import (
    POLY_PEAK_ACCEL,
    POLY_PEAK_SPEED,
    TRAP3_PEAK_ACCEL,
    TRAP3_PEAK_SPEED,
    ScalarProfile,
    ruckig_unit_profile,
    sampled_basis,
    trapezoid_for_limits,
)
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import JointJog, JointMove, Move, PoseMove, Profile, SpeedJointMove, Tracking
from parolkit.robot import JOINT_NAMES, RobotModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool
    from parolkit.motion.topp import ToppResult

__all__ = [
    "MOVEJOINT_DEFAULT_PCT",
    "MOVEPOSE_DEFAULT_PCT",
    "SPEED_ONLY_ACCEL_PCT",
    "RUCKIG_JERK_TIME_S",
    "sample_times",
    "build_trajectory",
    "hold",
    "check_target",
    "plan_joint_move",
    "plan_pose_move",
    "plan_joint_target",
    "plan_speed_joint",
    "plan_joint_jog",
]

#: MoveJoint with only targets: (speed %, accel %) of the original software.
MOVEJOINT_DEFAULT_PCT = (45.0, 27.0)
#: MovePose with only a pose: (speed %, accel %).
MOVEPOSE_DEFAULT_PCT = (50.0, 30.0)
#: Acceleration % used when only a speed % is given (the original UDP MOVEJOINT rule).
SPEED_ONLY_ACCEL_PCT = 50.0
#: Ruckig jerk limit = acceleration limit / this time (s): full acceleration within 0.1 s.
RUCKIG_JERK_TIME_S = 0.1


def sample_times(duration: float, rate_hz: float) -> NDArray[np.float64]:
    """Tick times 1/rate, 2/rate, ... up to the first tick at or after ``duration`` (s)."""
    n = max(1, int(math.ceil(duration * rate_hz - 1e-6)))
    return np.arange(1, n + 1, dtype=float) / rate_hz


# ---------------------------------------------------------------------------------------------
# building and checking the arrays
# ---------------------------------------------------------------------------------------------


def build_trajectory(
    move: Move, t: NDArray[np.float64], q_deg: NDArray[np.float64], qd_deg_s: NDArray[np.float64], *,
    start: NDArray[np.float64], model: RobotModel, rate: float, tracking: Tracking,
    notes: Sequence[str] = (), target_deg: NDArray[np.float64] | None = None, jog: bool = False,
    check_accel: bool = True, hint: str = "", proven: bool = False, timed_s: float | None = None,
    given_s: float | None = None,
) -> Trajectory:
    """Round to steps, validate (positions, speeds, accelerations) and wrap in a Trajectory.

    ``target_deg``: the last sample is set exactly to it (POSITION tracking ends on target).
    SPEED tracking gets a trailing zero-speed sample when the last speed is not zero.
    ``proven``: the caller has bounded the peak speed and acceleration analytically (a
    synchronised poly / trap profile checked against every joint's maxima); the sampled
    values cannot exceed those peaks, so only the positions are checked sample by sample.
    Speeds are checked against :func:`validate.speed_limits` for ``tracking`` (position-
    tracked: the position-tracking maximum), or the maximum jog speed (``jog``).
    ``timed_s``: the move has this duration (s), given by the user: accelerations over a
    joint's limit do not refuse it, they add :func:`validate.accel_warning` to the notes;
    ``given_s``: the duration the user gave when ``timed_s`` is that duration stretched.
    """
    name = getattr(move, "name", type(move).__name__)
    spd = validate.model_arrays(model).steps_per_deg
    steps_f = q_deg * spd
    pos = np.rint(steps_f).astype(np.int64)
    if target_deg is not None:
        pos[-1] = np.rint(np.asarray(target_deg) * spd).astype(np.int64)
    sp_f = qd_deg_s * spd
    validate.check_positions(name, t, pos, model)
    if not proven:
        limits = None if jog else validate.speed_limits(model, rate, tracking is Tracking.POSITION)
        validate.check_speeds(name, t, sp_f, model, jog=jog, hint=hint, limits=limits)
        if timed_s is not None:
            warning = validate.accel_warning(validate.peak_accels(sp_f, rate), model, timed_s, given_s)
            if warning is not None:
                notes = (*notes, warning)
        elif check_accel:
            validate.check_accels(name, t, sp_f, model, rate, hint=hint)
    sp = np.rint(sp_f).astype(np.int64)
    planned = q_deg
    if target_deg is not None:
        planned[-1] = target_deg
    if tracking is Tracking.SPEED and np.any(sp[-1] != 0):
        t = np.append(t, t[-1] + 1.0 / rate)
        pos = np.vstack([pos, pos[-1:]])
        sp = np.vstack([sp, np.zeros((1, 6), dtype=np.int64)])
        planned = np.vstack([planned, planned[-1:]])
    commands = np.full(len(t), tracking.board_command, dtype=np.uint8)
    return Trajectory(t=t, positions=pos, speeds=sp, commands=commands, rate_hz=rate, move=move,
                      notes=tuple(notes), start_deg=start, model=model, planned_deg=planned)


def hold(move: Move, start: NDArray[np.float64], target: NDArray[np.float64], model: RobotModel, rate: float,
         tracking: Tracking) -> Trajectory:
    """A move that is already at its target: one sample, or, when it has a duration, the
    target held for that long (a program's timing stays what the user wrote)."""
    duration = getattr(move, "duration_s", None)
    t = sample_times(duration, rate) if duration else np.array([1.0 / rate])
    q = np.repeat(np.asarray(target, dtype=float)[None, :], len(t), axis=0)
    note = "already at target" + (f": holding it for {duration:g} s" if duration else "")
    return build_trajectory(move, t, q, np.zeros_like(q), start=start, model=model, rate=rate,
                            tracking=tracking, notes=[note], target_deg=target, proven=True)


def check_target(
    name: str, target: NDArray[np.float64], model: RobotModel, what: str = "target", point: int | None = None,
) -> None:
    """Refuse a ``target`` (deg) outside the joint range, naming ``what`` it is (``point``: the
    index of the path point it is, carried by the :class:`PlanningError`)."""
    ma = validate.model_arrays(model)
    if (target >= ma.safe_lo).all() and (target <= ma.safe_hi).all():
        return
    lim = ma.safe_deg
    bad = np.nonzero((target < lim[:, 0]) | (target > lim[:, 1]))[0]
    if len(bad):
        j = int(bad[0])
        raise PlanningError(
            name,
            f"{what} {JOINT_NAMES[j]} = {target[j]:.3f} deg is outside the joint range "
            f"{lim[j, 0]:.3f} .. {lim[j, 1]:.3f} deg",
            joint=j, value=float(target[j]), point=point,
        )


# ---------------------------------------------------------------------------------------------
# joint-space point-to-point (MoveJoint, MovePose)
# ---------------------------------------------------------------------------------------------


def plan_joint_move(move: JointMove, start: NDArray[np.float64], model: RobotModel, rate: float) -> Trajectory:
    """MoveJoint from ``start`` (deg): the fast analytic path when it applies, else the general one."""
    fast = _fast_timed(move, start, move.target_deg, model, rate)
    if fast is not None:
        return fast
    return plan_joint_target(move, start, np.asarray(move.target_deg), model, rate,
                             MOVEJOINT_DEFAULT_PCT)


def plan_pose_move(
    move: PoseMove, start: NDArray[np.float64], model: RobotModel, tool: str | Tool | None, rate: float,
) -> Trajectory:
    from parolkit import kinematics

    try:
        target = np.asarray(kinematics.ik(move.pose, seed_deg=start, tool=tool), dtype=float)
    except kinematics.IKError as exc:  # an unreachable pose
        raise PlanningError(
            move.name, f"pose {_fmt_pose(move.pose)} is not reachable: {exc.reason}",
            joint=exc.joint, value=exc.value,
        ) from exc
    fast = _fast_timed(move, start, target.tolist(), model, rate)
    if fast is not None:
        return fast
    return plan_joint_target(move, start, target, model, rate, MOVEPOSE_DEFAULT_PCT)


def _fmt_pose(pose: Sequence[float]) -> str:
    return "[" + ", ".join(f"{v:g}" for v in pose) + "]"


_DURATION_NOTE = "duration given: it overrides speed and acceleration percentages"


def _fast_timed(
    move: JointMove | PoseMove, start: NDArray[np.float64], target: Sequence[float], model: RobotModel,
    rate: float,
) -> Trajectory | None:
    """The common case of :func:`plan_joint_target` (a duration with the POLY or TRAP
    profile, target inside the range, moving, fast enough) with the per-joint checks done on
    plain Python floats (6 values: cheaper than numpy calls).  Returns None whenever anything
    else applies (a refusal, a hold, another profile, a move over a joint's position-tracking
    maximum): the general path then plans it (stretched, or refused over the maximum speed),
    with its messages.  Same arithmetic, so the same decisions, as the general path."""
    T = move.duration_s
    if T is None:
        return None
    profile = move.profile
    if profile is None or profile is Profile.POLY:
        kind, kv, ka = "poly", POLY_PEAK_SPEED, POLY_PEAK_ACCEL
    elif profile is Profile.TRAP:
        kind, kv, ka = "trap", TRAP3_PEAK_SPEED, TRAP3_PEAK_ACCEL
    else:
        return None
    ma = validate.model_arrays(model)
    vlim = validate.speed_limits(model, rate, move.tracking is Tracking.POSITION)
    dist_max = 0.0
    tv = 0.0
    ra = 0.0  # the largest distance / acceleration limit (s^2 per unit profile acceleration)
    start_l = start.tolist()
    for q0, q1, k, v, a, lo, hi, tlo, thi in zip(start_l, target, ma.spd_list, vlim.list, ma.amax_list,
                                                 ma.round_lo_list, ma.round_hi_list,
                                                 ma.safe_lo_list, ma.safe_hi_list):
        if not tlo <= q1 <= thi:
            return None  # target outside the range: refused by the general path
        if not lo <= q0 * k <= hi:
            return None  # start outside the limits: the samples are checked one by one
        d = abs((q1 - q0) * k)  # steps
        if d > dist_max:
            dist_max = d
        tj = kv * d / v
        if tj > tv:
            tv = tj
        if d / a > ra:
            ra = d / a
    if dist_max < 0.5:
        return None  # already there: hold
    T = float(T)
    if T < tv * (1.0 - 1e-9):
        return None  # stretched (or refused) by the general path, naming the limiting joint
    notes: tuple[str, ...] = (
        (_DURATION_NOTE,) if move.speed_pct is not None or move.accel_pct is not None else ())
    if ka * ra > T * T * (1.0 + validate.ACCEL_TOLERANCE):  # over an acceleration limit: a warning
        warning = _timed_accel_warning(kind, T, start_l, list(target), ma, model)
        if warning is not None:
            notes = (*notes, warning)
    return _monotonic_trajectory(move, kind, T, T / 3.0 if kind == "trap" else 0.0, start,
                                 start_l, list(target), model, ma, rate, move.tracking, notes,
                                 start_inside=True)


def plan_joint_target(
    move: JointMove | PoseMove, start: NDArray[np.float64], target: NDArray[np.float64], model: RobotModel,
    rate: float, default_pct: tuple[float, float],
) -> Trajectory:
    name = move.name
    check_target(name, target, model)
    ma = validate.model_arrays(model)
    spd = ma.steps_per_deg
    delta = target - start  # deg
    dist = np.abs(delta * spd)  # steps
    limits = validate.speed_limits(model, rate, move.tracking is Tracking.POSITION)
    amax = ma.amax
    notes: list[str] = []
    tracking = move.tracking
    if dist.max() < 0.5:  # already there (less than half a step on every joint)
        return hold(move, start, target, model, rate, tracking)
    given = None if move.duration_s is None else float(move.duration_s)
    if given is not None:
        if move.speed_pct is not None or move.accel_pct is not None:
            notes.append(_DURATION_NOTE)
        prof, T = _timed_profile(name, move.profile or Profile.POLY, given, dist, limits, amax, start,
                                 delta, spd, notes)
    else:
        v_pct = move.speed_pct if move.speed_pct is not None else default_pct[0]
        if move.accel_pct is not None:
            a_pct = move.accel_pct
        else:
            a_pct = SPEED_ONLY_ACCEL_PCT if move.speed_pct is not None else default_pct[1]
        prof, T = _percent_profile(name, move.profile or Profile.TRAP, v_pct, a_pct, dist, limits,
                                   amax, start, delta, spd, model, notes)
    if isinstance(prof, ScalarProfile) and prof.kind in ("poly", "trap"):
        if given is not None:
            warning = _timed_accel_warning(prof.kind, T, start.tolist(), target.tolist(), ma, model, given)
            if warning is not None:
                notes.append(warning)
        return _monotonic_trajectory(move, prof.kind, prof.T, prof.ta, start, start.tolist(),
                                     target.tolist(), model, ma, rate, tracking, notes)
    t = sample_times(T, rate)
    proven = False
    if isinstance(prof, ScalarProfile):  # Ruckig: not monotonic in general, checked in full
        s, sd, _ = prof(t)
        q = start + s[:, None] * delta
        qd = sd[:, None] * delta
    else:  # TOPP-RA result on the straight joint path
        q, qd, _ = prof.evaluate(t)
        q = np.array(q, dtype=float)
        qd = np.array(qd, dtype=float)
    qd[-1] = 0.0
    return build_trajectory(move, t, q, qd, start=start, model=model, rate=rate, tracking=tracking,
                            notes=notes, target_deg=target, proven=proven,
                            timed_s=None if given is None else T, given_s=given)


def _monotonic_trajectory(
    move: JointMove | PoseMove, kind: str, T: float, ta: float, start: NDArray[np.float64], start_l: list[float],
    target: list[float], model: RobotModel, ma: validate.ModelArrays, rate: float, tracking: Tracking,
    notes: Sequence[str], *, start_inside: bool = False,
) -> Trajectory:
    """The Trajectory of a synchronised poly / trap move (``kind``, duration ``T`` s,
    trapezoid acceleration time ``ta`` s), validated analytically.

    ``q(t) = start + s(t) * delta`` with ``s`` monotonic from 0 to 1 (the sampled basis is
    cached per profile and rate), so:

    * positions: every sample lies between the start and the target (up to a few ulps).  The
      target was checked against the safe limits (whose float steps are within 0.499 steps of
      the step limits) and if the start's float steps are within 0.4995 steps of them too,
      every rounded sample is inside the step limits (``start_inside``: the caller has
      checked that already).  Otherwise the samples are checked one by one (same error as
      before: the first offending sample).
    * speeds and accelerations: the caller chose the duration from the closed-form peaks
      (quintic 1.875 |d| / T and 5.7735 |d| / T^2; trapezoid 1 / (T - ta) and
      1 / (ta (T - ta))) against every joint's maxima (a user's duration: against the speed
      limits, with a warning note for the acceleration ones).  Sampled speeds cannot exceed
      the continuous peak (the limits are whole steps/s, so rounding cannot cross them
      either) and finite differences over one tick cannot exceed the peak |s''| (mean-value
      theorem), including the first tick from rest and the final stop (speed 0 at or after
      ``T``).

    ``tests/unit/test_motion_joint.py`` checks this against a sample-by-sample scan.
    """
    t, basis, speed = sampled_basis(kind, T, ta, rate)
    n = len(t)
    q, pos, sp = _fill(basis, speed, start_l, target, ma.spd_list, n)
    if not start_inside and not validate.inside([a * k for a, k in zip(start_l, ma.spd_list)],
                                                ma.round_lo_list, ma.round_hi_list):
        validate.check_positions(move.name, t, pos, model)
    return Trajectory._trusted(t, pos, sp, _commands(n, tracking.board_command), rate, move, tuple(notes),
                               start, model, q)


def _fill_reference(
    basis: NDArray[np.float64], speed: NDArray[np.float64], start: list[float], target: list[float],
    spd: list[float], n: int,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """The arrays of ``q = start + s * (target - start)`` (deg; the last row exactly the
    target), its positions in steps and its speeds in steps/s (``s' * delta``), from the
    sampled profile ``basis`` (columns 1, s) and ``speed`` (s').  The reference of the
    compiled ``_csamples.fill`` (used when that is not built)."""
    # element by element, a product then a sum, as the compiled fill does: a matrix product
    # (BLAS) may fuse them into one rounding, and a sample on a half step then rounds the
    # other way (hypothesis found J6 one step apart)
    s = basis[:, 1:2]
    st = np.array(start, dtype=np.float64)
    delta = np.array(target, dtype=np.float64) - st
    sd = delta * np.array(spd, dtype=np.float64)
    q = st + s * delta  # start + s * delta (deg)
    q[-1] = target
    steps_f = st * np.array(spd, dtype=np.float64) + s * sd  # the same in steps
    steps_f[-1] = np.multiply(target, spd)
    np.rint(steps_f, out=steps_f)
    pos = steps_f.astype(np.int64)
    sp_f = np.reshape(speed, (-1, 1)) * sd  # s' * delta (steps/s); the basis ends at speed 0
    np.rint(sp_f, out=sp_f)
    return q, pos, sp_f.astype(np.int64)


def _fill_native(
    basis: NDArray[np.float64], speed: NDArray[np.float64], start: list[float], target: list[float],
    spd: list[float], n: int,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """:func:`_fill_reference` in one pass of compiled code (``_fill`` only when it is built)."""
    if _csamples is None:
        raise ImportError("parolkit.motion._csamples (the compiled sample fill) is not built")
    out: tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]] = _csamples.fill(
        basis, speed, start, target, spd)
    return out


_csamples = _native.load("parolkit.motion._csamples")
_fill = _fill_reference if _csamples is None else _fill_native


def _commands(n: int, value: int) -> NDArray[np.uint8]:
    """(n,) read-only uint8 array of the board command ``value`` (shared between plans of up
    to 4096 samples: bounded cache memory)."""
    if n <= 4096:
        return _cached_commands(n, value)
    out = np.full(n, value, dtype=np.uint8)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def _cached_commands(n: int, value: int) -> NDArray[np.uint8]:
    out = np.full(n, value, dtype=np.uint8)
    out.setflags(write=False)
    return out


def _min_duration(kind: str, dist: NDArray[np.float64], vmax: NDArray[np.float64]) -> tuple[float, int]:
    """Shortest duration (s) for a synchronised poly/trap(1/3) move within the speed limits
    ``vmax`` (steps/s), and the limiting joint.  (Acceleration does not limit a move with a
    duration: see :func:`_timed_accel_warning`.)"""
    kv = POLY_PEAK_SPEED if kind == "poly" else TRAP3_PEAK_SPEED
    tv = kv * dist / vmax
    return float(tv.max()), int(tv.argmax())


def _timed_accel_warning(
    kind: str, T: float, start: Sequence[float], target: Sequence[float], ma: validate.ModelArrays,
    model: RobotModel, given_s: float | None = None,
) -> str | None:
    """The warning of a synchronised poly/trap(1/3) move over ``T`` s whose peak acceleration
    (quintic 5.7735 |d| / T^2, trapezoid 4.5 |d| / T^2) exceeds a joint's limit; None if none.
    ``given_s``: the t given, when ``T`` is that t stretched."""
    ka = POLY_PEAK_ACCEL if kind == "poly" else TRAP3_PEAK_ACCEL
    peaks = [ka * abs((b - a) * k) / (T * T) for a, b, k in zip(start, target, ma.spd_list)]
    return validate.accel_warning(peaks, model, T, given_s)


def _binding_joint(vmax: NDArray[np.float64], dist: NDArray[np.float64]) -> int:
    """The joint whose speed limit ``vmax`` (steps/s) bounds a synchronised move over ``dist``
    (steps per joint): every joint's speed is the same fraction of its distance, so the one
    with the largest distance / limit."""
    return int(np.argmax(np.where(dist > 0, dist / vmax, -1.0)))


def _least_duration(fits: Callable[[float], bool], lo: float, hi: float) -> float:
    """The shortest duration (s, to 5 ms; the one returned fits) of a profile that does not
    fit in ``lo`` s; ``hi``: a first guess (doubled until it fits, up to an hour)."""
    hi = max(hi, lo * 1.01)
    while not fits(hi) and hi < 3600.0:
        lo, hi = hi, hi * 2.0
    while hi - lo > 0.005:
        mid = 0.5 * (lo + hi)
        if fits(mid):
            hi = mid
        else:
            lo = mid
    return hi


def _timed_profile(
    name: str, profile: Profile, T: float, dist: NDArray[np.float64], limits: validate.SpeedLimits,
    amax: NDArray[np.float64], start: NDArray[np.float64], delta: NDArray[np.float64], spd: NDArray[np.float64],
    notes: list[str],
) -> tuple[ScalarProfile | ToppResult, float]:
    """Profile lasting exactly ``T`` s, and its duration.

    When a joint would exceed its position-tracking maximum (``limits.array``) in ``T`` s but
    not its maximum speed (``limits.full``), the profile lasts instead the shortest duration
    within the position-tracking maximum, rounded up to 0.01 s, and ``notes`` gets
    :func:`validate.stretch_warning` (the seed's rule: a move within every joint's maximum
    speed runs).  Over a joint's maximum speed it is refused, naming the shortest duration
    accepted.  The acceleration limits ``amax`` (steps/s^2) shape the Ruckig and TOPP-RA
    profiles where the time allows; a move that needs more still lasts ``T`` (the caller adds
    the warning)."""
    vmax = limits.array
    full = limits.full
    asked = f"to finish in the t={T:g} s given"
    if profile in (Profile.POLY, Profile.TRAP):
        kind = "poly" if profile is Profile.POLY else "trap"

        def scalar(d: float) -> ScalarProfile:
            return ScalarProfile("poly", d) if kind == "poly" else ScalarProfile("trap", d, d / 3.0)

        tmin, j = _min_duration(kind, dist, vmax)
        if T >= tmin * (1.0 - 1e-9):
            return scalar(T), T
        stretched = max(validate.round_up_duration(tmin), tmin)
        tfull, jf = _min_duration(kind, dist, full)
        if T < tfull * (1.0 - 1e-9):
            _refuse_too_fast(name, kind, T, tfull, jf, dist, limits, stretched, j)
        k = POLY_PEAK_SPEED if kind == "poly" else TRAP3_PEAK_SPEED
        notes.append(validate.stretch_warning(limits, j, k * dist[j] / T, asked, stretched))
        return scalar(stretched), stretched
    if profile is Profile.RUCKIG:
        with np.errstate(divide="ignore"):
            a_s = float(np.min(amax / dist))
        j_s = a_s / RUCKIG_JERK_TIME_S

        def v_path(v: NDArray[np.float64]) -> float:
            with np.errstate(divide="ignore"):
                return float(np.min(v / dist))

        def soft(d: float, v_s: float) -> ScalarProfile:
            # the acceleration and jerk limits give way to the duration (scale-free, as a
            # Cartesian path's): only the speed limit holds
            return ruckig_unit_profile(v_s, max(a_s, 16.0 / d**2), max(j_s, 256.0 / d**3), min_duration=d)

        def in_time(prof: ScalarProfile, d: float) -> bool:
            return prof.T <= d * (1.0 + 1e-6)

        def timed(d: float, v_s: float) -> ScalarProfile:
            prof = ruckig_unit_profile(v_s, a_s, j_s, min_duration=d)
            return prof if in_time(prof, d) else soft(d, v_s)

        v_s = v_path(vmax)
        prof = timed(T, v_s)
        if in_time(prof, T):
            return prof, T
        j = _binding_joint(vmax, dist)
        stretched = validate.round_up_duration(_least_duration(lambda d: in_time(soft(d, v_s), d), T, prof.T))
        for _ in range(100):  # (the search's duration fits: at most a few rounding steps)
            prof = timed(stretched, v_s)
            if in_time(prof, stretched):
                break
            stretched += 0.01
        else:
            raise PlanningError(name, f"too fast for t={T:g} s: no jerk-limited timing found within the "
                                      f"{limits.describe(j)} up to {stretched:.2f} s")
        v_full = v_path(full)
        at_full = soft(T, v_full) if limits.position_tracked else prof
        if limits.position_tracked and in_time(at_full, T):
            notes.append(validate.stretch_warning(limits, j, at_full.peak_speed * dist[j], asked, stretched))
            return prof, stretched
        jf = _binding_joint(full, dist)
        least = _least_duration(lambda d: in_time(soft(d, v_full), d), T, at_full.T)
        raise PlanningError(
            name,
            f"too fast for t={T:g} s: the jerk-limited profile would need {JOINT_NAMES[jf]} above its "
            f"{limits.describe_full(jf)}; {limits.stretch_hint(validate.round_up_duration(least), stretched, j)}",
            joint=jf,
        )
    # TOPP-RA on the straight joint-space line
    from parolkit.motion.topp import toppra_parameterize

    path = np.vstack([start, start + delta])
    ends = np.array([0.0, 1.0])

    def topp(v: NDArray[np.float64], d: float, soft: bool = False) -> ToppResult | None:
        # soft: the acceleration limits give way to the duration; only the speed limits hold
        return toppra_parameterize(ends, path, v / spd, (amax * 1e3 if soft else amax) / spd, duration=d)

    def in_time_r(res: ToppResult | None, d: float) -> bool:
        return res is not None and res.duration <= d * (1.0 + 1e-6)

    def timed_r(v: NDArray[np.float64], d: float) -> ToppResult | None:
        res = topp(v, d)
        return res if in_time_r(res, d) else topp(v, d, soft=True)

    res = timed_r(vmax, T)
    if res is None:
        raise PlanningError(name, f"too fast for t={T:g} s: TOPP-RA finds no feasible timing")
    if in_time_r(res, T):
        return res, T
    j = _binding_joint(vmax, dist)
    stretched = validate.round_up_duration(res.duration)
    res_full = topp(full, T, soft=True) if limits.position_tracked else res
    if res_full is None:
        raise PlanningError(name, f"too fast for t={T:g} s: TOPP-RA finds no feasible timing")
    if limits.position_tracked and in_time_r(res_full, T):
        slow = timed_r(vmax, stretched)
        if slow is None or not in_time_r(slow, stretched):  # (the optimum itself, a hair longer)
            slow, stretched = res, res.duration
        needed = float(np.max(np.abs(res_full.evaluate(np.linspace(0.0, T, 201))[1][:, j]))) * spd[j]
        notes.append(validate.stretch_warning(limits, j, needed, asked, stretched))
        return slow, stretched
    jf = _binding_joint(full, dist)
    raise PlanningError(
        name,
        f"too fast for t={T:g} s: TOPP-RA finds at least {res_full.duration:.3f} s within the joints' "
        f"maximum speeds ({JOINT_NAMES[jf]}: {limits.describe_full(jf)}); "
        f"{limits.stretch_hint(validate.round_up_duration(res_full.duration), stretched, j)}",
        joint=jf,
    )


def _refuse_too_fast(
    name: str, kind: str, T: float, tmin: float, j: int, dist: NDArray[np.float64],
    limits: validate.SpeedLimits, stretched: float, j_stretched: int,
) -> NoReturn:
    """Refuse a poly/trap move over ``T`` s on which joint ``j`` would exceed its maximum speed
    (the shortest duration within it: ``tmin`` s); ``stretched``: the duration a move just
    above ``tmin`` runs stretched to (within ``j_stretched``'s position-tracking maximum)."""
    k = POLY_PEAK_SPEED if kind == "poly" else TRAP3_PEAK_SPEED
    value = k * dist[j] / T
    t_at = T / 2.0 if kind == "poly" else T / 3.0
    raise PlanningError(
        name,
        f"too fast for t={T:g} s with the {kind} profile: {JOINT_NAMES[j]} would need a speed of "
        f"{value:.0f} steps/s, above its {limits.describe_full(j)}; "
        f"{limits.stretch_hint(validate.round_up_duration(tmin), stretched, j_stretched)}",
        time_s=t_at, joint=j, value=value,
    )


def _percent_profile(
    name: str, profile: Profile, v_pct: float, a_pct: float, dist: NDArray[np.float64], limits: validate.SpeedLimits,
    amax: NDArray[np.float64], start: NDArray[np.float64], delta: NDArray[np.float64], spd: NDArray[np.float64],
    model: RobotModel, notes: list[str],
) -> tuple[ScalarProfile | ToppResult, float]:
    """Leading-joint v/a profile with every joint synchronised (finishing together).

    The percentages map onto min..max joint speed and onto ``accel_range_steps_s2`` as in the
    original.  When another joint could not follow within its maximum speed, the leading joint
    is slowed and a note says so (the seed: "the algorithm selects appropriate values").  A
    position-tracked move cannot go beyond the position-tracking maximum (``limits.array``):
    when the speed asked needs more, the move runs stretched within it and
    :func:`validate.stretch_warning` says which joint, the speed, that maximum and both
    durations.  Every joint keeps within its acceleration limit ``amax`` (steps/s^2): when the
    mapped acceleration is more, the leading joint's is lowered and a note says so."""
    vmax = limits.array
    full = limits.full
    lead = int(np.argmax(dist))
    v_lead = float(model.speed_from_percent(v_pct)[lead])
    a_lead = float(model.accel_from_percent(a_pct))
    asked = f"at v={v_pct:g} %"
    if profile is Profile.TOPPRA:
        # time-optimal: every joint within its own mapped speed and the mapped acceleration
        from parolkit.motion.topp import toppra_parameterize

        ends, path = np.array([0.0, 1.0]), np.vstack([start, start + delta])
        mapped = np.minimum(model.speed_from_percent(v_pct), full)
        a_joint = np.minimum(a_lead, amax) / spd
        res = toppra_parameterize(ends, path, np.minimum(mapped, vmax) / spd, a_joint)
        if res is None:
            raise PlanningError(name, "TOPP-RA finds no feasible timing within the joint limits")
        if np.any((mapped > vmax) & (dist > 0.0)):
            asked_res = toppra_parameterize(ends, path, mapped / spd, a_joint)
            if asked_res is not None and res.duration > asked_res.duration * (1.0 + 1e-6):
                t = np.linspace(0.0, asked_res.duration, 201)
                peaks = np.abs(asked_res.evaluate(t)[1]).max(axis=0) * spd
                j = int(np.argmax(peaks / vmax))
                notes.append(validate.stretch_warning(limits, j, float(peaks[j]), asked, res.duration,
                                                      from_s=asked_res.duration))
        return res, res.duration
    d = dist[lead]
    moving = dist > 0.0
    # unit-path limits: the leading joint's mapped values, capped so every joint stays inside
    v_s = v_lead / d
    a_s = a_lead / d
    with np.errstate(divide="ignore", over="ignore"):  # a sub-normal distance caps at inf, as intended
        v_caps_full = np.where(moving, full / np.where(moving, dist, 1.0), np.inf)
        v_caps = np.where(moving, vmax / np.where(moving, dist, 1.0), np.inf)
        a_caps = np.where(moving, amax / np.where(moving, dist, 1.0), np.inf)
    jv = int(np.argmin(v_caps_full))
    if v_caps_full[jv] < v_s * (1.0 - 1e-12):
        notes.append(
            f"leading joint {JOINT_NAMES[lead]} slowed from {v_lead:.0f} to {v_caps_full[jv] * d:.0f} steps/s: "
            f"{JOINT_NAMES[jv]} speed limit {full[jv]:.0f} steps/s (all joints finish together)"
        )
        v_s = float(v_caps_full[jv])
    ja = int(np.argmin(a_caps))
    if a_caps[ja] < a_s * (1.0 - 1e-12):
        notes.append(
            f"leading joint {JOINT_NAMES[lead]} acceleration lowered from {a_lead:.0f} to "
            f"{a_caps[ja] * d:.0f} steps/s^2: {JOINT_NAMES[ja]} acceleration limit {amax[ja]:.0f} steps/s^2"
        )
        a_s = float(a_caps[ja])
    jt = int(np.argmin(v_caps))
    if v_caps[jt] < v_s * (1.0 - 1e-12):  # over a position-tracking maximum: runs stretched
        wanted = _unit_profile(profile, v_s, a_s)
        v_s = float(v_caps[jt])
        prof = _unit_profile(profile, v_s, a_s)
        if prof.T > wanted.T * (1.0 + 1e-9):  # (a triangle that never reaches the cap is not)
            notes.append(validate.stretch_warning(limits, jt, wanted.peak_speed * dist[jt], asked, prof.T,
                                                  from_s=wanted.T))
    else:
        prof = _unit_profile(profile, v_s, a_s)
    if prof.kind == "trap" and abs(prof.ta - prof.T / 2.0) < 1e-12 and 1.0 / prof.ta < 0.95 * v_s:
        notes.append(
            f"triangular profile: {JOINT_NAMES[lead]} peaks at {d / prof.ta:.0f} steps/s before "
            f"reaching {v_s * d:.0f} steps/s"
        )
    return prof, prof.T


def _unit_profile(profile: Profile, v_s: float, a_s: float) -> ScalarProfile:
    """The unit profile (trap, poly or ruckig) within the path speed ``v_s`` (1/s) and
    acceleration ``a_s`` (1/s^2)."""
    if profile is Profile.TRAP:
        T, ta = trapezoid_for_limits(1.0, v_s, a_s)
        return ScalarProfile("trap", T, ta)
    if profile is Profile.POLY:
        return ScalarProfile("poly", max(POLY_PEAK_SPEED / v_s, math.sqrt(POLY_PEAK_ACCEL / a_s)))
    return ruckig_unit_profile(v_s, a_s, a_s / RUCKIG_JERK_TIME_S)


# ---------------------------------------------------------------------------------------------
# constant-speed streams (SpeedJoint, joint jogs): board command 123
# ---------------------------------------------------------------------------------------------


def _constant_speed(
    move: SpeedJointMove | JointJog, start: NDArray[np.float64], v_deg_s: NDArray[np.float64], T: float,
    model: RobotModel, rate: float, *, jog: bool, notes: Sequence[str] = (),
) -> Trajectory:
    """Constant joint speeds for ``T`` s (the last tick scaled so the integral is exact), then
    a zero-speed sample.  Positions are where the joints are expected at each tick.

    A jog (``jog=True``) that would leave a joint's range stops exactly at the limit and says
    so in the notes (``"stopped at the upper limit of J2 ..."``); a SpeedJoint is refused.
    """
    name = getattr(move, "name", type(move).__name__)
    spd = model.steps_per_deg
    sp_f = v_deg_s * spd
    mx = np.asarray(model.max_jog_speed_steps_s if jog else model.max_speed_steps_s, dtype=float)
    over = np.nonzero(np.abs(sp_f) > mx * (1 + 1e-9))[0]
    if len(over):
        j = int(over[0])
        kind = "maximum jog speed" if jog else "maximum speed"
        raise PlanningError(
            name, f"{JOINT_NAMES[j]} speed {abs(sp_f[j]):.0f} steps/s ({abs(v_deg_s[j]):.3f} deg/s) "
            f"exceeds the {kind} {mx[j]:.0f} steps/s ({mx[j] / spd[j]:.3f} deg/s)",
            time_s=1.0 / rate, joint=j, value=float(v_deg_s[j]),
        )
    # where would the joints leave their range?  Jogs stop there (with a note), other moves
    # are refused with the longest allowed duration.
    lim = model.safe_limits_deg
    end = start + v_deg_s * T
    bad = np.nonzero((end < lim[:, 0]) | (end > lim[:, 1]))[0]
    notes = list(notes)
    if len(bad):
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = np.where(v_deg_s > 0, lim[:, 1], lim[:, 0])
            t_hit = np.where(v_deg_s != 0, (bound - start) / v_deg_s, np.inf)
        j = int(bad[np.argmin(t_hit[bad])])
        th = max(0.0, float(t_hit[j]))
        side = "upper" if v_deg_s[j] > 0 else "lower"
        if jog:
            notes.append(f"stopped at the {side} limit of {JOINT_NAMES[j]} "
                         f"({bound[j]:.3f} deg) after {th:.3f} s")
            if th * rate < 1e-6:
                t = np.array([1.0 / rate])
                pos = np.rint(start * spd).astype(np.int64)[None, :]
                return Trajectory(t=t, positions=pos, speeds=np.zeros((1, 6), dtype=np.int64),
                                  commands=np.full(1, Tracking.SPEED.board_command, dtype=np.uint8),
                                  rate_hz=rate, move=move, notes=tuple(notes), start_deg=start,
                                  model=model)
            T = th
        else:
            raise PlanningError(
            name,
                f"{JOINT_NAMES[j]} would reach {end[j]:.3f} deg, beyond its range "
                f"{lim[j, 0]:.3f} .. {lim[j, 1]:.3f} deg (it gets there after {th:.3f} s; "
                f"the longest allowed duration is {math.floor(th * rate) / rate:.2f} s)",
                time_s=th, joint=j, value=float(end[j]),
            )
    n_full = int(math.floor(T * rate + 1e-9))
    frac = T * rate - n_full
    if frac < 1e-6:
        frac = 0.0
    n = n_full + (1 if frac > 0 else 0)
    scale = np.ones(n)
    if frac > 0:
        scale[-1] = frac
    speeds = np.outer(scale, v_deg_s)  # deg/s applied during each tick
    # sample k's speed acts during the tick ending at t[k]; its position is where the joints
    # are at t[k] (start + the speeds so far); the trailing zero-speed sample holds the end
    travelled = np.cumsum(speeds, axis=0) / rate
    q = start + np.vstack([travelled, travelled[-1:]])
    t = np.arange(1, n + 2, dtype=float) / rate
    qd = np.vstack([speeds, np.zeros((1, 6))])
    spdr = np.rint(qd * spd).astype(np.int64)
    pos = np.rint(q * spd).astype(np.int64)
    validate.check_positions(name, t, pos, model)
    return Trajectory(t=t, positions=pos, speeds=spdr,
                      commands=np.full(len(t), Tracking.SPEED.board_command, dtype=np.uint8),
                      rate_hz=rate, move=move, notes=tuple(notes), start_deg=start, model=model,
                      planned_deg=q)


def plan_speed_joint(move: SpeedJointMove, start: NDArray[np.float64], model: RobotModel, rate: float) -> Trajectory:
    return _constant_speed(move, start, np.asarray(move.speeds_deg_s, dtype=float),
                           float(move.duration_s), model, rate, jog=False)


def plan_joint_jog(move: JointJog, start: NDArray[np.float64], model: RobotModel, rate: float) -> Trajectory:
    spd = model.steps_per_deg
    v = np.zeros(6)
    for j, d, p in zip(move.joints, move.directions, move.speed_pct):
        v[j] = d * float(model.jog_speed_from_percent(p)[j]) / spd[j]
    notes = []
    T = move.duration_s
    if move.distance_deg is not None:
        j = move.joints[0]
        t_dist = move.distance_deg / abs(v[j])
        if T is None or t_dist < T:
            T = t_dist
            if move.duration_s is not None:
                notes.append(f"jog ends after {move.distance_deg:g} deg ({t_dist:.3f} s), before duration_s")
    if T is None:  # (a JointJog has duration_s and/or distance_deg: checked on construction)
        raise ParolkitValueError("a jog needs duration_s and/or distance_deg")
    return _constant_speed(move, start, v, float(T), model, rate, jog=True, notes=notes)
