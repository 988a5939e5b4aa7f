"""The compiled IK kernel (_cik.c) gives the same answers as the pure-Python reference.

``ik()`` runs the kernel when it is built; ``_ik_reference()`` is the Python code it copies
(and the fallback on machines without a C compiler).  Both must agree on every branch, tool,
seed, singularity, failure and odd input, so switching between them never changes a motion.
"""

from __future__ import annotations

import importlib
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from parolkit import _native
from parolkit.kinematics import IKError, fk, fk_batch, ik
from parolkit.kinematics.tools import DEFAULT_TOOL, FLANGE, Tool, get_tool
from parolkit.kinematics.types import Branch
from parolkit.robot import PAROL6

ikmod = importlib.import_module("parolkit.kinematics.ik")
LIM = PAROL6.safe_limits_deg
ROTATED_TOOL = Tool.from_pose("rotated", [10.0, -20.0, 80.0, 30.0, -45.0, 60.0])
PURE = os.environ.get("PAROLKIT_PURE_PYTHON", "") not in ("", "0")


def reference(pose, seed=None, tool=DEFAULT_TOOL, config=None):
    return ikmod._ik_reference(pose, seed, tool, config)


def same_outcome(pose, seed=None, tool=None, config=None):
    """ik() and the reference: both the same joints (to 1e-9 deg), or both the same error."""
    tool_obj = DEFAULT_TOOL if tool is None else get_tool(tool)
    try:
        want = reference(pose, seed, tool_obj, config)
    except IKError as exc:
        with pytest.raises(IKError) as info:
            ik(pose, seed, tool, config)
        assert str(info.value) == str(exc)
        return None
    got = ik(pose, seed, tool, config)
    assert type(got) is np.ndarray and got.dtype == float and got.shape == (6,)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    return got


def random_joints(n, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(LIM[:, 0], LIM[:, 1], size=(n, 6))


def test_the_kernel_is_built_in_this_checkout():
    if PURE:
        pytest.skip("PAROLKIT_PURE_PYTHON is set")
    assert ikmod.NATIVE, (
        "the compiled IK kernel is missing: "
        f"{_native.status().get('parolkit.kinematics._cik')}; `pip install -e .` needs a C compiler")


@pytest.mark.parametrize("tool", [DEFAULT_TOOL, FLANGE, ROTATED_TOOL], ids=lambda t: t.name)
def test_same_solution_as_the_reference_on_random_poses_and_seeds(tool):
    qs = random_joints(3000, 1)
    seeds = random_joints(3000, 2)
    poses = fk_batch(qs, tool=tool).tolist()
    for pose, q, other in zip(poses, qs.tolist(), seeds.tolist()):
        same_outcome(pose, q, tool)  # warm
        same_outcome(pose, other, tool)  # a far seed: often another branch
    for pose in poses[:500]:
        same_outcome(pose, None, tool)  # cold (standby)


@pytest.mark.parametrize("shoulder", [None, "front", "back"])
@pytest.mark.parametrize("elbow", [None, "up", "down"])
@pytest.mark.parametrize("flip", [None, False, True])
def test_same_solution_or_error_for_every_pinned_branch(shoulder, elbow, flip):
    config = Branch(shoulder, elbow, flip)
    qs = random_joints(150, 3)
    for pose, q in zip(fk_batch(qs).tolist(), qs.tolist()):
        same_outcome(pose, q, None, config)
        same_outcome(pose, None, None, str(config) if config.is_complete else config)


def test_same_result_at_singularities_and_full_stretch():
    cases = [
        ([20, -80, 170, 0, 0, 100], [20, -80, 170, 35, 0, 100]),  # wrist singular
        ([0, -90, 180, 0, 0, 180], None),  # standby
        ([10, -60, 107.866, 0, 45, 180], None),  # near the J3 limit
        ([0, -90, 180, 90, 90, 0], [0, -90, 180, 90, 90, 0]),  # J5 at its limit
    ]
    for q, seed in cases:
        same_outcome(fk(q), seed)
        same_outcome(fk(q), q)
    # the wrist centre on the J1 axis (shoulder singular)
    q3 = math.pi
    from parolkit.kinematics.model import A1, A2, A3, D4

    u = A2 + A3 * math.cos(q3) + D4 * math.sin(q3)
    v = D4 * math.cos(q3) - A3 * math.sin(q3)
    q2 = -math.acos(-A1 / math.hypot(u, v)) - math.atan2(v, u)
    q = [30.0, math.degrees((q2 + math.pi) % (2 * math.pi) - math.pi), 180.0, 10.0, 40.0, 120.0]
    for seed_j1 in (30.0, 50.0, -70.0):
        same_outcome(fk(q), [seed_j1] + q[1:])


def test_same_errors_for_unreachable_and_out_of_limit_targets():
    for pose in ([600, 0, 300, 0, 90, 0], [0, 0, 0, 0, 0, 0], [7, 250, 200, -100, 0, -90],
                 [0, 0, 800, 0, 0, 0], [100, 0, -400, 0, 0, 0], [-200, -50, 100, 180, 0, 45]):
        same_outcome(pose)
        same_outcome(pose, None, None, "back down flip")


@pytest.mark.parametrize("pose", [
    [7, 250, 200, -100, 0, -90],
    (7, 250, 200, -100, 0, -90),
    np.array([7.0, 250.0, 200.0, -100.0, 0.0, -90.0]),
    [np.float64(7), 250, 200, -100, 0, -90],
    [np.int64(7), 250, 200, -100, 0, -90],  # not a float subclass: the Python path takes it
    [True, 250, 200, -100, 0, -90],  # bool: the Python path decides
    [7, 250, 200, -100, 0, float("nan")],
    [7, 250, 200, -100, 0, math.inf],
    [7, 250, 200, -100, 0, 10**400],
    [7, 250, 200, -100, 0, "x"],
    [7, 250, 200, -100, 0],
    [[7, 250, 200, -100, 0, -90]],
    "7 250 200 -100 0 -90",
    None,
])
def test_odd_pose_inputs_behave_exactly_like_the_reference(pose):
    try:
        same_outcome(pose, [0, -90, 180, 0, 0, 180])
    except TypeError:  # a reference TypeError is only acceptable if ik() raises the same
        with pytest.raises(TypeError):
            ik(pose, [0, -90, 180, 0, 0, 180])


@pytest.mark.parametrize("seed", [
    None, [0, -90, 180, 0, 0, 180], (0, -90, 180, 0, 0, 180), np.array([0, -90, 180, 0, 0, 180.0]),
    [0, -90, 180, 0, 0, float("nan")], [0, -90, 180, 0, 0], [0, -90, 180, 0, 0, "a"],
    [1e308, 1e308, 0, 0, 0, 0],
])
def test_odd_seed_inputs_behave_exactly_like_the_reference(seed):
    same_outcome([7, 250, 200, -100, 0, -90], seed)


@settings(max_examples=300, deadline=None)
@given(
    q=st.tuples(*[st.floats(float(lo), float(hi)) for lo, hi in LIM]),
    seed=st.tuples(*[st.floats(-400, 400) for _ in range(6)]),
    dx=st.floats(-50, 50), dz=st.floats(-50, 50),
)
def test_hypothesis_agrees_on_perturbed_targets(q, seed, dx, dz):
    pose = fk(list(q)).tolist()
    pose[0] += dx
    pose[2] += dz
    same_outcome(pose, list(seed))
    same_outcome(pose, list(q))


def test_the_package_runs_without_the_kernel():
    code = ("import importlib; m = importlib.import_module('parolkit.kinematics.ik'); "
            "from parolkit import _native; from parolkit.kinematics import ik; "
            "print(m.NATIVE, _native.status()['parolkit.kinematics._cik']); "
            "print(ik([7, 250, 200, -100, 0, -90]).round(2).tolist())")
    env = dict(os.environ, PAROLKIT_PURE_PYTHON="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0] == "False pure Python: PAROLKIT_PURE_PYTHON is set"
    assert out[1] == "[90.26, -93.84, 147.79, -0.55, 28.38, 190.49]"


