"""Collision queries: one pose, a swept move between two poses, a trajectory's samples.

Units: joint vectors in RADIANS (``q``: 6 values, ``qs``: an (N, 6) array), distances and
margins in millimetres.  A :class:`Scene` is the arm, its tool, what it holds and the zones,
compiled once for the kernel; :func:`check`, :func:`check_swept` and :func:`check_path` build
(and cache) one for you.

Distances are clearances: the exact distance between two shapes when they are apart; <= 0
when they touch or overlap.  A pair is *within its margin* when its clearance is <= its
margin (a zone's ``margin``; :attr:`CollisionModel.self_margin` for self pairs); a verdict is
*clear* when no pair is.

The swept check (:meth:`Scene.check_swept`, :meth:`Scene.check_path` with ``swept=True``)
covers every pose on the straight joint-space segments between the samples, not only the
samples: a pair's clearance cannot shrink faster than its shapes can move toward each other,
which is bounded by the joint steps times lever arms taken from the link lengths
(:func:`parolkit.collision._geometry.pair_lipschitz`).  Each pair is evaluated again only where
that bound no longer proves it clear (conservative advancement).  Guarantee: if the sweep
says clear, no pose on the segments brings any pair within its margin.  If it reports a
violation between samples, the pose it names has that pair within its margin + ``tau_mm``
(0.01 mm by default); at a sample, within its margin.

The compiled kernel (``_ccollide.c``) runs when it is built; the numpy reference
(:mod:`parolkit.collision._reference`) otherwise or with ``PAROLKIT_PURE_PYTHON=1``.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np

from parolkit.collision import _reference as ref
from parolkit.collision._geometry import PairSpec, Static, frame_with_z, pack, pair_lipschitz, rot_rpy_deg
from parolkit.collision._kernel import ccollide as _ccollide
from parolkit.collision._kernel import kernel_name
from parolkit.collision.model import Body, BodyRole, CollisionModel, HeldObject, PairTable, default_model
from parolkit.collision.shapes import BoxZone, CylinderZone, PlaneZone, ToolShape
from parolkit.errors import ParolkitValueError
from parolkit.robot import as_joint_array

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    from parolkit.collision.shapes import Zone
    from parolkit.config import ToolSettings

__all__ = ["PairKind", "Pair", "PairDistance", "Verdict", "PathVerdict", "Scene", "check", "check_swept",
           "check_path", "kernel_name"]

#: Most capsules a scene may hold (the C kernel's fixed-size tables).
_MAX_BODIES = 256
#: Default tolerance of the sweep between samples, mm (see the module docstring).
TAU_MM = 0.01
#: The sweep gives up (and reports a violation it could not rule out) after this many
#: evaluations of one path: only a path that grazes a margin for a long way gets near it.
MAX_EVALUATIONS = 2_000_000


class PairKind(str, Enum):
    """Which check a pair belongs to."""

    SELF = "self"             # two bodies of the arm (with its tool and held objects)
    ARM_ZONE = "arm-zone"     # a link of the arm vs a zone
    ATTACHED_ZONE = "attached-zone"  # the tool or a held object vs a zone


_KINDS = (PairKind.SELF, PairKind.ARM_ZONE, PairKind.ATTACHED_ZONE)


@dataclass(frozen=True)
class Pair:
    """Two things that must not touch, by name: ``"J2 link vs J5 link"``, ``"J5 link vs zone 'monitor'"``."""

    a: str
    b: str
    kind: PairKind
    margin_mm: float

    def __str__(self) -> str:
        return f"{self.a} vs {self.b}"


@dataclass(frozen=True, slots=True)
class PairDistance:
    """A pair and its clearance, mm (<= 0: touching)."""

    pair: Pair
    distance_mm: float

    @property
    def margin_mm(self) -> float:
        return self.pair.margin_mm

    @property
    def within_margin(self) -> bool:
        """Clearance <= margin: a violation."""
        return self.distance_mm <= self.pair.margin_mm

    @property
    def contact(self) -> bool:
        return self.distance_mm <= 0.0

    def __str__(self) -> str:
        m = self.pair.margin_mm
        return f"{self.pair}: {self.distance_mm:.1f} mm" + (f" (margin {m:g} mm)" if m else "")


@dataclass(frozen=True, slots=True)
class Verdict:
    """The collision state of one pose.

    ``self_closest``: the closest checked self pair; ``zone_closest``: the closest link vs
    zone pair; ``attached_closest``: the closest tool or held object vs zone pair (None when
    there is no such pair); ``worst``: the pair whose clearance is smallest relative to its
    margin (clearance - margin), None when nothing is checked.  ``clear``: no pair is within
    its margin.
    """

    self_closest: PairDistance | None
    zone_closest: PairDistance | None
    attached_closest: PairDistance | None
    worst: PairDistance | None

    @property
    def clear(self) -> bool:
        w = self.worst
        return w is None or w.distance_mm > w.pair.margin_mm

    @property
    def violation(self) -> PairDistance | None:
        """The worst pair when it is within its margin, else None."""
        return None if self.clear else self.worst

    @property
    def closest(self) -> PairDistance | None:
        """The smallest clearance of all."""
        found = [p for p in (self.self_closest, self.zone_closest, self.attached_closest) if p is not None]
        return min(found, key=lambda p: p.distance_mm) if found else None

    def __str__(self) -> str:
        if self.clear:
            c = self.closest
            return "clear" + (f" (closest: {c})" if c else "")
        return f"within margin: {self.worst}"


class PathStatus(str, Enum):
    CLEAR = "clear"
    AT_SAMPLE = "at sample"
    BETWEEN_SAMPLES = "between samples"
    NOT_PROVEN = "not proven"  # the sweep ran out of evaluations: treated as a violation


@dataclass(frozen=True)
class PathVerdict:
    """The first violation along a trajectory, or clear.

    ``index``: the sample that violates (``status`` AT_SAMPLE), or the last sample before the
    violating pose (BETWEEN_SAMPLES, at ``fraction`` of the way to the next one; NOT_PROVEN);
    None when clear.  ``position`` = index + fraction, so the time into the move is
    ``position * dt``.  ``pair``: the pair within its margin and its clearance there (mm).
    ``evaluations``: poses the kernel evaluated.
    """

    status: PathStatus
    index: int | None
    fraction: float
    pair: PairDistance | None
    evaluations: int

    @property
    def clear(self) -> bool:
        return self.status is PathStatus.CLEAR

    @property
    def position(self) -> float | None:
        return None if self.index is None else self.index + self.fraction

    def __str__(self) -> str:
        if self.clear:
            return "clear"
        if self.status is PathStatus.AT_SAMPLE:
            return f"sample {self.index}: {self.pair}"
        if self.status is PathStatus.NOT_PROVEN:
            return (f"not proven clear after {self.evaluations} evaluations, near sample {self.index} + "
                    f"{self.fraction:.3f}: {self.pair.pair if self.pair else ''}")
        return f"between samples {self.index} and {self.index + 1 if self.index is not None else ''} " \
               f"(at {self.fraction:.3f}): {self.pair}"


def _zone_static(z: Zone) -> Static:
    mm = 1e-3
    if isinstance(z, PlaneZone):
        n = np.asarray(z.normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        c = tuple(v * mm for v in z.point)
        return Static(ref.PLANE, (c[0], c[1], c[2]), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
                      (float(n[0]), float(n[1]), float(n[2])))
    if isinstance(z, BoxZone):
        r = rot_rpy_deg(z.rpy)
        c = tuple(v * mm for v in z.center)
        e = tuple(v * 0.5 * mm for v in z.size)
        return Static(ref.BOX, (c[0], c[1], c[2]), tuple(float(v) for v in r.ravel()), (e[0], e[1], e[2]))
    if isinstance(z, CylinderZone):
        r = frame_with_z(z.axis)
        c = tuple(v * mm for v in z.center)
        return Static(ref.CYLINDER, (c[0], c[1], c[2]), tuple(float(v) for v in r.ravel()),
                      (z.radius * mm, z.height * 0.5 * mm, 0.0))
    raise ParolkitValueError(f"zones must be BoxZone, PlaneZone or CylinderZone objects, got {z!r}")


def _q6(q: object, name: str) -> NDArray[np.float64]:
    return as_joint_array(q, name, allow_batch=False)


class Scene:
    """The arm (``model``), a tool, held objects and zones, compiled for the kernel.

    Build one per combination and keep it (a scene is immutable; building one samples the
    self-collision pairs of a new tool or held object, ~10-100 ms, cached).  ``tau_mm``: the
    sweep's tolerance (module docstring).

    Attributes: ``bodies`` (all collision bodies, in kernel order), ``zones`` (the enabled
    zones), ``pairs`` (every pair checked, in kernel order), ``pair_table`` (the self pairs and
    why each is checked or not).
    """

    def __init__(self, model: CollisionModel | None = None, zones: Iterable[Zone] = (),
                 tool: ToolShape | ToolSettings | None = None, held: Sequence[HeldObject] | None = None,
                 *, tau_mm: float = TAU_MM, max_evaluations: int = MAX_EVALUATIONS) -> None:
        model = model or default_model()
        self.model = model
        held_t = tuple(model.held if held is None else held)
        zones_t = tuple(z for z in zones if z.enabled)
        names = [z.name for z in zones_t]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ParolkitValueError(f"zone names must be unique, {', '.join(repr(n) for n in dup)} given twice")
        if not 0.0 < tau_mm <= 10.0:
            raise ParolkitValueError(f"tau_mm must be in (0, 10] mm, got {tau_mm!r}")
        self.zones: tuple[Zone, ...] = zones_t
        self.bodies: tuple[Body, ...] = model.all_bodies(tool, held_t)
        self.pair_table: PairTable = model.pair_table(tool, held_t)
        self.tau_mm = float(tau_mm)

        # kernel bodies: every capsule (the base box is static 0); statics: base, then zones
        caps = [b for b in self.bodies if not b.is_box]
        if len(caps) > _MAX_BODIES:
            raise ParolkitValueError(f"a scene holds at most {_MAX_BODIES} capsules (the arm's 6 links, a tool and "
                                     f"held objects), got {len(caps)}")
        cap_index = {b.name: k for k, b in enumerate(caps)}
        segs = [b.segment() for b in caps]
        base = self.bodies[0]
        statics = [_base_static_of(base)] + [_zone_static(z) for z in zones_t]
        dh = _dh(model)
        specs: list[PairSpec] = []
        pairs: list[Pair] = []
        self_margin_m = model.self_margin * 1e-3
        checked = {(p.a, p.b) for p in self.pair_table.checked}
        for a, b in sorted(checked, key=lambda ab: (_order(self.bodies, ab[0]), _order(self.bodies, ab[1]))):
            if a == base.name:
                j = cap_index[b]
                specs.append(PairSpec(ref.CAP_STATIC, j, 0, ref.SELF, self_margin_m,
                                      pair_lipschitz(dh, segs[j], None)))
            else:
                i, j = cap_index[a], cap_index[b]
                specs.append(PairSpec(ref.CAP_CAP, i, j, ref.SELF, self_margin_m,
                                      pair_lipschitz(dh, segs[j], segs[i]) if segs[j].frame >= segs[i].frame
                                      else pair_lipschitz(dh, segs[i], segs[j])))
            pairs.append(Pair(a, b, PairKind.SELF, model.self_margin))
        n_self = len(pairs)
        zone_of: list[Zone] = []
        for zi, z in enumerate(zones_t):
            for k, body in enumerate(caps):
                cat = ref.ARM_ZONE if body.role is BodyRole.LINK else ref.ATTACHED_ZONE
                specs.append(PairSpec(ref.CAP_STATIC, k, zi + 1, cat, z.margin * 1e-3,
                                      pair_lipschitz(dh, segs[k], None)))
                pairs.append(Pair(body.name, f"zone '{z.name}'",
                                  PairKind.ARM_ZONE if cat == ref.ARM_ZONE else PairKind.ATTACHED_ZONE, z.margin))
                zone_of.append(z)
        #: link vs zone pairs whose clearance no joint can change (mm, from the scene's build):
        #: not checked (the J1 link turns about its own axis: its clearance to the table plane
        #: is the same at every pose; a margin it is within would refuse every pose, a zone it
        #: touches makes the scene an error)
        self.fixed_pairs: tuple[PairDistance, ...] = ()
        fixed = _fixed_zone_pairs(model, segs, statics, specs, pairs, n_self, caps)
        if fixed:
            for k, dist in fixed.items():
                if dist <= 0.0:
                    raise ParolkitValueError(
                        f"zone '{zone_of[k - n_self].name}' overlaps the {pairs[k].a} ({-dist:.1f} mm deep) at every "
                        "pose: the arm stands in it; move the zone")
            self.fixed_pairs = tuple(PairDistance(pairs[k], d) for k, d in fixed.items())
            specs = [sp for k, sp in enumerate(specs) if k not in fixed]
            pairs = [p for k, p in enumerate(pairs) if k not in fixed]
        self.pairs: tuple[Pair, ...] = tuple(pairs)
        #: the margin (mm) each pair is checked against: its own (:meth:`with_margins` copies differ)
        self.kernel_margins_mm: tuple[float, ...] = tuple(p.margin_mm for p in pairs)
        self.packed = pack(model.robot, segs, statics, specs, self.tau_mm * 1e-3, int(max_evaluations))
        self._u = ref.unpack(self.packed)
        self._kernel = _ccollide

    def __repr__(self) -> str:
        return (f"Scene({len(self.bodies)} bodies, {len(self.zones)} zones, {len(self.pairs)} pairs, "
                f"kernel {'C' if self._kernel is not None else 'numpy'})")

    # ---- one pose ----

    def _pd(self, k: int, d_m: float) -> PairDistance | None:
        return None if k < 0 else PairDistance(self.pairs[k], d_m * 1e3)

    def check(self, q: object) -> Verdict:
        """The :class:`Verdict` for joint vector ``q`` (6 values, rad)."""
        if self._kernel is not None:
            r = self._kernel.check(self.packed, q)
            if r is None:  # not 6 plain finite numbers: the precise error from as_joint_array
                r = self._kernel.check(self.packed, _q6(q, "q").tolist())
        else:
            r = ref.check(self._u, _q6(q, "q"))
        d0, k0, d1, k1, d2, k2, g, kw = r
        worst = None if kw < 0 else PairDistance(self.pairs[kw], (g * 1e3 + self.kernel_margins_mm[kw]))
        return Verdict(self._pd(k0, d0), self._pd(k1, d1), self._pd(k2, d2), worst)

    def distances(self, q: object) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Every pair's clearance at ``q`` (rad), mm, in the order of :attr:`pairs`, and the
        closest points on each side (world, mm; on a capsule, the point on its axis segment):
        shapes (P,), (P, 3), (P, 3).  For drawing (which link is near what) and for tests."""
        qs = _q6(q, "q")[None, :]
        d, pa, pb = self.distances_batch(qs)
        return d[0], pa[0], pb[0]

    def distances_batch(self, qs: object) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`distances` for many configurations ``qs`` (N, 6), rad: (N, P), (N, P, 3), (N, P, 3) mm."""
        arr = np.ascontiguousarray(as_joint_array(qs, "qs"), dtype=np.float64)
        if arr.ndim == 1:
            arr = arr[None, :]
        n, p = arr.shape[0], len(self.pairs)
        if self._kernel is not None:
            d = np.empty((n, p))
            pa = np.empty((n, p, 3))
            pb = np.empty((n, p, 3))
            self._kernel.distances(self.packed, arr, d, pa, pb)
        else:
            d, pa, pb = ref.pair_distances(self._u, arr)
        return d * 1e3, pa * 1e3, pb * 1e3

    # ---- paths ----

    def check_path(self, qs: object, *, swept: bool = True) -> PathVerdict:
        """The first violation along the samples ``qs`` ((N, 6), rad): at a sample, or (when
        ``swept``) on the straight joint-space segment between two samples."""
        arr = np.ascontiguousarray(as_joint_array(qs, "qs"), dtype=np.float64)
        if arr.ndim == 1:
            arr = arr[None, :]
        if self._kernel is not None:
            status, index, s, k, g, evals = self._kernel.path(self.packed, arr, bool(swept))
        else:
            status, index, s, k, g, evals = ref.path(self._u, arr, bool(swept))
        st = (PathStatus.CLEAR, PathStatus.AT_SAMPLE, PathStatus.BETWEEN_SAMPLES, PathStatus.NOT_PROVEN)[status]
        if st is PathStatus.CLEAR:
            return PathVerdict(st, None, 0.0, None, int(evals))
        pd = PairDistance(self.pairs[k], g * 1e3 + self.kernel_margins_mm[k])
        if st is PathStatus.NOT_PROVEN:
            pd = PairDistance(self.pairs[k], math.nan)
        return PathVerdict(st, int(index), float(s), pd, int(evals))

    def check_swept(self, q0: object, q1: object) -> PathVerdict:
        """Every pose on the straight joint-space move from ``q0`` to ``q1`` (rad), both included."""
        return self.check_path(np.stack([_q6(q0, "q0"), _q6(q1, "q1")]), swept=True)

    def path_raw(self, qs_flat: Sequence[float], swept: bool = True) -> tuple[int, int, float, int, float]:
        """:meth:`check_path` for a few poses in a hurry (the controller's tick): ``qs_flat`` the
        poses' joint angles one after the other (6 per pose, rad; best an ``array('d')``), not
        validated.  Returns ``(status, index, fraction, pair, clearance_mm)``: status 0 clear, 1
        at a sample, 2 between samples, 3 not proven (as :class:`PathStatus`, in that order);
        the pair's index in :attr:`pairs` (-1 when clear) and its clearance there (mm; NaN when
        not proven).  ~4 us for a handful of poses with the C kernel, against ~15 us for
        :meth:`check_path`'s checks and objects."""
        if self._kernel is not None:
            if not isinstance(qs_flat, (array, np.ndarray)):
                qs_flat = array("d", qs_flat)
            status, index, s, k, g, _ = self._kernel.path(self.packed, qs_flat, bool(swept))
        else:
            arr = np.asarray(qs_flat, dtype=np.float64).reshape(-1, 6)
            status, index, s, k, g, _ = ref.path(self._u, arr, bool(swept))
        if status == 0:
            return 0, -1, 0.0, -1, math.inf
        d = math.nan if status == 3 else g * 1e3 + self.kernel_margins_mm[k]
        return int(status), int(index), float(s), int(k), d

    def with_margins(self, margins_mm: Mapping[int, float]) -> Scene:
        """This scene with the pairs ``k`` of ``margins_mm`` checked against the margin given
        there (mm, any value: below 0 counts a pair as violated only once its overlap is
        deeper) instead of their own; every other pair, body and zone the same.  The pairs
        keep their names and own margins (:attr:`Pair.margin_mm`, shown in messages); the
        distances reported are the true clearances.  The path checks (:meth:`check_path`,
        :meth:`check_swept`, :meth:`path_raw`) and :attr:`Verdict.worst` judge by the margins
        given; :attr:`Verdict.clear` and :attr:`PairDistance.within_margin` still by each pair's
        own.  What a controller checks a motion that starts inside a margin with: the pair may
        not come any closer than it is (docs/collision.md, "Motion out of a margin")."""
        import copy

        key = tuple(sorted((int(k), float(v)) for k, v in margins_mm.items()))
        memo: dict[tuple[tuple[int, float], ...], Scene] = self.__dict__.setdefault("_relaxed", {})
        hit = memo.get(key)
        if hit is not None:
            return hit
        out = copy.copy(self)
        out.__dict__.pop("_relaxed", None)
        margins = list(self.kernel_margins_mm)
        buf = np.array(self.packed)
        m, s, p = int(buf[1]), int(buf[2]), int(buf[3])
        o = ref.HEADER + m * ref.BODY_W + s * ref.STATIC_W
        for k, v in margins_mm.items():
            if not 0 <= k < p:
                raise IndexError(f"pair {k} of a scene with {p} pairs")
            fv = float(v)
            if not math.isfinite(fv):
                raise ParolkitValueError(f"the margin of pair {k} must be a finite number of mm, got {v!r}")
            margins[k] = fv
            buf[o + k * ref.PAIR_W + 4] = fv * 1e-3
        buf.setflags(write=False)
        out.packed = buf
        out._u = ref.unpack(buf)
        out.kernel_margins_mm = tuple(margins)
        if len(memo) >= 8:  # (a motion inside a margin asks for the same margins tick after tick)
            memo.pop(next(iter(memo)))
        memo[key] = out
        return out


def _fixed_zone_pairs(model: CollisionModel, segs: Sequence[Any], statics: Sequence[Static],
                      specs: Sequence[PairSpec], pairs: Sequence[Pair], first: int,
                      caps: Sequence[Body]) -> dict[int, float]:
    """The zone pairs (index from ``first`` on) of a body moved by J1 alone whose clearance
    is the same at every J1 angle (found by turning J1: no other joint moves it), and that
    clearance, mm."""
    movable = {b.name for b in caps if b.frame <= 1}
    candidates = [k for k in range(first, len(pairs)) if pairs[k].a in movable]
    if not candidates:
        return {}
    u = ref.unpack(pack(model.robot, segs, statics, specs, TAU_MM * 1e-3, MAX_EVALUATIONS))
    qs = np.zeros((5, 6))
    qs[:, 0] = (0.0, 1.1, -2.3, 2.9, -0.6)
    d, _, _ = ref.pair_distances(u, qs, np.asarray(candidates, dtype=np.intp))
    return {k: float(d[0, i] * 1e3) for i, k in enumerate(candidates) if float(np.ptp(d[:, i])) < 1e-9}


def _dh(model: CollisionModel) -> NDArray[np.float64]:
    from parolkit.collision._geometry import dh_rows

    return dh_rows(model.robot)


def _order(bodies: tuple[Body, ...], name: str) -> int:
    return next(k for k, b in enumerate(bodies) if b.name == name)


def _base_static_of(base: Body) -> Static:
    from parolkit.collision.model import _base_static

    return _base_static(base)


# ---- the module-level functions: a scene cached on the identity of their arguments ----

_CACHE: dict[str, tuple[tuple[Any, ...], Scene]] = {}


def _scene(zones: Iterable[Zone], tool: ToolShape | ToolSettings | None, held: Sequence[HeldObject] | None,
           model: CollisionModel | None) -> Scene:
    m = model or default_model()
    zones_t = zones if isinstance(zones, tuple) else tuple(zones)
    held_t = m.held if held is None else (held if isinstance(held, tuple) else tuple(held))
    key = (m, m.version, zones_t, tool, held_t)
    hit = _CACHE.get("last")
    if hit is not None:
        k = hit[0]
        if k[0] is m and k[1] == m.version and (k[3] is tool or k[3] == tool) \
                and (k[2] is zones_t or k[2] == zones_t) and (k[4] is held_t or k[4] == held_t):
            return hit[1]
    scene = Scene(m, zones_t, tool, held_t)
    _CACHE["last"] = (key, scene)
    return scene


def check(q: object, zones: Iterable[Zone] = (), tool: ToolShape | ToolSettings | None = None,
          held: Sequence[HeldObject] | None = None, *, model: CollisionModel | None = None) -> Verdict:
    """The :class:`Verdict` of the arm at joint vector ``q`` (rad) among ``zones`` with ``tool``
    (its shape, if it has one) and ``held`` objects (None: ``model``'s attached ones).

    The compiled scene is kept for the next call with the same arguments; callers that switch
    between several combinations keep a :class:`Scene` each instead.
    """
    return _scene(zones, tool, held, model).check(q)


def check_swept(q0: object, q1: object, zones: Iterable[Zone] = (), tool: ToolShape | ToolSettings | None = None,
                held: Sequence[HeldObject] | None = None, *, model: CollisionModel | None = None) -> PathVerdict:
    """Every pose on the straight joint-space move ``q0`` -> ``q1`` (rad): see :meth:`Scene.check_swept`."""
    return _scene(zones, tool, held, model).check_swept(q0, q1)


def check_path(qs: object, zones: Iterable[Zone] = (), tool: ToolShape | ToolSettings | None = None,
               held: Sequence[HeldObject] | None = None, *, model: CollisionModel | None = None,
               swept: bool = True) -> PathVerdict:
    """A trajectory's samples ``qs`` ((N, 6), rad), and between them when ``swept``: see
    :meth:`Scene.check_path`."""
    return _scene(zones, tool, held, model).check_path(qs, swept=swept)
