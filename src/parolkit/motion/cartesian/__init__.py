"""Cartesian moves: MoveCart, MoveCartRelTRF, Cartesian jogs and the smooth paths.

Pipeline: geometry (:mod:`parolkit.motion.cartesian.geometry`, mm, exact) -> time-scaling ``s(t)`` of the
path progress (poly / trap / ruckig / TOPP-RA) -> the tool pose of every tick -> IK along the
path (``kinematics.ik_batch``, branch-continuous, seeded with the start joints) -> joint
speeds by differentiation -> the same sample checks as every move.

Timing:

* ``duration_s``: exactly that long (default POLY); a joint too fast -> refused.
* ``speed_pct`` (or the default :data:`DEFAULT_CART_SPEED_PCT` = 50 %): the move lasts
  path length / mapped speed (2..60 mm/s linear, 0.7..25 deg/s angular, the slower governs),
  as the original; default profile TRAP (1/3 accelerate, 1/3 cruise, 1/3 brake: the cruise
  speed is 1.5x the mapped mean speed).  When a joint
  cannot follow (speed or acceleration), the duration is stretched and a note says so.

Joint speeds: position-tracked paths (board command 156, the default) keep every joint within
:meth:`RobotModel.max_tracked_speed_steps_s` (the board's GO TO loop starts every tick 1.27x
faster than the stream moves at 100 Hz), checked on every sample's speed and on every tick's
step from the start on; speed-tracked paths (123) within the maximum speed.

A path through a singularity shows up as a joint needing an unbounded speed; beyond
:data:`MAX_STRETCH` times the requested duration the move is refused and the message names
the nearest singularity.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, NoReturn

import numpy as np

from parolkit.motion import singular, validate
from parolkit.motion.cartesian.geometry import (
    Arc,
    Line,
    Path,
    Segment,
    Spline,
    blend_corners,
    rot_about,
    rotation_angle,
)
from parolkit.motion.errors import PlanningError
from parolkit.motion.joint import (
    MOVEJOINT_DEFAULT_PCT,
    build_trajectory,
    hold,
    plan_joint_target,
    sample_times,
)
from parolkit.motion.profiles import (
    ScalarProfile,
    ruckig_unit_profile,
)
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import (
    ArcCenterMove,
    ArcParamMove,
    BlendMove,
    BlendSegment,
    CartAxis,
    CartJog,
    CartMove,
    CartRelTRFMove,
    CircleMove,
    Frame,
    HelixMove,
    JointMove,
    LineSegment,
    Plane,
    Profile,
    SplineMove,
    Tracking,
)
from parolkit.robot import JOINT_NAMES, RobotModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool

__all__ = [
    "plan_cartesian", "plan_cart_jog", "DEFAULT_CART_SPEED_PCT", "MAX_STRETCH",
    "CART_ACCEL_TIME_S", "ON_PATH_TOL_MM", "CartesianMove", "JogStart", "CartJogTrajectory",
]

#: The moves :func:`plan_cartesian` plans (a path of the tool; CartJog has its own planner).
CartesianMove = (
    CartMove | CartRelTRFMove | CircleMove | ArcCenterMove | ArcParamMove | HelixMove | SplineMove | BlendMove
)

#: MoveCart / smooth paths without duration and speed: this speed percentage (50 % -> a mean
#: speed of 31 mm/s or 12.85 deg/s), instead of the original's fixed 3.6 s.
DEFAULT_CART_SPEED_PCT = 50.0
#: A path needing more than this stretch of its duration is refused (singularity).
MAX_STRETCH = 8.0
#: Ruckig on a Cartesian path: reach the path speed within this time (s).
CART_ACCEL_TIME_S = 0.25
#: A start this close (mm / deg) to a circle/helix/start pose needs no approach segment.
ON_PATH_TOL_MM = 0.05
#: Arc ends may differ in radius by this much (mm); the arc then spirals linearly.
ARC_RADIUS_TOL_MM = 1.0


# ---------------------------------------------------------------------------------------------
# entry points
# ---------------------------------------------------------------------------------------------


def plan_cartesian(
    move: CartesianMove, start: NDArray[np.float64], *, model: RobotModel, tool: str | Tool | None,
    rate_hz: float,
) -> Trajectory:
    """Plan any Cartesian move or smooth path (see module docstring)."""
    from parolkit import kinematics as kin  # (imported when first needed)

    t0 = np.asarray(kin.fk_matrix(start, tool), dtype=float)
    p0, r0 = t0[:3, 3] * 1e3, t0[:3, :3]
    parts: list[Trajectory] = []
    notes: list[str] = []
    cur_q = start
    start_pose = getattr(move, "start_pose", None)
    if start_pose is not None:
        ts = _frame_pose(getattr(move, "frame", Frame.WRF), t0, start_pose)
        if _far(p0, r0, ts[:3, 3] * 1e3, ts[:3, :3]):
            approach = Path([Line(p0, ts[:3, 3] * 1e3, r0, ts[:3, :3])])
            parts.append(_time_and_solve(move, approach, cur_q, model, tool, rate_hz, approach=True))
            notes.append("approach: straight line to start_pose first")
            cur_q = parts[-1].final_deg
        p0, r0 = ts[:3, 3] * 1e3, ts[:3, :3]
        t0 = ts
    path, pre = _build_path(move, t0, p0, r0, rate_hz, model)
    for seg_path, note in pre:  # approach segments played as separate, resting moves
        parts.append(_time_and_solve(move, seg_path, cur_q, model, tool, rate_hz, approach=True))
        notes.append(note)
        cur_q = parts[-1].final_deg
    parts.append(_time_and_solve(move, path, cur_q, model, tool, rate_hz))
    if len(parts) == 1:
        return parts[0]
    return Trajectory.concatenate(parts, move, notes)


@dataclass(frozen=True)
class JogStart:
    """Where a streamed jog update continues the running jog (see
    :func:`plan_cart_jog`): the joint speeds (deg/s) at the start and the TCP orientation the
    running jog was following there (its path's, which the reached one may deviate from near
    the wrist singularity)."""

    speeds_deg_s: NDArray[np.float64]
    rotation: NDArray[np.float64] | None = None


@dataclass(frozen=True, eq=False)
class CartJogTrajectory(Trajectory):
    """A Cartesian jog's trajectory; ``path_rotations`` (N, 3, 3): the TCP orientation of the
    jog's path at every sample (a streamed update continues from it, :class:`JogStart`)."""

    path_rotations: NDArray[np.float64] | None = None

    def jog_start(self, k: int) -> JogStart:
        """The :class:`JogStart` for an update continuing from sample ``k``."""
        k = max(0, min(int(k), len(self) - 1))
        rot = None if self.path_rotations is None or not len(self.path_rotations) else self.path_rotations[
            min(k, len(self.path_rotations) - 1)]
        return JogStart(self.speeds[k] / self.model.steps_per_deg, rot)


def plan_cart_jog(
    move: CartJog, start: NDArray[np.float64], *, model: RobotModel, tool: str | Tool | None, rate_hz: float,
    jog_start: JogStart | None = None,
) -> CartJogTrajectory:
    """Constant Cartesian speed along / about one axis of WRF or TRF for ``duration_s``.

    Streamed with position + speed (board 156) so the tool stays on the line; the first tick
    already moves at the jog speed (as the original jog); a final zero-speed sample ends it.
    From or near the wrist singularity (standby) the singular-area policy keeps the TCP
    position exact from the first tick while J4/J6 turn (:mod:`parolkit.motion.singular`).
    ``jog_start``: a streamed update continuing a running jog (its orientation and speeds).
    """
    from parolkit import kinematics as kin

    t0 = np.asarray(kin.fk_matrix(start, tool), dtype=float)
    p0, r0 = t0[:3, 3] * 1e3, t0[:3, :3]
    start_speed = None
    if jog_start is not None:
        start_speed = np.asarray(jog_start.speeds_deg_s, dtype=float)
        if jog_start.rotation is not None:
            r0 = np.asarray(jog_start.rotation, dtype=float)
    jog_axis = CartAxis.parse(move.axis)
    is_rot, ax, sign = jog_axis.is_rotation, jog_axis.axis_index, jog_axis.sign
    axis = np.eye(3)[ax] if move.frame is Frame.WRF else r0[:, ax]
    T = float(move.duration_s)
    n = max(1, int(math.ceil(T * rate_hz - 1e-6)))
    t = np.arange(1, n + 1, dtype=float) / rate_hz
    tc = np.minimum(t, T)
    if is_rot:
        w = math.radians(model.cart_angular_speed_from_percent(move.speed_pct)) * sign
        rots = rot_about(axis, w * tc)
        rots = rots @ r0[None] if move.frame is Frame.WRF else r0[None] @ rot_about(np.eye(3)[ax], w * tc)
        pos = np.repeat(p0[None, :], n, axis=0)
    else:
        v = model.cart_linear_speed_from_percent(move.speed_pct) * sign
        pos = p0[None, :] + (v * tc)[:, None] * axis[None, :]
        rots = np.repeat(r0[None], n, axis=0)
    notes: list[str] = []
    vmax = validate.speed_limits(model, rate_hz, True).array / model.steps_per_deg

    def stopped(k: int, reason: str) -> None:
        notes.append(f"stopped after {k / rate_hz:.2f} s: {reason}")

    def at_rest(reason_k: int) -> CartJogTrajectory:
        q0 = np.asarray(start, dtype=float)[None, :]
        tr = build_trajectory(move, np.array([1.0 / rate_hz]), q0, np.zeros((1, 6)),
                              start=start, model=model, rate=rate_hz,
                              tracking=Tracking.POSITION, notes=notes, check_accel=False)
        return _jog_trajectory(tr, r0[None])

    q: NDArray[np.float64] | None = None
    area: singular.WristArea | None = None
    while q is None:
        try:
            q, area = _solve_path(move.name, pos, rots, start, tool, t, model, vmax, start_speed, jog=True)
        except PlanningError as exc:
            # a jog stops where the path leaves the workspace or a joint range (with a note)
            k = int(round((exc.time_s or t[0]) * rate_hz)) - 1
            notes[:] = []
            stopped(k, exc.reason)
            if k <= 0:
                return at_rest(k)
            t, pos, rots = t[:k], pos[:k], rots[:k]
            n = k
    if area is not None:
        over = area.first_over(singular.MAX_DEVIATION_DEG)
        if over is not None:
            stopped(over, f"near the wrist singularity the tool orientation would deviate more than "
                    f"{singular.MAX_DEVIATION_DEG:g} deg while J4/J6 turn (lower the jog speed, or "
                    f"move J5 away from 0)")
            if over == 0:
                return at_rest(0)
            t, q, pos, rots = t[:over], q[:over], pos[:over], rots[:over]
            area = singular.WristArea(q, area.deviation_deg[:over], t)
            n = over
        notes.insert(0, area.note())
    dt = 1.0 / rate_hz
    # speed to send at tick k: the motion to the next sample; the last: the rest of the jog
    full = np.vstack([start[None, :], q])
    step = np.diff(full, axis=0) / dt  # step[k]: speed from sample k-1 to sample k
    # a jog stops before the sample a joint cannot reach at its (position-tracking) maximum
    # speed (singularity)
    too_fast = np.nonzero(np.any(np.abs(step) > vmax, axis=1))[0]
    if len(too_fast):
        k = int(too_fast[0])
        j = int(np.argmax(np.abs(step[k]) / vmax))
        stopped(k, f"{JOINT_NAMES[j]} would exceed its position-tracking maximum speed"
                   f"{_sing_text(q[k], tool)}")
        if k == 0:
            return at_rest(0)
        t, q, step, rots = t[:k], q[:k], step[:k], rots[:k]
        n = k
    qd = np.vstack([step[1:], np.zeros((1, 6))]) if n > 1 else np.zeros((1, 6))
    t_all = np.append(t, t[-1] + dt)
    q_all = np.vstack([q, q[-1:]])
    qd_all = np.vstack([qd, np.zeros((1, 6))])
    tr = build_trajectory(move, t_all, q_all, qd_all, start=start, model=model, rate=rate_hz,
                          tracking=Tracking.POSITION, check_accel=False, notes=notes,
                          hint="lower the jog speed")
    return _jog_trajectory(tr, np.concatenate([rots, rots[-1:]]))


def _jog_trajectory(tr: Trajectory, rots: NDArray[np.float64]) -> CartJogTrajectory:
    return CartJogTrajectory(
        t=tr.t, positions=tr.positions, speeds=tr.speeds, commands=tr.commands, rate_hz=tr.rate_hz,
        move=tr.move, notes=tr.notes, start_deg=tr.start_deg, model=tr.model, planned_deg=tr.planned_deg,
        path_rotations=np.array(rots, dtype=float))


# ---------------------------------------------------------------------------------------------
# geometry from the move
# ---------------------------------------------------------------------------------------------


def _frame_pose(frame: Frame, t0: NDArray[np.float64], pose: Sequence[float]) -> NDArray[np.float64]:
    from parolkit import kinematics as kin

    m: NDArray[np.float64] = np.asarray(kin.pose_to_matrix(pose), dtype=float)
    return t0 @ m if frame is Frame.TRF else m


def _frame_point(frame: Frame, t0: NDArray[np.float64], point: Sequence[float]) -> NDArray[np.float64]:
    p: NDArray[np.float64] = np.asarray(point, dtype=float)
    return t0[:3, 3] * 1e3 + t0[:3, :3] @ p if frame is Frame.TRF else p


def _frame_rot(frame: Frame, t0: NDArray[np.float64]) -> NDArray[np.float64]:
    return t0[:3, :3] if frame is Frame.TRF else np.eye(3)


def _far(pa: NDArray[np.float64], ra: NDArray[np.float64], pb: NDArray[np.float64], rb: NDArray[np.float64]) -> bool:
    return float(np.linalg.norm(pa - pb)) > ON_PATH_TOL_MM or math.degrees(rotation_angle(ra, rb)) > ON_PATH_TOL_MM


def _build_path(
    move: CartesianMove, t0: NDArray[np.float64], p0: NDArray[np.float64], r0: NDArray[np.float64],
    rate_hz: float, model: RobotModel,
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
        t1 = _frame_pose(frame, t0, seg.pose)
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
        t1 = _frame_pose(frame, t0, seg.end_pose)
        c = _frame_point(frame, t0, seg.center_mm)
        return [_arc_through(name, p, t1[:3, 3] * 1e3, c, None, fr, seg.clockwise, r, t1[:3, :3])], None
    if isinstance(seg, ArcParamMove):
        t1 = _frame_pose(frame, t0, seg.end_pose)
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
        mats = [_frame_pose(frame, t0, wp) for wp in seg.waypoints]
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
        arc = _SpiralArc(arc, rb)
    return arc


class _SpiralArc(Arc):
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
            pct = move.speed_pct if move.speed_pct is not None else DEFAULT_CART_SPEED_PCT
            v = model.cart_linear_speed_from_percent(pct)
        radius = v * move.blend_time_s / 2.0
    if radius:
        segs = blend_corners(segs, radius)
    return Path(segs)


# ---------------------------------------------------------------------------------------------
# timing + IK + checks
# ---------------------------------------------------------------------------------------------


def _time_and_solve(move: CartesianMove, path: Path, start: NDArray[np.float64], model: RobotModel,
                    tool: str | Tool | None, rate_hz: float, *, approach: bool = False) -> Trajectory:
    name = move.name
    tracking = getattr(move, "tracking", Tracking.POSITION)
    duration = None if approach else move.duration_s
    pct = move.speed_pct if move.speed_pct is not None else DEFAULT_CART_SPEED_PCT
    v_lin = model.cart_linear_speed_from_percent(pct)  # mm/s
    w_ang = model.cart_angular_speed_from_percent(pct)  # deg/s
    mm_per_rad = v_lin / math.radians(w_ang)
    path = Path.weighted(path.segments, mm_per_rad)
    # duration at the mapped speeds: path length / speed, the slower of linear and angular
    base = max(path.length / v_lin, math.degrees(path.angle) / w_ang)
    notes: list[str] = []
    if base < 1e-9:
        return hold(move, start, np.asarray(start, dtype=float), model, rate_hz, tracking)
    profile = move.profile or (Profile.POLY if duration is not None else Profile.TRAP)
    if approach and profile is Profile.TOPPRA:
        profile = Profile.TRAP
    if profile is Profile.TOPPRA:
        # TOPP-RA times the exact joint path: from the wrist singularity J4/J6 turn first
        unwind = _unwind_wrist(move, path, start, model, tool, rate_hz, tracking)
        if unwind is not None:
            main = _time_and_solve(move, path, _planned_end(unwind), model, tool, rate_hz,
                                   approach=approach)
            return Trajectory.concatenate([unwind, main], move)
        return _toppra_path(move, path, start, model, tool, rate_hz, duration, base, tracking)
    if duration is None:
        if move.speed_pct is None and not approach:
            notes.append(f"no duration or speed given: path speed {DEFAULT_CART_SPEED_PCT:g} % "
                         f"({v_lin:g} mm/s, {w_ang:g} deg/s)")
    limits = validate.speed_limits(model, rate_hz, tracking is Tracking.POSITION)
    vmax = limits.array

    def timed(prof: ScalarProfile) -> _TimedPath:
        # a duration given: only the speed limits refuse it (the acceleration ones warn)
        return _TimedPath(name, prof, path, start, model, tool, rate_hz, limits,
                          accel_hard=duration is None)

    stretch = 1.0
    wrist_bound = False  # a stretch made for the singular area's bounds
    for _attempt in range(4):
        tm = timed(_path_profile(profile, base, duration, stretch))
        if tm.fits:
            break
        factor = tm.factor
        wrist_bound = wrist_bound or tm.r_dev >= max(tm.r_v, math.sqrt(tm.r_a))
        if factor > MAX_STRETCH and _near_singularity(tm.q, tm.v_steps, vmax):
            _refuse_singular(name, tm.t, tm.q, tm.v_steps, vmax, tool)
        if duration is not None:
            tm.refuse(_least_duration(tm, profile, base, timed))
        stretch *= factor * 1.02
    else:
        # stretching does not help: a kink (a sharp corner, or a singularity grazed)
        tm.refuse("the path has a sharp corner or grazes a singularity here: round the corners "
                  "(blend radius) or change the path")
        raise PlanningError(name, "no feasible timing found within the joint limits after stretching")
    t, q, qd, T = tm.t, tm.q, tm.qd, tm.T
    if stretch > 1.0:
        j = int(np.argmax(np.max(np.abs(tm.v_steps) / vmax, axis=0)))
        why = (f"J4/J6 turning out of the wrist singularity (orientation within "
               f"{singular.MAX_DEVIATION_DEG:g} deg, exact at the end)" if wrist_bound else
               f"joint speed/acceleration limits ({JOINT_NAMES[j]} the busiest)")
        notes.append(f"duration stretched from {_nominal(profile, base):.2f} s to {T:.2f} s: {why}")
    if tm.area is not None:
        notes.append(tm.area.note())
    if duration is not None:
        warning = validate.accel_warning(np.max(np.abs(tm.acc), axis=0), model, duration)
        if warning is not None:
            notes.append(warning)
    _check_jumps(name, t, np.vstack([start[None, :], q]), model, rate_hz, tool)
    # speeds and accelerations were checked sample by sample in the loop above (proven)
    return build_trajectory(move, t, q, qd, start=start, model=model, rate=rate_hz, tracking=tracking,
                            notes=notes, target_deg=q[-1], proven=True)


#: A path lasting at most this many ticks is also checked on a finer grid than the ticks
#: (:class:`_TimedPath`): its samples may not resolve it (a whole circle in one tick is one sample,
#: back at the start).
FINE_CHECK_TICKS = 20
#: Points of that finer grid (at least; 4 per tick for longer ones).
FINE_CHECK_POINTS = 32


class _TimedPath:
    """A path timed by ``prof`` and sampled at the ticks: joint angles, speeds, and how far
    they are over the limits (``r_v``, ``r_a``: 1 = at the limit).

    Speeds are checked three ways: the samples' speeds (central differences), what each tick
    asks the board to cover, from the start on (a move shorter than a tick is one sample of
    speed 0 that hid a jump of up to 2x the maximum speed), and, for short paths, the joints'
    speeds along the path itself on a finer grid than the ticks."""

    def __init__(self, name: str, prof: ScalarProfile, path: Path, start: NDArray[np.float64], model: RobotModel,
                 tool: str | Tool | None, rate_hz: float, limits: validate.SpeedLimits, *,
                 accel_hard: bool = True) -> None:
        self.name, self.model, self.rate_hz, self.limits = name, model, rate_hz, limits
        #: False for a duration given: the acceleration limits then do not count in ``fits``
        self.accel_hard = accel_hard
        T = self.T = prof.T
        t = self.t = sample_times(T, rate_hz)
        s, _, _ = prof(t)
        pos, rots = path.evaluate(s)
        spd = model.steps_per_deg
        vmax = limits.array
        q, self.area = _solve_path(name, pos, rots, start, tool, t, model, vmax / spd)
        self.q = q
        qd = self.qd = _derivative(q, start, rate_hz, t, T)
        amax = validate.model_arrays(model).amax  # per joint, steps/s^2
        v_steps = self.v_steps = qd * spd
        self.acc: NDArray[np.float64] = np.diff(np.vstack([np.zeros((1, 6)), v_steps]), axis=0) * rate_hz
        v_tick: NDArray[np.float64] = np.diff(np.vstack([start[None, :], q]), axis=0) * (rate_hz * spd)
        self.v_chk: NDArray[np.float64] = np.where(np.abs(v_tick) > np.abs(v_steps), v_tick, v_steps)
        self.r_v = float(np.max(np.abs(self.v_chk) / vmax))
        self.fine: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        #: how far over the singular-area orientation bound (1 = at it)
        self.r_dev = 0.0 if self.area is None else self.area.overload()
        if len(t) <= FINE_CHECK_TICKS:
            n = max(FINE_CHECK_POINTS, 4 * len(t))
            tf = np.linspace(0.0, T, n + 1)[1:]
            sf, _, _ = prof(tf)
            posf, rotsf = path.evaluate(sf)
            qf, area_f = _solve_path(name, posf, rotsf, start, tool, tf, model, vmax / spd)
            if area_f is not None:
                self.r_dev = max(self.r_dev, area_f.overload())
            vf: NDArray[np.float64] = np.diff(np.vstack([start[None, :], qf]), axis=0) * (spd * n / T)
            self.fine = (tf, vf)
            self.r_v = max(self.r_v, float(np.max(np.abs(vf) / vmax)))
        self.r_a = float(np.max(np.max(np.abs(self.acc), axis=0) / (amax * (1 + validate.ACCEL_TOLERANCE))))

    @property
    def fits(self) -> bool:
        return self.r_v <= 1.0 and (self.r_a <= 1.0 or not self.accel_hard) and self.r_dev <= 1.0

    @property
    def factor(self) -> float:
        """How much longer the path must take to fit (speeds scale with 1 / time,
        accelerations with 1 / time^2; the singular-area deviation roughly with 1 / time)."""
        return max(self.r_v, math.sqrt(self.r_a) if self.accel_hard else 1.0, self.r_dev, 1.0)

    def refuse(self, hint: str) -> None:
        """Raise the PlanningError of the first limit exceeded (joint, time, value, limit), with
        ``hint``; return when nothing is exceeded."""
        validate.check_speeds(self.name, self.t, self.v_chk, self.model, hint=hint, limits=self.limits)
        if self.fine is not None:
            tf, vf = self.fine
            validate.check_speeds(self.name, tf, vf, self.model, hint=hint, limits=self.limits)
        if self.accel_hard:
            validate.check_accels(self.name, self.t, self.v_steps, self.model, self.rate_hz, hint=hint)
        if self.r_dev > 1.0 and self.area is not None:
            raise _deviation_error(self.name, self.area, hint)


#: The refusal of a duration names the shortest one that fits, searched up to this long (s).
LEAST_DURATION_SEARCH_S = 600.0


def _least_duration(tm: _TimedPath, profile: Profile, base: float,
                    timed: Callable[[ScalarProfile], _TimedPath]) -> str:
    """How the refusal of ``tm``'s duration says what would fit: ``"give a duration of at
    least X s"`` with the shortest duration (to 0.01 s) at which the path fits.  Searched, not
    scaled: a move of less than a tick does not scale like a longer one (its one sample hid
    the path).  Grows the duration (by the overload, at most 4x a step) until it fits, then
    halves the interval down to 0.01 s; a dozen plans of the path at most, on refusals only."""

    def fits(T: float) -> tuple[bool, float]:
        try:
            trial = timed(_path_profile(profile, base, T, 1.0))
        except PlanningError:
            return False, 2.0
        return trial.fits, trial.factor

    lo = tm.T
    hi = max(math.ceil(max(tm.T, 1.0 / tm.rate_hz) * 100 - 1e-6) / 100, 0.01)
    factor = tm.factor
    ok = hi > lo and fits(hi)[0]
    while not ok:
        lo = hi
        hi = math.ceil(hi * min(max(factor * 1.02, 1.1), 4.0) * 100) / 100
        if hi > LEAST_DURATION_SEARCH_S:
            return f"no duration up to {LEAST_DURATION_SEARCH_S:g} s fits"
        ok, factor = fits(hi)
    while hi - lo > 0.0101:
        mid = math.ceil((lo + hi) / 2 * 100 - 1e-6) / 100
        if mid >= hi:
            break
        if fits(mid)[0]:
            hi = mid
        else:
            lo = mid
    return f"give a duration of at least {hi:.2f} s"


#: |J5| (deg) at or below which the start counts as exactly on the wrist singularity.
WRIST_SINGULAR_START_DEG = 0.01


def _unwind_wrist(
    move: CartesianMove | CartJog, path: Path | None, start: NDArray[np.float64], model: RobotModel,
    tool: str | Tool | None, rate_hz: float, tracking: Tracking, pct: tuple[float, float] | None = None,
    first: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> Trajectory | None:
    """A path starting exactly on the wrist singularity (J5 = 0, e.g. the standby pose after
    homing) may need J4 at another angle from the first tick on.  Axes 4 and 6 are aligned
    there, so J4 + d and J6 - d is the same pose: turn J4/J6 that way first (a joint move
    that leaves the tool where it is), then follow the path.  None when not needed.

    ``pct``: (speed %, accel %) of that joint move (default MoveJoint's); ``first``: the
    (positions, rotations) of the first path sample when there is no ``path``."""
    if abs(float(start[4])) > WRIST_SINGULAR_START_DEG:
        return None
    if first is not None:
        pos, rots = first
    elif path is not None:
        pos, rots = path.evaluate(np.array([1e-4]))
    else:
        raise TypeError("_unwind_wrist needs the path or its first sample")
    try:
        q_eps = _solve_ik(move.name, pos, rots, start, tool, np.array([0.0]))[0]
    except PlanningError:
        return None
    d = float(q_eps[3] - start[3])
    if abs(d) < 1e-3:
        return None
    target = np.array(start, dtype=float)
    target[3] += d
    target[5] -= d

    lim = model.safe_limits_deg
    if not lim[5, 0] <= target[5] <= lim[5, 1]:
        alt = target[5] + (360.0 if target[5] < lim[5, 0] else -360.0)
        if lim[5, 0] <= alt <= lim[5, 1]:
            target[5] = alt
    jm = JointMove(target.tolist(), tracking=tracking)
    try:
        tr = plan_joint_target(jm, np.asarray(start, dtype=float), target, model, rate_hz,
                                pct or MOVEJOINT_DEFAULT_PCT)
    except PlanningError as exc:
        raise PlanningError(move.name, f"the path starts on the wrist singularity and J4/J6 cannot "
                            f"turn out of it: {exc.reason}", joint=exc.joint, value=exc.value) from exc
    note = (f"start on the wrist singularity (J5 = 0): J4 turned {d:+.1f} deg and J6 {-d:+.1f} deg "
            f"first ({tr.duration:.2f} s, the tool does not move)")
    return Trajectory(t=tr.t, positions=tr.positions, speeds=tr.speeds, commands=tr.commands,
                      rate_hz=tr.rate_hz, move=move, notes=(note,), start_deg=tr.start_deg,
                      model=model, planned_deg=tr.planned_deg)


def _planned_end(tr: Trajectory) -> NDArray[np.float64]:
    """The joint angles (deg) the planner computed for the last sample of ``tr`` (every
    trajectory :mod:`parolkit.motion.joint` builds records them)."""
    if tr.planned_deg is None:
        raise ValueError(f"{tr.name}: a planned trajectory without planned_deg (a planner bug)")
    end: NDArray[np.float64] = tr.planned_deg[-1]
    return end


def _nominal(profile: Profile, base: float) -> float:
    return _path_profile(profile, base, None, 1.0).T


def _path_profile(profile: Profile, base: float, duration: float | None, stretch: float) -> ScalarProfile:
    """Unit profile: with ``duration`` exactly that long; otherwise ``base`` (s, path length /
    mapped speed) times ``stretch`` for poly and trap (the mapped speed is the MEAN speed, as
    in the original), and for Ruckig the mapped speed is the speed limit."""
    if duration is not None:
        T = duration
        if profile is Profile.TRAP:
            return ScalarProfile("trap", T, T / 3.0)
        if profile is Profile.RUCKIG:
            # scale-free limits (peak speed <= 2x the mean; the fastest such profile takes
            # ~0.7 T), Ruckig then fits the jerk-limited profile to exactly T
            return ruckig_unit_profile(2.0 / T, 16.0 / T**2, 256.0 / T**3, min_duration=T)
        return ScalarProfile("poly", T)
    if profile is Profile.TRAP:
        T = base * stretch
        return ScalarProfile("trap", T, T / 3.0)
    if profile is Profile.POLY:
        return ScalarProfile("poly", base * stretch)
    v_s = 1.0 / (base * stretch)
    a_s = v_s / (CART_ACCEL_TIME_S * stretch)
    return ruckig_unit_profile(v_s, a_s, a_s / 0.1 / stretch)


#: |r02| this close to 1 is the gimbal lock of the A, B, C convention (B = +-90 deg).
_GIMBAL_EPS = 1e-12


def poses_from_rotations(pos_mm: NDArray[np.float64], rots: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3) mm + (N, 3, 3) rotations -> (N, 6) poses [x, y, z mm, A, B, C deg] with
    R = Rx(C) Ry(B) Rz(A) (the kinematics convention; at B = +-90 deg, A = 0).

    Our rotations are orthonormal by construction, so handing the IK poses instead of 4x4
    matrices skips its per-matrix orthonormality check (a third of a Cartesian plan)."""
    r = rots
    out = np.empty((len(pos_mm), 6))
    out[:, :3] = pos_mm
    r00, r01, r02 = r[:, 0, 0], r[:, 0, 1], r[:, 0, 2]
    out[:, 3] = -np.arctan2(r01, r00)
    out[:, 4] = np.arctan2(r02, np.hypot(r00, r01))
    out[:, 5] = -np.arctan2(r[:, 1, 2], r[:, 2, 2])
    lock = np.abs(np.abs(r02) - 1.0) < _GIMBAL_EPS
    if lock.any():
        i = np.nonzero(lock)[0]
        out[i, 3] = 0.0
        out[i, 4] = np.arcsin(np.clip(r02[i], -1.0, 1.0))
        out[i, 5] = np.where(r02[i] > 0, np.arctan2(r[i, 2, 1], r[i, 1, 1]),
                             -np.arctan2(r[i, 1, 0], r[i, 2, 0]))
    np.degrees(out[:, 3:], out=out[:, 3:])
    return out


def _solve_ik(
    name: str, pos_mm: NDArray[np.float64], rots: NDArray[np.float64], seed: NDArray[np.float64],
    tool: str | Tool | None, t: NDArray[np.float64],
) -> NDArray[np.float64]:
    from parolkit import kinematics as kin

    n = len(pos_mm)
    poses = poses_from_rotations(pos_mm, rots)
    try:
        q: NDArray[np.float64] = np.asarray(kin.ik_batch(poses, seed, tool=tool), dtype=float)
        return q
    except kin.IKError as exc:
        k = exc.sample if exc.sample is not None else 0
        p = pos_mm[min(k, n - 1)]
        raise PlanningError(
            name, f"the path leaves the robot's reach at [{p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}] mm: {exc.reason}",
            time_s=float(t[min(k, n - 1)]), joint=exc.joint, value=exc.value,
        ) from exc


def _solve_path(
    name: str, pos_mm: NDArray[np.float64], rots: NDArray[np.float64], seed: NDArray[np.float64],
    tool: str | Tool | None, t: NDArray[np.float64], model: RobotModel, v_limits_deg_s: NDArray[np.float64],
    start_speed_deg_s: NDArray[np.float64] | None = None, jog: bool = False,
) -> tuple[NDArray[np.float64], singular.WristArea | None]:
    """Joint angles (deg) for the sampled path at times ``t`` (s): the exact IK, or where that
    turns J4/J6 faster than ``v_limits_deg_s`` near J5 = 0, the singular-area policy
    (:mod:`parolkit.motion.singular`: TCP position exact, orientation deviation measured).
    Returns (q, the policy's result or None when the exact solution is used)."""
    q = _solve_ik(name, pos_mm, rots, seed, tool, t)
    full = np.vstack([np.asarray(seed, dtype=float)[None, :], q])
    tt = np.concatenate(([0.0], t))
    if not singular.needs_policy(full, tt, v_limits_deg_s):
        return q, None
    from parolkit import kinematics as kin

    try:
        area = singular.follow(pos_mm, rots, q, seed, t, model=model, tool=tool,
                               v_limits_deg_s=v_limits_deg_s, start_speed_deg_s=start_speed_deg_s,
                               stop_at_end=not jog)
    except kin.IKError as exc:
        k = min(exc.sample if exc.sample is not None else 0, len(t) - 1)
        p = pos_mm[k]
        raise PlanningError(
            name, f"the path leaves the robot's reach at [{p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}] mm near the "
            f"wrist singularity: {exc.reason}", time_s=float(t[k])) from exc
    return area.q_deg, area


def _deviation_error(name: str, area: singular.WristArea, hint: str) -> PlanningError:
    if area.max_deviation_deg <= singular.MAX_DEVIATION_DEG:
        return PlanningError(
            name, f"near the wrist singularity (J5 = 0) J4/J6 cannot turn in time: the tool "
            f"orientation would still deviate {area.end_deviation_deg:.2f} deg from the target at the "
            f"end: {hint}", time_s=float(area.t[-1]), joint=3, value=area.end_deviation_deg)
    k = int(np.argmax(area.deviation_deg))
    return PlanningError(
        name, f"near the wrist singularity (J5 = 0) the tool orientation would deviate "
        f"{area.deviation_deg[k]:.1f} deg from the path while J4/J6 turn (at most "
        f"{singular.MAX_DEVIATION_DEG:g} deg): {hint}", time_s=float(area.t[k]), joint=3,
        value=float(area.deviation_deg[k]))


def _derivative(
    q: NDArray[np.float64], start: NDArray[np.float64], rate_hz: float, t: NDArray[np.float64], T: float,
) -> NDArray[np.float64]:
    """Joint speeds (deg/s) at the samples: central differences; zero once the path has ended."""
    full = np.vstack([start[None, :], q])
    qd: NDArray[np.float64] = np.gradient(full, 1.0 / rate_hz, axis=0)[1:]
    qd[t >= T - 1e-9] = 0.0
    return qd


def _check_jumps(
    name: str, t: NDArray[np.float64], full_q: NDArray[np.float64], model: RobotModel, rate_hz: float,
    tool: str | Tool | None,
) -> None:
    """A branch hop: a joint moving more than 4x its maximum speed allows within one tick."""
    step = np.abs(np.diff(full_q, axis=0))
    lim = 4.0 * model.max_speed_deg_s / rate_hz
    bad = np.argwhere(step > lim)
    if len(bad):
        k, j = int(bad[0][0]), int(bad[0][1])
        raise PlanningError(
            name, f"{JOINT_NAMES[j]} jumps {step[k, j]:.2f} deg within one tick (branch change or "
            f"singularity{_sing_text(full_q[k + 1], tool)})", time_s=float(t[k]), joint=j,
            value=float(full_q[k + 1, j]),
        )


def _sing_text(q: NDArray[np.float64], tool: str | Tool | None) -> str:
    try:
        from parolkit import kinematics as kin

        info = kin.singularity_distance(q)
    except Exception:  # informative only
        return ""
    return (f"; nearest: {info.nearest} singularity (wrist {info.wrist_deg:.2f} deg, shoulder "
            f"{info.shoulder_mm:.1f} mm, elbow {info.elbow_deg:.2f} deg)")


def _near_singularity(q: NDArray[np.float64], v_steps: NDArray[np.float64], vmax: NDArray[np.float64]) -> bool:
    """Is the sample needing the highest joint speed near a singularity?"""
    ratio = np.max(np.abs(v_steps) / vmax, axis=1)
    k = int(np.argmax(ratio))
    try:
        from parolkit import kinematics as kin

        return bool(kin.singularity_distance(q[k]).near)
    except Exception:  # no singularity information: judge by the spike alone
        return bool(ratio[k] > 20 * max(np.median(ratio), 1e-9))


def _refuse_singular(
    name: str, t: NDArray[np.float64], q: NDArray[np.float64], v_steps: NDArray[np.float64],
    vmax: NDArray[np.float64], tool: str | Tool | None,
) -> NoReturn:
    ratio = np.abs(v_steps) / vmax
    k, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    raise PlanningError(
        name,
        f"{JOINT_NAMES[j]} would need {abs(v_steps[k, j]):.0f} steps/s ({ratio[k, j]:.1f}x its maximum): "
        f"the path passes too close to a singularity{_sing_text(q[k], tool)}",
        time_s=float(t[k]), joint=int(j), value=float(v_steps[k, j]),
    )


def _toppra_path(
    move: CartesianMove, path: Path, start: NDArray[np.float64], model: RobotModel, tool: str | Tool | None,
    rate_hz: float, duration: float | None, base: float, tracking: Tracking,
) -> Trajectory:
    """TOPP-RA on the joint path (dense IK), then the exact geometry at the optimal s(t).

    Without a duration the mapped Cartesian speed (``1 / base`` of the path per second) is a
    path speed limit besides the joint speed and acceleration limits."""
    from parolkit.motion.topp import toppra_parameterize

    name = move.name
    m = int(min(400, max(30, path.length / 2.0, math.degrees(path.angle) / 2.0)))
    s_grid = np.linspace(0.0, 1.0, m)
    pos, rots = path.evaluate(s_grid)
    q_grid = _solve_ik(name, pos, rots, start, tool, s_grid)
    spd = model.steps_per_deg
    vmax = validate.speed_limits(model, rate_hz, tracking is Tracking.POSITION).array / spd
    amax = validate.model_arrays(model).amax / spd
    # a 7th coordinate = s itself (unconstrained) recovers s(t) from the joint-space result
    aug = np.hstack([q_grid, s_grid[:, None]])
    s_vmax = 1e6 if duration is not None else 1.0 / base
    res = toppra_parameterize(s_grid, aug, np.append(vmax, s_vmax), np.append(amax, 1e9), duration=duration)
    if duration is not None and (res is None or res.duration > duration * (1 + 1e-6)):
        # a duration given: the acceleration limits give way (a warning), the speed ones hold
        res = toppra_parameterize(s_grid, aug, np.append(vmax, s_vmax), np.append(amax * 1e3, 1e9),
                                  duration=duration)
    if res is None:
        raise PlanningError(name, "TOPP-RA finds no feasible timing within the joint limits")
    if duration is not None and res.duration > duration * (1 + 1e-6):
        raise PlanningError(name, f"too fast for t={duration:g} s: TOPP-RA needs at least {res.duration:.3f} s")
    T = res.duration
    t = sample_times(T, rate_hz)
    s = np.clip(res.evaluate(t)[0][:, 6], 0.0, 1.0)
    s = np.maximum.accumulate(s)
    s[t >= T - 1e-9] = 1.0
    pos, rots = path.evaluate(s)
    q = _solve_ik(name, pos, rots, start, tool, t)
    qd = _derivative(q, start, rate_hz, t, T)
    _check_jumps(name, t, np.vstack([start[None, :], q]), model, rate_hz, tool)
    return build_trajectory(move, t, q, qd, start=start, model=model, rate=rate_hz, tracking=tracking,
                            notes=[f"TOPP-RA time-optimal: {res.optimal_duration:.2f} s"
                                   + (f", slowed uniformly to {T:.2f} s" if T > res.optimal_duration * 1.001 else "")],
                            target_deg=q[-1], timed_s=duration,
                            hint="the time-optimal timing exceeds a limit after sampling")
