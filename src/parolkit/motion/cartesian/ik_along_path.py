"""The joint angles along a sampled Cartesian path: IK, joint speeds, and the checks that find a
singularity or a change of IK branch.

A stage of the Cartesian pipeline (:mod:`parolkit.motion.cartesian`): the tool poses of the
samples (mm, rotation matrices) -> ``kinematics.ik_batch`` (branch-continuous, seeded with the
start joints) or, where that turns J4/J6 too fast near J5 = 0, the singular-area policy
(:mod:`parolkit.motion.singular`) -> joint speeds by central differences.  A path the robot
cannot reach, or a joint that jumps or needs an unbounded speed, becomes a
:class:`~parolkit.motion.errors.PlanningError` naming the time, the joint and the nearest
singularity.
"""

from __future__ import annotations

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
    "singularity_text", "near_singularity", "refuse_singular",
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
    Returns (q, the policy's result or None when the exact solution is used)."""
    q = solve_ik(name, pos_mm, rots, seed, tool, t)
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


def deviation_error(name: str, area: singular.WristArea, hint: str) -> PlanningError:
    """The refusal of a path whose singular-area policy deviates from the tool orientation by more
    than :data:`~parolkit.motion.singular.MAX_DEVIATION_DEG`, or does not reach it at the end."""
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
