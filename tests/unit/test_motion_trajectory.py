"""Trajectory value object, conversions and planner options (rate, tracking, tool)."""

from __future__ import annotations

import numpy as np
import pytest

from parolkit import kinematics as kin
from parolkit.errors import ParolkitValueError
from parolkit.motion import (
    CartMove,
    JointMove,
    PlanningError,
    SpeedJointMove,
    Tracking,
    Trajectory,
    plan,
)
from parolkit.robot import PAROL6

START = np.array([90.0, -100.0, 150.0, 10.0, 40.0, 170.0])


def test_arrays_are_read_only_plain_numpy_with_the_documented_dtypes():
    tr = plan(JointMove([60, -80, 160, 0, 20, 150], duration_s=2), START)
    assert tr.t.dtype == float and tr.positions.dtype == np.int64 and tr.speeds.dtype == np.int64
    assert tr.commands.dtype == np.uint8 and len(tr) == len(tr.t) == 200
    with pytest.raises(ValueError):
        tr.positions[0, 0] = 0
    assert np.allclose(tr.positions_deg(), tr.positions / PAROL6.steps_per_deg)
    assert np.allclose(tr.speeds_deg_s(), tr.speeds / PAROL6.steps_per_deg)
    assert np.allclose(tr.final_deg, [60, -80, 160, 0, 20, 150], atol=0.01)
    assert "MoveJoint" in repr(tr) and "200 samples" in tr.summary()


def test_other_control_rates_space_the_samples_accordingly():
    tr = plan(JointMove([60, -80, 160, 0, 20, 150], duration_s=2), START, rate_hz=50)
    assert len(tr) == 100 and tr.t[0] == pytest.approx(0.02) and tr.rate_hz == 50
    with pytest.raises(ParolkitValueError, match="rate_hz"):
        plan(JointMove([60, -80, 160, 0, 20, 150]), START, rate_hz=0)


def test_bad_start_is_rejected():
    with pytest.raises(ParolkitValueError, match="start_deg"):
        plan(JointMove([60, -80, 160, 0, 20, 150]), [0, 0, 0])


def test_tcp_path_is_subsampled_forward_kinematics_from_start_to_end():
    tr = plan(CartMove(kin.fk(START) + np.array([0, 0, -40, 0, 0, 0]), duration_s=4), START)
    path = tr.tcp_path_mm(max_points=50)
    assert path.shape[1] == 3 and len(path) <= 50
    assert np.allclose(path[0], kin.fk(START)[:3], atol=1e-6)
    assert path[-1][2] == pytest.approx(kin.fk(START)[2] - 40, abs=0.1)
    assert tr.poses().shape == (len(tr), 6)


def test_cartesian_speed_tracking_streams_123_and_ends_at_rest():
    tr = plan(CartMove(kin.fk(START) + np.array([20, 0, 0, 0, 0, 0]), tracking="speed"), START)
    assert set(tr.commands.tolist()) == {Tracking.SPEED.board_command}
    assert np.all(tr.speeds[-1] == 0)


def test_a_tool_changes_the_tcp_that_follows_the_line():
    flange = kin.get_tool("flange")
    p0 = kin.fk(START, flange)
    tr = plan(CartMove(p0 + np.array([0, 0, -30, 0, 0, 0]), duration_s=3), START, tool=flange)
    q = np.vstack([START, tr.planned_deg])
    pos = kin.fk_batch(q, flange)[:, :3]
    assert np.allclose(pos[:, :2], p0[:2], atol=0.01)
    assert pos[-1, 2] == pytest.approx(p0[2] - 30, abs=0.01)


def test_concatenate_chains_times_and_keeps_notes():
    a = plan(JointMove([60, -80, 160, 0, 20, 150], duration_s=1.5), START)
    b = plan(SpeedJointMove([0, 0, 0, 0, 0, 5], 0.5), a.final_deg)
    c = Trajectory.concatenate([a, b], move="both", notes=["joined"])
    assert len(c) == len(a) + len(b)
    assert c.t[len(a)] == pytest.approx(a.duration + b.t[0])
    assert np.all(np.diff(c.t) > 0) and c.notes[0] == "joined"
    assert np.array_equal(c.start_deg, a.start_deg)


def test_planning_error_carries_the_fields_and_one_sentence():
    with pytest.raises(PlanningError) as ei:
        plan(JointMove([0, -90, 180, 0, 0, 180], duration_s=1.0), START)
    e = ei.value
    assert (e.move, e.joint_name) == ("MoveJoint", "J1")
    assert e.time_s is not None and e.value is not None and e.reason in str(e)
    assert str(e).startswith("MoveJoint refused at t=") and str(e).endswith(".")
