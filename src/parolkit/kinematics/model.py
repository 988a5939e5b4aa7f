"""Kinematic constants of the PAROL6, derived once from :data:`parolkit.robot.PAROL6`.

The closed forms in this package rely on the structure of the DH table (the twists
``alpha = -pi/2, pi, pi/2, -pi/2, pi/2, pi``, ``a4 = a5 = d2 = d3 = d5 = 0``: a spherical
wrist); the lengths come from the table.  :func:`check_structure` verifies that structure at
import, so a changed table fails loudly instead of giving wrong poses.

Notation (metres, radians):

* flange chain = the DH chain with row 6's ``d`` and ``a`` set to 0.  The flange origin is the
  wrist centre (axes 4, 5, 6 meet there).
* Closed form of the flange orientation:
  ``R = Rz(q1) Ry(q2 - q3) Rz(-q4) Ry(-q5) Rz(-q6)``.
* Wrist centre: ``(r cos q1, r sin q1, D1 - Y)`` with ``r = A1 + X`` and
  ``[X, Y] = Rot(q2) [u, v]``, ``u = A2 + A3 cos q3 + D4 sin q3``, ``v = D4 cos q3 - A3 sin q3``.
"""

from __future__ import annotations

import math

import numpy as np

from parolkit.errors import ParolkitError
from parolkit.robot import PAROL6, RobotModel

__all__ = [
    "D1", "A1", "A2", "A3", "D4", "L3", "PHI3", "TOOL_DEFAULT_T",
    "LIM_LO", "LIM_HI", "LIM_LO_ARR", "LIM_HI_ARR", "WEIGHTS", "STANDBY_RAD", "TWO_PI", "LIMIT_TOL",
    "check_structure",
]

TWO_PI = 2.0 * math.pi
#: Joint values this close (rad) outside a limit are numerical noise: they are snapped onto the
#: limit (1e-9 rad = 5.7e-8 deg, far below one microstep = 0.0088 deg on J1).
LIMIT_TOL = 1e-9

_EXPECTED_ALPHA = (-math.pi / 2, math.pi, math.pi / 2, -math.pi / 2, math.pi / 2, math.pi)


def check_structure(model: RobotModel = PAROL6) -> None:
    """Raise :class:`ParolkitError` if ``model.dh`` is not the PAROL6 spherical-wrist structure."""
    dh = model.dh
    for i, (row, alpha) in enumerate(zip(dh, _EXPECTED_ALPHA)):
        if abs(row.alpha - alpha) > 1e-12:
            raise ParolkitError(f"DH row {i + 1}: alpha {row.alpha} differs from {alpha}; the "
                                "closed-form kinematics assumes the PAROL6 twists")
    if dh[1].d != 0 or dh[2].d != 0 or dh[3].a != 0 or dh[4].a != 0 or dh[4].d != 0:
        raise ParolkitError("DH table is not a spherical-wrist PAROL6 chain (d2, d3, a4, a5, d5 != 0)")


check_structure(PAROL6)

_dh = PAROL6.dh
D1 = _dh[0].d
A1 = _dh[0].a
A2 = _dh[1].a
A3 = _dh[2].a
D4 = _dh[3].d
#: Distance elbow axis -> wrist centre and its angle: A3 cos q3 + D4 sin q3 = L3 cos(q3 - PHI3).
L3 = math.hypot(A3, D4)
PHI3 = math.atan2(D4, A3)
#: The original commander's TCP in the flange frame (from DH row 6): (a6, 0, -d6) metres.
TOOL_DEFAULT_T = (_dh[5].a, 0.0, -_dh[5].d)

_RAD = 180.0 / math.pi


def _inner_rad(limit_deg: float, upper: bool) -> float:
    """The limit in radians, nudged inward (by ulps) so ``value * (180 / pi)`` of any angle
    inside it stays inside the degree limit after rounding."""
    r = math.radians(limit_deg)
    if upper:
        while r * _RAD > limit_deg:
            r = math.nextafter(r, -math.inf)
    else:
        while r * _RAD < limit_deg:
            r = math.nextafter(r, math.inf)
    return r


_safe = PAROL6.safe_limits_deg
#: Safe joint limits in radians (the range IK results must lie in).
LIM_LO = tuple(_inner_rad(float(v), False) for v in _safe[:, 0])
LIM_HI = tuple(_inner_rad(float(v), True) for v in _safe[:, 1])

#: Weights of the joint distance used to pick the solution nearest the seed: the squared
#: inverse of each joint's maximum speed, so the distance is a travel-time measure
#: (normalised so the largest weight is 1).
_vmax = PAROL6.max_speed_deg_s
_w = (1.0 / _vmax) ** 2
WEIGHTS = tuple(float(v) for v in _w / _w.max())

#: Standby pose (default IK seed), radians.
STANDBY_RAD = tuple(math.radians(v) for v in PAROL6.standby_deg)

#: numpy copies for the vectorised code.
LIM_LO_ARR = np.array(LIM_LO)
LIM_HI_ARR = np.array(LIM_HI)
