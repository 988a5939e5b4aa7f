"""Sample-by-sample checks every trajectory passes before it is handed out.

Each check finds the FIRST offending sample and raises :class:`PlanningError` naming the move,
the sample time, the joint and the value with its limit.  Nothing is clamped.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion.errors import PlanningError
from parolkit.robot import JOINT_NAMES, RobotModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = [
    "check_positions", "check_speeds", "check_accels", "ACCEL_TOLERANCE", "model_arrays", "speed_limits",
    "SpeedLimits",
]

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
        self.amax = float(model.accel_range_steps_s2[1])
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
                  self.round_hi):
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
        self.array = model.max_tracked_speed_steps_s(rate_hz) if position_tracked else full.copy()
        self.array.setflags(write=False)
        self.list: list[float] = self.array.tolist()
        self.full_list: list[float] = full.tolist()

    def describe(self, j: int) -> str:
        """How a message names joint ``j``'s limit: ``"maximum speed 6500 steps/s"`` or, for a
        position-tracked trajectory, ``"position-tracking maximum 4961 steps/s (76 % of its
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


def check_accels(
    name: str, t: NDArray[np.float64], speeds_steps_s: NDArray[np.float64], model: RobotModel, rate_hz: float,
    *, hint: str = "",
) -> None:
    """Every finite-difference acceleration (from rest) within the top of the acceleration
    range (plus :data:`ACCEL_TOLERANCE` for sampling)."""
    amax = model_arrays(model).amax
    acc = np.empty_like(speeds_steps_s, dtype=float)
    acc[0] = speeds_steps_s[0]
    np.subtract(speeds_steps_s[1:], speeds_steps_s[:-1], out=acc[1:])
    acc *= rate_hz
    if np.abs(acc).max() <= amax * (1.0 + ACCEL_TOLERANCE):
        return
    hit = _first(np.abs(acc) > amax * (1.0 + ACCEL_TOLERANCE))
    if hit is None:
        return
    k, j = hit
    value = float(acc[k, j])
    raise PlanningError(
        name,
        f"{JOINT_NAMES[j]} acceleration {abs(value):.0f} steps/s^2 exceeds the maximum "
        f"{amax:.0f} steps/s^2" + (f"; {hint}" if hint else ""),
        time_s=float(t[k]), joint=j, value=value,
    )
