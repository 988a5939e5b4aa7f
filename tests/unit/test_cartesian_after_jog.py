"""Cartesian moves whose exact wrist, continued on the start's branch, leaves J4's range near
the wrist singularity (issue 24, item 8): after ``CARTJOG|WRF|X+|40|0.3`` from the standby pose
the wrist sits 0.5 deg from J5 = 0 with J5 < 0, and ``MOVECART|0|262.57|250|-90|0|-90|None|50``
passes within 0.2 deg of J5 = 0 to a pose whose in-range solution has J5 > 0 (J4 0, J5 12.3
deg); on the start's branch J4 would sweep to -180 deg.  The planner passes the singular area
onto the in-range branch (the singular-area policy, TCP position exact) and refuses only where
no branch keeps every joint in range, naming the joint, its value and its range."""

from __future__ import annotations

import math

import numpy as np
import pytest

from parolkit import kinematics as kin
from parolkit.motion import PlanningError, plan
from parolkit.moves import CartJog, CartMove
from parolkit.protocol.commands import parse_datagram
from parolkit.robot import PAROL6

STANDBY = np.array(PAROL6.standby_deg)
SPD = np.asarray(PAROL6.steps_per_deg, dtype=float)
JOG = "CARTJOG|WRF|X+|40|0.3"
MOVE = "MOVECART|0|262.57|250|-90|0|-90|None|50"
#: The board's counters after JOG from standby, read with GET_STATUS_JSON from the real
#: controller (`parolkit serve`, pre-homed simulated board, as tests/conftest.py starts it):
#: the MOVECART then was refused with "joint J4 would be -125.2 deg < -105.5".
MEASURED_STEPS = (10049, -31942, 58000, -967, -37, 34418)


def _move(text: str):
    return parse_datagram(text).command.move


def _jog_end() -> np.ndarray:
    """The joints (deg) the board ends on after JOG from standby: the counters of the jog's
    last frame (the pre-homed simulated board reaches them exactly)."""
    jog = plan(_move(JOG), STANDBY)
    return np.asarray(jog.positions[-1], dtype=float) / SPD


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1)))


def test_the_jog_planned_here_ends_where_the_real_controller_measured_it():
    assert tuple(int(v) for v in np.rint(_jog_end() * SPD)) == MEASURED_STEPS
    q = _jog_end()
    assert -0.6 < q[4] < -0.4 and q[3] == pytest.approx(-13.6, abs=0.1)  # J5 < 0, near the singularity


@pytest.mark.parametrize("start", ["planned", "measured"])
def test_movecart_after_the_jog_takes_the_in_range_wrist_branch_and_ends_on_its_pose(start):
    q0 = _jog_end() if start == "planned" else np.array(MEASURED_STEPS) / SPD
    move = _move(MOVE)
    tr = plan(move, q0)
    q = np.vstack([q0, tr.planned_deg])
    lim = PAROL6.safe_limits_deg
    assert np.all(q >= lim[:, 0]) and np.all(q <= lim[:, 1])
    steps = np.asarray(tr.positions)
    lim_steps = np.asarray(PAROL6.limits_steps)
    assert np.all(steps >= lim_steps[:, 0]) and np.all(steps <= lim_steps[:, 1])
    # the wrist crossed to J5 > 0 with J4 near 0 (the in-range branch), J4 never near -180
    assert q[-1, 3] == pytest.approx(0.0, abs=0.1) and q[-1, 4] == pytest.approx(12.33, abs=0.05)
    assert np.abs(q[:, 3]).max() < 14.0
    # continuous: no joint moves more than its maximum speed allows within a tick
    assert np.all(np.abs(np.diff(q, axis=0)) <= PAROL6.max_speed_deg_s / tr.rate_hz + 1e-9)
    # ends on the target pose
    m = kin.fk_batch(q, None, as_matrix=True)
    want = kin.pose_to_matrix(move.pose)
    assert np.linalg.norm(m[-1, :3, 3] - want[:3, 3]) * 1e3 < 0.1
    assert _angle_deg(m[-1, :3, :3], want[:3, :3]) < 0.1
    # the TCP on the straight line all along (the policy keeps the position exact) ...
    pos = m[:, :3, 3] * 1e3
    a, b = pos[0], pos[-1]
    u = (b - a) / np.linalg.norm(b - a)
    rel = pos - a
    assert np.linalg.norm(rel - np.outer(rel @ u, u), axis=1).max() < 0.01
    # ... and the orientation within a small, reported deviation while J4 turns
    note = next(n for n in tr.notes if n.startswith("wrist singular area"))
    dev = float(note.split("orientation deviates up to ")[1].split(" deg")[0])
    assert 0 < dev < 1.0
    assert "J4 on its other wrist branch past J5 = 0 (on the start's, J4 would be -12" in note


def test_on_the_starts_branch_alone_the_exact_path_leaves_j4s_range():
    """What the planner used to do: the branch-continuous exact IK refuses at J4; followed
    beyond the ranges it shows the sweep towards -180 deg."""
    from parolkit.motion.cartesian.geometry import Line, Path
    from parolkit.motion.cartesian.ik_along_path import poses_from_rotations

    q0 = _jog_end()
    t0 = kin.fk_matrix(q0)
    t1 = kin.pose_to_matrix(_move(MOVE).pose)
    pos, rots = Path([Line(t0[:3, 3] * 1e3, t1[:3, 3] * 1e3, t0[:3, :3], t1[:3, :3])]).evaluate(
        np.linspace(0, 1, 401)[1:])
    poses = poses_from_rotations(pos, rots)
    with pytest.raises(kin.IKError) as ei:
        kin.ik_batch(poses, q0)
    assert ei.value.joint == 3 and ei.value.value < -105.4
    free = kin.ik_batch(poses, q0, check_limits=False)
    assert free[-1, 3] == pytest.approx(-180.0, abs=0.01) and free[-1, 4] == pytest.approx(-12.33, abs=0.05)
    assert np.all(np.abs(np.diff(free[:, 3])) < 90)  # continuous (a sweep, not a hop)
    # the same poses are in range on the other branch at the end: J4 + 180, -J5, J6 - 180
    alt = free[-1] + np.array([0, 0, 0, 180, 0, -180])
    alt[4] = -alt[4]
    assert alt[3] == pytest.approx(0.0, abs=0.01) and alt[4] == pytest.approx(12.33, abs=0.05)
    assert np.allclose(kin.fk(alt), kin.fk(free[-1]), atol=1e-6)
    with pytest.raises(kin.IKError, match="continuous path only"):
        kin.ik_batch(poses, np.tile(q0, (len(poses), 1)), check_limits=False)


def test_when_no_branch_keeps_j6_in_range_the_refusal_names_joint_value_and_range():
    # the mirrored jog (J4 turns +13.6 deg) with the tool rolled 185 deg about its axis (J6
    # 351.4 deg): past the singularity the in-range J4 branch turns J6 the other way, over 360
    jog = plan(CartJog("WRF", "X-", 40, 0.3), STANDBY)
    q0 = np.asarray(jog.positions[-1], dtype=float) / SPD
    q0[5] += 185.0
    target = kin.fk(np.array([90.0, -91.6622, 166.0029, 0.0, 12.3328, 5.0]))
    with pytest.raises(PlanningError) as ei:
        plan(CartMove(target, speed_pct=50), q0)
    e = ei.value
    assert e.joint == 5 and 360.0 < e.value < 361.0
    assert "J6 would be 360." in e.reason and "(allowed 0.0 .. 360.0 deg)" in e.reason
    assert "on the start's, J4 would be 12" in e.reason and "(allowed -105.5 .. 105.5 deg)" in e.reason


def test_a_j4_range_refusal_away_from_the_wrist_singularity_is_unchanged():
    # J5 = 45 deg: no wrist turn near J5 = 0, so no other branch is tried
    q0 = np.array([90.0, -90.0, 180.0, 100.0, 45.0, 180.0])
    target = kin.fk(np.array([90.0, -90.0, 180.0, 110.0, 45.0, 180.0]))
    with pytest.raises(PlanningError, match=r"the path leaves the robot's reach at .*joint J4 would be 105\.\d deg "
                       r"> 105\.5 \(allowed -105\.5 \.\. 105\.5 deg\) following the path continuously"):
        plan(CartMove(target, speed_pct=50), q0)


def test_a_jog_continues_past_the_singularity_onto_the_in_range_branch():
    # a Z- jog from where the X+ jog ended passes J5 = 0 like the MoveCart; it used to stop
    # where J4 left its range on the start's branch
    q0 = _jog_end()
    tr = plan(CartJog("WRF", "Z-", 40, 1.0), q0)
    q = np.vstack([q0, tr.planned_deg])
    lim = PAROL6.safe_limits_deg
    assert np.all(q >= lim[:, 0]) and np.all(q <= lim[:, 1])
    assert not any("stopped" in n for n in tr.notes), tr.notes
    assert q[-1, 4] > 0.5  # across J5 = 0
    m = kin.fk_batch(q, None, as_matrix=True)
    d = (m[-1, :3, 3] - m[0, :3, 3]) * 1e3
    assert d[2] < -20 and abs(d[0]) < 0.05 and abs(d[1]) < 0.05
    note = next(n for n in tr.notes if n.startswith("wrist singular area"))
    assert "J4 on its other wrist branch" in note
