"""RBTscript against the real controller subprocess with the simulated board.

* the five seed examples run to completion (Loop programs: 2 passes) and end on the last target;
* every malformed program of the corpus is refused with its line:col error and a non-zero
  exit, and the controller receives no motion (same joints, same plan sequence, outputs low);
* ``parolkit run --sim`` starts its own controller and runs a program end to end.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tests.integration.status_log import StatusLog, command_runs

from conftest import REPO_ROOT, start_controller, wait_until
from parolkit.client.robot import Robot
from parolkit.script import Interpreter, InterpreterState, MoveCart, MoveCartRelTRF, MoveJoint, MovePose, load

EXAMPLES = sorted((REPO_ROOT / "examples").glob("*.rbt"))
CORPUS = sorted((REPO_ROOT / "tests" / "data" / "rbt" / "malformed").glob("*.rbt"))
_EXPECT = re.compile(r"^# expect: (\d+):(\d+): (.+)$", re.M)

#: the simulated board's position loop ends within a few microsteps of the target
TOLERANCE_DEG = 0.05


@pytest.fixture(scope="module")
def shared_controller(tmp_path_factory):
    cp = start_controller(log_dir=tmp_path_factory.mktemp("ctl"))
    yield cp
    cp.stop()


@pytest.fixture(scope="module")
def example_runs(tmp_path_factory):
    """Run the five examples at the same time, each on its own controller (the programs take
    77 s of planned motion and delays together; in parallel the suite waits ~35 s), each on a
    board in lockstep with the frames, with the status of every tick logged (which command
    ran on which ticks)."""
    from concurrent.futures import ThreadPoolExecutor

    log_dir = tmp_path_factory.mktemp("examples")

    def one(path: Path):
        cp = start_controller(log_dir=log_dir, lockstep=True)
        try:
            with Robot(cp.host, cp.port, ack_port=cp.ack_port) as robot:
                program = load(path)
                lines: list[int] = []
                log = StatusLog(robot)
                try:
                    interp = Interpreter(program, robot, loops=2 if program.loops else None,
                                         on_line=lambda p: lines.append(p.line))
                    result = interp.run()
                    wait_until(lambda: log.snapshot() and log.snapshot()[-1].command is None,
                               what="the status of the tick after the last command")
                finally:
                    log.close()
                return program, interp, result, lines, log.snapshot()
        finally:
            cp.stop()

    with ThreadPoolExecutor(max_workers=len(EXAMPLES)) as pool:
        futures = {p.stem: pool.submit(one, p) for p in EXAMPLES}
        return {name: f.result() for name, f in futures.items()}


@pytest.mark.slow
@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_seed_example_runs_to_completion_and_ends_on_the_last_target(path, example_runs):
    program, interp, result, lines, _ = example_runs[path.stem]
    assert result.state is InterpreterState.FINISHED, result.message
    assert not result.errors
    passes = 2 if program.loops else 1
    executed_lines = [c.line for c in program.commands if c.keyword != "Loop"]
    assert lines == executed_lines * passes
    assert result.iterations == passes
    # the robot ends where the dry run (planned from its joints before the run) said it would
    report = interp.report
    assert report is not None and report.ok
    moves = [c for c in program.commands if isinstance(c, (MoveJoint, MovePose, MoveCart, MoveCartRelTRF))]
    final = np.asarray(result.final_deg)
    np.testing.assert_allclose(final, report.final_deg, atol=TOLERANCE_DEG)
    if moves and isinstance(moves[-1], MoveJoint):
        np.testing.assert_allclose(final, moves[-1].move.target_deg, atol=TOLERANCE_DEG)
    if moves and isinstance(moves[-1], MoveCart):
        # the tool ends at the last MoveCart target (position within 0.5 mm)
        from parolkit.kinematics import fk

        np.testing.assert_allclose(np.asarray(fk(final))[:3], moves[-1].move.pose[:3], atol=0.5)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cartesian_trf", "cartesian_relative_trf"])
def test_the_seed_cartesian_programs_run_every_command_on_its_own_time(name, example_runs):
    """The seed's programs 2 and 3 (MoveJoint to standby, then MoveCart from that singular
    pose): each command, as it runs on the controller, lasts what the dry run planned (the
    original's timing) to within a few ticks, counted in the controller's ticks on a board in
    lockstep with the frames (what the machine's load does to the wall clock does not count);
    a MoveCart from standby took 3.71 s for a t=2 s move before."""
    program, interp, result, lines, statuses = example_runs[name]
    assert result.state is InterpreterState.FINISHED, result.message
    planned = {r.line: r.duration_s for r in interp.report.rows if r.duration_s}
    keyword = {c.line: c.keyword for c in program.commands}
    motions = ("MoveCart", "MoveCartRelTRF", "MoveJoint")
    moved = [line for line in lines if keyword[line] in motions]
    runs = [r for r in command_runs(statuses) if r.name in ("MOVECART", "MOVECARTRELTRF", "MOVEJOINT")]
    assert [r.name for r in runs] == [keyword[line].upper() for line in moved], runs
    period = 1.0 / statuses[-1].loop.rate_hz
    ticks = [(keyword[line], r.ticks, planned[line] / period) for line, r in zip(moved, runs)]
    # as planned, and a MoveCart up to 3 ticks more: the board reaching its exact end (a status
    # lost on the way would shorten a run by a tick)
    assert all(-1 <= n - want <= 3 for _, n, want in ticks), ticks
    assert sum(k.startswith("MoveCart") for k, _, _ in ticks) >= 1


def _motion_fingerprint(cp):
    """Joints, plan sequence (changes whenever a motion starts) and outputs, read with plain
    UDP queries (the CLI under test needs the controller's ack port for itself)."""
    import json

    status = json.loads(cp.query("GET_STATUS_JSON", 2.0).partition("|")[2])
    return (tuple(round(a, 4) for a in status["angles"]), status["plan_seq"],
            status["io"]["out1"], status["io"]["out2"], status["queue"])


@pytest.mark.slow
def test_malformed_programs_exit_non_zero_at_the_right_place_and_move_nothing(shared_controller, capsys):
    from parolkit.cli import main

    cp = shared_controller
    with Robot(cp.host, cp.port, ack_port=cp.ack_port) as robot:
        robot.move_joints([90, -90, 180, 0, 0, 180], duration=4.0)
        robot.set_output(1, False)
        robot.set_output(2, False)
    before = _motion_fingerprint(cp)
    for path in CORPUS:
        rc = main(["run", str(path), "--host", cp.host, "--port", str(cp.port),
                   "--ack-port", str(cp.ack_port), "--quiet"])
        out = capsys.readouterr()
        assert rc == 1, f"{path.name}: exit {rc}\n{out.out}{out.err}"
        for line, col, message in _EXPECT.findall(path.read_text()):
            assert f"{path}:{line}:{col}: error: " in out.err, f"{path.name}:\n{out.err}"
            assert message in out.err
    assert _motion_fingerprint(cp) == before


@pytest.mark.slow
def test_run_with_sim_starts_its_own_controller(tmp_path):
    program = tmp_path / "hello.rbt"
    program.write_text(
        "Begin()   # a tiny program\n"
        "MoveJoint(80, -95, 175, 5, 5, 170, t=0.6)\n"
        "Output(2, HIGH)  // the original rejected output 2\n"
        "Delay(0.1)\n"
        "End()\n"
    )
    proc = subprocess.run(
        [sys.executable, "-m", "parolkit", "run", str(program), "--sim"],
        capture_output=True, text=True, timeout=90, cwd=REPO_ROOT,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "line 2: MoveJoint(80, -95, 175, 5, 5, 170, t=0.6)" in proc.stdout
    assert "line 3: Output(2, HIGH)" in proc.stdout
    assert "finished after 5 commands" in proc.stdout
    final = re.search(r"final joints: \[([^\]]+)\]", proc.stdout).group(1)
    np.testing.assert_allclose([float(v) for v in final.split(",")], [80, -95, 175, 5, 5, 170], atol=TOLERANCE_DEG)
