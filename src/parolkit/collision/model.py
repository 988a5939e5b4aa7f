"""The PAROL6's collision model: the base, six link capsules, a tool, held objects, and which
pairs of them are checked for self-collision.

Lengths and joint placements come from :data:`parolkit.robot.PAROL6` (its DH table) through
parolkit's own FK (:func:`parolkit.kinematics.fk_frames`); the thicknesses (capsule radii, the
base's footprint) are an envelope estimated for the stock arm (:class:`ArmEnvelope`): the
PAROL6 sources give no link thicknesses, so measure your arm and pass your own envelope if it
differs.  Units: millimetres in the public types, metres inside.

Bodies (frame = the DH frame the body moves with; 6 is the flange, at the wrist centre):

========  =====  ==================================================================
body      frame  shape
========  =====  ==================================================================
base      0      box on the table, centred on the J1 axis
J1 link   1      capsule along the J1 axis, from the top of the base to the J2 axis
J2 link   2      capsule from the J2 axis to the J3 axis (the upper arm, DH a2)
J3 link   3      capsule from the J3 axis to the forearm's start (DH a3)
J4 link   4      capsule along the forearm to the wrist centre (DH d4)
J5 link   5      capsule along the J5 axis, through the wrist centre
J6 link   6      capsule from the wrist centre along the flange's z (the flange)
tool      6      :class:`parolkit.collision.ToolShape`, from ``[tools.NAME] shape``
held      6      what :meth:`CollisionModel.attach` attached, placed by a pose
========  =====  ==================================================================

Self-collision pairs are computed (:meth:`CollisionModel.pair_table`): every pair of bodies
that do not move together is sampled over :data:`PAIR_SAMPLES` random configurations within
the joint limits (fixed seed :data:`PAIR_SAMPLE_SEED`) plus the 64 corners of the limits; a
pair that is in contact (clearance <= 0) in every sample touches by construction (links
meeting at their joint) and is excluded; every other pair is checked.  The result is cached
per geometry and is the same on every machine.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from parolkit.collision import _reference as ref
from parolkit.collision._geometry import LinkCapsule, PairSpec, Static, pack, rot_abc_deg
from parolkit.collision.shapes import Capsule, HeldShape, Sphere, ToolShape
from parolkit.errors import ParolkitValueError
from parolkit.robot import PAROL6, RobotModel

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    from parolkit.config import ToolSettings

__all__ = ["ArmEnvelope", "BodyRole", "Body", "HeldObject", "PairInfo", "PairTable", "CollisionModel",
           "PAIR_SAMPLES", "PAIR_SAMPLE_SEED", "default_model", "held_object"]

#: Random configurations sampled to find the pairs that always touch (plus the 64 corners).
PAIR_SAMPLES = 20_000
#: Seed of those samples (numpy's default generator): the pair list is the same everywhere.
PAIR_SAMPLE_SEED = 6


@dataclass(frozen=True)
class ArmEnvelope:
    """Thicknesses of the arm's collision shapes, mm: an ESTIMATED envelope of the stock
    PAROL6 (its sources give no link thicknesses), generous rather than tight.  The lengths are
    the DH table's."""

    #: Base box edge lengths x, y, z (z from the table up), centred on the J1 axis.
    base_size: tuple[float, float, float] = (140.0, 140.0, 50.0)
    #: J1 link (the turning column and shoulder, from the base's top to the J2 axis).
    j1_radius: float = 45.0
    #: J2 link (the upper arm).
    j2_radius: float = 35.0
    #: J3 link (the elbow).
    j3_radius: float = 32.0
    #: J4 link (the forearm).
    j4_radius: float = 28.0
    #: J5 link (the wrist housing across the J5 axis): radius and half its width along the axis.
    j5_radius: float = 26.0
    j5_half_width: float = 25.0
    #: J6 link (the flange): radius and length from the wrist centre along the flange's z.
    j6_radius: float = 22.0
    j6_length: float = 30.0

    def __post_init__(self) -> None:
        for name in ("j1_radius", "j2_radius", "j3_radius", "j4_radius", "j5_radius", "j6_radius",
                     "j5_half_width", "j6_length"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 200:
                raise ParolkitValueError(f"ArmEnvelope.{name} must be a number in (0, 200] mm, got {v!r}")
        if len(self.base_size) != 3 or not all(isinstance(v, (int, float)) and 0 < v <= 1000 for v in self.base_size):
            raise ParolkitValueError(f"ArmEnvelope.base_size must be 3 numbers in (0, 1000] mm, got {self.base_size!r}")


class BodyRole(str, Enum):
    """What a body is: the fixed base, a link of the arm, the tool, or a held object."""

    BASE = "base"
    LINK = "link"
    TOOL = "tool"
    HELD = "held"


@dataclass(frozen=True)
class Body:
    """One collision shape, mm, in the DH frame ``frame`` (0 = base .. 6 = flange).

    A capsule: the segment ``start`` -> ``end`` swept by a ball of ``radius``.  The base is a
    box: centre ``start`` (= ``end``), edge lengths ``size``, axes those of the base frame.
    """

    name: str
    role: BodyRole
    frame: int
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float
    size: tuple[float, float, float] | None = None

    @property
    def is_box(self) -> bool:
        return self.size is not None

    def segment(self) -> LinkCapsule:
        """The kernel's capsule (metres)."""
        mm = 1e-3
        return LinkCapsule(self.frame, (self.start[0] * mm, self.start[1] * mm, self.start[2] * mm),
                       (self.end[0] * mm, self.end[1] * mm, self.end[2] * mm), self.radius * mm)


@dataclass(frozen=True)
class HeldObject:
    """An object held at the flange: ``shape`` placed by ``pose`` ``[x, y, z mm, A, B, C deg]``
    (its centre and orientation in the flange frame; a capsule lies along its own z)."""

    name: str
    shape: HeldShape
    pose: tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class PairInfo:
    """One pair of bodies and what the sampling found.

    ``checked``: whether the pair is checked for self-collision; ``reason``: why (or why not),
    in words; ``min_mm`` / ``max_mm``: its smallest and largest clearance over the samples
    (mm; <= 0 is contact); ``contact_fraction``: the share of samples in contact.
    """

    a: str
    b: str
    checked: bool
    reason: str
    min_mm: float
    max_mm: float
    contact_fraction: float

    def __str__(self) -> str:
        return f"{self.a} vs {self.b}: {'checked' if self.checked else 'excluded'} ({self.reason})"


@dataclass(frozen=True)
class PairTable:
    """Every pair of bodies, checked or excluded with the reason, and how that was decided."""

    pairs: tuple[PairInfo, ...]
    samples: int
    seed: int
    method: str

    @property
    def checked(self) -> tuple[PairInfo, ...]:
        return tuple(p for p in self.pairs if p.checked)

    @property
    def excluded(self) -> tuple[PairInfo, ...]:
        return tuple(p for p in self.pairs if not p.checked)


_METHOD = (f"{PAIR_SAMPLES:,} configurations drawn uniformly within the joint limits (numpy default_rng("
           f"{PAIR_SAMPLE_SEED})) plus the 64 corners of the limits; a pair in contact (clearance <= 0) in "
           f"every one is excluded; bodies that move together are excluded without sampling")


def _mm(v: Iterable[float]) -> tuple[float, float, float]:
    x, y, z = (float(c) * 1e3 for c in v)
    return (x + 0.0, y + 0.0, z + 0.0)


def _arm_bodies(robot: RobotModel, env: ArmEnvelope) -> tuple[Body, ...]:
    """The base and the six links, placed with parolkit's FK at the zero configuration."""
    from parolkit.kinematics import fk_frames

    f = fk_frames([0.0] * 6, tool="flange")  # (8, 4, 4), metres: base, frames 1..6 (6 = flange)
    origin = [f[k][:3, 3] for k in range(7)]
    zaxis = [f[k][:3, 2] for k in range(7)]
    d1 = robot.dh[0].d
    base_h = env.base_size[2] * 1e-3
    if not base_h < d1:
        raise ParolkitValueError(f"ArmEnvelope.base_size: the base's height ({env.base_size[2]:g} mm) must be below "
                                 f"the J2 axis ({d1 * 1e3:g} mm): the J1 link stands on the base")

    def local(k: int, world: NDArray[np.float64]) -> tuple[float, float, float]:
        return _mm(f[k][:3, :3].T @ (world - origin[k]))

    def capsule(name: str, k: int, p: NDArray[np.float64], q: NDArray[np.float64], radius: float) -> Body:
        return Body(name, BodyRole.LINK, k, local(k, p), local(k, q), float(radius))

    w5 = env.j5_half_width * 1e-3
    bs = env.base_size
    return (
        Body("base", BodyRole.BASE, 0, (0.0, 0.0, bs[2] / 2), (0.0, 0.0, bs[2] / 2), 0.0,
             size=(float(bs[0]), float(bs[1]), float(bs[2]))),
        capsule("J1 link", 1, np.array([0.0, 0.0, base_h]), np.array([0.0, 0.0, d1]), env.j1_radius),
        capsule("J2 link", 2, origin[1], origin[2], env.j2_radius),
        capsule("J3 link", 3, origin[2], origin[3], env.j3_radius),
        capsule("J4 link", 4, origin[3], origin[4], env.j4_radius),
        capsule("J5 link", 5, origin[5] - w5 * zaxis[4], origin[5] + w5 * zaxis[4], env.j5_radius),
        capsule("J6 link", 6, origin[6], origin[6] + env.j6_length * 1e-3 * zaxis[6], env.j6_radius),
    )


def held_object(name: str, start: Sequence[float], end: Sequence[float], radius: float,
                kind: str = "capsule") -> HeldObject:
    """A held object given as ``ATTACH`` and ``GET_ZONES`` give it (docs/protocol.md): a
    ``kind`` "capsule" whose axis runs from ``start`` to ``end``, or a "sphere" centred on
    ``start`` (``end`` ignored); points in mm in the flange frame, ``radius`` mm.

    The capsule is centred between its points with its own z axis along them: pose angles
    ``A = 0, B = asin(dz_x), C = atan2(-dz_y, dz_z)`` of ``R = Rx(C) Ry(B) Rz(A)`` (the unit
    direction ``dz``), so :func:`held_body` gives back the same two points.  Points that
    coincide make a capsule of length 0 (a sphere).  Pure: no model is changed."""
    p = tuple(float(v) for v in start)
    if kind == "sphere":
        return HeldObject(name, Sphere(radius), (p[0], p[1], p[2], 0.0, 0.0, 0.0))
    if kind != "capsule":
        raise ParolkitValueError(f"held object {name!r}: kind must be \"capsule\" or \"sphere\", got {kind!r}")
    q = tuple(float(v) for v in end)
    if len(p) != 3 or len(q) != 3:
        raise ParolkitValueError(f"held object {name!r}: start and end must be 3 numbers (mm), got {start!r}, {end!r}")
    d = [b - a for a, b in zip(p, q)]
    length = math.sqrt(sum(v * v for v in d))
    mid = [(a + b) / 2.0 for a, b in zip(p, q)]
    b_deg = c_deg = 0.0
    if length > 0.0:
        ux, uy, uz = (v / length for v in d)
        b_deg = math.degrees(math.asin(max(-1.0, min(1.0, ux))))
        if abs(ux) < 1.0 - 1e-12:
            c_deg = math.degrees(math.atan2(-uy, uz))
    return HeldObject(name, Capsule(radius, length), (mid[0], mid[1], mid[2], 0.0, b_deg, c_deg))


def tool_body(tool: ToolShape | ToolSettings | None) -> Body | None:
    """The tool's body (None: no tool geometry), from a :class:`ToolShape` or a config tool."""
    if tool is None:
        return None
    if isinstance(tool, ToolShape):
        shape: ToolShape | None = tool
    else:
        from parolkit.config import ToolSettings

        if not isinstance(tool, ToolSettings):
            raise ParolkitValueError(f"tool must be a ToolShape, a config tool (ToolSettings) or None, got {tool!r} "
                                     f"(a kinematics Tool has no shape: give its config entry a shape)")
        shape = tool.shape
    if shape is None:
        return None
    return Body(f"tool '{shape.name}'", BodyRole.TOOL, 6, shape.start, shape.end, shape.radius)


def held_body(obj: HeldObject) -> Body:
    """The body of a held object: its capsule's axis (or the sphere's centre) in the flange frame."""
    x, y, z, a, b, c = obj.pose
    rot = rot_abc_deg((a, b, c))
    half = obj.shape.length / 2 if isinstance(obj.shape, Capsule) else 0.0
    centre = np.array([x, y, z])
    p = centre - half * rot[:, 2]
    q = centre + half * rot[:, 2]
    return Body(f"held '{obj.name}'", BodyRole.HELD, 6, (float(p[0]), float(p[1]), float(p[2])),
                (float(q[0]), float(q[1]), float(q[2])), obj.shape.radius)


def _base_static(body: Body) -> Static:
    assert body.size is not None
    c = tuple(v * 1e-3 for v in body.start)
    e = tuple(v * 0.5e-3 for v in body.size)
    return Static(ref.BOX, (c[0], c[1], c[2]), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (e[0], e[1], e[2]))


def _sample_configs(robot: RobotModel) -> NDArray[np.float64]:
    lim = np.radians(robot.safe_limits_deg)
    rng = np.random.default_rng(PAIR_SAMPLE_SEED)
    qs = rng.uniform(lim[:, 0], lim[:, 1], size=(PAIR_SAMPLES, 6))
    corners = np.array(list(itertools.product(*[(lo, hi) for lo, hi in lim])))
    return np.vstack([qs, corners])


@functools.lru_cache(maxsize=64)
def _sampled_pairs(robot: RobotModel, bodies: tuple[Body, ...], candidates: tuple[tuple[int, int], ...],
                   ) -> tuple[tuple[float, float, float], ...]:
    """(min, max, contact fraction) of each candidate pair's clearance (mm) over the samples.
    ``bodies[0]`` is the base box; the others are capsules."""
    segs = [b.segment() for b in bodies]
    statics = [_base_static(bodies[0])]
    specs = []
    for i, j in candidates:
        if i == 0:
            specs.append(PairSpec(ref.CAP_STATIC, j, 0, ref.SELF, 0.0, (0.0,) * 6))
        else:
            specs.append(PairSpec(ref.CAP_CAP, i, j, ref.SELF, 0.0, (0.0,) * 6))
    packed = pack(robot, segs, statics, specs, 1e-5, 1)
    qs = _sample_configs(robot)
    out = []
    d_all = np.empty((qs.shape[0], len(specs)))
    from parolkit.collision._kernel import ccollide as _ccollide

    if _ccollide is not None:  # the same values as the reference to ~1e-13 mm (a decision is made at 0)
        d_all = np.empty((qs.shape[0], len(specs)))
        _ccollide.distances(packed, qs, d_all, np.empty((*d_all.shape, 3)), np.empty((*d_all.shape, 3)))
    else:
        u = ref.unpack(packed)
        for lo in range(0, qs.shape[0], 4096):  # in slices: the box bisection holds (n, pairs, 3) arrays
            d_all[lo:lo + 4096] = ref.pair_distances(u, qs[lo:lo + 4096])[0]
    d_all *= 1e3
    for k in range(len(specs)):
        d = d_all[:, k]
        out.append((float(d.min()), float(d.max()), float(np.mean(d <= 0.0))))
    return tuple(out)


class CollisionModel:
    """The arm's collision bodies and the objects it holds.

    ``robot``: the robot model (its joint limits bound the pair sampling); ``envelope``: the
    thicknesses (:class:`ArmEnvelope`); ``self_margin``: mm, a self-collision pair closer than
    this counts as a violation (default 0: only contact).

    :meth:`attach` / :meth:`detach` change the held objects (what a
    :class:`parolkit.collision.Scene` and :func:`parolkit.collision.check` use when they are
    not given ``held``).  Everything else is
    fixed at construction.
    """

    def __init__(self, robot: RobotModel = PAROL6, envelope: ArmEnvelope | None = None, *,
                 self_margin: float = 0.0) -> None:
        if isinstance(self_margin, bool) or not isinstance(self_margin, (int, float)) \
                or not 0.0 <= self_margin <= 100.0:
            raise ParolkitValueError(f"self_margin must be a number in [0, 100] mm, got {self_margin!r}")
        self.robot = robot
        self.envelope = envelope or ArmEnvelope()
        self.self_margin = float(self_margin)
        self.bodies: tuple[Body, ...] = _arm_bodies(robot, self.envelope)
        self._held: tuple[HeldObject, ...] = ()
        #: bumped by attach/detach, so cached scenes notice
        self.version = 0

    def __repr__(self) -> str:
        return f"CollisionModel(bodies={[b.name for b in self.bodies]}, held={[h.name for h in self._held]})"

    # ---- held objects ----

    @property
    def held(self) -> tuple[HeldObject, ...]:
        """The objects attached to the flange now."""
        return self._held

    def attach(self, shape: HeldShape, pose: Sequence[float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
               name: str = "object") -> HeldObject:
        """Attach ``shape`` (:class:`Capsule` or :class:`Sphere`) to the flange at ``pose``
        ``[x, y, z mm, A, B, C deg]`` (its centre in the flange frame; a capsule along its own
        z).  A held object of the same name is replaced.  Returns the :class:`HeldObject`."""
        if not isinstance(shape, (Capsule, Sphere)):
            raise ParolkitValueError(f"attach(): shape must be a Capsule or a Sphere (a box is held as "
                                     f"Capsule.around_box(size)), got {shape!r}")
        if isinstance(pose, (str, bytes)) or not isinstance(pose, Sequence) or len(pose) != 6 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pose):
            raise ParolkitValueError(f"attach(): pose must be 6 finite numbers [x, y, z mm, A, B, C deg], got {pose!r}")
        for i, v in enumerate(pose):
            hi, unit = (1000.0, "mm") if i < 3 else (360.0, "deg")
            if not -hi <= v <= hi:
                raise ParolkitValueError(f"attach(): pose {'xyzABC'[i]} = {v:g} {unit} is out of range "
                                         f"[{-hi:g}, {hi:g}] {unit}")
        from parolkit.collision.shapes import _check_name

        _check_name(name, "held object")
        p = tuple(float(v) for v in pose)
        obj = HeldObject(name, shape, (p[0], p[1], p[2], p[3], p[4], p[5]))
        self._held = tuple(h for h in self._held if h.name != name) + (obj,)
        self.version += 1
        return obj

    def detach(self, name: str | None = None) -> tuple[HeldObject, ...]:
        """Detach the held object ``name`` (None: all of them); returns what was detached.  An
        unknown name raises :class:`ParolkitValueError` naming the held ones."""
        if name is None:
            gone, self._held = self._held, ()
        else:
            gone = tuple(h for h in self._held if h.name == name)
            if not gone:
                known = ", ".join(repr(h.name) for h in self._held) or "nothing is held"
                raise ParolkitValueError(f"detach(): no held object named {name!r} ({known})")
            self._held = tuple(h for h in self._held if h.name != name)
        if gone:
            self.version += 1
        return gone

    # ---- pairs ----

    def all_bodies(self, tool: ToolShape | ToolSettings | None = None,
                   held: Sequence[HeldObject] | None = None) -> tuple[Body, ...]:
        """The arm's bodies, then the tool's (if it has a shape), then the held objects'."""
        extra = [b for b in (tool_body(tool),) if b is not None]
        extra += [held_body(h) for h in (self._held if held is None else held)]
        return self.bodies + tuple(extra)

    def pair_table(self, tool: ToolShape | ToolSettings | None = None,
                   held: Sequence[HeldObject] | None = None) -> PairTable:
        """Every pair of bodies (the arm's, the tool's, the held objects'), which ones are
        checked for self-collision and why (module docstring).  Cached per geometry."""
        bodies = self.all_bodies(tool, held)
        return _pair_table(self.robot, bodies)


@functools.lru_cache(maxsize=64)
def _pair_table(robot: RobotModel, bodies: tuple[Body, ...]) -> PairTable:
    n = len(bodies)
    candidates: list[tuple[int, int]] = []
    fixed: dict[tuple[int, int], str] = {}
    for i in range(n):
        for j in range(i + 1, n):
            fi, fj = bodies[i].frame, bodies[j].frame
            if fi == fj:
                fixed[(i, j)] = (f"they move together (both on {'the base' if fi == 0 else f'frame {fi}'}): their "
                                 f"distance never changes")
            else:
                candidates.append((i, j))
    # the arm's own pairs are the same whatever it holds: sampled (and cached) apart from each
    # added body's pairs with the arm
    arm = tuple(b for b in bodies if b.role in (BodyRole.BASE, BodyRole.LINK))
    stats: dict[tuple[int, int], tuple[float, float, float]] = {}
    groups: dict[int, list[tuple[int, int]]] = {}
    for i, j in candidates:
        groups.setdefault(j if j >= len(arm) else -1, []).append((i, j))
    for key, group in groups.items():
        if key == -1:
            stats.update(zip(group, _sampled_pairs(robot, arm, tuple(group))))
        else:  # body ``key`` against arm bodies: renumber it as the last body of arm + (it,)
            local = tuple((i, len(arm)) for i, _ in group)
            stats.update(zip(group, _sampled_pairs(robot, arm + (bodies[key],), local)))
    total = PAIR_SAMPLES + 64
    infos = []
    for i in range(n):
        for j in range(i + 1, n):
            a, b = bodies[i].name, bodies[j].name
            if (i, j) in fixed:
                infos.append(PairInfo(a, b, False, fixed[(i, j)], math.nan, math.nan, math.nan))
                continue
            lo, hi, frac = stats[(i, j)]
            if hi <= 0.0:
                reason = (f"in contact in all {total:,} sampled configurations (clearance {lo:.1f} .. {hi:.1f} mm): "
                          f"they meet at a joint")
                infos.append(PairInfo(a, b, False, reason, lo, hi, frac))
            else:
                reason = (f"apart in {100 * (1 - frac):.2f} % of {total:,} samples, closest {lo:.1f} mm"
                          + (f", in contact in {100 * frac:.2f} %" if frac > 0 else ""))
                infos.append(PairInfo(a, b, True, reason, lo, hi, frac))
    return PairTable(tuple(infos), total, PAIR_SAMPLE_SEED, _METHOD)


@functools.lru_cache(maxsize=1)
def default_model() -> CollisionModel:
    """The stock PAROL6's model (shared: do not attach to it; make your own CollisionModel
    for held objects)."""
    return CollisionModel()
