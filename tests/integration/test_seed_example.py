"""The seed's example script runs unchanged against ``parolkit serve`` in a fresh environment.

tests/data/seed_example.py is the ``from robot_api import ...`` block of the seed document,
byte for byte.  It runs in a subprocess of a bare interpreter (``-I -S``: no site-packages,
no parolkit, no numpy) next to a single copy of ``robot_api.py``, exactly as a user would
copy the file.  A small wrapper only points robot_api at the test controller's ports, scales
``time.sleep`` down (the sleeps merely wait for moves the controller queues anyway) and
records what every call returned.  Afterwards the test waits for the queued moves and checks
where the real (simulated) robot ended up.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from parolkit.client.robot import Robot

REPO = Path(__file__).resolve().parents[2]
SEED_SCRIPT = REPO / "tests" / "data" / "seed_example.py"
ROBOT_API = REPO / "src" / "parolkit" / "client" / "robot_api.py"

WRAPPER = r"""
import json, runpy, sys, time, types
workdir, port, ack_port = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
script, scale = sys.argv[4], float(sys.argv[5])
sys.path.insert(0, workdir)
import robot_api
robot_api.configure(host="127.0.0.1", port=port, ack_port=ack_port)
_sleep = time.sleep
time.sleep = lambda s: _sleep(s * scale)
calls, depth = [], [0]
def wrap(name, fn):
    def recorded(*args, **kwargs):
        depth[0] += 1
        try:
            result = fn(*args, **kwargs)
        finally:
            depth[0] -= 1
        if depth[0] == 0:
            calls.append({"name": name, "result": result})
        return result
    return recorded
for name in robot_api.__all__:
    obj = getattr(robot_api, name)
    if isinstance(obj, types.FunctionType) and not name.startswith(("build_", "parse_")):
        setattr(robot_api, name, wrap(name, obj))
runpy.run_path(script, run_name="__main__")
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("parolkit", "numpy", "spatialmath"))
print("RESULT=" + json.dumps({"calls": calls, "loaded": loaded}))
"""

#: the script's sleeps, scaled (its time.sleep(2) after control_electric_gripper("calibrate") need
#: not cover the calibration: the controller's queue holds the move sent next until the gripper
#: reports calibrated)
SLEEP_SCALE = 0.6

EXPECTED_CALLS = [
    "control_electric_gripper", "control_electric_gripper", "get_robot_joint_angles",
    "get_robot_pose", "control_pneumatic_gripper", "move_robot_joints", "move_robot_pose",
    "move_robot_cartesian", "delay_robot", "get_electric_gripper_status", "get_robot_io",
]


@pytest.mark.slow
def test_seed_example_runs_unchanged_and_every_call_returns_real_values(controller, tmp_path):
    assert SEED_SCRIPT.read_text().startswith("from robot_api import move_robot_joints, home_robot")
    shutil.copy(ROBOT_API, tmp_path / "robot_api.py")
    shutil.copy(SEED_SCRIPT, tmp_path / "seed_example.py")
    proc = subprocess.run(
        [sys.executable, "-I", "-S", "-c", WRAPPER, str(tmp_path), str(controller.port),
         str(controller.ack_port), str(tmp_path / "seed_example.py"), str(SLEEP_SCALE)],
        capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr + controller.log()
    assert "robot_api:" not in proc.stderr, proc.stderr  # no query timed out or failed
    lines = proc.stdout.splitlines()
    result = json.loads(next(ln for ln in lines if ln.startswith("RESULT="))[len("RESULT="):])
    assert result["loaded"] == []  # standard library only
    calls = result["calls"]
    assert [c["name"] for c in calls] == EXPECTED_CALLS
    by_name = {}
    for c in calls:
        by_name.setdefault(c["name"], []).append(c["result"])
    for name in ("control_electric_gripper", "control_pneumatic_gripper", "move_robot_joints",
                 "move_robot_pose", "move_robot_cartesian", "delay_robot"):
        for r in by_name[name]:
            assert isinstance(r, str) and r.startswith("Successfully sent command"), (name, r)
    # the queries happen before any move has finished: the robot is at its homed standby pose
    angles = by_name["get_robot_joint_angles"][0]
    assert angles == pytest.approx([90, -90, 180, 0, 0, 180], abs=0.01)
    pose = by_name["get_robot_pose"][0]
    assert pose == pytest.approx([0, 262.57, 288.75, -90, 0, -90], abs=0.05)
    gripper = by_name["get_electric_gripper_status"][0]
    assert len(gripper) == 6 and all(isinstance(v, int) for v in gripper)
    io = by_name["get_robot_io"][0]
    assert len(io) == 5 and io[4] == 1  # E-stop released
    # the script printed what the calls returned
    assert "Homing robot..." in lines and "Moving to new position..." in lines
    assert str(angles) in lines and str(io) in lines

    # every queued command really ran on the (simulated) robot
    with Robot(port=controller.port, timeout=2.0) as robot:
        status = robot.wait_until_idle(timeout=40)
        assert status.errors.message is None
        assert list(status.pose) == pytest.approx([7, 250, 150, -100, 0, -90], abs=0.5)
        assert status.io.out1 is True  # control_pneumatic_gripper("open", 1)
        assert status.gripper.calibrated
        assert status.gripper.position == 100  # control_electric_gripper('move', position=100)


def test_robot_api_module_needs_only_the_standard_library(tmp_path):
    (tmp_path / "robot_api.py").write_bytes(ROBOT_API.read_bytes())
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import robot_api; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('parolkit', 'numpy')))")
    out = subprocess.run([sys.executable, "-I", "-S", "-c", code, str(tmp_path)],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
