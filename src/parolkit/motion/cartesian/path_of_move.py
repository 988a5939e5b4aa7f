"""The path a Cartesian move describes: its segments (:mod:`.geometry`, mm, world frame) from
the tool pose at the start of the move.

The first stage of the Cartesian pipeline (:mod:`parolkit.motion.cartesian`): MoveCart and
MoveCartRelTRF are one line; circles and helices start at the point nearest the start (with
an approach line first when the start is elsewhere); arcs are built through their ends
(centre given, or radius and angle); splines through their waypoints; a blend joins its
segments and rounds the corners.  Poses and points are in the move's frame: the world (WRF)
or the tool frame at the start of the move (TRF).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion.cartesian.geometry import (
    Arc,
    Line,
    Path,
    Segment,
    SpiralArc,
    Spline,
    blend_corners,
    rotation_angle,
)
from parolkit.motion.errors import PlanningError
from parolkit.moves import (
    ArcCenterMove,
    ArcParamMove,
    BlendMove,
    BlendSegment,
    CartMove,
    CartRelTRFMove,
    CircleMove,
    Frame,
    HelixMove,
    LineSegment,
    Plane,
    SplineMove,
)

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.robot import RobotModel

__all__ = [
    "CartesianMove", "DEFAULT_CART_SPEED_PCT", "ON_PATH_TOL_MM", "ARC_RADIUS_TOL_MM", "path_speed_pct",
    "frame_pose", "far_apart", "build_path",
]

#: The moves :func:`~parolkit.motion.cartesian.plan_cartesian` plans (a path of the tool; CartJog
#: has its own planner, :mod:`.jog`).
CartesianMove = (
    CartMove | CartRelTRFMove | CircleMove | ArcCenterMove | ArcParamMove | HelixMove | SplineMove | BlendMove
)

#: MoveCart / smooth paths without duration and speed: this speed percentage (50 % -> a mean
#: speed of 31 mm/s or 12.85 deg/s), instead of the original's fixed 3.6 s.
DEFAULT_CART_SPEED_PCT = 50.0
#: A start this close (mm / deg) to a circle/helix/start pose needs no approach segment.
ON_PATH_TOL_MM = 0.05
#: Arc ends may differ in radius by this much (mm); the arc then spirals linearly.
ARC_RADIUS_TOL_MM = 1.0


def path_speed_pct(move: CartesianMove) -> float:
    """The path speed (%) the move asks for: its ``speed_pct``, or :data:`DEFAULT_CART_SPEED_PCT`."""
    return move.speed_pct if move.speed_pct is not None else DEFAULT_CART_SPEED_PCT


def frame_pose(frame: Frame, t0: NDArray[np.float64], pose: Sequence[float]) -> NDArray[np.float64]:
    """The 4x4 matrix of ``pose`` (mm/deg) given in ``frame``: in the world (WRF) or in the tool
    frame ``t0`` at the start of the move (TRF)."""
    from parolkit import kinematics as kin

    m: NDArray[np.float64] = np.asarray(kin.pose_to_matrix(pose), dtype=float)
    return t0 @ m if frame is Frame.TRF else m


def _frame_point(frame: Frame, t0: NDArray[np.float64], point: Sequence[float]) -> NDArray[np.float64]:
    p: NDArray[np.float64] = np.asarray(point, dtype=float)
    return t0[:3, 3] * 1e3 + t0[:3, :3] @ p if frame is Frame.TRF else p


def _frame_rot(frame: Frame, t0: NDArray[np.float64]) -> NDArray[np.float64]:
    return t0[:3, :3] if frame is Frame.TRF else np.eye(3)


def far_apart(
    pa: NDArray[np.float64], ra: NDArray[np.float64], pb: NDArray[np.float64], rb: NDArray[np.float64],
) -> bool:
    """Are two poses (mm, rotation) more than :data:`ON_PATH_TOL_MM` (mm or deg) apart?"""
    return float(np.linalg.norm(pa - pb)) > ON_PATH_TOL_MM or math.degrees(rotation_angle(ra, rb)) > ON_PATH_TOL_MM


def build_path(
    move: CartesianMove, t0: NDArray[np.float64], p0: NDArray[np.float64], r0: NDArray[np.float64],
    model: RobotModel,
) -> tuple[Path, list[tuple[Path, str]]]:
    """The main path and any approach paths (played first, each from rest to rest)."""
    from parolkit import kinematics as kin

    name = move.name
    pre: list[tuple[Path, str]] = []
    if isinstance(move, CartMove):
        t1 = np.asarray(kin.pose_to_matrix(move.pose), dtype=float)
        return Path([Line(p0, t1[:3, 3] * 1e3, r0, t1[:3, :3])]), pre
    if isinstance(move, CartRelTRFMove):
        t1 = t0 @ np.asarray(kin.pose_to_matrix(move.delta), dtype=float)
        return Path([Line(p0, t1[:3, 3] * 1e3, r0, t1[:3, :3])]), pre
    if isinstance(move, BlendMove):
        return _blend_path(move, t0, p0, r0, model), pre
    segs, approach = _segment_for(name, move, move.frame, t0, p0, r0)
    if approach is not None:
        pre.append((Path([approach]), f"approach: straight line ({approach.length:.1f} mm) onto the path first"))
    return Path(segs), pre


def _segment_for(
    name: str, seg: BlendSegment | HelixMove, frame: Frame, t0: NDArray[np.float64], p: NDArray[np.float64],
    r: NDArray[np.float64],
) -> tuple[list[Segment], Line | None]:
    """Segment(s) for one smooth element starting at position ``p`` / rotation ``r``; plus an
    approach line when the element starts elsewhere (circle, helix)."""
    fr = _frame_rot(frame, t0)
    if isinstance(seg, LineSegment):
        t1 = frame_pose(frame, t0, seg.pose)
        return [Line(p, t1[:3, 3] * 1e3, r, t1[:3, :3])], None
    if isinstance(seg, CircleMove):
        c = _frame_point(frame, t0, seg.center_mm)
        e1, e2 = _plane_axes(seg.plane, fr)
        n = np.cross(e1, e2)
        v = p - c
        v = v - np.dot(v, n) * n
        phi0 = math.atan2(float(np.dot(v, e2)), float(np.dot(v, e1))) if np.linalg.norm(v) > 1e-9 else 0.0
        entry = c + seg.radius_mm * (math.cos(phi0) * e1 + math.sin(phi0) * e2)
        arc = Arc(c, seg.radius_mm, e1, e2, phi0, -2 * math.pi if seg.clockwise else 2 * math.pi, 0.0, r, r)
        approach = Line(p, entry, r, r) if np.linalg.norm(entry - p) > ON_PATH_TOL_MM else None
        return [arc], approach
    if isinstance(seg, HelixMove):
        c = _frame_point(frame, t0, seg.center_mm)
        e1, e2, n = fr[:, 0], fr[:, 1], fr[:, 2]
        v = p - c
        h0 = float(np.dot(v, n))
        vr = v - h0 * n
        phi0 = math.atan2(float(np.dot(vr, e2)), float(np.dot(vr, e1))) if np.linalg.norm(vr) > 1e-9 else 0.0
        entry = c + h0 * n + seg.radius_mm * (math.cos(phi0) * e1 + math.sin(phi0) * e2)
        sweep = 2 * math.pi * abs(seg.height_mm) / seg.pitch_mm * (-1 if seg.clockwise else 1)
        arc = Arc(c + h0 * n, seg.radius_mm, e1, e2, phi0, sweep, seg.height_mm, r, r)
        approach = Line(p, entry, r, r) if np.linalg.norm(entry - p) > ON_PATH_TOL_MM else None
        return [arc], approach
    if isinstance(seg, ArcCenterMove):
        t1 = frame_pose(frame, t0, seg.end_pose)
        c = _frame_point(frame, t0, seg.center_mm)
        return [_arc_through(name, p, t1[:3, 3] * 1e3, c, None, fr, seg.clockwise, r, t1[:3, :3])], None
    if isinstance(seg, ArcParamMove):
        t1 = frame_pose(frame, t0, seg.end_pose)
        p1 = t1[:3, 3] * 1e3
        chord = p1 - p
        d = float(np.linalg.norm(chord))
        R = seg.radius_mm
        if d < 1e-6:
            raise PlanningError(name, "arc start and end positions coincide: give ArcCenterMove or CircleMove")
        if d > 2 * R + 1e-6:
            raise PlanningError(
                name, f"radius_mm {R:g} is too small: start and end are {d:.3f} mm apart (radius >= {d / 2:.3f} mm)",
                value=R,
            )
        minor = math.degrees(2 * math.asin(min(1.0, d / (2 * R))))
        major = 360.0 - minor
        want = seg.angle_deg
        if min(abs(want - minor), abs(want - major)) > 1.0:
            raise PlanningError(
                name,
                f"angle_deg {want:g} does not match the geometry: start and end {d:.3f} mm apart on "
                f"radius {R:g} mm span {minor:.3f} deg (or {major:.3f} deg the long way)",
                value=want,
            )
        use_major = abs(want - major) < abs(want - minor)
        u = chord / d
        n = fr[:, 2] - np.dot(fr[:, 2], u) * u
        if np.linalg.norm(n) < 1e-6:
            n = fr[:, 0] - np.dot(fr[:, 0], u) * u
        n /= np.linalg.norm(n)
        w = np.cross(n, u)  # in-plane, left of the chord seen from +n
        h = math.sqrt(max(0.0, R * R - d * d / 4))
        left = (not use_major) != seg.clockwise  # ccw minor / cw major: centre on the left
        c = (p + p1) / 2 + (h if left else -h) * w
        return [_arc_through(name, p, p1, c, n, fr, seg.clockwise, r, t1[:3, :3])], None
    if isinstance(seg, SplineMove):
        mats = [frame_pose(frame, t0, wp) for wp in seg.waypoints]
        pts = np.vstack([p[None, :]] + [m[None, :3, 3] * 1e3 for m in mats])
        rots = np.stack([r] + [m[:3, :3] for m in mats])
        try:
            return [Spline(pts, rots)], None
        except ValueError:
            raise PlanningError(name, "spline waypoints must include a point away from the start") from None
    raise PlanningError(name, f"unsupported path element {type(seg).__name__}")


def _plane_axes(plane: Plane, fr: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    x, y, z = fr[:, 0], fr[:, 1], fr[:, 2]
    if plane is Plane.XY:
        return x, y  # normal +Z
    if plane is Plane.XZ:
        return z, x  # normal +Y
    return y, z  # YZ: normal +X


def _arc_through(
    name: str, p0: NDArray[np.float64], p1: NDArray[np.float64], c: NDArray[np.float64],
    n: NDArray[np.float64] | None, fr: NDArray[np.float64], clockwise: bool, r0: NDArray[np.float64],
    r1: NDArray[np.float64],
) -> Arc:
    a, b = p0 - c, p1 - c
    ra, rb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if ra < 1e-6:
        raise PlanningError(name, "the arc's start lies on its centre (radius 0 mm)")
    if abs(ra - rb) > ARC_RADIUS_TOL_MM:
        raise PlanningError(
            name, f"start and end are not on one circle around the centre: radii {ra:.3f} mm and "
            f"{rb:.3f} mm differ by more than {ARC_RADIUS_TOL_MM:g} mm", value=rb - ra,
        )
    if n is None:
        cr = np.cross(a, b)
        if np.linalg.norm(cr) > 1e-6 * ra * rb:
            n = cr / np.linalg.norm(cr)
            # orientation convention: counter-clockwise seen from the side of +Z (then +X, +Y)
            for ref in (fr[:, 2], fr[:, 0], fr[:, 1]):
                dd = float(np.dot(n, ref))
                if abs(dd) > 1e-9:
                    if dd < 0:
                        n = -n
                    break
        else:
            n = fr[:, 2] - np.dot(fr[:, 2], a / ra) * a / ra
            if np.linalg.norm(n) < 1e-6:
                n = fr[:, 0] - np.dot(fr[:, 0], a / ra) * a / ra
            n = n / np.linalg.norm(n)
    e1 = a / ra
    e2 = np.cross(n, e1)
    theta = math.atan2(float(np.dot(np.cross(a, b), n)), float(np.dot(a, b)))
    if theta <= 1e-9:
        theta += 2 * math.pi
    sweep = theta - 2 * math.pi if clockwise else theta
    arc = Arc(c, ra, e1, e2, 0.0, sweep, 0.0, r0, r1)
    if abs(ra - rb) > 1e-9:
        arc = SpiralArc(arc, rb)
    return arc




def _blend_path(
    move: BlendMove, t0: NDArray[np.float64], p0: NDArray[np.float64], r0: NDArray[np.float64],
    model: RobotModel,
) -> Path:
    segs: list[Segment] = []
    p, r = p0, r0
    for el in move.segments:
        new, approach = _segment_for(move.name, el, move.frame, t0, p, r)
        if approach is not None:
            segs.append(approach)
        segs.extend(new)
        p = new[-1].p1
        r = new[-1].rotations(np.array([1.0]))[0]
    radius = move.blend_radius_mm
    if radius is None and move.blend_time_s:
        total = sum(s.length for s in segs)
        if move.duration_s is not None:
            v = total / move.duration_s
        else:
            v = model.cart_linear_speed_from_percent(path_speed_pct(move))
        radius = v * move.blend_time_s / 2.0
    if radius:
        segs = blend_corners(segs, radius)
    return Path(segs)
