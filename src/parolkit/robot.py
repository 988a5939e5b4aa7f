"""PAROL6 robot model: the one source of truth for every robot constant.

Every number here comes from the public PAROL6 sources (see docs/robot-model in the README).
Units are stated in every name or docstring:

* ``*_deg``: joint degrees, ``*_rad``: joint radians,
* ``*_steps``: motor microsteps as counted by the board (200 full steps x 32 microsteps per
  motor revolution, times the joint's gear ratio),
* ``*_steps_s`` / ``*_steps_s2``: microsteps per second / per second squared,
* lengths in metres inside (DH table), millimetres at the user-facing edges.

Conversions are vectorised: they accept a scalar, a length-6 sequence or an ``(N, 6)`` array
and return numpy arrays (``float64`` for angles, ``int64`` for steps).

Rounding rule for steps: degrees/radians -> steps rounds to the NEAREST step, ties to even
(``numpy.rint``).  The error of one conversion is therefore at most half a microstep
(0.0044 deg on J1, the coarsest joint).  Steps -> degrees is exact (float division).

Nothing in this module clamps or wraps.  Values outside a range raise
:class:`JointLimitError` (which names the joint and the bound) from the ``check_*``
functions; the conversions themselves only reject values that cannot be represented at all
(NaN, infinities, wrong shapes).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from parolkit.errors import JointLimitError, ParolkitValueError

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = [
    "NUM_JOINTS",
    "JOINT_NAMES",
    "FIRMWARE_SPEED_CLAMP_STEPS_S",
    "ACCEL_CEILING_STEPS_S2",
    "MAX_ACCEL_FACTOR_PER_S",
    "PUBLISHED_LIMITS_DEG",
    "PUBLISHED_LIMITS_STEPS",
    "FULL_STEPS_PER_REV",
    "MICROSTEPS",
    "MOTOR_DEG_PER_STEP",
    "DHRow",
    "RobotModel",
    "PAROL6",
    "deg_to_steps",
    "steps_to_deg",
    "rad_to_steps",
    "steps_to_rad",
    "deg_s_to_steps_s",
    "steps_s_to_deg_s",
    "rad_s_to_steps_s",
    "steps_s_to_rad_s",
    "check_joint_limits_deg",
    "check_joint_limits_steps",
    "check_joint_speeds_steps_s",
    "as_joint_array",
    "GOTO_GAIN_PER_S",
    "GOTO_FF_GAIN",
    "GOTO_ARRIVAL_JITTER_S",
    "goto_tracking_factor",
]

NUM_JOINTS = 6
JOINT_NAMES = ("J1", "J2", "J3", "J4", "J5", "J6")

#: Full steps per motor revolution (1.8 deg steppers).
FULL_STEPS_PER_REV = 200
#: Microstepping configured in the TMC5160 drivers.
MICROSTEPS = 32
#: Motor-shaft degrees per microstep: 360 / (200 * 32) = 0.05625.
MOTOR_DEG_PER_STEP = 360.0 / (FULL_STEPS_PER_REV * MICROSTEPS)

#: The firmware clamps every joint speed to this, steps/s (board-firmware.md: "speeds are
#: clamped to +-50,000 steps/s"): the physical speed ceiling of every joint, and the most a
#: configured speed (:attr:`RobotModel.max_speed_steps_s`, ``max_jog_speed_steps_s``) may be.
FIRMWARE_SPEED_CLAMP_STEPS_S = 50_000
#: The shortest ramp to full speed a configuration may ask for is 0.1 s (ten frames at
#: 100 Hz): ``accel_factor`` (the acceleration limit as a multiple of each joint's maximum
#: speed, 1/s) is at most this.
MAX_ACCEL_FACTOR_PER_S = 10.0
#: The most a configured joint acceleration limit (``max_accel_steps_s2``, the top of the
#: percentage mapping) may be, steps/s^2: the firmware's speed ceiling reached in 0.1 s,
#: 500,000; five times the highest acceleration any PAROL6 source uses (the maintained
#: upstream API's 96,000 steps/s^2 for J3 with its high-speed table; the original demo
#: programs peak near 80,000).  The firmware applies no acceleration limit of its own (JOG and
#: GO TO change speed at once), so this is the PC's ceiling: a value above it is a typo.
ACCEL_CEILING_STEPS_S2 = int(MAX_ACCEL_FACTOR_PER_S * FIRMWARE_SPEED_CLAMP_STEPS_S)
#: Largest gear ratio a configuration may give (joint : motor; the stock ones are 4..20).
MAX_GEAR_RATIO = 100.0
#: Ceiling of the Cartesian jog speed mapping (``cart_linear_speed_range_mm_s``), mm/s: the
#: TCP of the stock arm at every joint's maximum speed moves well under it.
MAX_CART_LINEAR_SPEED_MM_S = 1000.0
#: Ceiling of the Cartesian jog angular speed mapping (``cart_angular_speed_range_deg_s``), deg/s.
MAX_CART_ANGULAR_SPEED_DEG_S = 360.0

#: Largest offset of a user tool's TCP from the flange along each axis, mm (``[tools.NAME]
#: pose``; the arm itself reaches about 440 mm).
MAX_TOOL_OFFSET_MM = 1000.0

#: GO TO (board command 156) is a P loop the firmware re-evaluates on every pass of its main
#: loop (docs/board-emulator.md, "Commands"): ``v = int(((target - current) / 0.01 + v_ff) / 2)``,
#: i.e. ``v = GOTO_FF_GAIN * v_ff + GOTO_GAIN_PER_S * (target - current)`` [steps/s]: the
#: board heads for ``target + v_ff * GOTO_FF_GAIN / GOTO_GAIN_PER_S`` at a speed proportional
#: to the distance left, so within one frame its speed decays as ``exp(-GOTO_GAIN_PER_S t)``.
GOTO_GAIN_PER_S = 50.0
#: Weight of a GO TO frame's feed-forward speed in the board's speed (see GOTO_GAIN_PER_S).
GOTO_FF_GAIN = 0.5
#: Position-tracked (156) plans keep the board within its maximum speed even when a frame
#: reaches the board this much earlier than one period after the one before (a late tick
#: followed by an on-time one, USB scheduling), s.  See :func:`goto_tracking_factor`.
GOTO_ARRIVAL_JITTER_S = 0.001


@dataclass(frozen=True)
class DHRow:
    """One standard Denavit-Hartenberg row. ``d`` and ``a`` in metres, ``alpha`` in radians."""

    d: float
    a: float
    alpha: float


#: Joint position limits in degrees (lower, upper) for J1..J6, as published: the arm's
#: mechanical range (a configuration may narrow them, never widen them).
PUBLISHED_LIMITS_DEG: tuple[tuple[float, float], ...] = (
    (-123.046875, 123.046875),
    (-145.0088, -3.375),
    (107.866, 287.8675),
    (-105.46975, 105.46975),
    (-90.0, 90.0),
    (0.0, 360.0),
)
#: Joint position limits in microsteps (lower, upper), as published (the degree limits
#: converted with truncation toward zero by the original software).
PUBLISHED_LIMITS_STEPS: tuple[tuple[int, int], ...] = (
    (-14000, 14000),
    (-51558, -1200),
    (34699, 92604),
    (-7500, 7500),
    (-6400, 6400),
    (0, 64000),
)


def _is_number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _tuple6(values: Sequence[float], name: str) -> tuple[float, ...]:
    """Six finite numbers (J1..J6), else ParolkitValueError naming ``name`` and the joint."""
    if isinstance(values, (str, bytes)) or not isinstance(values, Sequence):
        raise ParolkitValueError(f"{name} must be a list of {NUM_JOINTS} numbers (J1..J6), got {values!r}")
    if len(values) != NUM_JOINTS:
        raise ParolkitValueError(f"{name} must have {NUM_JOINTS} values, got {len(values)}")
    for i, v in enumerate(values):
        if not _is_number(v):
            raise ParolkitValueError(f"{name}: {JOINT_NAMES[i]} must be a finite number, got {v!r}")
    return tuple(float(v) for v in values)


def _within(values: Sequence[float], name: str, lo: float, hi: float, unit: str, why: str = "") -> None:
    """Each of the six ``values`` in (lo, hi] (already checked to be numbers)."""
    for i, v in enumerate(values):
        if not lo < v <= hi:
            raise ParolkitValueError(f"{name}: {JOINT_NAMES[i]} = {v:g} {unit} is out of range "
                                     f"({lo:g}, {hi:g}] {unit}{why}")


def _pair(value: Sequence[float], name: str, hi: float, unit: str) -> None:
    """A (low, high) mapping range with 0 < low <= high <= hi."""
    if (isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 2
            or not all(_is_number(v) for v in value)):
        raise ParolkitValueError(f"{name} must be two numbers [low, high] in {unit}, got {value!r}")
    lo, top = value
    if not 0 < lo <= top <= hi:
        raise ParolkitValueError(f"{name} must satisfy 0 < low <= high <= {hi:g} {unit}, got [{lo:g}, {top:g}]")


@dataclass(frozen=True)
class RobotModel:
    """All PAROL6 parameters.  Frozen: derive a variant with :meth:`with_changes`.

    The default instance :data:`PAROL6` holds the stock values.  The limit tables are
    configurable (``parolkit.config``) because later community firmware runs faster
    (``HIGH_SPEED_MAX_STEPS_S``).
    """

    #: Gear ratio joint : motor for J1..J6.
    gear_ratios: tuple[float, ...] = (6.4, 20.0, 20.0 * 38.0 / 42.0, 4.0, 4.0, 10.0)
    #: Joint position limits in degrees (lower, upper) for J1..J6: the published ones, or
    #: narrower ones inside them.
    limits_deg: tuple[tuple[float, float], ...] = PUBLISHED_LIMITS_DEG
    #: Joint position limits in microsteps (lower, upper): the published ones, or narrower.
    limits_steps: tuple[tuple[int, int], ...] = PUBLISHED_LIMITS_STEPS
    #: Maximum joint speed, steps/s (stock values).
    max_speed_steps_s: tuple[float, ...] = (6500, 18000, 20000, 22000, 22000, 22000)
    #: Maximum jog speed, steps/s.
    max_jog_speed_steps_s: tuple[float, ...] = (1500, 3000, 3600, 7000, 7000, 18000)
    #: Minimum joint speed (also the minimum jog speed), steps/s.
    min_speed_steps_s: tuple[float, ...] = (100, 100, 100, 100, 100, 100)
    #: What 0..100 % of an acceleration percentage means, steps/s^2 (the GUI's slider, the
    #: ``a=`` of a program): a mapping, NOT a limit of the arm (see :attr:`accel_limit_steps_s2`).
    accel_range_steps_s2: tuple[float, float] = (100.0, 32000.0)
    #: Joint acceleration limit = this factor x the joint's maximum speed, steps/s^2 per
    #: steps/s (1/s): 3.0 reaches full speed in 1/3 s, as the maintained upstream API
    #: (19500, 54000, 60000, 66000, 66000, 66000 steps/s^2 with the stock speeds).  Ignored
    #: when :attr:`max_accel_steps_s2` is given.
    accel_factor: float = 3.0
    #: Per-joint acceleration limits, steps/s^2 (J1..J6); None: :attr:`accel_factor` x
    #: :attr:`max_speed_steps_s`.
    max_accel_steps_s2: tuple[float, ...] | None = None
    #: Cartesian jog linear speed range mapped from 0..100 %, mm/s.
    cart_linear_speed_range_mm_s: tuple[float, float] = (2.0, 60.0)
    #: Cartesian jog angular speed range mapped from 0..100 %, deg/s.
    cart_angular_speed_range_deg_s: tuple[float, float] = (0.7, 25.0)
    #: Standby pose (where homing ends), degrees.
    standby_deg: tuple[float, ...] = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)
    #: Standby pose in board counts, exactly as the firmware writes them after homing.
    standby_steps: tuple[int, ...] = (10240, -32000, 57905, 0, 0, 32000)
    #: Standard DH table, J1..J6.  Row 6 includes the original commander's tool point.
    dh: tuple[DHRow, ...] = (
        DHRow(0.11050, 0.02342, -math.pi / 2),
        DHRow(0.0, 0.18000, math.pi),
        DHRow(0.0, -0.04350, math.pi / 2),
        DHRow(-0.17635, 0.0, -math.pi / 2),
        DHRow(0.0, 0.0, math.pi / 2),
        DHRow(-0.06280, -0.04525, math.pi),
    )

    def __post_init__(self) -> None:
        """Every field is checked against its documented range (docs/config.md); an error
        names the field, the joint and the range."""
        _within(_tuple6(self.gear_ratios, "gear_ratios"), "gear_ratios", 0.0, MAX_GEAR_RATIO, "(joint : motor)")
        self._check_limits()
        vmax = _tuple6(self.max_speed_steps_s, "max_speed_steps_s")
        ceiling = f" (the firmware clamps every joint at {FIRMWARE_SPEED_CLAMP_STEPS_S} steps/s)"
        _within(vmax, "max_speed_steps_s", 0.0, FIRMWARE_SPEED_CLAMP_STEPS_S, "steps/s", ceiling)
        jog = _tuple6(self.max_jog_speed_steps_s, "max_jog_speed_steps_s")
        _within(jog, "max_jog_speed_steps_s", 0.0, FIRMWARE_SPEED_CLAMP_STEPS_S, "steps/s", ceiling)
        vmin = _tuple6(self.min_speed_steps_s, "min_speed_steps_s")
        for i in range(NUM_JOINTS):
            if not 0 < vmin[i] <= vmax[i] or jog[i] > vmax[i]:
                raise ParolkitValueError(
                    f"{JOINT_NAMES[i]} speeds must satisfy 0 < min_speed_steps_s ({vmin[i]:g}) <= "
                    f"max_speed_steps_s ({vmax[i]:g}) and max_jog_speed_steps_s ({jog[i]:g}) <= "
                    f"max_speed_steps_s, steps/s")
        _pair(self.accel_range_steps_s2, "accel_range_steps_s2", ACCEL_CEILING_STEPS_S2, "steps/s^2")
        f = self.accel_factor
        if not _is_number(f) or not 0 < f <= MAX_ACCEL_FACTOR_PER_S:
            raise ParolkitValueError(
                f"accel_factor must be a number in (0, {MAX_ACCEL_FACTOR_PER_S:g}] 1/s (the acceleration limit is "
                f"this times the joint's maximum speed: {MAX_ACCEL_FACTOR_PER_S:g} reaches full speed in "
                f"{1 / MAX_ACCEL_FACTOR_PER_S:g} s), got {f!r}")
        if self.max_accel_steps_s2 is not None:
            if f != 3.0:
                raise ParolkitValueError(
                    "give either accel_factor or max_accel_steps_s2 (the per-joint acceleration "
                    "limits), not both")
            amax = _tuple6(self.max_accel_steps_s2, "max_accel_steps_s2")
            _within(amax, "max_accel_steps_s2", 0.0, ACCEL_CEILING_STEPS_S2, "steps/s^2")
        _pair(self.cart_linear_speed_range_mm_s, "cart_linear_speed_range_mm_s", MAX_CART_LINEAR_SPEED_MM_S,
              "mm/s")
        _pair(self.cart_angular_speed_range_deg_s, "cart_angular_speed_range_deg_s",
              MAX_CART_ANGULAR_SPEED_DEG_S, "deg/s")
        if len(self.dh) != NUM_JOINTS:
            raise ParolkitValueError("dh needs one row per joint")

    def _check_limits(self) -> None:
        """The position limits lie inside the published ones (the arm's mechanical range: they
        can be narrowed, never widened) and the standby pose inside them."""
        for name, table, stock, integer in (("limits_deg", self.limits_deg, PUBLISHED_LIMITS_DEG, False),
                                            ("limits_steps", self.limits_steps, PUBLISHED_LIMITS_STEPS, True)):
            if isinstance(table, (str, bytes)) or not isinstance(table, Sequence) or len(table) != NUM_JOINTS:
                raise ParolkitValueError(f"{name} needs one (low, high) pair per joint, J1..J6")
            for i, (pair, (slo, shi)) in enumerate(zip(table, stock)):
                if (isinstance(pair, (str, bytes)) or not isinstance(pair, Sequence) or len(pair) != 2
                        or not all(_is_number(v) and (not integer or isinstance(v, int)) for v in pair)):
                    kind = "whole numbers" if integer else "numbers"
                    raise ParolkitValueError(f"{name}: {JOINT_NAMES[i]} must be two {kind} (low, high), got {pair!r}")
                lo, hi = pair
                if not lo < hi:
                    raise ParolkitValueError(f"{JOINT_NAMES[i]} limits must be (low, high) with low < high")
                if not slo <= lo < hi <= shi:
                    raise ParolkitValueError(
                        f"{name}: {JOINT_NAMES[i]} ({lo:g}, {hi:g}) must lie inside the published range "
                        f"[{slo:g}, {shi:g}] (the arm's mechanical range: limits can be narrowed, not widened)")
        for name, pose, table in (("standby_deg", self.standby_deg, self.limits_deg),
                                  ("standby_steps", self.standby_steps, self.limits_steps)):
            for i, (v, (lo, hi)) in enumerate(zip(_tuple6(pose, name), table)):
                if name == "standby_steps" and not isinstance(pose[i], int):
                    raise ParolkitValueError(f"standby_steps: {JOINT_NAMES[i]} must be a whole number of steps, "
                                             f"got {pose[i]!r}")
                if not lo <= v <= hi:
                    raise ParolkitValueError(f"{name}: {JOINT_NAMES[i]} = {v:g} is outside the joint's limits "
                                             f"[{lo:g}, {hi:g}]")

    def with_changes(self, **changes: Any) -> RobotModel:
        """A copy with some fields replaced (validated like the original)."""
        return replace(self, **changes)

    # ---- derived arrays (cheap; numpy arrays are created on each access, never shared) ----

    @property
    def steps_per_deg(self) -> NDArray[np.float64]:
        """Microsteps per joint degree, J1..J6 (113.78, 355.56, 321.69, 71.11, 71.11, 177.78)."""
        return np.asarray(self.gear_ratios, dtype=np.float64) / MOTOR_DEG_PER_STEP

    @property
    def steps_per_rad(self) -> NDArray[np.float64]:
        """Microsteps per joint radian, J1..J6."""
        return self.steps_per_deg * (180.0 / math.pi)

    @property
    def limits_deg_array(self) -> NDArray[np.float64]:
        """(6, 2) array of the published degree limits."""
        return np.asarray(self.limits_deg, dtype=np.float64)

    @property
    def limits_steps_array(self) -> NDArray[np.int64]:
        """(6, 2) int64 array of the published step limits (what the wire guard enforces)."""
        return np.asarray(self.limits_steps, dtype=np.int64)

    @property
    def safe_limits_deg(self) -> NDArray[np.float64]:
        """(6, 2) degree limits that are safe on BOTH tables.

        The published degree and step tables differ by a fraction of a step (the original
        truncated when converting).  Planning and IK use this intersection, so any angle they
        accept converts (with :func:`deg_to_steps` rounding) to counts the wire guard accepts.
        """
        spd = self.steps_per_deg
        steps = self.limits_steps_array.astype(float)
        # an angle x converts to rint(x * spd); it stays inside [lo_steps, hi_steps] as long as
        # x * spd is within 0.499 steps beyond them (0.499, not 0.5: ties round to even)
        lo = np.maximum(self.limits_deg_array[:, 0], (steps[:, 0] - 0.499) / spd)
        hi = np.minimum(self.limits_deg_array[:, 1], (steps[:, 1] + 0.499) / spd)
        return np.stack([lo, hi], axis=1)

    @property
    def max_speed_deg_s(self) -> NDArray[np.float64]:
        return np.asarray(self.max_speed_steps_s, dtype=np.float64) / self.steps_per_deg

    @property
    def max_jog_speed_deg_s(self) -> NDArray[np.float64]:
        return np.asarray(self.max_jog_speed_steps_s, dtype=np.float64) / self.steps_per_deg

    @property
    def min_speed_deg_s(self) -> NDArray[np.float64]:
        return np.asarray(self.min_speed_steps_s, dtype=np.float64) / self.steps_per_deg

    @property
    def accel_limit_steps_s2(self) -> NDArray[np.float64]:
        """Per-joint acceleration limit, steps/s^2: :attr:`max_accel_steps_s2` when given, else
        :attr:`accel_factor` x :attr:`max_speed_steps_s` (stock: 19500, 54000, 60000, 66000,
        66000, 66000).  Moves without a duration are planned within it; a move with a
        duration that needs more runs in its time with a warning (the seed: "t overrides a
        and v"); only the speed limit refuses one."""
        if self.max_accel_steps_s2 is not None:
            return np.asarray(self.max_accel_steps_s2, dtype=np.float64)
        return np.asarray(self.max_speed_steps_s, dtype=np.float64) * float(self.accel_factor)

    @property
    def max_accel_deg_s2(self) -> NDArray[np.float64]:
        """Per-joint acceleration limit (:attr:`accel_limit_steps_s2`) in deg/s^2."""
        return self.accel_limit_steps_s2 / self.steps_per_deg

    # ---- percent mappings used by the original software ----

    def speed_from_percent(self, percent: float) -> NDArray[np.float64]:
        """Joint speed (steps/s, per joint) for a move speed percentage: 0 % -> min, 100 % -> max."""
        p = _check_percent(percent, "speed_percentage")
        mn = np.asarray(self.min_speed_steps_s, dtype=np.float64)
        mx = np.asarray(self.max_speed_steps_s, dtype=np.float64)
        return mn + (mx - mn) * p / 100.0

    def jog_speed_from_percent(self, percent: float) -> NDArray[np.float64]:
        """Jog speed (steps/s, per joint): 0..100 % -> 0..max jog speed (as the original)."""
        p = _check_percent(percent, "speed_percentage")
        return np.asarray(self.max_jog_speed_steps_s, dtype=np.float64) * p / 100.0

    def accel_from_percent(self, percent: float) -> float:
        """Joint acceleration (steps/s^2) for a percentage: 0 % -> 100, 100 % -> 32000."""
        p = _check_percent(percent, "accel_percentage")
        lo, hi = self.accel_range_steps_s2
        return lo + (hi - lo) * p / 100.0

    def cart_linear_speed_from_percent(self, percent: float) -> float:
        """Cartesian linear speed in mm/s: 0..100 % -> 2..60 mm/s."""
        p = _check_percent(percent, "speed_percentage")
        lo, hi = self.cart_linear_speed_range_mm_s
        return lo + (hi - lo) * p / 100.0

    def max_tracked_speed_steps_s(self, rate_hz: float) -> NDArray[np.float64]:
        """Fastest joint speeds (steps/s) a position-tracked (GO TO, 156) stream may ask for
        at control rate ``rate_hz``: :attr:`max_speed_steps_s` x :func:`goto_tracking_factor`
        (0.763 at 100 Hz: [4960, 13737, 15264, 16790, 16790, 16790]), rounded down to whole
        steps/s so that a speed rounded to whole steps/s cannot cross it.  Speed-only streams
        (123) may use the full maximum."""
        return np.floor(np.asarray(self.max_speed_steps_s, dtype=np.float64) * goto_tracking_factor(rate_hz))

    def cart_angular_speed_from_percent(self, percent: float) -> float:
        """Cartesian angular speed in deg/s: 0..100 % -> 0.7..25 deg/s."""
        p = _check_percent(percent, "speed_percentage")
        lo, hi = self.cart_angular_speed_range_deg_s
        return lo + (hi - lo) * p / 100.0


def _check_percent(value: float, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ParolkitValueError(f"{name} must be a number in 0..100, got {value!r}") from None
    if not math.isfinite(v) or not 0.0 <= v <= 100.0:
        raise ParolkitValueError(f"{name} must be in 0..100 %, got {value!r}")
    return v


def goto_tracking_factor(rate_hz: float, jitter_s: float = GOTO_ARRIVAL_JITTER_S) -> float:
    """Largest fraction of a joint's maximum speed a GO TO (156) stream may move at, at
    control rate ``rate_hz`` (Hz), so that the board itself never runs faster than the maximum.

    Derivation (k = :data:`GOTO_GAIN_PER_S`, T = 1 / ``rate_hz``).  Within one frame the
    board's speed decays from its start value u0 as ``u0 exp(-k t)`` (the P loop closes on a
    fixed target), so in one period it covers ``u0 (1 - a) / k`` with ``a = exp(-k T)``.  A
    stream that steps its target by ``s = v T`` every period therefore settles where the
    board covers ``s`` per period: ``u0 = k s / (1 - a)``, i.e. the board starts every period
    at ``v kT / (1 - a)`` = 1.2707 v at 100 Hz whatever the feed-forward (the issue 12
    measurement: 100 % speed peaked at 1.27x the maximum).  Ramps and decelerations settle
    from below, so this steady state is the peak.  If a frame arrives ``jitter_s`` early
    (the board has had ``T - jitter_s`` to close the gap) the start speed is
    ``k s (1 + a' / (1 - a))`` with ``a' = exp(-k (T - jitter_s))``.  Keeping that within the
    maximum gives the factor::

        v / vmax <= 1 / (k T (1 + a' / (1 - a)))   = (1 - a) / (k T) when jitter_s = 0

    = 0.7870 (1 / 1.2707) at 100 Hz on time, 0.7633 with the default 1 ms of jitter.
    """
    r = float(rate_hz)
    if not math.isfinite(r) or r <= 0:
        raise ParolkitValueError(f"rate_hz must be a positive number of Hz, got {rate_hz!r}")
    period = 1.0 / r
    kt = GOTO_GAIN_PER_S * period
    a = math.exp(-kt)
    a_early = math.exp(-GOTO_GAIN_PER_S * max(0.0, period - max(0.0, float(jitter_s))))
    return 1.0 / (kt * (1.0 + a_early / (1.0 - a)))


#: The stock PAROL6.
PAROL6 = RobotModel()

#: Hardware maxima used by later community software (steps/s); opt in via the config file.
HIGH_SPEED_MAX_STEPS_S = (15000, 25000, 32000, 10000, 10000, 27000)


# --------------------------------------------------------------------------------------------
# Conversions
# --------------------------------------------------------------------------------------------


def as_joint_array(values: object, name: str = "joints", *, allow_batch: bool = True) -> NDArray[np.float64]:
    """Validate and convert joint values to a float64 array of shape (6,) or (N, 6).

    Raises :class:`ParolkitValueError` naming ``name`` for wrong shapes, non-numbers, NaN or
    infinities.
    """
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ParolkitValueError(f"{name} must be numbers, got {values!r}") from None
    if arr.ndim == 1 and arr.shape[0] == NUM_JOINTS:
        pass
    elif allow_batch and arr.ndim == 2 and arr.shape[1] == NUM_JOINTS:
        pass
    else:
        want = "6 values or an (N, 6) array" if allow_batch else "6 values"
        raise ParolkitValueError(f"{name} must be {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        joint = JOINT_NAMES[int(bad[-1])]
        raise ParolkitValueError(f"{name}: {joint} is not a finite number")
    return arr


def _scale(values: object, name: str, model: RobotModel | None) -> tuple[NDArray[np.float64], RobotModel]:
    return as_joint_array(values, name), (model or PAROL6)


def _to_steps(x: NDArray[np.float64]) -> NDArray[np.int64]:
    out = np.rint(x)
    if np.any(np.abs(out) > 2**53):
        raise ParolkitValueError("value too large to express in steps")
    return out.astype(np.int64)


def deg_to_steps(deg: object, model: RobotModel | None = None) -> NDArray[np.int64]:
    """Joint degrees -> microsteps (int64), nearest step, ties to even."""
    arr, m = _scale(deg, "joints_deg", model)
    return _to_steps(arr * m.steps_per_deg)


def steps_to_deg(steps: object, model: RobotModel | None = None) -> NDArray[np.float64]:
    """Microsteps -> joint degrees (float64, exact)."""
    arr, m = _scale(steps, "joints_steps", model)
    return arr / m.steps_per_deg


def rad_to_steps(rad: object, model: RobotModel | None = None) -> NDArray[np.int64]:
    """Joint radians -> microsteps (int64), nearest step, ties to even."""
    arr, m = _scale(rad, "joints_rad", model)
    return _to_steps(arr * m.steps_per_rad)


def steps_to_rad(steps: object, model: RobotModel | None = None) -> NDArray[np.float64]:
    """Microsteps -> joint radians (float64)."""
    arr, m = _scale(steps, "joints_steps", model)
    return arr / m.steps_per_rad


def deg_s_to_steps_s(deg_s: object, model: RobotModel | None = None) -> NDArray[np.int64]:
    """Joint deg/s -> steps/s (int64), nearest, ties to even."""
    arr, m = _scale(deg_s, "speeds_deg_s", model)
    return _to_steps(arr * m.steps_per_deg)


def steps_s_to_deg_s(steps_s: object, model: RobotModel | None = None) -> NDArray[np.float64]:
    """Steps/s -> joint deg/s (float64)."""
    arr, m = _scale(steps_s, "speeds_steps_s", model)
    return arr / m.steps_per_deg


def rad_s_to_steps_s(rad_s: object, model: RobotModel | None = None) -> NDArray[np.int64]:
    """Joint rad/s -> steps/s (int64), nearest, ties to even."""
    arr, m = _scale(rad_s, "speeds_rad_s", model)
    return _to_steps(arr * m.steps_per_rad)


def steps_s_to_rad_s(steps_s: object, model: RobotModel | None = None) -> NDArray[np.float64]:
    """Steps/s -> joint rad/s (float64)."""
    arr, m = _scale(steps_s, "speeds_steps_s", model)
    return arr / m.steps_per_rad


# --------------------------------------------------------------------------------------------
# Limit checks
# --------------------------------------------------------------------------------------------


def _first_violation(
    arr: NDArray[np.float64], lo: NDArray[np.float64 | np.int64],
    hi: NDArray[np.float64 | np.int64],
) -> tuple[int, int, float, str, float] | None:
    flat = np.atleast_2d(arr)
    below = flat < lo
    above = flat > hi
    if not (below.any() or above.any()):
        return None
    bad = np.argwhere(below | above)[0]
    row, j = int(bad[0]), int(bad[1])
    value = float(flat[row, j])
    if below[row, j]:
        return row, j, value, "lower", float(lo[j])
    return row, j, value, "upper", float(hi[j])


def check_joint_limits_deg(
    deg: object, model: RobotModel | None = None, *, safe: bool = True, what: str = "joints"
) -> NDArray[np.float64]:
    """Raise :class:`JointLimitError` if any angle is outside its range; return the array.

    ``safe=True`` (default) uses :attr:`RobotModel.safe_limits_deg` (the range every part of
    parolkit plans in); ``safe=False`` the published degree table.
    """
    m = model or PAROL6
    arr = as_joint_array(deg, what)
    lim = m.safe_limits_deg if safe else m.limits_deg_array
    v = _first_violation(arr, lim[:, 0], lim[:, 1])
    if v is not None:
        row, j, value, side, bound = v
        raise JointLimitError(
            joint=j, value=value, low=float(lim[j, 0]), high=float(lim[j, 1]), unit="deg",
            sample=row if arr.ndim == 2 else None, what=what,
        )
    return arr


def check_joint_limits_steps(
    steps: object, model: RobotModel | None = None, *, what: str = "joints"
) -> NDArray[np.float64]:
    """Raise :class:`JointLimitError` if any count is outside the published step limits."""
    m = model or PAROL6
    arr = as_joint_array(steps, what)
    lim = m.limits_steps_array
    v = _first_violation(arr, lim[:, 0], lim[:, 1])
    if v is not None:
        row, j, value, side, bound = v
        raise JointLimitError(
            joint=j, value=value, low=float(lim[j, 0]), high=float(lim[j, 1]), unit="steps",
            sample=row if arr.ndim == 2 else None, what=what,
        )
    return arr


def check_joint_speeds_steps_s(
    speeds: object, model: RobotModel | None = None, *, jog: bool = False, what: str = "speeds"
) -> NDArray[np.float64]:
    """Raise :class:`JointLimitError` if any |speed| exceeds the max (or max jog) speed."""
    m = model or PAROL6
    arr = as_joint_array(speeds, what)
    mx = np.asarray(m.max_jog_speed_steps_s if jog else m.max_speed_steps_s, dtype=np.float64)
    v = _first_violation(arr, -mx, mx)
    if v is not None:
        row, j, value, side, bound = v
        raise JointLimitError(
            joint=j, value=value, low=float(-mx[j]), high=float(mx[j]), unit="steps/s",
            sample=row if arr.ndim == 2 else None, what=what,
        )
    return arr
