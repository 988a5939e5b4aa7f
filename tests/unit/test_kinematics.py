"""Forward kinematics, pose conventions, tools, Jacobian and import cost of parolkit.kinematics."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from parolkit.config import Config, ToolSettings
from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.kinematics import (
    TOOLS,
    Tool,
    fk,
    fk_batch,
    fk_frames,
    fk_matrix,
    get_tool,
    jacobian,
    manipulability,
    matrix_to_pose,
    pose_to_matrix,
    singularity_distance,
)
from parolkit.robot import PAROL6

DATA = Path(__file__).resolve().parents[1] / "data" / "fk_reference.json"
CASES = json.loads(DATA.read_text())["cases"]
LIM = PAROL6.safe_limits_deg


def wrap_deg(d):
    return (np.asarray(d) + 180.0) % 360.0 - 180.0


def random_joints(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(LIM[:, 0], LIM[:, 1], size=(n, 6))


# ---------------------------------------------------------------------------------------------
# FK against the reference data
# ---------------------------------------------------------------------------------------------


def test_reference_file_has_50_cases():
    assert len(CASES) == 50


@pytest.mark.parametrize("case", CASES, ids=[str(i) for i in range(len(CASES))])
def test_fk_matches_reference_pose_and_matrices(case):
    pose = fk(case["joints_deg"])
    expected = np.array(case["tcp_pose"])
    assert np.abs(pose[:3] - expected[:3]).max() <= 1e-6  # mm (reference is rounded to 1e-6)
    # angles compared modulo 360 (-180 and 180 are the same angle at the gimbal lock)
    assert np.abs(wrap_deg(pose[3:] - expected[3:])).max() <= 1e-6
    np.testing.assert_allclose(fk_matrix(case["joints_deg"]), case["tcp_matrix"], atol=1e-9)
    np.testing.assert_allclose(fk_matrix(case["joints_deg"], "flange"), case["flange_matrix"], atol=1e-9)


def test_fk_batch_matches_reference_and_single_calls():
    q = np.array([c["joints_deg"] for c in CASES])
    poses = fk_batch(q)
    expected = np.array([c["tcp_pose"] for c in CASES])
    assert np.abs(poses[:, :3] - expected[:, :3]).max() <= 1e-6
    assert np.abs(wrap_deg(poses[:, 3:] - expected[:, 3:])).max() <= 1e-6
    mats = fk_batch(q, as_matrix=True)
    np.testing.assert_allclose(mats, [c["tcp_matrix"] for c in CASES], atol=1e-9)
    singles = np.array([fk(v) for v in q])
    np.testing.assert_allclose(poses[:, :3], singles[:, :3], atol=1e-9)
    assert np.abs(wrap_deg(poses[:, 3:] - singles[:, 3:])).max() < 1e-9


def test_spec_examples_of_the_pose_convention():
    np.testing.assert_allclose(fk([0, -90, 180, 0, 0, 180]), [262.57, 0, 288.75, 0, 90, -180], atol=1e-9)
    np.testing.assert_allclose(fk([90, -90, 180, 0, 0, 180]), [0, 262.57, 288.75, -90, 0, -90], atol=1e-9)


def test_fk_frames_chain_agrees_with_closed_form_fk():
    for q in random_joints(50, seed=3):
        frames = fk_frames(q)
        assert frames.shape == (8, 4, 4)
        np.testing.assert_allclose(frames[0], np.eye(4))
        np.testing.assert_allclose(frames[7], fk_matrix(q), atol=1e-12)
        np.testing.assert_allclose(frames[6], fk_matrix(q, "flange"), atol=1e-12)
        # the wrist is spherical: frames 4, 5, 6 share their origin
        np.testing.assert_allclose(frames[4, :3, 3], frames[6, :3, 3], atol=1e-12)
        np.testing.assert_allclose(frames[5, :3, 3], frames[6, :3, 3], atol=1e-12)


def test_fk_accepts_out_of_limit_angles_but_rejects_non_finite_values():
    fk([200, 10, 0, 0, 170, -30])  # geometry, not a limit check
    with pytest.raises(ParolkitValueError, match="J3 is not a finite number"):
        fk([0, 0, float("nan"), 0, 0, 0])
    with pytest.raises(ParolkitValueError, match="6 values"):
        fk([0, 0, 0])
    with pytest.raises(ParolkitValueError, match=r"\(N, 6\)"):
        fk_batch(np.zeros((4, 5)))


def test_fk_batch_of_a_single_row_returns_one_row():
    assert fk_batch([0, -90, 180, 0, 0, 180]).shape == (1, 6)
    assert fk_batch(np.zeros((3, 6)), as_matrix=True).shape == (3, 4, 4)


# ---------------------------------------------------------------------------------------------
# pose conventions
# ---------------------------------------------------------------------------------------------


def test_pose_matrix_round_trip_on_random_poses():
    rng = np.random.default_rng(5)
    poses = np.column_stack([rng.uniform(-300, 300, (200, 3)), rng.uniform(-179, 179, (200, 1)),
                             rng.uniform(-89, 89, (200, 1)), rng.uniform(-179, 179, (200, 1))])
    mats = pose_to_matrix(poses)
    assert mats.shape == (200, 4, 4)
    back = matrix_to_pose(mats)
    np.testing.assert_allclose(back, poses, atol=1e-9)
    for p, m in zip(poses[:20], mats[:20]):
        np.testing.assert_allclose(pose_to_matrix(p), m, atol=1e-15)
        np.testing.assert_allclose(matrix_to_pose(m), p, atol=1e-9)


def test_rotation_order_is_rx_c_ry_b_rz_a():
    a, b, c = 20.0, 30.0, 40.0
    def rx(t):
        return np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])

    def ry(t):
        return np.array([[math.cos(t), 0, math.sin(t)], [0, 1, 0], [-math.sin(t), 0, math.cos(t)]])

    def rz(t):
        return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])
    expected = rx(math.radians(c)) @ ry(math.radians(b)) @ rz(math.radians(a))
    m = pose_to_matrix([1, 2, 3, a, b, c])
    np.testing.assert_allclose(m[:3, :3], expected, atol=1e-15)
    np.testing.assert_allclose(m[:3, 3], [0.001, 0.002, 0.003])


def test_gimbal_lock_puts_the_whole_rotation_into_c():
    for b in (90.0, -90.0):
        m = pose_to_matrix([0, 0, 0, 30, b, 10])
        pose = matrix_to_pose(m)
        assert pose[3] == 0.0 and pose[4] == pytest.approx(b)
        np.testing.assert_allclose(pose_to_matrix(pose), m, atol=1e-12)


def test_matrix_to_pose_rejects_non_rotations():
    m = np.eye(4)
    m[0, 0] = 2.0
    with pytest.raises(ParolkitValueError, match="not a proper rotation"):
        matrix_to_pose(m)
    m = np.eye(4)
    m[3, 0] = 1.0
    with pytest.raises(ParolkitValueError, match=r"last row must be \[0, 0, 0, 1\]"):
        matrix_to_pose(m)
    with pytest.raises(ParolkitValueError, match="B is not a finite number"):
        pose_to_matrix([0, 0, 0, 0, float("inf"), 0])


# ---------------------------------------------------------------------------------------------
# tools
# ---------------------------------------------------------------------------------------------


def test_builtin_tools_default_and_flange():
    assert set(TOOLS) == {"default", "flange"}
    assert get_tool(None) is TOOLS["default"]
    np.testing.assert_allclose(TOOLS["default"].pose, [-45.25, 0, 62.8, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(TOOLS["flange"].matrix, np.eye(4))
    q = [10, -80, 170, 5, 20, 100]
    # the default tool is the original DH row 6 (d = -62.8 mm, a = -45.25 mm)
    np.testing.assert_allclose(fk_matrix(q, "flange") @ TOOLS["default"].matrix, fk_matrix(q), atol=1e-15)


def test_user_tool_from_config_and_from_tool_object():
    cfg = Config(tools=(ToolSettings("pen", (0, 0, 120, 0, 0, 0)),))
    pen = get_tool("pen", cfg)
    assert pen.name == "pen"
    np.testing.assert_allclose(pen.matrix[:3, 3], [0, 0, 0.12])
    q = [0, -90, 180, 0, 0, 180]
    np.testing.assert_allclose(fk_matrix(q, pen), fk_matrix(q, "flange") @ pen.matrix, atol=1e-15)
    assert get_tool(pen) is pen
    with pytest.raises(ParolkitValueError, match=r"unknown tool 'gripper' \(known: default, flange, pen\)"):
        get_tool("gripper", cfg)


def test_tool_rejects_bad_matrices():
    with pytest.raises(ParolkitValueError, match="not a proper rotation"):
        Tool("bad", np.diag([1.0, 1.0, -1.0, 1.0]))
    with pytest.raises(ParolkitValueError, match="4x4"):
        Tool("bad", np.eye(3))
    with pytest.raises(ParolkitValueError, match="pose"):
        Tool.from_pose("bad", [0, 0, 0])


def test_rotated_tool_pose_round_trips_through_its_matrix():
    tool = Tool.from_pose("angled", [10, -20, 80, 15, -30, 45])
    np.testing.assert_allclose(tool.pose, [10, -20, 80, 15, -30, 45], atol=1e-9)
    q = random_joints(20, seed=8)
    np.testing.assert_allclose(fk_batch(q, tool, as_matrix=True),
                               fk_batch(q, "flange", as_matrix=True) @ tool.matrix, atol=1e-15)


# ---------------------------------------------------------------------------------------------
# Jacobian, manipulability, singularities
# ---------------------------------------------------------------------------------------------


def _numeric_jacobian(q_deg, tool=None, h=1e-6):
    base = fk_matrix(q_deg, tool)
    jac = np.zeros((6, 6))
    for i in range(6):
        dq = np.array(q_deg, dtype=float)
        dq[i] += math.degrees(h)
        m = fk_matrix(dq, tool)
        jac[:3, i] = (m[:3, 3] - base[:3, 3]) / h
        dr = m[:3, :3] @ base[:3, :3].T  # small rotation
        jac[3:, i] = np.array([dr[2, 1] - dr[1, 2], dr[0, 2] - dr[2, 0], dr[1, 0] - dr[0, 1]]) / (2 * h)
    return jac


def test_jacobian_matches_finite_differences_of_fk():
    for q in random_joints(10, seed=11):
        np.testing.assert_allclose(jacobian(q), _numeric_jacobian(q), atol=2e-6)
        np.testing.assert_allclose(jacobian(q, "flange"), _numeric_jacobian(q, "flange"), atol=2e-6)


def test_manipulability_vanishes_at_the_wrist_singularity():
    q = [20, -80, 170, 10, 0, 100]
    assert manipulability(q) < 1e-12
    assert manipulability([20, -80, 170, 10, 30, 100]) > 1e-4


def test_singularity_distance_measures():
    info = singularity_distance([90, -90, 180, 0, 0, 180])
    assert info.nearest == "wrist" and info.wrist_deg == 0.0 and info.near
    assert info.shoulder_mm == pytest.approx(199.77, abs=1e-9)  # wrist centre to J1 axis
    far = singularity_distance([0, -90, 180, 0, 45, 0])
    assert far.wrist_deg == pytest.approx(45.0) and not far.near
    # elbow stretched: q3 = PHI3 (+ 360)
    stretched = math.degrees(math.atan2(PAROL6.dh[3].d, PAROL6.dh[2].a)) + 360.0
    el = singularity_distance([0, -60, stretched, 0, 45, 0])
    assert el.elbow_deg == pytest.approx(0.0, abs=1e-9) and el.nearest == "elbow"


def test_exceptions_are_parolkit_errors():
    with pytest.raises(ParolkitError):
        get_tool(3.5)


# ---------------------------------------------------------------------------------------------
# import cost
# ---------------------------------------------------------------------------------------------


def test_import_pulls_in_no_heavy_library():
    code = (
        "import sys, parolkit.kinematics as k; "
        "heavy = [m for m in ('roboticstoolbox', 'spatialmath', 'numba', 'scipy', 'toppra', "
        "'matplotlib') if m in sys.modules]; print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_user_tool_shadows_builtin_of_the_same_name_and_is_cached():
    cfg = Config(tools=(ToolSettings("flange", (0, 0, 50, 0, 0, 0)), ToolSettings("pen", (0, 0, 120, 0, 0, 0))))
    np.testing.assert_allclose(get_tool("flange", cfg).matrix[:3, 3], [0, 0, 0.05])
    assert get_tool("pen", cfg) is get_tool("pen", cfg)
    assert get_tool("flange") is TOOLS["flange"]
