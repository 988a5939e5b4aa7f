"""The compiled sample fill (_csamples.c) builds the same joint-move arrays as the numpy reference.

``joint._fill`` is the compiled kernel when it is built; ``joint._fill_reference`` is the
numpy code it replaces (and the fallback without a C compiler).  Positions and speeds must be
identical step for step, the planned angles equal to float rounding, so a MoveJoint is the
same motion either way.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from parolkit import _native
from parolkit.motion import JointMove, PlanningError, plan
from parolkit.motion.profiles import sampled_basis
from parolkit.robot import PAROL6

joint = importlib.import_module("parolkit.motion.joint")
LIM = PAROL6.safe_limits_deg
SPD = PAROL6.steps_per_deg.tolist()
PURE = os.environ.get("PAROLKIT_PURE_PYTHON", "") not in ("", "0")


def both(kind, T, ta, rate, start, target):
    _t, basis, speed = sampled_basis(kind, T, ta, rate)
    n = len(basis)
    ref = joint._fill_reference(basis, speed, start, target, SPD, n)
    got = joint._fill(basis, speed, start, target, SPD, n)
    return ref, got


def assert_same(ref, got):
    (q_r, p_r, s_r), (q_g, p_g, s_g) = ref, got
    assert q_g.dtype == np.float64 and p_g.dtype == np.int64 and s_g.dtype == np.int64
    assert q_g.shape == p_g.shape == s_g.shape == q_r.shape
    np.testing.assert_allclose(q_g, q_r, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(p_g, p_r)
    np.testing.assert_array_equal(s_g, s_r)


def test_the_kernel_is_built_in_this_checkout():
    if PURE:
        pytest.skip("PAROLKIT_PURE_PYTHON is set")
    assert joint._csamples is not None, (
        "the compiled sample fill is missing: "
        f"{_native.status().get('parolkit.motion._csamples')}; `pip install -e .` needs a C compiler")


def test_same_arrays_as_the_reference_for_random_moves():
    rng = np.random.default_rng(7)
    for _ in range(400):
        start = rng.uniform(LIM[:, 0], LIM[:, 1]).tolist()
        target = rng.uniform(LIM[:, 0], LIM[:, 1]).tolist()
        kind = "poly" if rng.random() < 0.5 else "trap"
        T = float(rng.uniform(0.02, 12.0))
        rate = float(rng.choice([50.0, 100.0, 250.0, 1000.0]))
        assert_same(*both(kind, T, T / 3 if kind == "trap" else 0.0, rate, start, target))


def test_one_sample_moves_and_long_uncached_moves():
    start = [0.0, -90.0, 180.0, 0.0, 0.0, 180.0]
    target = [10.0, -80.0, 170.0, 5.0, 5.0, 170.0]
    assert_same(*both("poly", 0.004, 0.0, 100.0, start, target))  # one tick
    assert_same(*both("trap", 40.0, 40.0 / 3, 100.0, start, target))  # 4000 samples: not cached


def test_the_arrays_are_fresh_and_read_only():
    start = [0.0, -90.0, 180.0, 0.0, 0.0, 180.0]
    target = [10.0, -80.0, 170.0, 5.0, 5.0, 170.0]
    _t, basis, speed = sampled_basis("poly", 1.0, 0.0, 100.0)
    a = joint._fill(basis, speed, start, target, SPD, len(basis))
    b = joint._fill(basis, speed, start, target, SPD, len(basis))
    for x, y in zip(a, b):
        assert x is not y and not np.shares_memory(x, y)
    tr = plan(JointMove(target, duration_s=1.0), start)
    for arr in (tr.positions, tr.speeds, tr.planned_deg, tr.start_deg):
        with pytest.raises(ValueError):
            arr[0] = 0


def test_huge_values_round_like_numpy():
    """Far outside any range (the planner refuses such a start afterwards): still numpy's
    values, to the last bits numpy's matrix product (which may fuse multiply-adds) leaves."""
    start = [1e13, -1e14, 3e15, 0.0, 0.0, 0.0]
    target = [0.0, -90.0, 180.0, 0.0, 0.0, 180.0]
    (q_r, p_r, s_r), (q_g, p_g, s_g) = both("poly", 0.5, 0.0, 100.0, start, target)
    np.testing.assert_allclose(q_g, q_r, rtol=1e-12)
    np.testing.assert_allclose(p_g, p_r, rtol=1e-12)
    np.testing.assert_allclose(s_g, s_r, rtol=1e-12)
    assert np.abs(p_g).max() > 2**50  # beyond where every float is an exact half-integer
    with pytest.raises(PlanningError, match="MoveJoint refused"):
        plan(JointMove(target, duration_s=0.5), start)


@pytest.mark.skipif(PURE, reason="PAROLKIT_PURE_PYTHON is set")
def test_kernel_rejects_malformed_arguments_with_a_message():
    _t, basis, speed = sampled_basis("poly", 1.0, 0.0, 100.0)
    fill = joint._csamples.fill
    ok = [0.0] * 6
    with pytest.raises(TypeError, match="takes 5 arguments"):
        fill(basis, speed, ok, ok)
    with pytest.raises(ValueError, match="start must have 6 values"):
        fill(basis, speed, [0.0] * 5, ok, SPD)
    with pytest.raises(TypeError, match="basis must be a C-contiguous float64"):
        fill(basis.astype(np.float32), speed, ok, ok, SPD)
    with pytest.raises(TypeError, match="speed must be a C-contiguous float64 array of the right size"):
        fill(basis, speed[:-1], ok, ok, SPD)
    with pytest.raises(TypeError):
        fill(basis, speed, ok, ["x"] * 6, SPD)


@settings(max_examples=200, deadline=None)
@given(
    start=st.tuples(*[st.floats(float(lo), float(hi)) for lo, hi in LIM]),
    target=st.tuples(*[st.floats(float(lo), float(hi)) for lo, hi in LIM]),
    T=st.floats(0.01, 20.0), trap=st.booleans(), rate=st.sampled_from([10.0, 100.0, 333.0]),
)
# found by hypothesis: a sample on a half step (J6, sample 84) that a matrix product (BLAS, a
# fused multiply-add) rounded one step the other way in the reference
@example(start=(0.0, -4.0, 108.0, 0.0, 0.0, 0.5), target=(0.0, -4.0, 108.0, 0.0, 0.0, 0.0), T=1.0, trap=True,
         rate=100.0)
def test_hypothesis_same_arrays(start, target, T, trap, rate):
    kind = "trap" if trap else "poly"
    assert_same(*both(kind, T, T / 3 if trap else 0.0, rate, list(start), list(target)))


def test_plans_are_identical_with_and_without_the_kernels():
    """Whole plans (MoveJoint poly/trap/percent, MovePose) in this process and in one running
    the pure-Python references give the same samples."""
    code = r"""
import json, sys
import numpy as np
from parolkit.motion import JointMove, PoseMove, Profile, Tracking, plan
moves = [
    JointMove([40, -80, 160, 30, 10, 120], duration_s=3.0),
    JointMove([40, -80, 160, 30, 10, 120], duration_s=2.0, profile=Profile.TRAP),
    JointMove([-60, -120, 200, -90, 40, 300], speed_pct=70, accel_pct=40),
    JointMove([10, -95, 185, 0, 5, 170], duration_s=4.0, tracking=Tracking.SPEED),
    PoseMove([7, 250, 200, -100, 0, -90], duration_s=2.5),
    PoseMove([133.0, 271.2, 233.5, -82.0, 19.8, -81.1]),
]
out = []
for m in moves:
    tr = plan(m, [90.0, -100.0, 150.0, 10.0, 40.0, 170.0])
    out.append([tr.positions.tolist(), tr.speeds.tolist(), tr.commands.tolist(),
                tr.planned_deg.tolist()])
json.dump(out, sys.stdout)
"""
    runs = []
    for pure in ("0", "1"):
        env = dict(os.environ, PAROLKIT_PURE_PYTHON=pure)
        res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                             check=True)
        runs.append(json.loads(res.stdout))
    for compiled, reference in zip(*runs):
        assert compiled[:3] == reference[:3]  # positions, speeds, commands: identical
        np.testing.assert_allclose(compiled[3], reference[3], rtol=0, atol=1e-9)  # planned deg
        assert len(compiled[0]) > 10  # a real plan
