"""``parolkit teach`` on a recorded jog demonstration (real controller, real UDP): the program
it writes dry-runs within 5 mm / 2 deg of the recording along the path, and it runs."""

from __future__ import annotations

import subprocess
import time

import numpy as np
import pytest

from conftest import REPO_ROOT
from parolkit.client.robot import Robot
from parolkit.record.reader import load_recording
from parolkit.record.segments import rest_segments, steps_to_deg
from parolkit.record.teach import path_deviation, planned_path_deg

from .test_record import _env, _parolkit, _start_recorder, _statuses_in, _stop, wait_until


@pytest.mark.slow
def test_teach_on_a_jog_demonstration_reproduces_it_and_runs(controller_factory, tmp_path):
    cp = controller_factory()
    demo, prog = tmp_path / "demo.mcap", tmp_path / "prog.rbt"
    rec = _start_recorder(cp.port, demo)
    wait_until(lambda: _statuses_in(demo) > 0, timeout=30, what="the recorder's first chunk")
    with Robot(cp.host, cp.port) as robot:
        # a demonstration by jogging: four presses with pauses, an output switched between; the
        # last one a Cartesian jog straight down (its TCP line is taught as a MoveCart)
        robot.jog_joint(1, 40, duration=0.8, wait=True, timeout=30)
        time.sleep(0.6)
        robot.jog_multiple([-2, 3], [30, 30], duration=0.7, wait=True, timeout=30)
        robot.set_output(1, True)
        time.sleep(0.6)
        robot.jog_joint(-5, 50, duration=0.6, wait=True, timeout=30)
        time.sleep(0.6)
        robot.jog_cartesian("WRF", "Z-", 40, duration=0.8, wait=True, timeout=30)
        time.sleep(0.5)
    out = _stop(rec)
    assert rec.returncode == 0, out

    taught = subprocess.run(_parolkit("teach", str(demo), "-o", str(prog)),
                            capture_output=True, text=True, env=_env(), cwd=REPO_ROOT, timeout=120)
    assert taught.returncode == 0, taught.stdout + taught.stderr
    assert "deviation along the path" in taught.stdout and "within 5 mm / 2 deg" in taught.stdout
    text = prog.read_text()
    print(taught.stdout, text, sep="\n")
    assert text.count("Delay(") >= 3 and "Output(1, HIGH)" in text
    assert 4 <= text.count("MoveJoint(") <= 12  # short: the start pose and about one move per press
    assert text.count("MoveCart(") == 1 and text.rstrip().splitlines()[-2].startswith("MoveCart(")
    assert "(1 MoveCart)" in taught.stdout

    # the dry run of the program, judged here independently of teach's own figure
    r = load_recording(demo)
    segs = rest_segments(r, 30)
    assert len(segs) == 4
    start = tuple(float(v) for v in steps_to_deg(r.steps[segs[0].start]))
    planned = planned_path_deg(text, start, r.rate_hz)
    rows = np.arange(segs[0].start, segs[-1].end + 1)
    mm, deg = path_deviation(steps_to_deg(r.steps[rows]), planned)
    assert mm <= 5.0 and deg <= 2.0, (mm, deg)

    # and the program runs on the controller
    run = subprocess.run(_parolkit("run", str(prog), "--host", "127.0.0.1", "--port", str(cp.port),
                                   "--ack-port", str(cp.ack_port)),
                         capture_output=True, text=True, env=_env(), cwd=REPO_ROOT, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    with Robot(cp.host, cp.port) as robot:
        assert np.allclose(robot.angles(), steps_to_deg(r.steps[segs[-1].end]), atol=0.05)
