"""/joint_states latency of ``parolkit ros2``: from the status it reflects to the ROS sample.

Starts a simulated controller (``parolkit serve --sim``) and ``parolkit ros2`` as separate
processes.  This process subscribes to the controller's status (as the bridge does, so both
receive the same datagram of each tick) and reads ``/joint_states`` over DDS (cyclonedds).
While the robot moves (every tick has new angles), each JointState is matched to the status
with the same angles; latency = JointState received here - that status received here
(``time.monotonic_ns``, one clock).  It is the bridge's whole path: UDP status in, decode,
JointState out over DDS, delivered to another process.

Prints p50 / p99 / max in ms and the acceptance (p99 <= 2 ms).  Needs ``parolkit[ros2]``.

    python bench/ros2_latency.py [--seconds 8]
"""

from __future__ import annotations

import argparse
import math
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from parolkit.client.core import RobotStatus
from parolkit.client.robot import Robot
from parolkit.ros2 import msgs
from parolkit.ros2.bridge import ros_qos

REPO = Path(__file__).resolve().parent.parent
_RAD = 180.0 / math.pi


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _key(angles_deg: list[float] | tuple[float, ...]) -> tuple[float, ...]:
    return tuple(round(a, 4) for a in angles_deg)  # the status carries 4 decimals


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=8.0, help="measuring time (s)")
    args = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"), PYTHONUNBUFFERED="1")
    port = _free_port()
    domain = 200 + os.getpid() % 30
    procs = [subprocess.Popen([sys.executable, "-m", "parolkit", "serve", "--sim", "--udp-port", str(port),
                               "--ack-port", str(_free_port())], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        robot = Robot(port=port, timeout=2.0)
        deadline = time.monotonic() + 30
        while True:
            try:
                st = robot.status()
                if st.all_homed and st.state == "IDLE":
                    break
            except Exception:
                pass
            if time.monotonic() > deadline:
                print("controller did not come up", file=sys.stderr)
                return 1
            time.sleep(0.2)
        robot.close()  # a fresh client now that the controller is up (its ACK_HERE must arrive)
        robot = Robot(port=port, timeout=2.0)
        procs.append(subprocess.Popen([sys.executable, "-m", "parolkit", "ros2", "--connect", f"127.0.0.1:{port}",
                                       "--domain", str(domain)], env=env, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))
        status_at: dict[tuple[float, ...], int] = {}
        repeated: set[tuple[float, ...]] = set()
        lock = threading.Lock()

        def on_status(s: RobotStatus) -> None:
            # only angles seen in exactly one status identify it (not a robot at rest)
            t = time.monotonic_ns()
            k = _key(s.angles)
            with lock:
                if k in status_at:
                    repeated.add(k)
                status_at[k] = t

        sub = robot.subscribe(1, callback=on_status)
        dp = DomainParticipant(domain)
        reader: DataReader[msgs.JointState] = DataReader(dp, Topic(dp, "rt/joint_states", msgs.JointState), ros_qos())
        ws = WaitSet(dp)
        ws.attach(ReadCondition(reader, SampleState.NotRead | ViewState.Any | InstanceState.Any))
        got: list[tuple[int, tuple[float, ...]]] = []
        # wait for the bridge
        end = time.monotonic() + 30
        while not got and time.monotonic() < end:
            ws.wait(duration(milliseconds=100))
            got += [(time.monotonic_ns(), _key([p * _RAD for p in m.position])) for m in reader.take(N=64)]
        if not got:
            print("no /joint_states from the bridge", file=sys.stderr)
            return 1
        start = robot.status().angles
        # several joints over the whole measuring time: (almost) every tick has new angles
        robot.move_joints([start[0] - 40, start[1] - 10, start[2] + 10, start[3] + 20, start[4] + 20, start[5] - 40],
                          duration=args.seconds + 1.0, wait=False)
        got.clear()
        t_end = time.monotonic() + args.seconds
        while time.monotonic() < t_end:
            ws.wait(duration(milliseconds=50))
            now = time.monotonic_ns()
            got += [(now, _key([p * _RAD for p in m.position])) for m in reader.take(N=64)]
        sub.close()
        with lock:
            lat = [(t - status_at[k]) / 1e6 for t, k in got if k in status_at and k not in repeated]
        moving = len({k for _, k in got})
        if len(lat) < 50:
            print(f"too few matched samples ({len(lat)})", file=sys.stderr)
            return 1
        lat.sort()
        p50 = lat[len(lat) // 2]
        p99 = lat[min(len(lat) - 1, int(len(lat) * 0.99))]
        print(f"/joint_states latency from its status: n={len(lat)} ({moving} distinct positions) "
              f"p50={p50:.3f} ms p99={p99:.3f} ms max={lat[-1]:.3f} ms  "
              f"[{'OK' if p99 <= 2.0 else 'OVER'} p99 <= 2 ms]")
        robot.close()
        return 0
    finally:
        for p in reversed(procs):
            p.terminate()
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()


if __name__ == "__main__":
    sys.exit(main())
