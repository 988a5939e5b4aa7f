"""Cartesian jogs: constant speed along or about one axis of the world (WRF) or tool (TRF) frame.

Planned by :func:`plan_cart_jog` (re-exported by :mod:`parolkit.motion.cartesian`).  Unlike a
Cartesian move a jog is not refused where it cannot go on: it stops there, with a note (the
edge of the workspace, a joint range, a joint at its maximum speed, the orientation deviation
bound near the wrist singularity).  A held jog is streamed as updates, each continuing the
running one from a :class:`JogStart`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from parolkit.motion import singular, validate
from parolkit.motion.cartesian.geometry import rot_about
from parolkit.motion.cartesian.ik_along_path import singularity_text, solve_path
from parolkit.motion.errors import PlanningError
from parolkit.motion.joint import build_trajectory
from parolkit.motion.trajectory import Trajectory
from parolkit.moves import CartAxis, CartJog, Frame, Tracking
from parolkit.robot import JOINT_NAMES

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool
    from parolkit.robot import RobotModel

__all__ = ["JogStart", "CartJogTrajectory", "plan_cart_jog"]


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
            q, area = solve_path(move.name, pos, rots, start, tool, t, model, vmax, start_speed, jog=True)
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
            area = dataclasses.replace(area, q_deg=q, deviation_deg=area.deviation_deg[:over], t=t)
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
                   f"{singularity_text(q[k], tool)}")
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
