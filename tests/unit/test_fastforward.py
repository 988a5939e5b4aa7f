"""The in-process controller that ``parolkit run --sim`` drives (parolkit.controller.fastforward):
commands reach the core at ticks fixed by the program, so a run paced at real time and a
fast-forwarded one write the same frames; a failing program fails the same way in both; STOP
ends a fast-forwarded program; bad ``--fast`` / ``--frame-log`` flags are refused in one line."""

from __future__ import annotations

import io
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from parolkit.cli import main
from parolkit.client.errors import CommandFailed
from parolkit.client.robot import Robot
from parolkit.config import load_config
from parolkit.controller.fastforward import InProcessController, parse_frame_log
from parolkit.protocol.frames import BoardCommand, CommandFrame, IOBits
from parolkit.script.interpreter import Interpreter, InterpreterState
from parolkit.script.parser import parse

REPO = Path(__file__).resolve().parents[2]


def _frames(log: str) -> list[tuple[int, CommandFrame]]:
    return parse_frame_log(log)


@pytest.fixture()
def fast():
    """A fast-forwarded controller (ready: homed) and its Robot; the frame log's text."""
    log = io.StringIO()
    sim = InProcessController(load_config(None), paced=False, frame_log=log)
    sim.start()
    robot = Robot(channel=sim)
    yield sim, robot, log
    robot.close()
    sim.close()


def _output_pulse(pause_s: float) -> tuple[int, str]:
    """Delay, a wall-clock pause, OUTPUT 1 high: (the tick OUT1 went high less the tick count
    when it was sent, the frame log)."""
    log = io.StringIO()
    with InProcessController(load_config(None), paced=False, frame_log=log) as sim:
        robot = Robot(channel=sim)
        robot.delay(0.1)
        time.sleep(pause_s)  # the client thinks: no tick runs meanwhile
        before = sim.ticks
        robot.set_output(1, True)  # waits for COMPLETED: the controller ticks meanwhile
        robot.close()
    frames = _frames(log.getvalue())
    first_high = next(t for t, f in frames if f.io & IOBits.OUT1)
    return first_high - before, log.getvalue()


def test_a_command_reaches_the_board_at_a_tick_the_program_fixes_not_the_clock():
    prompt, log_prompt = _output_pulse(0.0)
    late, log_late = _output_pulse(0.3)
    assert prompt == late and prompt in (0, 1)  # the tick after the send takes it in
    assert log_prompt == log_late


def test_the_controller_ticks_only_while_its_client_waits(fast):
    sim, robot, _ = fast
    ticks = sim.ticks
    robot.delay(0.5, wait=False)  # (waits for the first ack only)
    after_send = sim.ticks
    assert robot.angles() is not None  # queries are answered at once, between ticks
    assert sim.ticks == after_send
    robot.delay(0.01)  # queued behind the first delay: both end before this returns
    assert sim.ticks - ticks >= round(0.5 / sim.period)


def test_queries_answer_from_the_latest_tick_without_ticking(fast):
    sim, robot, _ = fast
    t = sim.ticks
    for _ in range(5):
        robot.ping()
        robot.status()
    assert sim.ticks == t


def _run(text: str, paced: bool) -> tuple[InterpreterState, str, str, int]:
    cfg = load_config(None)
    program = parse(text, "prog.rbt").program
    assert program is not None
    log = io.StringIO()
    with InProcessController(cfg, paced=paced, frame_log=log) as sim:
        robot = Robot(channel=sim)
        result = Interpreter(program, robot, model=cfg.robot, rate_hz=cfg.controller.rate_hz).run()
        robot.close()
        ticks = sim.ticks
    return result.state, result.message.split(", ", 1)[0] + " | " + (
        result.errors[0].format() if result.errors else ""), log.getvalue(), ticks


def test_a_program_that_fails_midway_fails_alike_paced_and_fast():
    # the simulated inputs are low: Input(1, HIGH) times out after 0.2 s and the program fails
    text = ("Begin()\nMoveJoint(88, -92, 178, 2, 2, 178, t=0.3)\nInput(1, HIGH, t=0.2)\n"
            "MoveJoint(90, -90, 180, 0, 0, 180, t=0.3)\nEnd()\n")
    fast_run = _run(text, paced=False)
    paced_run = _run(text, paced=True)
    assert fast_run[0] is InterpreterState.FAILED
    assert "prog.rbt:3:1: error: Input failed: IN1 did not become 1 within 0.2 s" in fast_run[1], fast_run[1]
    assert fast_run[1] == paced_run[1]
    assert fast_run[2] == paced_run[2]  # the same frames, tick for tick
    assert fast_run[3] == paced_run[3]


def test_stop_ends_a_fast_forwarded_program_and_cancels_its_command():
    cfg = load_config(None)
    program = parse("Begin()\nDelay(3600)\nEnd()\n", "long.rbt").program
    assert program is not None
    with InProcessController(cfg, paced=False) as sim:
        robot = Robot(channel=sim)
        interp = Interpreter(program, robot, model=cfg.robot, rate_hz=cfg.controller.rate_hz)
        thread = interp.start()
        started = threading.Event()
        while not started.wait(0.01):  # the Delay runs (the controller ticks in the program's thread)
            if sim.ticks - sim.ready_ticks > 100:
                started.set()
        interp.stop()  # from this thread: STOP reaches the controller between two ticks
        thread.join(30)
        assert not thread.is_alive()
        assert interp.result is not None and interp.result.state is InterpreterState.STOPPED
        assert sim.board_seconds < 3600
        status = robot.status()
        assert status.command is None and status.queue == 0
        robot.close()


def test_a_failed_command_raises_through_the_channel(fast):
    _, robot, _ = fast
    with pytest.raises(CommandFailed):
        robot.wait_input(1, "HIGH", input_timeout=0.05)


def test_the_status_stream_is_refused_over_a_channel(fast):
    from parolkit.client.errors import RobotError

    _, robot, _ = fast
    with pytest.raises(RobotError, match="in-process"):
        robot.subscribe()


def test_the_final_frames_at_close_are_logged_with_their_tick(fast):
    sim, robot, log = fast
    robot.delay(0.05)
    ticks = sim.ticks
    sim.close()
    last_tick, last = _frames(log.getvalue())[-1]
    assert last.command == BoardCommand.DISABLE and last_tick == ticks


@pytest.mark.parametrize("argv, says", [
    (["--fast"], "--fast needs --sim"),
    (["--frame-log", "{tmp}/f.log"], "--frame-log needs --sim"),
    (["--sim", "--fast", "--dry-run"], "--fast applies to a --sim run"),
    (["--sim", "--frame-log", "{tmp}/no/folder/f.log"], "--frame-log {tmp}/no/folder/f.log: No such file or directory"),
])
def test_bad_fast_forward_flags_are_refused_in_one_line(tmp_path, capsys, argv, says):
    argv = [a.format(tmp=tmp_path) for a in argv]
    rc = main(["run", str(REPO / "examples" / "output_click.rbt"), *argv])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.strip() == f"parolkit run: {says.format(tmp=tmp_path)}" or says.format(tmp=tmp_path) in err, err
    assert len(err.strip().splitlines()) == 1


def test_run_sim_fast_prints_the_speed_and_ends_like_a_paced_run(tmp_path):
    program = tmp_path / "p.rbt"
    program.write_text("Begin()\nOutput(1, HIGH)\nDelay(0.5)\nOutput(1, LOW)\nEnd()\n")
    out = subprocess.run([sys.executable, "-m", "parolkit", "run", str(program), "--sim", "--fast",
                          "--frame-log", str(tmp_path / "f.log")], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "finished after 5 commands" in out.stdout
    assert "fast-forward: " in out.stdout and "x real time" in out.stdout
    frames = _frames((tmp_path / "f.log").read_text())
    assert any(f.io & IOBits.OUT1 for _, f in frames)


def test_a_frame_log_that_is_not_one_is_refused_naming_the_line():
    with pytest.raises(ValueError, match="not a parolkit frame log"):
        parse_frame_log("12 aabb\n")
    from parolkit.controller.fastforward import FRAME_LOG_HEADER

    with pytest.raises(ValueError, match="frame log line 3"):
        parse_frame_log(FRAME_LOG_HEADER + "0 " + CommandFrame().encode().hex() + "\n7 zz\n")
    assert parse_frame_log(FRAME_LOG_HEADER + "5 " + CommandFrame().encode().hex() + "\n")[0][0] == 5
