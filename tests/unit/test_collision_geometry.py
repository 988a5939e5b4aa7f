"""The collision kernel's distances are exact: capsule-capsule, capsule-plane, capsule-box and
capsule-cylinder clearances match a brute-force search along the capsule's axis (dense
sampling, then a fine pass around the best sample) to 1e-6 mm, in both kernels (the compiled
one and the numpy reference), and the closest points they return are on the shapes and that
far apart.

The shapes are placed directly in the base frame (bodies on frame 0 of a hand-packed scene), so
these tests judge the geometry alone, not the arm's kinematics.
"""

from __future__ import annotations

import numpy as np
import pytest

from parolkit.collision import _reference as ref
from parolkit.collision._geometry import LinkCapsule, PairSpec, Static, frame_with_z, pack
from parolkit.collision._kernel import ccollide
from parolkit.robot import PAROL6

KERNELS = ["reference"] + (["compiled"] if ccollide is not None else [])
ZERO6 = (0.0,) * 6


def _random_rot(rng: np.random.Generator) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _distances(kernel: str, packed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair's clearance and closest points at q = 0 (the bodies are on frame 0)."""
    u = ref.unpack(packed)
    qs = np.zeros((1, 6))
    if kernel == "reference":
        d, pa, pb = ref.pair_distances(u, qs)
    else:
        p = u.pairs.shape[0]
        d, pa, pb = np.empty((1, p)), np.empty((1, p, 3)), np.empty((1, p, 3))
        ccollide.distances(packed, qs, d, pa, pb)
    return d[0], pa[0], pb[0]


def _brute_along(f, n: int = 4001) -> float:
    """min over t in [0, 1] of the vectorised f(t): a dense pass, then a fine one around the best."""
    t = np.linspace(0.0, 1.0, n)
    v = f(t)
    i = int(np.argmin(v))
    lo, hi = t[max(i - 1, 0)], t[min(i + 1, n - 1)]
    t2 = np.linspace(lo, hi, n)
    return float(min(v.min(), f(t2).min()))


def _point_box(p: np.ndarray, e: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.maximum(np.abs(p) - e, 0.0), axis=-1)


def _point_cylinder(p: np.ndarray, radius: float, half: float) -> np.ndarray:
    dr = np.maximum(np.hypot(p[..., 0], p[..., 1]) - radius, 0.0)
    dz = np.maximum(np.abs(p[..., 2]) - half, 0.0)
    return np.hypot(dr, dz)


def _case(rng: np.random.Generator, kind: int):
    """A random capsule (axis near the shape, sometimes a point) and a random static of ``kind``."""
    a = rng.uniform(-0.15, 0.15, 3)
    length = 0.0 if rng.random() < 0.1 else rng.uniform(0.0, 0.25)
    b = a + length * _random_rot(rng)[:, 0]
    r = rng.uniform(0.005, 0.04)
    rot = _random_rot(rng)
    c = rng.uniform(-0.05, 0.05, 3)
    if kind == ref.PLANE:
        n = rot[:, 2]
        return LinkCapsule(0, tuple(a), tuple(b), r), Static(ref.PLANE, tuple(c), tuple(np.eye(3).ravel()), tuple(n))
    if kind == ref.BOX:
        e = rng.uniform(0.005, 0.1, 3)
        return LinkCapsule(0, tuple(a), tuple(b), r), Static(ref.BOX, tuple(c), tuple(rot.ravel()), tuple(e))
    e = (rng.uniform(0.005, 0.1), rng.uniform(0.005, 0.1), 0.0)
    return LinkCapsule(0, tuple(a), tuple(b), r), Static(ref.CYLINDER, tuple(c), tuple(rot.ravel()), e)


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("kind", [ref.PLANE, ref.BOX, ref.CYLINDER], ids=["plane", "box", "cylinder"])
def test_capsule_to_static_clearance_is_the_brute_force_minimum(kernel, kind):
    rng = np.random.default_rng(100 + kind)
    segs, statics, pairs = [], [], []
    for k in range(250):  # (a packed scene holds at most 256 bodies)
        seg, st = _case(rng, kind)
        segs.append(seg)
        statics.append(st)
        pairs.append(PairSpec(ref.CAP_STATIC, k, k, ref.SELF, 0.0, ZERO6))
    d, pa, pb = _distances(kernel, pack(PAROL6, segs, statics, pairs, 1e-5, 10))
    contacts = 0
    for k, (seg, st) in enumerate(zip(segs, statics)):
        a, b = np.array(seg.start), np.array(seg.end)
        c, rot, e = np.array(st.center), np.array(st.rot).reshape(3, 3), np.array(st.e)

        def local(t, a=a, b=b, c=c, rot=rot):
            return ((a + t[:, None] * (b - a)) - c) @ rot

        if kind == ref.PLANE:
            want = min(float((a - c) @ e), float((b - c) @ e)) - seg.radius  # signed: exact below 0 too
        elif kind == ref.BOX:
            want = _brute_along(lambda t, e=e, local=local: _point_box(local(t), e)) - seg.radius
        else:
            want = _brute_along(lambda t, e=e, local=local: _point_cylinder(local(t), e[0], e[1])) - seg.radius
        contacts += d[k] <= 0.0
        if want > 0 or kind == ref.PLANE:
            assert d[k] == pytest.approx(want, abs=1e-9), (k, d[k], want)  # 1e-9 m = 1e-6 mm
        else:
            assert d[k] <= 0.0
        # the closest points: one on the capsule's axis, one on the shape, d + r apart
        t = np.dot(pa[k] - a, b - a) / max(np.dot(b - a, b - a), 1e-30)
        assert np.linalg.norm(a + np.clip(t, 0, 1) * (b - a) - pa[k]) < 1e-12
        if kind != ref.PLANE and d[k] > 0:
            pl = (pb[k] - c) @ rot
            on = _point_box(pl, e) if kind == ref.BOX else _point_cylinder(pl, e[0], e[1])
            assert on < 1e-12
            assert np.linalg.norm(pa[k] - pb[k]) - seg.radius == pytest.approx(d[k], abs=1e-12)
    assert 0 < contacts < 250  # both sides of contact were exercised


@pytest.mark.parametrize("kernel", KERNELS)
def test_capsule_to_capsule_clearance_is_the_brute_force_minimum(kernel):
    rng = np.random.default_rng(7)
    segs, pairs, cases = [], [], []
    for k in range(120):
        a0 = rng.uniform(-0.1, 0.1, 3)
        # parallel, crossing, point-like and general segments
        mode = k % 4
        d1 = _random_rot(rng)[:, 0] * rng.uniform(0, 0.2)
        if mode == 0:
            d2 = d1 * rng.uniform(-2, 2)
        elif mode == 1:
            d2 = np.zeros(3)
        else:
            d2 = _random_rot(rng)[:, 0] * rng.uniform(0, 0.2)
        b0 = rng.uniform(-0.1, 0.1, 3)
        ra, rb = rng.uniform(0.001, 0.03, 2)
        segs += [LinkCapsule(0, tuple(a0), tuple(a0 + d1), ra), LinkCapsule(0, tuple(b0), tuple(b0 + d2), rb)]
        pairs.append(PairSpec(ref.CAP_CAP, 2 * k, 2 * k + 1, ref.SELF, 0.0, ZERO6))
        cases.append((a0, a0 + d1, b0, b0 + d2, ra + rb))
    d, pa, pb = _distances(kernel, pack(PAROL6, segs, [], pairs, 1e-5, 10))
    for k, (a0, a1, b0, b1, rr) in enumerate(cases):
        db = b1 - b0

        def seg_to_segment(t, a0=a0, a1=a1, b0=b0, db=db):
            p = a0 + t[:, None] * (a1 - a0)
            s = np.clip(((p - b0) @ db) / max(db @ db, 1e-30), 0.0, 1.0)
            return np.linalg.norm(p - (b0 + s[:, None] * db), axis=1)

        want = _brute_along(seg_to_segment) - rr
        assert d[k] == pytest.approx(want, abs=1e-9), (k, d[k], want)
        assert np.linalg.norm(pa[k] - pb[k]) - rr == pytest.approx(d[k], abs=1e-12)


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_capsule_axis_inside_a_box_or_cylinder_is_contact_at_minus_its_radius(kernel):
    seg = LinkCapsule(0, (-0.01, 0.0, 0.0), (0.01, 0.0, 0.0), 0.02)
    box = Static(ref.BOX, (0.0, 0.0, 0.0), tuple(np.eye(3).ravel()), (0.05, 0.05, 0.05))
    cyl = Static(ref.CYLINDER, (0.0, 0.0, 0.0), tuple(frame_with_z((1, 1, 0)).ravel()), (0.05, 0.05, 0.0))
    plane = Static(ref.PLANE, (0.0, 0.0, 0.03), tuple(np.eye(3).ravel()), (0.0, 0.0, 1.0))
    pairs = [PairSpec(ref.CAP_STATIC, 0, j, ref.SELF, 0.0, ZERO6) for j in range(3)]
    d, _, _ = _distances(kernel, pack(PAROL6, [seg], [box, cyl, plane], pairs, 1e-5, 10))
    assert d[0] == pytest.approx(-0.02) and d[1] == pytest.approx(-0.02)
    assert d[2] == pytest.approx(-0.05)  # a plane's overlap is the depth: 30 mm below it, radius 20
