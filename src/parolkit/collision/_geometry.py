"""Geometry helpers of the collision package: rotations, the DH rows the kernel multiplies,
the joint-step bounds (Lipschitz constants) and the packing of a scene into the kernel's array.

Everything here is in metres and radians (the packed scene is documented in
:mod:`parolkit.collision._reference`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from parolkit.collision import _reference as ref
from parolkit.robot import PAROL6, RobotModel

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["rot_rpy_deg", "rot_abc_deg", "frame_with_z", "dh_rows", "LinkCapsule", "Static", "PairSpec",
           "pair_lipschitz", "pack"]

Vec3 = tuple[float, float, float]


def rot_rpy_deg(rpy: Sequence[float]) -> NDArray[np.float64]:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` for ``rpy = (roll, pitch, yaw)`` in degrees (URDF)."""
    r, p, y = (math.radians(float(v)) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def rot_abc_deg(abc: Sequence[float]) -> NDArray[np.float64]:
    """The pose convention of parolkit (``R = Rx(C) Ry(B) Rz(A)``, degrees), as a 3x3 matrix."""
    from parolkit.kinematics.pose import pose_to_matrix

    return np.asarray(pose_to_matrix([0.0, 0.0, 0.0, *abc]))[:3, :3]


def frame_with_z(axis: Sequence[float]) -> NDArray[np.float64]:
    """A rotation whose third column is the unit vector along ``axis`` (the first two: a
    deterministic completion to a right-handed frame).  In plain floats: the FCL cross-check
    and its benchmark place a capsule with it per pose."""
    x, y, z = (float(v) for v in axis)
    n = math.sqrt(x * x + y * y + z * z)
    x, y, z = x / n, y / n, z / n
    hx, hy, hz = (1.0, 0.0, 0.0) if abs(x) < 0.9 else (0.0, 1.0, 0.0)
    d = hx * x + hy * y + hz * z
    ux, uy, uz = hx - d * x, hy - d * y, hz - d * z
    m = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / m, uy / m, uz / m
    vx, vy, vz = y * uz - z * uy, z * ux - x * uz, x * uy - y * ux
    return np.array([[ux, vx, x], [uy, vy, y], [uz, vz, z]])


def dh_rows(robot: RobotModel = PAROL6) -> NDArray[np.float64]:
    """(6, 4) rows ``d, a, cos(alpha), sin(alpha)`` of the frames the kernel multiplies: the DH
    table with row 6's ``d`` and ``a`` left out (frame 6 is the flange, as
    :func:`parolkit.kinematics.fk_frames`), the twists' cosines rounded as fk_frames rounds them
    (exact 0 and +-1 for the PAROL6's right angles)."""
    rows = []
    for i, row in enumerate(robot.dh):
        d, a = (row.d, row.a) if i < 5 else (0.0, 0.0)
        rows.append((d, a, round(math.cos(row.alpha), 15) + 0.0, round(math.sin(row.alpha), 15) + 0.0))
    return np.array(rows, dtype=np.float64)


@dataclass(frozen=True)
class LinkCapsule:
    """A capsule for the kernel: axis from ``start`` to ``end`` (m, in frame ``frame``), ``radius`` m."""

    frame: int
    start: Vec3
    end: Vec3
    radius: float


@dataclass(frozen=True)
class Static:
    """A shape fixed in the base frame: ``kind`` (ref.PLANE / BOX / CYLINDER), centre (m),
    rotation (columns = its axes), ``e`` (plane: unit normal; box: half edges; cylinder:
    radius, half height, 0), all in metres."""

    kind: int
    center: Vec3
    rot: tuple[float, ...]
    e: Vec3


@dataclass(frozen=True)
class PairSpec:
    """A pair for the kernel: ``kind`` ref.CAP_CAP (bodies i, j) or ref.CAP_STATIC (body i,
    static j), ``category`` (ref.SELF / ARM_ZONE / ATTACHED_ZONE), ``margin`` m, ``lipschitz``
    (6 values, m/rad)."""

    kind: int
    i: int
    j: int
    category: int
    margin: float
    lipschitz: tuple[float, ...]


def _reach(seg: LinkCapsule) -> float:
    """How far (m) any point of the capsule lies from its frame's origin at most."""
    return max(math.hypot(*seg.start), math.hypot(*seg.end)) + seg.radius


def pair_lipschitz(dh: NDArray[np.float64], seg: LinkCapsule, other: LinkCapsule | None) -> tuple[float, ...]:
    """For each joint j, how far (m) a joint step of 1 rad can move ``seg``'s points relative to
    ``other`` (None: relative to the base frame) at most, in ANY configuration.

    A point x of a body on frame k moves, for joint speeds qdot, at most
    ``sum_j |qdot_j| dist(x, axis j)`` (j <= k).  Axis j passes through the foot of frame j's
    origin on it, which lies ``|a_j|`` from frame j's origin; from there to x the chain adds
    each later row's length ``hypot(a_i, d_i)`` and the body's reach from its frame's origin.
    Joints that move both bodies rigidly (j <= the other body's frame) do not count."""
    lengths = [math.hypot(float(dh[i, 0]), float(dh[i, 1])) for i in range(6)]
    k = seg.frame
    lo = 0 if other is None else other.frame
    out = [0.0] * 6
    for j in range(1, k + 1):  # joint j rotates about the z axis of frame j - 1
        if j <= lo:
            continue
        out[j - 1] = abs(float(dh[j - 1, 1])) + sum(lengths[j:k]) + _reach(seg)
    return tuple(out)


def pack(robot: RobotModel, segments: Sequence[LinkCapsule], statics: Sequence[Static],
         pairs: Sequence[PairSpec], tau: float, max_evals: int) -> NDArray[np.float64]:
    """The kernel's float64 array (layout: :mod:`parolkit.collision._reference`), read-only."""
    parts: list[float] = [ref.MAGIC, float(len(segments)), float(len(statics)), float(len(pairs)), float(tau),
                          float(max_evals)]
    parts += [float(v) for v in dh_rows(robot).ravel()]
    for s in segments:
        parts += [float(s.frame), *s.start, *s.end, float(s.radius)]
    for st in statics:
        parts += [float(st.kind), *st.center, *st.rot, *st.e]
    for p in pairs:
        parts += [float(p.kind), float(p.i), float(p.j), float(p.category), float(p.margin), *p.lipschitz, 0.0]
    buf = np.array(parts, dtype=np.float64)
    buf.setflags(write=False)
    return buf
