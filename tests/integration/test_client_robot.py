"""Robot and AsyncRobot round trips against the REAL controller (``parolkit serve --sim``).

One controller subprocess serves the whole module, on a board in lockstep with its frames.  The
tests leave the robot idle and enabled for the next one.
"""

from __future__ import annotations

import asyncio
import math
import socket
import time

import pytest
from tests.conftest import start_controller, wait_until

from parolkit.client.async_robot import AsyncRobot
from parolkit.client.core import AckStatus
from parolkit.client.errors import CommandCancelled, CommandFailed, CommandInvalid
from parolkit.client.robot import Robot

STANDBY = [90, -90, 180, 0, 0, 180]
#: away from the wrist singularity of the standby pose (J5 = 0): Cartesian paths are free here
WORK = [90, -100, 160, 0, 30, 180]


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    cp = start_controller(log_dir=tmp_path_factory.mktemp("ctl"), lockstep=True)
    yield cp
    cp.stop()


@pytest.fixture
def robot(served):
    # acks go to the controller's --ack-port (docs/protocol.md); listen there
    r = Robot(port=served.port, ack_port=served.ack_port, timeout=2.0)
    yield r
    try:
        st = r.status()
        if st.command is not None or st.queue:
            r.stop()
        if st.state != "IDLE":
            r.enable()
    finally:
        r.close()


def test_move_joints_waits_until_the_robot_is_at_the_target(robot):
    target = [80, -95, 170, 5, 5, 170]
    seq0 = robot.status().seq
    res = robot.move_joints(target, duration=0.8)
    assert res.status is AckStatus.COMPLETED and res.command == "MOVEJOINT"
    assert robot.status().seq - seq0 >= 80  # the move's 80 ticks have run
    assert robot.angles() == pytest.approx(target, abs=0.02)
    robot.move_joints(STANDBY, speed=80)
    assert robot.status().angles == pytest.approx(STANDBY, abs=0.02)


def test_a_200_point_path_with_velocities_goes_in_one_datagram_and_ends_on_its_last_point(robot):
    """MOVEJOINTPATH at its largest (200 points, velocities, full float precision: ~50 KB) through
    the real server: one command, COMPLETED on the last point."""
    start = robot.angles()
    amp = [5.0, -3.0, 4.0, 6.0, 5.0, -7.0]  # deg: out and back, q = start + amp (1 - cos(2 pi t / T)) / 2
    period = 2.0
    times = [period * (k + 1) / 200 for k in range(200)]
    points = [[q0 + a * (1 - math.cos(2 * math.pi * t / period)) / 2 for q0, a in zip(start, amp)] for t in times]
    points[-1] = list(start)
    velocities = [[a * math.pi / period * math.sin(2 * math.pi * t / period) for a in amp] for t in times]
    velocities[-1] = [0.0] * 6
    res = robot.move_joint_path(points, times, velocities, timeout=20)
    assert res.status is AckStatus.COMPLETED and res.command == "MOVEJOINTPATH"
    assert robot.angles() == pytest.approx(start, abs=0.02)


def test_unreachable_pose_fails_with_the_controllers_ik_reason(robot):
    with pytest.raises(CommandFailed) as info:
        robot.move_pose([900, 0, 0, 0, 0, 0], duration=1)
    assert "reach" in info.value.reason and info.value.command == "MOVEPOSE"


def test_refused_command_is_invalid_and_names_the_field_and_range(robot):
    with pytest.raises(CommandInvalid) as info:
        robot.move_joints([200, -90, 180, 0, 0, 180], duration=1)
    assert "J1" in info.value.reason and "123.0469" in info.value.reason
    assert isinstance(info.value, ValueError)


def test_stop_cancels_a_running_move_and_its_handle_reports_it(robot):
    handle = robot.move_joints([60, -100, 160, 10, 10, 160], duration=3, wait=False)
    assert handle.status() in (AckStatus.QUEUED, AckStatus.EXECUTING)
    wait_until(lambda: handle.status() is AckStatus.EXECUTING, what="the move running")
    assert robot.stop().ok
    with pytest.raises(CommandCancelled) as info:
        handle.result(timeout=3)
    assert "STOP" in info.value.reason
    robot.move_joints(STANDBY, speed=80)


def test_wait_input_fails_with_the_reason_when_the_input_never_comes(robot):
    with pytest.raises(CommandFailed) as info:
        robot.wait_input(1, 1, input_timeout=0.3)
    assert "IN1" in info.value.reason
    assert robot.wait_input(1, 0, input_timeout=1).ok  # IN1 is low: completes at once


def test_queries_agree_with_the_status_snapshot(robot):
    st = robot.status()
    assert st.state == "IDLE" and st.all_homed and st.board.connected and st.board.simulated
    assert st.loop.rate_hz == pytest.approx(100.0)
    assert robot.angles() == pytest.approx(st.angles, abs=1e-3)
    assert list(robot.pose()) == pytest.approx(list(st.pose), abs=0.05)
    m = robot.pose_matrix()
    assert m[3] == (0, 0, 0, 1) and m[0][3] * 1000 == pytest.approx(st.pose.x, abs=0.05)
    assert robot.io().estop_pressed is False
    assert robot.ping() is True
    assert robot.queue().active is None
    assert robot.tool().name == st.tool
    assert robot.loop_stats().ticks > 0


def test_subscribe_streams_typed_statuses_every_n_ticks(robot):
    with robot.subscribe(every_n=10) as sub:
        statuses = [sub.next(timeout=2) for _ in range(4)]
    seqs = [s.seq for s in statuses]
    assert all(b > a for a, b in zip(seqs, seqs[1:]))
    gaps = [b - a for a, b in zip(seqs, seqs[1:])]
    assert max(gaps) >= 9  # one status per 10 control ticks (seq counts ticks)
    assert statuses[-1].angles == pytest.approx(robot.angles(), abs=0.01)


def test_async_robot_round_trip(served):
    async def main():
        async with AsyncRobot(port=served.port, ack_port=served.ack_port, timeout=2.0) as r:
            res = await r.move_joints([85, -92, 175, 2, 2, 175], duration=1.0)
            assert res.ok
            assert await r.angles() == pytest.approx([85, -92, 175, 2, 2, 175], abs=0.02)
            with pytest.raises(CommandInvalid):
                await r.move_joints([0, 0, 0, 0, 0, 0], duration=1)  # J2 = 0 is out of range
            async with r.subscribe(every_n=5) as sub:
                st = await sub.next(timeout=2)
            assert st.state == "IDLE"
            await r.move_joints(STANDBY, speed=80)

    asyncio.run(main())


def test_robot_api_acks_and_queries_against_the_controller(served):
    from parolkit.client import robot_api

    before = robot_api.configure()
    robot_api.configure(port=served.port, ack_port=served.ack_port)
    try:
        res = robot_api.move_robot_joints([85, -95, 175, 3, 3, 175], duration=0.6, wait_for_ack=True,
                                          timeout=5.0)
        assert res["status"] == "COMPLETED", res
        assert robot_api.get_robot_joint_angles() == pytest.approx([85, -95, 175, 3, 3, 175], abs=0.02)
        bad = robot_api.move_robot_joints([0, 0, 180, 0, 0, 180], duration=1, wait_for_ack=True)
        assert bad["status"] == "INVALID" and "J2" in bad["details"]
        cid = robot_api.move_robot_joints(STANDBY, speed_percentage=80, wait_for_ack=True,
                                          non_blocking=True)
        assert robot_api.wait_for_robot_stopped(timeout=10, poll_rate=0.05)
        deadline = time.monotonic() + 5
        while not (robot_api.check_command_status(cid) or {}).get("completed"):
            assert time.monotonic() < deadline
            time.sleep(0.02)
        assert robot_api.check_command_status(cid)["status"] == "COMPLETED"
        st = robot_api.get_robot_status()
        assert st["state"] == "IDLE" and st["homed"] == [True] * 6 and st["estop"] is False
        assert st["angles"] == pytest.approx(STANDBY, abs=0.02)
        assert robot_api.ping_robot() is True
    finally:
        robot_api.configure(port=before["port"], ack_port=before["ack_port"])  # stops the listener


def test_smooth_paths_and_cartesian_moves_run_or_fail_with_the_planners_reason(robot):
    robot.move_joints(WORK, duration=1.2)
    x, y, z, a, b, c = robot.pose()
    res = robot.smooth_blend([{"type": "LINE", "end": [x + 10, y, z, a, b, c], "duration": 0.6},
                              {"type": "LINE", "end": [x + 10, y - 10, z, a, b, c], "duration": 0.6}])
    assert res.ok
    assert list(robot.pose())[:3] == pytest.approx([x + 10, y - 10, z], abs=0.5)
    assert robot.move_cart([x, y, z - 10, a, b, c], speed=50).ok
    assert robot.move_cart_rel_trf([0, 0, 5, 0, 0, 0], duration=0.5).ok
    with pytest.raises(CommandFailed) as info:  # a joint would have to move too fast
        robot.smooth_helix([x, y - 20, z], 20, 10, 20, duration=1)
    assert "speed" in info.value.reason and info.value.command == "SMOOTH_HELIX"
    robot.move_joints(STANDBY, duration=1.2)


def test_software_estop_cancels_motion_until_enable(robot):
    assert "ENABLE" in robot.estop().details
    with pytest.raises((CommandCancelled, CommandFailed), match="E-stop"):  # refused while latched
        robot.move_joints([85, -90, 180, 0, 0, 180], duration=1)
    assert robot.enable().ok
    deadline = time.monotonic() + 5
    while robot.status().state != "IDLE":
        assert time.monotonic() < deadline
        time.sleep(0.02)
    assert robot.move_joints(STANDBY, duration=0.6).ok


def _forge(port: int, cid: str) -> None:
    """Another process on the machine sends a COMPLETED ack for ``cid`` to ``port``."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for _ in range(3):
            s.sendto(f"ACK|{cid}|COMPLETED|forged".encode(), ("127.0.0.1", port))


def test_a_forged_ack_is_ignored_by_robot_and_robot_api(served):
    from parolkit.client import robot_api

    with Robot(port=served.port, ack_port=0, timeout=2.0) as r:
        h = r.move_joints([80, -85, 170, 5, 5, 170], duration=1.5, wait=False)
        _forge(r.ack_port, h.id)
        time.sleep(0.2)
        assert not h.done(), "a forged COMPLETED was taken for the controller's"
        res = h.result(timeout=10)
        assert res.ok and "forged" not in res.details
        r.move_joints(STANDBY, speed=80)

    before = robot_api.configure()
    robot_api.configure(port=served.port, ack_port=served.ack_port)
    try:
        cid = robot_api.move_robot_joints([80, -85, 170, 5, 5, 170], duration=1.5, wait_for_ack=True,
                                          non_blocking=True)
        _forge(served.ack_port, cid)
        # an ack for an ID this process never sent is not recorded either
        _forge(served.ack_port, "zz99ZZ99")
        time.sleep(0.2)
        assert not (robot_api.check_command_status(cid) or {}).get("completed")
        assert robot_api.check_command_status("zz99ZZ99") is None
        end = time.monotonic() + 10
        while not (robot_api.check_command_status(cid) or {}).get("completed") and time.monotonic() < end:
            time.sleep(0.05)
        st = robot_api.check_command_status(cid)
        assert st["status"] == "COMPLETED" and st["details"] != "forged"
        robot_api.move_robot_joints(STANDBY, speed_percentage=80, wait_for_ack=True, timeout=10)
    finally:
        robot_api.configure(**{k: before[k] for k in ("host", "port", "ack_port")})


def test_command_ids_are_unguessable_and_never_read_as_names():
    from parolkit.client import robot_api
    from parolkit.protocol.commands import is_command_id

    ids = {robot_api.new_command_id() for _ in range(20_000)}
    assert len(ids) == 20_000
    assert all(is_command_id(i) for i in ids)
    # letters and digits of both cases: 62 symbols per position, not 16 hex digits
    assert len(set("".join(ids))) == 62
