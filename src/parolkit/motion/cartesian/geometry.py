"""Cartesian path geometry: lines, arcs/circles/helices, splines, blended corners.

Positions in mm, rotations as 3x3 matrices (world frame).  Every segment is parameterised by
``u`` in [0, 1] PROPORTIONAL TO ARC LENGTH (exactly for lines, arcs and helices; through an
arc-length table for splines and blend curves), so a time-scaling ``s(t)`` applied to ``u``
gives the Cartesian speed profile directly.  Samples are evaluated analytically: every sample
lies on the exact geometry (no chords).

Orientation: SLERP between the segment's end orientations (held for circles and helices;
a rotation spline for splines).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray
    from scipy.interpolate import CubicSpline
    from scipy.spatial.transform import RotationSpline

__all__ = [
    "quat_from_matrix", "quat_to_matrix", "slerp", "rotation_angle", "rot_about",
    "Segment", "Line", "Arc", "SpiralArc", "Spline", "CubicBezier", "Path", "blend_corners", "frame_axes",
]


# ---------------------------------------------------------------------------------------------
# rotations (vectorised; quaternions are [w, x, y, z])
# ---------------------------------------------------------------------------------------------


def quat_from_matrix(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """3x3 rotation -> unit quaternion [w, x, y, z] (w >= 0)."""
    m = np.asarray(r, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    out = np.asarray(q)
    out /= np.linalg.norm(out)
    return -out if out[0] < 0 else out


def quat_to_matrix(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 4) quaternions -> (N, 3, 3) rotations."""
    q = np.atleast_2d(q)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    out = np.empty((len(q), 3, 3))
    out[:, 0, 0] = 1 - 2 * (y * y + z * z)
    out[:, 0, 1] = 2 * (x * y - z * w)
    out[:, 0, 2] = 2 * (x * z + y * w)
    out[:, 1, 0] = 2 * (x * y + z * w)
    out[:, 1, 1] = 1 - 2 * (x * x + z * z)
    out[:, 1, 2] = 2 * (y * z - x * w)
    out[:, 2, 0] = 2 * (x * z - y * w)
    out[:, 2, 1] = 2 * (y * z + x * w)
    out[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def slerp(q0: NDArray[np.float64], q1: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
    """Spherical linear interpolation (shortest way) at fractions ``u`` -> (N, 4)."""
    u = np.asarray(u, dtype=float)
    d = float(np.dot(q0, q1))
    if d < 0:
        q1, d = -q1, -d
    if d > 1.0 - 1e-12:
        out = q0[None, :] + u[:, None] * (q1 - q0)[None, :]
        unit: NDArray[np.float64] = out / np.linalg.norm(out, axis=1, keepdims=True)
        return unit
    th = math.acos(min(1.0, d))
    s = math.sin(th)
    a = np.sin((1.0 - u) * th) / s
    b = np.sin(u * th) / s
    return a[:, None] * q0[None, :] + b[:, None] * q1[None, :]


def rotation_angle(r0: NDArray[np.float64], r1: NDArray[np.float64]) -> float:
    """Angle (rad) of the rotation taking r0 to r1."""
    c = (np.trace(r0.T @ r1) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, c)))


def rot_about(axis: NDArray[np.float64], angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3, 3) rotations by ``angles`` (rad) about the unit ``axis`` (Rodrigues)."""
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    kx: NDArray[np.float64] = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    a: NDArray[np.float64] = np.atleast_1d(np.asarray(angles, dtype=float))
    return (np.eye(3)[None] + np.sin(a)[:, None, None] * kx[None]
            + (1 - np.cos(a))[:, None, None] * (kx @ kx)[None])


# ---------------------------------------------------------------------------------------------
# segments
# ---------------------------------------------------------------------------------------------


class Segment:
    """A piece of path.  ``length`` (mm), ``angle`` (rad of orientation change)."""

    length: float
    angle: float
    r0: NDArray[np.float64]
    r1: NDArray[np.float64]

    def positions(self, u: NDArray[np.float64]) -> NDArray[np.float64]:  # (n, 3) mm
        raise NotImplementedError

    def rotations(self, u: NDArray[np.float64]) -> NDArray[np.float64]:  # (n, 3, 3)
        q0, q1 = quat_from_matrix(self.r0), quat_from_matrix(self.r1)
        return quat_to_matrix(slerp(q0, q1, u))

    def tangent(self, u: float) -> NDArray[np.float64]:
        """Unit tangent at ``u`` (numerical, mm/mm)."""
        h = 1e-6
        a, b = max(0.0, u - h), min(1.0, u + h)
        d: NDArray[np.float64] = self.positions(np.array([b]))[0] - self.positions(np.array([a]))[0]
        n = float(np.linalg.norm(d))
        return d / n if n > 0 else d

    @property
    def p0(self) -> NDArray[np.float64]:
        p: NDArray[np.float64] = self.positions(np.array([0.0]))[0]
        return p

    @property
    def p1(self) -> NDArray[np.float64]:
        p: NDArray[np.float64] = self.positions(np.array([1.0]))[0]
        return p


@dataclass
class Line(Segment):
    """Straight line p0 -> p1 (mm) with orientation SLERP r0 -> r1."""

    a: NDArray[np.float64]
    b: NDArray[np.float64]
    r0: NDArray[np.float64]
    r1: NDArray[np.float64]

    def __post_init__(self) -> None:
        self.a = np.asarray(self.a, dtype=float)
        self.b = np.asarray(self.b, dtype=float)
        self.length = float(np.linalg.norm(self.b - self.a))
        self.angle = rotation_angle(self.r0, self.r1)

    def positions(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        u = np.asarray(u, dtype=float)
        return self.a[None, :] + u[:, None] * (self.b - self.a)[None, :]


@dataclass
class Arc(Segment):
    """Arc / full circle / helix: ``center`` (mm), ``radius`` (mm), orthonormal in-plane axes
    ``e1``, ``e2`` (the sweep turns from e1 toward e2 for a positive ``sweep``), start angle
    ``phi0`` (rad), signed ``sweep`` (rad), axial ``rise`` (mm along e1 x e2)."""

    center: NDArray[np.float64]
    radius: float
    e1: NDArray[np.float64]
    e2: NDArray[np.float64]
    phi0: float
    sweep: float
    rise: float
    r0: NDArray[np.float64]
    r1: NDArray[np.float64]

    def __post_init__(self) -> None:
        self.center = np.asarray(self.center, dtype=float)
        self.normal = np.cross(self.e1, self.e2)
        self.length = float(math.hypot(self.radius * self.sweep, self.rise))
        self.angle = rotation_angle(self.r0, self.r1)

    def positions(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        u = np.asarray(u, dtype=float)
        phi = self.phi0 + self.sweep * u
        return (self.center[None, :] + self.radius * (np.cos(phi)[:, None] * self.e1[None, :]
                                                     + np.sin(phi)[:, None] * self.e2[None, :])
                + (self.rise * u)[:, None] * self.normal[None, :])


class SpiralArc(Arc):
    """An arc whose radius changes linearly from start to end (ends off by <= 1 mm)."""

    def __init__(self, arc: Arc, r_end: float) -> None:
        self.__dict__.update(arc.__dict__)
        self.r_end = r_end
        self.length = float(abs(self.sweep) * (self.radius + r_end) / 2)

    def positions(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        u = np.asarray(u, dtype=float)
        phi = self.phi0 + self.sweep * u
        rad = self.radius + (self.r_end - self.radius) * u
        return self.center[None, :] + rad[:, None] * (np.cos(phi)[:, None] * self.e1[None, :]
                                                     + np.sin(phi)[:, None] * self.e2[None, :])


class _TabulatedSegment(Segment):
    """Shared arc-length inversion for curves with a non-uniform native parameter."""

    _n_table = 512
    _w: NDArray[np.float64]  # native parameter of the table rows
    _cum: NDArray[np.float64]  # arc-length fraction of the table rows

    def _build_table(self) -> None:
        w = np.linspace(0.0, 1.0, self._n_table)
        p = self._native(w)
        seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.length = float(cum[-1])
        self._w = w
        self._cum = cum / cum[-1] if cum[-1] > 0 else w

    def _native(self, w: NDArray[np.float64]) -> NDArray[np.float64]:
        raise NotImplementedError

    def native_param(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        w: NDArray[np.float64] = np.interp(np.asarray(u, dtype=float), self._cum, self._w)
        return w

    def positions(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._native(self.native_param(u))


class CubicBezier(_TabulatedSegment):
    """Cubic Bezier a -> b leaving along ``ta`` and arriving along ``tb`` (unit tangents):
    G1-continuous corner rounding.  Orientation SLERP r0 -> r1 along the arc length."""

    def __init__(self, a: NDArray[np.float64], ta: NDArray[np.float64], b: NDArray[np.float64],
                 tb: NDArray[np.float64], r0: NDArray[np.float64], r1: NDArray[np.float64]) -> None:
        a, b = np.asarray(a, float), np.asarray(b, float)
        h = float(np.linalg.norm(b - a)) / 3.0
        self.ctrl: NDArray[np.float64] = np.stack([a, a + h * np.asarray(ta), b - h * np.asarray(tb), b])
        self.r0, self.r1 = r0, r1
        self.angle = rotation_angle(r0, r1)
        self._build_table()

    def _native(self, w: NDArray[np.float64]) -> NDArray[np.float64]:
        w = np.asarray(w, dtype=float)[:, None]
        c = self.ctrl
        m = 1.0 - w
        p: NDArray[np.float64] = m**3 * c[0] + 3 * m * m * w * c[1] + 3 * m * w * w * c[2] + w**3 * c[3]
        return p


class Spline(_TabulatedSegment):
    """Cubic spline (chord-length knots, natural ends) through ``points`` (M, 3) mm; the
    orientation follows a rotation spline through ``rotations`` (M, 3, 3) at the same knots."""

    def __init__(self, points: NDArray[np.float64], rotations: NDArray[np.float64]) -> None:
        from scipy.interpolate import CubicSpline

        pts = np.asarray(points, dtype=float)
        chord = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        keep = np.concatenate([[True], chord > 1e-9])
        pts, rots = pts[keep], np.asarray(rotations)[keep]
        if len(pts) < 2:
            raise ValueError("a spline needs at least two distinct points")
        knots = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        knots /= knots[-1]
        self.knots = knots
        self.points = pts
        self._cs: CubicSpline = CubicSpline(knots, pts, bc_type="natural" if len(pts) > 2 else "not-a-knot")
        self._rots = rots
        self.r0, self.r1 = rots[0], rots[-1]
        self.angle = sum(rotation_angle(rots[i], rots[i + 1]) for i in range(len(rots) - 1))
        self._n_table = int(min(4096, 256 * (len(pts) - 1) + 256))
        self._build_table()
        self._rspline: RotationSpline | None = None
        if self.angle > 1e-9:
            if len(rots) > 2:
                from scipy.spatial.transform import Rotation, RotationSpline

                self._rspline = RotationSpline(knots, Rotation.from_matrix(rots))

    def _native(self, w: NDArray[np.float64]) -> NDArray[np.float64]:
        p: NDArray[np.float64] = self._cs(np.asarray(w, dtype=float))  # (scipy is untyped)
        return p

    def rotations(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        if self._rspline is not None:
            r: NDArray[np.float64] = self._rspline(self.native_param(u)).as_matrix()  # (untyped)
            return r
        return super().rotations(self.native_param(u))


# ---------------------------------------------------------------------------------------------
# composite path
# ---------------------------------------------------------------------------------------------


@dataclass
class Path:
    """Segments played one after another; global progress ``s`` in [0, 1] is split over the
    segments in proportion to their ``weights`` (equivalent lengths, see :meth:`weighted`)."""

    segments: list[Segment]
    weights: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        if not len(self.weights):
            self.weights = np.array([max(s.length, 1e-12) for s in self.segments])
        self.weights = np.asarray(self.weights, dtype=float)
        total = float(self.weights.sum())
        self.bounds = np.concatenate([[0.0], np.cumsum(self.weights)]) / total if total > 0 else \
            np.linspace(0.0, 1.0, len(self.segments) + 1)

    @classmethod
    def weighted(cls, segments: list[Segment], mm_per_rad: float) -> Path:
        """Weights max(length, angle * mm_per_rad): the slower of linear and angular governs."""
        return cls(segments, np.array([max(s.length, s.angle * mm_per_rad, 1e-12) for s in segments]))

    @property
    def length(self) -> float:
        """Total linear length (mm)."""
        return float(sum(s.length for s in self.segments))

    @property
    def angle(self) -> float:
        """Total orientation change (rad)."""
        return float(sum(s.angle for s in self.segments))

    def evaluate(self, s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Positions (n, 3) mm and rotations (n, 3, 3) at global progress ``s`` (n,)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        n = len(self.segments)
        idx = np.clip(np.searchsorted(self.bounds, s, side="right") - 1, 0, n - 1)
        pos = np.empty((len(s), 3))
        rot = np.empty((len(s), 3, 3))
        for i in np.unique(idx):
            m = idx == i
            lo, hi = self.bounds[i], self.bounds[i + 1]
            u = (s[m] - lo) / (hi - lo) if hi > lo else np.ones(int(m.sum()))
            u = np.clip(u, 0.0, 1.0)
            seg = self.segments[i]
            pos[m] = seg.positions(u)
            rot[m] = seg.rotations(u)
        return pos, rot


def frame_axes(rot: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Columns x, y, z of a rotation matrix."""
    return rot[:, 0].copy(), rot[:, 1].copy(), rot[:, 2].copy()


def blend_corners(segments: Sequence[Segment], radius: float | Sequence[float]) -> list[Segment]:
    """Round every corner between consecutive segments: cut ``radius`` mm (at most 45 % of
    each neighbour) before and after the corner and join with a G1 cubic Bezier.  Corners whose
    tangents already agree (< 0.5 deg) are left alone.  ``radius``: one for every corner, or
    one per corner (the corner after segment ``i`` is ``radius[i]``; 0: left sharp)."""
    segs = list(segments)
    radii = [float(radius)] * max(0, len(segs) - 1) if isinstance(radius, (int, float)) else list(radius)
    if len(radii) != max(0, len(segs) - 1):
        raise ValueError(f"blend_corners: {len(segs)} segments have {max(0, len(segs) - 1)} corners, "
                         f"got {len(radii)} radii")
    if not any(r > 0 for r in radii) or len(segs) < 2:
        return segs
    out: list[Segment] = []
    # fractions to trim at the start/end of every segment
    cut0 = [0.0] * len(segs)
    cut1 = [0.0] * len(segs)
    for i in range(len(segs) - 1):
        a, b = segs[i], segs[i + 1]
        ta, tb = a.tangent(1.0), b.tangent(0.0)
        if float(np.dot(ta, tb)) > math.cos(math.radians(0.5)) or a.length <= 0 or b.length <= 0:
            continue
        if radii[i] <= 0:
            continue
        r = min(radii[i], 0.45 * a.length, 0.45 * b.length)
        cut1[i] = r / a.length
        cut0[i + 1] = r / b.length
    trimmed = [_Trimmed(s, c0, 1.0 - c1) if (c0 or c1) else s for s, c0, c1 in zip(segs, cut0, cut1)]
    for i, seg in enumerate(trimmed):
        out.append(seg)
        if i < len(segs) - 1 and cut1[i] > 0:
            nxt = trimmed[i + 1]
            out.append(CubicBezier(seg.p1, seg.tangent(1.0), nxt.p0, nxt.tangent(0.0),
                                   seg.rotations(np.array([1.0]))[0], nxt.rotations(np.array([0.0]))[0]))
    return out


class _Trimmed(Segment):
    """The part u0..u1 of a segment (u proportional to arc length, so still uniform)."""

    def __init__(self, seg: Segment, u0: float, u1: float) -> None:
        self.seg, self.u0, self.u1 = seg, u0, u1
        self.length = seg.length * (u1 - u0)
        self.r0 = seg.rotations(np.array([u0]))[0]
        self.r1 = seg.rotations(np.array([u1]))[0]
        self.angle = rotation_angle(self.r0, self.r1)

    def _map(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.u0 + np.asarray(u, dtype=float) * (self.u1 - self.u0)

    def positions(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.seg.positions(self._map(u))

    def rotations(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.seg.rotations(self._map(u))
