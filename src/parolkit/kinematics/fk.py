"""Forward kinematics: joint angles (deg) -> TCP pose (mm/deg) or transform (metres).

FK accepts any finite joint angles (it is geometry, not a limit check).  The single-pose
functions run in plain floats (closed form of the DH chain, a few microseconds); the batch
function is vectorised numpy.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from parolkit.kinematics.model import A1, A2, A3, D1, D4
from parolkit.kinematics.pose import _abc_from_rot, _Num, _Rot9, _rot_to_poses, _Vec3, cos_sin
from parolkit.kinematics.tools import DEFAULT_TOOL as _DEFAULT_TOOL
from parolkit.kinematics.tools import Tool, get_tool
from parolkit.robot import PAROL6, as_joint_array

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["fk", "fk_matrix", "fk_batch", "fk_frames"]

_DEG = math.pi / 180.0
_RAD = 180.0 / math.pi
_isfinite = math.isfinite


def _joints_rad(joints_deg: object, name: str = "joints_deg") -> tuple[float, ...]:
    """Six finite joint angles in degrees -> six radians (fast path for lists/tuples/arrays)."""
    if type(joints_deg) is np.ndarray and joints_deg.shape == (6,):
        joints_deg = joints_deg.tolist()
    if (type(joints_deg) is list or type(joints_deg) is tuple) and len(joints_deg) == 6:
        try:
            q1, q2, q3, q4, q5, q6 = joints_deg
            out = (q1 * _DEG, q2 * _DEG, q3 * _DEG, q4 * _DEG, q5 * _DEG, q6 * _DEG)
            if _isfinite(out[0] + out[1] + out[2] + out[3] + out[4] + out[5]):
                return out
        except (TypeError, ValueError, OverflowError):
            pass
    arr = as_joint_array(joints_deg, name, allow_batch=False)  # raises the precise error
    return tuple(float(v) * _DEG for v in arr)


def _flange_from_trig(
    c1: _Num, s1: _Num, c2: _Num, s2: _Num, c3: _Num, s3: _Num, cp: _Num, sp: _Num,
    c4: _Num, s4: _Num, c5: _Num, s5: _Num, c6: _Num, s6: _Num,
) -> tuple[_Rot9[_Num], _Vec3[_Num]]:
    """The closed-form flange pose from the joints' cosines/sines (``cp``, ``sp``: of
    q2 - q3).  Plain arithmetic, so it serves floats (single pose) and numpy arrays (batch)
    alike: rotation (9 entries, row-major) and position (3 entries, metres)."""
    # W = Rz(-q4) Ry(-q5) Rz(-q6)
    c4c5 = c4 * c5
    s4c5 = s4 * c5
    w00 = c4c5 * c6 - s4 * s6
    w01 = c4c5 * s6 + s4 * c6
    w02 = -c4 * s5
    w10 = -s4c5 * c6 - c4 * s6
    w11 = -s4c5 * s6 + c4 * c6
    w12 = s4 * s5
    w20 = s5 * c6
    w21 = s5 * s6
    w22 = c5
    # Ry(psi) W
    a00 = cp * w00 + sp * w20
    a01 = cp * w01 + sp * w21
    a02 = cp * w02 + sp * w22
    a20 = cp * w20 - sp * w00
    a21 = cp * w21 - sp * w01
    a22 = cp * w22 - sp * w02
    # Rz(q1) (...)
    rot = (
        c1 * a00 - s1 * w10, c1 * a01 - s1 * w11, c1 * a02 - s1 * w12,
        s1 * a00 + c1 * w10, s1 * a01 + c1 * w11, s1 * a02 + c1 * w12,
        a20, a21, a22,
    )
    u = A2 + A3 * c3 + D4 * s3
    v = D4 * c3 - A3 * s3
    r = A1 + u * c2 - v * s2
    pos = (r * c1, r * s1, D1 - (u * s2 + v * c2))
    return rot, pos


def _flange_rad(
    q1: float, q2: float, q3: float, q4: float, q5: float, q6: float,
) -> tuple[_Rot9[float], _Vec3[float]]:
    """Flange (= wrist centre) rotation (9 floats, row-major) and position (metres)."""
    psi = q2 - q3
    return _flange_from_trig(
        math.cos(q1), math.sin(q1), math.cos(q2), math.sin(q2), math.cos(q3), math.sin(q3),
        math.cos(psi), math.sin(psi), math.cos(q4), math.sin(q4), math.cos(q5), math.sin(q5),
        math.cos(q6), math.sin(q6),
    )


def _apply_tool(
    r: _Rot9[_Num], p: _Vec3[_Num], tool: Tool,
) -> tuple[_Rot9[_Num], _Vec3[_Num]]:
    """Flange rotation ``r`` (9 entries) and position ``p`` (3) -> TCP rotation and position.
    Plain arithmetic: the entries may be floats (single pose) or numpy arrays (batch)."""
    tx, ty, tz = tool._t
    pos = (
        p[0] + r[0] * tx + r[1] * ty + r[2] * tz,
        p[1] + r[3] * tx + r[4] * ty + r[5] * tz,
        p[2] + r[6] * tx + r[7] * ty + r[8] * tz,
    )
    if tool._identity_rot:
        return r, pos
    t = tool._rot
    rot = (
        r[0] * t[0] + r[1] * t[3] + r[2] * t[6], r[0] * t[1] + r[1] * t[4] + r[2] * t[7],
        r[0] * t[2] + r[1] * t[5] + r[2] * t[8],
        r[3] * t[0] + r[4] * t[3] + r[5] * t[6], r[3] * t[1] + r[4] * t[4] + r[5] * t[7],
        r[3] * t[2] + r[4] * t[5] + r[5] * t[8],
        r[6] * t[0] + r[7] * t[3] + r[8] * t[6], r[6] * t[1] + r[7] * t[4] + r[8] * t[7],
        r[6] * t[2] + r[7] * t[5] + r[8] * t[8],
    )
    return rot, pos


def _tcp_rad(q: tuple[float, ...], tool: Tool) -> tuple[_Rot9[float], _Vec3[float]]:
    """TCP rotation (9 floats) and position (metres) for joint radians ``q``."""
    r, p = _flange_rad(*q)
    return _apply_tool(r, p, tool)


def fk(joints_deg: object, tool: str | Tool | None = None) -> NDArray[np.float64]:
    """TCP pose ``[x, y, z mm, A, B, C deg]`` (R = Rx(C) Ry(B) Rz(A)) for six joint angles in deg."""
    q = _joints_rad(joints_deg)
    rot, pos = _tcp_rad(q, _DEFAULT_TOOL if tool is None else get_tool(tool))
    a, b, c = _abc_from_rot(*rot)
    return np.array((pos[0] * 1e3, pos[1] * 1e3, pos[2] * 1e3, a * _RAD, b * _RAD, c * _RAD))


def fk_matrix(joints_deg: object, tool: str | Tool | None = None) -> NDArray[np.float64]:
    """4x4 base -> TCP transform in metres for six joint angles in degrees."""
    q = _joints_rad(joints_deg)
    r, p = _tcp_rad(q, get_tool(tool))
    return np.array([
        [r[0], r[1], r[2], p[0]],
        [r[3], r[4], r[5], p[1]],
        [r[6], r[7], r[8], p[2]],
        [0.0, 0.0, 0.0, 1.0],
    ])


def _flange_batch(
    q_t: NDArray[np.float64],
) -> tuple[_Rot9[NDArray[np.float64]], _Vec3[NDArray[np.float64]]]:
    """Vectorised flange rotation entries (9 arrays) and position (3 arrays), metres.

    ``q_t``: joint radians as a C-ordered (6, N) array (one contiguous row per joint).
    """
    c, s = cos_sin(q_t)
    c1, c2, c3, c4, c5, c6 = c
    s1, s2, s3, s4, s5, s6 = s
    cp = c2 * c3 + s2 * s3  # cos(q2 - q3)
    sp = s2 * c3 - c2 * s3
    return _flange_from_trig(c1, s1, c2, s2, c3, s3, cp, sp, c4, s4, c5, s5, c6, s6)


def _tcp_batch(
    q_t: NDArray[np.float64], tool: Tool,
) -> tuple[_Rot9[NDArray[np.float64]], _Vec3[NDArray[np.float64]]]:
    r, p = _flange_batch(q_t)
    return _apply_tool(r, p, tool)


def fk_batch(joints_deg: object, tool: str | Tool | None = None, as_matrix: bool = False) -> NDArray[np.float64]:
    """Vectorised FK: ``(N, 6)`` joint degrees -> ``(N, 6)`` poses (mm/deg) or ``(N, 4, 4)`` (m)."""
    arr = as_joint_array(joints_deg, "joints_deg")
    if arr.ndim == 1:
        arr = arr[None, :]
    q_t = np.multiply(arr.T, _DEG, order="C")
    rot, pos = _tcp_batch(q_t, get_tool(tool))
    if as_matrix:
        out = np.zeros((arr.shape[0], 4, 4))
        for k in range(9):
            out[:, k // 3, k % 3] = rot[k]
        for k in range(3):
            out[:, k, 3] = pos[k]
        out[:, 3, 3] = 1.0
        return out
    return _rot_to_poses(*rot, *pos)


def _dh_matrix(theta: float, d: float, a: float, alpha: float) -> NDArray[np.float64]:
    ct, st = math.cos(theta), math.sin(theta)
    # exact 0/+-1 for the right-angle twists of the PAROL6 table
    ca, sa = round(math.cos(alpha), 15) + 0.0, round(math.sin(alpha), 15) + 0.0
    return np.array([
        [ct, -st * ca, st * sa, a * ct],
        [st, ct * ca, -ct * sa, a * st],
        [0.0, sa, ca, d],
        [0.0, 0.0, 0.0, 1.0],
    ])


def fk_frames(joints_deg: object, tool: str | Tool | None = None) -> NDArray[np.float64]:
    """All link frames for drawing: ``(8, 4, 4)`` metres.

    Index 0 is the base (identity), 1..6 the DH frames of joints 1..6 with frame 6 = the
    flange (row 6's d and a set to 0), 7 the TCP (flange @ tool).  Computed by multiplying the
    DH matrices one by one (independent of the closed form used by :func:`fk`).
    """
    q = _joints_rad(joints_deg)
    frames = np.empty((8, 4, 4))
    frames[0] = np.eye(4)
    for i, row in enumerate(PAROL6.dh):
        d, a = (row.d, row.a) if i < 5 else (0.0, 0.0)
        frames[i + 1] = frames[i] @ _dh_matrix(q[i], d, a, row.alpha)
    frames[7] = frames[6] @ get_tool(tool).matrix
    return frames

