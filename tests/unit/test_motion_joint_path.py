"""MoveJointPath: timed joint points planned as ONE trajectory (parolkit.motion.joint_path), and the
JointPathMove value object's field checks."""

from __future__ import annotations

import numpy as np
import pytest

from parolkit.errors import ParolkitValueError
from parolkit.motion import JointPathMove, PlanningError, plan, validate
from parolkit.motion.joint_path import hermite, spline_velocities
from parolkit.moves import MAX_PATH_POINTS
from parolkit.robot import PAROL6

RATE = 100.0
START = np.array([90.0, -90.0, 180.0, 0.0, 0.0, 180.0])
OFFSETS = [[8, -5, 6, 10, 8, -12], [15, -8, 10, 5, 15, -20], [20, -10, 12, 15, 20, -25]]
TIMES = [1.5, 3.0, 4.0]
SPD = PAROL6.steps_per_deg


def _move(offsets=OFFSETS, times=TIMES, velocities=None, start=START) -> JointPathMove:  # type: ignore[no-untyped-def]
    return JointPathMove([list(start + np.array(o, dtype=float)) for o in offsets], times, velocities)


def _refusal(move: JointPathMove, start: np.ndarray = START) -> PlanningError:
    with pytest.raises(PlanningError) as info:
        plan(move, start, rate_hz=RATE)
    return info.value


def test_each_point_is_commanded_exactly_on_its_tick_and_the_path_ends_on_the_last_at_rest() -> None:
    traj = plan(_move(), START, rate_hz=RATE)
    assert len(traj) == 400 and traj.t[0] == pytest.approx(0.01) and traj.duration == pytest.approx(4.0)
    assert set(traj.commands.tolist()) == {156}  # position tracking with feed-forward speeds
    for offset, t in zip(OFFSETS, TIMES):
        target = np.rint((START + offset) * SPD)
        assert np.array_equal(traj.positions[round(t * RATE) - 1], target), t
    assert np.array_equal(traj.positions[-1], np.rint((START + OFFSETS[-1]) * SPD))
    assert not traj.speeds[-1].any()
    # it starts from rest: the first sample is less than a step's worth of a speed away
    assert np.all(np.abs(traj.positions[0] - np.rint(START * SPD)) <= np.abs(traj.speeds[0]) / RATE + 1)


def test_a_point_is_due_on_the_tick_nearest_its_time() -> None:
    traj = plan(_move(OFFSETS[:2], [1.504, 2.996]), START, rate_hz=RATE)
    assert len(traj) == 300
    assert np.array_equal(traj.positions[149], np.rint((START + OFFSETS[0]) * SPD))


def test_the_path_does_not_stop_at_its_interior_points_and_keeps_within_every_limit() -> None:
    traj = plan(_move(), START, rate_hz=RATE)
    for t in TIMES[:-1]:
        assert np.abs(traj.speeds[round(t * RATE) - 1]).max() > 100  # passing, not resting
    limits = validate.speed_limits(PAROL6, RATE, position_tracked=True).array
    assert np.all(np.abs(traj.speeds) <= limits)
    accel = np.abs(np.diff(np.vstack([np.zeros(6), traj.speeds]), axis=0)) * RATE
    assert np.all(accel <= PAROL6.accel_limit_steps_s2 * (1 + validate.ACCEL_TOLERANCE))
    # and the sampled positions follow the feed-forward speeds (they are one curve)
    moved = np.diff(traj.positions, axis=0)
    mid = 0.5 * (traj.speeds[1:] + traj.speeds[:-1]) / RATE
    assert np.abs(moved - mid).max() <= 1.0  # steps: rounding to steps and the cubic's curvature


def test_the_spline_is_c2_at_unevenly_spaced_interior_points() -> None:
    knot_s = np.array([0.0, 0.7, 1.5, 1.8, 3.0])
    q = np.array([[0.0, 1.0], [3.0, -2.0], [1.0, 4.0], [2.0, 0.0], [5.0, 1.0]])
    m = spline_velocities(knot_s, q)
    assert not m[0].any() and not m[-1].any()
    h = np.diff(knot_s)[:, None]
    # second derivative of each Hermite segment at its end (s = 1) and at its start (s = 0)
    end = (6 * q[:-1] + 2 * h * m[:-1] - 6 * q[1:] + 4 * h * m[1:]) / h**2
    begin = (-6 * q[:-1] - 4 * h * m[:-1] + 6 * q[1:] - 2 * h * m[1:]) / h**2
    np.testing.assert_allclose(end[:-1], begin[1:], atol=1e-9)


def test_hermite_segments_end_exactly_on_their_point_with_its_velocity() -> None:
    q0, q1 = np.array([[0.1, -3.3]]), np.array([[7.123456789, 2.2]])
    v0, v1 = np.array([[1.0, 2.0]]), np.array([[-4.0, 0.5]])
    q, qd = hermite(np.array([1.0]), np.array([0.37]), q0, q1, v0, v1)
    assert np.array_equal(q, q1) and np.allclose(qd, v1)
    q, qd = hermite(np.array([0.0]), np.array([0.37]), q0, q1, v0, v1)
    assert np.allclose(q, q0) and np.allclose(qd, v0)


def test_given_velocities_are_the_feed_forward_speeds_at_the_points() -> None:
    velocities = [[4, -2, 3, -1, 5, -6], [3, -1, 1, 4, 2, -2], [0] * 6]
    traj = plan(_move(velocities=velocities), START, rate_hz=RATE)
    spline = plan(_move(), START, rate_hz=RATE)
    for v, t in zip(velocities, TIMES):
        assert np.array_equal(traj.speeds[round(t * RATE) - 1], np.rint(np.array(v) * SPD))
    assert not np.array_equal(traj.speeds, spline.speeds)
    assert "as given" in traj.notes[0] and "spline" in spline.notes[0]


def test_one_point_is_a_smooth_rest_to_rest_move_to_it() -> None:
    traj = plan(_move(OFFSETS[:1], [2.0]), START, rate_hz=RATE)
    assert len(traj) == 200 and np.array_equal(traj.positions[-1], np.rint((START + OFFSETS[0]) * SPD))
    j1 = traj.positions[:, 0]
    assert np.all(np.diff(j1) >= 0)  # monotonic: no overshoot with zero end velocities


def test_too_fast_is_refused_naming_the_joint_the_segment_the_value_the_limit_and_the_fix() -> None:
    err = _refusal(_move([[-5, 0, 0, 0, 0, 0], [-45, 0, 0, 0, 0, 0]], [1.0, 1.3]))
    text = str(err)
    assert text.startswith("MoveJointPath refused at t=")
    assert "too fast between the start and point 0 (t=1.000 s): J1 speed" in text
    assert "exceeds the position-tracking maximum 4884 steps/s" in text
    assert "multiply the times by at least" in text
    assert (err.joint, err.point) == (0, 0) and abs(err.value or 0) > 4884


def test_a_given_velocity_over_a_joints_maximum_speed_is_refused_at_its_point() -> None:
    err = _refusal(_move(OFFSETS[:2], [2.0, 4.0], [[60, 0, 0, 0, 0, 0], [0] * 6]))
    assert "too fast at point 0 (t=2.000 s): J1 speed 6827 steps/s exceeds" in str(err)
    assert "multiply the times (and the velocities divided) by at least" in str(err)
    assert (err.joint, err.point) == (0, 0)


def test_a_path_within_the_maximum_speed_but_over_the_tracking_maximum_runs_stretched_with_a_warning() -> None:
    """The seed's speed rule (issue 24, item 7): a given velocity of 5689 steps/s on J1 (of
    6500, above the position-tracking maximum 4884) runs: every time and velocity scaled by one
    factor, the points kept, a warning naming the joint, the speed and the stretched time."""
    move = _move(OFFSETS[:2], [2.0, 4.0], [[50, 0, 0, 0, 0, 0], [0] * 6])
    traj = plan(move, START, rate_hz=RATE)
    warning = traj.notes[-1]
    assert warning.startswith("warning: J1 needs 5689 steps/s to pass the points at the times given, above its "
                              "position-tracking maximum 4884 steps/s"), warning
    assert "the move runs stretched from 4.00 s to" in warning
    factor = traj.duration / 4.0
    assert 5689 / 4884 <= factor < 5689 / 4884 * 1.02
    limit = 4884
    assert np.abs(traj.speeds[:, 0]).max() <= limit
    times = traj.move.times_s  # the stretched times: each the given one x the same factor
    assert np.allclose(np.asarray(times) / np.asarray(move.times_s), times[-1] / 4.0)
    for k, p in enumerate(OFFSETS[:2]):  # the points, at their stretched ticks
        assert np.array_equal(traj.positions[round(times[k] * RATE) - 1], np.rint((START + np.asarray(p)) * SPD))


def test_too_abrupt_is_refused_naming_the_acceleration_and_its_limit() -> None:
    start = np.array([0.0, -90.0, 180.0, 0.0, 0.0, 180.0])
    err = _refusal(_move([[3, 0, 0, 0, 0, 0], [0] * 6], [0.2, 0.4], start=start), start)
    assert ("too abrupt between the start and point 0 (t=0.200 s): J1 acceleration 48640 steps/s^2 exceeds its "
            "limit 19500 steps/s^2; multiply the times by at least 1.58 (the last point at t >= 0.64 s)") in str(err)
    assert (err.joint, err.point) == (0, 0)
    # and the suggested times work
    plan(_move([[3, 0, 0, 0, 0, 0], [0] * 6], [0.32, 0.64], start=start), start, rate_hz=RATE)


def test_a_point_outside_the_joint_range_is_refused_naming_it() -> None:
    err = _refusal(_move([[5, 0, 0, 0, 0, 0], [40, 0, 0, 0, 0, 0]], [1.0, 5.0]))
    assert "point 1 (t=5.000 s): J1 = 130.000 deg is outside the joint range -123.047 .. 123.047 deg" in str(err)
    assert (err.joint, err.point) == (0, 1)


def test_a_spline_overshooting_a_joint_limit_between_points_is_refused_naming_the_segment() -> None:
    start = np.array([0.0, -90.0, 180.0, 0.0, 0.0, 180.0])
    err = _refusal(_move([[0, 0, 0, 0, 89.9, 0], [0, 0, 0, 0, 89.9, 0], [0] * 6], [1.0, 2.0, 3.0], start=start),
                   start)
    assert ("the path leaves the joint range between point 0 (t=1.000 s) and point 1 (t=2.000 s): J5 = "
            in str(err))
    assert "above the upper limit 90.000 deg" in str(err) and "add a point there" in str(err)
    assert (err.joint, err.point) == (4, 1)


@pytest.mark.parametrize(("times", "message", "point"), [
    ([0.004, 1.0], r"point 0 \(t=0\.004 s\) falls on tick 0, not after the start \(tick 0\): points must be at "
                   r"least one control tick \(0\.010 s\) apart", 0),
    ([1.0, 1.004], r"point 1 \(t=1\.004 s\) falls on tick 100, not after point 0 \(t=1\.000 s, tick 100\)", 1),
])
def test_points_less_than_a_tick_apart_are_refused(times: list[float], message: str, point: int) -> None:
    with pytest.raises(PlanningError, match=message) as info:
        plan(_move(OFFSETS[:2], times), START, rate_hz=RATE)
    assert info.value.point == point


def test_the_move_holds_its_fields_as_tuples_and_names_its_end() -> None:
    m = JointPathMove([[1, 2, 3, 4, 5, 6]], [2])
    assert m.points_deg == ((1.0, 2.0, 3.0, 4.0, 5.0, 6.0),) and m.times_s == (2.0,)
    assert m.velocities_deg_s is None and m.duration_s == 2.0 and m.target_deg == (1, 2, 3, 4, 5, 6)
    assert m.name == "MoveJointPath"


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"points_deg": [], "times_s": []}, f"points_deg must hold 1..{MAX_PATH_POINTS} points, got 0"),
    ({"points_deg": [[0] * 6] * 201, "times_s": list(range(1, 202))}, "points_deg must hold 1..200 points, got 201"),
    ({"points_deg": "abc", "times_s": [1]}, "points_deg must be a list of joint positions"),
    ({"points_deg": [[0] * 6, [0] * 5], "times_s": [1, 2]}, "points_deg[1] must be 6 numbers, got 5"),
    ({"points_deg": [[0, 0, float("inf"), 0, 0, 0]], "times_s": [1]}, "points_deg[0][2] must be a finite number"),
    ({"points_deg": [[0] * 6], "times_s": [1, 2]}, "times_s must hold one time per point (1), got 2"),
    ({"points_deg": [[0] * 6], "times_s": [0]}, "times_s[0] must be in (0, 3600] s, got 0"),
    ({"points_deg": [[0] * 6], "times_s": [4000]}, "times_s[0] must be in (0, 3600] s, got 4000"),
    ({"points_deg": [[0] * 6], "times_s": ["x"]}, "times_s[0] must be a number, got 'x'"),
    ({"points_deg": [[0] * 6] * 2, "times_s": [2, 2]},
     "times_s[1] = 2 s must be greater than times_s[0] = 2 s (times strictly increasing)"),
    ({"points_deg": [[0] * 6], "times_s": [1], "velocities_deg_s": [[0] * 6] * 2},
     "velocities_deg_s must hold one 6-vector per point (1), got 2"),
    ({"points_deg": [[0] * 6], "times_s": [1], "velocities_deg_s": [[0] * 7]},
     "velocities_deg_s[0] must be 6 numbers, got 7"),
    ({"points_deg": [[0] * 6], "times_s": [1], "velocities_deg_s": [[0, 0, 0, 0.5, 0, 0]]},
     "velocities_deg_s[0][3] must be 0 deg/s (the path ends at rest on its last point), got 0.5"),
])
def test_bad_fields_are_refused_naming_the_field_and_the_allowed_range(kwargs: dict, message: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(ParolkitValueError) as info:
        JointPathMove(**kwargs)
    assert message in str(info.value)
