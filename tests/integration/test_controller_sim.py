"""``parolkit serve --sim`` as a real subprocess: INVALID/ERROR replies, GET_PLAN, config
precedence, bind warning, 250 Hz, streaming Cartesian jogs, the headless-commander name."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from tests.conftest import REPO_ROOT, free_udp_port, wait_until
from tests.integration.test_controller_pty import AckListener

from parolkit.client.launch import die_with_parent


class Client:
    def __init__(self, ctl) -> None:
        self.ctl = ctl
        self.acks = AckListener(ctl.ack_port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(1.0)
        self.n = 0

    def send(self, text: str, cid: str | None = None) -> str:
        self.n += 1
        cid = cid or f"s{self.n:07d}"
        self.sock.sendto(f"{cid}|{text}".encode(), (self.ctl.host, self.ctl.port))
        return cid

    def query(self, text: str | bytes) -> str | None:
        self.sock.sendto(text.encode() if isinstance(text, str) else text, (self.ctl.host, self.ctl.port))
        try:
            return self.sock.recvfrom(65535)[0].decode()
        except TimeoutError:
            return None

    def json(self, q: str) -> dict:
        return json.loads(self.query(q).split("|", 1)[1])

    def close(self) -> None:
        self.acks.close()
        self.sock.close()


@pytest.fixture
def client(controller):
    c = Client(controller)
    yield c
    c.close()


def test_malformed_datagrams_get_invalid_acks_naming_the_field_and_never_stop_the_server(client):
    cid = client.send("MOVEJOINT|90|-200|180|0|0|180|1|None")
    status, details = client.acks.terminal(cid, 5)
    assert status == "INVALID" and "J2 angle = -200 deg is out of range" in details
    cid = client.send("JOG|3|150|1|None")
    assert client.acks.terminal(cid, 5) == ("INVALID", "JOG: speed% = 150 % is out of range (0, 100] %")
    assert client.query("GET_ANGLES|junk").startswith("ERROR|GET_ANGLES takes no arguments")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:
        for junk in (b"\xff\xfe", b"|||", b"MOVEJOINT", b"x" * 60000, b"GET_"):
            other.sendto(junk, (client.ctl.host, client.ctl.port))
    assert client.query("PING") == "PONG"
    assert client.query("GET_STATUS").endswith("|SERIAL=1")
    # an ID'd query is answered and acked once
    r = client.query("abcdef12|GET_ANGLES")
    assert r.startswith("ANGLES|")
    assert client.acks.terminal("abcdef12", 5)[0] == "COMPLETED"


def test_set_port_accepts_only_a_serial_device_so_a_client_cannot_make_the_controller_write_files(
        client, tmp_path):
    target = tmp_path / "written-by-a-datagram.log"
    for port in (f"spy+/dev/ttyACM0?log={target}", "sim://", "faulty+sim://", "nope://x"):
        cid = client.send(f"SET_PORT|{port}")
        status, details = client.acks.terminal(cid, 5)
        assert status == "INVALID" and details.startswith("SET_PORT: "), (port, details)
    assert not target.exists()
    assert client.query("GET_STATUS").endswith("|SERIAL=1")  # still on its board


def test_get_plan_describes_the_active_motion(client):
    cid = client.send("MOVEJOINT|60|-80|170|10|10|170|2|None")
    client.acks.wait_status(cid, "EXECUTING")
    plan = client.json("GET_PLAN")
    assert plan["command"] == "MOVEJOINT" and plan["id"] == cid
    assert plan["target_angles"] == pytest.approx([60, -80, 170, 10, 10, 170], abs=0.01)
    assert 2 <= len(plan["tcp_path"]) <= 400 and len(plan["tcp_path"][0]) == 3
    st = client.json("GET_STATUS_JSON")
    assert st["state"] == "MOVING" and st["command"]["id"] == cid and st["plan_seq"] == plan["seq"]
    queue = client.json("GET_QUEUE")
    assert queue["active"]["id"] == cid
    assert client.acks.terminal(cid, 10)[0] == "COMPLETED"
    assert client.json("GET_PLAN")["tcp_path"] is None


def test_streaming_cartesian_jog_moves_while_updated_and_stops_when_updates_stop(client):
    assert client.acks.terminal(client.send("STREAM|ON"))[0] == "COMPLETED"
    z0 = client.json("GET_STATUS_JSON")["pose"][2]
    ids = []
    for _ in range(25):
        ids.append(client.send("CARTJOG|WRF|Z-|50|0.2"))
        time.sleep(0.02)
    for cid in ids:
        assert client.acks.terminal(cid, 5)[0] in ("COMPLETED", "FAILED")

    def stopped():
        st = client.json("GET_STATUS_JSON")
        return st if st["speeds"] == [0] * 6 and st["command"] is None else None

    st = wait_until(stopped, what="the jog stopping once updates stop")
    assert st["pose"][2] < z0 - 2.0  # it moved down while updates came
    completed = [client.acks.terminal(c)[0] for c in ids].count("COMPLETED")
    assert completed >= len(ids) // 2
    client.send("STREAM|OFF")


def _run_ctl(args, timeout=15.0):
    port, ack = free_udp_port(), free_udp_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "parolkit", "serve", "--udp-port", str(port), "--ack-port", str(ack), *args],
        cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**__import__("os").environ, "PYTHONPATH": str(REPO_ROOT / "src")},
        preexec_fn=die_with_parent,
    )
    return proc, port


def _wait_serial(port: int, timeout: float = 20.0) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.settimeout(0.3)
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        s.sendto(b"GET_STATUS", ("127.0.0.1", port))
        try:
            reply = s.recvfrom(65535)[0]
            if reply.startswith(b"STATUS|") and reply.endswith(b"|SERIAL=1"):
                return s
        except TimeoutError:
            pass
    raise AssertionError("controller never reported SERIAL=1")


def _ask(s: socket.socket, port: int, q: bytes, prefix: str) -> str:
    """Send ``q`` and return the first reply starting with ``prefix`` (late replies to an earlier query are skipped)."""
    s.sendto(q, ("127.0.0.1", port))
    end = time.monotonic() + 5
    while time.monotonic() < end:
        try:
            r = s.recvfrom(65535)[0].decode()
        except TimeoutError:
            s.sendto(q, ("127.0.0.1", port))
            continue
        if r.startswith(prefix):
            return r
    raise AssertionError(f"no {prefix} reply to {q!r}")


def test_toml_config_then_flags_and_the_bind_warning(tmp_path):
    cfg = tmp_path / "p.toml"
    cfg.write_text("[controller]\nrate_hz = 250\nhome_on_start = false\n")
    proc, port = _run_ctl(["--sim", "--config", str(cfg), "--bind", "0.0.0.0"])
    try:
        s = _wait_serial(port)
        r = _ask(s, port, b"GET_LOOP_STATS", "LOOP_STATS|")
        assert json.loads(r.split("|", 1)[1])["rate_hz"] == 250.0
        assert "HOMED=0,0,0,0,0,0" in _ask(s, port, b"GET_STATUS", "STATUS|")  # home_on_start = false
    finally:
        proc.terminate()
        out, err = proc.communicate(timeout=10)
    assert proc.returncode == 0
    assert "WARNING: listening on 0.0.0.0" in err
    assert "parolkit controller listening on udp://0.0.0.0:" in out
    proc, port = _run_ctl(["--sim", "--config", str(cfg), "--rate", "100"])
    try:
        s = _wait_serial(port)
        r = _ask(s, port, b"GET_LOOP_STATS", "LOOP_STATS|")
        assert json.loads(r.split("|", 1)[1])["rate_hz"] == 100.0
    finally:
        proc.terminate()
        proc.communicate(timeout=10)


def test_bad_config_is_refused_with_the_key_named(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[controller]\nrate_hz = -5\n")
    proc, _ = _run_ctl(["--sim", "--config", str(cfg)])
    out, err = proc.communicate(timeout=20)
    assert proc.returncode == 2 and "controller.rate_hz" in err


def test_250_hz_runs_moves_and_headless_commander_is_the_same_program(tmp_path):
    exe = Path(sys.executable).with_name("headless-commander")
    port, ack = free_udp_port(), free_udp_port()
    args = [str(exe)] if exe.exists() else [
        sys.executable, "-c", "import sys; from parolkit.cli import serve_main; sys.exit(serve_main())"]
    proc = subprocess.Popen([*args, "--rate", "250", "--udp-port", str(port), "--ack-port", str(ack),
                             "--sim-speedup", "200"], cwd=REPO_ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=die_with_parent)
    acks = AckListener(ack)
    try:
        s = _wait_serial(port)
        end = time.monotonic() + 30
        while time.monotonic() < end:
            r = _ask(s, port, b"GET_STATUS", "STATUS|")
            if "HOMED=1,1,1,1,1,1" in r and "STATE=HOMING" not in r:
                break
            time.sleep(0.1)
        s.sendto(b"abcd0250|MOVEJOINT|70|-90|170|0|0|180|1|None", ("127.0.0.1", port))
        assert acks.terminal("abcd0250", 15)[0] == "COMPLETED"
        assert acks.statuses("abcd0250") == ["QUEUED", "EXECUTING", "COMPLETED"]
        # (the loop statistics are a view reused for 0.25 s: ask, one round trip after the
        # other, until one made after the move has come)
        end = time.monotonic() + 5
        while True:
            stats = json.loads(_ask(s, port, b"GET_LOOP_STATS", "LOOP_STATS|").split("|", 1)[1])
            if stats["frames_sent"] > 250 or time.monotonic() > end:
                break
        assert stats["rate_hz"] == 250.0 and stats["frames_sent"] > 250
    finally:
        acks.close()
        proc.terminate()
        proc.communicate(timeout=10)
    assert proc.returncode == 0


def test_acks_also_reach_the_sending_socket_so_robot_with_an_ephemeral_ack_port_works(controller):
    from parolkit import Robot

    robot = Robot(controller.host, controller.port, ack_port=0, timeout=5.0)
    try:
        result = robot.move_joints([90, -85, 175, 0, 0, 180], duration=1.5, wait=True, timeout=10)
        assert result.status.name == "COMPLETED"
        assert robot.angles()[1] == pytest.approx(-85, abs=0.05)
    finally:
        robot.close()


def test_a_command_sent_right_after_stops_ack_is_not_cancelled_by_that_stop(client):
    client.send("MOVEJOINT|90|-80|170|0|0|180|5|None")
    for _ in range(3):
        stop = client.send("STOP")
        assert client.acks.terminal(stop, 5)[0] == "COMPLETED"
        cid = client.send("DELAY|0.05")
        status, details = client.acks.terminal(cid, 5)
        assert status == "COMPLETED", details



def test_parolkit_serve_reads_stops_from_the_safety_socket_the_kernel_steers_them_to(client):
    """``parolkit serve`` binds its port itself (to answer PING early): it must bind the
    safety socket too, or every stop waits behind a flood in the command socket's queue
    (parolkit.controller.steering; the first version bound it only in Controller.bind)."""
    stop = client.send("STOP")
    assert client.acks.terminal(stop, 5)[0] == "COMPLETED"
    # (the status is the last tick's: the count may show a tick after the ack)
    wait_until(lambda: client.json("GET_STATUS_JSON")["server"]["steered"] == 1, 2, what="server.steered == 1")
