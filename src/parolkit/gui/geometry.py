"""The arm as simple solids generated from the DH table (no mesh files).

The live view places them with ``parolkit.kinematics.fk_frames`` (same frame order);
:func:`dh_frames` is a dependency-free twin used for the initial pose and in tests.

Frames (index): 0 base, 1..5 the DH frames 1..5, 6 the flange (DH frame 6 with row 6's d and
a set to 0), 7 the TCP (the full row 6: the original commander's tool point).  Every solid is
rigidly attached to one frame, so a live update only moves 8 frames.

Link *i* of a standard DH chain goes from the origin of frame *i-1* along z_{i-1} by d_i (a
cylinder fixed in frame *i-1*: it is symmetric about z, so theta_i does not change it) and
then along x_i by a_i (a cylinder fixed in frame *i*, from (-a_i, 0, 0) to its origin).  Joint
housings are short, wider cylinders on each joint axis z_{i-1}.

Lengths here are metres; :data:`SCENE_SCALE` converts to scene units (decimetres, so the
default grid of 1-unit cells is a 10 cm grid).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from parolkit.robot import PAROL6, DHRow, RobotModel

__all__ = [
    "SCENE_SCALE",
    "N_FRAMES",
    "Solid",
    "dh_frames",
    "arm_solids",
    "frame_pose_for_scene",
    "rotation_y_to",
]

#: scene units per metre (1 unit = 1 dm)
SCENE_SCALE = 10.0
#: base, frames 1..5, flange, TCP
N_FRAMES = 8

Mat4 = list[list[float]]


def _identity() -> Mat4:
    return [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]


def _matmul(a: Mat4, b: Mat4) -> Mat4:
    return [[a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] + a[i][3] * b[3][j]
             for j in range(4)] for i in range(4)]


def _dh(theta: float, row: DHRow) -> Mat4:
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(row.alpha), math.sin(row.alpha)
    return [
        [ct, -st * ca, st * sa, row.a * ct],
        [st, ct * ca, -ct * sa, row.a * st],
        [0.0, sa, ca, row.d],
        [0.0, 0.0, 0.0, 1.0],
    ]


def dh_frames(joints_deg: Sequence[float], model: RobotModel = PAROL6) -> list[Mat4]:
    """The 8 frames (4x4, metres) for joint angles in degrees: base, 1..5, flange, TCP.

    Plain floats (about 10 µs): this runs for every status sample the 3D view shows.
    """
    if len(joints_deg) != 6:
        raise ValueError(f"joints_deg must have 6 values, got {len(joints_deg)}")
    t = _identity()
    out = [t]
    for i in range(5):
        t = _matmul(t, _dh(math.radians(float(joints_deg[i])), model.dh[i]))
        out.append(t)
    theta6 = math.radians(float(joints_deg[5]))
    row6 = model.dh[5]
    out.append(_matmul(t, _dh(theta6, replace(row6, d=0.0, a=0.0))))
    out.append(_matmul(t, _dh(theta6, row6)))
    return out


@dataclass(frozen=True)
class Solid:
    """A primitive fixed in frame ``frame``.

    ``shape``: 'cylinder' (``radius``, ``length``; axis along the segment ``start`` -> ``end``),
    'sphere' (``radius`` at ``start``) or 'box' (``size`` centred at ``start``).  Points in
    metres, in the frame's coordinates.  ``role``: 'joint', 'link', 'tool' or 'base' (colour).
    ``body``: the collision model's body this solid stands for ("base", "J1 link" .. "J6 link",
    "tool": :mod:`parolkit.collision`), so the view colours it when that body is within a margin.
    """

    frame: int
    shape: str
    start: tuple[float, float, float]
    end: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.0
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    role: str = "link"
    body: str = ""

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    @property
    def center(self) -> tuple[float, float, float]:
        (sx, sy, sz), (ex, ey, ez) = self.start, self.end
        return ((sx + ex) / 2, (sy + ey) / 2, (sz + ez) / 2)

    def rotation_y_to_axis(self) -> list[list[float]]:
        """Rotation taking the +Y axis (three.js cylinder axis) onto start->end."""
        return rotation_y_to([e - s for s, e in zip(self.start, self.end)])


def rotation_y_to(direction: Sequence[float]) -> list[list[float]]:
    """Rotation (rows) taking the +Y axis (three.js's cylinder axis) onto ``direction`` (any
    length; the identity for a zero vector)."""
    d = [float(v) for v in direction]
    n = math.sqrt(sum(v * v for v in d))
    if n == 0:
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    u = [v / n for v in d]
    # Rodrigues rotation from y = (0,1,0) to u
    y = (0.0, 1.0, 0.0)
    c = u[1]
    axis = (y[1] * u[2] - y[2] * u[1], y[2] * u[0] - y[0] * u[2], y[0] * u[1] - y[1] * u[0])
    s = math.sqrt(sum(a * a for a in axis))
    if s < 1e-12:
        return ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] if c > 0
                else [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    k = [a / s for a in axis]
    kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]]
    kk = [[sum(kx[i][m] * kx[m][j] for m in range(3)) for j in range(3)] for i in range(3)]
    return [[(1.0 if i == j else 0.0) + s * kx[i][j] + (1 - c) * kk[i][j] for j in range(3)]
            for i in range(3)]


#: joint housing radius and height (m) per joint axis 1..6
_JOINT_R = (0.040, 0.034, 0.030, 0.026, 0.024, 0.020)
_JOINT_H = (0.070, 0.075, 0.064, 0.052, 0.050, 0.030)
#: link cylinder radius (m) per link 1..6
_LINK_R = (0.032, 0.026, 0.024, 0.022, 0.018, 0.016)


def arm_solids(model: RobotModel = PAROL6, *, min_length: float = 1e-6) -> list[Solid]:
    """Every solid of the arm, generated from ``model.dh`` (see the module docstring).

    Each names the collision body it stands for (:attr:`Solid.body`), as
    :mod:`parolkit.collision` divides the arm: DH row *i*'s link (its ``d`` and ``a`` parts) and
    the housing of joint *i* belong to "J<i> link" (the J1 link is the column, the J5 link the
    wrist housing across the J5 axis, the J6 link the flange); the drawn tool to "tool"."""
    solids: list[Solid] = [
        Solid(0, "cylinder", (0.0, 0.0, 0.0), (0.0, 0.0, 0.025), radius=0.075, role="base", body="base"),
    ]
    for i, row in enumerate(model.dh):
        if i == 5:
            break  # the sixth row is the flange + tool, drawn below
        body = f"J{i + 1} link"
        h = _JOINT_H[i] / 2
        solids.append(Solid(i, "cylinder", (0.0, 0.0, -h), (0.0, 0.0, h), radius=_JOINT_R[i], role="joint", body=body))
        if abs(row.d) > min_length:
            solids.append(Solid(i, "cylinder", (0.0, 0.0, 0.0), (0.0, 0.0, row.d), radius=_LINK_R[i], body=body))
        if abs(row.a) > min_length:
            solids.append(Solid(i + 1, "cylinder", (-row.a, 0.0, 0.0), (0.0, 0.0, 0.0), radius=_LINK_R[i], body=body))
    # joint 6 housing on axis z5, the flange disc and the tool (row 6's d and a) in the flange frame
    solids.append(Solid(5, "cylinder", (0.0, 0.0, -_JOINT_H[5] / 2), (0.0, 0.0, _JOINT_H[5] / 2),
                        radius=_JOINT_R[5], role="joint", body="J6 link"))
    solids.append(Solid(6, "cylinder", (0.0, 0.0, 0.0), (0.0, 0.0, 0.006), radius=0.022, role="joint", body="J6 link"))
    row6 = model.dh[5]
    # TCP frame = flange * Tz(d) * Tx(a) (the rotations are shared): in flange coordinates the
    # tool goes from the origin along z by d, then along the flange x (rotated by alpha only
    # about x, which keeps x) by a.
    if abs(row6.d) > min_length:
        solids.append(Solid(6, "cylinder", (0.0, 0.0, 0.0), (0.0, 0.0, -row6.d), radius=0.010, role="tool",
                            body="tool"))
    if abs(row6.a) > min_length:
        solids.append(Solid(7, "cylinder", (-row6.a, 0.0, 0.0), (0.0, 0.0, 0.0), radius=0.008, role="tool",
                            body="tool"))
    solids.append(Solid(7, "sphere", (0.0, 0.0, 0.0), radius=0.009, role="tool", body="tool"))
    return solids


def frame_pose_for_scene(t: Mat4) -> tuple[list[float], list[list[float]]]:
    """(translation in scene units, 3x3 rotation) of one 4x4 frame in metres."""
    return ([float(t[0][3]) * SCENE_SCALE, float(t[1][3]) * SCENE_SCALE, float(t[2][3]) * SCENE_SCALE],
            [[float(t[i][j]) for j in range(3)] for i in range(3)])
