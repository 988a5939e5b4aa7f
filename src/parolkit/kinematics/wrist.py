"""IK with J4 given: the TCP position exactly, the orientation as close as the wrist allows.

Near the wrist singularity (J5 = 0, axes 4 and 6 aligned) the exact IK asks J4 and J6 to turn
arbitrarily fast: the tool's tilt (J5) away from the forearm axis is small but its direction
(J4) swings.  The singular-area policy of :mod:`parolkit.motion.singular` instead chooses J4
as a smooth, speed- and acceleration-limited curve; this module solves the other five joints
for such a J4:

* J5 and J6 make the flange orientation as close as possible to the wanted one: the flange
  z axis is projected onto the plane J5 can tilt it in (the plane through the forearm axis
  perpendicular to the J5 axis that J4 sets) and J6 takes the twist.  The orientation error
  left is the out-of-plane part of the tilt, at most |J5| of the exact solution (deg for
  deg) and zero where J4 equals the exact solution's J4 (modulo 180 deg, with J5's sign);
* J1, J2, J3 put the wrist centre where the TCP position is exact for *that* orientation
  (the tool offset turns with the flange).  Orientation and wrist centre depend on each
  other, so both are iterated to a fixed point (a contraction: the tool offset is short
  against the arm; typically 3 to 6 rounds to 1e-10 m).

Vectorised numpy over N samples; units at the edges: mm, deg, rotations as (N, 3, 3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from parolkit.kinematics.fk import fk_batch
from parolkit.kinematics.model import A1, A2, A3, D1, D4, L3, PHI3, TWO_PI
from parolkit.kinematics.tools import Tool, get_tool
from parolkit.kinematics.types import IKError, IKFailure

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["WristSolution", "solve_with_j4", "orientation_error_deg"]

_K0 = A2 * A2 + L3 * L3
_INV_2A2L = 1.0 / (2.0 * A2 * L3)
_REACH_EPS = 1e-12
#: Fixed-point iteration: stop when the wrist centre moves less than this (m) ...
_CONVERGED_M = 1e-11
#: ... or after this many rounds (the TCP position error is then checked by the caller).
_MAX_ROUNDS = 40


@dataclass(frozen=True)
class WristSolution:
    """Joint angles for a path with J4 given.

    Attributes:
        q_deg: (N, 6) joint angles, deg; J4 as given, J1..J3 continuous with the reference.
        deviation_deg: (N,) angle of the rotation from the wanted to the reached TCP
            orientation, deg (0 where J4 is the exact solution's).
        position_error_mm: largest distance between the wanted and the reached TCP (mm).
    """

    q_deg: NDArray[np.float64]
    deviation_deg: NDArray[np.float64]
    position_error_mm: float


def _rz(a: NDArray[np.float64]) -> NDArray[np.float64]:
    c, s = np.cos(a), np.sin(a)
    m = np.zeros((len(a), 3, 3))
    m[:, 0, 0] = c
    m[:, 0, 1] = -s
    m[:, 1, 0] = s
    m[:, 1, 1] = c
    m[:, 2, 2] = 1.0
    return m


def _ry(a: NDArray[np.float64]) -> NDArray[np.float64]:
    c, s = np.cos(a), np.sin(a)
    m = np.zeros((len(a), 3, 3))
    m[:, 0, 0] = c
    m[:, 0, 2] = s
    m[:, 1, 1] = 1.0
    m[:, 2, 0] = -s
    m[:, 2, 2] = c
    return m


def orientation_error_deg(r_a: NDArray[np.float64], r_b: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N,) angle (deg) of the rotation between the (N, 3, 3) rotations ``r_a`` and ``r_b``."""
    tr = np.einsum("nij,nij->n", r_a, r_b)  # trace(r_a^T r_b)
    out: NDArray[np.float64] = np.degrees(np.arccos(np.clip((tr - 1.0) * 0.5, -1.0, 1.0)))
    return out


def _arm(p_w: NDArray[np.float64], back: bool, down: bool) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """J1, J2, J3 (rad, raw) putting the wrist centre at ``p_w`` ((N, 3) m) in one branch;
    and which samples are within reach."""
    x, y, z = p_w[:, 0], p_w[:, 1], p_w[:, 2]
    rho = np.sqrt(x * x + y * y)
    q1 = np.arctan2(y, x) + (math.pi if back else 0.0)
    X = (-rho if back else rho) - A1
    Y = D1 - z
    c = (X * X + Y * Y - _K0) * _INV_2A2L
    ok = np.abs(c) <= 1.0 + _REACH_EPS
    delta = np.arccos(np.clip(c, -1.0, 1.0))
    q3 = PHI3 + delta if down else PHI3 - delta
    c3, s3 = np.cos(q3), np.sin(q3)
    u = A2 + A3 * c3 + D4 * s3
    v = D4 * c3 - A3 * s3
    q2 = np.arctan2(Y, X) - np.arctan2(v, u)
    return q1, q2, q3, ok


def _near(raw: NDArray[np.float64], ref: NDArray[np.float64]) -> NDArray[np.float64]:
    """``raw`` shifted by whole turns to the representation nearest ``ref`` (rad)."""
    out: NDArray[np.float64] = raw + TWO_PI * np.floor((ref - raw) / TWO_PI + 0.5)
    return out


def solve_with_j4(
    pos_mm: NDArray[np.float64], rots: NDArray[np.float64], q4_deg: NDArray[np.float64],
    q_ref_deg: NDArray[np.float64], tool: str | Tool | None = None,
) -> WristSolution:
    """Joint angles with J4 = ``q4_deg`` reaching the TCP positions ``pos_mm`` ((N, 3) mm)
    exactly and the TCP rotations ``rots`` ((N, 3, 3)) as closely as that J4 allows.

    ``q_ref_deg``: (N, 6) reference joints (the exact IK of the same path): the arm branch
    (shoulder, elbow) is taken from its first sample and every joint is the representation
    nearest the reference (J6 continuous from sample to sample, starting nearest the
    reference's first J6).  Raises :class:`IKError` (``.sample`` set) where the wrist centre
    leaves the arm's reach.
    """
    tl = get_tool(tool)
    n = len(pos_mm)
    ref = np.radians(np.asarray(q_ref_deg, dtype=float))
    q4 = np.radians(np.asarray(q4_deg, dtype=float))
    t_rot = np.asarray(tl.matrix[:3, :3], dtype=float)
    t_off = np.asarray(tl.matrix[:3, 3], dtype=float)
    r_flange = rots @ t_rot.T  # wanted flange rotations
    p_tcp = np.asarray(pos_mm, dtype=float) * 1e-3
    # the branch of the reference's first sample
    best: tuple[float, bool, bool] | None = None
    p_w0 = p_tcp[:1] - r_flange[:1] @ t_off
    for back in (False, True):
        for down in (False, True):
            a1, a2, a3, ok = _arm(p_w0, back, down)
            if not ok[0]:
                continue
            d = sum(abs(float(_near(a, ref[:1, j])[0] - ref[0, j])) for j, a in enumerate((a1, a2, a3)))
            if best is None or d < best[0]:
                best = (d, back, down)
    if best is None:
        raise IKError("the wrist centre is out of the arm's reach", kind=IKFailure.OUT_OF_REACH, sample=0)
    _, back, down = best
    rz4 = _rz(q4)
    rz4_inv = _rz(-q4)
    r_reached = r_flange
    p_w = p_tcp - np.einsum("nij,j->ni", r_reached, t_off)
    q1 = q2 = q3 = q5 = q6 = np.zeros(n)
    for _ in range(_MAX_ROUNDS):
        q1, q2, q3, ok = _arm(p_w, back, down)
        if not ok.all():
            i = int(np.argmin(ok))
            raise IKError(f"the wrist centre leaves the arm's reach at sample {i}",
                          kind=IKFailure.OUT_OF_REACH, sample=i)
        arm = _rz(q1) @ _ry(q2 - q3)
        m = rz4 @ np.transpose(arm, (0, 2, 1)) @ r_flange  # Rz(q4) A^T R = Ry(-q5) Rz(-q6) (+ error)
        q5 = np.arctan2(-m[:, 0, 2], m[:, 2, 2])
        nm = _ry(q5) @ m
        q6 = np.arctan2(-nm[:, 1, 0], nm[:, 0, 0])
        r_reached = arm @ rz4_inv @ _ry(-q5) @ _rz(-q6)
        p_new = p_tcp - np.einsum("nij,j->ni", r_reached, t_off)
        moved = float(np.max(np.abs(p_new - p_w)))
        p_w = p_new
        if moved < _CONVERGED_M:
            break
    q1, q2, q3, ok = _arm(p_w, back, down)
    q = np.empty((n, 6))
    q[:, 0] = _near(q1, ref[:, 0])
    q[:, 1] = _near(q2, ref[:, 1])
    q[:, 2] = _near(q3, ref[:, 2])
    q[:, 3] = q4
    q[:, 4] = q5
    # J6: continuous along the path, its first sample nearest the reference's
    q6c = np.unwrap(q6)
    q[:, 5] = q6c + TWO_PI * math.floor((ref[0, 5] - q6c[0]) / TWO_PI + 0.5)
    q_deg = np.degrees(q)
    m_fk = fk_batch(q_deg, tl, as_matrix=True)  # the reached TCP, by the forward kinematics
    err_mm = float(np.max(np.linalg.norm(m_fk[:, :3, 3] - p_tcp, axis=1))) * 1e3 if n else 0.0
    dev = orientation_error_deg(m_fk[:, :3, :3], rots)
    return WristSolution(q_deg, dev, err_mm)
