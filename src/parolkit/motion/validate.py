"""Sample-by-sample checks every trajectory passes before it is handed out.

Each check finds the FIRST offending sample and raises :class:`PlanningError` naming the move,
the sample time, the joint and the value with its limit.  Nothing is clamped.

The robot's limits (``RobotModel``): per-joint maximum speed (hard: a move that needs more is
refused, with the shortest duration that works when it has one) and per-joint acceleration
limit (:attr:`RobotModel.accel_limit_steps_s2`, default 3x the maximum speed per second).
Moves without a duration are planned within the acceleration limit; a move WITH a duration
that needs more acceleration runs in its time and carries a warning
(:func:`accel_warning`): the seed says "If t is defined, the robot finishes the move in that
time. t overrides a and v", and the original software enforced only the speed limit.

Position-tracked plans (every frame a bounded GO TO) keep to the position-tracking maximum
(:class:`SpeedLimits`, 75-76 % of the maximum at 100 Hz).  A joint move that needs more than
it but no more than the joint's maximum speed is not refused: the planners stretch it to the
shortest duration within the position-tracking maximum and add :func:`stretch_warning`
(the seed's rule is the maximum speed; the margin is this controller's bounded frames).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion.errors import PlanningError
from parolkit.robot import JOINT_NAMES, RobotModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = [
    "check_positions", "check_speeds", "check_accels", "ACCEL_TOLERANCE", "model_arrays", "speed_limits",
    "SpeedLimits", "accel_warning", "accel_excess", "WARNING_PREFIX", "min_duration_for_speed",
    "peak_accels", "stretch_warning", "round_up_duration",
]

#: Every planner warning (a note the controller puts into the move's ack and logs) starts so.
WARNING_PREFIX = "warning: "

#: Finite-difference accelerations may exceed the analytic peak by this fraction (sampling).
ACCEL_TOLERANCE = 0.02


class ModelArrays:
    """Per-model constant arrays, computed once (read-only)."""

    def __init__(self, model: RobotModel) -> None:
        self.steps_per_deg = model.steps_per_deg
        self.limits_steps = model.limits_steps_array
        self.lim_lo = self.limits_steps[:, 0].copy()
        self.lim_hi = self.limits_steps[:, 1].copy()
        self.safe_deg = model.safe_limits_deg
        self.vmax = np.asarray(model.max_speed_steps_s, dtype=float)
        self.vmax_jog = np.asarray(model.max_jog_speed_steps_s, dtype=float)
        #: per-joint acceleration limits, steps/s^2 (``RobotModel.accel_limit_steps_s2``)
        self.amax = model.accel_limit_steps_s2
        self.amax_list: list[float] = self.amax.tolist()
        self.safe_lo = self.safe_deg[:, 0].copy()
        self.safe_hi = self.safe_deg[:, 1].copy()
        # float step positions that round (np.rint) into the step limits with room to spare
        # for a few ulps of arithmetic: [lo - 0.4995, hi + 0.4995]
        self.round_lo = self.lim_lo - 0.4995
        self.round_hi = self.lim_hi + 0.4995
        # the same as Python float lists: per-plan checks on 6 values are several times
        # faster in plain Python than as numpy calls (each numpy reduction costs microseconds)
        self.spd_list = self.steps_per_deg.tolist()
        self.safe_lo_list = self.safe_lo.tolist()
        self.safe_hi_list = self.safe_hi.tolist()
        self.round_lo_list = self.round_lo.tolist()
        self.round_hi_list = self.round_hi.tolist()
        self.vmax_list = self.vmax.tolist()
        for a in (self.steps_per_deg, self.limits_steps, self.lim_lo, self.lim_hi, self.safe_deg,
                  self.vmax, self.vmax_jog, self.safe_lo, self.safe_hi, self.round_lo,
                  self.round_hi, self.amax):
            a.setflags(write=False)


_CACHE: dict[int, tuple[RobotModel, ModelArrays]] = {}


def model_arrays(model: RobotModel) -> ModelArrays:
    """Cached :class:`ModelArrays` of ``model`` (models are frozen)."""
    hit = _CACHE.get(id(model))
    if hit is not None and hit[0] is model:
        return hit[1]
    arrays = ModelArrays(model)
    if len(_CACHE) > 32:
        _CACHE.clear()
    _CACHE[id(model)] = (model, arrays)
    return arrays


class SpeedLimits:
    """The joint speeds (steps/s) a trajectory's samples may ask for, and how to name them.

    Position-tracked streams (board command 156) keep to
    :meth:`RobotModel.max_tracked_speed_steps_s` (the board's GO TO loop starts every tick
    1.27x faster than the stream moves at 100 Hz, see :func:`parolkit.robot.goto_tracking_factor`);
    speed-only streams (123) to the maximum speed itself."""

    def __init__(self, model: RobotModel, rate_hz: float, position_tracked: bool) -> None:
        full = np.asarray(model.max_speed_steps_s, dtype=float)
        self.position_tracked = position_tracked
        #: what the samples may ask for (steps/s): the position-tracking maximum, or the maximum
        self.array = model.max_tracked_speed_steps_s(rate_hz) if position_tracked else full.copy()
        self.array.setflags(write=False)
        #: each joint's maximum speed (steps/s): a move that needs more is refused; one within
        #: it but over :attr:`array` runs stretched (with :func:`stretch_warning`)
        self.full = full
        self.full.setflags(write=False)
        self.list: list[float] = self.array.tolist()
        self.full_list: list[float] = full.tolist()

    def describe_full(self, j: int) -> str:
        """How a refusal names joint ``j``'s maximum speed: ``"maximum speed 6500 steps/s"``."""
        return f"maximum speed {self.full_list[j]:.0f} steps/s"

    def stretch_hint(self, least_s: float, stretched_s: float, j: int) -> str:
        """The hint of a refusal over the maximum speed that names the shortest duration
        accepted, ``least_s`` (s, already rounded up): ``"give t >= 0.36 s"``, and, when a
        duration from there up to ``stretched_s`` would run stretched (position-tracked),
        ``" (a t below 0.48 s runs stretched to 0.48 s: J5 position-tracking maximum 16714
        steps/s)"``; ``j``: the joint that bounds the stretched duration."""
        hint = f"give t >= {least_s:.2f} s"
        if self.position_tracked and stretched_s > least_s + 1e-9:
            hint += (f" (a t below {stretched_s:.2f} s runs stretched to {stretched_s:.2f} s: "
                     f"{JOINT_NAMES[j]} position-tracking maximum {self.list[j]:.0f} steps/s)")
        return hint

    def describe(self, j: int) -> str:
        """How a message names joint ``j``'s limit: ``"maximum speed 6500 steps/s"`` or, for a
        position-tracked trajectory, ``"position-tracking maximum 4884 steps/s (75 % of its
        maximum speed 6500 steps/s: the board's GO TO loop starts each tick up to 1.31x faster
        than the stream moves)"``."""
        v = self.list[j]
        if not self.position_tracked:
            return f"maximum speed {v:.0f} steps/s"
        full = self.full_list[j]
        return (f"position-tracking maximum {v:.0f} steps/s ({100 * v / full:.0f} % of its maximum speed "
                f"{full:.0f} steps/s: the board's GO TO loop starts each tick up to {full / v:.2f}x faster "
                f"than the stream moves)")


_LIMITS: dict[tuple[int, float, bool], tuple[RobotModel, SpeedLimits]] = {}


def speed_limits(model: RobotModel, rate_hz: float, position_tracked: bool) -> SpeedLimits:
    """Cached :class:`SpeedLimits` of ``model`` at ``rate_hz`` (Hz) for a position-tracked
    (156) or speed-only (123) trajectory."""
    key = (id(model), float(rate_hz), bool(position_tracked))
    hit = _LIMITS.get(key)
    if hit is not None and hit[0] is model:
        return hit[1]
    lim = SpeedLimits(model, rate_hz, bool(position_tracked))
    if len(_LIMITS) > 64:
        _LIMITS.clear()
    _LIMITS[key] = (model, lim)
    return lim


def inside(values: list[float], lo: list[float], hi: list[float]) -> bool:
    """``lo[j] <= values[j] <= hi[j]`` for every j (False for NaN); plain Python floats."""
    for v, a, b in zip(values, lo, hi):
        if not a <= v <= b:
            return False
    return True


def _first(mask: NDArray[np.bool_]) -> tuple[int, int] | None:
    if not mask.any():
        return None
    k, j = np.argwhere(mask)[0]
    return int(k), int(j)


def check_positions(name: str, t: NDArray[np.float64], steps: NDArray[np.int64], model: RobotModel) -> None:
    """Every (rounded) sample inside ``model.limits_steps``."""
    ma = model_arrays(model)
    lim = ma.limits_steps
    if steps.min(axis=0).__ge__(ma.lim_lo).all() and steps.max(axis=0).__le__(ma.lim_hi).all():
        return
    hit = _first((steps < lim[:, 0]) | (steps > lim[:, 1]))
    if hit is None:
        return
    k, j = hit
    spd = model.steps_per_deg[j]
    value = float(steps[k, j])
    lo, hi = lim[j]
    side = f"below the lower limit {lo / spd:.3f} deg" if value < lo else f"above the upper limit {hi / spd:.3f} deg"
    raise PlanningError(
        name,
        f"{JOINT_NAMES[j]} = {value / spd:.3f} deg ({int(value)} steps) is {side} "
        f"(allowed {lo / spd:.3f} .. {hi / spd:.3f} deg)",
        time_s=float(t[k]), joint=j, value=value / spd,
    )


def check_speeds(
    name: str, t: NDArray[np.float64], speeds_steps_s: NDArray[np.float64], model: RobotModel, *,
    jog: bool = False, hint: str = "", limits: SpeedLimits | None = None,
) -> None:
    """Every |speed| within the maximum joint speed (``jog``: the maximum jog speed;
    ``limits``: those limits, e.g. the position-tracking ones of :func:`speed_limits`)."""
    ma = model_arrays(model)
    mx = limits.array if limits is not None else ma.vmax_jog if jog else ma.vmax
    peak = np.abs(speeds_steps_s).max(axis=0)
    if np.all(peak <= mx * (1.0 + 1e-9)):
        return
    hit = _first(np.abs(speeds_steps_s) > mx * (1.0 + 1e-9))
    if hit is None:
        return
    k, j = hit
    value = float(speeds_steps_s[k, j])
    if limits is not None:
        what = limits.describe(j)
    else:
        what = f"{'maximum jog speed' if jog else 'maximum speed'} {mx[j]:.0f} steps/s"
    raise PlanningError(
        name,
        f"{JOINT_NAMES[j]} speed {abs(value):.0f} steps/s exceeds the {what}"
        + (f"; {hint}" if hint else ""),
        time_s=float(t[k]), joint=j, value=value,
    )


def _finite_accels(speeds_steps_s: NDArray[np.float64], rate_hz: float) -> NDArray[np.float64]:
    """Finite-difference accelerations (steps/s^2) of tick-spaced speeds, the first from rest."""
    acc = np.empty_like(speeds_steps_s, dtype=float)
    acc[0] = speeds_steps_s[0]
    np.subtract(speeds_steps_s[1:], speeds_steps_s[:-1], out=acc[1:])
    acc *= rate_hz
    return acc


def check_accels(
    name: str, t: NDArray[np.float64], speeds_steps_s: NDArray[np.float64], model: RobotModel, rate_hz: float,
    *, hint: str = "",
) -> None:
    """Every finite-difference acceleration (from rest) within the joint's acceleration limit
    (:attr:`RobotModel.accel_limit_steps_s2`, plus :data:`ACCEL_TOLERANCE` for sampling).
    For moves planned without a duration (a duration's move gets :func:`accel_warning`)."""
    amax = model_arrays(model).amax
    acc = _finite_accels(speeds_steps_s, rate_hz)
    over = np.abs(acc) > amax * (1.0 + ACCEL_TOLERANCE)
    hit = _first(over)
    if hit is None:
        return
    k, j = hit
    value = float(acc[k, j])
    raise PlanningError(
        name,
        f"{JOINT_NAMES[j]} acceleration {abs(value):.0f} steps/s^2 exceeds its limit "
        f"{amax[j]:.0f} steps/s^2" + (f"; {hint}" if hint else ""),
        time_s=float(t[k]), joint=j, value=value,
    )


def accel_excess(peaks_steps_s2: NDArray[np.float64] | list[float], model: RobotModel) -> tuple[int, float] | None:
    """The joint whose peak |acceleration| (steps/s^2, one value per joint) exceeds its limit
    the most (by ratio), and that peak; None when every joint is within (plus
    :data:`ACCEL_TOLERANCE`)."""
    amax = model_arrays(model).amax_list
    worst: tuple[int, float] | None = None
    ratio = 1.0 + ACCEL_TOLERANCE
    for j, (a, lim) in enumerate(zip(np.abs(np.asarray(peaks_steps_s2, dtype=float)).tolist(), amax)):
        r = a / lim
        if r > ratio:
            ratio, worst = r, (j, a)
    return worst


def accel_warning(
    peaks_steps_s2: NDArray[np.float64] | list[float], model: RobotModel, duration_s: float,
    given_s: float | None = None,
) -> str | None:
    """The warning a move with a duration gets when it needs more acceleration than a joint's
    limit (it still runs in ``duration_s``), naming the joint, the acceleration needed and the
    limit, e.g. ``"warning: J5 needs an acceleration of 80107 steps/s^2, above its limit 66000
    steps/s^2 (1127 deg/s^2 > 928 deg/s^2): the move runs in the t=0.8 s given"``.  None when
    every joint is within its limit.  ``peaks_steps_s2``: the peak |acceleration| per joint
    (analytic for a profile, or :func:`peak_accels` of sampled speeds).  ``given_s``: the t
    given when the move was stretched to ``duration_s`` (see :func:`stretch_warning`): the
    text then ends ``"the move runs in 0.48 s (stretched from the t=0.4 s given)"``."""
    hit = accel_excess(peaks_steps_s2, model)
    if hit is None:
        return None
    j, a = hit
    ma = model_arrays(model)
    lim = ma.amax_list[j]
    k = ma.spd_list[j]
    when = (f"in the t={duration_s:g} s given" if given_s is None or abs(given_s - duration_s) < 1e-9
            else f"in {duration_s:.2f} s (stretched from the t={given_s:g} s given)")
    return (f"{WARNING_PREFIX}{JOINT_NAMES[j]} needs an acceleration of {a:.0f} steps/s^2, above its "
            f"limit {lim:.0f} steps/s^2 ({a / k:.0f} deg/s^2 > {lim / k:.0f} deg/s^2): the move runs "
            f"{when}")


def peak_accels(speeds_steps_s: NDArray[np.float64], rate_hz: float) -> NDArray[np.float64]:
    """Per-joint peak |finite-difference acceleration| (steps/s^2) of tick-spaced speeds
    (the first from rest), for :func:`accel_warning`."""
    peaks: NDArray[np.float64] = np.abs(_finite_accels(speeds_steps_s, rate_hz)).max(axis=0)
    return peaks


def round_up_duration(duration_s: float) -> float:
    """``duration_s`` rounded UP to 0.01 s (what refusals and stretch warnings name, so that a
    user who gives that duration gets exactly that move); never below ``duration_s`` by more
    than the planners' relative tolerance of 1e-9 (a float a hair over 0.01 s steps is not
    rounded up a whole 0.01 s)."""
    return math.ceil(duration_s * 100.0 * (1.0 - 1e-9)) / 100.0


def stretch_warning(
    limits: SpeedLimits, j: int, needed_steps_s: float, asked: str, stretched_s: float,
    from_s: float | None = None,
) -> str:
    """The warning of a move that needs ``needed_steps_s`` on joint ``j``, within its maximum
    speed but above the position-tracking maximum of ``limits``, and runs stretched to
    ``stretched_s`` (s) instead of being refused (the seed's speed rule), e.g. ``"warning: J1
    needs 5473 steps/s to finish in the t=4 s given, above its position-tracking maximum 4884
    steps/s (75 % of its maximum speed 6500 steps/s: ...): the move runs stretched to
    4.49 s"``.  ``asked``: what asked for that speed (``"to finish in the t=4 s given"``,
    ``"at v=100 %"``); ``from_s``: the duration it would have had (s), when not the t given.
    Durations are named rounded UP to 0.01 s (a stretched t already is: a move given that t
    runs as it does)."""
    to = round_up_duration(stretched_s)
    span = f"from {round_up_duration(from_s):.2f} s to {to:.2f} s" if from_s is not None else f"to {to:.2f} s"
    return (f"{WARNING_PREFIX}{JOINT_NAMES[j]} needs {needed_steps_s:.0f} steps/s {asked}, above its "
            f"{limits.describe(j)}: the move runs stretched {span}")


def min_duration_for_speed(duration_s: float, peak_ratio: float) -> float:
    """The shortest duration (s, rounded UP to 0.01 s) at which a move that over
    ``duration_s`` peaks at ``peak_ratio`` times a joint's speed limit keeps within it
    (speeds scale with 1 / duration)."""
    return math.ceil(duration_s * peak_ratio * 100.0 - 1e-6) / 100.0
