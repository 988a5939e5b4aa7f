"""Blending queued moves: a chain of MoveCart (or of MoveJoint / MovePose) whose corners are
rounded within each move's ``blend`` radius, planned and played as ONE trajectory, so the arm
does not stop at the corners (issue 24, item 4).

The controller core finds the chain in its queue (consecutive moves of one kind, each but the
last with a ``blend``) and asks for :func:`plan_blended`; the trajectory is played by one
activity, and each move of the chain completes when the arm passes the sample nearest its
target (:attr:`BlendedPlan.marks`).

* **Cartesian** (MoveCart): straight lines through the targets (WRF), each corner cut ``blend``
  mm before and after it (at most 45 % of either line) and joined by a tangent-continuous cubic
  Bezier (:func:`parolkit.motion.cartesian.geometry.blend_corners`), orientation interpolated
  along it; timed as one path by the Cartesian pipeline (Ruckig at the path speed: the TCP
  speed stays up through every corner), IK along it, stretched where a joint cannot follow.
* **Joint space** (MoveJoint, MovePose: a pose target is solved once, seeded with the target
  before it): straight joint-space lines through the targets, each corner cut ``blend`` deg
  (joint-space distance) before and after it (at most 45 % of either line) and joined by a
  quadratic Bezier; timed by TOPP-RA within every joint's speed and acceleration at the
  chain's percentages (position-tracked: the position-tracking maximum).

Timing of a chain: when every move gives a duration, the chain lasts their sum (never less
than the fastest the joints allow: then it runs slower, with a note); otherwise it runs at the
slowest speed (and acceleration) percentage any of its moves asks for, each move's own or its
default, and durations given are not used (a note says so).  The path passes every corner
within its ``blend`` (the rounding lies inside the corner's triangle).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from parolkit.errors import ParolkitValueError
from parolkit.motion import validate
from parolkit.motion.errors import PlanningError
from parolkit.motion.joint import MOVEJOINT_DEFAULT_PCT, MOVEPOSE_DEFAULT_PCT, build_trajectory, sample_times
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import MAX_BLEND_CHAIN, CartMove, JointMove, PoseMove, Profile, Tracking, blend_kind

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool
    from parolkit.robot import RobotModel

__all__ = ["BlendChain", "BlendedPlan", "plan_blended", "blend_kind", "MAX_CHAIN"]

#: Spacing of the points a joint-space chain is sampled at for TOPP-RA (deg of joint-space
#: distance) and the points per rounded corner.
_JOINT_STEP_DEG = 2.0
_CORNER_POINTS = 9
#: The most moves one blended chain holds.
MAX_CHAIN = MAX_BLEND_CHAIN


@dataclass(frozen=True)
class BlendChain:
    """Moves of one kind planned as one trajectory, the corner after each move but the last
    rounded within its ``blend``.  Timing fields as the Cartesian pipeline reads them."""

    moves: tuple[JointMove | PoseMove | CartMove, ...]
    duration_s: float | None = None
    speed_pct: float | None = None
    accel_pct: float | None = None
    profile: Profile | None = None
    tracking: Tracking = Tracking.POSITION
    notes: tuple[str, ...] = field(default=(), compare=False)

    @property
    def name(self) -> str:
        """``"MoveCart x20 blended"``: how the planner's messages name the chain."""
        return f"{self.moves[0].name} x{len(self.moves)} blended"


@dataclass(frozen=True)
class BlendedPlan:
    """The chain's trajectory and, for each move but the last, the sample index at which the
    arm passes its target (nearest the corner): that move is done once that sample is played."""

    trajectory: Trajectory
    marks: tuple[int, ...]


def _chain(moves: Sequence[object]) -> BlendChain:
    ms = tuple(m for m in moves if isinstance(m, (JointMove, PoseMove, CartMove)))
    if len(ms) != len(moves) or len({blend_kind(m) for m in ms}) != 1:
        names = ", ".join(type(m).__name__ for m in moves)
        raise ParolkitValueError(f"a blended chain is all MoveCart or all MoveJoint/MovePose, got {names}")
    if not 2 <= len(ms) <= MAX_CHAIN:
        raise ParolkitValueError(f"a blended chain holds 2..{MAX_CHAIN} moves, got {len(ms)}")
    trackings = {m.tracking for m in ms}
    if len(trackings) != 1:
        raise ParolkitValueError("the moves of a blended chain must all use the same tracking")
    tracking = trackings.pop()
    notes: list[str] = []
    durations = [m.duration_s for m in ms]
    profile = next((m.profile for m in ms if m.profile is not None), None)
    given = [d for d in durations if d is not None]
    if len(given) == len(ms):
        total = float(sum(given))
        return BlendChain(ms, duration_s=total, profile=profile, tracking=tracking,
                          notes=(f"blended chain of {len(ms)} moves timed by their durations ({total:.2f} s in all)",))
    if given:
        notes.append("blended chain: the durations given are not used (not every move gives one): it runs at the "
                     "slowest speed percentage of its moves")
    if isinstance(ms[0], CartMove):
        from parolkit.motion.cartesian.path_of_move import DEFAULT_CART_SPEED_PCT

        v = min(m.speed_pct if m.speed_pct is not None else DEFAULT_CART_SPEED_PCT for m in ms)
        return BlendChain(ms, speed_pct=v, profile=profile or Profile.RUCKIG, tracking=tracking,
                          notes=(*notes, f"blended chain of {len(ms)} moves at {v:g} % path speed"))
    vs, accs = [], []
    for m in ms:
        assert not isinstance(m, CartMove)
        dv, da = MOVEJOINT_DEFAULT_PCT if isinstance(m, JointMove) else MOVEPOSE_DEFAULT_PCT
        vs.append(m.speed_pct if m.speed_pct is not None else dv)
        accs.append(m.accel_pct if m.accel_pct is not None else da)
    return BlendChain(ms, speed_pct=min(vs), accel_pct=min(accs), profile=profile, tracking=tracking,
                      notes=(*notes, f"blended chain of {len(ms)} moves at {min(vs):g} % speed, "
                                     f"{min(accs):g} % acceleration"))


def plan_blended(
    moves: Sequence[object], start_deg: Sequence[float] | NDArray[np.float64], *, model: RobotModel,
    tool: str | Tool | None = None, rate_hz: float = 100.0,
) -> BlendedPlan:
    """Plan ``moves`` (2..:data:`MAX_CHAIN`, all MoveCart or all MoveJoint/MovePose) from
    ``start_deg`` as one blended trajectory (see the module docstring).  Raises
    :class:`PlanningError` naming the chain (and the move, for an unreachable pose)."""
    chain = _chain(moves)
    start = np.asarray(start_deg, dtype=float)
    if start.shape != (6,) or not np.all(np.isfinite(start)):
        raise ParolkitValueError(f"start_deg must be 6 finite joint angles (deg), got {start_deg!r}")
    if blend_kind(chain.moves[0]) == "cart":
        return _plan_cartesian(chain, start, model, tool, rate_hz)
    return _plan_joint(chain, start, model, tool, rate_hz)


# ---------------------------------------------------------------------------------------------
# Cartesian chains
# ---------------------------------------------------------------------------------------------


def _plan_cartesian(chain: BlendChain, start: NDArray[np.float64], model: RobotModel, tool: str | Tool | None,
                    rate: float) -> BlendedPlan:
    from parolkit import kinematics as kin
    from parolkit.motion.cartesian.geometry import Line, Path, Segment, blend_corners
    from parolkit.motion.cartesian.path_of_move import far_apart
    from parolkit.motion.cartesian.timing import time_and_solve

    t0 = np.asarray(kin.fk_matrix(start, tool), dtype=float)
    p, r = t0[:3, 3] * 1e3, t0[:3, :3]
    segs: list[Segment] = []
    radii: list[float] = []
    corners: list[NDArray[np.float64]] = []
    for k, m in enumerate(chain.moves):
        assert isinstance(m, CartMove)
        tm = np.asarray(kin.pose_to_matrix(m.pose), dtype=float)
        p1, r1 = tm[:3, 3] * 1e3, tm[:3, :3]
        corners.append(p1)
        if not far_apart(p, r, p1, r1):
            continue  # already there: no segment (its mark is the corner before)
        if segs and k > 0:
            radii.append(float(chain.moves[k - 1].blend or 0.0))
        segs.append(Line(p, p1, r, r1))
        p, r = p1, r1
    if not segs:
        raise PlanningError(chain.name, "every target is where the chain starts: nothing to blend")
    path = Path(blend_corners(segs, radii))
    traj = time_and_solve(chain, path, start, model, tool, rate)  # type: ignore[arg-type]
    traj = traj.with_notes((*chain.notes, *traj.notes), move=chain)
    q = traj.planned_deg if traj.planned_deg is not None else traj.positions_deg()
    tcp = np.asarray(kin.fk_batch(q, tool), dtype=float)[:, :3]
    marks = _marks(tcp, corners[:-1], [float(m.blend or 0.0) for m in chain.moves[:-1]], tol=1.0)
    return BlendedPlan(traj, marks)


# ---------------------------------------------------------------------------------------------
# joint-space chains
# ---------------------------------------------------------------------------------------------


def _plan_joint(chain: BlendChain, start: NDArray[np.float64], model: RobotModel, tool: str | Tool | None,
                rate: float) -> BlendedPlan:
    from parolkit.motion.joint import check_target
    from parolkit.motion.topp import toppra_parameterize

    name = chain.name
    points = [start]
    for k, m in enumerate(chain.moves):
        if isinstance(m, PoseMove):
            from parolkit import kinematics

            try:
                q = np.asarray(kinematics.ik(m.pose, seed_deg=points[-1], tool=tool), dtype=float)
            except kinematics.IKError as exc:
                raise PlanningError(name, f"move {k + 1} ({m.name}): pose "
                                          f"[{', '.join(f'{v:g}' for v in m.pose)}] is not reachable: {exc.reason}",
                                    joint=exc.joint, value=exc.value) from exc
        else:
            assert isinstance(m, JointMove)
            q = np.asarray(m.target_deg, dtype=float)
        check_target(name, q, model, what=f"move {k + 1} ({m.name}) target:")
        points.append(q)
    path = _rounded_polyline(points, [float(m.blend or 0.0) for m in chain.moves[:-1]])
    if len(path) < 2:
        raise PlanningError(name, "every target is where the chain starts: nothing to blend")
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    spd = validate.model_arrays(model).steps_per_deg
    tracked = chain.tracking is Tracking.POSITION
    lim = validate.speed_limits(model, rate, tracked)
    assert chain.speed_pct is not None or chain.duration_s is not None
    v_pct = chain.speed_pct if chain.speed_pct is not None else 100.0
    a_pct = chain.accel_pct if chain.accel_pct is not None else 100.0
    vmax = np.minimum(model.speed_from_percent(v_pct), lim.array) / spd
    amax = np.minimum(model.accel_from_percent(a_pct), np.asarray(model.accel_limit_steps_s2, dtype=float)) / spd
    res = toppra_parameterize(s, path, vmax, amax, duration=chain.duration_s)
    if res is None:
        raise PlanningError(name, "no timing within the joints' speed and acceleration limits was found for the "
                                  "blended path: give smaller blend radii or a lower speed")
    notes = list(chain.notes)
    if chain.duration_s is not None and res.duration > chain.duration_s + 1e-6:
        notes.append(f"the durations given ({chain.duration_s:.2f} s) are too short for the joints: it runs "
                     f"{res.duration:.2f} s")
    t = sample_times(res.duration, rate)
    q, qd, _ = res.evaluate(t)
    q = np.array(q, dtype=float)
    qd = np.array(qd, dtype=float)
    qd[-1] = 0.0
    traj = build_trajectory(chain, t, q, qd, start=start, model=model, rate=rate,  # type: ignore[arg-type]
                            tracking=chain.tracking, notes=notes, target_deg=points[-1], check_accel=False)
    marks = _marks(q, points[1:-1], [float(m.blend or 0.0) for m in chain.moves[:-1]], tol=0.5)
    return BlendedPlan(traj, marks)


def _rounded_polyline(points: Sequence[NDArray[np.float64]], radii: Sequence[float]) -> NDArray[np.float64]:
    """Dense points along the joint-space polyline through ``points`` with the corner at each
    inner point rounded: cut ``radii[k]`` (at most 45 % of either neighbour line) before and
    after ``points[k + 1]`` and joined by a quadratic Bezier whose control point is the corner.
    Repeated points are dropped."""
    pts = [np.asarray(points[0], dtype=float)]
    rad = [0.0]
    for k in range(1, len(points)):
        p = np.asarray(points[k], dtype=float)
        if float(np.linalg.norm(p - pts[-1])) < 1e-9:
            continue
        pts.append(p)
        rad.append(float(radii[k - 1]) if k - 1 < len(radii) else 0.0)
    if len(pts) < 2:
        return np.asarray(pts)
    lengths = [float(np.linalg.norm(b - a)) for a, b in zip(pts, pts[1:])]
    # the cut at each inner point (index i = 1 .. len - 2)
    cut = [0.0] * len(pts)
    for i in range(1, len(pts) - 1):
        cut[i] = min(rad[i], 0.45 * lengths[i - 1], 0.45 * lengths[i])
    out: list[NDArray[np.float64]] = [pts[0]]
    for i in range(len(pts) - 1):
        a, b = pts[i], pts[i + 1]
        d = (b - a) / lengths[i]
        line_from = a + d * cut[i]
        line_to = b - d * cut[i + 1] if i + 1 < len(pts) - 1 else b
        n = max(1, int(math.ceil(float(np.linalg.norm(line_to - line_from)) / _JOINT_STEP_DEG)))
        for u in np.linspace(0.0, 1.0, n + 1)[1:]:
            out.append(line_from + (line_to - line_from) * u)
        if i + 1 < len(pts) - 1 and cut[i + 1] > 0.0:
            c = pts[i + 1]
            e = c + (pts[i + 2] - c) / lengths[i + 1] * cut[i + 1]
            for u in np.linspace(0.0, 1.0, _CORNER_POINTS)[1:]:
                out.append((1 - u) ** 2 * line_to + 2 * (1 - u) * u * c + u ** 2 * e)
    return np.asarray(out)


# ---------------------------------------------------------------------------------------------
# where each move of the chain is done
# ---------------------------------------------------------------------------------------------


def _marks(samples: NDArray[np.float64], corners: Sequence[NDArray[np.float64]], radii: Sequence[float], *,
           tol: float) -> tuple[int, ...]:
    """For each corner in order, the index of the sample nearest it on the way: walking on from
    the previous corner's sample, the first local minimum of the distance that lies within the
    corner's radius (+ ``tol``); the path passes every corner in order, so a later pass near
    the same point (a zigzag) is never taken for an earlier one."""
    out: list[int] = []
    i = 0
    n = len(samples)
    for c, r in zip(corners, radii):
        d = np.linalg.norm(samples[i:] - np.asarray(c, dtype=float), axis=1)
        near = np.nonzero(d <= r + tol)[0]
        if len(near) == 0:  # (cannot happen: the path passes within r) the nearest then
            j = int(np.argmin(d))
        else:
            j = int(near[0])
            while j + 1 < len(d) and d[j + 1] <= d[j]:
                j += 1
        i = min(n - 1, i + j)
        out.append(i)
    return tuple(out)
