"""The shared vocabulary of motion: the words (enums) and the move value objects.

Every layer speaks about motion in these terms and no layer defines its own copy:

* :mod:`parolkit.protocol.commands` parses a datagram into a command that CARRIES one of these
  moves (``MOVEJOINT`` -> ``MoveJoint(move=JointMove(...))``);
* :mod:`parolkit.motion` plans them (``plan(JointMove(...), start_deg)``) and re-exports them;
* :mod:`parolkit.script` statements carry them (``MoveJoint(...)`` in a program);
* :mod:`parolkit.gui` builds its jogs from them.

The standard-library client (:mod:`parolkit.client.robot_api`) cannot import anything from the
rest of the package, so it keeps plain copies of the words (``PROFILES``, ``FRAMES``, ...);
``tests/unit/test_vocabulary.py`` asserts that those copies agree with the enums here.

This module imports only the standard library and :mod:`parolkit.errors`: the controller's
start-up path (protocol parsing) uses it without loading numpy-heavy motion code.

Units at the edge: degrees, millimetres, percent (0-100), seconds.  Every move validates its
fields on construction and raises :class:`~parolkit.errors.ParolkitValueError` naming the field
and the allowed range.  A move says WHAT to do; :func:`parolkit.motion.plan` decides HOW
(profile, duration, samples).  Timing fields follow the seed's rules (``docs/motion.md``):

* ``duration_s`` given: the move lasts exactly that long (it overrides ``speed_pct`` and
  ``accel_pct``), default profile ``POLY``;
* ``speed_pct`` (and ``accel_pct``) given: trapezoid on the leading joint (joint moves) or on
  the path speed (Cartesian moves);
* neither: the conservative default of the case.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any, Generic, TypeVar, dataclass_transform

from parolkit.errors import ParolkitValueError

__all__ = [
    "MAX_DURATION_S",
    "MAX_BLEND",
    "MAX_BLEND_CHAIN",
    "blend_kind",
    "Profile",
    "Tracking",
    "Frame",
    "Plane",
    "Timing",
    "CartAxis",
    "JointMove",
    "JointPathMove",
    "MAX_PATH_POINTS",
    "PoseMove",
    "CartMove",
    "CartRelTRFMove",
    "SpeedJointMove",
    "JointJog",
    "CartJog",
    "CircleMove",
    "ArcCenterMove",
    "ArcParamMove",
    "HelixMove",
    "SplineMove",
    "LineSegment",
    "BlendMove",
    "BlendSegment",
    "Move",
]

#: Longest duration any timed move (or jog, delay, wait) may ask for, s.
MAX_DURATION_S = 3600.0
#: Shortest duration a timed move may ask for, s (a shorter one is refused before planning:
#: the square of 1e-300 s is 0.0 in floating point, and no move lasts less than a tick anyway;
#: durations from here up to a tick are refused by the planner naming the shortest that fits)
MIN_DURATION_S = 1e-9
#: Most points a :class:`JointPathMove` may carry (one datagram holds 200 points with their
#: velocities in full float precision, under the protocol's datagram cap)
MAX_PATH_POINTS = 200


def _word(value: object) -> object:
    """The wire word of ``value``: an enum's value, anything else unchanged."""
    return value.value if isinstance(value, Enum) else value


class Profile(str, Enum):
    """Time-scaling profile of a move; ``None`` in a move means the seed's default for the case.

    The values are the wire words (``MOVEJOINT|...|trap``, RBTscript ``trap``).
    """

    POLY = "poly"  #: quintic polynomial: zero speed and acceleration at both ends
    TRAP = "trap"  #: trapezoidal speed (with a duration: 1/3 accelerate, 1/3 cruise, 1/3 brake)
    RUCKIG = "ruckig"  #: jerk-limited (Ruckig), time-optimal within speed/accel/jerk limits
    TOPPRA = "toppra"  #: time-optimal path parameterisation (TOPP-RA) within joint limits

    @classmethod
    def parse(cls, value: Profile | str | None) -> Profile | None:
        """Accept a Profile, its word in any case, ``"None"``/``""`` or None (= default)."""
        if value is None or isinstance(value, Profile):
            return value
        word = _word(value)
        if isinstance(word, str):
            key = word.strip().lower()
            if key in ("", "none"):
                return None
            for p in cls:
                if p.value == key:
                    return p
        raise ParolkitValueError(
            f"profile must be one of poly, trap, ruckig, toppra or None, got {value!r}"
        )


class Tracking(str, Enum):
    """How the board follows a trajectory.  The values are the wire words."""

    POSITION = "position"  #: position + feed-forward speed (board command 156): ends exactly on target
    SPEED = "speed"  #: speed only (board command 123): smoother, may end slightly off target

    @property
    def board_command(self) -> int:
        """The board command code that streams this tracking: 156 (GOTO) or 123 (JOG), as in
        :class:`parolkit.protocol.frames.BoardCommand` (a unit test checks they agree)."""
        return 156 if self is Tracking.POSITION else 123

    @classmethod
    def parse(cls, value: Tracking | str | None) -> Tracking:
        """Accept a Tracking, ``"position"``/``"speed"`` in any case, or None (= POSITION)."""
        if value is None:
            return cls.POSITION
        if isinstance(value, Tracking):
            return value
        word = _word(value)
        if isinstance(word, str):
            key = word.strip().lower()
            for t in cls:
                if t.value == key:
                    return t
        raise ParolkitValueError(f"tracking must be 'position' or 'speed', got {value!r}")


class Frame(str, Enum):
    """Reference frame: the world (robot base) or the tool frame at the start of the move."""

    WRF = "WRF"
    TRF = "TRF"

    @classmethod
    def parse(cls, value: Frame | str) -> Frame:
        """Accept a Frame or ``"WRF"``/``"TRF"`` in any case."""
        if isinstance(value, Frame):
            return value
        word = _word(value)
        if isinstance(word, str) and word.strip().upper() in ("WRF", "TRF"):
            return cls(word.strip().upper())
        raise ParolkitValueError(f"frame must be WRF or TRF, got {value!r}")


class Plane(str, Enum):
    """Plane of a circle, with its normal: XY (+Z), XZ (+Y), YZ (+X)."""

    XY = "XY"
    XZ = "XZ"
    YZ = "YZ"

    @classmethod
    def parse(cls, value: Plane | str) -> Plane:
        """Accept a Plane or ``"XY"``/``"XZ"``/``"YZ"`` in any case."""
        if isinstance(value, Plane):
            return value
        word = _word(value)
        if isinstance(word, str) and word.strip().upper() in ("XY", "XZ", "YZ"):
            return cls(word.strip().upper())
        raise ParolkitValueError(f"plane must be XY, XZ or YZ, got {value!r}")


class Timing(str, Enum):
    """How a smooth path's time is given on the wire (``SMOOTH_*|...|DURATION|3``): a total
    duration in s or a path speed in percent.  A move object holds the same choice as
    ``duration_s`` / ``speed_pct``; :meth:`fields` converts."""

    DURATION = "DURATION"
    SPEED = "SPEED"

    def fields(self, value: float) -> tuple[float | None, float | None]:
        """``(duration_s, speed_pct)`` of a move timed with ``value`` (s or %) in this mode."""
        return (value, None) if self is Timing.DURATION else (None, value)


class CartAxis(str, Enum):
    """A Cartesian jog direction: along (X, Y, Z) or about (RX, RY, RZ) an axis, + or -.

    The values are the wire words of ``CARTJOG``.  Rotations turn about the TCP.
    """

    X_POS = "X+"
    X_NEG = "X-"
    Y_POS = "Y+"
    Y_NEG = "Y-"
    Z_POS = "Z+"
    Z_NEG = "Z-"
    RX_POS = "RX+"
    RX_NEG = "RX-"
    RY_POS = "RY+"
    RY_NEG = "RY-"
    RZ_POS = "RZ+"
    RZ_NEG = "RZ-"

    @property
    def is_rotation(self) -> bool:
        """True for RX, RY, RZ (a rotation about the axis), False for a translation."""
        return self.value.startswith("R")

    @property
    def sign(self) -> int:
        """+1 or -1: the direction along / about the axis."""
        return 1 if self.value.endswith("+") else -1

    @property
    def axis_index(self) -> int:
        """0..2 for X/Y/Z (the translation or rotation axis).  (Not ``index``: that is
        ``str.index``, which a str enum must keep.)"""
        return "XYZ".index(self.value.rstrip("+-")[-1])

    @classmethod
    def parse(cls, value: CartAxis | str) -> CartAxis:
        """Accept a CartAxis or its word (``"x+"``, ``"RZ-"``, ...) in any case."""
        if isinstance(value, CartAxis):
            return value
        word = _word(value)
        if isinstance(word, str):
            key = word.strip().upper()
            for a in cls:
                if a.value == key:
                    return a
        raise ParolkitValueError(
            f"axis must be one of {', '.join(a.value for a in cls)}, got {value!r}"
        )


# ---------------------------------------------------------------------------------------------
# field validators (each names the field and the allowed range)
# ---------------------------------------------------------------------------------------------


def _num(value: float, name: str) -> float:
    # (typed as the fields declare; the checks also catch whatever an untyped caller passes)
    if isinstance(value, bool):
        raise ParolkitValueError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ParolkitValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ParolkitValueError(f"{name} must be a finite number, got {value!r}")
    return v


def _vec(values: Iterable[float], n: int, name: str) -> tuple[float, ...]:
    try:
        seq = list(values)
    except TypeError:
        raise ParolkitValueError(f"{name} must be {n} numbers, got {values!r}") from None
    if len(seq) != n:
        raise ParolkitValueError(f"{name} must be {n} numbers, got {len(seq)}")
    return tuple(_num(v, f"{name}[{i}]") for i, v in enumerate(seq))


def _opt_duration(value: float | None, name: str = "duration_s") -> float | None:
    if value is None:
        return None
    v = _num(value, name)
    if not MIN_DURATION_S <= v <= MAX_DURATION_S:
        raise ParolkitValueError(f"{name} must be in {MIN_DURATION_S:g}..{MAX_DURATION_S:g} s, got {value!r}")
    return v


def _opt_pct(value: float | None, name: str, *, allow_zero: bool = True) -> float | None:
    if value is None:
        return None
    v = _num(value, name)
    lo_ok = v >= 0.0 if allow_zero else v > 0.0
    if not (lo_ok and v <= 100.0):
        rng = "0..100 %" if allow_zero else "(0, 100] %"
        raise ParolkitValueError(f"{name} must be in {rng}, got {value!r}")
    return v


#: The largest blend radius (``blend``): mm on a Cartesian move, deg on a joint-space one.
MAX_BLEND = 100.0


#: The most moves one blended chain holds (a longer run of blended moves is split there).
MAX_BLEND_CHAIN = 100


def blend_kind(move: object) -> str | None:
    """Which blended chains ``move`` can join: ``"cart"`` (:class:`CartMove`), ``"joint"``
    (:class:`JointMove`, :class:`PoseMove`), None (it cannot be blended)."""
    if isinstance(move, CartMove):
        return "cart"
    if isinstance(move, (JointMove, PoseMove)):
        return "joint"
    return None


def _opt_blend(value: float | None, unit: str) -> float | None:
    """A move's blend radius: None or 0 (no blending: the move ends at rest) or a number in
    (0, :data:`MAX_BLEND`] ``unit``."""
    if value is None:
        return None
    v = _num(value, "blend")
    if not 0.0 <= v <= MAX_BLEND:
        raise ParolkitValueError(f"blend must be in 0..{MAX_BLEND:g} {unit}, got {value!r}")
    return v or None


def _pose(values: Iterable[float], name: str) -> tuple[float, ...]:
    return _vec(values, 6, name)


def _opt_pose(values: Iterable[float] | None, name: str) -> tuple[float, ...] | None:
    return None if values is None else _pose(values, name)


def _positive(value: float, name: str, unit: str) -> float:
    v = _num(value, name)
    if v <= 0.0:
        raise ParolkitValueError(f"{name} must be > 0 {unit}, got {value!r}")
    return v


if TYPE_CHECKING:  # (structural types for the checker only: no classes built at import)
    from typing import Protocol

    class _Timed(Protocol):
        """The timing fields :func:`_timing` normalises."""

        @property
        def duration_s(self) -> float | None: ...
        @property
        def speed_pct(self) -> float | None: ...

    class _Smooth(_Timed, Protocol):
        """A smooth path's common fields, normalised by :func:`_smooth_common`."""

        @property
        def start_pose(self) -> Sequence[float] | None: ...


def _timing(obj: _Timed) -> None:
    """Common fields: duration_s, speed_pct (profile and tracking are :class:`WordField` descriptors)."""
    object.__setattr__(obj, "duration_s", _opt_duration(obj.duration_s))
    object.__setattr__(
        obj, "speed_pct", _opt_pct(obj.speed_pct, "speed_pct", allow_zero=True)
    )


# ---------------------------------------------------------------------------------------------
# fields that take the words
#
# A field holds the enum (``profile: Profile | None``, ``frame: Frame``): every consumer reads
# the enum.  The constructor also takes the words (``JointMove(q, profile="trap")``,
# ``CartJog("trf", "x+", 50, 1)``).  Such a field is a :class:`WordField` descriptor that says
# both once: ``profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse,
# default=None)`` takes a Profile, its word or None, and holds what ``Profile.parse`` makes of
# it (its error names the field and the words allowed).  The generated __init__ assigns the
# field, which runs the descriptor's ``__set__``; type checkers take the constructor's (and
# ``dataclasses.replace``'s) parameter type from ``__set__`` and the attribute's type from
# ``__get__`` (the Python docs, dataclasses, "Descriptor-typed fields"; for a field without a
# default see :func:`_move`).  tests/unit/test_moves_typing.py runs mypy on user code to check
# what the constructors accept and what the fields read as.
# ---------------------------------------------------------------------------------------------

_In = TypeVar("_In")
_Out = TypeVar("_Out")
_C = TypeVar("_C")


class _Required:
    """The default of a :class:`WordField` that has none: the field is required."""

    def __repr__(self) -> str:
        return "<required>"


_REQUIRED = _Required()


class WordField(Generic[_In, _Out]):
    """A move field that takes an ``_In`` (the enum or its word) and holds ``parse(value)``, an
    ``_Out``.  ``default``: the field's default (an ``_Out``), or none: the field is required.

    The value lives in the instance's ``__dict__`` under the field's own name, so a move's
    ``vars()``, copies and pickles are those of a plain dataclass.
    """

    __slots__ = ("parse", "default", "name")

    def __init__(self, parse: Callable[[_In], _Out], *, default: _Out | _Required = _REQUIRED) -> None:
        self.parse = parse
        self.default = default
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, obj: object | None, owner: type | None = None) -> _Out:
        if obj is None:  # the class's attribute: dataclasses reads the default here
            if isinstance(self.default, _Required):
                raise AttributeError(f"{self.name} has no default")
            return self.default
        value: _Out = obj.__dict__[self.name]
        return value

    def __set__(self, obj: object, value: _In) -> None:
        obj.__dict__[self.name] = self.parse(value)


@dataclass_transform(frozen_default=True, field_specifiers=(WordField,))
def _move(cls: type[_C]) -> type[_C]:
    """A move class: a frozen dataclass.  (Declared a dataclass transform whose field specifier
    is :class:`WordField` so that mypy also takes a REQUIRED WordField's constructor type from
    ``__set__``: for plain dataclasses it does so only for fields with a default.)"""
    return dataclass(frozen=True)(cls)


# ---------------------------------------------------------------------------------------------
# point-to-point moves
# ---------------------------------------------------------------------------------------------


@_move
class JointMove:
    """MoveJoint: go to ``target_deg`` (J1..J6, degrees) on a straight joint-space path.

    ``duration_s`` (s) overrides ``speed_pct``/``accel_pct`` (percent of the leading joint's
    speed and of the acceleration range).  With neither: v=45 %, a=27 %, trapezoid.
    ``blend`` (deg, 0..100): round the corner into the next queued joint-space move, starting
    that far (joint-space distance) before the target; None or 0: stop at the target.
    """

    target_deg: Sequence[float]
    duration_s: float | None = None
    speed_pct: float | None = None
    accel_pct: float | None = None
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)
    blend: float | None = None

    name = "MoveJoint"


    def __post_init__(self) -> None:
        object.__setattr__(self, "target_deg", _vec(self.target_deg, 6, "target_deg"))
        _timing(self)
        object.__setattr__(self, "accel_pct", _opt_pct(self.accel_pct, "accel_pct"))
        object.__setattr__(self, "blend", _opt_blend(self.blend, "deg"))


@_move
class PoseMove:
    """MovePose: IK once at ``pose`` [x, y, z mm, A, B, C deg], then a joint-space move.

    Same timing rules as :class:`JointMove`; defaults v=50 %, a=30 %.  ``blend`` (deg) as
    :class:`JointMove`'s.
    """

    pose: Sequence[float]
    duration_s: float | None = None
    speed_pct: float | None = None
    accel_pct: float | None = None
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)
    blend: float | None = None

    name = "MovePose"


    def __post_init__(self) -> None:
        object.__setattr__(self, "pose", _pose(self.pose, "pose"))
        _timing(self)
        object.__setattr__(self, "accel_pct", _opt_pct(self.accel_pct, "accel_pct"))
        object.__setattr__(self, "blend", _opt_blend(self.blend, "deg"))


@_move
class CartMove:
    """MoveCart: straight line to ``pose`` (WRF, mm/deg), orientation by SLERP, IK along it.

    ``speed_pct`` maps to 2..60 mm/s and 0.7..25 deg/s (the slower governs); without
    ``duration_s`` and ``speed_pct`` the default is 50 % (see docs/motion.md).  ``blend`` (mm,
    0..100): round the corner into the next queued MoveCart, starting that far before the
    target, so the arm does not stop there; None or 0: stop at the target.
    """

    pose: Sequence[float]
    duration_s: float | None = None
    speed_pct: float | None = None
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)
    blend: float | None = None

    name = "MoveCart"


    def __post_init__(self) -> None:
        object.__setattr__(self, "pose", _pose(self.pose, "pose"))
        _timing(self)
        object.__setattr__(self, "blend", _opt_blend(self.blend, "mm"))


@_move
class CartRelTRFMove:
    """MoveCartRelTRF: straight-line move by ``delta`` [dx, dy, dz mm, dA, dB, dC deg] in
    the tool frame at the start of the move (post-multiplied)."""

    delta: Sequence[float]
    duration_s: float | None = None
    speed_pct: float | None = None
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)

    name = "MoveCartRelTRF"


    def __post_init__(self) -> None:
        object.__setattr__(self, "delta", _pose(self.delta, "delta"))
        _timing(self)


@_move
class SpeedJointMove:
    """SpeedJoint: constant joint speeds ``speeds_deg_s`` (deg/s) for ``duration_s`` s,
    streamed as speed commands (board 123), then a zero-speed sample."""

    speeds_deg_s: Sequence[float]
    duration_s: float

    name = "SpeedJoint"

    def __post_init__(self) -> None:
        object.__setattr__(self, "speeds_deg_s", _vec(self.speeds_deg_s, 6, "speeds_deg_s"))
        d = _opt_duration(self.duration_s)
        if d is None:
            raise ParolkitValueError(
                f"duration_s is required for SpeedJoint (0 < t <= {MAX_DURATION_S:g} s)"
            )
        object.__setattr__(self, "duration_s", d)


@_move
class JointJog:
    """Jog one or several joints at constant speed (board 123).

    ``joints``: 0-based indices (0 = J1); ``directions``: +1 / -1 per joint; ``speed_pct``: per
    joint, 0 < p <= 100 % of the joint's maximum jog speed.  Give ``duration_s`` (s),
    ``distance_deg`` (deg, single-joint jog only) or both (the shorter ends the jog).
    """

    joints: Sequence[int]
    directions: Sequence[int]
    speed_pct: Sequence[float]
    duration_s: float | None = None
    distance_deg: float | None = None

    name = "Jog"

    def __post_init__(self) -> None:
        joints = tuple(self.joints)
        n = len(joints)
        if n == 0 or n > 6:
            raise ParolkitValueError(f"joints must name 1..6 joints, got {n}")
        for i, j in enumerate(joints):
            if isinstance(j, bool) or not isinstance(j, int) or not 0 <= j <= 5:
                raise ParolkitValueError(f"joints[{i}] must be an integer 0..5, got {j!r}")
        if len(set(joints)) != n:
            raise ParolkitValueError(
                f"joints must not repeat a joint (+ and - of one joint together is invalid): {joints}"
            )
        dirs = tuple(self.directions)
        if len(dirs) != n:
            raise ParolkitValueError(f"directions must have {n} values (one per joint), got {len(dirs)}")
        for i, d in enumerate(dirs):
            if d not in (1, -1) or isinstance(d, bool):
                raise ParolkitValueError(f"directions[{i}] must be +1 or -1, got {d!r}")
        pct = _vec(self.speed_pct, n, "speed_pct")
        for i, p in enumerate(pct):
            if not 0.0 < p <= 100.0:
                raise ParolkitValueError(f"speed_pct[{i}] must be in (0, 100] %, got {p!r}")
        dur = _opt_duration(self.duration_s)
        dist = None
        if self.distance_deg is not None:
            dist = _positive(self.distance_deg, "distance_deg", "deg")
            if n != 1:
                raise ParolkitValueError("distance_deg is only allowed when jogging one joint")
        if dur is None and dist is None:
            raise ParolkitValueError("a jog needs duration_s and/or distance_deg")
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "directions", tuple(int(d) for d in dirs))
        object.__setattr__(self, "speed_pct", pct)
        object.__setattr__(self, "duration_s", dur)
        object.__setattr__(self, "distance_deg", dist)

    @classmethod
    def single(
        cls, joint: int, direction: int, speed_pct: float, *, duration_s: float | None = None,
        distance_deg: float | None = None,
    ) -> JointJog:
        """Jog one joint: ``joint`` 0..5 (0 = J1), ``direction`` +1 / -1, ``speed_pct`` (0, 100]."""
        return cls((joint,), (direction,), (speed_pct,), duration_s, distance_deg)

    @classmethod
    def from_index(
        cls, index: int, speed_pct: float, duration_s: float | None = None,
        distance_deg: float | None = None,
    ) -> JointJog:
        """The UDP JOG convention: index 0-5 = J1..J6 positive, 6-11 = negative."""
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= 11:
            raise ParolkitValueError(f"joint index must be an integer 0..11, got {index!r}")
        return cls((index % 6,), (1 if index < 6 else -1,), (speed_pct,), duration_s, distance_deg)

    @property
    def wire_indices(self) -> tuple[int, ...]:
        """The UDP JOG/MULTIJOG index of each jogged joint: 0-5 positive, 6-11 negative."""
        return tuple(j if d > 0 else j + 6 for j, d in zip(self.joints, self.directions))


@_move
class CartJog:
    """Cartesian jog along/about one axis of WRF or TRF at a constant speed for ``duration_s``.

    ``axis``: a :class:`CartAxis` or its word (X+ X- Y+ Y- Z+ Z- RX+ RX- RY+ RY- RZ+ RZ-);
    ``speed_pct`` (0, 100] maps to 2..60 mm/s (translations) or 0.7..25 deg/s (rotations).
    Rotations turn about the TCP.
    """

    frame: WordField[Frame | str, Frame] = WordField(Frame.parse)
    axis: WordField[CartAxis | str, CartAxis] = WordField(CartAxis.parse)
    speed_pct: float
    duration_s: float

    name = "CartJog"


    def __post_init__(self) -> None:
        object.__setattr__(self, "speed_pct", _opt_pct(self.speed_pct, "speed_pct", allow_zero=False))
        d = _opt_duration(self.duration_s)
        if d is None:
            raise ParolkitValueError(
                f"duration_s is required for CartJog (0 < t <= {MAX_DURATION_S:g} s)"
            )
        object.__setattr__(self, "duration_s", d)


# ---------------------------------------------------------------------------------------------
# a timed joint-space path (MOVEJOINTPATH, the ROS 2 bridge's JointTrajectory)
# ---------------------------------------------------------------------------------------------


@_move
class JointPathMove:
    """MoveJointPath: pass through ``points_deg`` (J1..J6, degrees) at ``times_s`` (s from the
    start of the move), played as ONE planned trajectory (no stop at the points).

    The path starts at the joints' position when the move starts (time 0, at rest) and ends at
    rest on the last point.  ``times_s``: one per point, > 0 and strictly increasing, each at
    most :data:`MAX_DURATION_S`.  ``velocities_deg_s`` (deg/s): None (the planner chooses them:
    a smooth C2 spline) or one 6-vector per point, the last all zeros (the path ends at rest).
    At most :data:`MAX_PATH_POINTS` points.  Always position-tracked (board 156): each point
    is commanded exactly on its tick.  Joint ranges, speeds and accelerations are the
    planner's to check (:func:`parolkit.motion.plan`): they depend on the robot model.
    """

    points_deg: Sequence[Sequence[float]]
    times_s: Sequence[float]
    velocities_deg_s: Sequence[Sequence[float]] | None = None

    name = "MoveJointPath"

    def __post_init__(self) -> None:
        points = _path_points(self.points_deg)
        object.__setattr__(self, "points_deg", points)
        object.__setattr__(self, "times_s", _path_times(self.times_s, len(points)))
        if self.velocities_deg_s is not None:
            object.__setattr__(self, "velocities_deg_s", _path_velocities(self.velocities_deg_s, len(points)))

    @property
    def duration_s(self) -> float:
        """Time of the last point (s): how long the move lasts."""
        return self.times_s[-1]

    @property
    def target_deg(self) -> tuple[float, ...]:
        """The last point (deg): where the move ends."""
        return tuple(self.points_deg[-1])


def _listed(values: object, name: str, what: str) -> list[Any]:
    """``values`` as a list, or an error naming the field (a str is not a list of numbers)."""
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise ParolkitValueError(f"{name} must be a list of {what}, got {values!r}")
    return list(values)


def _path_points(values: object) -> tuple[tuple[float, ...], ...]:
    seq = _listed(values, "points_deg", "joint positions (6 numbers each, deg)")
    if not 1 <= len(seq) <= MAX_PATH_POINTS:
        raise ParolkitValueError(f"points_deg must hold 1..{MAX_PATH_POINTS} points, got {len(seq)}")
    return tuple(_vec(p, 6, f"points_deg[{k}]") for k, p in enumerate(seq))


def _path_times(values: object, n: int) -> tuple[float, ...]:
    seq = _listed(values, "times_s", "times (s)")
    if len(seq) != n:
        raise ParolkitValueError(f"times_s must hold one time per point ({n}), got {len(seq)}")
    times: list[float] = []
    for k, v in enumerate(seq):
        t = _num(v, f"times_s[{k}]")
        if not 0.0 < t <= MAX_DURATION_S:
            raise ParolkitValueError(f"times_s[{k}] must be in (0, {MAX_DURATION_S:g}] s, got {v!r}")
        if times and t <= times[-1]:
            raise ParolkitValueError(
                f"times_s[{k}] = {t:g} s must be greater than times_s[{k - 1}] = {times[-1]:g} s "
                f"(times strictly increasing)")
        times.append(t)
    return tuple(times)


def _path_velocities(values: object, n: int) -> tuple[tuple[float, ...], ...]:
    seq = _listed(values, "velocities_deg_s", "joint velocities (6 numbers each, deg/s)")
    if len(seq) != n:
        raise ParolkitValueError(f"velocities_deg_s must hold one 6-vector per point ({n}), got {len(seq)}")
    vel = tuple(_vec(v, 6, f"velocities_deg_s[{k}]") for k, v in enumerate(seq))
    last = vel[-1]
    if any(v != 0.0 for v in last):
        j = next(i for i, v in enumerate(last) if v != 0.0)
        raise ParolkitValueError(
            f"velocities_deg_s[{n - 1}][{j}] must be 0 deg/s (the path ends at rest on its last point), "
            f"got {last[j]!r}")
    return vel


# ---------------------------------------------------------------------------------------------
# smooth paths (mirroring the UDP SMOOTH_* arguments)
# ---------------------------------------------------------------------------------------------


def _smooth_common(obj: _Smooth) -> None:
    object.__setattr__(obj, "start_pose", _opt_pose(obj.start_pose, "start_pose"))
    _timing(obj)


@_move
class CircleMove:
    """A full 360 deg circle of ``radius_mm`` around ``center_mm`` in ``plane`` of ``frame``.

    The circle starts at the point of the circle nearest the start position (a straight
    approach to it is planned first when the start is not on the circle, > 0.05 mm away).
    Orientation is held.  Counter-clockwise about the plane normal unless ``clockwise``.
    """

    center_mm: Sequence[float]
    radius_mm: float
    plane: WordField[Plane | str, Plane] = WordField(Plane.parse, default=Plane.XY)
    frame: WordField[Frame | str, Frame] = WordField(Frame.parse, default=Frame.WRF)
    start_pose: Sequence[float] | None = None
    duration_s: float | None = None
    speed_pct: float | None = None
    clockwise: bool = False
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)

    name = "SmoothCircle"


    def __post_init__(self) -> None:
        object.__setattr__(self, "center_mm", _vec(self.center_mm, 3, "center_mm"))
        object.__setattr__(self, "radius_mm", _positive(self.radius_mm, "radius_mm", "mm"))
        object.__setattr__(self, "clockwise", bool(self.clockwise))
        _smooth_common(self)


@_move
class ArcCenterMove:
    """An arc from the start position to ``end_pose`` around ``center_mm``.

    Both ends must lie at the same distance from the centre (within 1 mm).  The arc turns
    counter-clockwise about the frame's Z axis (seen from +Z) unless ``clockwise``.
    Orientation by SLERP from start to end.
    """

    end_pose: Sequence[float]
    center_mm: Sequence[float]
    frame: WordField[Frame | str, Frame] = WordField(Frame.parse, default=Frame.WRF)
    start_pose: Sequence[float] | None = None
    duration_s: float | None = None
    speed_pct: float | None = None
    clockwise: bool = False
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)

    name = "SmoothArcCenter"


    def __post_init__(self) -> None:
        object.__setattr__(self, "end_pose", _pose(self.end_pose, "end_pose"))
        object.__setattr__(self, "center_mm", _vec(self.center_mm, 3, "center_mm"))
        object.__setattr__(self, "clockwise", bool(self.clockwise))
        _smooth_common(self)


@_move
class ArcParamMove:
    """An arc of ``radius_mm`` sweeping ``angle_deg`` from the start position to ``end_pose``.

    The centre lies in the plane through the chord and the frame's Z axis; the chord must
    match the radius and angle (2 R sin(angle/2), within 1 deg of angle).
    """

    end_pose: Sequence[float]
    radius_mm: float
    angle_deg: float
    frame: WordField[Frame | str, Frame] = WordField(Frame.parse, default=Frame.WRF)
    start_pose: Sequence[float] | None = None
    duration_s: float | None = None
    speed_pct: float | None = None
    clockwise: bool = False
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)

    name = "SmoothArcParam"


    def __post_init__(self) -> None:
        object.__setattr__(self, "end_pose", _pose(self.end_pose, "end_pose"))
        object.__setattr__(self, "radius_mm", _positive(self.radius_mm, "radius_mm", "mm"))
        a = _num(self.angle_deg, "angle_deg")
        if not 0.0 < a < 360.0:
            raise ParolkitValueError(f"angle_deg must be in (0, 360) deg, got {self.angle_deg!r}")
        object.__setattr__(self, "angle_deg", a)
        object.__setattr__(self, "clockwise", bool(self.clockwise))
        _smooth_common(self)


@_move
class HelixMove:
    """A helix around the axis through ``center_mm`` parallel to the frame's Z axis.

    ``radius_mm`` > 0, ``pitch_mm`` > 0 (rise per turn), ``height_mm`` (total rise, sign =
    direction along Z, non-zero).  It starts at the start position's height, at the point of
    the cylinder nearest the start (approach line first if needed).  Orientation is held.
    """

    center_mm: Sequence[float]
    radius_mm: float
    pitch_mm: float
    height_mm: float
    frame: WordField[Frame | str, Frame] = WordField(Frame.parse, default=Frame.WRF)
    start_pose: Sequence[float] | None = None
    duration_s: float | None = None
    speed_pct: float | None = None
    clockwise: bool = False
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)

    name = "SmoothHelix"


    def __post_init__(self) -> None:
        object.__setattr__(self, "center_mm", _vec(self.center_mm, 3, "center_mm"))
        object.__setattr__(self, "radius_mm", _positive(self.radius_mm, "radius_mm", "mm"))
        object.__setattr__(self, "pitch_mm", _positive(self.pitch_mm, "pitch_mm", "mm"))
        h = _num(self.height_mm, "height_mm")
        if h == 0.0:
            raise ParolkitValueError("height_mm must be non-zero (mm)")
        if abs(h) / self.pitch_mm > 100:
            raise ParolkitValueError(
                f"height_mm / pitch_mm must be at most 100 turns, got {abs(h) / self.pitch_mm:g}"
            )
        object.__setattr__(self, "height_mm", h)
        object.__setattr__(self, "clockwise", bool(self.clockwise))
        _smooth_common(self)


@_move
class SplineMove:
    """A cubic spline (chord-length parameterised) from the start through ``waypoints``
    (poses mm/deg, at least one); orientation by a smooth rotation spline through the
    waypoint orientations."""

    waypoints: Sequence[Sequence[float]]
    frame: WordField[Frame | str, Frame] = WordField(Frame.parse, default=Frame.WRF)
    start_pose: Sequence[float] | None = None
    duration_s: float | None = None
    speed_pct: float | None = None
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)

    name = "SmoothSpline"


    def __post_init__(self) -> None:
        try:
            wps = list(self.waypoints)
        except TypeError:
            raise ParolkitValueError("waypoints must be a list of poses") from None
        if not 1 <= len(wps) <= 1000:
            raise ParolkitValueError(f"waypoints must hold 1..1000 poses, got {len(wps)}")
        object.__setattr__(
            self, "waypoints", tuple(_pose(w, f"waypoints[{i}]") for i, w in enumerate(wps))
        )
        _smooth_common(self)


@_move
class LineSegment:
    """A straight segment to ``pose`` (mm/deg) inside a :class:`BlendMove`."""

    pose: Sequence[float]

    name = "Line"

    def __post_init__(self) -> None:
        object.__setattr__(self, "pose", _pose(self.pose, "pose"))


#: What a :class:`BlendMove` joins (each in the blend's frame; their own timing is ignored).
BlendSegment = LineSegment | CircleMove | ArcCenterMove | ArcParamMove | SplineMove
_BLEND_SEGMENT_TYPES = (LineSegment, CircleMove, ArcCenterMove, ArcParamMove, SplineMove)


@_move
class BlendMove:
    """Several segments (LINE / CIRCLE / ARC / SPLINE) joined into one path whose corners are
    rounded, then timed as ONE move: continuous in position and velocity.

    Corner rounding: ``blend_radius_mm`` (mm, distance from the corner where the rounding
    starts) or ``blend_time_s`` (s, converted with the path's mean speed: r = v * t / 2).
    The segments' own timing and frame fields are ignored (every segment is in ``frame``);
    ``duration_s`` / ``speed_pct`` time the whole.
    """

    segments: Sequence[BlendSegment]
    blend_radius_mm: float | None = None
    blend_time_s: float | None = None
    frame: WordField[Frame | str, Frame] = WordField(Frame.parse, default=Frame.WRF)
    start_pose: Sequence[float] | None = None
    duration_s: float | None = None
    speed_pct: float | None = None
    profile: WordField[Profile | str | None, Profile | None] = WordField(Profile.parse, default=None)
    tracking: WordField[Tracking | str, Tracking] = WordField(Tracking.parse, default=Tracking.POSITION)

    name = "SmoothBlend"


    def __post_init__(self) -> None:
        segs = tuple(self.segments)
        if not 1 <= len(segs) <= 100:
            raise ParolkitValueError(f"segments must hold 1..100 segments, got {len(segs)}")
        for i, s in enumerate(segs):
            if not isinstance(s, _BLEND_SEGMENT_TYPES):
                raise ParolkitValueError(
                    f"segments[{i}] must be a LineSegment, CircleMove, ArcCenterMove, "
                    f"ArcParamMove or SplineMove, got {type(s).__name__}"
                )
        object.__setattr__(self, "segments", segs)
        if self.blend_radius_mm is not None and self.blend_time_s is not None:
            raise ParolkitValueError("give blend_radius_mm or blend_time_s, not both")
        if self.blend_radius_mm is not None:
            r = _num(self.blend_radius_mm, "blend_radius_mm")
            if r < 0:
                raise ParolkitValueError(f"blend_radius_mm must be >= 0 mm, got {r!r}")
            object.__setattr__(self, "blend_radius_mm", r)
        if self.blend_time_s is not None:
            t = _num(self.blend_time_s, "blend_time_s")
            if not 0.0 <= t <= 60.0:
                raise ParolkitValueError(f"blend_time_s must be in 0..60 s, got {t!r}")
            object.__setattr__(self, "blend_time_s", t)
        _smooth_common(self)


#: Every move :func:`parolkit.motion.plan` accepts.
Move = (
    JointMove | JointPathMove | PoseMove | CartMove | CartRelTRFMove | SpeedJointMove | JointJog | CartJog
    | CircleMove | ArcCenterMove | ArcParamMove | HelixMove | SplineMove | BlendMove
)
