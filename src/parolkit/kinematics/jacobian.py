"""Differential kinematics: geometric Jacobian, manipulability, distance to singularities."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from parolkit.kinematics.fk import _flange_rad, _joints_rad, fk_frames
from parolkit.kinematics.model import PHI3
from parolkit.kinematics.tools import Tool
from parolkit.kinematics.types import SingularityInfo

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["jacobian", "manipulability", "singularity_distance"]

#: Warning thresholds used to rank singularities: wrist deg, shoulder mm, elbow deg.
SINGULARITY_THRESHOLDS = (5.0, 20.0, 5.0)


def jacobian(joints_deg: object, tool: str | Tool | None = None) -> NDArray[np.float64]:
    """Geometric Jacobian (6, 6) at the TCP, in the base frame.

    Column i maps joint i's rate (rad/s) to the TCP twist: rows 0..2 linear velocity in m/s,
    rows 3..5 angular velocity in rad/s (all revolute: ``[z x (p_tcp - p_i); z]``).
    """
    frames = fk_frames(joints_deg, tool)
    p_tcp = frames[7, :3, 3]
    z = frames[:6, :3, 2]  # axis of joint i = z of frame i-1
    o = frames[:6, :3, 3]
    jac = np.empty((6, 6))
    jac[:3] = np.cross(z, p_tcp - o).T
    jac[3:] = z.T
    return jac


def manipulability(joints_deg: object, tool: str | Tool | None = None) -> float:
    """Yoshikawa manipulability ``sqrt(det(J J^T))`` (0 at a singularity).

    For the square 6x6 Jacobian this equals ``|det J|`` (computed that way: it keeps full
    precision near zero).  Units: m^3 (three linear rows in m/s per rad/s).
    """
    jac = jacobian(joints_deg, tool)
    return abs(float(np.linalg.det(jac)))


def _fold(angle_deg: float) -> float:
    """Distance (deg) of an angle from the nearest multiple of 180 deg."""
    return abs(((angle_deg + 90.0) % 180.0) - 90.0)


def singularity_distance(joints_deg: object) -> SingularityInfo:
    """How far ``joints_deg`` is from the wrist, shoulder and elbow singularities.

    Independent of the tool (the singularities are properties of the arm).  See
    :class:`SingularityInfo` for the three measures and how ``nearest`` is ranked.
    """
    q = _joints_rad(joints_deg)
    _rot, pos = _flange_rad(*q)
    wrist = _fold(math.degrees(q[4]))
    shoulder = math.hypot(pos[0], pos[1]) * 1e3
    elbow = _fold(math.degrees(q[2] - PHI3))
    th = SINGULARITY_THRESHOLDS
    ratios = {"wrist": wrist / th[0], "shoulder": shoulder / th[1], "elbow": elbow / th[2]}
    nearest = min(ratios, key=ratios.__getitem__)
    return SingularityInfo(wrist, shoulder, elbow, nearest, th)
