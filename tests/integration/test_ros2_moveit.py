"""`parolkit ros2` with ``[ros2] joint_convention = "community"`` against a REAL ROS 2 Jazzy rclpy
node and a simulated controller (as tests/integration/test_ros2.py, whose helpers this uses):
what a community PAROL6 MoveIt configuration sees and sends.

* ``/robot_description`` is the URDF in the community convention; ``/joint_states`` carries the
  community values of the controller's joint angles;
* a MoveIt-style trajectory in the community convention (its start point at time 0 a few
  mrad from where the arm is, velocities at every point, the last point 4 ms after the one
  before it) is accepted with that point merged, ends on its tick and within one step of its
  last point at the board.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from typing import Any

import numpy as np
import pytest
from tests.conftest import REPO_ROOT, start_controller, wait_until
from tests.integration.status_log import StatusLog
from tests.integration.test_ros2 import (
    NAMES,
    ROS_PYTHON,
    RosNode,
    _joint_states_at,
    _start_seq,
    _steps_off,
    _the_command,
)

from parolkit.client.robot import Robot
from parolkit.robot import PAROL6, rad_to_steps
from parolkit.ros2.convention import COMMUNITY

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def community(tmp_path_factory):  # type: ignore[no-untyped-def]
    if not ROS_PYTHON.exists():
        pytest.fail(f"the ROS 2 test environment {ROS_PYTHON} is missing: run `make ros-venv` "
                    "(or set PAROLKIT_ROS_PYTHON to a python with ros-jazzy-rclpy)")
    log_dir = tmp_path_factory.mktemp("ros2_moveit")
    ctl = start_controller(log_dir=log_dir, lockstep=True)
    domain = 100 + (os.getpid() + 50) % 100  # not test_ros2.py's domain when both run in one process
    ns = f"parol6c_{os.getpid()}"
    cfg = log_dir / "parolkit.toml"
    cfg.write_text('[ros2]\njoint_convention = "community"\n')
    env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO_ROOT / "src"))
    bridge_log = open(log_dir / "bridge.log", "w")
    bridge = subprocess.Popen(
        [sys.executable, "-m", "parolkit", "ros2", "--connect", f"127.0.0.1:{ctl.port}",
         "--domain", str(domain), "--namespace", ns, "--config", str(cfg)],
        stdout=bridge_log, stderr=subprocess.STDOUT, env=env, cwd=REPO_ROOT)
    node = RosNode(domain, ns)
    robot = Robot(port=ctl.port, timeout=2.0)
    log = StatusLog(robot)
    yield {"ctl": ctl, "node": node, "robot": robot, "log": log, "bridge_log": log_dir / "bridge.log"}
    log.close()
    robot.close()
    node.close()
    bridge.terminate()
    try:
        bridge.wait(10)
    except subprocess.TimeoutExpired:
        bridge.kill()
    bridge_log.close()
    ctl.stop()


def test_the_description_and_joint_states_are_in_the_community_convention(community) -> None:  # type: ignore[no-untyped-def]
    urdf = community["node"].ask(cmd="description")["urdf"]
    assert urdf is not None, community["bridge_log"].read_text()
    assert "Joint convention: community" in urdf
    axes = [j.find("axis").get("xyz") for j in ET.fromstring(urdf).findall("joint")  # type: ignore[union-attr]
            if j.get("type") == "revolute"]
    assert axes == ["0 0 1", "0 0 1", "0 0 -1", "0 0 -1", "0 0 -1", "0 0 -1"]
    msgs = community["node"].ask(cmd="joint_states", n=20)["msgs"]
    assert len(msgs) >= 20
    st = community["robot"].status()
    for m in msgs:  # the idle arm at standby: (90, 0, 0, 0, 0, 0) deg in the community convention
        np.testing.assert_allclose(m["position"], COMMUNITY.to_ros_rad(st.angles), atol=1e-6)
    np.testing.assert_allclose(msgs[-1]["position"], np.radians([90, 0, 0, 0, 0, 0]), atol=math.radians(0.01))


def test_a_moveit_style_community_trajectory_with_a_merged_last_point_ends_on_time(community) -> None:  # type: ignore[no-untyped-def]
    node, robot, log = community["node"], community["robot"], community["log"]
    start = robot.status()
    rate = start.loop.rate_hz
    # parolkit degrees: the start (5 mrad off on J2, within MoveIt's 0.01 rad), three points with
    # velocities, the last 4 ms after the point before it (both on tick 250)
    offsets = [[0, math.degrees(0.005), 0, 0, 0, 0], [5, -3, 4, 6, 5, -7], [10, -5, 8, 10, 10, -12],
               [11.98, -5.99, 8.99, 11.98, 11.98, -13.98], [12, -6, 9, 12, 12, -14]]
    times = [0.0, 1.0, 2.0, 2.5, 2.504]
    vel_deg_s = [[0] * 6, [5, -3, 4, 5, 5, -7], [3, -1, 2, 3, 3, -3], [0.2, -0.1, 0.1, 0.2, 0.2, -0.2], [0] * 6]
    q_deg = [np.array(start.angles) + np.array(o) for o in offsets]
    points: list[list[Any]] = [[t, list(COMMUNITY.to_ros_rad(q)), list(COMMUNITY.rate_to_ros(np.radians(v)))]
                               for t, q, v in zip(times, q_deg, vel_deg_s)]
    log.clear()
    node.ask(cmd="publish", names=NAMES, points=points)
    ev = node.ask(cmd="event")["event"]
    assert ev == ("accepted: 3 points, 250 ticks (2.500 s), the message's velocities; point 3 merged into the "
                  "last point (on the same control tick)"), (ev, community["bridge_log"].read_text())
    done = node.ask(cmd="event", timeout=30)["event"]
    assert done is not None and done.startswith("done:"), done
    wait_until(lambda: log.snapshot()[-1].command is None, timeout=10, what="the path to end")
    seen = log.snapshot()
    planned = round(times[-1] * rate)
    path = _the_command(seen)
    first = _start_seq(path, planned)
    last_sample = next(s.seq for s in path if s.command is not None and s.command.progress == 1.0)
    assert abs((last_sample - first) - planned) <= 1, (last_sample - first, planned)
    target = rad_to_steps(np.radians(q_deg[-1]), PAROL6)
    assert _steps_off(seen[-1], target) <= 1
    # the community values of the last point (once the bridge has published what it had queued)
    wait_until(lambda: _joint_states_at(node, points[-1][1]), 30, what="the ROS node's joint states at the last point")
