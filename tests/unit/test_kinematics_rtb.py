"""Cross-check against an independent implementation: roboticstoolbox-python (dev-only).

roboticstoolbox builds the chain from the same DH table with its own code (C++ ETS); our FK
uses a hand-derived closed form.  Agreement on random samples checks both the DH reading and
the pose convention.  Skipped when roboticstoolbox is not installed (it is not a runtime
dependency).
"""

from __future__ import annotations

import numpy as np
import pytest

from parolkit.kinematics import fk, fk_batch, fk_matrix, ik, matrix_to_pose, pose_to_matrix
from parolkit.robot import PAROL6

rtb = pytest.importorskip("roboticstoolbox")
sm = pytest.importorskip("spatialmath")

LIM = PAROL6.safe_limits_deg


def _robot(flange: bool = False):
    links = []
    for i, (row, lim) in enumerate(zip(PAROL6.dh, LIM)):
        d, a = (0.0, 0.0) if (flange and i == 5) else (row.d, row.a)
        links.append(rtb.RevoluteDH(d=d, a=a, alpha=row.alpha, qlim=np.radians(lim)))
    return rtb.DHRobot(links, name="PAROL6")


@pytest.fixture(scope="module")
def robot():
    return _robot()


@pytest.fixture(scope="module")
def samples():
    rng = np.random.default_rng(42)
    # beyond the limits too: FK is pure geometry
    return rng.uniform(LIM[:, 0] - 30, LIM[:, 1] + 30, size=(500, 6))


def test_fk_matches_roboticstoolbox_on_random_samples(robot, samples):
    theirs = np.array(robot.fkine(np.radians(samples)).A)
    ours = fk_batch(samples, as_matrix=True)
    np.testing.assert_allclose(ours, theirs, atol=1e-12)


def test_flange_fk_matches_roboticstoolbox_chain_without_tool_row(samples):
    theirs = np.array(_robot(flange=True).fkine(np.radians(samples)).A)
    np.testing.assert_allclose(fk_batch(samples, "flange", as_matrix=True), theirs, atol=1e-12)


def test_pose_convention_matches_spatialmath_rpy_xyz(robot, samples):
    for q in samples[:100]:
        pose = fk(q)
        T = sm.SE3.RPY(pose[3:], order="xyz", unit="deg")
        np.testing.assert_allclose(T.R, pose_to_matrix(pose)[:3, :3], atol=1e-12)
        theirs = robot.fkine(np.radians(q))
        np.testing.assert_allclose(theirs.rpy("deg", "xyz"), matrix_to_pose(theirs.A)[3:], atol=1e-9)


def test_ik_finds_the_configuration_roboticstoolbox_converged_to(robot):
    """Where ik_LM converges inside the limits, seeding our IK with its answer returns it."""
    ets = robot.ets()
    rng = np.random.default_rng(7)
    qs = rng.uniform(LIM[:, 0], LIM[:, 1], size=(60, 6))
    np.random.seed(7)  # ik_LM's random restarts
    compared = 0
    for q in qs:
        T = pose_to_matrix(fk(q))
        sol = ets.ik_LM(T, tol=1e-14, ilimit=100)
        q_rtb = np.degrees(sol.q)
        if not sol.success or np.any(q_rtb < LIM[:, 0]) or np.any(q_rtb > LIM[:, 1]):
            continue
        if abs(q_rtb[4]) < 1.0:  # near the wrist singularity J4/J6 are ill-defined: skip
            continue
        ours = ik(T, seed_deg=q_rtb)
        # ik_LM stops at its residual tolerance (~1e-3 deg near stretched elbows): same branch
        np.testing.assert_allclose(ours, q_rtb, atol=1e-2)
        # ... and ours is the exact closed-form answer
        err_ours = np.abs(fk_matrix(ours) - T).max()
        assert err_ours <= 1e-12
        assert err_ours <= np.abs(fk_matrix(q_rtb) - T).max() + 1e-15
        compared += 1
    assert compared >= 30
