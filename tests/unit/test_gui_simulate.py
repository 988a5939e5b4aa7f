"""Simulate first (issue 26 item 3), the logic without a browser (parolkit.gui.simulate): the
planned run as a timeline of joints, its playback at 1x / 2x / 5x, the run speed's factor and
its scaling of Speed() lines, and the program's start pose.  The timelines come from real dry
runs of real programs (the planner, the collision check), not from made-up trajectories."""

from __future__ import annotations

import numpy as np
import pytest

from parolkit.collision import TABLE_ZONE, BoxZone
from parolkit.errors import ParolkitValueError
from parolkit.gui.simulate import (
    AT_START_DEG,
    MAX_FRAME_STEP_S,
    RUN_SPEED_MIN_PCT,
    SIM_SPEEDS,
    SimTimeline,
    Simulation,
    StartPose,
    duration_factor,
    run_speed_errors,
    run_speed_pct,
    scaled_override,
    sim_speed,
    start_pose,
)
from parolkit.kinematics import fk
from parolkit.robot import PAROL6
from parolkit.script import dry_run, parse

#: the box the J1 swing of test_collision_view's program drives into (its third line)
MONITOR = BoxZone("monitor", center=(141.0, 141.0, 334.0), size=(40.0, 50.0, 60.0), rpy=(0.0, 0.0, 30.0), margin=10.0)
START = (80.0, -90.0, 180.0, 0.0, 0.0, 180.0)


def _program(text: str):
    result = parse(text, "test")
    assert result.ok, result.errors
    return result.program


def _timeline(text: str, start=START, **kw) -> tuple[SimTimeline, object]:
    report = dry_run(_program(text), start, **kw)
    return SimTimeline.from_report(report), report


# ---- speeds ----------------------------------------------------------------------------------


def test_the_simulation_plays_at_1x_2x_or_5x_and_says_so_for_anything_else():
    assert [sim_speed(s) for s in (1, 2, 5)] == list(SIM_SPEEDS) == [1.0, 2.0, 5.0]
    for bad in (3, 0, -1, 10.0):
        with pytest.raises(ParolkitValueError, match=r"simulation speed must be one of 1x, 2x, 5x, got"):
            sim_speed(bad)
    for bad in ("2", True, None, float("nan")):
        with pytest.raises(ParolkitValueError, match="simulation speed must be a number"):
            sim_speed(bad)


def test_the_run_speed_is_10_to_100_percent_and_a_move_takes_100_over_it_times_its_planned_time():
    assert run_speed_pct(10) == RUN_SPEED_MIN_PCT and run_speed_pct(100) == 100.0 and run_speed_pct(30.0) == 30.0
    for bad in (9.9, 0, 101, -30):
        with pytest.raises(ParolkitValueError, match=r"run speed must be 10\.\.100 %, got"):
            run_speed_pct(bad)
    with pytest.raises(ParolkitValueError, match="run speed must be a number"):
        run_speed_pct("30")
    assert duration_factor(30) == pytest.approx(1 / 0.3)
    assert duration_factor(100) == 1.0
    with pytest.raises(ParolkitValueError, match="run speed"):
        duration_factor(5)


def test_a_speed_line_runs_at_its_share_of_the_run_speed_and_below_1_percent_is_an_error_at_its_line():
    assert scaled_override(50, 30) == 15.0
    assert scaled_override(100, 30) == 30.0
    assert scaled_override(10, 10) == 1.0
    with pytest.raises(ParolkitValueError, match=r"Speed\(5\) at the 10 % run speed would be 0\.5 %: the speed "
                                                 r"override is 1\.\.100 %; run at 20 % or more"):
        scaled_override(5, 10)
    program = _program("Begin()\nSpeed(5)\nMoveJoint(80, -90, 180, 0, 0, 180, t=1)\nSpeed(50)\nEnd()\n")
    errors = run_speed_errors(program, 10)
    assert [(e.line, e.col) for e in errors] == [(2, 1)]
    assert "run at 20 % or more" in errors[0].message
    assert run_speed_errors(program, 20) == []


# ---- the timeline ----------------------------------------------------------------------------


def test_the_timeline_plays_each_move_as_planned_holds_through_a_delay_and_slows_after_speed():
    text = ("Begin()\nMoveJoint(90, -90, 180, 0, 0, 180, t=1)\nDelay(0.5)\nSpeed(50)\n"
            "MoveJoint(70, -80, 170, 0, 10, 180, t=1)\nEnd()\n")
    tl, report = _timeline(text)
    move2, move5 = (traj for _, traj in report.segments)
    assert tl.lines == (2, 3, 5)
    assert tl.duration_s == pytest.approx(1.0 + 0.5 + 2.0)  # the second move at 50 %: twice its time
    f0 = tl.at(0.0)
    assert f0.line == 2 and f0.joints_deg == pytest.approx(START) and not f0.done
    # inside line 2: the planned sample at that time
    k = 49
    assert tl.at(float(move2.t[k])).joints_deg == pytest.approx(tuple(move2.positions_deg()[k]))
    # the Delay holds line 2's end
    for t in (1.01, 1.25, 1.49):
        f = tl.at(t)
        assert f.line == 3 and f.joints_deg == pytest.approx(tuple(move2.final_deg))
    # line 5 after Speed(50): its planned sample k at twice its time
    f = tl.at(1.5 + 2 * float(move5.t[k]))
    assert f.line == 5 and f.joints_deg == pytest.approx(tuple(move5.positions_deg()[k]))
    end = tl.at(99.0)
    assert end.done and end.time_s == tl.duration_s and end.line == 5
    assert end.joints_deg == pytest.approx(report.final_deg)
    assert tl.at(-1.0).joints_deg == f0.joints_deg


def test_between_samples_the_ghost_moves_on_the_straight_line_between_them():
    tl, report = _timeline("MoveJoint(90, -90, 180, 0, 0, 180, t=1)\nEnd()\n")
    traj = report.segments[0][1]
    a, b = traj.positions_deg()[10], traj.positions_deg()[11]
    mid = tl.at((float(traj.t[10]) + float(traj.t[11])) / 2).joints_deg
    assert mid == pytest.approx(tuple((a + b) / 2))
    # before the first sample: from the start joints
    first = (np.array(START) + traj.positions_deg()[0]) / 2
    assert tl.at(float(traj.t[0]) / 2).joints_deg == pytest.approx(tuple(first))


def test_a_colliding_line_is_marked_while_it_plays_and_the_others_are_not():
    text = "Begin()\nMoveJoint(80, -80, 170, 0, 10, 180, t=1.5)\nMoveJoint(0, -90, 180, 0, 0, 180, t=4)\nEnd()\n"
    tl, report = _timeline(text, zones=[TABLE_ZONE, MONITOR])
    assert [e.line for e in report.errors] == [3]
    assert tl.lines == (2, 3)
    assert not tl.at(0.7).collides and tl.at(0.7).line == 2
    assert tl.at(3.0).collides and tl.at(3.0).line == 3
    # the colliding move still plays to its planned end (the dry run went on from there)
    assert tl.at(99).joints_deg == pytest.approx(report.final_deg)


def test_home_puts_the_ghost_at_the_standby_pose_and_a_line_that_cannot_be_planned_is_skipped():
    text = ("Begin()\nMoveJoint(60, -90, 180, 0, 0, 180, t=1)\nHome()\n"
            "MovePose(1000, 0, 300, 0, 0, 0)\nMoveJoint(80, -90, 180, 0, 0, 180, t=1)\nEnd()\n")
    tl, report = _timeline(text)
    assert [e.line for e in report.errors] == [4]  # out of reach: refused, nothing planned
    assert tl.lines == (2, 3, 5)
    home = next(s for s in tl.steps if s.line == 3)
    assert home.duration_s == 0.0 and tuple(home.rows_deg[0]) == pytest.approx(PAROL6.standby_deg)
    # line 5 starts from the standby pose, where the arm is after line 3
    line5 = next(s for s in tl.steps if s.line == 5)
    assert tuple(line5.rows_deg[0]) == pytest.approx(PAROL6.standby_deg, abs=1e-3)
    assert tl.at(99).joints_deg == pytest.approx(report.final_deg)


def test_a_loop_program_plays_both_checked_passes_also_when_the_second_repeats_the_first():
    """The dry run plans pass 2 only if it starts elsewhere than pass 1; starting where the
    program ends, pass 2 repeats pass 1 (``report.repeats``): the timeline plays it as a copy
    one pass later."""
    text = ("Begin()\nMoveJoint(90, -90, 180, 0, 0, 180, t=1)\nDelay(0.5)\n"
            "MoveJoint(80, -90, 180, 0, 0, 180, t=1)\nLoop()\n")
    report0 = dry_run(_program(text), START)
    end = report0.final_deg  # start exactly where a pass ends: pass 2 repeats pass 1
    tl, report = _timeline(text, start=end)
    assert report.repeats == (2, 1) and report.iterations == 2
    assert tl.duration_s == pytest.approx(report.total_s) == pytest.approx(5.0)
    assert tl.lines == (2, 3, 4, 2, 3, 4)
    assert [s.iteration for s in tl.steps] == [1, 1, 1, 2, 2, 2]
    for t in (0.3, 1.2, 2.0):
        a, b = tl.at(t), tl.at(t + 2.5)
        assert a.line == b.line and a.joints_deg == pytest.approx(b.joints_deg)
    # without a repeat the dry run plans pass 2 itself: still two passes
    tl2, report2 = _timeline(text)
    assert report2.repeats is None and tl2.lines == (2, 3, 4, 2, 3, 4)
    assert tl2.duration_s == pytest.approx(report2.total_s)


def test_a_program_without_moves_has_a_timeline_of_its_delays_only():
    tl, _ = _timeline("Begin()\nOutput(1, HIGH)\nDelay(0.3)\nOutput(1, LOW)\nEnd()\n")
    assert tl.lines == (3,) and tl.duration_s == pytest.approx(0.3)
    assert tl.at(0.1).joints_deg == pytest.approx(START)


# ---- playback --------------------------------------------------------------------------------


def _play(sim: Simulation, start: float, end: float, frame_s: float = 0.02) -> float:
    """Frames every ``frame_s`` from ``start`` to ``end`` (s of the clock); the time shown then."""
    n = round((end - start) / frame_s)
    for k in range(1, n + 1):
        sim.frame(start + k * frame_s)
    return sim.advance(end)


def test_playback_runs_the_timeline_on_the_clock_it_is_given_at_its_speed():
    tl, _ = _timeline("MoveJoint(90, -90, 180, 0, 0, 180, t=2)\nDelay(2)\nEnd()\n")
    assert tl.duration_s == pytest.approx(4.0)
    sim = Simulation(tl, speed=1)
    assert not sim.playing(100.0) and sim.advance(100.0) == 0.0
    sim.start(100.0)
    assert sim.playing(100.0)
    assert _play(sim, 100.0, 101.0) == pytest.approx(1.0)  # real time
    assert sim.frame(101.0) == tl.at(sim.advance(101.0))
    sim.set_speed(5, now=101.0)  # from here five times as fast
    assert _play(sim, 101.0, 101.2) == pytest.approx(2.0)
    assert _play(sim, 101.2, 101.7) == 4.0 and not sim.playing(101.7)  # held at the end
    assert sim.frame(200.0).done
    fast = Simulation(tl, speed=2)
    fast.start(0.0)
    assert _play(fast, 0.0, 1.0) == pytest.approx(2.0) and fast.playing(1.0)
    fast.stop()
    assert not fast.playing(5.0) and fast.advance(5.0) == pytest.approx(2.0)  # stopped: the time stands
    with pytest.raises(ParolkitValueError, match="simulation speed"):
        Simulation(tl, speed=3)
    with pytest.raises(ParolkitValueError, match="simulation speed"):
        fast.set_speed(4, now=1.0)


def test_a_held_up_server_slows_the_playback_down_and_skips_no_line():
    """One frame advances the simulation by at most MAX_FRAME_STEP_S of wall time (x its speed):
    frames 2 s apart (a loaded machine) show every line, at 0.1 s of the program a frame."""
    tl, _ = _timeline("Begin()\nMoveJoint(84, -90, 180, 0, 0, 180, t=0.4)\nDelay(0.15)\n"
                      "MoveJoint(80, -90, 180, 0, 0, 180, t=0.4)\nEnd()\n")
    sim = Simulation(tl, speed=1)
    sim.start(0.0)
    seen = [sim.frame(2.0 * k) for k in range(1, 12)]
    assert [f.time_s for f in seen] == pytest.approx([min(tl.duration_s, k * MAX_FRAME_STEP_S) for k in range(1, 12)])
    assert [f.line for f in seen] == [tl.at(k * MAX_FRAME_STEP_S).line for k in range(1, 12)]
    assert {f.line for f in seen} == {2, 3, 4} and tl.duration_s < 1.0 and seen[-1].done
    fast = Simulation(tl, speed=5)
    fast.start(0.0)
    assert fast.advance(10.0) == pytest.approx(5 * MAX_FRAME_STEP_S)
    # a clock that goes back (a second caller's older 'now') advances nothing
    assert fast.advance(9.0) == pytest.approx(5 * MAX_FRAME_STEP_S)


# ---- the start pose ----------------------------------------------------------------------------


def test_the_start_pose_is_the_target_of_the_first_absolute_move():
    p = start_pose(_program("Begin()\nDelay(1)\nHome()\nMoveJoint(80, -90, 180, 0, 0, 180, t=1)\n"
                            "MoveCart(0, 263, 161, -90, 0, -90)\nEnd()\n"))
    assert p == StartPose(4, "MoveJoint", joints_deg=(80.0, -90.0, 180.0, 0.0, 0.0, 180.0))
    assert p.command() == "MOVEJOINT|80.0000|-90.0000|180.0000|0.0000|0.0000|180.0000|None|25|25"
    assert p.describe() == "line 4's MoveJoint target"
    assert p.target_text() == "(80, -90, 180, 0, 0, 180)"
    cart = start_pose(_program("Begin()\nMoveCart(0, 263.23, 161.241, -90, 0, -89.5)\nEnd()\n"))
    assert isinstance(cart, StartPose) and cart.pose == (0.0, 263.23, 161.241, -90.0, 0.0, -89.5)
    assert cart.command(speed_pct=10, accel_pct=20) == \
        "MOVEPOSE|0.0000|263.2300|161.2410|-90.0000|0.0000|-89.5000|None|10|20"
    rel = start_pose(_program("Begin()\nMoveCartRelTRF(-80, 0, 0, 0, 0, 0)\nMoveJoint(80, -90, 180, 0, 0, 180)\n"
                              "End()\n"))
    assert rel == ("the first move (MoveCartRelTRF at line 2) is relative to where the arm is: the program has "
                   "no fixed start pose")
    assert start_pose(_program("Begin()\nOutput(1, HIGH)\nEnd()\n")) == "the program has no move"


def test_the_arm_is_at_the_start_pose_within_a_tenth_of_a_degree_or_half_a_millimetre():
    joints = StartPose(2, "MoveJoint", joints_deg=START)
    pose = tuple(float(v) for v in fk(START))
    assert joints.reached(START, pose)
    near = list(START)
    near[4] += AT_START_DEG * 0.9
    assert joints.reached(near, pose)
    near[4] += AT_START_DEG
    assert not joints.reached(near, pose)
    target = StartPose(2, "MovePose", pose=pose)
    assert target.reached(START, pose)
    moved = list(pose)
    moved[0] += 0.4
    assert target.reached(START, moved)
    moved[0] += 0.2
    assert not target.reached(START, moved)
    turned = list(pose)
    turned[5] += 0.5
    assert not target.reached(START, turned)
    # the same orientation written another way (an angle 360 deg on) is the same pose
    same = list(pose)
    same[3] += 360.0
    assert target.reached(START, same)
