"""Closed-form inverse kinematics of the PAROL6 (spherical wrist): every branch, in limits.

For a TCP pose the solver removes the tool, takes the flange origin as the wrist centre and
solves, in closed form,

* J1 from the wrist centre's azimuth (shoulder ``front``: J1 = atan2(y, x); ``back``: +180),
* J3 from the distance shoulder axis -> wrist centre (elbow ``up`` / ``down``),
* J2 from the direction to the wrist centre,
* J4, J5, J6 as ZYZ Euler angles of the remaining rotation (two wrist solutions).

Each angle is then mapped into its joint range (theta or theta +- 360; where two
representations fit, as J6 = 0 / 360, the one closer to the seed), solutions with a joint out
of range are dropped, and the solution with the smallest weighted joint distance to the seed
wins (weights: squared inverse joint speeds, a travel-time measure).

Singularities do not fail: on the wrist singularity (J5 = 0, axes 4 and 6 aligned) J4 keeps
the seed's value and J6 takes the rest; on the shoulder singularity (wrist centre on the J1
axis) J1 keeps the seed's value.  Unreachable or out-of-limit targets raise :class:`IKError`
with the reason (out of reach by N mm; Jn would be X deg > limit).

All computations of one pose run in plain floats (no numpy per call).  :func:`ik` runs the
compiled copy of this file's hot path (``_cik.c``, the same steps in the same floating-point
order) when it is built; this file is the reference, used for everything else and whenever the
kernel is missing (see :mod:`parolkit._native`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, overload

import numpy as np

from parolkit import _native
from parolkit.errors import ParolkitValueError
from parolkit.kinematics.fk import _joints_rad
from parolkit.kinematics.model import (
    A1,
    A2,
    A3,
    D1,
    D4,
    L3,
    LIM_HI,
    LIM_LO,
    LIMIT_TOL,
    PHI3,
    STANDBY_RAD,
    TWO_PI,
    WEIGHTS,
)
from parolkit.kinematics.pose import _rot_from_abc, as_matrix_array, as_pose_array
from parolkit.kinematics.tools import DEFAULT_TOOL as _DEFAULT_TOOL
from parolkit.kinematics.tools import Tool, get_tool
from parolkit.kinematics.types import Branch, IKError, IKFailure, IKSolution
from parolkit.robot import as_joint_array

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["ik", "ik_all", "ik_batch", "solve_all_rad", "diagnose"]

_DEG = math.pi / 180.0
_RAD = 180.0 / math.pi
_PI = math.pi
_HALF_PI = math.pi / 2
_atan2 = math.atan2
_cos = math.cos
_sin = math.sin
_floor = math.floor
_sqrt = math.sqrt
_acos = math.acos
_isfinite = math.isfinite

#: sin(J5) below this is treated as the wrist singularity (J4 is then taken from the seed).
WRIST_SINGULAR_EPS = 1e-9
#: Wrist-centre distance from the J1 axis (m) below which J1 is taken from the seed.
SHOULDER_SINGULAR_EPS = 1e-9
#: Relative slack on the elbow cosine (numerical noise at full stretch).
_REACH_EPS = 1e-12

_K0 = A2 * A2 + L3 * L3
_INV_2A2L = 1.0 / (2.0 * A2 * L3)
#: Distance from the J2 axis to the wrist centre: min / max (m).
REACH_MIN = abs(A2 - L3)
REACH_MAX = A2 + L3

_LO1, _LO2, _LO3, _LO4, _LO5, _LO6 = LIM_LO
_HI1, _HI2, _HI3, _HI4, _HI5, _HI6 = LIM_HI
_W1, _W2, _W3, _W4, _W5, _W6 = WEIGHTS
_WIDE = tuple(hi - lo >= TWO_PI - 2 * LIMIT_TOL for lo, hi in zip(LIM_LO, LIM_HI))
if any(_WIDE[:5]) or not _WIDE[5]:  # pragma: no cover - the inlined fits assume these ranges
    raise ImportError("parolkit.kinematics.ik assumes J1..J5 ranges narrower than 360 deg and J6 a full turn")
if LIM_LO[4] < -_HALF_PI - 1e-12 or LIM_HI[4] != -LIM_LO[4]:  # pragma: no cover
    raise ImportError("parolkit.kinematics.ik assumes a symmetric J5 range within +-90 deg")
_LO1M, _LO2M, _LO3M, _LO4M, _LO5M, _LO6M = (v - LIMIT_TOL for v in LIM_LO)
_HI1P, _HI2P, _HI3P, _HI4P, _HI5P, _HI6P = (v + LIMIT_TOL for v in LIM_HI)
#: J6 values up to this also fit one turn higher (J6 = 0 and 360 are both in range).
_HI6_LOW_TWIN = _HI6P - TWO_PI
_LO1M_2PI, _LO2M_2PI, _LO3M_2PI, _LO4M_2PI, _LO5M_2PI, _LO6M_2PI = (
    v + TWO_PI for v in (_LO1M, _LO2M, _LO3M, _LO4M, _LO5M, _LO6M))
_INF = math.inf
#: PHI3 shifted by whole turns into J3's range, so J3 = PHI3 -+ delta mostly needs no wrap.
_PHI3_IN_RANGE = PHI3 + TWO_PI * math.ceil((LIM_LO[2] - PHI3) / TWO_PI)
_INV_2PI = 1.0 / TWO_PI
_ELBOWS = ("up", "down")
_SHOULDER_CODE = {None: -1, "front": 0, "back": 1}
_ELBOW_CODE = {None: -1, "up": 0, "down": 1}
_FLIP_CODE = {None: -1, False: 0, True: 1}

#: One solution of :func:`solve_all_rad`: (weighted distance to the seed, (q1..q6 rad),
#: shoulder, elbow, wrist flip).
_Candidate = tuple[float, tuple[float, float, float, float, float, float], str, str, bool]
#: One branch of :func:`_raw_branches`: (shoulder, elbow, flip, q1..q6 rad or None when out of
#: reach, distance beyond reach in m).
_RawBranch = tuple[str, str, bool, tuple[float, ...] | None, float]


def _native_constants() -> tuple[float, ...]:
    """Every constant the compiled kernel uses, in the order ``_cik.c`` reads them."""
    return (A1, A2, A3, D1, D4, _K0, _INV_2A2L, PHI3, _PHI3_IN_RANGE, _INV_2PI, _HI6_LOW_TWIN,
            WRIST_SINGULAR_EPS, SHOULDER_SINGULAR_EPS, _REACH_EPS, _DEG, _RAD,
            *LIM_LO, *LIM_HI, *STANDBY_RAD, LIMIT_TOL, *WEIGHTS)


_cik = _native.load("parolkit.kinematics._cik")
if _cik is not None:
    _cik.configure(_native_constants())
#: True when :func:`ik` runs the compiled kernel.
NATIVE = _cik is not None


def _clamp(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


def _flange_target(
    rot: Sequence[float], pos: Sequence[float], tool: Tool,
) -> tuple[Sequence[float], tuple[float, float, float]]:
    """Remove the tool: flange rotation (9 floats) and flange origin (= wrist centre, m)."""
    if tool._identity_rot:
        r = rot
    else:
        t = tool._rot  # R_f = R T^T
        r = tuple(
            rot[3 * i] * t[3 * j] + rot[3 * i + 1] * t[3 * j + 1] + rot[3 * i + 2] * t[3 * j + 2]
            for i in range(3) for j in range(3)
        )
    tx, ty, tz = tool._t
    p = (
        pos[0] - (r[0] * tx + r[1] * ty + r[2] * tz),
        pos[1] - (r[3] * tx + r[4] * ty + r[5] * tz),
        pos[2] - (r[6] * tx + r[7] * ty + r[8] * tz),
    )
    return r, p


def solve_all_rad(
    r: Sequence[float], p: Sequence[float], seed: Sequence[float], shoulder: str | None = None,
    elbow: str | None = None, flip: bool | None = None, best_only: bool = False,
) -> list[_Candidate]:
    """Every in-limit solution for flange rotation ``r`` (9 floats) and wrist centre ``p`` (m).

    ``seed`` is six radians.  ``shoulder``/``elbow``/``flip`` restrict the branch (None = any).
    Returns a list of ``(distance, (q1..q6 rad), shoulder, elbow, flip)``; with ``best_only``
    a list holding only the nearest one (or empty).

    This is the hot path of :func:`ik`: plain floats, every joint fit inlined (J1..J5 ranges
    are narrower than 360 deg, so their in-range representation is unique; J6 spans a full
    turn, where 0 and 360 both fit the one nearer the seed is taken), early exits as soon as a
    joint is out of range, and with ``best_only`` a branch-and-bound: the nearer shoulder and
    elbow are tried first and a branch is abandoned once its partial distance (J1, J3, J2
    terms) already exceeds the best complete one.
    """
    s1, s2, s3, s4, s5, s6 = seed
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
    x, y, z = p
    rho = _sqrt(x * x + y * y)
    Y = D1 - z
    out: list[_Candidate] = []
    best: _Candidate | None = None
    best_d = _INF
    shoulders: tuple[tuple[str, float, float, float, float], ...]
    if rho < SHOULDER_SINGULAR_EPS:
        q1f = _clamp(s1, _LO1, _HI1)
        shoulders = ((shoulder or "front", q1f, 0.0, _cos(q1f), _sin(q1f)),)
    else:
        base = _atan2(y, x)
        c1f = x / rho
        s1f = y / rho
        d = base - s1
        if d > _PI or d < -_PI:
            d -= TWO_PI * _floor(d * _INV_2PI + 0.5)
        if -_HALF_PI <= d <= _HALF_PI:
            shoulders = (("front", base, rho, c1f, s1f), ("back", base + _PI, -rho, -c1f, -s1f))
        else:
            shoulders = (("back", base + _PI, -rho, -c1f, -s1f), ("front", base, rho, c1f, s1f))
    d = s3 - PHI3
    if d > _PI or d < -_PI:
        d -= TWO_PI * _floor(d * _INV_2PI + 0.5)
    elbow_order = (("up", -1.0), ("down", 1.0)) if d <= 0.0 else (("down", 1.0), ("up", -1.0))
    for sh_name, q1, rr, c1, sn1 in shoulders:
        if shoulder is not None and sh_name != shoulder:
            continue
        if q1 < _LO1M or q1 >= _LO1M_2PI:
            q1 -= TWO_PI * _floor((q1 - _LO1M) * _INV_2PI)
        if q1 > _HI1P:
            continue
        if q1 < _LO1:
            q1 = _LO1
        elif q1 > _HI1:
            q1 = _HI1
        e = q1 - s1
        d1 = _W1 * e * e
        if d1 >= best_d:
            continue
        X = rr - A1
        c = (X * X + Y * Y - _K0) * _INV_2A2L
        if c > 1.0:
            if c > 1.0 + _REACH_EPS:
                continue
            c = 1.0
        elif c < -1.0:
            if c < -1.0 - _REACH_EPS:
                continue
            c = -1.0
        delta = _acos(c)
        atan_y = _atan2(Y, X)
        # N = Rz(-q1) R (rows 0 and 1; row 2 is R's)
        n00 = c1 * r00 + sn1 * r10
        n01 = c1 * r01 + sn1 * r11
        n02 = c1 * r02 + sn1 * r12
        n10 = c1 * r10 - sn1 * r00
        n12 = c1 * r12 - sn1 * r02
        for el_name, sign in elbow_order:
            if elbow is not None and el_name != elbow:
                continue
            q3 = _PHI3_IN_RANGE + sign * delta
            if q3 < _LO3M or q3 >= _LO3M_2PI:
                q3 -= TWO_PI * _floor((q3 - _LO3M) * _INV_2PI)
            if q3 > _HI3P:
                continue
            if q3 < _LO3:
                q3 = _LO3
            elif q3 > _HI3:
                q3 = _HI3
            e = q3 - s3
            d13 = d1 + _W3 * e * e
            if d13 >= best_d:
                continue
            c3 = _cos(q3)
            sn3 = _sin(q3)
            q2 = atan_y - _atan2(D4 * c3 - A3 * sn3, A2 + A3 * c3 + D4 * sn3)
            if q2 < _LO2M or q2 >= _LO2M_2PI:
                q2 -= TWO_PI * _floor((q2 - _LO2M) * _INV_2PI)
            if q2 > _HI2P:
                continue
            if q2 < _LO2:
                q2 = _LO2
            elif q2 > _HI2:
                q2 = _HI2
            e = q2 - s2
            d123 = d13 + _W2 * e * e
            if d123 >= best_d:
                continue
            psi = q2 - q3
            cp = _cos(psi)
            sp = _sin(psi)
            m02 = cp * n02 - sp * r22
            m22 = sp * n02 + cp * r22
            sb = _sqrt(m02 * m02 + n12 * n12)
            if sb > WRIST_SINGULAR_EPS:
                be = _atan2(sb, m22)  # in (0, pi]: J5 = +be (noflip) or -be (flip)
                if be > _HI5P:
                    continue  # |J5| > 90 deg in both wrist solutions
                if be > _HI5:
                    be = _HI5
                al = _atan2(n12, m02)
                ga = _atan2(sp * n01 + cp * r21, -(sp * n00 + cp * r20))
                if flip is not True:  # noflip: (pi - al, be, pi - ga)
                    q4 = _PI - al
                    if q4 < _LO4M or q4 >= _LO4M_2PI:
                        q4 -= TWO_PI * _floor((q4 - _LO4M) * _INV_2PI)
                    if q4 <= _HI4P:
                        if q4 < _LO4:
                            q4 = _LO4
                        elif q4 > _HI4:
                            q4 = _HI4
                        e4 = q4 - s4
                        e5 = be - s5
                        d = d123 + _W4 * e4 * e4 + _W5 * e5 * e5
                    else:
                        d = _INF
                    if d < best_d:
                        q6 = _PI - ga
                        if q6 < _LO6M or q6 >= _LO6M_2PI:
                            q6 -= TWO_PI * _floor((q6 - _LO6M) * _INV_2PI)
                        if q6 <= _HI6_LOW_TWIN and abs(q6 + TWO_PI - s6) < abs(q6 - s6):
                            q6 += TWO_PI
                        if q6 < _LO6:
                            q6 = _LO6
                        elif q6 > _HI6:
                            q6 = _HI6
                        e6 = q6 - s6
                        d += _W6 * e6 * e6
                        if not best_only:
                            out.append((d, (q1, q2, q3, q4, be, q6), sh_name, el_name, False))
                        elif d < best_d:
                            best_d = d
                            best = (d, (q1, q2, q3, q4, be, q6), sh_name, el_name, False)
                if flip is not False:  # flip: (-al, -be, -ga)
                    q4 = -al
                    if q4 < _LO4M or q4 >= _LO4M_2PI:
                        q4 -= TWO_PI * _floor((q4 - _LO4M) * _INV_2PI)
                    if q4 <= _HI4P:
                        if q4 < _LO4:
                            q4 = _LO4
                        elif q4 > _HI4:
                            q4 = _HI4
                        e4 = q4 - s4
                        e5 = be + s5
                        d = d123 + _W4 * e4 * e4 + _W5 * e5 * e5
                    else:
                        d = _INF
                    if d < best_d:
                        q6 = -ga
                        if q6 < _LO6M or q6 >= _LO6M_2PI:
                            q6 -= TWO_PI * _floor((q6 - _LO6M) * _INV_2PI)
                        if q6 <= _HI6_LOW_TWIN and abs(q6 + TWO_PI - s6) < abs(q6 - s6):
                            q6 += TWO_PI
                        if q6 < _LO6:
                            q6 = _LO6
                        elif q6 > _HI6:
                            q6 = _HI6
                        e6 = q6 - s6
                        d += _W6 * e6 * e6
                        if not best_only:
                            out.append((d, (q1, q2, q3, q4, -be, q6), sh_name, el_name, True))
                        elif d < best_d:
                            best_d = d
                            best = (d, (q1, q2, q3, q4, -be, q6), sh_name, el_name, True)
            else:
                # wrist singular: J4 keeps the seed's value, J6 takes the rest of J4 + J6
                if m22 < 0:
                    continue  # J5 = 180 deg
                q4 = _clamp(s4, _LO4, _HI4)
                m00 = cp * n00 - sp * r20
                q6 = -_atan2(n10, m00) - q4
                if q6 < _LO6M or q6 >= _LO6M_2PI:
                    q6 -= TWO_PI * _floor((q6 - _LO6M) * _INV_2PI)
                if q6 <= _HI6_LOW_TWIN and abs(q6 + TWO_PI - s6) < abs(q6 - s6):
                    q6 += TWO_PI
                if q6 < _LO6:
                    q6 = _LO6
                elif q6 > _HI6:
                    q6 = _HI6
                e4 = q4 - s4
                e6 = q6 - s6
                d = d123 + _W4 * e4 * e4 + _W5 * s5 * s5 + _W6 * e6 * e6
                fl = flip if flip is not None else False
                if not best_only:
                    out.append((d, (q1, q2, q3, q4, 0.0, q6), sh_name, el_name, fl))
                elif d < best_d:
                    best_d = d
                    best = (d, (q1, q2, q3, q4, 0.0, q6), sh_name, el_name, fl)
    if best_only:
        return [best] if best is not None else []
    return out


# ---------------------------------------------------------------------------------------------
# input parsing
# ---------------------------------------------------------------------------------------------


def _target(pose: object) -> tuple[Sequence[float], tuple[float, float, float]]:
    """Pose ([x,y,z,A,B,C] mm/deg or 4x4 m) -> (rotation 9 floats, position 3 floats, metres)."""
    if type(pose) is np.ndarray:
        if pose.shape == (6,):
            pose = pose.tolist()
        elif pose.shape == (4, 4):
            return _target_matrix(pose)
        else:  # any other shape: the precise error (unpacked below, its rows would be scaled in place)
            return _target_slow(pose)
    if type(pose) is not list and type(pose) is not tuple:
        return _target_slow(pose)
    if len(pose) != 6:
        return _target_slow(pose)
    try:
        x, y, z, a, b, c = pose
        # new objects, never in place: an entry may be the caller's (0-d) array
        x = x * 1e-3
        y = y * 1e-3
        z = z * 1e-3
        a = a * _DEG
        b = b * _DEG
        c = c * _DEG
        if not _isfinite(x + y + z + a + b + c):  # NaN/inf (or a sum overflow): slow path decides
            return _target_slow(pose)
        ca = _cos(a)
        sa = _sin(a)
        cb = _cos(b)
        sb = _sin(b)
        cc = _cos(c)
        sc = _sin(c)
    except (TypeError, ValueError, OverflowError):  # strings, complex, ...: precise error there
        return _target_slow(pose)
    scsb = sc * sb
    ccsb = cc * sb
    return (
        (cb * ca, -cb * sa, sb,
         cc * sa + scsb * ca, cc * ca - scsb * sa, -sc * cb,
         sc * sa - ccsb * ca, sc * ca + ccsb * sa, cc * cb),
        (x, y, z),
    )


def _target_flange(pose: object, tool: Tool) -> tuple[Sequence[float], tuple[float, float, float]]:
    """Pose -> flange rotation (9 floats) and wrist centre (3 floats, m) for ``tool``."""
    r, p = _target(pose)
    return _flange_target(r, p, tool)


def _target_matrix(pose: object) -> tuple[tuple[float, ...], tuple[float, float, float]]:
    try:
        m = as_matrix_array(pose, "pose", allow_batch=False)
    except ParolkitValueError as exc:
        raise IKError(str(exc), kind=IKFailure.BAD_INPUT) from None
    return tuple(m[:3, :3].ravel().tolist()), (float(m[0, 3]), float(m[1, 3]), float(m[2, 3]))


def _target_slow(pose: object) -> tuple[Sequence[float], tuple[float, float, float]]:
    """Validate an unusual pose argument with a precise error, then convert it."""
    try:
        arr = np.asarray(pose, dtype=float)
    except (TypeError, ValueError, OverflowError):
        arr = None
    if arr is not None and arr.shape == (4, 4):
        return _target_matrix(arr)
    try:
        arr = as_pose_array(pose, "pose", allow_batch=False)
    except ParolkitValueError as exc:
        raise IKError(str(exc) + " (or give a 4x4 matrix in metres)", kind=IKFailure.BAD_INPUT) from None
    x, y, z, a, b, c = arr.tolist()
    return _rot_from_abc(a * _DEG, b * _DEG, c * _DEG), (x * 1e-3, y * 1e-3, z * 1e-3)


@overload
def _branch(config: Branch | str) -> Branch: ...
@overload
def _branch(config: Branch | str | None) -> Branch | None: ...
def _branch(config: Branch | str | None) -> Branch | None:
    if config is None or isinstance(config, Branch):
        return config
    if isinstance(config, str):
        return Branch.parse(config)
    raise IKError(f"config must be a Branch, a string like 'front up noflip' or None, got {config!r}",
                  kind=IKFailure.BAD_INPUT)


def _seed(seed_deg: object) -> tuple[float, ...]:
    """Seed joint angles in degrees (None = standby) -> six radians."""
    if seed_deg is None:
        return STANDBY_RAD
    try:
        return _joints_rad(seed_deg, "seed_deg")
    except ParolkitValueError as exc:
        raise IKError(str(exc), kind=IKFailure.BAD_INPUT) from None


# ---------------------------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------------------------


def ik(pose: object, seed_deg: object = None, tool: str | Tool | None = None,
       config: Branch | str | None = None) -> NDArray[np.float64]:
    """Joint angles (deg, inside the safe limits) reaching ``pose`` with the TCP of ``tool``.

    ``pose``: ``[x, y, z mm, A, B, C deg]`` or a 4x4 transform in metres.  ``seed_deg``: the
    configuration to stay close to (default: standby).  ``config``: a :class:`Branch` (or
    ``"front up noflip"``-style string) pinning some or all branch flags.

    Raises :class:`IKError` (out of reach, joint limits, malformed input).
    """
    tool_obj = _DEFAULT_TOOL if tool is None else get_tool(tool)
    if _cik is not None:
        if config is None:
            sh = el = fl = -1
        else:
            br = _branch(config)
            sh, el, fl = _SHOULDER_CODE[br.shoulder], _ELBOW_CODE[br.elbow], _FLIP_CODE[br.wrist_flip]
        if type(pose) is np.ndarray and pose.shape == (6,):
            pose = pose.tolist()
        if type(seed_deg) is np.ndarray and seed_deg.shape == (6,):
            seed_deg = seed_deg.tolist()
        out = np.empty(6)
        if _cik.ik(pose, seed_deg, tool_obj._native, sh, el, fl, out) == 1:
            return out
        # 0 (no solution: diagnose() says why) or -1 (input the kernel does not take)
    return _ik_reference(pose, seed_deg, tool_obj, config)


def _ik_reference(pose: object, seed_deg: object, tool_obj: Tool, config: Branch | str | None) -> NDArray[np.float64]:
    """:func:`ik` in pure Python (the reference of the compiled kernel; also its fallback,
    and the path that explains failures and malformed input)."""
    rf, pf = _target_flange(pose, tool_obj)
    seed = STANDBY_RAD if seed_deg is None else _seed(seed_deg)
    if config is None:
        br = None
        found = solve_all_rad(rf, pf, seed, None, None, None, True)
    else:
        br = _branch(config)
        found = solve_all_rad(rf, pf, seed, br.shoulder, br.elbow, br.wrist_flip, True)
    if not found:
        raise diagnose(rf, pf, seed, br)
    q = found[0][1]
    return np.array((q[0] * _RAD, q[1] * _RAD, q[2] * _RAD, q[3] * _RAD, q[4] * _RAD, q[5] * _RAD))


def ik_all(pose: object, tool: str | Tool | None = None, seed_deg: object = None) -> list[IKSolution]:
    """Every in-limit IK solution (up to 8) of ``pose``, nearest to ``seed_deg`` first.

    Where a joint has two in-range representations (J6 = 0 / 360) the one closer to the seed
    (default standby) is listed.  At a singularity the free angle comes from the seed, so the
    coinciding solutions are listed once.  Raises :class:`IKError` when there is none.
    """
    r, p = _target(pose)
    seed = _seed(seed_deg)
    rf, pf = _flange_target(r, p, get_tool(tool))
    found = solve_all_rad(rf, pf, seed)
    if not found:
        raise diagnose(rf, pf, seed, None)
    found.sort(key=lambda item: item[0])
    out: list[IKSolution] = []
    kept: list[tuple[float, ...]] = []
    for _dist, q, sh, el, fl in found:
        if any(max(abs(a - b) for a, b in zip(q, other)) < 1e-9 for other in kept):
            continue  # elbow fully stretched: up == down
        kept.append(q)
        out.append(IKSolution(np.array(q) * _RAD, Branch(sh, el, fl)))
    return out


# ---------------------------------------------------------------------------------------------
# diagnostics: why did it fail?
# ---------------------------------------------------------------------------------------------


def _violation(theta: float, j: int) -> tuple[float, float]:
    """(how far outside the range in rad, the representation nearest the range) for joint j."""
    lo, hi = LIM_LO[j], LIM_HI[j]
    t = theta - TWO_PI * _floor((theta - lo) / TWO_PI)  # in [lo, lo + 2pi)
    if t <= hi:
        return 0.0, t
    over = t - hi
    under = lo - (t - TWO_PI)
    return (over, t) if over <= under else (under, t - TWO_PI)


def _raw_branches(r: Sequence[float], p: Sequence[float], seed: Sequence[float]) -> list[_RawBranch]:
    """All 8 branches ignoring limits: list of (shoulder, elbow, flip, q or None, excess m)."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = r
    x, y, z = p
    rho = math.hypot(x, y)
    Y = D1 - z
    base = _atan2(y, x) if rho >= SHOULDER_SINGULAR_EPS else seed[0]
    out: list[_RawBranch] = []
    for sh, th1, rr in (("front", base, rho), ("back", base + _PI, -rho)):
        X = rr - A1
        dist = math.hypot(X, Y)
        if dist > REACH_MAX * (1 + _REACH_EPS) or dist < REACH_MIN * (1 - _REACH_EPS):
            excess = dist - REACH_MAX if dist > REACH_MAX else REACH_MIN - dist
            for el in _ELBOWS:
                for fl in (False, True):
                    out.append((sh, el, fl, None, excess))
            continue
        c = max(-1.0, min(1.0, (X * X + Y * Y - _K0) * _INV_2A2L))
        delta = math.acos(c)
        c1, sn1 = _cos(th1), _sin(th1)
        for el, th3 in (("up", PHI3 - delta), ("down", PHI3 + delta)):
            c3, sn3 = _cos(th3), _sin(th3)
            u = A2 + A3 * c3 + D4 * sn3
            v = D4 * c3 - A3 * sn3
            th2 = _atan2(Y, X) - _atan2(v, u)
            psi = th2 - th3
            cp, sp = _cos(psi), _sin(psi)
            n00 = c1 * r00 + sn1 * r10
            n01 = c1 * r01 + sn1 * r11
            n02 = c1 * r02 + sn1 * r12
            n10 = c1 * r10 - sn1 * r00
            n12 = c1 * r12 - sn1 * r02
            m02 = cp * n02 - sp * r22
            m22 = sp * n02 + cp * r22
            sb = math.hypot(m02, n12)
            if sb > WRIST_SINGULAR_EPS:
                al = _atan2(n12, m02)
                be = _atan2(sb, m22)
                ga = _atan2(sp * n01 + cp * r21, -(sp * n00 + cp * r20))
                wr = ((True, -al, -be, -ga), (False, _PI - al, be, _PI - ga))
            else:
                m00 = cp * n00 - sp * r20
                q4 = seed[3]
                if m22 > 0:
                    w = (0.0, -_atan2(n10, m00) - q4)
                else:
                    w = (_PI, _atan2(-n10, -m00) + q4)
                wr = ((False, q4, w[0], w[1]), (True, q4, w[0], w[1]))
            for fl, t4, t5, t6 in wr:
                out.append((sh, el, fl, (th1, th2, th3, t4, t5, t6), 0.0))
    return out


def _mm(value: float) -> str:
    return f"{value:.1f}" if abs(value) < 1e6 else f"{value:.3g}"


def _branch_words(sh: str, el: str, fl: bool) -> str:
    return f"{sh} {el} {'flip' if fl else 'noflip'}"


def diagnose(r: Sequence[float], p: Sequence[float], seed: Sequence[float], branch: Branch | None) -> IKError:
    """Build the :class:`IKError` explaining why no in-limit solution exists (flange target)."""
    raw = _raw_branches(r, p, seed)
    wanted = [b for b in raw if branch is None or branch.matches(Branch(b[0], b[1], b[2]))]
    reachable = [(sh, el, fl, q) for sh, el, fl, q, _ in wanted if q is not None]
    if not reachable:
        excess_mm = min(b[4] for b in wanted) * 1e3
        x, y, z = p
        rho = math.hypot(x, y)
        dist = min(math.hypot(rr - A1, D1 - z) for rr in (rho, -rho)) * 1e3
        if dist * 1e-3 > REACH_MAX:
            detail = (f"the wrist centre would be {_mm(dist)} mm from the shoulder (J2) axis, "
                      f"the arm reaches at most {REACH_MAX * 1e3:.1f} mm")
        else:
            detail = (f"the wrist centre would be {_mm(dist)} mm from the shoulder (J2) axis, "
                      f"closer than the minimum {REACH_MIN * 1e3:.1f} mm")
        return IKError(f"target out of reach by {_mm(excess_mm)} mm: {detail}",
                       kind=IKFailure.OUT_OF_REACH, value=excess_mm)
    best: tuple[tuple[float, int, float], str, str, bool] | None = None
    for sh, el, fl, q in reachable:
        worst = (0.0, -1, 0.0)
        for j in range(6):
            if j == 4:
                t = (q[4] + _PI) % TWO_PI - _PI
                over = max(0.0, t - LIM_HI[4], LIM_LO[4] - t)
                viol, rep = over, t
            else:
                viol, rep = _violation(q[j], j)
            if viol > worst[0]:
                worst = (viol, j, rep)
        if best is None or worst[0] < best[0][0]:
            best = (worst, sh, el, fl)
    assert best is not None  # reachable is not empty
    (viol, j, rep), sh, el, fl = best
    if j < 0:  # every joint in range: cannot happen unless limits are inconsistent
        return IKError("no solution within the joint limits", kind=IKFailure.JOINT_LIMIT)
    lo, hi = LIM_LO[j] * _RAD, LIM_HI[j] * _RAD
    val = rep * _RAD
    side = f"> {hi:.4g}" if val > hi else f"< {lo:.4g}"
    reason = (f"joint J{j + 1} would be {val:.1f} deg {side} (allowed {lo:.4g} .. {hi:.4g} deg)"
              f" in the closest branch ({_branch_words(sh, el, fl)})")
    if branch is not None:
        others = [(o_sh, o_el, o_fl, o_q) for o_sh, o_el, o_fl, o_q, _ in raw
                  if o_q is not None and not branch.matches(Branch(o_sh, o_el, o_fl))]
        ok = [b for b in others if all(_violation_any(b[3][k], k) == 0.0 for k in range(6))]
        if ok:
            reason += (f"; the pinned branch '{branch}' excludes the reachable branch "
                       f"'{_branch_words(ok[0][0], ok[0][1], ok[0][2])}'")
    return IKError(reason, kind=IKFailure.JOINT_LIMIT, joint=j, value=val)


def _violation_any(theta: float, j: int) -> float:
    if j == 4:
        t = (theta + _PI) % TWO_PI - _PI
        return max(0.0, t - LIM_HI[4] - LIMIT_TOL, LIM_LO[4] - LIMIT_TOL - t)
    viol, _ = _violation(theta, j)
    return 0.0 if viol <= LIMIT_TOL else viol


# ---------------------------------------------------------------------------------------------
# batch
# ---------------------------------------------------------------------------------------------


def ik_batch(poses: object, seed_deg: object = None, tool: str | Tool | None = None,
             config: Branch | str | None = None, *, continuous: bool | None = None,
             check_limits: bool = True) -> NDArray[np.float64]:
    """IK for N poses at once: ``(N, 6)`` mm/deg or ``(N, 4, 4)`` m -> ``(N, 6)`` deg.

    With one seed (``(6,)``, default standby) the poses are treated as a path
    (``continuous=True``): sample 0 is solved like :func:`ik`, every later sample stays on
    the same shoulder/elbow branch and moves each joint the short way from the previous sample
    (no branch hop, no 360 deg wrap; the wrist follows the nearer of its two solutions unless
    ``config`` pins ``wrist_flip``).  With ``continuous=False`` or one seed per pose
    (``(N, 6)``) every pose is solved independently, nearest to its seed.

    ``check_limits=False`` (continuous mode only): sample 0 is still solved within the joint
    ranges, but the path is then followed continuously even where a joint leaves its range
    (the angles are returned unclipped; the caller checks them).  The singular-area policy
    uses it: near J5 = 0 the continuous wrist may swing J4 out of its range where the same
    pose with the other wrist branch (J4 +- 180, -J5, J6 +- 180) is inside it.

    Raises :class:`IKError` with ``.sample`` = index of the first pose that fails.
    """
    from parolkit.kinematics import batch as _b

    tool_obj = get_tool(tool)
    br = _branch(config)
    try:
        rot, pos = _b.targets_from_poses(poses, tool_obj)
    except ParolkitValueError as exc:
        raise IKError(str(exc), kind=IKFailure.BAD_INPUT) from None
    n = rot[0].shape[0]
    if seed_deg is None:
        seeds = np.array(STANDBY_RAD)
    else:
        try:
            seeds = as_joint_array(seed_deg, "seed_deg") * _DEG
        except ParolkitValueError as exc:
            raise IKError(str(exc), kind=IKFailure.BAD_INPUT) from None
        if seeds.ndim == 2 and seeds.shape[0] != n:
            raise IKError(f"seed_deg has {seeds.shape[0]} rows for {n} poses (give one seed or one per pose)",
                          kind=IKFailure.BAD_INPUT)
    if continuous is None:
        continuous = seeds.ndim == 1
    elif continuous and seeds.ndim == 2:
        raise IKError("continuous=True takes one seed (6 values), not one per pose", kind=IKFailure.BAD_INPUT)
    if not check_limits and not continuous:
        raise IKError("check_limits=False applies to a continuous path only (one seed)", kind=IKFailure.BAD_INPUT)
    if n == 0:
        return np.zeros((0, 6))

    def sample(i: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
        return tuple(float(v[i]) for v in rot), tuple(float(v[i]) for v in pos)

    if continuous:
        r0, p0 = sample(0)
        seed0 = tuple(seeds.tolist())
        if br is None:
            found = solve_all_rad(r0, p0, seed0, best_only=True)
        else:
            found = solve_all_rad(r0, p0, seed0, br.shoulder, br.elbow, br.wrist_flip, best_only=True)
        if not found:
            raise diagnose(r0, p0, seed0, br).with_sample(0)
        _d, q0, sh, el, fl = found[0]
        pin_flip = br is not None and br.wrist_flip is not None
        q, _sel = _b.solve_continuous(rot, pos, q0, Branch(sh, el, fl), pin_flip, check_limits)
        return np.multiply(q, _RAD, order="C")
    q, ok, _b_idx = _b.solve_independent(rot, pos, seeds, br)
    if not ok.all():
        i = int(np.argmin(ok))
        r_i, p_i = sample(i)
        seed_i = tuple((seeds if seeds.ndim == 1 else seeds[i]).tolist())
        raise diagnose(r_i, p_i, seed_i, br).with_sample(i)
    return np.multiply(q, _RAD, order="C")
