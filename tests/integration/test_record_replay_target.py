"""Where ``parolkit replay`` may move a robot: a controller whose board is not simulated (here a
``parolkit board-sim`` pty, which the controller cannot tell from the real board) only with
``--real-robot``; a simulated controller given with ``--connect`` without it."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import REPO_ROOT, free_udp_port, wait_until
from parolkit.client.launch import die_with_parent
from parolkit.client.robot import Robot
from parolkit.motion import plan
from parolkit.moves import JointMove
from parolkit.record import messages
from parolkit.record.schemas import JOINT_STATE, TOPIC_JOINT_STATES
from parolkit.record.segments import steps_to_deg
from parolkit.record.writer import RecordingWriter
from parolkit.robot import PAROL6

from .test_record import _env, _parolkit

TARGET = [88.0, -92.0, 178.0, 2.0, 1.0, 179.0]


def _recording(path) -> None:
    """A recording of one MoveJoint (t=1 s) from standby, as the controller would report it."""
    start = np.array(PAROL6.standby_deg)
    traj = plan(JointMove(TARGET, duration_s=1.0), start)
    rest0 = np.rint(start * PAROL6.steps_per_deg).astype(np.int64)
    rows = [(rest0, None)] * 10
    n = len(traj.positions)
    rows += [(p, {"id": "abcd1234", "name": "MOVEJOINT", "progress": round((j + 1) / n, 4)})
             for j, p in enumerate(traj.positions)]
    rows += [(traj.positions[-1], None)] * 10
    w = RecordingWriter(path)
    for seq, (steps, cmd) in enumerate(rows):
        st = {"seq": seq, "time": seq / 100, "angles": steps_to_deg(steps).tolist(), "steps": steps.tolist(),
              "speeds_deg_s": [0.0] * 6, "pose": [0, 262.57, 288.75, -90, 0, -90], "command": cmd,
              "loop": {"rate_hz": 100.0}}
        w.write_ros(TOPIC_JOINT_STATES, JOINT_STATE, messages.joint_state(st, seq), seq, seq)
        w.write_status(st, seq, seq)
    w.close()


def test_replay_refuses_a_controller_with_a_real_board_without_real_robot(controller_factory, tmp_path):
    link = tmp_path / "p6"
    board = subprocess.Popen([sys.executable, "-m", "parolkit", "board-sim", "--link", str(link), "--speedup", "50"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO_ROOT, env=_env(),
                             preexec_fn=die_with_parent)
    try:
        wait_until(link.exists, timeout=20, what="the board-sim pty")
        cp = controller_factory(["--port", str(link)], wait_homed=False)
        rec = tmp_path / "one.mcap"
        _recording(rec)
        r = subprocess.run(_parolkit("replay", str(rec), "--connect", f"127.0.0.1:{cp.port}"),
                           capture_output=True, text=True, env=_env(), cwd=REPO_ROOT, timeout=60)
        assert r.returncode == 2, r.stdout + r.stderr
        assert "drives a real robot (its board is not simulated): add --real-robot" in r.stderr
        reply = cp.query("GET_STATUS") or ""
        assert "QUEUE=0" in reply and "CMD=None" in reply  # nothing was sent
    finally:
        board.terminate()
        board.wait(10)


def test_replay_into_a_simulated_controller_given_with_connect(controller_factory, tmp_path):
    cp = controller_factory()
    rec = tmp_path / "one.mcap"
    _recording(rec)
    r = subprocess.run(_parolkit("replay", str(rec), "--connect", f"127.0.0.1:{cp.port}"),
                       capture_output=True, text=True, env=_env(), cwd=REPO_ROOT, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "replayed 1 commands" in r.stdout
    with Robot(cp.host, cp.port) as robot:
        assert np.allclose(robot.angles(), TARGET, atol=0.02)


def test_replay_reports_an_unreachable_controller(tmp_path):
    rec = tmp_path / "one.mcap"
    _recording(rec)
    port = free_udp_port()
    t0 = time.monotonic()
    r = subprocess.run(_parolkit("replay", str(rec), "--connect", f"127.0.0.1:{port}"),
                       capture_output=True, text=True, env=_env(), cwd=REPO_ROOT, timeout=60)
    assert r.returncode == 1 and f"no status from the controller at 127.0.0.1:{port}" in r.stderr
    assert time.monotonic() - t0 < 30


pytestmark = pytest.mark.timeout(300)
