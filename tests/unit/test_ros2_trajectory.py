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
from parolkit.ros2.urdf import trajectory_velocity_limits_rad_s

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
    with pytest.raises(TrajectoryRefused, match=r"point 0 is at time_from_start 0 but L1 is 0\.0873 rad away from the "
                       r"current position \(tolerance 0\.01 rad, \[ros2\] start_tolerance_rad\)"):
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
    # two points of the path on one tick: refused (only a LAST point is merged, when it is close)
    (NAMES, [_pt([1] * 6, 1.0), _pt([2] * 6, 1.004), _pt([3] * 6, 2.0)],
     r"point 1: time_from_start 1\.0040 s is not at least one control tick \(0\.0100 s\) after the previous point"),
    (NAMES, [_pt([1] * 6, 1.0), _pt([2] * 6, 1.004)],
     r"point 1: on the same control tick as point 0 \(a tick is 0\.0100 s\) but L1 is 0\.01745 rad away from it, "
     r"more than one tick of motion at its velocity limit \(0\.007492 rad\)"),
    (NAMES, [_pt([0] * 6, 0.0), _pt([1] * 6, 0.004)], r"point 1: time_from_start 0\.0040 s is not at least one"),
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
    # issue 27: MoveIt's start tolerance and the joint convention
    cfg = load_config(search_default_paths=False,
                      overrides={"ros2": {"start_tolerance_rad": 0.05, "joint_convention": "community"}})
    assert (cfg.ros2.start_tolerance_rad, cfg.ros2.joint_convention) == (0.05, "community")
    assert Ros2Settings().start_tolerance_rad == 0.01 and Ros2Settings().joint_convention == "parolkit"
    for bad in (0, -0.01, 0.2, math.nan, "0.01", True):
        with pytest.raises(ParolkitValueError, match=r"ros2\.start_tolerance_rad must be a number in \(0, 0\.1\], got"):
            Ros2Settings(start_tolerance_rad=bad)  # type: ignore[arg-type]
    with pytest.raises(ParolkitValueError,
                       match=r"ros2\.joint_convention must be one of \['community', 'parolkit'\], got 'urdf'"):
        load_config(search_default_paths=False, overrides={"ros2": {"joint_convention": "urdf"}})


# ---- issue 27: plans MoveIt makes are taken -------------------------------------------------------------------


def test_the_start_tolerance_is_moveits_001_rad_by_default_and_configurable() -> None:
    def start_at(off_rad: float) -> TrajectoryPoint:
        rad = [math.radians(v) for v in START]
        rad[3] += off_rad
        return TrajectoryPoint(rad, 0.0)

    path = plan_joint_trajectory(NAMES, [start_at(0.0099), _pt([0, 0, 0, 5, 0, 0], 1.0)], START, PAROL6, 100.0)
    assert path.first_index == 1 and path.points == 1  # within MoveIt's 0.01 rad: only the start
    with pytest.raises(TrajectoryRefused, match=r"L4 is 0\.0101 rad away .* \(tolerance 0\.01 rad"):
        plan_joint_trajectory(NAMES, [start_at(0.0101), _pt([0, 0, 0, 5, 0, 0], 1.0)], START, PAROL6, 100.0)
    with pytest.raises(TrajectoryRefused, match=r"L4 is 0\.0020 rad away .* \(tolerance 0\.001 rad"):
        plan_joint_trajectory(NAMES, [start_at(0.002), _pt([0, 0, 0, 5, 0, 0], 1.0)], START, PAROL6, 100.0,
                              start_tolerance_rad=0.001)
    path = plan_joint_trajectory(NAMES, [start_at(-0.04), _pt([0, 0, 0, 5, 0, 0], 1.0)], START, PAROL6, 100.0,
                                 start_tolerance_rad=0.05)
    assert path.first_index == 1


def _moveit_tail(last_dt: float) -> list[TrajectoryPoint]:
    """A MoveIt-style trajectory of J1 (start at 0, velocities everywhere) whose last point
    comes ``last_dt`` s after the point before it (time parameterisation resampled at 0.1 s)."""
    v = [0.0, 4.0, 4.0, 1.0]
    pos = [0.0, 0.2, 0.6, 0.85]
    pts = [_pt([p, 0, 0, 0, 0, 0], 0.1 * k, vel_deg_s=[vk, 0, 0, 0, 0, 0]) for k, (p, vk) in enumerate(zip(pos, v))]
    pts.append(_pt([0.85 + 1.0 * last_dt / 2, 0, 0, 0, 0, 0], 0.3 + last_dt, vel_deg_s=[0] * 6))
    return pts


def test_a_last_point_less_than_a_tick_after_the_one_before_is_merged_into_it() -> None:
    pts = _moveit_tail(0.003)  # the last point at 0.303 s: on tick 30 like the point at 0.3 s
    path = plan_joint_trajectory(NAMES, pts, START, PAROL6, 100.0)
    assert path.merged == 3 and path.first_index == 1 and path.points == 3
    assert path.notes == ("point 3 merged into the last point (on the same control tick)",)
    assert path.ticks == 30  # the last point on its own tick, round(0.303 * 100)
    assert path.move.times_s[-1] == 0.303
    np.testing.assert_allclose(path.move.points_deg[-1][0], START[0] + 0.85 + 0.0015, atol=1e-9)
    assert path.move.velocities_deg_s is not None and path.move.velocities_deg_s[-1] == (0.0,) * 6
    # a last point a whole tick later is a point of its own: nothing merged
    path = plan_joint_trajectory(NAMES, _moveit_tail(0.012), START, PAROL6, 100.0)
    assert path.merged is None and path.points == 4 and path.ticks == 31 and path.notes == ()


def test_a_last_point_on_the_tick_before_it_but_further_than_a_tick_of_motion_is_refused() -> None:
    pts = _moveit_tail(0.003)
    reach_deg = math.degrees(float(trajectory_velocity_limits_rad_s(PAROL6, 100.0)[0])) / 100.0  # 0.429 deg
    last = pts[-1]
    for gap, ok in ((reach_deg * 0.999, True), (reach_deg * 1.01, False)):
        rad = list(pts[-2].positions_rad)
        rad[0] += math.radians(gap)
        pts[-1] = TrajectoryPoint(rad, last.time_s, last.velocities_rad_s)
        if ok:  # merged; a tick's motion at full speed from a slow tail: the planner's acceleration check
            with pytest.raises(TrajectoryRefused, match=r"point 4 \(t = 0\.303 s\): .*too abrupt .* J1 acceleration"
                               r".*without the message's point 3, merged into the last\)$"):
                plan_joint_trajectory(NAMES, pts, START, PAROL6, 100.0)
        else:
            with pytest.raises(TrajectoryRefused, match=r"point 4: on the same control tick as point 3 .* L1 is "):
                plan_joint_trajectory(NAMES, pts, START, PAROL6, 100.0)


def test_the_urdf_velocity_limit_is_exactly_what_a_trajectory_may_ask_for() -> None:
    """A trajectory at the URDF's velocity limit runs on time; 1 % over it is refused (the
    planner would stretch it: late), with the factor to slow it down by."""
    ramp, cruise = 0.4, 0.1  # s: from rest to full speed (cubic), at full speed, back to rest
    for j in range(6):
        vmax_deg = math.degrees(float(trajectory_velocity_limits_rad_s(PAROL6, 100.0)[j]))
        lo, hi = PAROL6.safe_limits_deg[j]
        start = list(START)
        start[j] = lo + 1.0  # from one end of the range towards the other
        for scale, ok in ((1.0, True), (1.01, False)):
            v = vmax_deg * scale
            at_speed = [v if i == j else 0.0 for i in range(6)]
            q = [math.radians(a) for a in start]
            pts = []
            for dq, t, vel in ((v * ramp / 2, ramp, at_speed), (v * cruise, ramp + cruise, at_speed),
                               (v * ramp / 2, 2 * ramp + cruise, [0.0] * 6)):
                q[j] += math.radians(dq)
                pts.append(TrajectoryPoint(list(q), t, [math.radians(x) for x in vel]))
            assert math.degrees(q[j]) < hi
            if ok:
                path = plan_joint_trajectory(NAMES, pts, start, PAROL6, 100.0)
                assert path.ticks == 90, j
            else:
                late = (r"point 2 \(t = 0\.900 s\): the path cannot run on time \(it would end at 0\.9\d\d s\): "
                        rf"J{j + 1} needs \d+ steps/s .* multiply the times")
                with pytest.raises(TrajectoryRefused, match=late):
                    plan_joint_trajectory(NAMES, pts, start, PAROL6, 100.0)


def test_the_community_convention_is_converted_before_anything_else() -> None:
    from parolkit.ros2.convention import COMMUNITY

    targets = [[5, -5, 5, 5, 5, -5], [10, -8, 8, 8, 8, -8]]
    vel = [[4, -3, 2, 1, 3, -2], [0] * 6]
    ours = [_pt([0] * 6, 0.0), *(_pt(o, t, vel_deg_s=v) for o, t, v in zip(targets, (1.5, 3.0), vel))]
    comm = [TrajectoryPoint(list(COMMUNITY.to_ros_rad(np.degrees(p.positions_rad))), p.time_s,
                            None if p.velocities_rad_s is None else list(COMMUNITY.rate_to_ros(p.velocities_rad_s)))
            for p in ours]
    a = plan_joint_trajectory(NAMES, ours, START, PAROL6, 100.0)
    b = plan_joint_trajectory(NAMES, comm, START, PAROL6, 100.0, convention=COMMUNITY)
    np.testing.assert_allclose(b.move.points_deg, a.move.points_deg, atol=1e-9)
    np.testing.assert_allclose(b.move.velocities_deg_s, a.move.velocities_deg_s, atol=1e-9)  # type: ignore[arg-type]
    assert (a.ticks, a.first_index) == (b.ticks, b.first_index) == (300, 1)
    # the community's values read as parolkit's are far from the current position: refused
    with pytest.raises(TrajectoryRefused, match=r"point 0 is at time_from_start 0 but L3 is 3\.1416 rad away"):
        plan_joint_trajectory(NAMES, comm, START, PAROL6, 100.0)
