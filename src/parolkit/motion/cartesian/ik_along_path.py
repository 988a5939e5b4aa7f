"""The joint angles along a sampled Cartesian path: IK, joint speeds, and the checks that find a
singularity or a change of IK branch.

A stage of the Cartesian pipeline (:mod:`parolkit.motion.cartesian`): the tool poses of the
samples (mm, rotation matrices) -> ``kinematics.ik_batch`` (branch-continuous, seeded with the
start joints) or, where that turns J4/J6 too fast near J5 = 0, the singular-area policy
(:mod:`parolkit.motion.singular`; also where the start's wrist branch would swing J4/J6 out of
range there, J4 then passing onto the other, in-range branch) -> joint speeds by central
differences.  A path the robot cannot reach, or a joint that jumps or needs an unbounded
speed, becomes a :class:`~parolkit.motion.errors.PlanningError` naming the time, the joint and
the nearest singularity.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NoReturn

import numpy as np

from parolkit.motion import singular
from parolkit.motion.errors import PlanningError
from parolkit.robot import JOINT_NAMES

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool
    from parolkit.robot import RobotModel

__all__ = [
    "poses_from_rotations", "solve_ik", "solve_path", "deviation_error", "derivative", "check_jumps",
    "singularity_text", "near_singularity", "refuse_singular", "OtherBranchArea",
]


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


def solve_ik(
    name: str, pos_mm: NDArray[np.float64], rots: NDArray[np.float64], seed: NDArray[np.float64],
    tool: str | Tool | None, t: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Joint angles (deg) of the path's samples by the exact IK from ``seed``; a sample out of
    reach -> PlanningError naming its position and time (``t``, s)."""
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


def solve_path(
    name: str, pos_mm: NDArray[np.float64], rots: NDArray[np.float64], seed: NDArray[np.float64],
    tool: str | Tool | None, t: NDArray[np.float64], model: RobotModel, v_limits_deg_s: NDArray[np.float64],
    start_speed_deg_s: NDArray[np.float64] | None = None, jog: bool = False,
) -> tuple[NDArray[np.float64], singular.WristArea | None]:
    """Joint angles (deg) for the sampled path at times ``t`` (s): the exact IK, or where that
    turns J4/J6 faster than ``v_limits_deg_s`` near J5 = 0, the singular-area policy
    (:mod:`parolkit.motion.singular`: TCP position exact, orientation deviation measured).
    Returns (q, the policy's result or None when the exact solution is used).

    A path passing close to J5 = 0 swings the exact wrist's J4 by up to 180 deg; continued
    on the start's wrist branch, J4 (or J6) may leave its range where the same poses on the
    other wrist branch (J4 +- 180, -J5, J6 +- 180) are inside it (after a jog from standby,
    a MoveCart back down).  The exact IK is then followed beyond the ranges and the policy,
    whose J4 takes the in-range one of the two branches, passes the singular area; a joint
    still out of its range is refused naming the joint, its value and its range."""
    out_of_range: PlanningError | None = None
    try:
        q = solve_ik(name, pos_mm, rots, seed, tool, t)
    except PlanningError as exc:
        beyond = _beyond_range(exc, pos_mm, rots, seed, tool, t, v_limits_deg_s)
        if beyond is None:
            raise
        q, out_of_range = beyond, exc
    full = np.vstack([np.asarray(seed, dtype=float)[None, :], q])
    tt = np.concatenate(([0.0], t))
    if not singular.needs_policy(full, tt, v_limits_deg_s):
        if out_of_range is not None:  # (not reached: _beyond_range found a fast turn)
            raise out_of_range
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
    if out_of_range is None:
        return area.q_deg, area
    other = OtherBranchArea(area.q_deg, area.deviation_deg, area.t, start_branch=_start_branch(out_of_range, model))
    _check_range(name, other, model)
    return other.q_deg, other


#: The wrist joints whose range the policy's choice of wrist branch decides (J4, J6).
_WRIST_JOINTS = (3, 5)


def _beyond_range(
    exc: PlanningError, pos_mm: NDArray[np.float64], rots: NDArray[np.float64], seed: NDArray[np.float64],
    tool: str | Tool | None, t: NDArray[np.float64], v_limits_deg_s: NDArray[np.float64],
) -> NDArray[np.float64] | None:
    """The exact joint path followed beyond the joint ranges, when ``exc`` (the exact IK's
    refusal) is J4 or J6 leaving its range after the exact wrist has swung J4/J6 faster than
    they can turn near J5 = 0 (the singular area, where the policy picks the wrist branch);
    None otherwise (``exc`` stands)."""
    from parolkit import kinematics as kin

    cause = exc.__cause__
    if not (isinstance(cause, kin.IKError) and cause.kind is kin.IKFailure.JOINT_LIMIT
            and cause.joint in _WRIST_JOINTS and cause.sample is not None):
        return None
    try:
        q = np.asarray(kin.ik_batch(poses_from_rotations(pos_mm, rots), seed, tool=tool, check_limits=False),
                       dtype=float)
    except kin.IKError:
        return None
    k = min(int(cause.sample), len(q) - 1)
    full = np.vstack([np.asarray(seed, dtype=float)[None, :], q[:k + 1]])
    tt = np.concatenate(([0.0], np.asarray(t, dtype=float)[:k + 1]))
    return q if singular.needs_policy(full, tt, v_limits_deg_s) else None


def _start_branch(exact: PlanningError, model: RobotModel) -> str:
    """``"J4 would be -125.2 deg (allowed -105.5 .. 105.5 deg)"``: the joint the exact IK's
    refusal ``exact`` found out of range on the start's wrist branch."""
    from parolkit import kinematics as kin

    cause = exact.__cause__
    if not (isinstance(cause, kin.IKError) and cause.joint is not None and cause.value is not None):
        return exact.reason  # pragma: no cover - _beyond_range takes only such refusals
    return f"{JOINT_NAMES[cause.joint]} would be {cause.value:.1f} deg ({_allowed(model, cause.joint)})"


def _allowed(model: RobotModel, j: int) -> str:
    lim = model.safe_limits_deg
    return f"allowed {lim[j, 0]:.1f} .. {lim[j, 1]:.1f} deg"


def _check_range(name: str, area: OtherBranchArea, model: RobotModel) -> None:
    """Refuse the policy's joints where one is still outside its range: J4, when it cannot
    turn to its in-range branch in time; J6, which continues from the start and may have no
    in-range value on that branch."""
    lim = model.safe_limits_deg
    q = area.q_deg
    bad = (q < lim[:, 0]) | (q > lim[:, 1])
    if not bad.any():
        return
    k = int(np.argmax(bad.any(axis=1)))
    j = int(np.argmax(bad[k]))
    if j == 3:
        text = (f"J4 would leave its range on either wrist branch past the wrist singularity (J5 near 0): "
                f"on the start's, {area.start_branch}; turning to the other (J4 +- 180 deg, -J5), "
                f"{q[k, j]:.1f} deg")
    else:
        text = (f"past the wrist singularity (J5 near 0) {JOINT_NAMES[j]} would be {q[k, j]:.1f} deg "
                f"({_allowed(model, j)}) on the wrist branch that keeps J4 in range; on the start's, "
                f"{area.start_branch}")
    raise PlanningError(name, text, time_s=float(area.t[k]), joint=j, value=float(q[k, j]))


@dataclass(frozen=True)
class OtherBranchArea(singular.WristArea):
    """The singular-area policy's result for a path whose exact IK, continued on the start's
    wrist branch, leaves a joint range (``start_branch`` says which: ``"J4 would be
    -125.2 deg (allowed -105.5 .. 105.5 deg)"``): J4 passes the singular area to the other branch."""

    start_branch: str = ""

    def note(self) -> str:
        return f"{super().note()}; J4 on its other wrist branch past J5 = 0 (on the start's, {self.start_branch})"


def deviation_error(name: str, area: singular.WristArea, hint: str) -> PlanningError:
    """The refusal of a path whose singular-area policy deviates from the tool orientation by more
    than :data:`~parolkit.motion.singular.MAX_DEVIATION_DEG`, or does not reach it at the end."""
    if isinstance(area, OtherBranchArea):
        hint = f"J4 turns to its other wrist branch (on the start's, {area.start_branch}); {hint}"
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


def derivative(
    q: NDArray[np.float64], start: NDArray[np.float64], rate_hz: float, t: NDArray[np.float64], T: float,
) -> NDArray[np.float64]:
    """Joint speeds (deg/s) at the samples: central differences; zero once the path has ended."""
    full = np.vstack([start[None, :], q])
    qd: NDArray[np.float64] = np.gradient(full, 1.0 / rate_hz, axis=0)[1:]
    qd[t >= T - 1e-9] = 0.0
    return qd


def check_jumps(
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
            f"singularity{singularity_text(full_q[k + 1], tool)})", time_s=float(t[k]), joint=j,
            value=float(full_q[k + 1, j]),
        )


def singularity_text(q: NDArray[np.float64], tool: str | Tool | None) -> str:
    """``"; nearest: ... singularity (...)"`` for the joints ``q`` (deg), for an error message;
    empty when the kinematics cannot tell."""
    try:
        from parolkit import kinematics as kin

        info = kin.singularity_distance(q)
    except Exception:  # informative only
        return ""
    return (f"; nearest: {info.nearest} singularity (wrist {info.wrist_deg:.2f} deg, shoulder "
            f"{info.shoulder_mm:.1f} mm, elbow {info.elbow_deg:.2f} deg)")


def near_singularity(q: NDArray[np.float64], v_steps: NDArray[np.float64], vmax: NDArray[np.float64]) -> bool:
    """Is the sample needing the highest joint speed near a singularity?"""
    ratio = np.max(np.abs(v_steps) / vmax, axis=1)
    k = int(np.argmax(ratio))
    try:
        from parolkit import kinematics as kin

        return bool(kin.singularity_distance(q[k]).near)
    except Exception:  # no singularity information: judge by the spike alone
        return bool(ratio[k] > 20 * max(np.median(ratio), 1e-9))


def refuse_singular(
    name: str, t: NDArray[np.float64], q: NDArray[np.float64], v_steps: NDArray[np.float64],
    vmax: NDArray[np.float64], tool: str | Tool | None,
) -> NoReturn:
    """Refuse the path at the sample and joint most over its speed limit, naming the singularity."""
    ratio = np.abs(v_steps) / vmax
    k, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    raise PlanningError(
        name,
        f"{JOINT_NAMES[j]} would need {abs(v_steps[k, j]):.0f} steps/s ({ratio[k, j]:.1f}x its maximum): "
        f"the path passes too close to a singularity{singularity_text(q[k], tool)}",
        time_s=float(t[k]), joint=int(j), value=float(v_steps[k, j]),
    )
