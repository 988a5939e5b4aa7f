"""Cartesian moves and smooth paths: samples lie on their geometry, limits hold, refusals are
precise.  Geometry is checked with forward kinematics of the planner's joint angles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from parolkit import kinematics as kin
from parolkit.motion import (
    ArcCenterMove,
    ArcParamMove,
    BlendMove,
    CartJog,
    CartMove,
    CartRelTRFMove,
    CircleMove,
    HelixMove,
    LineSegment,
    PlanningError,
    SplineMove,
    plan,
)
from parolkit.robot import PAROL6

#: a comfortable start: wrist away from its singularity (J5 = 40 deg)
START = np.array([90.0, -100.0, 150.0, 10.0, 40.0, 170.0])
P0 = kin.fk(START)
#: position-tracked (156) plans keep to this at 100 Hz (issue 12: the board's GO TO loop starts
#: every tick 1.27x faster than the stream moves)
VTRACK = PAROL6.max_tracked_speed_steps_s(100)
#: per-joint acceleration limits, steps/s^2 (a duration given may need more: then with a warning)
AMAX = PAROL6.accel_limit_steps_s2


def _tcp(tr) -> tuple[np.ndarray, np.ndarray]:
    """Planned TCP positions (N, 3) mm and rotations (N, 3, 3), start included."""
    q = np.vstack([tr.start_deg[None, :], tr.planned_deg])
    m = kin.fk_batch(q, None, as_matrix=True)
    return m[:, :3, 3] * 1e3, m[:, :3, :3]


def _assert_limits(tr) -> None:
    lim = PAROL6.limits_steps_array
    assert np.all(tr.positions >= lim[:, 0]) and np.all(tr.positions <= lim[:, 1])
    assert np.all(np.abs(tr.speeds) <= VTRACK)
    steps = np.abs(np.diff(np.vstack([np.rint(tr.start_deg * PAROL6.steps_per_deg), tr.positions]), axis=0))
    assert np.all(steps <= VTRACK / tr.rate_hz + 1)  # every tick's target step, from the start on
    acc = np.abs(np.diff(np.vstack([np.zeros(6), tr.speeds.astype(float)]), axis=0)) * tr.rate_hz
    if not any(n.startswith("warning: ") for n in tr.notes):
        assert np.all(acc <= AMAX * 1.02 + 100)


def _rot_angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1)))


def test_movecart_samples_lie_on_the_straight_segment_with_monotonic_progress():
    target = P0 + np.array([50, -30, -40, 10, 0, 10])
    tr = plan(CartMove(target), START)
    pos, rot = _tcp(tr)
    a, b = P0[:3], target[:3]
    d = (b - a) / np.linalg.norm(b - a)
    rel = pos - a
    along = rel @ d
    dev = np.linalg.norm(rel - np.outer(along, d), axis=1)
    assert dev.max() <= 0.01
    assert np.all(np.diff(along) >= -1e-9)
    assert along[-1] == pytest.approx(np.linalg.norm(b - a), abs=0.01)
    # orientation by SLERP: the angle turned is proportional to the progress
    r_end = kin.pose_to_matrix(target)[:3, :3]
    total = _rot_angle(rot[0], r_end)
    turned = np.array([_rot_angle(rot[0], r) for r in rot[::25]])
    assert np.allclose(turned, total * along[::25] / along[-1], atol=0.01)
    _assert_limits(tr)
    # POSITION tracking: the last sample is exactly the target joints, speed zero
    assert np.array_equal(tr.positions[-1], np.rint(tr.planned_deg[-1] * PAROL6.steps_per_deg))
    assert np.all(tr.speeds[-1] == 0)
    # the rounded steps are still within a step's worth of the line
    fk_steps = kin.fk_batch(tr.positions_deg())[:, :3]
    rel2 = fk_steps - a
    assert np.linalg.norm(rel2 - np.outer(rel2 @ d, d), axis=1).max() < 0.2


def test_movecart_default_speed_is_the_documented_conservative_mean_speed():
    target = P0 + np.array([0, 0, -60, 0, 0, 0])
    tr = plan(CartMove(target), START)
    pos, _ = _tcp(tr)
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=1) * tr.rate_hz
    v50 = PAROL6.cart_linear_speed_from_percent(50)  # 31 mm/s mean
    assert tr.duration == pytest.approx(60 / v50, abs=0.011)
    assert speed.max() == pytest.approx(1.5 * v50, rel=0.02)  # trapezoid, 1/3 phases
    assert any("50 %" in n for n in tr.notes)


def test_movecart_speed_percent_maps_to_linear_speed_and_slower_governs():
    target = P0 + np.array([0, 40, 0, 0, 0, 0])
    tr = plan(CartMove(target, speed_pct=20), START)
    pos, _ = _tcp(tr)
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=1) * tr.rate_hz
    v20 = PAROL6.cart_linear_speed_from_percent(20)
    assert tr.duration == pytest.approx(40 / v20, abs=0.011)
    assert speed.max() == pytest.approx(1.5 * v20, rel=0.02)
    # a large rotation with a short translation: the angular speed governs
    target2 = P0 + np.array([0, 0, 2, 0, 0, 30])
    tr2 = plan(CartMove(target2, speed_pct=20), START)
    w = PAROL6.cart_angular_speed_from_percent(20)
    _, rot = _tcp(tr2)
    ang = np.array([_rot_angle(rot[i], rot[i + 1]) for i in range(len(rot) - 1)]) * tr2.rate_hz
    assert tr2.duration == pytest.approx(30 / w, abs=0.011)
    assert ang.max() == pytest.approx(1.5 * w, rel=0.03)


def test_movecart_with_duration_is_exact_and_poly_ends_at_rest():
    target = P0 + np.array([30, 0, -30, 0, 0, 0])
    tr = plan(CartMove(target, duration_s=3.0), START)
    assert tr.duration == pytest.approx(3.0) and len(tr) == 300
    pos, _ = _tcp(tr)
    v = np.linalg.norm(np.diff(pos, axis=0), axis=1) * 100
    assert v[0] < 0.05 and v[-1] < 0.05


def test_movecart_too_fast_for_duration_is_refused_with_the_minimum():
    target = P0 + np.array([0, 100, -100, 0, 0, 0])
    with pytest.raises(PlanningError) as ei:
        plan(CartMove(target, duration_s=0.2), START)
    e = ei.value
    assert e.move == "MoveCart" and e.joint is not None and e.time_s is not None
    assert "give a duration of at least" in str(e)


def test_unreachable_pose_is_refused_naming_the_point():
    with pytest.raises(PlanningError, match="reach") as ei:
        plan(CartMove([0, 600, 250, P0[3], P0[4], P0[5]]), START)
    assert ei.value.time_s is not None


def test_path_grazing_the_wrist_singularity_takes_the_in_range_wrist_branch_or_is_refused_naming_joint_and_time():
    a = np.array([90.0, -90.0, 180.0, 0.0, 10.0, 180.0])
    b = kin.fk([90.0, -90.0, 180.0, 5.0, -10.0, 175.0])
    # on the start's wrist branch J4 would swing past its limit: J4 passes J5 = 0 onto the
    # other branch instead (issue 24, item 8), the TCP exact, and ends on the pose
    tr = plan(CartMove(b), a)
    assert np.abs(tr.planned_deg[-1] - [90.0, -90.0, 180.0, 5.0, -10.0, 175.0]).max() < 0.01
    assert any("J4 on its other wrist branch" in n for n in tr.notes)
    _assert_limits(tr)
    # with too little time for that turn: refused naming J4, the time and J4's range
    with pytest.raises(PlanningError) as ei:
        plan(CartMove(b, duration_s=1.0), a)
    e = ei.value
    assert e.joint == 3 and e.time_s is not None and 0 < e.time_s <= 1.0
    assert "J4" in str(e) and "-105.5" in str(e)


def test_a_circle_from_the_wrist_singularity_follows_the_circle_from_the_first_tick_in_its_time():
    """Standby (J5 = 0): the singular-area policy keeps the TCP exactly on the circle from the
    first sample while J4/J6 turn, the move takes exactly t, the orientation deviation is
    bounded, reported, and gone at the end."""
    standby = np.array(PAROL6.standby_deg)  # J5 = 0 after homing
    p = kin.fk(standby)
    centre = p[:3] + np.array([0, 0, -30])
    tr = plan(CircleMove(centre, 30, "XZ", duration_s=4.0), standby)
    assert tr.duration == pytest.approx(4.0, abs=1e-9)
    note = next(n for n in tr.notes if n.startswith("wrist singular area"))
    pos, rot = _tcp(tr)
    assert np.abs(np.linalg.norm(pos - centre, axis=1) - 30).max() <= 1e-3  # on the circle, always
    assert np.linalg.norm(pos[10] - p[:3]) > 0.01  # moving within 0.1 s (a smooth start)
    r0 = kin.fk_matrix(standby)[:3, :3]
    dev = np.array([_rot_angle(r, r0) for r in rot])
    reported = float(note.split("deviates up to ")[1].split(" deg")[0])
    assert dev.max() == pytest.approx(reported, abs=0.02) and 0.1 < dev.max() <= 10.0
    assert dev[-1] <= 0.01  # ends on its pose
    _assert_limits(tr)


def test_movecart_reltrf_pure_rotation_keeps_the_tcp_in_place():
    tr = plan(CartRelTRFMove([0, 0, 0, 0, 25, 0]), START)
    pos, rot = _tcp(tr)
    assert np.linalg.norm(pos - P0[:3], axis=1).max() <= 0.01
    r0 = kin.fk_matrix(START)[:3, :3]
    want = r0 @ kin.pose_to_matrix([0, 0, 0, 0, 25, 0])[:3, :3]
    assert _rot_angle(rot[-1], want) < 0.01


def test_movecart_reltrf_translation_moves_along_the_tool_axis():
    tr = plan(CartRelTRFMove([0, 0, -30, 0, 0, 0]), START)
    pos, _ = _tcp(tr)
    z_tool = kin.fk_matrix(START)[:3, 2]
    assert np.allclose(pos[-1], P0[:3] - 30 * z_tool, atol=0.01)


def test_slow_joints_stretch_the_duration_and_say_so():
    near = np.array([90.0, -100.0, 150.0, 10.0, 4.0, 170.0])  # close to the wrist singularity
    p = kin.fk(near)
    tr = plan(CartMove(p + np.array([15, 0, 0, 0, 0, 0]), speed_pct=100), near)
    assert any("stretched" in n for n in tr.notes)
    _assert_limits(tr)


@pytest.mark.parametrize("profile", ["ruckig", "toppra"])
def test_jerk_limited_and_time_optimal_cartesian_paths_stay_on_the_line(profile):
    target = P0 + np.array([40, -20, -30, 0, 0, 0])
    tr = plan(CartMove(target, profile=profile), START)
    pos, _ = _tcp(tr)
    a, b = P0[:3], target[:3]
    d = (b - a) / np.linalg.norm(b - a)
    rel = pos - a
    along = rel @ d
    assert np.linalg.norm(rel - np.outer(along, d), axis=1).max() <= 0.01
    assert np.all(np.diff(along) >= -1e-9)
    _assert_limits(tr)


def test_circle_samples_lie_on_the_circle_full_turn_back_to_start():
    c = P0[:3] + np.array([0, 0, -25])
    tr = plan(CircleMove(c, 25, "XZ"), START)
    pos, _ = _tcp(tr)
    y_axis = np.array([0, 1.0, 0])
    rel = pos - c
    assert np.abs(rel @ y_axis).max() <= 0.01  # in the plane
    assert np.abs(np.linalg.norm(rel, axis=1) - 25).max() <= 0.01
    ang = np.unwrap(np.arctan2(rel[:, 0], rel[:, 2]))  # XZ plane, normal +Y: z -> x
    assert abs(ang[-1] - ang[0]) == pytest.approx(2 * math.pi, abs=1e-3)
    assert np.all(np.diff(ang) * np.sign(ang[-1] - ang[0]) >= -1e-9)
    assert np.linalg.norm(pos[-1] - P0[:3]) <= 0.01
    _assert_limits(tr)


def test_circle_off_the_start_gets_an_approach_first():
    c = P0[:3] + np.array([0, 0, -40])
    tr = plan(CircleMove(c, 25, "XZ", duration_s=8), START)
    assert any("approach" in n for n in tr.notes)
    pos, _ = _tcp(tr)
    rel = pos - c
    on = np.abs(np.linalg.norm(rel, axis=1) - 25) <= 0.01
    assert on[-600:].all()  # the circle itself (8 s) is entirely on the geometry


def test_arc_by_centre_lies_on_the_circle_and_ends_on_the_end_pose():
    end = P0 + np.array([20, -20, 0, 0, 0, 0])
    c = P0[:3] + np.array([0, -20, 0])
    tr = plan(ArcCenterMove(end, c), START)
    pos, _ = _tcp(tr)
    assert np.abs(np.linalg.norm(pos - c, axis=1) - 20).max() <= 0.01
    assert np.linalg.norm(pos[-1] - end[:3]) <= 0.01


def test_arc_by_radius_and_angle_lies_on_its_circle():
    end = P0 + np.array([20, -20, 0, 0, 0, 0])
    tr = plan(ArcParamMove(end, 20, 90), START)
    pos, _ = _tcp(tr)
    # centre from three samples: the circumcentre
    a, b, c = pos[0], pos[len(pos) // 2], pos[-1]
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    centre = a + (np.cross(n, ab) * (ac @ ac) + np.cross(ac, n) * (ab @ ab)) / (2 * (n @ n))
    assert np.abs(np.linalg.norm(pos - centre, axis=1) - 20).max() <= 0.01
    with pytest.raises(PlanningError, match="angle_deg 45 does not match"):
        plan(ArcParamMove(end, 20, 45), START)
    with pytest.raises(PlanningError, match="radius_mm 5 is too small"):
        plan(ArcParamMove(end, 5, 90), START)


def test_helix_samples_lie_on_the_helix():
    c = P0[:3] + np.array([15, 0, 0])
    tr = plan(HelixMove(c, 15, 10, -20), START)
    pos, _ = _tcp(tr)
    rel = pos - c
    r = np.hypot(rel[:, 0], rel[:, 1])
    assert np.abs(r - 15).max() <= 0.01
    phi = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    turned = phi - phi[0]
    # rise proportional to the angle: -20 mm over 2 turns (pitch 10 mm)
    assert np.allclose(rel[:, 2] - rel[0, 2], -10 * turned / (2 * math.pi), atol=0.01)
    assert turned[-1] == pytest.approx(4 * math.pi, abs=1e-3)


def test_spline_passes_through_every_waypoint_smoothly():
    wps = [P0 + np.array([20, 0, -10, 0, 0, 0]), P0 + np.array([40, 10, -20, 0, 0, 0]),
           P0 + np.array([0, 20, -20, 0, 0, 0])]
    tr = plan(SplineMove(wps), START)
    pos, _ = _tcp(tr)
    step = np.linalg.norm(np.diff(pos, axis=0), axis=1).max()
    for w in wps:
        assert np.linalg.norm(pos - w[:3], axis=1).min() <= step / 2 + 0.01
    assert np.linalg.norm(pos[-1] - wps[-1][:3]) <= 0.01
    _assert_limits(tr)


def test_blended_path_is_continuous_in_position_and_velocity():
    x, y, z, A, B, C = P0
    segs = [LineSegment([x + 40, y, z, A, B, C]), LineSegment([x + 40, y, z - 40, A, B, C]),
            LineSegment([x, y, z - 40, A, B, C])]
    tr = plan(BlendMove(segs, blend_radius_mm=10), START)
    pos, _ = _tcp(tr)
    vel = np.diff(pos, axis=0) * tr.rate_hz  # mm/s between ticks
    dv = np.linalg.norm(np.diff(vel, axis=0), axis=1)
    # continuous velocity: the change per tick stays small (rounding a 10 mm corner at
    # <= 47 mm/s cruise needs about v^2/r = 220 mm/s^2 -> a few mm/s per tick; a sharp corner
    # would change the velocity by ~66 mm/s in one tick)
    assert dv.max() < 6.0
    # the corners are rounded: the path passes near, not through, them
    corner = np.array([x + 40, y, z])
    assert 2.0 < np.linalg.norm(pos - corner, axis=1).min() < 10.0
    assert np.linalg.norm(pos[-1] - np.array([x, y, z - 40])) <= 0.01
    _assert_limits(tr)


def test_blend_time_sets_the_rounding_from_the_path_speed():
    x, y, z, A, B, C = P0
    segs = [LineSegment([x + 40, y, z, A, B, C]), LineSegment([x + 40, y, z - 40, A, B, C])]
    tr = plan(BlendMove(segs, blend_time_s=0.5, speed_pct=50), START)
    pos, _ = _tcp(tr)
    r = PAROL6.cart_linear_speed_from_percent(50) * 0.5 / 2
    corner = np.array([x + 40, y, z])
    # a cubic corner cut r before/after the corner passes about r/4..r/2 from it
    assert r / 5 < np.linalg.norm(pos - corner, axis=1).min() < r


def test_cartesian_jog_wrf_moves_straight_at_the_jog_speed():
    tr = plan(CartJog("WRF", "Z-", 50, 1.0), START)
    pos, _ = _tcp(tr)
    v = PAROL6.cart_linear_speed_from_percent(50)
    assert np.allclose(pos[:, :2], P0[:2], atol=0.01)
    assert pos[-1, 2] == pytest.approx(P0[2] - v * 1.0, abs=0.01)
    assert np.all(tr.speeds[-1] == 0)


def test_cartesian_jog_trf_rotation_turns_about_the_tool_axis_in_place():
    tr = plan(CartJog("TRF", "RZ+", 40, 0.5), START)
    pos, rot = _tcp(tr)
    assert np.linalg.norm(pos - P0[:3], axis=1).max() <= 0.01
    w = PAROL6.cart_angular_speed_from_percent(40)
    assert _rot_angle(rot[0], rot[-1]) == pytest.approx(w * 0.5, abs=0.01)
    # the tool z axis does not move when turning about it
    assert np.allclose(rot[-1][:, 2], rot[0][:, 2], atol=1e-6)


def test_cartesian_jog_stops_at_the_edge_of_the_workspace_with_a_note():
    tr = plan(CartJog("WRF", "Z-", 100, 20.0), START)
    assert tr.duration < 20.0 and any(n.startswith("stopped") for n in tr.notes)
    assert np.all(np.abs(tr.speeds) <= VTRACK)


def test_start_pose_that_differs_from_the_current_pose_is_approached_first():
    x, y, z, A, B, C = P0
    tr = plan(CircleMove([x, y, z - 45], 20, "XZ", start_pose=[x, y, z - 25, A, B, C]), START)
    assert tr.notes and "start_pose" in tr.notes[0]
    pos, _ = _tcp(tr)
    assert np.abs(np.linalg.norm(pos[-300:] - np.array([x, y, z - 45]), axis=1) - 20).max() <= 0.01


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(d=st.tuples(st.floats(-60, 60), st.floats(-60, 60), st.floats(-60, 60),
                   st.floats(-15, 15), st.floats(-15, 15), st.floats(-15, 15)),
       pct=st.one_of(st.none(), st.floats(1, 100)))
def test_property_movecart_is_refused_or_inside_every_limit_on_the_line(d, pct):
    target = P0 + np.array(d)
    try:
        tr = plan(CartMove(target, speed_pct=pct), START)
    except PlanningError as e:
        assert e.move == "MoveCart" and str(e).startswith("MoveCart refused")
        return
    _assert_limits(tr)
    pos, _ = _tcp(tr)
    a, b = P0[:3], target[:3]
    if np.linalg.norm(b - a) > 1e-3:
        dd = (b - a) / np.linalg.norm(b - a)
        rel = pos - a
        assert np.linalg.norm(rel - np.outer(rel @ dd, dd), axis=1).max() <= 0.01


def test_cartesian_jog_from_the_homed_pose_moves_along_x_from_the_first_tick():
    """Standby (J5 = 0), X+ needs J4 at -90 deg: the TCP moves along X at the jog speed from
    the first tick (no wrist unwind first) while J4/J6 turn; the orientation deviation is
    reported in the notes and stays within the policy's bound."""
    standby = np.array(PAROL6.standby_deg)
    p = kin.fk(standby)
    tr = plan(CartJog("WRF", "X+", 50, 0.5), standby)
    assert tr.notes[0].startswith("wrist singular area") and "deviates up to" in tr.notes[0]
    pos, rot = _tcp(tr)
    v = PAROL6.cart_linear_speed_from_percent(50)
    assert pos[1, 0] == pytest.approx(p[0] + v / 100, abs=0.01)  # the first tick
    assert pos[-1, 0] == pytest.approx(p[0] + v * 0.5, abs=0.01)
    assert np.allclose(pos[:, 1:], p[1:3], atol=1e-3)  # only X changes, never Y or Z
    assert tr.planned_deg[-1, 3] < -10  # J4 is turning towards -90
    r0 = kin.fk_matrix(standby)[:3, :3]
    assert max(_rot_angle(r, r0) for r in rot) <= 10.0
    assert np.all(np.abs(tr.speeds) <= VTRACK)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(off=st.tuples(st.floats(-30, 30), st.floats(-30, 30), st.floats(-30, 30)),
       radius=st.floats(5, 40), plane=st.sampled_from(["XY", "XZ", "YZ"]), cw=st.booleans(),
       frame=st.sampled_from(["WRF", "TRF"]))
def test_property_circles_are_refused_or_on_the_circle_inside_every_limit(off, radius, plane, cw, frame):
    centre = np.array(off) if frame == "TRF" else P0[:3] + np.array(off)
    move = CircleMove(centre, radius, plane, frame=frame, clockwise=cw, duration_s=8)
    try:
        tr = plan(move, START)
    except PlanningError as e:
        assert str(e).startswith("SmoothCircle refused")
        return
    _assert_limits(tr)
    pos, _ = _tcp(tr)
    t0 = kin.fk_matrix(START)
    c = centre if frame == "WRF" else t0[:3, 3] * 1e3 + t0[:3, :3] @ centre
    circle = pos[-800:]  # the circle itself lasts exactly 8 s (any approach comes first)
    assert np.abs(np.linalg.norm(circle - c, axis=1) - radius).max() <= 0.01


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(duration=st.sampled_from([1e-9, 1e-4, 0.005, 0.01, 0.015, 0.02, 0.05]),
       dz=st.floats(0.2, 8.0), dx=st.floats(-3.0, 3.0))
def test_a_cartesian_move_never_asks_a_tick_for_more_than_the_maximum_speed(duration, dz, dx):
    """Issue 12: MOVECARTRELTRF with a duration of 1e-9 s was one sample whose step from the
    start was up to 2.1x what the maximum speed covers in a tick (its sample speed was 0).
    Either the plan is refused, or every tick's step, from the start on, is within it."""
    from parolkit.errors import ParolkitError
    from parolkit.robot import deg_to_steps

    start = [60, -80, 170, 10, 40, 170]
    try:
        traj = plan(CartRelTRFMove([dx, 0, dz, 0, 0, 0], duration_s=duration), start, model=PAROL6, rate_hz=100)
    except ParolkitError:
        return
    pos = np.vstack([np.asarray(deg_to_steps(start))[None, :], traj.positions])
    per_tick = np.abs(np.diff(pos, axis=0)).max(axis=0)
    assert np.all(per_tick <= VTRACK / 100 + 1), per_tick
