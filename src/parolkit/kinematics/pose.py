"""Pose conventions: ``[x, y, z, A, B, C]`` (mm, deg) <-> 4x4 homogeneous matrices (metres).

The orientation convention is the original PAROL6 software's:

    R = Rx(C) * Ry(B) * Rz(A)

(spatialmath ``SE3.RPY([A, B, C], order='xyz')``).  :func:`matrix_to_pose` is its inverse and
resolves the gimbal lock at B = +-90 deg the way spatialmath's ``tr2rpy(order='xyz')`` does
(A = 0, the whole rotation about the common axis goes into C), so poses read back from the
original software compare equal.

Scalar helpers (``_rot_from_abc``, ``_abc_from_rot``) work on plain floats; the public
functions accept one pose or a batch and return numpy arrays.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from parolkit.errors import ParolkitValueError

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["pose_to_matrix", "matrix_to_pose", "as_pose_array", "as_matrix_array"]

_DEG = math.pi / 180.0
_RAD = 180.0 / math.pi
#: spatialmath's gimbal-lock tolerance: |r02| within 20 eps of 1.
_GIMBAL_TOL = 20 * np.finfo(float).eps

_POSE_FIELDS = ("x", "y", "z", "A", "B", "C")

#: An entry of the closed forms: a float (one pose) or an array over N poses (a batch).
_Num = TypeVar("_Num", float, "NDArray[np.float64]")
#: A row-major 3x3 rotation as its 9 entries.
_Rot9 = tuple[_Num, _Num, _Num, _Num, _Num, _Num, _Num, _Num, _Num]
#: A position (x, y, z).
_Vec3 = tuple[_Num, _Num, _Num]


def _rot_from_abc(a: float, b: float, c: float) -> _Rot9[float]:
    """Row-major 3x3 rotation Rx(c) Ry(b) Rz(a) from radians."""
    ca, sa = math.cos(a), math.sin(a)
    cb, sb = math.cos(b), math.sin(b)
    cc, sc = math.cos(c), math.sin(c)
    return (
        cb * ca, -cb * sa, sb,
        cc * sa + sc * sb * ca, cc * ca - sc * sb * sa, -sc * cb,
        sc * sa - cc * sb * ca, sc * ca + cc * sb * sa, cc * cb,
    )


def _abc_from_rot(r00: float, r01: float, r02: float, r10: float, r11: float, r12: float,
                  r20: float, r21: float, r22: float) -> tuple[float, float, float]:
    """(A, B, C) radians with Rx(C) Ry(B) Rz(A) = R; spatialmath's gimbal-lock rule."""
    if abs(abs(r02) - 1.0) < _GIMBAL_TOL:
        b = math.asin(max(-1.0, min(1.0, r02)))
        if r02 > 0:
            c = math.atan2(r21, r11)
        else:
            c = -math.atan2(r10, r20)
        return 0.0, b, c
    a = -math.atan2(r01, r00)
    c = -math.atan2(r12, r22)
    b = math.atan2(r02, math.hypot(r00, r01))
    return a, b, c


def cos_sin(angles: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Vectorised (cos, sin) of radians from one ``tan`` of the half angle.

    ``numpy.cos`` and ``numpy.sin`` are separate libm loops; one ``tan`` plus a few
    multiplications is several times cheaper and accurate to a few ulp
    (cos = (1 - t^2) / (1 + t^2), sin = 2 t / (1 + t^2), t = tan(angle / 2)).
    """
    t = np.tan(angles * 0.5)
    t2 = t * t
    inv = 1.0 / (1.0 + t2)
    return (1.0 - t2) * inv, (t + t) * inv


def as_pose_array(pose: object, name: str = "pose", *, allow_batch: bool = True) -> NDArray[np.float64]:
    """Validate ``[x, y, z mm, A, B, C deg]`` (or an ``(N, 6)`` batch) as a float64 array."""
    try:
        arr = np.asarray(pose, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ParolkitValueError(f"{name} must be numbers [x, y, z mm, A, B, C deg], got {pose!r}") from None
    if not (arr.shape == (6,) or (allow_batch and arr.ndim == 2 and arr.shape[1] == 6)):
        want = "[x, y, z, A, B, C] or an (N, 6) array" if allow_batch else "[x, y, z, A, B, C]"
        raise ParolkitValueError(f"{name} must be {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        where = f" (sample {bad[0]})" if arr.ndim == 2 else ""
        raise ParolkitValueError(f"{name}{where}: {_POSE_FIELDS[int(bad[-1])]} is not a finite number")
    return arr


def as_matrix_array(matrix: object, name: str = "matrix", *, allow_batch: bool = True,
                    tol: float = 1e-6) -> NDArray[np.float64]:
    """Validate a 4x4 homogeneous transform (or ``(N, 4, 4)``), metres.

    The rotation part must be orthonormal with determinant +1 (within ``tol``) and the last row
    ``[0, 0, 0, 1]``; otherwise :class:`ParolkitValueError` says which property fails.
    """
    try:
        arr = np.asarray(matrix, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ParolkitValueError(f"{name} must be a 4x4 matrix of numbers") from None
    if not (arr.shape == (4, 4) or (allow_batch and arr.ndim == 3 and arr.shape[1:] == (4, 4))):
        raise ParolkitValueError(f"{name} must be a 4x4 matrix{' or (N, 4, 4)' if allow_batch else ''}, "
                                 f"got shape {arr.shape}")
    flat = arr.reshape(-1, 4, 4)
    if not np.all(np.isfinite(flat)):
        bad = int(np.argwhere(~np.isfinite(flat))[0][0])
        raise ParolkitValueError(f"{name}{_sample(arr, bad)} contains a non-finite number")
    last = np.abs(flat[:, 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=1)
    if np.any(last > tol):
        bad = int(np.argmax(last > tol))
        raise ParolkitValueError(f"{name}{_sample(arr, bad)}: last row must be [0, 0, 0, 1]")
    rot = flat[:, :3, :3]
    ortho = np.abs(np.einsum("nij,nkj->nik", rot, rot) - np.eye(3)).max(axis=(1, 2))
    c0, c1, c2 = rot[:, :, 0], rot[:, :, 1], rot[:, :, 2]
    det = np.einsum("ni,ni->n", c0, np.cross(c1, c2))
    badmask = (ortho > tol) | (det < 0)
    if np.any(badmask):
        bad = int(np.argmax(badmask))
        raise ParolkitValueError(
            f"{name}{_sample(arr, bad)}: rotation part is not a proper rotation "
            f"(|R R^T - I| = {ortho[bad]:.3g}, det = {det[bad]:.6g}; need orthonormal, det +1)"
        )
    return arr


def _sample(arr: NDArray[np.float64], idx: int) -> str:
    return f" (sample {idx})" if arr.ndim == 3 else ""


def pose_to_matrix(pose: object) -> NDArray[np.float64]:
    """``[x, y, z mm, A, B, C deg]`` -> 4x4 transform in metres (``(N, 6)`` -> ``(N, 4, 4)``)."""
    arr = as_pose_array(pose)
    if arr.ndim == 1:
        r = _rot_from_abc(arr[3] * _DEG, arr[4] * _DEG, arr[5] * _DEG)
        return np.array([
            [r[0], r[1], r[2], arr[0] * 1e-3],
            [r[3], r[4], r[5], arr[1] * 1e-3],
            [r[6], r[7], r[8], arr[2] * 1e-3],
            [0.0, 0.0, 0.0, 1.0],
        ])
    return _poses_to_matrices(arr)


def _poses_to_matrices(arr: NDArray[np.float64]) -> NDArray[np.float64]:
    n = arr.shape[0]
    cs, sn = cos_sin(arr[:, 3:] * _DEG)
    ca, cb, cc = cs[:, 0], cs[:, 1], cs[:, 2]
    sa, sb, sc = sn[:, 0], sn[:, 1], sn[:, 2]
    out = np.zeros((n, 4, 4))
    out[:, 0, 0] = cb * ca
    out[:, 0, 1] = -cb * sa
    out[:, 0, 2] = sb
    out[:, 1, 0] = cc * sa + sc * sb * ca
    out[:, 1, 1] = cc * ca - sc * sb * sa
    out[:, 1, 2] = -sc * cb
    out[:, 2, 0] = sc * sa - cc * sb * ca
    out[:, 2, 1] = sc * ca + cc * sb * sa
    out[:, 2, 2] = cc * cb
    out[:, :3, 3] = arr[:, :3] * 1e-3
    out[:, 3, 3] = 1.0
    return out


def matrix_to_pose(matrix: object) -> NDArray[np.float64]:
    """4x4 transform in metres -> ``[x, y, z mm, A, B, C deg]`` (``(N, 4, 4)`` -> ``(N, 6)``)."""
    arr = as_matrix_array(matrix)
    if arr.ndim == 2:
        m = arr
        a, b, c = _abc_from_rot(m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2],
                                m[2, 0], m[2, 1], m[2, 2])
        return np.array([m[0, 3] * 1e3, m[1, 3] * 1e3, m[2, 3] * 1e3, a * _RAD, b * _RAD, c * _RAD])
    return _matrices_to_poses(arr)


def _matrices_to_poses(m: NDArray[np.float64]) -> NDArray[np.float64]:
    return _rot_to_poses(m[:, 0, 0], m[:, 0, 1], m[:, 0, 2], m[:, 1, 0], m[:, 1, 1], m[:, 1, 2],
                         m[:, 2, 0], m[:, 2, 1], m[:, 2, 2], m[:, 0, 3], m[:, 1, 3], m[:, 2, 3])


def _rot_to_poses(r00: NDArray[np.float64], r01: NDArray[np.float64], r02: NDArray[np.float64],
                  r10: NDArray[np.float64], r11: NDArray[np.float64], r12: NDArray[np.float64],
                  r20: NDArray[np.float64], r21: NDArray[np.float64], r22: NDArray[np.float64],
                  px: NDArray[np.float64], py: NDArray[np.float64], pz: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vectorised pose extraction from rotation entries (1-D arrays) and positions (metres)."""
    out = np.empty((r00.shape[0], 6))
    out[:, 0] = px * 1e3
    out[:, 1] = py * 1e3
    out[:, 2] = pz * 1e3
    out[:, 3] = np.negative(np.arctan2(r01, r00))
    out[:, 4] = np.arctan2(r02, np.hypot(r00, r01))
    out[:, 5] = np.negative(np.arctan2(r12, r22))
    lock = np.abs(np.abs(r02) - 1.0) < _GIMBAL_TOL
    if np.any(lock):
        idx = np.nonzero(lock)[0]
        pos = r02[idx] > 0
        out[idx, 3] = 0.0
        out[idx, 4] = np.arcsin(np.clip(r02[idx], -1.0, 1.0))
        out[idx, 5] = np.where(pos, np.arctan2(r21[idx], r11[idx]), -np.arctan2(r10[idx], r20[idx]))
    np.multiply(out[:, 3:], _RAD, out=out[:, 3:])
    return out
