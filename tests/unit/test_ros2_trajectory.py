"""JointTrajectory -> MoveJoint segments (parolkit.ros2.trajectory) and the [ros2] config section.

Pure planning: no DDS, no controller.  A trajectory is refused as a whole, with the point and
the reason, before anything would be sent.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from parolkit.config import Ros2Settings, load_config
from parolkit.errors import ParolkitValueError
from parolkit.robot import PAROL6
from parolkit.ros2.trajectory import TrajectoryPoint, TrajectoryRefused, plan_joint_trajectory

NAMES = ["L1", "L2", "L3", "L4", "L5", "L6"]
START = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)


def _pt(offset_deg: list[float], t: float, order: list[int] | None = None) -> TrajectoryPoint:
    rad = [math.radians(a + b) for a, b in zip(START, offset_deg)]
    if order is not None:
        rad = [rad[i] for i in order]
    return TrajectoryPoint(rad, t)


def test_points_become_whole_tick_segments_in_degrees_with_the_joints_reordered() -> None:
    order = [5, 4, 3, 2, 1, 0]
    names = [NAMES[i] for i in order]
    segs = plan_joint_trajectory(
        names, [_pt([5, -5, 5, 5, 5, -5], 1.504, order), _pt([10, -8, 8, 8, 8, -8], 3.0, order)],
        START, PAROL6, 100.0)
    assert [s.ticks for s in segs] == [150, 150]  # 1.504 s is due at tick 150, 3.0 s at tick 300
    np.testing.assert_allclose(segs[1].target_deg, np.array(START) + [10, -8, 8, 8, 8, -8], atol=1e-9)
    assert segs[0].duration_s == pytest.approx(1.5)


def test_a_first_point_at_time_zero_is_the_start_and_must_be_the_current_position() -> None:
    segs = plan_joint_trajectory(NAMES, [_pt([0] * 6, 0.0), _pt([5, 0, 0, 0, 0, 0], 1.0)], START, PAROL6, 100.0)
    assert len(segs) == 1 and segs[0].ticks == 100
    with pytest.raises(TrajectoryRefused, match=r"point 0 is at time_from_start 0 but L1 is 0\.0873 rad away"):
        plan_joint_trajectory(NAMES, [_pt([5, 0, 0, 0, 0, 0], 0.0)], START, PAROL6, 100.0)


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
