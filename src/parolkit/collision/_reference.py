"""The collision kernel's pure-Python reference (numpy), and the packed scene both kernels read.

``_ccollide.c`` is a copy of this file's algorithms in C (same steps, same stopping rules); this
file is what runs when the extension is not built or ``PAROLKIT_PURE_PYTHON=1`` (see
:mod:`parolkit._native`), and what tests/unit/test_collision_native.py compares the kernel with.
Everything here is in metres and radians.

The packed scene (one float64 array, built by :func:`parolkit.collision.scene.Scene`)::

    [0] MAGIC  [1] M bodies  [2] S statics  [3] P pairs  [4] tau (m)  [5] max evaluations
    [6 .. 30)  DH rows 1..6: d, a, cos(alpha), sin(alpha) (row 6 with d = a = 0: the flange)
    bodies,  M x 8:  frame (0..6), start xyz, end xyz (in that frame), radius
    statics, S x 16: type (0 plane, 1 box, 2 cylinder), centre xyz, R (3x3 row-major: its
                     columns are the shape's axes in the base frame), e0 e1 e2
                     (plane: unit normal, pointing out of the forbidden side; box: half edge
                     lengths; cylinder: radius, half height, 0)
    pairs,   P x 12: kind (0 capsule-capsule, 1 capsule-static), i (body), j (body or static),
                     category (0 self, 1 arm vs zone, 2 tool/held vs zone), margin (m),
                     c1..c6 (m/rad: how far a joint step of 1 rad can move the pair's shapes
                     toward each other at most), unused

Distances are *clearances*: the exact Euclidean distance between the two shapes when they are
apart (> 0); <= 0 when they touch or overlap (then the value measures the overlap, exactly for
capsule-capsule and capsule-plane pairs, as minus the capsule's radius when a capsule's axis
enters a box or cylinder).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    F64 = NDArray[np.float64]

__all__ = [
    "MAGIC", "HEADER", "BODY_W", "STATIC_W", "PAIR_W", "PLANE", "BOX", "CYLINDER", "SELF", "ARM_ZONE",
    "ATTACHED_ZONE", "CAP_CAP", "CAP_STATIC", "BISECT_TOL", "BISECT_MAX",
    "Unpacked", "unpack", "frames", "body_segments", "pair_distances", "check", "path",
]

MAGIC = 7301.0
HEADER = 30
BODY_W = 8
STATIC_W = 16
PAIR_W = 12
PLANE, BOX, CYLINDER = 0, 1, 2
SELF, ARM_ZONE, ATTACHED_ZONE = 0, 1, 2
CAP_CAP, CAP_STATIC = 0, 1
#: The box and cylinder distances stop when the minimum along the capsule's axis is known to
#: this (m): the tangents at both ends of the bracket bound it from below, the better end from
#: above (1e-10 m = 1e-7 mm).
BISECT_TOL = 1e-10
#: ... or after this many halvings of the bracket (2^-60 of the axis: below rounding).
BISECT_MAX = 60
#: Segments shorter than this (m) are points.
_EPS_LEN2 = 1e-24


class Unpacked:
    """The packed scene as arrays (see the module docstring)."""

    def __init__(self, buf: F64) -> None:
        if buf.ndim != 1 or buf.shape[0] < HEADER or buf[0] != MAGIC:
            raise ValueError("not a packed collision scene")
        m, s, p = int(buf[1]), int(buf[2]), int(buf[3])
        if buf.shape[0] != HEADER + m * BODY_W + s * STATIC_W + p * PAIR_W:
            raise ValueError("packed collision scene of the wrong length")
        self.tau = float(buf[4])
        self.max_evals = int(buf[5])
        self.dh = buf[6:HEADER].reshape(6, 4)
        o = HEADER
        self.bodies = buf[o:o + m * BODY_W].reshape(m, BODY_W)
        o += m * BODY_W
        self.statics = buf[o:o + s * STATIC_W].reshape(s, STATIC_W)
        o += s * STATIC_W
        self.pairs = buf[o:o + p * PAIR_W].reshape(p, PAIR_W)
        self.body_frame = self.bodies[:, 0].astype(np.intp)
        self.kind = self.pairs[:, 0].astype(np.intp)
        self.pi = self.pairs[:, 1].astype(np.intp)
        self.pj = self.pairs[:, 2].astype(np.intp)
        self.category = self.pairs[:, 3].astype(np.intp)
        self.margin = self.pairs[:, 4].copy()
        self.lipschitz = self.pairs[:, 5:11].copy()


def unpack(buf: F64) -> Unpacked:
    return Unpacked(buf)


def frames(dh: F64, qs: F64) -> tuple[F64, F64]:
    """Frames 0..6 (base, DH frames 1..5, flange) for joint radians ``qs`` (N, 6):
    rotations (N, 7, 3, 3) and origins (N, 7, 3), by multiplying the DH rows one by one
    (``T_k = T_(k-1) Rz(q_k) Tz(d_k) Tx(a_k) Rx(alpha_k)``)."""
    n = qs.shape[0]
    rot = np.empty((n, 7, 3, 3))
    pos = np.empty((n, 7, 3))
    rot[:, 0] = np.eye(3)
    pos[:, 0] = 0.0
    for k in range(6):
        d, a, ca, sa = (float(v) for v in dh[k])
        ct = np.cos(qs[:, k])
        st = np.sin(qs[:, k])
        r = rot[:, k]
        # columns of M = [[ct, -st ca, st sa], [st, ct ca, -ct sa], [0, sa, ca]]
        c0 = r[:, :, 0] * ct[:, None] + r[:, :, 1] * st[:, None]
        c1 = (r[:, :, 0] * (-st * ca)[:, None] + r[:, :, 1] * (ct * ca)[:, None]) + r[:, :, 2] * sa
        c2 = (r[:, :, 0] * (st * sa)[:, None] + r[:, :, 1] * (-ct * sa)[:, None]) + r[:, :, 2] * ca
        rot[:, k + 1, :, 0] = c0
        rot[:, k + 1, :, 1] = c1
        rot[:, k + 1, :, 2] = c2
        # p_k = p_(k-1) + R_(k-1) (a ct, a st, d)
        pos[:, k + 1] = pos[:, k] + (r[:, :, 0] * (a * ct)[:, None] + r[:, :, 1] * (a * st)[:, None]) \
            + r[:, :, 2] * d
    return rot, pos


def body_segments(u: Unpacked, qs: F64) -> tuple[F64, F64]:
    """World end points (N, M, 3) x 2 of every body's axis segment."""
    rot, pos = frames(u.dh, qs)
    f = u.body_frame
    r = rot[:, f]  # (N, M, 3, 3)
    p = pos[:, f]
    a = np.einsum("nmij,mj->nmi", r, u.bodies[:, 1:4]) + p
    b = np.einsum("nmij,mj->nmi", r, u.bodies[:, 4:7]) + p
    return a, b


def _dot(x: F64, y: F64) -> F64:
    out: F64 = np.einsum("...i,...i->...", x, y)
    return out


def _segseg(a0: F64, a1: F64, b0: F64, b1: F64) -> tuple[F64, F64]:
    """Closest points of segments [a0, a1] and [b0, b1] (arrays of (..., 3)): the points."""
    d1 = a1 - a0
    d2 = b1 - b0
    r = a0 - b0
    a = _dot(d1, d1)
    e = _dot(d2, d2)
    f = _dot(d2, r)
    c = _dot(d1, r)
    b = _dot(d1, d2)
    with np.errstate(divide="ignore", invalid="ignore"):
        a_pt = a <= _EPS_LEN2
        e_pt = e <= _EPS_LEN2
        den = a * e - b * b
        s = np.where(den > 1e-12 * a * e, np.clip((b * f - c * e) / den, 0.0, 1.0), 0.0)
        t = (b * s + f) / e
        s = np.where(t < 0.0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / a, 0.0, 1.0), s))
        t = np.clip(t, 0.0, 1.0)
        # one of them a point
        s = np.where(a_pt, 0.0, np.where(e_pt, np.clip(-c / a, 0.0, 1.0), s))
        t = np.where(e_pt, 0.0, np.where(a_pt, np.clip(f / e, 0.0, 1.0), t))
    s = np.nan_to_num(s)
    t = np.nan_to_num(t)
    return a0 + s[..., None] * d1, b0 + t[..., None] * d2


def _project(kind: int, x: F64, e: F64) -> F64:
    """Closest points of the solid box / cylinder (local frame, half sizes ``e``) to ``x``."""
    if kind == BOX:
        return np.clip(x, -e, e)
    rho = np.hypot(x[..., 0], x[..., 1])
    rad = e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(rho > rad, rad / rho, 1.0)
    out = np.empty_like(x)
    out[..., 0] = x[..., 0] * k
    out[..., 1] = x[..., 1] * k
    out[..., 2] = np.clip(x[..., 2], -e[..., 1], e[..., 1])
    return out


def _fg(kind: int, p0: F64, dv: F64, e: F64, t: F64) -> tuple[F64, F64, F64]:
    """Distance f(t) from p0 + t dv to the shape, its derivative in t, and the closest point."""
    x = p0 + t[..., None] * dv
    y = _project(kind, x, e)
    v = x - y
    f = np.sqrt(_dot(v, v))
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where(f > 0.0, _dot(v, dv) / f, 0.0)
    return f, g, y


def _seg_convex(kind: int, p0: F64, p1: F64, e: F64) -> tuple[F64, F64, F64]:
    """Distance from segments [p0, p1] (local frame) to a solid box or cylinder: value, the
    parameter t of the closest point on the segment, and the closest point of the shape.

    f(t), the distance from the point at t to a convex shape, is convex: bisect on the sign of
    its derivative, and stop when the tangents at the bracket's ends prove the minimum within
    :data:`BISECT_TOL` of the better end (or f or f' is 0 at a midpoint)."""
    dv = p1 - p0
    n = p0.shape[0]
    zeros, ones = np.zeros(n), np.ones(n)
    f0, g0, y0 = _fg(kind, p0, dv, e, zeros)
    f1, g1, y1 = _fg(kind, p0, dv, e, ones)
    t_best = np.where(g0 >= 0.0, 0.0, 1.0)
    f_best = np.where(g0 >= 0.0, f0, f1)
    y_best = np.where((g0 >= 0.0)[:, None], y0, y1)
    active = (g0 < 0.0) & (g1 > 0.0)
    lo, hi = zeros.copy(), ones.copy()
    flo, glo, fhi, ghi = f0.copy(), g0.copy(), f1.copy(), g1.copy()
    ylo, yhi = y0.copy(), y1.copy()
    for _ in range(BISECT_MAX):
        if not active.any():
            break
        # the tangents at lo and hi meet at tx; the minimum is at least their value there
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = (fhi - flo + glo * lo - ghi * hi) / (glo - ghi)
        lower = np.maximum(flo + glo * (tx - lo), 0.0)
        upper = np.minimum(flo, fhi)
        done = active & (upper - lower <= BISECT_TOL)
        active &= ~done
        if not active.any():
            break
        mid = 0.5 * (lo + hi)
        fm, gm, ym = _fg(kind, p0, dv, e, mid)
        hit = active & ((fm == 0.0) | (gm == 0.0))
        # a midpoint on the minimum: that is the answer
        lo = np.where(hit, mid, lo)
        flo = np.where(hit, fm, flo)
        ylo = np.where(hit[:, None], ym, ylo)
        hi = np.where(hit, mid, hi)
        fhi = np.where(hit, fm, fhi)
        yhi = np.where(hit[:, None], ym, yhi)
        active &= ~hit
        up = active & (gm > 0.0)
        dn = active & (gm < 0.0)
        hi = np.where(up, mid, hi)
        fhi = np.where(up, fm, fhi)
        ghi = np.where(up, gm, ghi)
        yhi = np.where(up[:, None], ym, yhi)
        lo = np.where(dn, mid, lo)
        flo = np.where(dn, fm, flo)
        glo = np.where(dn, gm, glo)
        ylo = np.where(dn[:, None], ym, ylo)
    bracketed = (g0 < 0.0) & (g1 > 0.0)
    use_lo = flo <= fhi
    t_br = np.where(use_lo, lo, hi)
    f_br = np.where(use_lo, flo, fhi)
    y_br = np.where(use_lo[:, None], ylo, yhi)
    t_best = np.where(bracketed, t_br, t_best)
    f_best = np.where(bracketed, f_br, f_best)
    y_best = np.where(bracketed[:, None], y_br, y_best)
    return f_best, t_best, y_best


def pair_distances(u: Unpacked, qs: F64, pairs: NDArray[np.intp] | None = None,
                   ) -> tuple[F64, F64, F64]:
    """Clearance (m) of every pair (or of ``pairs``) at every configuration ``qs`` (N, 6), and
    the closest points (world, m) on each side: (N, P), (N, P, 3), (N, P, 3).  For a capsule the
    point given is on its axis segment (the surface is ``radius`` from it)."""
    qs = np.atleast_2d(np.asarray(qs, dtype=np.float64))
    idx = np.arange(u.pairs.shape[0]) if pairs is None else np.asarray(pairs, dtype=np.intp)
    n, p = qs.shape[0], idx.shape[0]
    a_w, b_w = body_segments(u, qs)
    dist = np.empty((n, p))
    pa = np.empty((n, p, 3))
    pb = np.empty((n, p, 3))
    kind = u.kind[idx]
    pi = u.pi[idx]
    pj = u.pj[idx]
    ri = u.bodies[pi, 7]
    # capsule - capsule
    sel = np.nonzero(kind == CAP_CAP)[0]
    if sel.size:
        i, j = pi[sel], pj[sel]
        x, y = _segseg(a_w[:, i], b_w[:, i], a_w[:, j], b_w[:, j])
        dist[:, sel] = np.sqrt(_dot(x - y, x - y)) - ri[sel] - u.bodies[j, 7]
        pa[:, sel] = x
        pb[:, sel] = y
    # capsule - static
    st = u.statics
    styp = np.full(p, -1, dtype=np.intp)
    on_static = kind == CAP_STATIC
    styp[on_static] = st[pj[on_static], 0].astype(np.intp)
    for typ in (PLANE, BOX, CYLINDER):
        sel = np.nonzero(styp == typ)[0]
        if not sel.size:
            continue
        i, j = pi[sel], pj[sel]
        c = st[j, 1:4]                      # (K, 3)
        rm = st[j, 4:13].reshape(-1, 3, 3)  # (K, 3, 3), columns = axes
        e = st[j, 13:16]                    # (K, 3)
        a0, a1 = a_w[:, i], b_w[:, i]       # (N, K, 3)
        if typ == PLANE:
            sa = _dot(a0 - c, e)
            sb = _dot(a1 - c, e)
            first = sa <= sb
            s = np.where(first, sa, sb)
            x = np.where(first[..., None], a0, a1)
            dist[:, sel] = s - ri[sel]
            pa[:, sel] = x
            pb[:, sel] = x - s[..., None] * e
            continue
        # to the shape's frame: x_local = R^T (x - c)
        l0 = np.einsum("kji,nkj->nki", rm, a0 - c)
        l1 = np.einsum("kji,nkj->nki", rm, a1 - c)
        ee = np.broadcast_to(e, l0.shape)
        f, t, yl = _seg_convex(typ, l0.reshape(-1, 3), l1.reshape(-1, 3), ee.reshape(-1, 3))
        f = f.reshape(n, -1)
        t = t.reshape(n, -1)
        yl = yl.reshape(n, -1, 3)
        dist[:, sel] = f - ri[sel]
        pa[:, sel] = a0 + t[..., None] * (a1 - a0)
        pb[:, sel] = np.einsum("kij,nkj->nki", rm, yl) + c
    return dist, pa, pb


def check(u: Unpacked, q: F64) -> tuple[float, int, float, int, float, int, float, int]:
    """One configuration: per category (self, arm vs zone, tool/held vs zone) the smallest
    clearance and its pair (inf, -1 when the category has no pair), then the smallest
    clearance minus margin and its pair.  Ties: the lowest pair index."""
    d = pair_distances(u, np.asarray(q, dtype=np.float64)[None, :])[0][0]
    out: list[float | int] = []
    for cat in (SELF, ARM_ZONE, ATTACHED_ZONE):
        sel = np.nonzero(u.category == cat)[0]
        if sel.size:
            k = int(sel[int(np.argmin(d[sel]))])
            out += [float(d[k]), k]
        else:
            out += [math.inf, -1]
    if d.size:
        g = d - u.margin
        k = int(np.argmin(g))
        out += [float(g[k]), k]
    else:
        out += [math.inf, -1]
    return tuple(out)  # type: ignore[return-value]


def path(u: Unpacked, qs: F64, swept: bool) -> tuple[int, int, float, int, float, int]:
    """The first violation along the samples ``qs`` (N, 6): (status, index, s, pair,
    clearance - margin (m), evaluations).

    status 0: clear; 1: sample ``index`` violates; 2: a pose between samples ``index`` and
    ``index + 1``, at fraction ``s``, is within its margin + tau (swept only); 3: the
    evaluation budget ran out before the path was proven clear (treat as a violation).

    Not swept: every sample is checked completely.  Swept: the path is the straight joint-space
    segments between the samples; each pair keeps the clearance proven for it, less what the
    joints' moves can take off (the pair's Lipschitz bound times the joint steps), and is
    evaluated again only where that runs out (conservative advancement).  A pose is only ever
    passed over when the bound proves its pairs clear.
    """
    n = qs.shape[0]
    npairs = u.pairs.shape[0]
    evals = 0
    if n == 0 or npairs == 0:
        return 0, -1, 0.0, -1, math.inf, 0
    if not swept:
        for k in range(n):
            d = pair_distances(u, qs[k:k + 1])[0][0]
            evals += 1
            g = d - u.margin
            j = int(np.argmin(g))
            if g[j] <= 0.0:
                return 1, k, 0.0, j, float(g[j]), evals
        return 0, -1, 0.0, -1, math.inf, evals
    tau = u.tau
    lip = u.lipschitz
    budget = np.zeros(npairs)  # <= 0: not proven at the current sample, evaluate it there
    for k in range(n):
        stale = np.nonzero(budget <= 0.0)[0]
        if stale.size:
            d = pair_distances(u, qs[k:k + 1], stale)[0][0]
            evals += 1
            g = d - u.margin[stale]
            w = int(np.argmin(g))
            if g[w] <= 0.0:
                return 1, k, 0.0, int(stale[w]), float(g[w]), evals
            budget[stale] = g
        if k == n - 1:
            break
        rate = lip @ np.abs(qs[k + 1] - qs[k])  # (P,) m per unit of s on this segment
        far = budget > rate
        budget[far] -= rate[far]
        needy = np.nonzero(~far)[0]
        if not needy.size:
            continue
        horizon = budget[needy] / rate[needy]  # rate > 0 here: budget > 0 and budget <= rate
        left = np.ones(needy.size, dtype=bool)
        while True:
            cand = np.where(left, horizon, np.inf)
            s = float(cand.min())
            if not s < 1.0:
                break
            if evals >= u.max_evals:
                return 3, k, s, int(needy[int(np.argmin(cand))]), 0.0, evals
            due = np.nonzero(left & (horizon <= s))[0]
            q = qs[k] + s * (qs[k + 1] - qs[k])
            d = pair_distances(u, q[None, :], needy[due])[0][0]
            evals += 1
            g = d - u.margin[needy[due]]
            bad = np.nonzero(g <= tau)[0]
            if bad.size:
                w = int(bad[int(np.argmin(g[bad]))])
                return 2, k, s, int(needy[due[w]]), float(g[w]), evals
            horizon[due] = s + g / rate[needy[due]]
            past = horizon[due] >= 1.0
            done = due[past]
            budget[needy[done]] = g[past] - rate[needy[done]] * (1.0 - s)
            left[done] = False
        # horizons reached 1 without an evaluation (budget == rate): nothing left at the next sample
        rest = needy[left]
        budget[rest] -= rate[rest]
    return 0, -1, 0.0, -1, math.inf, evals
