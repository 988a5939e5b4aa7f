"""The interpreter's controls against the real controller (simulated board): stop, pause /
resume, single step, the current line, Home / Input / SpeedJoint / Output(2), endless loops,
and the pre-run check that refuses a program before anything moves."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from tests.integration.status_log import StatusLog

from conftest import frames_pass, start_controller, wait_until
from parolkit.client.robot import Robot
from parolkit.script import Interpreter, InterpreterState, parse

STANDBY = [90.0, -90.0, 180.0, 0.0, 0.0, 180.0]


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    cp = start_controller(log_dir=tmp_path_factory.mktemp("interp"))
    try:
        with Robot(cp.host, cp.port, ack_port=cp.ack_port) as r:
            yield r
    finally:
        cp.stop()


def program(text: str):
    return parse(text, "test.rbt").unwrap()


def test_home_input_and_speedjoint_run_in_order(robot):
    prog = program(
        "Begin()\n"
        "MoveJoint(80, -95, 175, 5, 5, 170, t=0.8)\n"
        "Input(1, LOW, 2)      # the simulated inputs are low: returns at once\n"
        "SpeedJoint(5, 0, 0, 0, 0, 0, t=1)\n"
        "Home()\n"
        "End()\n"
    )
    seen: list[tuple[int, str]] = []
    result = Interpreter(prog, robot, on_line=lambda p: seen.append((p.line, p.command))).run()
    assert result.state is InterpreterState.FINISHED, result.message
    assert [line for line, _ in seen] == [1, 2, 3, 4, 5, 6]
    assert seen[3][1] == "SpeedJoint(5, 0, 0, 0, 0, 0, t=1)"
    np.testing.assert_allclose(result.final_deg, STANDBY, atol=0.05)


def test_output_sets_the_named_output_high_then_low(robot):
    """Output(2, ...) works (the original always rejected it); HIGH means the output is on."""
    prog = program("Begin()\nOutput(2, HIGH)\nOutput(1, HIGH)\nOutput(2, LOW)\nOutput(1, LOW)\nEnd()")
    # the outputs the board reported, tick by tick (the lines run back to back, one tick each:
    # reading the IO between lines would race the next line, already queued at the controller)
    log = StatusLog(robot)
    try:
        result = Interpreter(prog, robot).run()
        assert result.ok, result.message
        # the last Output completed when the controller's status showed it; its status datagram
        # reaches the log a moment later
        wait_until(lambda: (log.snapshot() or [None])[-1] is not None
                   and not (log.snapshot()[-1].io.out1 or log.snapshot()[-1].io.out2), 5,
                   what="the last status with both outputs off")
        states = [(st.io.out1, st.io.out2) for st in log.snapshot()]
    finally:
        log.close()
    seen = [s for i, s in enumerate(states) if i == 0 or s != states[i - 1]]
    assert seen == [(False, False), (False, True), (True, True), (True, False), (False, False)], seen


def test_speedjoint_moves_the_joint_by_speed_times_duration(robot):
    robot.move_joints(STANDBY, duration=1.0)
    starts: dict[int, float] = {}
    prog = program("Begin()\nSpeedJoint(-8, 0, 0, 0, 0, 0, t=1.5)\nEnd()")
    result = Interpreter(prog, robot, on_line=lambda p: starts.setdefault(p.line, time.monotonic())).run()
    assert result.ok, result.message
    wall = starts[3] - starts[2]
    moved = 90.0 - result.final_deg[0]
    # at least speed x duration (12 deg); at most speed x the time the command was active (a
    # loaded machine makes the simulated controller's ticks late, never early)
    assert 8 * 1.5 - 0.3 <= moved <= 8 * wall + 0.3, (moved, wall)
    np.testing.assert_allclose(result.final_deg[1:], STANDBY[1:], atol=0.05)


def test_input_timeout_fails_at_its_line_and_stops_the_program(robot):
    """The line after the Input never starts, not even for the round trip the STOP that
    cancels it takes: it is sent only after the Input's outcome.  Failed before on a busy
    machine (a fresh clone, 2026-11-30): queued behind the Input, the MoveJoint started when
    the input timed out and ran 2.6 deg before the STOP came."""
    robot.move_joints(STANDBY, duration=1.0)
    log = StatusLog(robot)
    try:
        prog = program("Begin()\nInput(2, HIGH, 0.3)\nMoveJoint(80, -95, 175, 5, 5, 170, t=1)\nEnd()")
        result = Interpreter(prog, robot).run()
        assert result.state is InterpreterState.FAILED
        (err,) = result.errors
        assert (err.line, err.col) == (2, 1)
        assert err.message.startswith("Input failed")
        frames_pass(_ticks(robot), 20)  # a MoveJoint sent ahead would have shown by now
        ran = sorted({s.command.name for s in log.snapshot() if s.command is not None})
    finally:
        log.close()
    assert "MOVEJOINT" not in ran, ran
    np.testing.assert_allclose(robot.angles(), STANDBY, atol=0.05)  # line 3 never ran


def _ticks(robot):
    """The controller's frame count for :func:`conftest.frames_pass` (its ticks, not the clock)."""
    return lambda: {"frames_sent": robot.loop_stats().frames_sent}


def test_stop_during_a_move_sends_stop_and_leaves_the_robot_short_of_the_target(robot):
    robot.move_joints(STANDBY, duration=1.0)
    target = [40.0, -90.0, 180.0, 0.0, 0.0, 180.0]
    prog = program(f"Begin()\nMoveJoint({', '.join(map(str, target))}, t=6)\nDelay(5)\nEnd()")
    interp = Interpreter(prog, robot)
    interp.start()
    wait_until(lambda: interp.current_line == 2 and interp.state is InterpreterState.RUNNING)
    frames_pass(_ticks(robot), 100)  # 1 s of the 6 s move, in the controller's ticks
    sent = robot.loop_stats().frames_sent
    interp.stop()
    result = interp.wait(10)
    assert robot.loop_stats().frames_sent - sent < 300  # stopped within 3 s of the controller's time
    assert result.state is InterpreterState.STOPPED
    assert interp.current_line is None
    wait_until(lambda: max(abs(s) for s in robot.speeds()) == 0, what="the robot standing still")
    j1 = robot.angles()[0]
    assert 41.0 < j1 < 89.5, j1  # moved, but was stopped well before the target
    assert robot.status().queue == 0


A = [85.0, -92.0, 178.0, 2.0, 2.0, 178.0]
B = [80.0, -95.0, 175.0, 5.0, 5.0, 175.0]


def test_single_step_runs_one_command_per_step_and_pauses_between(robot):
    robot.move_joints(STANDBY, duration=1.0)
    states: list[InterpreterState] = []
    prog = program(f"Begin()\nMoveJoint({', '.join(map(str, A))}, t=1)\n"
                   f"MoveJoint({', '.join(map(str, B))}, t=1)\nEnd()")
    interp = Interpreter(prog, robot, step=True, on_state=states.append)
    interp.start()
    wait_until(lambda: interp.state is InterpreterState.PAUSED)
    assert interp.current_line == 1
    interp.step()  # Begin()
    wait_until(lambda: interp.state is InterpreterState.PAUSED and interp.current_line == 2)
    np.testing.assert_allclose(robot.angles(), STANDBY, atol=0.05)
    interp.step()  # the first move
    wait_until(lambda: interp.state is InterpreterState.PAUSED and interp.current_line == 3)
    np.testing.assert_allclose(robot.angles(), A, atol=0.05)
    frames_pass(_ticks(robot), 30)
    assert interp.current_line == 3 and interp.state is InterpreterState.PAUSED  # stays paused
    np.testing.assert_allclose(robot.angles(), A, atol=0.05)
    interp.resume()
    result = interp.wait(10)
    assert result.state is InterpreterState.FINISHED
    np.testing.assert_allclose(result.final_deg, B, atol=0.05)
    assert InterpreterState.CHECKING in states and states[-1] is InterpreterState.FINISHED


def test_pause_lets_the_move_in_progress_finish_then_waits(robot):
    robot.move_joints(STANDBY, duration=1.0)
    prog = program(f"Begin()\nMoveJoint({', '.join(map(str, A))}, t=1.2)\n"
                   f"MoveJoint({', '.join(map(str, B))}, t=1)\nEnd()")
    paused = threading.Event()

    def on_line(p):
        if p.line == 2:
            interp.pause()  # requested just as the move starts

    def on_state(s):
        if s is InterpreterState.PAUSED:
            paused.set()

    interp = Interpreter(prog, robot, on_line=on_line, on_state=on_state)
    interp.start()
    assert paused.wait(10)
    assert interp.current_line == 3
    np.testing.assert_allclose(robot.angles(), A, atol=0.05)  # the move finished
    frames_pass(_ticks(robot), 30)
    np.testing.assert_allclose(robot.angles(), A, atol=0.05)  # line 3 does not run while paused
    interp.resume()
    assert interp.wait(10).state is InterpreterState.FINISHED
    np.testing.assert_allclose(robot.angles(), B, atol=0.05)


def test_a_step_while_lines_are_queued_ahead_runs_exactly_one_of_them(robot):
    """The lines after the running one are queued at the controller ahead of execution; a
    pause holds them there (PAUSE|QUEUE) and each step lets exactly one start (RESUME|ONE):
    the arm goes to that line's target and stays, the others wait; resume runs the rest."""
    robot.move_joints(STANDBY, duration=1.0)

    moves = [A, B, A, B, A]
    prog = program("Begin()\n" + "".join(f"MoveJoint({', '.join(map(str, q))}, t=0.8)\n" for q in moves) + "End()")
    interp = Interpreter(prog, robot)
    interp.start()
    wait_until(lambda: interp.current_line == 2 and robot.status().queue == 4,
               what="the first move running, the other four queued ahead")
    interp.pause()
    wait_until(lambda: interp.state is InterpreterState.PAUSED, what="PAUSED")
    assert interp.current_line == 3
    np.testing.assert_allclose(robot.angles(), A, atol=0.05)  # the running move finished
    frames_pass(_ticks(robot), 30)
    np.testing.assert_allclose(robot.angles(), A, atol=0.05)  # the held ones do not run
    assert robot.status().queue == 4
    for line, q, left in ((3, B, 3), (4, A, 2)):
        interp.step()
        wait_until(lambda line=line: interp.current_line == line + 1, what=f"line {line} stepped")
        wait_until(lambda left=left: robot.status().queue == left and robot.status().command is None,
                   what=f"{left} lines still held, nothing running")
        np.testing.assert_allclose(robot.angles(), q, atol=0.05)
        assert interp.state is InterpreterState.PAUSED
    frames_pass(_ticks(robot), 30)
    np.testing.assert_allclose(robot.angles(), A, atol=0.05)  # still one line per step
    interp.resume()
    result = interp.wait(20)
    assert result.state is InterpreterState.FINISHED and result.commands_executed == 7, result
    np.testing.assert_allclose(result.final_deg, A, atol=0.05)


def test_endless_loop_runs_until_stopped(robot):
    passes: list[int] = []
    prog = program("Begin()\nDelay(0.05)\nLoop()")
    interp = Interpreter(prog, robot, on_line=lambda p: passes.append(p.iteration))
    interp.start()
    wait_until(lambda: interp.iteration >= 3)
    interp.stop()
    result = interp.wait(10)
    assert result.state is InterpreterState.STOPPED
    assert result.iterations >= 3 and max(passes) >= 3


def test_check_refuses_an_unreachable_program_before_anything_moves(robot):
    robot.move_joints(STANDBY, duration=1.0)
    before = robot.status().plan_seq
    prog = program("Begin()\nMoveJoint(80, -95, 175, 5, 5, 170, t=1)\nMovePose(0, 900, 100, -90, 0, -90)\nEnd()")
    result = Interpreter(prog, robot).run()
    assert result.state is InterpreterState.FAILED
    assert result.commands_executed == 0
    (err,) = result.errors
    assert (err.line, err.col) == (3, 1) and "MovePose cannot be planned" in err.message
    assert robot.status().plan_seq == before
    np.testing.assert_allclose(robot.angles(), STANDBY, atol=0.05)


def test_a_failing_callback_is_logged_and_does_not_end_the_run(robot, caplog):
    def broken(progress):
        raise RuntimeError("GUI went away")

    result = Interpreter(program("Begin()\nDelay(0.05)\nEnd()"), robot, on_line=broken).run()
    assert result.state is InterpreterState.FINISHED
    assert result.commands_executed == 3
    assert "GUI went away" in caplog.text


def test_movecart_lines_with_r_run_as_one_blended_motion_through_every_corner(robot):
    """Issue 24, item 4, from a program: MoveCart lines with r= are sent ahead while they blend,
    the controller plays them as one motion: the TCP does not stop at the corners, passes each
    within r, and every line is announced in order as the arm reaches it."""
    from parolkit.kinematics import fk

    start = [90.0, -90.0, 180.0, 0.0, 30.0, 180.0]
    p = fk(start)
    corners = [(p[0] + (15 if i % 2 == 0 else -15), p[1] + 4 * (i + 1), p[2]) for i in range(8)]
    lines = [f"MoveJoint({', '.join(f'{v:g}' for v in start)}, t=1)"]
    lines += [f"MoveCart({x:.3f}, {y:.3f}, {z:.3f}, {p[3]:.3f}, {p[4]:.3f}, {p[5]:.3f}, v=60"
              + (", r=10)" if i < 7 else ")") for i, (x, y, z) in enumerate(corners)]
    prog = program("\n".join(lines) + "\n")
    seen: list[int] = []
    log = StatusLog(robot)
    try:
        result = Interpreter(prog, robot, on_line=lambda pr: seen.append(pr.line)).run()
        assert result.state is InterpreterState.FINISHED, result.message
        assert seen == list(range(1, 10))
        wait_until(lambda: not log.snapshot()[-1].moving, 5, what="the last status at rest")
        moving = [s for s in log.snapshot() if s.command is not None and s.command.name == "MOVECART"]
    finally:
        log.close()
    tcp = np.array([s.pose[:3] for s in moving])
    seqs = [s.seq for s in moving]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "a status every tick"
    # from the first corner to the last, the TCP never stands still for a tick
    near = [int(np.argmin(np.linalg.norm(tcp - np.asarray(c), axis=1))) for c in corners]
    step = np.linalg.norm(np.diff(tcp[near[0]:near[-2] + 1], axis=0), axis=1)
    assert step.min() > 0.005, step.min()
    for c in corners[:-1]:
        assert np.min(np.linalg.norm(tcp - np.asarray(c), axis=1)) <= 10.0 + 1.0
