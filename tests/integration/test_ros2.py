"""`parolkit ros2` against a REAL ROS 2 Jazzy rclpy node (PyPI wheels, Fast DDS) and a real
simulated controller (``parolkit serve`` on a simulated board in lockstep with its frames).

Three processes besides pytest: the controller, ``parolkit ros2`` (cyclonedds) and
tests/integration/ros2_node.py run by the ROS test venv's python (``make ros-venv`` creates
``.venv-ros`` with ros-jazzy-rclpy, ros-jazzy-rmw-fastrtps-cpp and the message packages;
``PAROLKIT_ROS_PYTHON`` overrides the interpreter).  They talk over DDS on a domain of their
own.  The board's side is judged from the controller's status stream (steps and ticks), not
from wall-clock sleeps.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import threading
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from tests.conftest import REPO_ROOT, start_controller, wait_until
from tests.integration.status_log import StatusLog

from parolkit.client.core import RobotStatus
from parolkit.client.robot import Robot
from parolkit.robot import PAROL6, rad_to_steps

pytestmark = pytest.mark.slow

ROS_PYTHON = Path(os.environ.get("PAROLKIT_ROS_PYTHON", REPO_ROOT / ".venv-ros" / "bin" / "python"))
NODE = Path(__file__).with_name("ros2_node.py")
NAMES = ["L1", "L2", "L3", "L4", "L5", "L6"]


class RosNode:
    """The rclpy node subprocess: send a JSON request, read its JSON reply."""

    def __init__(self, domain: int, namespace: str) -> None:
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), RMW_IMPLEMENTATION="rmw_fastrtps_cpp")
        env.pop("PYTHONPATH", None)  # the ROS venv must not see parolkit: DDS is the only link
        self.proc = subprocess.Popen([str(ROS_PYTHON), str(NODE), namespace], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        first = self._read(60)
        assert first == {"ready": True}, first

    def _read(self, timeout: float) -> Any:
        out: list[str] = []
        t = threading.Thread(target=lambda: out.append(self.proc.stdout.readline()))  # type: ignore[union-attr]
        t.start()
        t.join(timeout)
        if not out or not out[0]:
            self.proc.kill()
            raise AssertionError(f"rclpy node gave no reply within {timeout} s; stderr:\n{self.proc.stderr.read()}")  # type: ignore[union-attr]
        return json.loads(out[0])

    def ask(self, timeout: float = 60, **req: Any) -> Any:
        self.proc.stdin.write(json.dumps(req) + "\n")  # type: ignore[union-attr]
        self.proc.stdin.flush()  # type: ignore[union-attr]
        return self._read(timeout)

    def close(self) -> None:
        try:
            self.ask(timeout=10, cmd="quit")
        except (AssertionError, OSError, ValueError):
            pass
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)


@pytest.fixture(scope="module")
def setup(tmp_path_factory):  # type: ignore[no-untyped-def]
    if not ROS_PYTHON.exists():
        pytest.fail(f"the ROS 2 test environment {ROS_PYTHON} is missing: run `make ros-venv` "
                    "(or set PAROLKIT_ROS_PYTHON to a python with ros-jazzy-rclpy)")
    log_dir = tmp_path_factory.mktemp("ros2")
    # the board in lockstep with the frames: where it is at a tick does not depend on the load
    ctl = start_controller(log_dir=log_dir, lockstep=True)
    domain = 100 + os.getpid() % 100
    # a namespace of this process's own: another test process (pytest -n, another checkout)
    # on the same DDS domain never mixes its topics with these
    ns = f"parol6_{os.getpid()}"
    env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO_ROOT / "src"))
    bridge_log = open(log_dir / "bridge.log", "w")
    bridge = subprocess.Popen(
        [sys.executable, "-m", "parolkit", "ros2", "--connect", f"127.0.0.1:{ctl.port}",
         "--domain", str(domain), "--namespace", ns],
        stdout=bridge_log, stderr=subprocess.STDOUT, env=env, cwd=REPO_ROOT)
    node = RosNode(domain, ns)
    robot = Robot(port=ctl.port, timeout=2.0)
    log = StatusLog(robot)
    yield {"ctl": ctl, "node": node, "robot": robot, "log": log, "bridge": bridge,
           "bridge_log": log_dir / "bridge.log"}
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


def test_robot_description_arrives_transient_local_and_parses_as_the_parol6_urdf(setup) -> None:  # type: ignore[no-untyped-def]
    urdf = setup["node"].ask(cmd="description")["urdf"]
    assert urdf is not None, setup["bridge_log"].read_text()
    root = ET.fromstring(urdf)
    assert root.get("name") == "parol6"
    assert [j.get("name") for j in root.findall("joint") if j.get("type") == "revolute"] == NAMES


def test_joint_states_reach_rclpy_in_radians_at_the_status_rate(setup) -> None:  # type: ignore[no-untyped-def]
    msgs = setup["node"].ask(cmd="joint_states", n=50)["msgs"]
    assert len(msgs) >= 50, setup["bridge_log"].read_text()
    st = setup["robot"].status()
    for m in msgs:
        assert m["name"] == NAMES
        np.testing.assert_allclose(m["position"], np.radians(st.angles), atol=1e-6)  # idle robot
        assert m["velocity"] == [0.0] * 6
    stamps = [m["stamp"] for m in msgs]
    assert all(b > a for a, b in zip(stamps, stamps[1:]))
    # one message per control tick: the mean interval is the controller's period
    mean = (stamps[-1] - stamps[0]) / (len(stamps) - 1)
    period = 1.0 / st.loop.rate_hz
    assert 0.5 * period < mean < 2.0 * period, (mean, period)


def _points_rad(start_deg: tuple[float, ...], offsets_deg: list[list[float]]) -> list[list[float]]:
    return [list(np.radians(np.array(start_deg) + np.array(o))) for o in offsets_deg]


def test_a_trajectory_over_the_speed_limit_is_refused_and_nothing_moves(setup) -> None:  # type: ignore[no-untyped-def]
    node, robot, log = setup["node"], setup["robot"], setup["log"]
    start = robot.status()
    assert start.command is None and start.queue == 0
    # J1 -40 deg in 0.3 s (about 133 deg/s; J1's maximum is 57 deg/s) after a reachable first point
    pts = _points_rad(start.angles, [[-5, 0, 0, 0, 0, 0], [-45, 0, 0, 0, 0, 0]])
    log.clear()
    node.ask(cmd="publish", names=NAMES, points=[[1.0, pts[0]], [1.3, pts[1]]])
    ev = node.ask(cmd="event")["event"]
    assert ev is not None and ev.startswith("refused:") and "J1" in ev and "too fast" in ev, ev
    # nothing was sent: every status since the publish shows the same steps and no command
    wait_until(lambda: len(log.snapshot()) >= 50, timeout=10, what="50 statuses")
    seen = log.snapshot()
    assert all(s.raw["steps"] == start.raw["steps"] and s.command is None and s.queue == 0 for s in seen)
    assert "refused" in setup["bridge_log"].read_text()


def _run_trajectory(setup, offsets: list[list[float]], times: list[float],  # type: ignore[no-untyped-def]
                    velocities_deg_s: list[list[float]] | None = None, accepted: str = "accepted:"):
    """Publish a trajectory from the current position (with the velocities, rad/s, when given);
    return (points rad, statuses seen, rate)."""
    node, robot, log = setup["node"], setup["robot"], setup["log"]
    start = robot.status()
    rate = start.loop.rate_hz
    pts = _points_rad(start.angles, offsets)
    points: list[list[Any]] = [[t, q] for t, q in zip(times, pts)]
    if velocities_deg_s is not None:
        points = [[t, q, list(np.radians(v))] for (t, q), v in zip(points, velocities_deg_s)]
    log.clear()
    node.ask(cmd="publish", names=NAMES, points=points)
    ev = node.ask(cmd="event")["event"]
    assert ev is not None and ev.startswith(accepted), (ev, setup["bridge_log"].read_text())
    done = node.ask(cmd="event", timeout=30)["event"]
    assert done is not None and done.startswith("done:"), done
    wait_until(lambda: log.snapshot()[-1].command is None, timeout=10, what="the path to end")
    return pts, log.snapshot(), rate


def _the_command(seen: list[RobotStatus]) -> list[RobotStatus]:
    """The statuses of the trajectory's command: the bridge sends ONE MOVEJOINTPATH."""
    by_id: dict[str, list[RobotStatus]] = {}
    for s in seen:
        if s.command is not None and s.command.id:
            by_id.setdefault(s.command.id, []).append(s)
    assert len(by_id) == 1, {k: v[0].command.name for k, v in by_id.items() if v[0].command is not None}
    (statuses,) = by_id.values()
    assert statuses[0].command is not None and statuses[0].command.name == "MOVEJOINTPATH"
    return statuses


def _start_seq(statuses: list[RobotStatus], planned_ticks: int) -> int:
    """The tick (seq) before the command's first sample, from the first status seen of it and
    its progress (k / planned_ticks after k samples): right even when the test lost status
    datagrams at the start (a loaded machine), as seq counts the controller's ticks."""
    first = statuses[0]
    assert first.command is not None and first.command.progress is not None
    return first.seq - round(first.command.progress * planned_ticks)


def _steps_off(st: RobotStatus, target: np.ndarray) -> int:
    return int(np.abs(np.array(st.raw["steps"]) - target).max())


OFFSETS = [[8, -5, 6, 10, 8, -12], [15, -8, 10, 5, 15, -20], [20, -10, 12, 15, 20, -25]]
TIMES = [1.5, 3.0, 4.0]


def test_a_three_point_trajectory_over_4_s_passes_its_points_and_ends_within_one_step_of_the_last(setup) -> None:  # type: ignore[no-untyped-def]
    pts, seen, rate = _run_trajectory(setup, OFFSETS, TIMES)
    path = _the_command(seen)
    start = _start_seq(path, round(TIMES[-1] * rate))
    # the interior points are passed without stopping, on time: within a few ticks of its time the
    # board comes within 15 steps of each (the GO TO loop follows the moving target a tick behind)
    for k, t in enumerate(TIMES[:-1]):
        target = rad_to_steps(pts[k], PAROL6)
        tick = start + round(t * rate)
        near = [s for s in seen if tick - 1 <= s.seq <= tick + 3]
        assert near and min(_steps_off(s, target) for s in near) <= 15, (k, [_steps_off(s, target) for s in near])
        assert any(any(v != 0 for v in s.speeds_deg_s) for s in near), (k, "stopped at an interior point")
    final = np.array(seen[-1].raw["steps"])
    assert np.abs(final - rad_to_steps(pts[-1], PAROL6)).max() <= 1
    # the joint states the ROS node sees come to the last point (a bridge held up on a busy
    # machine still publishes the statuses it had queued: the next 5 were from mid-motion once)
    wait_until(lambda: _joint_states_at(setup["node"], pts[-1]), 30,
               what="the ROS node's joint states at the last point")


def _joint_states_at(node: Any, position: list[float]) -> bool:
    """The newest of the next 5 joint_states ``node`` receives is at ``position`` (rad, within
    0.01 deg)."""
    got = node.ask(cmd="joint_states", n=5)["msgs"]
    return bool(got) and bool(np.allclose(got[-1]["position"], position, atol=math.radians(0.01), rtol=0))


def test_a_three_point_trajectory_over_4_s_ends_on_time_within_one_tick(setup) -> None:  # type: ignore[no-untyped-def]
    # back towards the start of the previous test
    back = [[a - b for a, b in zip(o, OFFSETS[-1])] for o in ([12, -6, 6, 8, 12, -15], [4, -2, 2, 3, 4, -5], [0] * 6)]
    pts, seen, rate = _run_trajectory(setup, back, TIMES)
    planned = round(TIMES[-1] * rate)
    path = _the_command(seen)
    first = _start_seq(path, planned)
    target = rad_to_steps(pts[-1], PAROL6)
    last_sample = next(s.seq for s in path if s.command is not None and s.command.progress == 1.0)
    arrival = next(s.seq for s in seen if s.seq > first and _steps_off(s, target) <= 1)
    print(f"trajectory end: last sample {last_sample - first} ticks after the start (planned {planned}); "
          f"the board within 1 step of the last point after {arrival - first} ticks")
    assert abs((last_sample - first) - planned) <= 1, (last_sample - first, planned)
    assert abs((arrival - first) - planned) <= 1, (arrival - first, planned)


def test_a_moveit_style_trajectory_with_a_start_point_and_velocities_follows_them_and_ends_on_time(setup) -> None:  # type: ignore[no-untyped-def]
    # as MoveIt plans: point 0 is the current position at time 0, every point has velocities
    offsets = [[0] * 6, [5, -3, 4, 6, 5, -7], [10, -5, 8, 10, 10, -12], [12, -6, 9, 12, 12, -14]]
    times = [0.0, 1.0, 2.0, 2.5]
    velocities = [[0] * 6, [5, -3, 4, 5, 5, -7], [3, -1, 2, 3, 3, -3], [0] * 6]
    pts, seen, rate = _run_trajectory(setup, offsets, times, velocities,
                                      accepted="accepted: 3 points, 250 ticks (2.500 s), the message's velocities")
    planned = round(times[-1] * rate)
    path = _the_command(seen)
    first = _start_seq(path, planned)
    last_sample = next(s.seq for s in path if s.command is not None and s.command.progress == 1.0)
    assert abs((last_sample - first) - planned) <= 1, (last_sample - first, planned)
    assert _steps_off(seen[-1], rad_to_steps(pts[-1], PAROL6)) <= 1


def test_the_bridge_exits_with_status_1_when_the_controller_goes_silent(tmp_path) -> None:  # type: ignore[no-untyped-def]
    ctl = start_controller(log_dir=tmp_path)
    env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO_ROOT / "src"))
    bridge = subprocess.Popen(
        [sys.executable, "-m", "parolkit", "ros2", "--connect", f"127.0.0.1:{ctl.port}",
         "--domain", str(100 + (os.getpid() + 50) % 100)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, cwd=REPO_ROOT, text=True)
    try:
        lines = [bridge.stdout.readline() for _ in range(2)]  # type: ignore[union-attr]
        assert any("parolkit ros2: ready" in line for line in lines), lines
        ctl.stop()
        assert bridge.wait(30) == 1
        out = bridge.stdout.read()  # type: ignore[union-attr]
        assert f"no status from the controller at 127.0.0.1:{ctl.port} for 5 s: exiting" in out, out
    finally:
        if bridge.poll() is None:
            bridge.kill()
        ctl.stop()
