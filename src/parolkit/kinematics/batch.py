"""Vectorised closed-form IK over N poses (numpy; all branches at once).

Two modes (:func:`parolkit.kinematics.ik_batch`):

* **continuous** (one seed, the default): the poses are a path.  Sample 0 is solved like
  :func:`ik` (nearest to the seed, optional branch pin); every later sample stays on the same
  shoulder and elbow branch, and each joint takes the representation (theta + k 360) nearest
  its previous value, so joints never wrap and never hop to another branch.  The wrist follows
  the nearer of its two solutions (passing through J5 = 0 is a continuous motion in which the
  J5 sign changes), unless ``config`` pins ``wrist_flip``.  On the wrist / shoulder
  singularities the free angle (J4 / J1) keeps its previous value.  The first sample that
  leaves the workspace or a joint range raises :class:`IKError` with ``.sample``.
* **independent** (``continuous=False`` or one seed per pose): each pose is solved like
  :func:`ik` with its own seed; all 8 branches are evaluated for all poses at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TypeVar, cast

import numpy as np

from parolkit.errors import ParolkitValueError
from parolkit.kinematics.model import (
    A1,
    A2,
    A3,
    D1,
    D4,
    L3,
    LIM_HI,
    LIM_HI_ARR,
    LIM_LO,
    LIM_LO_ARR,
    LIMIT_TOL,
    PHI3,
    TWO_PI,
    WEIGHTS,
)
from parolkit.kinematics.pose import _Vec3, as_matrix_array, as_pose_array, cos_sin
from parolkit.kinematics.tools import Tool
from parolkit.kinematics.types import Branch, IKError, IKFailure

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["solve_independent", "solve_continuous", "targets_from_poses"]


def _raise_malloc_thresholds() -> None:
    """Let the C allocator keep the memory of large numpy temporaries instead of unmapping it.

    A 10,000-pose batch creates a few hundred temporary arrays of 80 kB (several MB at a
    time).  With glibc's start-up settings those are carved from fresh heap pages that are
    given back to the OS after every call, so each call pays ~2,000 page faults (about half
    of its run time).  glibc raises its mmap / trim thresholds itself the first time a large
    ``mmap``-ed block is freed (mallopt(3), "dynamic mmap threshold"); allocating and freeing
    one 16 MiB array (never touched, so it costs no memory) triggers that once, at import.
    The effect is process-wide but benign: up to ~32 MiB of freed heap is kept for reuse.
    Other C libraries simply see one allocation and one free.
    """
    buf = np.empty(1 << 21)  # 16 MiB, above the initial 128 kB mmap threshold
    del buf


_raise_malloc_thresholds()

_PI = math.pi
_HALF_PI = math.pi / 2
_RAD = 180.0 / math.pi
_DEG = math.pi / 180.0
_K0 = A2 * A2 + L3 * L3
_INV_2A2L = 1.0 / (2.0 * A2 * L3)
_REACH_MAX = A2 + L3
_REACH_MIN = abs(A2 - L3)
_WRIST_EPS = 1e-9
_SHOULDER_EPS = 1e-9
_REACH_EPS = 1e-12
_COS_PHI3 = math.cos(PHI3)
_SIN_PHI3 = math.sin(PHI3)


# ---------------------------------------------------------------------------------------------
# targets
# ---------------------------------------------------------------------------------------------


_PerSample = TypeVar("_PerSample", "bool | NDArray[np.bool_]", "float | NDArray[np.float64]",
                      "float | NDArray[np.floating[Any]]")


def _take(v: _PerSample, idx: NDArray[np.intp]) -> _PerSample:
    """The samples ``idx`` of a per-sample array; a value shared by every sample (a plain
    bool or float) as it is."""
    return v[idx] if isinstance(v, np.ndarray) else v


def _as_float_array(poses: object) -> NDArray[np.generic]:
    if isinstance(poses, np.ndarray):
        return poses
    try:
        return np.asarray(poses, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ParolkitValueError("poses must be numbers: an (N, 6) array of [x, y, z mm, A, B, C deg] "
                                 "or (N, 4, 4) matrices in metres") from None


def targets_from_poses(
    poses: object, tool: Tool,
) -> tuple[list[NDArray[np.float64]], list[NDArray[np.float64]]]:
    """``(N, 6)`` mm/deg or ``(N, 4, 4)`` m TCP poses -> flange rotation (9 arrays) + wrist centre (3)."""
    arr = _as_float_array(poses)
    if arr.ndim == 3 or arr.shape == (4, 4):
        m = as_matrix_array(arr, "poses")
        if m.ndim == 2:
            m = m[None]
        rot = [m[:, i, j] for i in range(3) for j in range(3)]
        pos = [m[:, 0, 3], m[:, 1, 3], m[:, 2, 3]]
    else:
        a = as_pose_array(arr, "poses")
        if a.ndim == 1:
            a = a[None, :]
        # (3, N) C-ordered so every row (angle) is contiguous for the element-wise maths below
        cs, sn = cos_sin(np.multiply(a[:, 3:].T, _DEG, order="C"))
        ca, cb, cc = cs
        sa, sb, sc = sn
        scsb = sc * sb
        ccsb = cc * sb
        rot = [cb * ca, -cb * sa, sb,
               cc * sa + scsb * ca, cc * ca - scsb * sa, -sc * cb,
               sc * sa - ccsb * ca, sc * ca + ccsb * sa, cc * cb]
        xyz = np.multiply(a[:, :3].T, 1e-3, order="C")
        pos = [xyz[0], xyz[1], xyz[2]]
    if not tool._identity_rot:
        t = tool._rot
        rot = [rot[3 * i] * t[3 * j] + rot[3 * i + 1] * t[3 * j + 1] + rot[3 * i + 2] * t[3 * j + 2]
               for i in range(3) for j in range(3)]
    tx, ty, tz = tool._t
    if tx or ty or tz:
        pos = [pos[0] - (rot[0] * tx + rot[1] * ty + rot[2] * tz),
               pos[1] - (rot[3] * tx + rot[4] * ty + rot[5] * tz),
               pos[2] - (rot[6] * tx + rot[7] * ty + rot[8] * tz)]
    return rot, pos


# ---------------------------------------------------------------------------------------------
# raw branch solutions (no limits)
# ---------------------------------------------------------------------------------------------


class _Shoulder:
    """Per-shoulder quantities shared by both elbows (arrays over N), continuous mode.

    ``free_q1`` (array) replaces J1 where the wrist centre is on the J1 axis.
    """

    __slots__ = ("q1", "X", "Y", "c", "sdel", "delta", "atan_y", "n00", "n01", "n02", "n10", "n12",
                 "reach_ok", "excess")

    def __init__(self, rot: Sequence[NDArray[np.float64]], pos: Sequence[NDArray[np.float64]], back: bool,
                 free_q1: NDArray[np.float64] | None) -> None:
        x, y, z = pos
        rho = np.sqrt(x * x + y * y)
        base = np.arctan2(y, x)
        sing = rho < _SHOULDER_EPS
        with np.errstate(invalid="ignore", divide="ignore"):
            c1 = x / rho
            s1 = y / rho
        if back:
            base = base + _PI
            rr = -rho
            c1 = -c1
            s1 = -s1
        else:
            rr = rho
        if sing.any():
            assert free_q1 is not None  # solve_continuous passes it whenever a sample is on the axis
            base = np.where(sing, free_q1, base)
            c1 = np.where(sing, np.cos(base), c1)
            s1 = np.where(sing, np.sin(base), s1)
        self.q1 = base
        X = rr - A1
        Y = D1 - z
        c = (X * X + Y * Y - _K0) * _INV_2A2L
        self.reach_ok = np.abs(c) <= 1.0 + _REACH_EPS
        dist = np.sqrt(X * X + Y * Y)
        self.excess = np.maximum(dist - _REACH_MAX, _REACH_MIN - dist)
        c = np.clip(c, -1.0, 1.0)
        self.c = c
        self.sdel = np.sqrt(1.0 - c * c)
        self.delta = np.arccos(c)
        self.atan_y = np.arctan2(Y, X)
        self.X = X
        self.Y = Y
        r00, r01, r02, r10, r11, r12 = rot[:6]
        self.n00 = c1 * r00 + s1 * r10
        self.n01 = c1 * r01 + s1 * r11
        self.n02 = c1 * r02 + s1 * r12
        self.n10 = c1 * r10 - s1 * r00
        self.n12 = c1 * r12 - s1 * r02


def _arm(
    sh: _Shoulder, rot: Sequence[NDArray[np.float64]], down: bool, free_q4: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], _Vec3[NDArray[np.float64]],
           _Vec3[NDArray[np.float64]], NDArray[np.bool_]]:
    """Raw joint arrays for one (shoulder, elbow): q1, q2, q3 and both wrist solutions.

    Returns ``(q1, q2, q3, noflip (q4, q5, q6), flip (q4, q5, q6), singular mask)``.  On the
    wrist singularity both wrist entries hold J4 = ``free_q4`` and J6 = the rest.
    """
    c = sh.c
    sdel = sh.sdel
    if down:
        q3 = PHI3 + sh.delta
        c3 = _COS_PHI3 * c - _SIN_PHI3 * sdel
        s3 = _SIN_PHI3 * c + _COS_PHI3 * sdel
    else:
        q3 = PHI3 - sh.delta
        c3 = _COS_PHI3 * c + _SIN_PHI3 * sdel
        s3 = _SIN_PHI3 * c - _COS_PHI3 * sdel
    u = A2 + A3 * c3 + D4 * s3
    v = D4 * c3 - A3 * s3
    q2 = sh.atan_y - np.arctan2(v, u)
    inv = 1.0 / (u * u + v * v)
    c2 = (sh.X * u + sh.Y * v) * inv
    s2 = (sh.Y * u - sh.X * v) * inv
    cp = c2 * c3 + s2 * s3  # cos(q2 - q3)
    sp = s2 * c3 - c2 * s3
    r20, r21, r22 = rot[6], rot[7], rot[8]
    m02 = cp * sh.n02 - sp * r22
    m22 = sp * sh.n02 + cp * r22
    n12 = sh.n12
    sb = np.sqrt(m02 * m02 + n12 * n12)
    al = np.arctan2(n12, m02)
    be = np.arctan2(sb, m22)
    ga = np.arctan2(sp * sh.n01 + cp * r21, -(sp * sh.n00 + cp * r20))
    sing = sb <= _WRIST_EPS
    nf = (_PI - al, be, _PI - ga)
    fl = (-al, -be, -ga)
    if sing.any():
        m00 = cp * sh.n00 - sp * r20
        # Rz(-(q4 + q6)) when J5 = 0; J5 = 180 (m22 < 0) is out of range anyway
        total = np.where(m22 > 0, -np.arctan2(sh.n10, m00), np.arctan2(-sh.n10, -m00))
        q5s = np.where(m22 > 0, 0.0, _PI)
        q6s = np.where(m22 > 0, total - free_q4, total + free_q4)
        nf = (np.where(sing, free_q4, nf[0]), np.where(sing, q5s, nf[1]), np.where(sing, q6s, nf[2]))
        fl = (np.where(sing, free_q4, fl[0]), np.where(sing, q5s, fl[1]), np.where(sing, q6s, fl[2]))
    return sh.q1, q2, q3, nf, fl, sing


# ---------------------------------------------------------------------------------------------
# independent mode
# ---------------------------------------------------------------------------------------------

_BRANCHES = [(sh, el, fl) for sh in ("front", "back") for el in ("up", "down") for fl in (False, True)]
_NARROW = tuple(hi - lo < TWO_PI - 2 * LIMIT_TOL for lo, hi in zip(LIM_LO, LIM_HI))
_INV_2PI = 1.0 / TWO_PI


def _fit_narrow(theta: NDArray[np.float64], j: int) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """In-range representation of ``theta`` for a joint whose range is narrower than 360 deg.

    Returns (t, valid).  Values within LIMIT_TOL outside the range are snapped onto it.
    """
    lo = LIM_LO[j] - LIMIT_TOL
    # t = theta - 2pi floor((theta - lo) / 2pi), in [lo - tol, lo - tol + 2pi); in place
    t = theta - lo
    t *= _INV_2PI
    np.floor(t, out=t)
    t *= TWO_PI
    np.subtract(theta, t, out=t)
    valid = t <= LIM_HI[j] + LIMIT_TOL
    np.maximum(t, LIM_LO[j], out=t)  # = np.clip, without its Python-level dispatch
    np.minimum(t, LIM_HI[j], out=t)
    return t, valid


def _fit_wide(theta: NDArray[np.float64], j: int, seed: float | NDArray[np.float64]) -> NDArray[np.float64]:
    """In-range representation for a joint with a full-turn range (J6): nearest the seed.

    ``seed`` is a float or an array like ``theta``.
    """
    lo, hi = LIM_LO[j], LIM_HI[j]
    t = theta - TWO_PI * np.floor((theta - (lo - LIMIT_TOL)) * _INV_2PI)
    two = t <= hi + LIMIT_TOL - TWO_PI  # both t and t + 2pi fit (J6 = 0 / 360)
    if two.any():
        k = np.nonzero(two)[0]
        tk = t[k]
        sk = seed[k] if isinstance(seed, np.ndarray) else seed
        t[k] = np.where(np.abs(tk + TWO_PI - sk) < np.abs(tk - sk), tk + TWO_PI, tk)
    np.maximum(t, lo, out=t)
    np.minimum(t, hi, out=t)
    return t


_BIG = 1e300  # "no solution" distance (finite, so blends never produce NaN)


def solve_independent(
    rot: Sequence[NDArray[np.float64]], pos: Sequence[NDArray[np.float64]], seeds: NDArray[np.float64],
    branch: Branch | None,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]:
    """Nearest in-limit solution per sample (all 8 branches, vectorised).

    ``rot``: 9 arrays (flange rotation, row-major), ``pos``: 3 arrays (wrist centre, m),
    ``seeds``: (6,) or (N, 6) radians.  Returns (q (N, 6) rad, ok (N,), branch index (N,)
    into ``_BRANCHES``, -1 where no solution).

    A vectorised branch-and-bound: per sample the shoulder and elbow nearer the seed are tried
    first; each later arm works only on the samples where it is still in range (J1, reach, J3,
    J2) AND its partial joint distance (J1, J3, J2 terms) does not exceed the best complete
    solution found so far.  With a good seed nearly every sample is settled by its first arm,
    so the other branches cost little.  Equal distances go to the lower branch index, so the
    result does not depend on the order in which the arms were tried.
    """
    if not all(_NARROW[:5]) or _NARROW[5]:  # pragma: no cover - PAROL6 ranges
        raise NotImplementedError("vectorised IK assumes J1..J5 narrower than 360 deg and J6 a full turn")
    n = rot[0].shape[0]
    seeds = np.asarray(seeds, dtype=float)
    per_sample = seeds.ndim == 2
    if per_sample:
        seed_cols = list(np.ascontiguousarray(seeds.T))  # six contiguous rows
    else:
        seed_cols = [float(v) for v in seeds]
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    x, y, z = pos
    rho = np.sqrt(x * x + y * y)
    base = np.arctan2(y, x)
    with np.errstate(invalid="ignore", divide="ignore"):
        c1f = x / rho
        s1f = y / rho
    sing_sh = rho < _SHOULDER_EPS
    if sing_sh.any():
        free = np.clip(seed_cols[0], LIM_LO[0], LIM_HI[0]) + np.zeros(n)
        base = np.where(sing_sh, free, base)
        c1f = np.where(sing_sh, np.cos(free), c1f)
        s1f = np.where(sing_sh, np.sin(free), s1f)
    Yall = D1 - z
    best_d = np.full(n, _BIG)
    best_q = np.zeros((6, n))
    best_b = np.full(n, -1, dtype=np.int64)
    want_sh = None if branch is None else branch.shoulder
    want_el = None if branch is None else branch.elbow
    want_fl = None if branch is None else branch.wrist_flip
    w1, w2, w3, w4, w5, w6 = WEIGHTS
    # Per sample, the shoulder and elbow nearer the seed are tried first (as single IK does),
    # so the first pass usually finds the final answer and the later passes prune almost
    # every sample at their J1 / J3 terms.  The pass order only affects the work: ties are
    # resolved towards the lower branch index, whatever order the branches were tried in.
    # a pass is one bool for all samples, or a bool per sample
    shoulder_passes: tuple[bool | NDArray[np.bool_], ...]
    elbow_passes: tuple[bool | NDArray[np.bool_], ...]
    if want_sh is not None:
        shoulder_passes = (want_sh == "back",)
    else:
        dd = base - seed_cols[0]
        dd -= TWO_PI * np.floor(dd * _INV_2PI + 0.5)
        pref_back = np.abs(dd) > _HALF_PI
        shoulder_passes = (pref_back, ~pref_back)
    if want_el is not None:
        elbow_passes = (want_el == "down",)
    else:
        dd = seed_cols[2] - PHI3
        dd = dd - TWO_PI * np.floor(dd * _INV_2PI + 0.5)
        pref_down = dd > 0.0
        elbow_passes = (pref_down, ~pref_down if per_sample else not pref_down)
    for back_all in shoulder_passes:
        # back_all: a bool or a bool array over all N samples
        q1, ok = _fit_narrow(base + _PI * back_all, 0)
        e = q1 - seed_cols[0]
        d1 = w1 * e * e
        ok &= d1 <= best_d
        sg_all = 1.0 - 2.0 * back_all  # +1 front, -1 back (exact sign flips below)
        X = rho * sg_all - A1
        c = (X * X + Yall * Yall - _K0) * _INV_2A2L
        ok &= np.abs(c) <= 1.0 + _REACH_EPS
        idx = np.nonzero(ok)[0]
        if idx.size == 0:
            continue
        # --- restrict everything to the samples this shoulder can still improve
        back_i = _take(back_all, idx)
        sg_i = _take(sg_all, idx)
        q1 = q1[idx]
        d1 = d1[idx]
        X = X[idx]
        Y = Yall[idx]
        c = np.maximum(c[idx], -1.0)
        np.minimum(c, 1.0, out=c)
        sd = [col[idx] for col in seed_cols] if per_sample else seed_cols
        delta = np.arccos(c)
        sdel = np.sqrt(1.0 - c * c)
        atan_y = np.arctan2(Y, X)
        for down_all in elbow_passes:
            down = _take(down_all, idx)
            # elbow sign on delta: -1 up, +1 down (float64; numpy's stubs widen bool * float to floating)
            es = cast("float | NDArray[np.float64]", 2.0 * down - 1.0)
            q3, ok3 = _fit_narrow(PHI3 + es * delta, 2)
            e = q3 - sd[2]
            d13 = d1 + w3 * e * e
            bound = best_d[idx]
            ok3 &= d13 <= bound
            # stage 1: keep only the samples where this elbow fits J3 and can still win
            s1i = np.nonzero(ok3)[0]
            if s1i.size == 0:
                continue
            back, sg = back_i, sg_i
            if s1i.size != ok3.size:
                q3, d13, bound = q3[s1i], d13[s1i], bound[s1i]
                cc, sdl, Xs, Ys, aty = c[s1i], sdel[s1i], X[s1i], Y[s1i], atan_y[s1i]
                where = idx[s1i]
                sds = [col[s1i] for col in sd] if per_sample else sd
                q1s = q1[s1i]
                back, sg, down, es = _take(back, s1i), _take(sg, s1i), _take(down, s1i), _take(es, s1i)
            else:
                cc, sdl, Xs, Ys, aty = c, sdel, X, Y, atan_y
                where = idx
                sds = sd
                q1s = q1
            c3 = _COS_PHI3 * cc - es * (_SIN_PHI3 * sdl)
            s3 = _SIN_PHI3 * cc + es * (_COS_PHI3 * sdl)
            u = A2 + A3 * c3 + D4 * s3
            v = D4 * c3 - A3 * s3
            q2, ok2 = _fit_narrow(aty - np.arctan2(v, u), 1)
            e = q2 - sds[1]
            d123 = d13 + w2 * e * e
            ok2 &= d123 <= bound
            # stage 2: ... and fits J2
            sub = np.nonzero(ok2)[0]
            if sub.size == 0:
                continue
            if sub.size != ok2.size:
                q2, q3, c3, s3, u, v, d123 = q2[sub], q3[sub], c3[sub], s3[sub], u[sub], v[sub], d123[sub]
                Xs, Ys = Xs[sub], Ys[sub]
                sds = [col[sub] for col in sds] if per_sample else sds
                q1s = q1s[sub]
                where = where[sub]
                back, sg, down = _take(back, sub), _take(sg, sub), _take(down, sub)
            # the orientation part only for the samples that survived: N = Rz(-q1) R
            cw = c1f[where] * sg
            sw = s1f[where] * sg
            a00, a10, a02, a12 = r00[where], r10[where], r02[where], r12[where]
            b20, b21, b22 = r20[where], r21[where], r22[where]
            m_n00 = cw * a00 + sw * a10
            m_n01 = cw * r01[where] + sw * r11[where]
            m_n02 = cw * a02 + sw * a12
            m_n10 = cw * a10 - sw * a00
            m_n12 = cw * a12 - sw * a02
            inv = 1.0 / (u * u + v * v)
            c2 = (Xs * u + Ys * v) * inv
            s2 = (Ys * u - Xs * v) * inv
            cp = c2 * c3 + s2 * s3  # cos(q2 - q3)
            sp = s2 * c3 - c2 * s3
            m02 = cp * m_n02 - sp * b22
            m22 = sp * m_n02 + cp * b22
            sb = np.sqrt(m02 * m02 + m_n12 * m_n12)
            al = np.arctan2(m_n12, m02)
            be = np.arctan2(sb, m22)
            ga = np.arctan2(sp * m_n01 + cp * b21, -(sp * m_n00 + cp * b20))
            sing = sb <= _WRIST_EPS
            if sing.any():
                # J4 from the seed, J6 the rest (noflip: q4 = pi - al, q6 = pi - ga)
                free4 = np.clip(sds[3], LIM_LO[3], LIM_HI[3])
                m00 = cp * m_n00 - sp * b20
                total = -np.arctan2(m_n10, m00)
                al = np.where(sing, _PI - free4, al)
                ga = np.where(sing, _PI - total + free4, ga)
                be = np.where(sing, np.where(m22 > 0, 0.0, _PI), be)
            ok5 = be <= LIM_HI[4] + LIMIT_TOL
            np.minimum(be, LIM_HI[4], out=be)
            opts = []
            for flip in (False, True):
                if want_fl is not None and want_fl != flip:
                    continue
                if flip:
                    q4, ok4 = _fit_narrow(-al, 3)
                    q6 = _fit_wide(-ga, 5, sds[5])
                    e5 = be + sds[4]
                else:
                    q4, ok4 = _fit_narrow(_PI - al, 3)
                    q6 = _fit_wide(_PI - ga, 5, sds[5])
                    e5 = be - sds[4]
                ok4 &= ok5
                e4 = q4 - sds[3]
                e6 = q6 - sds[5]
                d = d123 + w4 * e4 * e4 + w5 * e5 * e5 + w6 * e6 * e6
                d[~ok4] = _BIG
                opts.append((flip, q4, q6, d))
            if len(opts) == 2:
                (_, q4a, q6a, da), (_, q4b, q6b, db) = opts
                use_b = db < da
                fb = use_b.astype(float)
                q4 = q4a + fb * (q4b - q4a)
                q6 = q6a + fb * (q6b - q6a)
                q5 = be - 2.0 * fb * be
                d = np.minimum(da, db)
                flips = use_b.astype(np.int64)
            else:
                flip, q4, q6, d = opts[0]
                q5 = -be if flip else be
                flips = 1 if flip else 0
            b_idx = 4 * back + 2 * down + flips  # index into _BRANCHES (int or int array)
            prev = best_d[where]
            better = d < prev
            tie = d == prev
            if tie.any():  # equal distance: the lower branch index wins (index-order semantics)
                better |= tie & (b_idx < best_b[where])
            if better.all():
                tgt = where
                sel = slice(None)
            else:
                if not better.any():
                    continue
                tgt = where[better]
                sel = better
            best_d[tgt] = d[sel]
            best_b[tgt] = b_idx if np.ndim(b_idx) == 0 else b_idx[sel]
            best_q[0, tgt] = q1s[sel]
            best_q[1, tgt] = q2[sel]
            best_q[2, tgt] = q3[sel]
            best_q[3, tgt] = q4[sel]
            best_q[4, tgt] = q5[sel]
            best_q[5, tgt] = q6[sel]
    ok = best_b >= 0
    return best_q.T, ok, best_b



# ---------------------------------------------------------------------------------------------
# continuous mode
# ---------------------------------------------------------------------------------------------


def _ffill(values: NDArray[np.float64], holes: NDArray[np.bool_], first: float) -> NDArray[np.float64]:
    """Replace ``values[holes]`` by the last non-hole value before them (``first`` at the start)."""
    n = values.shape[0]
    idx = np.where(holes, -1, np.arange(n))
    np.maximum.accumulate(idx, out=idx)
    src = np.concatenate(([first], values))
    return np.where(holes, src[idx + 1], values)


def _wrap(d: NDArray[np.float64]) -> NDArray[np.float64]:
    return d - TWO_PI * np.floor(d * _INV_2PI + 0.5)


def solve_continuous(
    rot: Sequence[NDArray[np.float64]], pos: Sequence[NDArray[np.float64]], q0: tuple[float, ...],
    branch0: Branch, pin_flip: bool, check_limits: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.bool_] | None]:
    """Branch-continuous solutions (N, 6) rad given sample 0's solution ``q0`` and its branch.

    Raises :class:`IKError` with ``.sample`` at the first sample that cannot be followed (out
    of reach; with ``check_limits``, also a joint out of its range; without it the path is
    followed continuously whatever the ranges, unclipped, and the caller checks them).
    """
    n = rot[0].shape[0]
    back = branch0.shoulder == "back"
    down = branch0.elbow == "down"
    x, y, _ = pos
    shoulder_sing = np.sqrt(x * x + y * y) < _SHOULDER_EPS
    free_q1 = None
    if shoulder_sing.any():
        # J1 free on the J1 axis: keep the previous sample's J1
        raw = np.arctan2(y, x) + (_PI if back else 0.0)
        free_q1 = _ffill(raw, shoulder_sing, q0[0])
    sh = _Shoulder(rot, pos, back, free_q1)
    if not sh.reach_ok.all():
        i = int(np.argmin(sh.reach_ok))
        raise IKError(
            f"target out of reach by {sh.excess[i] * 1e3:.4g} mm (following the path in branch "
            f"'{branch0.shoulder} {branch0.elbow}')", kind=IKFailure.OUT_OF_REACH, sample=i,
            value=float(sh.excess[i] * 1e3))
    free_q4 = np.full(n, q0[3])
    _, q2r, q3r, nf, fl, sing = _arm(sh, rot, down, free_q4)
    q1r = sh.q1
    # --- wrist: choose noflip / flip per sample
    if pin_flip:
        wr = fl if branch0.wrist_flip else nf
        q4r, q5r, q6r = wr
        sel = None
    else:
        ns = ~sing
        sel = np.zeros(n, dtype=bool)  # True = flip solution
        idx = np.nonzero(ns)[0]
        if idx.size:
            a4, a5, a6 = nf[0][idx], nf[1][idx], nf[2][idx]
            b4, b5, b6 = fl[0][idx], fl[1][idx], fl[2][idx]
            # first non-singular sample: the solution nearer the previous (sample 0's) wrist
            i0 = idx[0]
            da = (WEIGHTS[3] * _wrap(a4[0] - q0[3]) ** 2 + WEIGHTS[4] * (a5[0] - q0[4]) ** 2
                  + WEIGHTS[5] * _wrap(a6[0] - q0[5]) ** 2)
            db = (WEIGHTS[3] * _wrap(b4[0] - q0[3]) ** 2 + WEIGHTS[4] * (b5[0] - q0[4]) ** 2
                  + WEIGHTS[5] * _wrap(b6[0] - q0[5]) ** 2)
            first_flip = bool(db < da) if i0 > 0 else bool(branch0.wrist_flip)
            if idx.size > 1:
                d_same = (WEIGHTS[3] * _wrap(a4[1:] - a4[:-1]) ** 2 + WEIGHTS[4] * (a5[1:] - a5[:-1]) ** 2
                          + WEIGHTS[5] * _wrap(a6[1:] - a6[:-1]) ** 2)
                d_swap = (WEIGHTS[3] * _wrap(a4[1:] - b4[:-1]) ** 2 + WEIGHTS[4] * (a5[1:] - b5[:-1]) ** 2
                          + WEIGHTS[5] * _wrap(a6[1:] - b6[:-1]) ** 2)
                parity = np.concatenate(([0], np.cumsum(d_swap < d_same) & 1)).astype(bool)
            else:
                parity = np.zeros(1, dtype=bool)
            sel[idx] = parity ^ first_flip
        q4r = np.where(sel, fl[0], nf[0])
        q5r = np.where(sel, fl[1], nf[1])
        q6r = np.where(sel, fl[2], nf[2])
    if sing.any():
        # wrist singular: keep the previous J4 (forward fill of the raw values), J6 takes the rest
        q4_fill = _ffill(q4r, sing, q0[3])
        shift = q4_fill - free_q4
        q6r = np.where(sing, np.where(q5r > 1.0, q6r + shift, q6r - shift), q6r)
        q4r = q4_fill
    # every joint the short way from the previous sample (J5 never wraps: |J5| <= 180 deg)
    raw = np.array([q1r, q2r, q3r, q4r, q5r, q6r])  # (6, n), one contiguous row per joint
    k = np.empty_like(raw)
    k[:, 0] = np.floor((np.asarray(q0) - raw[:, 0]) * _INV_2PI + 0.5)
    if n > 1:
        # (floor(x + 0.5) rather than rint: several times faster in numpy, same result here)
        np.floor(np.diff(raw, axis=1) * -_INV_2PI + 0.5, out=k[:, 1:])
        np.cumsum(k, axis=1, out=k)
    q = raw + TWO_PI * k
    if not check_limits:
        return q.T, sel
    lo_c = LIM_LO_ARR[:, None]
    hi_c = LIM_HI_ARR[:, None]
    above = q > hi_c + LIMIT_TOL
    bad = (q < lo_c - LIMIT_TOL) | above
    if bad.any():
        i = int(np.argmax(bad.any(axis=0)))
        j = int(np.argmax(bad[:, i]))
        val = q[j, i] * _RAD
        lo, hi = LIM_LO[j] * _RAD, LIM_HI[j] * _RAD
        side = f"> {hi:.4g}" if above[j, i] else f"< {lo:.4g}"
        raise IKError(
            f"joint J{j + 1} would be {val:.1f} deg {side} (allowed {lo:.4g} .. {hi:.4g} deg) "
            f"following the path continuously from sample {i - 1 if i else 0} in branch "
            f"'{branch0.shoulder} {branch0.elbow}'", kind=IKFailure.JOINT_LIMIT, sample=i, joint=j,
            value=float(val))
    np.clip(q, lo_c, hi_c, out=q)
    return q.T, sel

