"""JointTrajectory -> one MoveJointPath (parolkit.ros2.trajectory) and the [ros2] config section.

Pure planning: no DDS, no controller.  A trajectory is refused as a whole, with the point and
the reason, before anything would be sent.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from parolkit.config import Ros2Settings, load_config
from parolkit.errors import ParolkitValueError
from parolkit.moves import JointPathMove
from parolkit.robot import PAROL6
from parolkit.ros2.trajectory import TrajectoryPoint, TrajectoryRefused, plan_joint_trajectory

NAMES = ["L1", "L2", "L3", "L4", "L5", "L6"]
START = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)


def _pt(offset_deg: list[float], t: float, order: list[int] | None = None,
        vel_deg_s: list[float] | None = None) -> TrajectoryPoint:
    rad = [math.radians(a + b) for a, b in zip(START, offset_deg)]
    vel = None if vel_deg_s is None else [math.radians(v) for v in vel_deg_s]
    if order is not None:
        rad = [rad[i] for i in order]
        vel = None if vel is None else [vel[i] for i in order]
    return TrajectoryPoint(rad, t, vel)


def test_the_points_become_one_path_in_degrees_with_the_joints_reordered() -> None:
    order = [5, 4, 3, 2, 1, 0]
    names = [NAMES[i] for i in order]
    path = plan_joint_trajectory(
        names, [_pt([5, -5, 5, 5, 5, -5], 1.504, order), _pt([10, -8, 8, 8, 8, -8], 3.0, order)],
        START, PAROL6, 100.0)
    assert isinstance(path.move, JointPathMove) and path.points == 2
    assert path.ticks == 300 and path.first_index == 0  # the last point is due at tick 300
    assert path.move.times_s == (1.504, 3.0)  # the controller rounds them to ticks (150, 300)
    np.testing.assert_allclose(path.move.points_deg[1], np.array(START) + [10, -8, 8, 8, 8, -8], atol=1e-9)
    assert path.move.velocities_deg_s is None  # none given: the controller's spline


def test_a_first_point_at_time_zero_is_the_start_and_must_be_the_current_position() -> None:
    path = plan_joint_trajectory(NAMES, [_pt([0] * 6, 0.0), _pt([5, 0, 0, 0, 0, 0], 1.0)], START, PAROL6, 100.0)
    assert path.points == 1 and path.ticks == 100 and path.first_index == 1
    with pytest.raises(TrajectoryRefused, match=r"point 0 is at time_from_start 0 but L1 is 0\.0873 rad away"):
        plan_joint_trajectory(NAMES, [_pt([5, 0, 0, 0, 0, 0], 0.0)], START, PAROL6, 100.0)


def test_the_velocities_are_used_in_degrees_when_every_point_of_the_path_has_them() -> None:
    order = [5, 4, 3, 2, 1, 0]
    names = [NAMES[i] for i in order]
    points = [_pt([0] * 6, 0.0, order), _pt([5, -5, 5, 5, 5, -5], 1.5, order, [4, -3, 2, 1, 3, -2]),
              _pt([10, -8, 8, 8, 8, -8], 3.0, order, [0] * 6)]
    path = plan_joint_trajectory(names, points, START, PAROL6, 100.0)
    assert path.move.velocities_deg_s is not None
    np.testing.assert_allclose(path.move.velocities_deg_s, [[4, -3, 2, 1, 3, -2], [0] * 6], atol=1e-9)
    # one point without them: the controller's spline for the whole path
    points[1] = _pt([5, -5, 5, 5, 5, -5], 1.5, order)
    assert plan_joint_trajectory(names, points, START, PAROL6, 100.0).move.velocities_deg_s is None


def test_a_refusal_names_the_messages_point_when_its_point_0_was_the_start() -> None:
    with pytest.raises(TrajectoryRefused) as info:
        plan_joint_trajectory(NAMES, [_pt([0] * 6, 0.0), _pt([-5, 0, 0, 0, 0, 0], 1.0), _pt([-45, 0, 0, 0, 0, 0], 1.3)],
                              START, PAROL6, 100.0)
    text = str(info.value)
    assert text.startswith("point 1 (t = 1.000 s): MoveJointPath refused at t=")
    assert "too fast between the start and point 0 (t=1.000 s): J1 speed" in text
    assert text.endswith("(the planner counts the path's points from the message's point 1 as 0)")


@pytest.mark.parametrize(("names", "points", "message"), [
    (NAMES[:5], [_pt([1] * 6, 1.0)], r"missing joints \['L6'\]"),
    ([*NAMES[:5], "J6"], [_pt([1] * 6, 1.0)], r"unknown joints \['J6'\]"),
    ([*NAMES, "L1"], [_pt([1] * 6, 1.0)], r"repeated joints \['L1'\]"),
    (NAMES, [], "no points"),
    (NAMES, [TrajectoryPoint([0.0] * 5, 1.0)], "point 0: 5 positions for 6 joints"),
    (NAMES, [TrajectoryPoint([math.nan] * 6, 1.0)], "point 0: positions and time_from_start must be finite"),
    (NAMES, [_pt([1] * 6, 1.0), _pt([2] * 6, 1.004)], r"point 1: time_from_start 1\.0040 s is not at least one"),
    (NAMES, [_pt([-40, 0, 0, 0, 0, 0], 0.3)], r"point 0 \(t = 0\.300 s\): .*too fast.*J1"),
    (NAMES, [_pt([40, 0, 0, 0, 0, 0], 3.0)], r"point 0 .*J1 = 130\.000 deg is outside the joint range"),
    (NAMES, [_pt([0] * 6, 1.0, vel_deg_s=[0] * 5)], r"point 0: 5 velocities for 6 joints \(give 6 or none\)"),
    (NAMES, [_pt([0] * 6, 1.0, vel_deg_s=[0, math.inf, 0, 0, 0, 0])], "point 0: velocities must be finite"),
    (NAMES, [_pt([1] * 6, 1.0, vel_deg_s=[1] * 6), _pt([2] * 6, 2.0, vel_deg_s=[0, 0, 3, 0, 0, 0])],
     r"point 1: the last point's velocities must be 0 \(the trajectory ends at rest\), L3 has 0\.05236 rad/s"),
    (NAMES, [_pt([0] * 6, 0.01 * (k + 1)) for k in range(202)], "the trajectory has 202 points; at most 201"),
    (NAMES, [_pt([0] * 6, 0.01 * (k + 1)) for k in range(201)],
     "the trajectory has 201 points after its start; at most 200 are accepted"),
])
def test_a_trajectory_that_cannot_be_followed_is_refused_with_the_reason(names, points, message) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(TrajectoryRefused, match=message):
        plan_joint_trajectory(names, points, START, PAROL6, 100.0)


def test_ros2_config_section_validates_and_overrides() -> None:
    assert load_config(search_default_paths=False).ros2 == Ros2Settings()
    cfg = load_config(search_default_paths=False, overrides={"ros2": {"domain": 7, "namespace": "lab/arm1"}})
    assert (cfg.ros2.domain, cfg.ros2.namespace) == (7, "lab/arm1")
    with pytest.raises(ParolkitValueError, match=r"ros2.domain must be an integer in 0..232, got 300"):
        Ros2Settings(domain=300)
    with pytest.raises(ParolkitValueError, match=r"ros2.namespace must be a ROS name .* got '1arm'"):
        Ros2Settings(namespace="1arm")
    with pytest.raises(ParolkitValueError, match=r"unknown key ros2.rate"):
        load_config(search_default_paths=False, overrides={"ros2": {"rate": 5}})
