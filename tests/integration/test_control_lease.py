"""Who may move the robot: the control lease, tried on a real controller process over real UDP
sockets, as a second (hostile or just careless) local client would (issue 13); and what such a
client on the same host could forge until issue 22:

1. Every sender (address and port) is its own client: once one socket holds the control lease,
   no other socket moves the arm, and a flood of ACK_HERE sockets never pushes the holder out.
2. A command ID belongs to its sender: another sender reusing it (read from GET_STATUS_JSON)
   is refused, and nothing with that ID reaches the owner's ack port.
3. No status stream to an address that did not ask: until the subscribing address echoes its
   cookie, the controller sends it no more bytes than it received.

The issue 22 tests judge time by the controller's own tick counter (the status ``seq``), never
by wall time.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time

import pytest
from tests.conftest import start_controller, udp_query, wait_until

from parolkit.client import robot_api
from parolkit.client.errors import CommandCancelled, CommandFailed
from parolkit.client.robot import Robot

STANDBY = [90, -90, 180, 0, 0, 180]
SECRET = "s3cr3t-pass-1234"


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
    wait_until(lambda: holder(served.port) is None, 5, what="the lease free")


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


# ================================================================== issue 22


@pytest.fixture
def api(served):
    """robot_api pointed at the controller (its ack listener closed afterwards)."""
    before = robot_api.configure()
    robot_api.configure(port=served.port, ack_port=served.ack_port)
    yield robot_api
    robot_api.configure(port=before["port"], ack_port=before["ack_port"])  # stops the listener


def status(port: int) -> dict:
    reply = udp_query(port, "GET_STATUS_JSON", 2.0) or ""
    assert reply.startswith("STATUS_JSON|"), reply
    return json.loads(reply.split("|", 1)[1])


def wait_ticks(port: int, ticks: int) -> dict:
    """Wait until the controller has run ``ticks`` more control ticks; its status then."""
    start = status(port)["seq"]
    return wait_until(lambda: (s := status(port))["seq"] >= start + ticks and s, 30,
                      what=f"{ticks} ticks")


def holder(port: int) -> str | None:
    reply = udp_query(port, "GET_CONTROL", 2.0) or ""
    assert reply.startswith("CONTROL|"), reply
    return json.loads(reply.split("|", 1)[1])["holder"]


def fresh_socket(timeout: float = 2.0) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(timeout)
    return s


def receive_all(sock: socket.socket) -> list[bytes]:
    """Every datagram waiting on ``sock`` now."""
    sock.setblocking(False)
    out = []
    try:
        while True:
            out.append(sock.recv(65535))
    except BlockingIOError:
        return out
    finally:
        sock.setblocking(True)


def until_idle(port: int) -> None:
    wait_until(lambda: (s := status(port))["command"] is None and s["queue"] == 0, 20, what="idle")


# ------------------------------------------------------------------ 1. every sender is its own client


def configured(controller_factory, tmp_path, toml: str):
    """A controller started with ``[controller]`` settings ``toml``."""
    cfg = tmp_path / "controller.toml"
    cfg.write_text(f"[controller]\n{toml}\n")
    return controller_factory(["--config", str(cfg)])


def test_with_the_secret_held_by_one_process_another_processs_move_is_refused(controller_factory, tmp_path):
    """The issue's reproduction: one process takes control with the secret, another sends a
    move without it; the move used to complete (every sender without ACK_HERE was one client)."""
    ctl = configured(controller_factory, tmp_path, f'secret = "{SECRET}"')
    take = (f"import socket;s=socket.socket(2,2);"
            f"s.sendto(b'abcd1234|CONTROL|TAKE|{SECRET}',('127.0.0.1',{ctl.port}))")
    subprocess.run([sys.executable, "-c", take], check=True, timeout=30)
    wait_until(lambda: holder(ctl.port) is not None, 10, what="the lease taken")
    with fresh_socket() as other:  # another process's socket
        other.sendto(b"MOVEJOINT|80|-90|180|0|0|180|3|None", ("127.0.0.1", ctl.port))
        reply = other.recv(65535).decode()
    assert reply.startswith("ERROR|MOVEJOINT refused: the robot is controlled by 127.0.0.1:"), reply
    st = wait_ticks(ctl.port, 50)  # half a second of the controller's time: nothing moved
    assert st["command"] is None and st["queue"] == 0
    assert st["angles"] == pytest.approx(STANDBY, abs=0.01)


def test_the_socket_that_took_control_moves_and_no_other_socket_does(controller_factory, tmp_path):
    ctl = configured(controller_factory, tmp_path, f'secret = "{SECRET}"')
    with Robot(port=ctl.port, ack_port=0, timeout=2.0) as mine, fresh_socket() as other:
        assert mine.take_control(secret=SECRET).ok
        assert holder(ctl.port) == f"127.0.0.1:{mine.ack_port}"
        other.sendto(b"ACK_HERE", ("127.0.0.1", ctl.port))  # registering changes nothing
        other.sendto(b"HOME", ("127.0.0.1", ctl.port))
        assert other.recv(65535).decode().startswith("ERROR|HOME refused: the robot is controlled by")
        assert mine.move_joints([85, -90, 180, 0, 0, 180], duration=0.5).ok
        assert mine.move_joints(STANDBY, duration=0.5).ok


def test_a_flood_of_ack_here_sockets_never_pushes_the_holder_out(controller_factory, tmp_path):
    """300 sockets registering with ACK_HERE used to push the holder out of the 256-entry table,
    after which its own commands were refused (and its lease lapsed to whoever came next).  Now
    the table refuses the newcomers ("busy") and the holder keeps both its place and its lease."""
    ctl = configured(controller_factory, tmp_path, "lease_timeout_s = 1.0")
    dest = ("127.0.0.1", ctl.port)
    with Robot(port=ctl.port, ack_port=0, timeout=2.0) as mine:
        assert mine.take_control().ok
        flood = [fresh_socket() for _ in range(300)]
        try:
            for s in flood:
                s.sendto(b"ACK_HERE", dest)
            refused = 0
            for s in flood:  # a PING after each ACK_HERE: its PONG comes after any refusal
                s.sendto(b"PING", dest)
                while (reply := s.recv(65535).decode()) != "PONG":
                    assert reply.startswith("ERROR|ACK_HERE refused: controller busy"), reply
                    refused += 1
            # the holder still moves, and gets its acks on its own socket
            assert mine.move_joints([85, -90, 180, 0, 0, 180], duration=0.5).ok
            assert holder(ctl.port) == f"127.0.0.1:{mine.ack_port}"
            assert refused >= 300 - 255, refused  # the holder's place was never given away
            flood[0].sendto(b"MOVEJOINT|80|-90|180|0|0|180|1|None", dest)
            assert flood[0].recv(65535).decode().startswith("ERROR|MOVEJOINT refused: the robot is controlled by")
            wait_until(lambda: status(ctl.port)["server"]["clients_refused"] == refused, 5,
                       what="the refusals counted")
            assert mine.move_joints(STANDBY, duration=0.5).ok
        finally:
            for s in flood:
                s.close()


def test_scripts_that_send_each_command_from_a_new_socket_work_while_nobody_holds_the_lease(served):
    """The original robot_api sends each command from a new socket: while the lease is free
    those commands run, and none of them takes the lease (the next one, from another socket,
    would then be refused)."""
    until_idle(served.port)
    wait_until(lambda: holder(served.port) is None, 5, what="the lease free")
    targets = ([85, -90, 180, 0, 0, 180], [85, -85, 175, 0, 0, 180], STANDBY)
    for t in targets:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(("MOVEJOINT|" + "|".join(map(str, t)) + "|0.4|None").encode(), ("127.0.0.1", served.port))
        assert holder(served.port) is None
    until_idle(served.port)
    assert status(served.port)["angles"] == pytest.approx(STANDBY, abs=0.01)


def test_robot_api_take_control_covers_the_processs_commands_and_no_other_sockets(served, api):
    until_idle(served.port)
    assert api.take_control()["status"] == "COMPLETED"
    assert holder(served.port) == f"127.0.0.1:{served.ack_port}"  # the listener's socket
    try:
        # fire and forget from this process: the same socket, the same client
        assert api.move_robot_joints([85, -90, 180, 0, 0, 180], duration=0.4).startswith("Successfully sent")
        wait_until(lambda: status(served.port)["angles"] == pytest.approx([85, -90, 180, 0, 0, 180], abs=0.01),
                   10, what="the fire-and-forget move")
        with fresh_socket() as other:  # another process on the host
            other.sendto(b"MOVEJOINT|80|-90|180|0|0|180|1|None", ("127.0.0.1", served.port))
            assert other.recv(65535).decode().startswith(
                f"ERROR|MOVEJOINT refused: the robot is controlled by 127.0.0.1:{served.ack_port}")
        assert api.move_robot_joints(STANDBY, duration=0.4, wait_for_ack=True, timeout=10)["status"] == "COMPLETED"
    finally:
        assert api.release_control()["status"] == "COMPLETED"


# ------------------------------------------------------------------ 2. a command ID belongs to its sender


def test_another_sender_cannot_end_a_running_command_with_its_id(served, api):
    """The issue's reproduction: the running command's ID is read from GET_STATUS_JSON and sent
    back as ``<ID>|PING`` (COMPLETED) and ``<ID>|\\xff`` (INVALID); the owner's wait used to
    return COMPLETED a second into a long move.  Now both are refused to their sender and the
    owner's only terminal ack is the move's own."""
    until_idle(served.port)
    cid = api.move_robot_joints([80, -85, 170, 5, 5, 170], duration=2.0, wait_for_ack=True, non_blocking=True)
    wait_until(lambda: (status(served.port)["command"] or {}).get("id") == cid, 10, what="the move running")
    with fresh_socket() as attacker:
        for forged in (f"{cid}|PING".encode(), f"{cid}|".encode() + b"\xff", f"{cid}|GET_ANGLES".encode(),
                       f"{cid}|MOVEJOINT|1|2".encode()):
            attacker.sendto(forged, ("127.0.0.1", served.port))
            reply = attacker.recv(65535).decode()
            assert reply.startswith("ERROR|") and f"command ID {cid} belongs to another client" in reply, reply
            assert receive_all(attacker) == []  # the refusal and nothing else (no PONG, no reply)
        assert (api.check_command_status(cid) or {}).get("completed") is not True
        rec = wait_until(lambda: (r := api.check_command_status(cid)) and r["completed"] and r, 15,
                         what="the move's terminal ack")
        assert rec["status"] == "COMPLETED" and rec["details"].startswith("MoveJoint finished"), rec
        assert status(served.port)["angles"] == pytest.approx([80, -85, 170, 5, 5, 170], abs=0.01)
        assert [s for s in rec["history"] if s in robot_api.TERMINAL_STATUSES] == ["COMPLETED"], rec
        # an ID that ended a moment ago stays its sender's too
        attacker.sendto(f"{cid}|PING".encode(), ("127.0.0.1", served.port))
        assert f"command ID {cid} belongs to another client" in attacker.recv(65535).decode()
    # counted (the status shows the server's counters as of its last tick)
    wait_until(lambda: status(served.port)["server"]["foreign_ids"] >= 5, 5, what="5 refusals counted")
    api.move_robot_joints(STANDBY, speed_percentage=80, wait_for_ack=True, timeout=10)


# ------------------------------------------------------------------ 3. no stream to an address that did not ask


def test_a_subscriber_that_never_echoes_its_cookie_gets_no_more_than_it_sent(served):
    """One SUBSCRIBE (with and without an ID) from a socket that never answers: over 100 ticks
    it receives one COOKIE no longer than its request and no status; no ack leaves either.
    This is what a victim whose address a spoofed SUBSCRIBE names receives (the server cannot
    tell the two apart: it answers the address in the datagram and waits for the echo); the
    forged datagram itself needs a raw socket, so the suite sends a real one that never
    echoes.  On 1dfd036 the same request streamed 88 KB in 100 ticks."""
    with fresh_socket() as silent, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as acks:
        acks.bind(("127.0.0.1", served.ack_port))
        port = silent.getsockname()[1]
        requests = [f"SUBSCRIBE|{port}|1".encode(), f"sub00001|SUBSCRIBE|{port}|1".encode()]
        for r in requests:
            silent.sendto(r, ("127.0.0.1", served.port))
        wait_ticks(served.port, 100)
        got = receive_all(silent)
        assert sum(map(len, got)) <= sum(map(len, requests)), [g[:40] for g in got]
        assert len(got) == 2 and all(g.startswith(b"COOKIE|") for g in got)
        assert all(len(g) <= len(r) for g, r in zip(got, requests))
        assert receive_all(acks) == []
        # echoing the cookie starts the stream
        cookie = got[0].decode().split("|", 1)[1]
        silent.sendto(f"SUBSCRIBE|{port}|1|{cookie}".encode(), ("127.0.0.1", served.port))
        assert silent.recv(65535).startswith(b"STATUS_JSON|")
        silent.sendto(f"UNSUBSCRIBE|{port}".encode(), ("127.0.0.1", served.port))
