"""What the 3D view draws of the collision world: keep-out zones, the tool's shape and the
objects held at the flange, as plain primitives (no NiceGUI here: tested without a browser).

The world comes from the controller (``GET_ZONES`` through the client: :class:`ZoneInfo`,
:class:`ToolShapeInfo`, :class:`HeldInfo`, mm and degrees).  Every primitive is in scene
units (:data:`parolkit.gui.geometry.SCENE_SCALE` per metre: 1 unit = 100 mm):

* a **box** zone: a translucent box at its centre, turned by its ``rpy``
  (``R = Rz(yaw) Ry(pitch) Rx(roll)``), and its margin as a faint wire box ``margin`` larger
  on every side;
* a **cylinder** zone: a translucent cylinder along its axis, the margin a wire cylinder
  ``margin`` wider and longer at each end;
* a **plane** zone (a half-space): a large translucent square on the plane (centred where the
  plane is nearest the middle of the arm's reach, :data:`PLANE_ANCHOR_MM`), a darker slab on
  its forbidden side, a line along the normal (pointing out of the forbidden side) and the
  margin as a wire square ``margin`` in front of it;
* each zone's name as a label;
* the tool's shape and held objects: capsules (a cylinder and two end spheres) or spheres in
  the flange frame, translucent.

Margins of 0 draw no outline.  The ``owner`` of each primitive is the collision check's name
of the body it stands for (``zone 'monitor'``, ``tool 'pen'``, ``held 'ball'``), so the view
colours what is within a margin (:mod:`parolkit.gui.collision`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from parolkit.client.core import HeldInfo, ToolShapeInfo, ZoneInfo
from parolkit.gui.geometry import SCENE_SCALE, rotation_y_to

__all__ = [
    "Shape", "zone_shapes", "attached_shapes", "tool_shapes", "held_shapes", "rot_rpy", "frame_with_z",
    "ZONE_COLOUR", "MARGIN_COLOUR", "FORBIDDEN_COLOUR", "ATTACHED_COLOUR", "COLLISION_RED", "PLANE_SIZE_MM",
    "PLANE_ANCHOR_MM", "MM",
]

#: scene units per millimetre
MM = SCENE_SCALE / 1000.0
#: a zone's body, its margin outline, a plane's forbidden side, the tool's and held objects' shapes
ZONE_COLOUR = "#f59e0b"
MARGIN_COLOUR = "#fcd34d"
FORBIDDEN_COLOUR = "#b45309"
ATTACHED_COLOUR = "#38bdf8"
#: a body (link, tool, held object) within its margin, and the margin outline of the zone it is in
COLLISION_RED = "#ef4444"
#: the side of the square a plane is drawn as, mm
PLANE_SIZE_MM = 1200.0
#: a plane is drawn centred on the point of the plane nearest this point (mm, base frame): the
#: middle of the arm's reach, so a table is drawn under the base and a wall beside the arm
PLANE_ANCHOR_MM = (0.0, 0.0, 250.0)
#: the thickness of a plane's square and the depth of its forbidden-side slab, mm
_QUAD_MM = 0.5
_SLAB_MM = 40.0
#: the length of a plane's normal line, mm
_NORMAL_MM = 120.0
#: a label's look: white on a dark chip (readable over any background: axe-core checks it)
LABEL_STYLE = ("color:#ffffff;background:rgba(15,23,42,0.85);padding:0 4px;border-radius:3px;"
               "font:11px/1.4 ui-monospace,monospace;white-space:nowrap;pointer-events:none")

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]
_EYE: Mat3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@dataclass(frozen=True)
class Shape:
    """One primitive to draw, scene units.

    ``kind``: "box" (``args`` width, height, depth along its own x, y, z), "cylinder" (radius,
    height along its own y: three.js's axis), "sphere" (radius), "line" (start and end, relative
    to ``position``) or "text" (the label).  ``position`` and ``rotation`` (3x3, rows) place it;
    ``owner`` names the body it stands for; ``part``: "body", "margin", "forbidden", "normal",
    "label".
    """

    owner: str
    part: str
    kind: str
    args: tuple[float, ...] | tuple[Vec3, Vec3] | tuple[str, str]
    position: Vec3
    rotation: Mat3 = _EYE
    color: str = ZONE_COLOUR
    opacity: float = 1.0
    wireframe: bool = False


def _v(a: Sequence[float]) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


def _scaled(p: Sequence[float]) -> Vec3:
    return (p[0] * MM, p[1] * MM, p[2] * MM)


def _add(a: Sequence[float], b: Sequence[float], s: float = 1.0) -> Vec3:
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2])


def _dot(a: Sequence[float], b: Sequence[float]) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _unit(a: Sequence[float]) -> Vec3:
    n = math.sqrt(_dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def _cross(a: Sequence[float], b: Sequence[float]) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def rot_rpy(rpy: Sequence[float]) -> Mat3:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` for ``rpy = (roll, pitch, yaw)`` in degrees (a box zone's
    ``rpy``, as URDF and the collision check), rows."""
    r, p, y = (math.radians(float(v)) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return ((cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
            (sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
            (-sp, cp * sr, cp * cr))


def frame_with_z(axis: Sequence[float]) -> Mat3:
    """A rotation (rows) whose third column is the unit vector along ``axis``."""
    z = _unit(axis)
    helper = (1.0, 0.0, 0.0) if abs(z[0]) < 0.9 else (0.0, 1.0, 0.0)
    x = _unit(_add(helper, z, -_dot(helper, z)))
    y = _cross(z, x)
    return ((x[0], y[0], z[0]), (x[1], y[1], z[1]), (x[2], y[2], z[2]))


def _label(owner: str, text: str, at_mm: Sequence[float]) -> Shape:
    return Shape(owner, "label", "text", (text, LABEL_STYLE), _scaled(at_mm))


def zone_shapes(zone: ZoneInfo) -> list[Shape]:
    """The primitives of one keep-out zone (module docstring), its body first."""
    owner = f"zone '{zone.name}'"
    m = float(zone.margin)
    out: list[Shape] = []
    if zone.kind == "box" and zone.center is not None and zone.size is not None:
        rot = rot_rpy(zone.rpy or (0.0, 0.0, 0.0))
        c = _scaled(zone.center)
        sx, sy, sz = zone.size
        out.append(Shape(owner, "body", "box", (sx * MM, sy * MM, sz * MM), c, rot, ZONE_COLOUR, 0.3))
        if m > 0:
            out.append(Shape(owner, "margin", "box", ((sx + 2 * m) * MM, (sy + 2 * m) * MM, (sz + 2 * m) * MM), c, rot,
                             MARGIN_COLOUR, 0.45, wireframe=True))
        top = 0.5 * math.sqrt(sx * sx + sy * sy + sz * sz) + m + 15.0
        out.append(_label(owner, zone.name, _add(zone.center, (0.0, 0.0, top))))
    elif zone.kind == "cylinder" and zone.center is not None and zone.axis is not None \
            and zone.radius is not None and zone.height is not None:
        axis_rot = _rows(rotation_y_to(zone.axis))
        c = _scaled(zone.center)
        r, h = float(zone.radius), float(zone.height)
        out.append(Shape(owner, "body", "cylinder", (r * MM, h * MM), c, axis_rot, ZONE_COLOUR, 0.3))
        if m > 0:
            out.append(Shape(owner, "margin", "cylinder", ((r + m) * MM, (h + 2 * m) * MM), c, axis_rot,
                             MARGIN_COLOUR, 0.45, wireframe=True))
        a = _unit(zone.axis)
        tip = _add(zone.center, a, 0.5 * h + m + 15.0) if a[2] >= 0 else _add(zone.center, a, -(0.5 * h + m + 15.0))
        out.append(_label(owner, zone.name, tip))
    elif zone.kind == "plane" and zone.point is not None and zone.normal is not None:
        n = _unit(zone.normal)
        p = _v(zone.point)
        # the point of the plane nearest the anchor
        foot = _add(PLANE_ANCHOR_MM, n, -_dot(_add(PLANE_ANCHOR_MM, p, -1.0), n))
        rot = frame_with_z(n)
        w = PLANE_SIZE_MM * MM
        out.append(Shape(owner, "body", "box", (w, w, _QUAD_MM * MM), _scaled(foot), rot, ZONE_COLOUR, 0.08))
        out.append(Shape(owner, "forbidden", "box", (w, w, _SLAB_MM * MM), _scaled(_add(foot, n, -_SLAB_MM / 2)), rot,
                         FORBIDDEN_COLOUR, 0.1))
        out.append(Shape(owner, "normal", "line", ((0.0, 0.0, 0.0), _scaled(_add((0.0, 0.0, 0.0), n, _NORMAL_MM))),
                         _scaled(foot), _EYE, ZONE_COLOUR, 0.9))
        if m > 0:
            out.append(Shape(owner, "margin", "box", (w, w, _QUAD_MM * MM), _scaled(_add(foot, n, m)), rot,
                             MARGIN_COLOUR, 0.45, wireframe=True))
        # the label near a corner of the square, just off the plane on the allowed side
        u = (rot[0][0], rot[1][0], rot[2][0])
        v = (rot[0][1], rot[1][1], rot[2][1])
        corner = _add(_add(_add(foot, u, 0.42 * PLANE_SIZE_MM), v, 0.42 * PLANE_SIZE_MM), n, 10.0)
        out.append(_label(owner, zone.name, corner))
    return out


def _rows(m: Sequence[Sequence[float]]) -> Mat3:
    return (_v(m[0]), _v(m[1]), _v(m[2]))


def attached_shapes(owner: str, start_mm: Sequence[float], end_mm: Sequence[float], radius_mm: float,
                    sphere: bool = False) -> list[Shape]:
    """A capsule from ``start_mm`` to ``end_mm`` (or a sphere at ``start_mm``) with ``radius_mm``,
    in the flange frame: a cylinder and a sphere at each end, translucent."""
    r = float(radius_mm) * MM
    a = _scaled(start_mm)
    if sphere:
        return [Shape(owner, "body", "sphere", (r,), a, _EYE, ATTACHED_COLOUR, 0.5)]
    b = _scaled(end_mm)
    d = _add(b, a, -1.0)
    length = math.sqrt(_dot(d, d))
    out = [Shape(owner, "body", "sphere", (r,), a, _EYE, ATTACHED_COLOUR, 0.5)]
    if length > 1e-9:
        mid = _add(a, d, 0.5)
        out.append(Shape(owner, "body", "cylinder", (r, length), mid, _rows(rotation_y_to(d)), ATTACHED_COLOUR, 0.5))
        out.append(Shape(owner, "body", "sphere", (r,), b, _EYE, ATTACHED_COLOUR, 0.5))
    return out


def tool_shapes(tool_name: str, shape: ToolShapeInfo | None) -> list[Shape]:
    """The tool's body (None: it has none), in the flange frame; owner ``tool 'NAME'``."""
    if shape is None:
        return []
    return attached_shapes(f"tool '{tool_name}'", shape.start, shape.end, shape.radius)


def held_shapes(held: Sequence[HeldInfo]) -> list[Shape]:
    """The objects held at the flange, in the flange frame; owner ``held 'NAME'``."""
    out: list[Shape] = []
    for h in held:
        out += attached_shapes(f"held '{h.name}'", h.start, h.end, h.radius, sphere=h.kind == "sphere")
    return out
