"""Keep-out zones and the shapes of what the arm carries: typed, frozen, validated.

Standard library only (``parolkit.config`` builds these while it reads a TOML file).  Units
are the user's: millimetres and degrees; every zone lives in the base frame (x forward, z up,
origin on the surface the arm stands on).

Zones (``[[zones]]`` in the config, docs/collision.md):

* :class:`BoxZone`: a box, ``center`` (mm), ``size`` (full edge lengths along its own x, y, z,
  mm) and ``rpy`` (deg): roll about x, pitch about y, yaw about z, fixed axes, i.e.
  ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (URDF's convention).
* :class:`PlaneZone`: a half-space.  ``point`` (mm) lies on its boundary and ``normal``
  points OUT of the forbidden side, into the space the arm may use: the forbidden side is
  ``{x : normal . (x - point) <= 0}`` (a table under the arm: normal ``[0, 0, 1]``).
* :class:`CylinderZone`: a solid cylinder, ``center`` (the middle of its axis, mm),
  ``axis`` (direction, any length), ``radius`` and ``height`` (mm, the whole length).

Each zone has a ``margin`` (mm, >= 0): a pose whose distance to the zone is at most the
margin counts as a violation.  :data:`TABLE_ZONE` (the plane z = 0, margin 0) is on by
default; a config turns it off (``enabled = false``) or moves it (a zone named ``"table"``).

Moving shapes:

* :class:`ToolShape`: the tool as a capsule between two points of the flange frame (by default
  the flange origin and the TCP), with a radius; ``[tools.NAME] shape = {...}``.
* :class:`Capsule` and :class:`Sphere`: shapes a program attaches to the flange
  (:meth:`parolkit.collision.CollisionModel.attach`), centred on their own origin, the
  capsule along its own z axis.  A box-shaped part is held as its enclosing capsule
  (:meth:`Capsule.around_box`).

Every value is checked when the object is built; an error names the zone (or tool), the field
and the allowed range (:class:`parolkit.errors.ParolkitValueError`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from parolkit.errors import ParolkitValueError

__all__ = [
    "BoxZone", "PlaneZone", "CylinderZone", "Zone", "ZONE_KINDS", "TABLE_ZONE",
    "ToolShape", "Capsule", "Sphere", "HeldShape",
    "MAX_ZONE_COORD_MM", "MAX_ZONE_SIZE_MM", "MAX_MARGIN_MM", "MAX_SHAPE_RADIUS_MM", "MAX_SHAPE_LENGTH_MM",
    "zone_from_mapping", "tool_shape_from_mapping",
]

#: A zone's centre or point lies within this many mm of the base on each axis (the arm reaches
#: about 440 mm; a value beyond this is a typo, e.g. metres taken for mm the other way round).
MAX_ZONE_COORD_MM = 10_000.0
#: Largest box edge, cylinder height or radius, mm.
MAX_ZONE_SIZE_MM = 20_000.0
#: Largest margin of a zone, mm.
MAX_MARGIN_MM = 1_000.0
#: Largest radius of a tool or held shape, mm.
MAX_SHAPE_RADIUS_MM = 500.0
#: Largest length of a held capsule, mm.
MAX_SHAPE_LENGTH_MM = 2_000.0
#: Largest offset of a tool shape's end points from the flange, mm (as a tool's TCP:
#: ``parolkit.robot.MAX_TOOL_OFFSET_MM``).
MAX_TOOL_POINT_MM = 1_000.0

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _.\-]{0,63}")
_AXES = ("x", "y", "z")
_RPY = ("roll", "pitch", "yaw")


def _is_number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _check_name(name: object, what: str) -> str:
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise ParolkitValueError(
            f"{what} name must be 1..64 characters: letters, digits, spaces, '_', '-' or '.', starting with a "
            f"letter or digit (it is quoted in messages such as \"J5 link vs zone 'monitor'\"), got {name!r}")
    return name


def _vec3(value: object, where: str, lo: float, hi: float, unit: str, *, open_low: bool = False,
          names: tuple[str, str, str] = _AXES) -> tuple[float, float, float]:
    """Three finite numbers, each in [lo, hi] (or (lo, hi] with ``open_low``)."""
    if (isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 3
            or not all(_is_number(v) for v in value)):
        raise ParolkitValueError(f"{where} must be 3 finite numbers [{', '.join(names)}] in {unit}, got {value!r}")
    for n, v in zip(names, value):
        if not (lo < v <= hi if open_low else lo <= v <= hi):
            rng = f"({lo:g}, {hi:g}]" if open_low else f"[{lo:g}, {hi:g}]"
            raise ParolkitValueError(f"{where}: {n} = {v:g} {unit} is out of range {rng} {unit}")
    return (float(value[0]), float(value[1]), float(value[2]))


def _direction(value: object, where: str) -> tuple[float, float, float]:
    """Three finite numbers, not all zero (a direction; its length does not matter)."""
    if (isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 3
            or not all(_is_number(v) for v in value)):
        raise ParolkitValueError(f"{where} must be a direction: 3 finite numbers [x, y, z], not all 0, got {value!r}")
    x, y, z = (float(v) for v in value)
    n = math.sqrt(x * x + y * y + z * z)
    if not n > 1e-9 or not math.isfinite(n):
        raise ParolkitValueError(f"{where} must be a direction: 3 finite numbers [x, y, z], not all 0, got {value!r}")
    return (x, y, z)


def _number(value: object, where: str, lo: float, hi: float, unit: str, *, open_low: bool) -> float:
    ok = _is_number(value) and ((lo < value <= hi) if open_low else (lo <= value <= hi))  # type: ignore[operator]
    if not ok:
        rng = f"({lo:g}, {hi:g}]" if open_low else f"[{lo:g}, {hi:g}]"
        raise ParolkitValueError(f"{where} must be a number in {rng} {unit}, got {value!r}")
    return float(value)  # type: ignore[arg-type]


def _margin(value: object, where: str) -> float:
    return _number(value, f"{where}.margin", 0.0, MAX_MARGIN_MM, "mm", open_low=False)


def _enabled(value: object, where: str) -> None:
    if not isinstance(value, bool):
        raise ParolkitValueError(f"{where}.enabled must be true or false, got {value!r}")


@dataclass(frozen=True)
class BoxZone:
    """A box-shaped keep-out zone in the base frame.

    ``center`` mm; ``size`` mm, the full edge lengths along the box's own x, y, z, each in
    (0, 20000]; ``rpy`` deg, each in [-360, 360], ``R = Rz(yaw) Ry(pitch) Rx(roll)``;
    ``margin`` mm in [0, 1000].
    """

    name: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    margin: float = 0.0
    enabled: bool = True
    kind: ClassVar[str] = "box"

    def __post_init__(self) -> None:
        w = f"zones.{_check_name(self.name, 'zone')}"
        object.__setattr__(self, "center", _vec3(self.center, f"{w}.center", -MAX_ZONE_COORD_MM,
                                                 MAX_ZONE_COORD_MM, "mm"))
        object.__setattr__(self, "size", _vec3(self.size, f"{w}.size", 0.0, MAX_ZONE_SIZE_MM, "mm", open_low=True))
        object.__setattr__(self, "rpy", _vec3(self.rpy, f"{w}.rpy", -360.0, 360.0, "deg", names=_RPY))
        object.__setattr__(self, "margin", _margin(self.margin, w))
        _enabled(self.enabled, w)


@dataclass(frozen=True)
class PlaneZone:
    """A half-space keep-out zone: everything on the far side of a plane.

    ``point`` mm, on the plane; ``normal`` (any length, not zero) points OUT of the forbidden
    side, toward the space the arm may use: the forbidden side is
    ``{x : normal . (x - point) <= 0}``.  ``margin`` mm in [0, 1000].
    """

    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    margin: float = 0.0
    enabled: bool = True
    kind: ClassVar[str] = "plane"

    def __post_init__(self) -> None:
        w = f"zones.{_check_name(self.name, 'zone')}"
        object.__setattr__(self, "point", _vec3(self.point, f"{w}.point", -MAX_ZONE_COORD_MM,
                                                MAX_ZONE_COORD_MM, "mm"))
        object.__setattr__(self, "normal", _direction(self.normal, f"{w}.normal"))
        object.__setattr__(self, "margin", _margin(self.margin, w))
        _enabled(self.enabled, w)


@dataclass(frozen=True)
class CylinderZone:
    """A solid cylinder keep-out zone.

    ``center`` mm, the middle of the axis; ``axis`` a direction (any length, not zero);
    ``radius`` mm in (0, 20000]; ``height`` mm, the whole length along the axis, in
    (0, 20000]; ``margin`` mm in [0, 1000].
    """

    name: str
    center: tuple[float, float, float]
    axis: tuple[float, float, float]
    radius: float
    height: float
    margin: float = 0.0
    enabled: bool = True
    kind: ClassVar[str] = "cylinder"

    def __post_init__(self) -> None:
        w = f"zones.{_check_name(self.name, 'zone')}"
        object.__setattr__(self, "center", _vec3(self.center, f"{w}.center", -MAX_ZONE_COORD_MM,
                                                 MAX_ZONE_COORD_MM, "mm"))
        object.__setattr__(self, "axis", _direction(self.axis, f"{w}.axis"))
        object.__setattr__(self, "radius", _number(self.radius, f"{w}.radius", 0.0, MAX_ZONE_SIZE_MM, "mm",
                                                   open_low=True))
        object.__setattr__(self, "height", _number(self.height, f"{w}.height", 0.0, MAX_ZONE_SIZE_MM, "mm",
                                                   open_low=True))
        object.__setattr__(self, "margin", _margin(self.margin, w))
        _enabled(self.enabled, w)


#: Any keep-out zone.
Zone = BoxZone | PlaneZone | CylinderZone

#: Zone kinds by their config name.
ZONE_KINDS: dict[str, type[BoxZone] | type[PlaneZone] | type[CylinderZone]] = {
    "box": BoxZone, "plane": PlaneZone, "cylinder": CylinderZone}

#: The table the arm stands on: the half-space below z = 0 of the base frame (the base's
#: underside), margin 0.  On by default (``parolkit.config.Config.zones``).
TABLE_ZONE = PlaneZone("table", point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), margin=0.0)

_ZONE_KEYS = {
    "box": ("name", "kind", "center", "size", "rpy", "margin", "enabled"),
    "plane": ("name", "kind", "point", "normal", "margin", "enabled"),
    "cylinder": ("name", "kind", "center", "axis", "radius", "height", "margin", "enabled"),
}
_ZONE_REQUIRED = {
    "box": ("center", "size"),
    "plane": ("point", "normal"),
    "cylinder": ("center", "axis", "radius", "height"),
}


def zone_from_mapping(spec: Mapping[str, Any], where: str) -> Zone:
    """A zone from one ``[[zones]]`` table (``where`` names it in errors, e.g. ``"[[zones]] #2"``).

    Keys: ``name``, ``kind`` ("box", "plane" or "cylinder"), the kind's own keys (see the
    classes), ``margin`` (default 0) and ``enabled`` (default true).
    """
    if not isinstance(spec, Mapping):
        raise ParolkitValueError(f"{where} must be a table (name = ..., kind = ...), got {spec!r}")
    if "name" not in spec:
        raise ParolkitValueError(f"{where}: name is required (a short label such as \"monitor\")")
    name = _check_name(spec["name"], f"{where}: zone")
    w = f"zones.{name}"
    kind = spec.get("kind")
    if kind not in ZONE_KINDS:
        raise ParolkitValueError(f"{w}.kind must be one of \"box\", \"plane\", \"cylinder\", got {kind!r}")
    allowed = _ZONE_KEYS[kind]
    unknown = sorted(k for k in spec if k not in allowed)
    if unknown:
        raise ParolkitValueError(f"{w}: unknown key{'s' if len(unknown) > 1 else ''} {', '.join(unknown)} "
                                 f"(a {kind} zone has: {', '.join(allowed)})")
    missing = [k for k in _ZONE_REQUIRED[kind] if k not in spec]
    if missing:
        raise ParolkitValueError(f"{w}: a {kind} zone needs {', '.join(missing)} "
                                 f"(it has: {', '.join(allowed)})")
    args = {k: v for k, v in spec.items() if k != "kind"}  # lists become tuples in the classes
    cls: Any = ZONE_KINDS[kind]
    zone: Zone = cls(**args)
    return zone


@dataclass(frozen=True)
class ToolShape:
    """A tool's body: a capsule from ``start`` to ``end`` (mm, flange frame) with ``radius`` mm.

    ``parolkit.config`` fills ``end`` with the tool's TCP when the config leaves it out, and
    ``start`` with the flange origin.  Radius in (0, 500] mm; points within +-1000 mm.
    ``name`` is the tool's name (it names the tool in messages: "tool 'pen' vs zone 'box'").
    """

    name: str
    radius: float
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    end: tuple[float, float, float] = (0.0, 0.0, 0.0)
    kind: ClassVar[str] = "capsule"

    def __post_init__(self) -> None:
        w = f"tools.{self.name}.shape"
        if not isinstance(self.name, str) or not self.name:
            raise ParolkitValueError(f"a tool shape needs the tool's name, got {self.name!r}")
        object.__setattr__(self, "radius", _number(self.radius, f"{w}.radius", 0.0, MAX_SHAPE_RADIUS_MM, "mm",
                                                   open_low=True))
        object.__setattr__(self, "start", _vec3(self.start, f"{w}.start", -MAX_TOOL_POINT_MM, MAX_TOOL_POINT_MM,
                                                "mm"))
        object.__setattr__(self, "end", _vec3(self.end, f"{w}.end", -MAX_TOOL_POINT_MM, MAX_TOOL_POINT_MM, "mm"))


_TOOL_SHAPE_KEYS = ("kind", "radius", "start", "end")


def tool_shape_from_mapping(name: str, spec: object, tcp_mm: Sequence[float]) -> ToolShape:
    """``[tools.NAME] shape = {kind = "capsule", radius = R, start = [...], end = [...]}``:
    ``start`` defaults to the flange origin, ``end`` to the TCP ``tcp_mm`` (the pose's x, y, z)."""
    w = f"tools.{name}.shape"
    if not isinstance(spec, Mapping):
        raise ParolkitValueError(f"{w} must be a table such as {{ kind = \"capsule\", radius = 20 }}, got {spec!r}")
    unknown = sorted(k for k in spec if k not in _TOOL_SHAPE_KEYS)
    if unknown:
        raise ParolkitValueError(f"{w}: unknown key{'s' if len(unknown) > 1 else ''} {', '.join(unknown)} "
                                 f"(a tool shape has: {', '.join(_TOOL_SHAPE_KEYS)})")
    kind = spec.get("kind", "capsule")
    if kind != "capsule":
        raise ParolkitValueError(f"{w}.kind must be \"capsule\" (a capsule from start to end, by default from "
                                 f"the flange to the TCP), got {kind!r}")
    if "radius" not in spec:
        raise ParolkitValueError(f"{w} needs radius (mm): the tool is a capsule from start to end with this radius")
    return ToolShape(name=name, radius=spec["radius"], start=spec.get("start", (0.0, 0.0, 0.0)),
                     end=spec.get("end", tuple(tcp_mm)))


@dataclass(frozen=True)
class Capsule:
    """A held capsule: ``length`` mm between the centres of its end caps (>= 0, along its own z
    axis, centred on its origin) and ``radius`` mm (> 0)."""

    radius: float
    length: float
    kind: ClassVar[str] = "capsule"

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _number(self.radius, "Capsule.radius", 0.0, MAX_SHAPE_RADIUS_MM, "mm",
                                                   open_low=True))
        object.__setattr__(self, "length", _number(self.length, "Capsule.length", 0.0, MAX_SHAPE_LENGTH_MM, "mm",
                                                   open_low=False))

    @classmethod
    def around_box(cls, size: Sequence[float]) -> Capsule:
        """The capsule along z that encloses a box of edge lengths ``size`` (x, y, z mm) centred
        on the origin: radius = half the xy diagonal, length = the z edge, capped by spheres
        that still hold the box's corners (a conservative stand-in for a held box)."""
        sx, sy, sz = _vec3(size, "Capsule.around_box size", 0.0, MAX_SHAPE_LENGTH_MM, "mm", open_low=True)
        return cls(radius=0.5 * math.hypot(sx, sy), length=sz)


@dataclass(frozen=True)
class Sphere:
    """A held sphere of ``radius`` mm (> 0), centred on its origin."""

    radius: float
    kind: ClassVar[str] = "sphere"

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _number(self.radius, "Sphere.radius", 0.0, MAX_SHAPE_RADIUS_MM, "mm",
                                                   open_low=True))


#: A shape that can be attached to the flange.
HeldShape = Capsule | Sphere
