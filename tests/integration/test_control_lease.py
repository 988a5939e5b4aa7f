"""Who may move the robot: the control lease, tried on a real controller process over real UDP
sockets, as a second (hostile or just careless) local client would (issue 13)."""

from __future__ import annotations

import json
import socket
import time

import pytest
from tests.conftest import start_controller, wait_until

from parolkit.client.errors import CommandCancelled, CommandFailed
from parolkit.client.robot import Robot

STANDBY = [90, -90, 180, 0, 0, 180]


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    d = tmp_path_factory.mktemp("lease")
    cfg = d / "controller.toml"
    cfg.write_text("[controller]\nlease_timeout_s = 1.0\n")
    cp = start_controller(["--config", str(cfg)], log_dir=d)
    yield cp
    cp.stop()


@pytest.fixture
def two(served):
    a = Robot(port=served.port, ack_port=0, timeout=2.0)
    b = Robot(port=served.port, ack_port=0, timeout=2.0)
    yield a, b
    for r in (a, b):
        try:
            r.stop()
            r.release_control()
        except Exception:
            pass
        r.close()
    # nobody holds the lease for the next test
    wait_until(lambda: a_free(served), 5, what="the lease free")


def a_free(served) -> bool:
    reply = served.query("GET_CONTROL") or ""
    return reply.startswith("CONTROL|") and json.loads(reply.split("|", 1)[1])["holder"] is None


def test_a_second_clients_move_is_refused_while_the_first_holds_the_lease(two):
    a, b = two
    h = a.move_joints([80, -85, 170, 5, 5, 170], duration=2.0, wait=False)
    with pytest.raises(CommandFailed) as info:
        b.move_joints([95, -95, 185, 0, 0, 185], duration=1.0)
    msg = str(info.value)
    assert f"controlled by 127.0.0.1:{a.ack_port}" in msg and "CONTROL TAKE" in msg and "STOP" in msg
    for bad in (lambda: b.home(), lambda: b.set_tool("flange"), lambda: b.enable()):
        with pytest.raises(CommandFailed, match="controlled by"):
            bad()
    assert a.control()["holder"] == f"127.0.0.1:{a.ack_port}"
    assert h.result(timeout=10).ok
    a.move_joints(STANDBY, speed=80)


def test_the_lease_passes_on_release_and_on_expiry(two):
    a, b = two
    a.move_joints([85, -90, 180, 0, 0, 180], duration=0.5)
    with pytest.raises(CommandFailed, match="controlled by"):
        b.move_joints(STANDBY, duration=0.5)
    a.release_control()
    assert b.move_joints(STANDBY, duration=0.5).ok  # taken implicitly
    with pytest.raises(CommandFailed, match="controlled by"):
        a.move_joints([85, -90, 180, 0, 0, 180], duration=0.5)
    # b falls silent with the robot idle: after lease_timeout_s (1 s) anyone may take it
    time.sleep(1.3)
    assert a.move_joints([85, -90, 180, 0, 0, 180], duration=0.5).ok
    a.move_joints(STANDBY, duration=0.5)


def test_the_lease_does_not_lapse_while_the_holders_move_runs(two):
    a, b = two
    h = a.move_joints([80, -85, 170, 5, 5, 170], duration=2.5, wait=False)
    time.sleep(1.5)  # silent for longer than the 1 s timeout, but the move still runs
    with pytest.raises(CommandFailed, match="controlled by"):
        b.move_joints(STANDBY, duration=0.5)
    assert h.result(timeout=10).ok
    a.move_joints(STANDBY, speed=80)


def test_stop_and_estop_work_from_anyone(two):
    a, b = two
    h = a.move_joints([80, -85, 170, 5, 5, 170], duration=3.0, wait=False)
    time.sleep(0.2)
    b.stop()
    with pytest.raises(CommandCancelled):
        h.result(timeout=5)
    h = a.move_joints(STANDBY, duration=3.0, wait=False)
    time.sleep(0.2)
    b.estop()
    with pytest.raises(CommandCancelled):
        h.result(timeout=5)
    # releasing the E-stop is a command of the lease holder
    with pytest.raises(CommandFailed, match="controlled by"):
        b.enable()
    a.enable()
    a.move_joints(STANDBY, speed=80)


def test_a_forced_take_over_cancels_the_holders_commands(two):
    a, b = two
    h = a.move_joints([80, -85, 170, 5, 5, 170], duration=3.0, wait=False)
    time.sleep(0.2)
    with pytest.raises(CommandFailed, match="controlled by"):
        b.take_control()
    assert "taken over" in b.take_control(force=True).details
    # the holder learns why (it read "stopped by STOP", a STOP nobody sent)
    with pytest.raises(CommandCancelled, match="control taken over from .* by "):
        h.result(timeout=5)
    assert b.move_joints(STANDBY, speed=80).ok


def test_set_port_from_a_non_holder_is_refused(two):
    a, b = two
    a.move_joints(STANDBY, duration=0.3)
    with pytest.raises(CommandFailed, match="controlled by"):
        b.set_port("/dev/ttyACM0")


def test_get_queue_shows_other_clients_commands_without_their_ids(two):
    a, b = two
    first = a.move_joints([80, -85, 170, 5, 5, 170], duration=1.5, wait=False)
    second = a.move_joints(STANDBY, duration=1.5, wait=False)
    time.sleep(0.1)
    mine, theirs = a.queue(), b.queue()
    assert mine.active.id == first.id and mine.queued[0][0] == second.id
    assert theirs.active.id is None and theirs.active.name == "MOVEJOINT"
    assert theirs.queued == ((None, "MOVEJOINT"),)
    second.result(timeout=10)


def test_subscribe_to_a_third_address_is_refused(served):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as victim:
        s.bind(("127.0.0.1", 0))
        victim.bind(("127.0.0.1", 0))
        victim.settimeout(0.5)
        s.settimeout(1.0)
        request = f"SUBSCRIBE|{victim.getsockname()[1]}|1"
        s.sendto(request.encode(), ("127.0.0.1", served.port))
        cookie = s.recvfrom(65535)[0].decode()  # first the cookie, to the sender alone
        assert cookie.startswith("COOKIE|") and len(cookie) <= len(request)
        s.sendto(f"{request}|{cookie.split('|', 1)[1]}".encode(), ("127.0.0.1", served.port))
        reply = s.recvfrom(65535)[0].decode()
        assert reply.startswith("ERROR|") and "applies to the socket that sends it" in reply
        with pytest.raises(TimeoutError):
            victim.recvfrom(65535)


def test_an_untracked_command_from_a_non_holder_gets_an_error_reply(two, served):
    a, _ = two
    h = a.move_joints([80, -85, 170, 5, 5, 170], duration=1.5, wait=False)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.settimeout(1.0)
        s.sendto(b"HOME", ("127.0.0.1", served.port))
        reply = s.recvfrom(65535)[0].decode()
    assert reply.startswith("ERROR|HOME refused: the robot is controlled by")
    h.result(timeout=10)
    a.move_joints(STANDBY, speed=80)
