"""Closed-form IK: round trips, branches, angle representation, singularities, errors, batches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from parolkit.errors import ParolkitError
from parolkit.kinematics import (
    Branch,
    IKError,
    IKFailure,
    IKSolution,
    Tool,
    fk,
    fk_batch,
    fk_matrix,
    ik,
    ik_all,
    ik_batch,
    pose_to_matrix,
)
from parolkit.kinematics.model import A1, A2, A3, D4
from parolkit.robot import PAROL6

LIM = PAROL6.safe_limits_deg
STANDBY = np.array(PAROL6.standby_deg)
N_ROUND_TRIP = 10_000


def wrap_deg(d):
    return (np.asarray(d) + 180.0) % 360.0 - 180.0


def random_joints(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(LIM[:, 0], LIM[:, 1], size=(n, 6))


def assert_same_pose(p, q, mm=1e-6, deg=1e-6):
    """Same position (mm) and same orientation: rotation angle between them <= deg.

    (Compared as rotations: [A, B, C] and [A + 180, 180 - B, C + 180] are the same pose.)
    """
    p, q = np.atleast_2d(p), np.atleast_2d(q)
    assert np.abs(p[:, :3] - q[:, :3]).max() <= mm
    rp, rq = pose_to_matrix(p)[:, :3, :3], pose_to_matrix(q)[:, :3, :3]
    rel = np.einsum("nij,nkj->nik", rp, rq)  # Rp Rq^T
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    # arccos is ill-conditioned near 0: use the skew part for the small angles we expect
    skew = np.stack([rel[:, 2, 1] - rel[:, 1, 2], rel[:, 0, 2] - rel[:, 2, 0], rel[:, 1, 0] - rel[:, 0, 1]], 1)
    angle = np.degrees(np.arctan2(np.linalg.norm(skew, axis=1) / 2.0, cos))
    assert angle.max() <= deg


def in_limits(q):
    q = np.atleast_2d(q)
    return bool(np.all(q >= LIM[:, 0]) and np.all(q <= LIM[:, 1]))


# ---------------------------------------------------------------------------------------------
# acceptance: the client example and the round trip
# ---------------------------------------------------------------------------------------------


def test_client_example_pose_from_standby():
    q = ik([7, 250, 200, -100, 0, -90], seed_deg=STANDBY)
    np.testing.assert_allclose(q, [90.26, -93.84, 147.79, -0.55, 28.38, 190.49], atol=0.01)
    assert_same_pose(fk(q), [7, 250, 200, -100, 0, -90])
    # J6 in its 0..360 range, not the wrapped -169.5 of the original numerical solver
    assert 190 < q[5] < 191


def test_round_trip_10000_random_configurations_single_calls():
    qs = random_joints(N_ROUND_TRIP, seed=1)
    poses = fk_batch(qs)
    sols = np.array([ik(p, seed_deg=q) for p, q in zip(poses, qs)])
    assert in_limits(sols)
    assert np.abs(sols - qs).max() <= 1e-6  # 100 % success, the seed's own configuration
    assert_same_pose(fk_batch(sols), poses)


def test_round_trip_10000_random_configurations_batch():
    qs = random_joints(N_ROUND_TRIP, seed=2)
    poses = fk_batch(qs)
    sols = ik_batch(poses, seed_deg=qs)  # one seed per pose: independent solves
    assert sols.shape == (N_ROUND_TRIP, 6) and in_limits(sols)
    assert np.abs(sols - qs).max() <= 1e-6
    assert_same_pose(fk_batch(sols), poses)
    # cold: every pose from the standby seed still reaches the exact pose, in limits
    cold = ik_batch(poses, continuous=False)
    assert in_limits(cold)
    assert_same_pose(fk_batch(cold), poses)


@pytest.mark.parametrize("config", [None, "back", "down", "flip", "front up noflip", "back down flip"])
def test_batch_with_unrelated_seeds_picks_the_same_branch_as_single_ik(config):
    # seeds unrelated to the targets: the nearest in-limit branch is often not the seed's
    # shoulder/elbow, so the batch solver's seed-nearest-first arm order must not matter
    qs = random_joints(1000, seed=5)
    seeds = random_joints(1000, seed=6)
    poses = fk_batch(qs)
    want, ok = [], []
    for p, s in zip(poses, seeds):
        try:
            want.append(ik(p, seed_deg=s, config=config))
            ok.append(True)
        except IKError:
            ok.append(False)
    ok = np.array(ok)
    assert ok.sum() >= 50  # enough reachable samples for the pinned configs too
    got = ik_batch(poses[ok], seed_deg=seeds[ok], config=config)
    np.testing.assert_allclose(got, np.array(want), rtol=0, atol=1e-9)


def test_matrix_input_gives_the_same_solution_as_pose_input():
    q = [30, -70, 190, 20, -40, 250]
    np.testing.assert_allclose(ik(fk_matrix(q), seed_deg=q), q, atol=1e-9)
    np.testing.assert_allclose(ik_batch(fk_batch([q, q], as_matrix=True), seed_deg=q), [q, q], atol=1e-9)


# ---------------------------------------------------------------------------------------------
# branches
# ---------------------------------------------------------------------------------------------


def test_ik_all_lists_every_in_limit_branch_each_reaching_the_pose():
    q = [100, -100, 240, 30, 40, 200]  # elbow near stretch: several branches in range
    sols = ik_all(fk(q), seed_deg=q)
    assert all(isinstance(s, IKSolution) for s in sols)
    assert 2 <= len(sols) <= 8
    assert len({s.config for s in sols}) == len(sols)  # each branch once
    np.testing.assert_allclose(sols[0].joints_deg, q, atol=1e-9)  # nearest to the seed first
    for s in sols:
        assert in_limits(s.joints_deg)
        assert s.config.is_complete
        assert_same_pose(fk(s.joints_deg), fk(q))
        assert s.config.wrist_flip == (s.joints_deg[4] < 0)


def test_standby_is_front_up_and_config_pins_a_branch():
    (sol,) = [s for s in ik_all(fk(STANDBY)) if s.config.elbow == "up"]
    assert sol.config.shoulder == "front"
    q = [100, -100, 240, 30, 40, 200]
    pose = fk(q)
    for s in ik_all(pose):
        got = ik(pose, seed_deg=STANDBY, config=s.config)
        np.testing.assert_allclose(got, s.joints_deg, atol=1e-9)
    flipped = ik(pose, seed_deg=q, config=Branch(wrist_flip=True))
    assert flipped[4] < 0
    assert_same_pose(fk(flipped), pose)
    assert Branch.parse("front, down noflip") == Branch("front", "down", False)
    np.testing.assert_allclose(ik(pose, seed_deg=q, config="noflip"), q, atol=1e-9)


def test_seed_selects_the_nearest_branch():
    q = [100, -100, 240, 30, 40, 200]
    pose = fk(q)
    for s in ik_all(pose):
        np.testing.assert_allclose(ik(pose, seed_deg=s.joints_deg), s.joints_deg, atol=1e-9)


def test_invalid_branch_values_are_rejected():
    with pytest.raises(ParolkitError, match="Branch.shoulder must be 'front', 'back' or None"):
        Branch(shoulder="left")
    with pytest.raises(ParolkitError, match="branch word 'sideways' unknown"):
        Branch.parse("sideways")


# ---------------------------------------------------------------------------------------------
# angle representation
# ---------------------------------------------------------------------------------------------


def test_j6_zero_or_360_follows_the_seed():
    q = [20, -80, 170, 10, 30, 0.0]
    pose = fk(q)
    assert ik(pose, seed_deg=[20, -80, 170, 10, 30, 10])[5] == pytest.approx(0.0, abs=1e-9)
    assert ik(pose, seed_deg=[20, -80, 170, 10, 30, 350])[5] == pytest.approx(360.0, abs=1e-9)


def test_j3_is_reported_in_its_107_to_288_range():
    q = [0, -60, 270, 0, 20, 90]  # the same elbow angle as -90, which is out of range
    sols = ik_all(fk(q), seed_deg=[0, -60, -90, 0, 20, 90])
    assert any(s.joints_deg[2] == pytest.approx(270.0, abs=1e-9) for s in sols)
    assert all(LIM[2, 0] <= s.joints_deg[2] <= LIM[2, 1] for s in sols)
    assert ik(fk(q), seed_deg=q)[2] == pytest.approx(270.0, abs=1e-9)


def test_joint_values_at_the_limits_are_accepted_exactly():
    q = np.array([LIM[0, 1], LIM[1, 0], LIM[2, 1], LIM[3, 0], LIM[4, 1], LIM[5, 0]])
    sol = ik(fk(q), seed_deg=q)
    assert in_limits(sol)
    np.testing.assert_allclose(sol, q, atol=1e-7)


# ---------------------------------------------------------------------------------------------
# singularities
# ---------------------------------------------------------------------------------------------


def test_wrist_singularity_keeps_the_seed_j4():
    q = [20, -80, 170, 0, 0, 100]
    pose = fk(q)
    sol = ik(pose, seed_deg=[20, -80, 170, 35, 0, 100])
    assert sol[3] == pytest.approx(35.0, abs=1e-9)
    assert sol[4] == 0.0
    assert sol[5] == pytest.approx(65.0, abs=1e-7)  # J4 + J6 is what the pose fixes
    assert_same_pose(fk(sol), pose)
    np.testing.assert_allclose(ik(pose, seed_deg=q), q, atol=1e-7)


def _shoulder_singular_config(q1):
    """A configuration whose wrist centre lies on the J1 axis (r = A1 + X = 0)."""
    q3 = math.pi
    u = A2 + A3 * math.cos(q3) + D4 * math.sin(q3)
    v = D4 * math.cos(q3) - A3 * math.sin(q3)
    big = math.hypot(u, v)
    for sign in (1, -1):
        q2 = sign * math.acos(-A1 / big) - math.atan2(v, u)
        q2 = (q2 + math.pi) % (2 * math.pi) - math.pi
        if LIM[1, 0] < math.degrees(q2) < LIM[1, 1]:
            return [q1, math.degrees(q2), 180.0, 10.0, 40.0, 120.0]
    raise AssertionError("no shoulder-singular configuration in range")


def test_shoulder_singularity_keeps_the_seed_j1():
    q = _shoulder_singular_config(30.0)
    frames_wrist = fk_matrix(q, "flange")[:3, 3]
    assert math.hypot(frames_wrist[0], frames_wrist[1]) < 1e-12
    pose = fk(q)
    for seed_j1 in (30.0, 50.0, -70.0):
        sol = ik(pose, seed_deg=[seed_j1] + q[1:])
        assert sol[0] == pytest.approx(seed_j1, abs=1e-9)
        assert in_limits(sol)
        assert_same_pose(fk(sol), pose)


# ---------------------------------------------------------------------------------------------
# errors
# ---------------------------------------------------------------------------------------------


def test_unreachable_target_reports_the_distance():
    with pytest.raises(IKError, match=r"out of reach by 172\.0 mm") as info:
        ik([600, 0, 300, 0, 90, 0])
    err = info.value
    assert isinstance(err, ParolkitError)
    assert err.kind is IKFailure.OUT_OF_REACH and err.value == pytest.approx(172.0, abs=0.1)
    assert err.sample is None and err.joint is None


def test_out_of_limit_target_names_the_joint_and_value():
    with pytest.raises(IKError, match=r"joint J5 would be 100\.0 deg > 90") as info:
        ik(fk([0, -90, 180, 0, 100, 180]))
    assert info.value.joint == 4 and info.value.joint_name == "J5"
    assert info.value.value == pytest.approx(100.0)
    assert info.value.kind is IKFailure.JOINT_LIMIT


def test_pinned_branch_that_cannot_reach_says_which_branch_can():
    with pytest.raises(IKError, match="excludes the reachable branch 'front up noflip'"):
        ik([7, 250, 200, -100, 0, -90], config="back")


def test_malformed_inputs_raise_ik_errors_naming_the_field():
    with pytest.raises(IKError, match="z is not a finite number"):
        ik([1, 2, float("nan"), 0, 0, 0])
    with pytest.raises(IKError, match=r"got shape \(3,\)"):
        ik([1, 2, 3])
    with pytest.raises(IKError, match="seed_deg: J2 is not a finite number"):
        ik([7, 250, 200, -100, 0, -90], seed_deg=[0, float("inf"), 0, 0, 0, 0])
    bad = np.eye(4)
    bad[:3, :3] *= 2
    with pytest.raises(IKError, match="not a proper rotation"):
        ik(bad)
    with pytest.raises(IKError, match="config must be a Branch"):
        ik([7, 250, 200, -100, 0, -90], config=3)


def test_a_wrongly_shaped_pose_array_is_rejected_and_left_unchanged():
    column = fk(STANDBY).reshape(6, 1)
    before = column.copy()
    for solve in (ik, ik_all):
        with pytest.raises(IKError, match=r"got shape \(6, 1\)"):
            solve(column)
        assert np.array_equal(column, before)


def test_a_pose_of_numpy_0d_arrays_is_solved_and_left_unchanged():
    pose = [np.array(v) for v in fk([90, -100, 170, 10, 20, 180])]
    before = [float(v) for v in pose]
    assert np.allclose(ik(pose, [90, -100, 170, 10, 20, 180]), [90, -100, 170, 10, 20, 180])
    assert [float(v) for v in pose] == before


def test_ik_never_returns_nan_or_a_wrong_pose_on_random_targets():
    rng = np.random.default_rng(9)
    poses = np.column_stack([rng.uniform(-450, 450, (2000, 3)), rng.uniform(-180, 180, (2000, 3))])
    solved = failed = 0
    for p in poses:
        try:
            q = ik(p)
        except IKError as exc:
            assert exc.kind in (IKFailure.OUT_OF_REACH, IKFailure.JOINT_LIMIT)
            failed += 1
            continue
        solved += 1
        assert np.all(np.isfinite(q)) and in_limits(q)
        assert_same_pose(fk(q), p)
    assert solved > 0 and failed > 0


# ---------------------------------------------------------------------------------------------
# batches: continuity, sample indices
# ---------------------------------------------------------------------------------------------


def _joint_path(q_start, q_end, n):
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(q_start) + t * (np.asarray(q_end) - np.asarray(q_start))


def test_batch_follows_a_path_without_branch_hops_through_the_wrist_singularity():
    # J5 crosses 0 (sample 100 of 201 is exactly singular)
    path = _joint_path([40, -100, 200, 30, 25, 100], [60, -80, 180, -20, -25, 200], 201)
    poses = fk_batch(path)
    sols = ik_batch(poses, seed_deg=path[0])
    assert_same_pose(fk_batch(sols), poses)
    assert in_limits(sols)
    steps = np.abs(np.diff(sols, axis=0)).max(axis=0)
    assert np.all(steps < 2.0)  # joints move continuously: no flip, no 360 wrap
    regular = np.ones(201, dtype=bool)
    regular[100] = False
    np.testing.assert_allclose(sols[regular], path[regular], atol=1e-6)


def test_batch_continuity_allows_j6_past_180_without_wrapping():
    path = _joint_path([0, -90, 180, 0, 30, 100], [0, -90, 180, 0, 30, 300], 101)
    sols = ik_batch(fk_batch(path), seed_deg=path[0])
    np.testing.assert_allclose(sols, path, atol=1e-6)


def test_batch_raises_at_the_first_sample_leaving_a_joint_range_instead_of_hopping():
    path = _joint_path([100, -90, 180, 0, 30, 100], [140, -90, 180, 0, 30, 100], 41)
    poses = fk_batch(path)  # J1 passes its 123.05 deg limit at 123.05: sample 24 (124 deg)
    first_bad = int(np.argmax(path[:, 0] > LIM[0, 1]))
    with pytest.raises(IKError, match="joint J1 would be") as info:
        ik_batch(poses, seed_deg=path[0])
    assert info.value.sample == first_bad and info.value.joint == 0


def test_batch_reports_unreachable_sample_index():
    poses = np.array([[200, 0, 300, 0, 90, 180]] * 5, dtype=float)
    poses[3, 0] = 700.0
    with pytest.raises(IKError, match="out of reach") as info:
        ik_batch(poses, seed_deg=STANDBY)
    assert info.value.sample == 3
    with pytest.raises(IKError, match="out of reach") as info:
        ik_batch(poses, continuous=False)
    assert info.value.sample == 3


def test_batch_pinned_branch_is_kept():
    q = [100, -100, 240, 30, 40, 200]
    pose = fk(q)
    for s in ik_all(pose):
        got = ik_batch(np.array([pose, pose]), seed_deg=STANDBY, config=s.config)
        np.testing.assert_allclose(got, [s.joints_deg, s.joints_deg], atol=1e-9)
        got = ik_batch(np.array([pose, pose]), seed_deg=STANDBY, config=s.config, continuous=False)
        np.testing.assert_allclose(got, [s.joints_deg, s.joints_deg], atol=1e-9)


def test_batch_input_errors():
    with pytest.raises(IKError, match="seed_deg has 2 rows for 3 poses"):
        ik_batch(np.zeros((3, 6)), seed_deg=np.zeros((2, 6)))
    with pytest.raises(IKError, match=r"poses \(sample 1\): y is not a finite number"):
        ik_batch([[200, 0, 300, 0, 90, 180], [200, float("nan"), 300, 0, 90, 180]])
    assert ik_batch(np.zeros((0, 6))).shape == (0, 6)


# ---------------------------------------------------------------------------------------------
# tools
# ---------------------------------------------------------------------------------------------


def test_ik_with_flange_and_rotated_tools_round_trips():
    tool = Tool.from_pose("angled", [10, -20, 80, 15, -30, 45])
    qs = random_joints(300, seed=4)
    for t in ("flange", tool, "default"):
        poses = fk_batch(qs, t)
        sols = np.array([ik(p, seed_deg=q, tool=t) for p, q in zip(poses, qs)])
        np.testing.assert_allclose(sols, qs, atol=1e-6)
        np.testing.assert_allclose(ik_batch(poses, seed_deg=qs, tool=t), qs, atol=1e-6)
    m = pose_to_matrix(fk(qs[0], tool))
    np.testing.assert_allclose(ik(m, seed_deg=qs[0], tool=tool), qs[0], atol=1e-6)


def test_non_numeric_pose_and_seed_entries_are_rejected_not_crashing():
    with pytest.raises(IKError, match="pose must be numbers"):
        ik(["a", 0, 0, 0, 0, 0])
    with pytest.raises(IKError, match="pose must be numbers"):
        ik([1j, 0, 0, 0, 0, 0])
    with pytest.raises(IKError, match="seed_deg must be numbers"):
        ik([7, 250, 200, -100, 0, -90], seed_deg=["x", 0, 0, 0, 0, 0])
    with pytest.raises(IKError, match=r"out of reach by 1\.41e\+308 mm"):
        ik([1e308, 1e308, 0, 0, 0, 0])


def test_numpy_scalars_tuples_and_arrays_give_identical_results():
    target = [7, 250, 200, -100, 0, -90]
    ref = ik(target)
    np.testing.assert_array_equal(ik(tuple(target)), ref)
    np.testing.assert_array_equal(ik(np.array(target, dtype=float)), ref)
    np.testing.assert_array_equal(ik([np.float64(v) for v in target], seed_deg=STANDBY), ref)


def test_ik_all_without_solution_raises_and_single_pose_batch_works():
    with pytest.raises(IKError, match="out of reach"):
        ik_all([600, 0, 300, 0, 90, 0])
    q = ik_batch([7, 250, 200, -100, 0, -90])
    np.testing.assert_allclose(q[0], ik([7, 250, 200, -100, 0, -90]), atol=1e-9)


def test_branch_words_round_trip():
    b = Branch("back", "down", True)
    assert str(b) == "back down flip" and Branch.parse(str(b)) == b
    assert str(Branch()) == "any" and not Branch(elbow="up").is_complete


def test_batch_singular_samples_keep_the_seed_free_angle_in_both_modes():
    wrist = [20, -80, 170, 0, 0, 100]
    shoulder = _shoulder_singular_config(30.0)
    poses = np.array([fk(wrist), fk(shoulder), fk(wrist)])
    seeds = np.array([[20, -80, 170, 35, 0, 100], [50] + shoulder[1:], [20, -80, 170, -10, 0, 100]])
    sols = ik_batch(poses, seed_deg=seeds)
    assert sols[0, 3] == pytest.approx(35.0, abs=1e-9) and sols[2, 3] == pytest.approx(-10.0, abs=1e-9)
    assert sols[1, 0] == pytest.approx(50.0, abs=1e-9)
    assert_same_pose(fk_batch(sols), poses)
    # continuous: a path sitting on the wrist singularity keeps J4 from the seed throughout
    path = ik_batch(np.array([fk(wrist)] * 4), seed_deg=[20, -80, 170, 35, 0, 100])
    np.testing.assert_allclose(path[:, 3], 35.0, atol=1e-9)
    assert_same_pose(fk_batch(path), np.array([fk(wrist)] * 4))


@pytest.mark.parametrize("poses", ["abc", [[1, 2, "x", 4, 5, 6]], [[1, 2, 3]], None, [[1e400] * 6],
                                   [[10**400, 0, 0, 0, 0, 0]]])
def test_batch_garbage_gets_a_clear_error(poses):
    with pytest.raises(IKError, match="poses"):
        ik_batch(poses, continuous=False)
