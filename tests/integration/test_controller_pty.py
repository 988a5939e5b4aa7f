"""The real controller process on one side, ``parolkit board-sim`` on a real pty on the other.

board-sim runs in its own process at raised priority (``tests/integration/boardsim.py``), as a
real board is a microcontroller of its own; ``parolkit serve --port <pty>`` runs as a
subprocess (``tests/conftest.py``'s ``start_controller``) and opens the pty with pyserial like
a real ``/dev/ttyACM0``.  The tests change the board (E-stop, object, cable, link faults) and
read its state over board-sim's control channel; acks are read on a real UDP socket.  Where a
test waits for something to happen, it waits on a condition, on the controller's ticks or on
the frames the board received, not on the wall clock.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path

import pytest
from tests.conftest import start_controller, wait_until
from tests.integration.boardsim import BoardSim

from parolkit.protocol.frames import BoardCommand

TERMINAL = {"COMPLETED", "FAILED", "CANCELLED", "INVALID"}


class AckListener:
    """Collects every ack sent to the controller's ack port, in order, per ID."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
        self.sock.bind(("127.0.0.1", port))
        self.sock.settimeout(0.2)
        self.acks: dict[str, list[tuple[str, str]]] = defaultdict(list)
        self._stop = False
        self._cv = threading.Condition()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop:
            try:
                data, _ = self.sock.recvfrom(65535)
            except TimeoutError:
                continue
            except OSError:
                return
            parts = data.decode(errors="replace").split("|", 3)
            if len(parts) >= 3 and parts[0] == "ACK":
                with self._cv:
                    self._record(parts[1], parts[2], parts[3] if len(parts) > 3 else "")
                    self._cv.notify_all()

    def _record(self, cid: str, status: str, details: str) -> None:
        """Keep one ack (called with the lock held, as it is read)."""
        self.acks[cid].append((status, details))

    def statuses(self, cid: str) -> list[str]:
        with self._cv:
            return [s for s, _ in self.acks.get(cid, [])]

    def terminal(self, cid: str, timeout: float = 20.0) -> tuple[str, str]:
        end = time.monotonic() + timeout
        with self._cv:
            while True:
                for s, d in self.acks.get(cid, []):
                    if s in TERMINAL:
                        return s, d
                left = end - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"no terminal ack for {cid}: {self.acks.get(cid)}")
                self._cv.wait(left)

    def wait_status(self, cid: str, status: str, timeout: float = 10.0) -> None:
        end = time.monotonic() + timeout
        with self._cv:
            while status not in [s for s, _ in self.acks.get(cid, [])]:
                left = end - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"no {status} ack for {cid}: {self.acks.get(cid)}")
                self._cv.wait(left)

    def close(self) -> None:
        self._stop = True
        self.thread.join(2.0)
        self.sock.close()


class Bench:
    """Controller subprocess on a board's pty + ack listener + a UDP socket for commands.

    The board is ``parolkit board-sim`` (:attr:`board`, homing 100 times faster than the real
    one) unless ``link`` names the pty of a board the caller runs (then :attr:`board` is None).
    ``config_text``: more of the controller's TOML config (e.g. ``[[zones]]`` tables).
    """

    def __init__(self, tmp_path: Path, *, start_homed: bool = True, link_timeout_ticks: int = 150,
                 extra: list[str] | None = None, link: Path | None = None, config_text: str = "") -> None:
        self.board: BoardSim | None = None
        if link is None:
            self.board = BoardSim(tmp_path, start_homed=start_homed, speedup=100)
            link = self.board.link
        # the controller shares 2 busy cores with other test processes: these tests allow 150
        # silent ticks (1.5 s) before "link lost" (link-loss detection is not what they are
        # about: tests/integration/test_link_faults_pty.py): beside two CPU hogs and the suite
        # the kernel's pty worker held replies back 500 ms (50 ticks, the default) and the link
        # was lost mid-test; the silence test below uses 3
        cfg = tmp_path / "controller.toml"
        cfg.write_text(f"[controller]\nlink_timeout_ticks = {link_timeout_ticks}\n" + config_text)
        self.ctl = start_controller(["--port", str(link), "--config", str(cfg), *(extra or [])],
                                    log_dir=tmp_path, wait_homed=False)
        self.acks = AckListener(self.ctl.ack_port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(1.0)
        self._n = 0
        # the controller answers PING at once; wait until the board link is up too
        wait_until(lambda: self.serial(retry=False) == "1", 20, 0.05, what="the board link")
        # and until the start-up probe has told the controller the board's state (a test that
        # damages the link right away would otherwise damage the probe's answers too)
        wait_until(lambda: self.status().get("board", {}).get("state_known"), 20, 0.05,
                   what="the board's state known")

    @property
    def sim(self) -> BoardSim:
        """The board-sim (RuntimeError for a bench on a caller's board)."""
        if self.board is None:
            raise RuntimeError("this bench runs on the caller's board, not on board-sim")
        return self.board

    def new_id(self) -> str:
        self._n += 1
        return f"t{self._n:07d}"

    def send(self, text: str) -> str:
        return self.send_from(self.sock, text)

    def send_from(self, sock: socket.socket, text: str) -> str:
        cid = self.new_id()
        sock.sendto(f"{cid}|{text}".encode(), (self.ctl.host, self.ctl.port))
        return cid

    def run(self, text: str, timeout: float = 20.0) -> tuple[str, str]:
        return self.acks.terminal(self.send(text), timeout)

    def query(self, text: str, retry: bool = True) -> str | None:
        """One query; on a busy machine a reply may take long, so retry a few times.

        Replies that do not answer this query (a late one of an earlier retry) are skipped."""
        want = {"PING": "PONG", "GET_STATUS": "STATUS|", "GET_STATUS_JSON": "STATUS_JSON|",
                "GET_LOOP_STATS": "LOOP_STATS|"}.get(text)
        for _ in range(5 if retry else 1):
            self.sock.sendto(text.encode(), (self.ctl.host, self.ctl.port))
            try:
                while True:
                    r = self.sock.recvfrom(65535)[0].decode()
                    if want is None or r.startswith(want):
                        return r
            except TimeoutError:
                continue
        return None

    def status(self) -> dict:
        return json.loads(self.query("GET_STATUS_JSON").split("|", 1)[1])

    def loop_stats(self) -> dict:
        return json.loads(self.query("GET_LOOP_STATS").split("|", 1)[1])

    def serial(self, retry: bool = True) -> str | None:
        """``SERIAL=`` of GET_STATUS: "1" while the board link is up, "0" while it is down."""
        r = self.query("GET_STATUS", retry=retry)
        return None if r is None else r.rpartition("|SERIAL=")[2]

    def wait_ticks(self, n: int) -> None:
        """Until the controller has ticked ``n`` more times (the link up or not)."""
        start = self.loop_stats()["ticks"]
        wait_until(lambda: self.loop_stats()["ticks"] - start >= n, 20, 0.05, what=f"{n} controller ticks")

    def wait_frames(self, n: int) -> None:
        """Until board-sim has accepted ``n`` more frames from the controller."""
        start = self.sim.status()["frames_accepted"]
        wait_until(lambda: self.sim.status()["frames_accepted"] - start >= n, 20, 0.05,
                   what=f"{n} frames at the board")

    def wait_j1_moving(self, below_deg: float) -> None:
        """Until the board's J1 is below ``below_deg`` (a move from standby's 90 degrees is under way)."""
        wait_until(lambda: self.sim.positions_deg()[0] < below_deg, 20, what=f"the board's J1 below {below_deg}")

    def close(self) -> int:
        rc = self.ctl.stop()
        self.acks.close()
        self.sock.close()
        if self.board is not None:
            self.board.close()
        return rc


@pytest.fixture
def bench(tmp_path):
    b = Bench(tmp_path)
    yield b
    b.close()


@pytest.mark.slow
def test_every_command_of_the_table_over_a_real_pty(bench):
    ok = "COMPLETED"
    cases = [
        ("MOVEJOINT|90|-90|160|12|12|180|1.5|None", ok),
        ("MOVEPOSE|7|250|200|-100|0|-90|2|None", ok),
        ("MOVECART|7|250|180|-100|0|-90|None|60", ok),
        ("MOVECARTRELTRF|0|0|-10|0|0|0|1|None", ok),
        ("JOG|0|30|0.3|None", ok),
        ("JOG|6|30|None|2", ok),
        ("MULTIJOG|0,7|30,30|0.3", ok),
        ("CARTJOG|WRF|Z+|30|0.3", ok),
        ("SPEEDJOINT|3|0|0|0|0|0|0.3", ok),
        ("MOVEJOINT|90|-90|160|12|12|180|None|40", ok),
        ("SMOOTH_CIRCLE|7,250,170|15|XY|WRF|CURRENT|DURATION|3|0", ok),
        ("DELAY|0.1", ok),
        ("PNEUMATICGRIPPER|open|1", ok),
        ("PNEUMATICGRIPPER|close|1", ok),
        ("ELECTRICGRIPPER|calibrate", ok),
        ("ELECTRICGRIPPER|move|100|150|300", ok),
        ("ELECTRICGRIPPER|clear_error", ok),
        ("WAIT_INPUT|1|0|1", ok),
        ("WAIT_INPUT|1|1|0.2", "FAILED"),
        ("MOVEJOINT|190|-90|160|12|12|180|1|None", "INVALID"),
        ("HOME", ok),
    ]
    for text, want in cases:
        cid = bench.send(text)
        status, details = bench.acks.terminal(cid, 30)
        assert status == want, f"{text}: {status} {details}"
        seq = bench.acks.statuses(cid)
        if want in ("COMPLETED", "FAILED") and text != "WAIT_INPUT|1|1|0.2":
            assert seq[:2] == ["QUEUED", "EXECUTING"] and seq[-1] == want and len(seq) == 3, (text, seq)
    for q, prefix in [("GET_POSE", "POSE|"), ("GET_ANGLES", "ANGLES|"), ("GET_IO", "IO|"),
                      ("GET_GRIPPER", "GRIPPER|"), ("GET_SPEEDS", "SPEEDS|"), ("PING", "PONG"),
                      ("GET_STATUS", "STATUS|"), ("GET_STATUS_JSON", "STATUS_JSON|"),
                      ("GET_LOOP_STATS", "LOOP_STATS|"), ("GET_PLAN", "PLAN|"), ("GET_TOOL", "TOOL|default|"),
                      ("GET_QUEUE", "QUEUE|")]:
        assert bench.query(q).startswith(prefix)
    assert bench.query("PING") == "PONG" and bench.serial() == "1"  # exactly the original's answer
    assert len(bench.query("GET_POSE").split("|")[1].split(",")) == 16
    # immediate commands
    for text in ("STREAM|ON", "STREAM|OFF", "SET_TOOL|flange", "SET_TOOL|default", "CLEAR_ERROR", "DISABLE",
                 "ENABLE", "STOP"):
        assert bench.run(text)[0] == "COMPLETED", text
    assert bench.run("SET_TOOL|nosuchtool")[0] == "INVALID"
    assert bench.sim.status()["outputs"] == [False, False]


def _gripper(bench) -> list[int]:
    """GET_GRIPPER's six fields."""
    return [int(v) for v in bench.query("GET_GRIPPER").split("|")[1].split(",")]


def _jaws(bench) -> int:
    """The emulated gripper's jaw position (0 open .. 255 closed), as board-sim has it."""
    return bench.sim.status()["gripper"]["position"]


def test_a_gripper_move_sent_right_after_calibrate_over_a_real_pty_reaches_the_jaws(bench):
    """Issue 22 item 9 over the serial link: the emulated SSG-48 ignores moves while it
    calibrates; the move sent right after the calibrate waits for it and reaches the jaws."""
    cal = bench.send("ELECTRICGRIPPER|calibrate")
    move = bench.send("ELECTRICGRIPPER|move|200|255|400")
    assert bench.acks.terminal(cal, 10)[0] == "COMPLETED"
    assert bench.acks.terminal(move, 10)[0] == "COMPLETED"
    wait_until(lambda: _jaws(bench) == 200, 10, what="the jaws at 200")


def test_get_gripper_object_detection_over_a_real_pty_follows_the_status_byte(bench):
    """GET_GRIPPER's object-detection field is 1 only while the status byte reports an object
    (object code 1 or 2); the board's own byte, a constant 1, read "object" all the time."""
    assert bench.run("ELECTRICGRIPPER|calibrate")[0] == "COMPLETED"
    wait_until(lambda: _gripper(bench)[4] & 0x01, 10, what="the gripper calibrated")
    assert bench.run("ELECTRICGRIPPER|move|255|255|400")[0] == "COMPLETED"
    # closed on nothing: at its position (object code 3), no object
    g = wait_until(lambda: (lambda g: g if g[1] == 255 and g[4] & 0x30 == 0x30 else None)(_gripper(bench)), 10,
                   what="GET_GRIPPER closed at 255")
    assert g[5] == 0, g
    assert bench.run("ELECTRICGRIPPER|move|0|255|400")[0] == "COMPLETED"
    wait_until(lambda: _jaws(bench) == 0, 10, what="the jaws open")
    bench.sim.control("object 24")
    assert bench.run("ELECTRICGRIPPER|move|255|255|400")[0] == "COMPLETED"
    # stopped on the 24 mm object while closing: object code 1
    g = wait_until(lambda: (lambda g: g if g[4] & 0x30 == 0x10 else None)(_gripper(bench)), 10,
                   what="GET_GRIPPER holding the object")
    assert g[5] == 1 and g[1] == 128, g


def _reported_j1(bench) -> float:
    """J1 as the controller reports it, once the report has caught up with the board's own
    position (on a busy machine the status may show a frame or two before the newest)."""
    def agreed() -> list[float] | None:
        board_j1 = bench.sim.positions_deg()[0]
        j1 = bench.status()["angles"][0]
        return [j1] if abs(j1 - board_j1) < 0.01 else None

    return wait_until(agreed, 10, what="the controller's J1 caught up with the board's")[0]


def test_stop_mid_move_cancels_and_holds(bench):
    a = bench.send("MOVEJOINT|40|-90|180|0|0|180|3|None")
    b = bench.send("MOVEJOINT|90|-90|180|0|0|180|3|None")
    bench.acks.wait_status(a, "EXECUTING")
    bench.wait_j1_moving(below_deg=85)
    bench.run("STOP")
    assert bench.acks.terminal(a)[0] == "CANCELLED"
    assert bench.acks.terminal(b)[0] == "CANCELLED"
    wait_until(lambda: not any(bench.sim.status()["speeds"]), 10, what="the board at rest")
    j1 = _reported_j1(bench)
    bench.wait_frames(50)
    assert abs(bench.status()["angles"][0] - j1) < 0.2
    assert 40 < j1 < 90


def _board_disabled(bench) -> bool:
    """board-sim is disabled and its last command was DISABLE."""
    board = bench.sim.status()
    return not board["enabled"] and board["command"] == BoardCommand.DISABLE


def test_estop_press_mid_move_cancels_disables_and_latches_until_release_and_enable(bench):
    a = bench.send("MOVEJOINT|40|-90|180|0|0|180|3|None")
    bench.acks.wait_status(a, "EXECUTING")
    bench.wait_j1_moving(below_deg=89)
    bench.sim.control("estop 1")
    status, details = bench.acks.terminal(a, 2)
    assert status == "CANCELLED" and "E-stop" in details
    wait_until(lambda: _board_disabled(bench), what="board disabled")
    st = bench.status()
    assert st["state"] == "ESTOP" and st["estop_latched"]
    assert bench.run("DELAY|0.1")[0] == "FAILED"
    assert bench.run("ENABLE")[0] == "FAILED"  # still pressed
    bench.sim.control("estop 0")
    bench.wait_frames(30)  # the release has been reported for 30 frames
    assert bench.status()["estop_latched"]  # no automatic restart
    assert not bench.sim.status()["enabled"]
    assert bench.run("ENABLE")[0] == "COMPLETED"
    wait_until(lambda: bench.sim.status()["enabled"] and not bench.status()["estop_latched"], what="enabled again")
    assert bench.run("MOVEJOINT|60|-90|180|0|0|180|4|None")[0] == "COMPLETED"


def test_pulling_the_cable_mid_move_cancels_reports_and_reconnects_without_resuming(bench):
    a = bench.send("MOVEJOINT|40|-90|180|0|0|180|3|None")
    bench.acks.wait_status(a, "EXECUTING")
    bench.wait_j1_moving(below_deg=89)
    bench.sim.control("unplug")
    status, details = bench.acks.terminal(a, 10)  # 150 unanswered frames: 1.5 s of ticks
    assert status == "CANCELLED" and "link lost" in details
    assert bench.serial() == "0"
    st = bench.status()
    assert st["state"] == "DISCONNECTED" and st["errors"]["message"]
    bench.wait_ticks(50)  # the cable stays out for 50 ticks
    bench.sim.control("replug")
    wait_until(lambda: bench.serial() == "1", 6, 0.1, what="the link up again")
    j1 = _reported_j1(bench)
    bench.wait_frames(50)
    assert abs(bench.status()["angles"][0] - j1) < 0.05  # the cancelled move is not resumed
    assert bench.status()["command"] is None
    assert bench.run("CLEAR_ERROR")[0] == "COMPLETED"


def test_one_percent_corruption_of_the_telemetry_is_filtered_and_moves_complete(bench):
    """A corrupted IO byte equal to the last one with only the E-stop bit cleared reads as a
    press and latches at once (executor._hardware_estop: a real press must stop the board in
    one tick; 1 in 255 corrupted IO bytes, the safe side).  That may happen once here (a clean
    run saw it): the batch then runs again after ENABLE.  Every other corruption is filtered."""
    done = ("COMPLETED", "MoveJoint finished successfully")
    for attempt in range(2):
        bench.sim.control("faults corrupt=0.01 dir=from_board")
        ids = [bench.send(f"MOVEJOINT|{90 - 5 * (i % 2)}|-90|180|0|0|180|0.8|None") for i in range(4)]
        # a move whose replies were corrupted may run stretched (its window anchored on older
        # trusted replies), and says so after the usual text
        results = [(s, d if not d.startswith(done[1] + "; warning: ran stretched") else done[1])
                   for s, d in (bench.acks.terminal(cid, 40) for cid in ids)]
        if all(r == done for r in results):
            break
        assert attempt == 0 and ("CANCELLED", "E-stop: hardware E-stop pressed") in results, results
        assert all(r in (done, ("CANCELLED", "E-stop: hardware E-stop pressed")) for r in results), results
        bench.sim.control("faults clear")
        assert not bench.sim.status()["estop_pressed"]
        wait_until(lambda: bench.run("ENABLE")[0] == "COMPLETED", 10, what="ENABLE after the false press")
        wait_until(lambda: bench.sim.status()["enabled"] and not bench.status()["estop_latched"],
                   what="enabled again")
    stats = bench.loop_stats()
    assert stats["implausible_frames"] > 0 and stats["bytes_dropped"] > 0
    assert not bench.status()["estop_latched"]
    bench.sim.control("faults clear")


def test_one_percent_byte_corruption_both_ways_every_command_still_gets_one_terminal_ack(bench):
    # PC -> board corruption reaches the stock firmware unchecked (the link has no checksum):
    # a corrupted target can really move a joint; the controller then refuses to continue
    # from an unexpected place (FAILED), but never crashes or loses an ack.
    bench.sim.control("faults corrupt=0.01 dir=both")
    ids = [bench.send(f"MOVEJOINT|{90 - 5 * (i % 2)}|-90|180|0|0|180|0.8|None") for i in range(6)]
    ids += [bench.send("DELAY|0.1") for _ in range(3)]
    for cid in ids:
        bench.acks.terminal(cid, 40)
    bench.wait_ticks(30)  # time for a second terminal ack, were there one
    for cid in ids:
        st = bench.acks.statuses(cid)
        assert sum(s in TERMINAL for s in st) == 1, (cid, st)
    # the corruption really reached the parser: it dropped bytes (the board answers every tick,
    # so it does within a few seconds even when the first uncommanded motion disabled the robot
    # and every command ended at once)
    wait_until(lambda: bench.loop_stats()["bytes_dropped"] > 0, 20, what="bytes dropped by the parser")
    assert bench.ctl.proc.poll() is None
    bench.sim.control("faults clear")


def test_a_query_sent_after_an_ack_never_reads_an_older_state(bench):
    """Acks wait for the status snapshot that shows what they report (Outbox.hold): a script that
    reads the status right after COMPLETED / CANCELLED sees the job gone, not one tick behind.
    The board's replies come 2.5 ms late, as over a slow USB link: the tick that completes a job
    then spends that long waiting for the reply before it publishes its snapshot."""
    bench.sim.control("faults delay=0.0025 dir=from_board")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.settimeout(5.0)
        dest = (bench.ctl.host, bench.ctl.port)
        s.sendto(b"ACK_HERE", dest)

        def until_ack(cid: str, wanted: str) -> None:
            seen = []  # (a terminal ack other than the one wanted fails at once, saying which)
            while True:
                try:
                    parts = s.recvfrom(65535)[0].decode().split("|")
                except TimeoutError:
                    raise AssertionError(f"no {wanted} ack for {cid} within 5 s; its acks: {seen}") from None
                if parts[0] == "ACK" and parts[1] == cid:
                    seen.append("|".join(parts[2:]))
                    if parts[2] == wanted:
                        return
                    assert parts[2] not in ("COMPLETED", "FAILED", "CANCELLED", "INVALID"), \
                        f"{cid} ended {seen[-1]!r}, not {wanted}; its acks: {seen}"

        def status_now() -> dict:
            s.sendto(b"GET_STATUS_JSON", dest)
            while True:
                try:
                    text = s.recvfrom(65535)[0].decode()
                except TimeoutError:
                    raise AssertionError("no reply to GET_STATUS_JSON within 5 s") from None
                if text.startswith("STATUS_JSON|"):
                    return json.loads(text.split("|", 1)[1])

        for i in range(40):
            cid = f"c{i:07d}"
            s.sendto(f"{cid}|DELAY|0.01".encode(), dest)
            until_ack(cid, "COMPLETED")
            st = status_now()
            assert st["command"] is None and st["state"] == "IDLE", (i, st)
        s.sendto(b"m0000001|MOVEJOINT|60|-90|180|0|0|180|3|None", dest)
        until_ack("m0000001", "EXECUTING")
        assert status_now()["state"] == "MOVING"
        s.sendto(b"s0000001|STOP", dest)
        until_ack("s0000001", "COMPLETED")
        st = status_now()
        assert st["command"] is None and st["state"] != "MOVING" and st["queue"] == 0, st
        s.sendto(b"d0000001|DISABLE", dest)
        until_ack("d0000001", "COMPLETED")
        assert status_now()["state"] == "DISABLED"
        s.sendto(b"e0000001|ENABLE", dest)
        until_ack("e0000001", "COMPLETED")
        assert status_now()["state"] == "IDLE"
    bench.sim.control("faults clear")


_FLOOD_SENDER = r"""
import json, random, socket, sys, threading, time
host, port, ack_port = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
duration, rate = float(sys.argv[4]), int(sys.argv[5])
acks = {}
lock = threading.Lock()  # the listener adds to acks while the main thread counts them
ack_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
ack_sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 23)
ack_sock.bind(("127.0.0.1", ack_port))
ack_sock.settimeout(0.2)
stop = False
def listen():
    while not stop:
        try:
            data = ack_sock.recv(65535)
        except socket.timeout:
            continue
        p = data.decode(errors="replace").split("|", 3)
        if len(p) >= 3 and p[0] == "ACK":
            with lock:
                acks.setdefault(p[1], []).append(p[2])
t = threading.Thread(target=listen, daemon=True); t.start()
rng = random.Random(7)
garbage = [b"", b"\xff\xfe\x00", b"MOVEJOINT|1|2", b"|||||", b"GET_ANGLES|x", b"JOG|99|1|1|1",
           b"A" * 3000, b"SMOOTH_BLEND|2|||||", b"ESTOPX", b"abcd|MOVE"]
valid = ["DELAY|0.01", "GET_ANGLES", "PING", "JOG|0|10|0.05|None", "GET_STATUS",
         "MOVEJOINT|90|-90|180|0|0|180|0.5|None", "ELECTRICGRIPPER|move|10|10|200"]
ids = []
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
sock.setblocking(False)
t0 = time.monotonic(); n = 0
while True:
    now = time.monotonic()
    if now - t0 >= duration:
        break
    due = int((now - t0) * rate)
    while n < due:
        n += 1
        r = rng.random()
        if r < 0.5:
            data = rng.choice(garbage) if rng.random() < 0.7 else rng.randbytes(rng.randint(1, 60))
        elif r < 0.8:
            cid = "f%07d" % n
            ids.append(cid)
            data = ("%s|%s" % (cid, rng.choice(valid + ["MOVEJOINT|500|0|0|0|0|0|1|None", "NOPE|1"]))).encode()
        else:
            data = rng.choice(valid).encode()
        try:
            sock.sendto(data, (host, port))
        except BlockingIOError:
            pass
    time.sleep(0.001)
end = time.monotonic() + 15
def completed():
    with lock:
        return "COMPLETED" in acks.get("zzzzzzz1", [])
while not completed() and time.monotonic() < end:
    sock.sendto(b"zzzzzzz1|STOP", (host, port))
    time.sleep(0.2)
count, quiet = -1, time.monotonic()
while time.monotonic() - quiet < 1.5 and time.monotonic() < end + 10:
    with lock:
        c = sum(len(v) for v in acks.values())
    if c != count:
        count, quiet = c, time.monotonic()
    time.sleep(0.1)
stop = True
t.join()
print(json.dumps({"sent": n, "ids": ids, "acks": acks}))
"""


@pytest.mark.slow
def test_flood_of_5000_datagrams_per_second_keeps_the_loop_and_acks_exact(bench):
    """10 s of 5,000 datagrams/s (half garbage, a third ID'd commands) from another process."""
    bench.acks.close()  # the sender process listens on the ack port itself
    before = bench.loop_stats()
    out = subprocess.run(
        [sys.executable, "-c", _FLOOD_SENDER, bench.ctl.host, str(bench.ctl.port), str(bench.ctl.ack_port),
         "10", "5000"], capture_output=True, text=True, timeout=60,
    )
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    stats = bench.loop_stats()
    received = stats["datagrams_received"] - before["datagrams_received"]
    print(f"flood: {res['sent']} datagrams sent, {received} received; loop period "
          f"p50 {stats['period_p50_ms']:.2f} ms, p99 {stats['period_p99_ms']:.2f} ms, "
          f"max {stats['period_max_ms']:.2f} ms, overruns {stats['overruns'] - before['overruns']}; "
          f"invalid {stats['datagrams_invalid'] - before['datagrams_invalid']}; "
          f"board link losses {stats['link_losses'] - before['link_losses']}")
    assert bench.ctl.proc.poll() is None
    # the board link is up, or comes back by itself: beside two CPU hogs a 289 ms stall of the
    # whole machine exceeded the 3-tick link timeout right at the flood's end (a lost link is
    # the right answer to that, and the controller reconnects once a second)
    wait_until(lambda: bench.serial() == "1", 10, what="the board link up after the flood")
    acked = [cid for cid in res["ids"] if cid in res["acks"]]
    for cid in acked:
        st = res["acks"][cid]
        assert sum(s in TERMINAL for s in st) == 1, (cid, st)
    # datagrams the kernel dropped before delivery cannot be acked; all delivered ones were
    assert len(acked) >= 0.9 * len(res["ids"]) * min(1.0, received / res["sent"])
    assert "COMPLETED" in res["acks"]["zzzzzzz1"]
    # the loop kept ticking through the flood (the period figures are reported, not asserted)
    assert stats["ticks"] - before["ticks"] >= 0.5 * 100 * 10


def test_serial_silence_is_detected_within_the_default_three_ticks(tmp_path):
    b = Bench(tmp_path, link_timeout_ticks=3)
    try:
        # on this busy machine a natural stall (30 ms) can also trip the 3-tick limit, even with
        # board-sim at raised priority (seen at load 12 beside another test module): the move is
        # then cancelled before the silence; try again
        for _attempt in range(3):
            a = b.send("MOVEJOINT|40|-90|180|0|0|180|3|None")
            try:
                b.acks.wait_status(a, "EXECUTING")
                break
            except AssertionError:
                wait_until(lambda: b.serial() == "1", 6, 0.1, what="the link up again")
        b.sim.control("faults silent=1")
        status, details = b.acks.terminal(a, 2)
        assert status == "CANCELLED" and "link lost" in details
        assert b.serial() == "0"
        b.sim.control("faults clear")
        wait_until(lambda: b.serial() == "1", 6, 0.1, what="the link up again")
    finally:
        b.close()


def test_sigterm_stops_motion_sends_disable_and_closes_the_port(bench):
    a = bench.send("MOVEJOINT|40|-90|180|0|0|180|3|None")
    bench.acks.wait_status(a, "EXECUTING")
    bench.wait_j1_moving(below_deg=89)
    assert bench.ctl.stop() == 0
    wait_until(lambda: _board_disabled(bench), what="the final DISABLE frame reaching the board")
    assert "shutting down" in bench.ctl.log()


def test_status_stream_subscribers_get_one_datagram_per_n_ticks(bench):
    sub = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sub.bind(("127.0.0.1", 0))
    sub.settimeout(1.0)
    port = sub.getsockname()[1]
    # the stream starts once the socket echoed its cookie: the first SUBSCRIBE is answered with
    # COOKIE|c alone (no ack: the controller sends no more than it received)
    first = bench.new_id()
    sub.sendto(f"{first}|SUBSCRIBE|{port}|10".encode(), (bench.ctl.host, bench.ctl.port))
    answer = sub.recvfrom(65535)[0].decode()
    assert answer.startswith("COOKIE|"), answer
    cookie = answer.split("|", 1)[1]
    # the stream goes only to the socket that asks: SUBSCRIBE for another port is refused
    other = port + 1 if port < 65535 else port - 1
    status, details = bench.acks.terminal(bench.send_from(sub, f"SUBSCRIBE|{other}|10|{cookie}"))
    assert status == "FAILED" and f"from port {other}" in details
    assert bench.acks.terminal(bench.send_from(sub, f"SUBSCRIBE|{port}|10|{cookie}"))[0] == "COMPLETED"
    assert bench.acks.statuses(first) == []
    got = []
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        try:
            got.append(sub.recvfrom(65535)[0].decode())
        except TimeoutError:
            break
    # one datagram every 10th tick: judged by the ticks the objects carry, not by wall time,
    # which a loaded machine stretches
    seqs = [json.loads(g.split("|", 1)[1])["seq"] for g in got]
    assert len(seqs) >= 3 and all(b - a == 10 for a, b in zip(seqs, seqs[1:])), seqs
    st = json.loads(got[-1].split("|", 1)[1])
    assert {"angles", "pose", "io", "gripper", "homed", "state", "loop", "errors"} <= set(st)
    cid = bench.new_id()
    sub.sendto(f"{cid}|UNSUBSCRIBE|{port}".encode(), (bench.ctl.host, bench.ctl.port))
    assert bench.acks.terminal(cid)[0] == "COMPLETED"
    sub.close()


def _explain(bench, what: str, lines: int = 60) -> str:
    """``what``, the controller's status and the tail of its log: a failure that explains itself
    (the log is lost with the test's tmp dir)."""
    try:
        st = json.dumps(bench.status(), sort_keys=True)
    except Exception as exc:  # (the controller may be gone)
        st = f"no status: {exc}"
    tail = "\n".join(bench.ctl.log().splitlines()[-lines:])
    return f"{what}\ncontroller status: {st}\ncontroller log (last {lines} lines):\n{tail}"


def test_set_port_switches_the_board_link(bench, tmp_path):
    """SET_PORT is COMPLETED once the board on the new port answers and its state is known:
    a move sent right after that ack runs there (no polling of the status: the test used to
    wait for ``connected`` and then move, while a client that moved after the ack got
    FAILED "board link is down")."""
    board2 = BoardSim(tmp_path, name="p6b")
    try:
        before = board2.status()["frames_accepted"]
        cid = bench.send(f"SET_PORT|{board2.link}")
        status, details = bench.acks.terminal(cid)
        assert status == "COMPLETED", _explain(bench, f"SET_PORT: {status} {details!r}")
        assert bench.acks.statuses(cid) == ["EXECUTING", "COMPLETED"]
        status, details = bench.run("MOVEJOINT|80|-90|180|0|0|180|2|None")
        assert status == "COMPLETED", _explain(bench, f"MOVEJOINT after SET_PORT: {status} {details!r}")
        assert abs(board2.positions_deg()[0] - 80) < 0.1
        assert board2.status()["frames_accepted"] > before
        st = bench.status()
        assert str(board2.link) in st["board"]["port"] and bench.serial() == "1"
        assert st["errors"]["message"] is None  # a switch asked for is no link fault
    finally:
        board2.close()


def test_set_port_and_a_move_sent_back_to_back_never_cancel_the_move(bench, tmp_path):
    """SET_PORT and a MOVEJOINT sent back to back (no wait for the ack), as a script does: the
    move used to be QUEUED in the tick of the switch and then CANCELLED by it ("board link
    lost: switching to port ..."; 9 of 10 runs beside two CPU hogs).  Now, in the order the
    controller took them: SET_PORT first, the move is refused (FAILED) until SET_PORT is
    COMPLETED, so it never runs on a board whose state is not known; the move first, it runs
    on the first board and SET_PORT is refused while it does.  (The tick by tick account:
    tests/unit/test_set_port.py.)"""
    board2 = BoardSim(tmp_path, name="p6b")
    try:
        cid = bench.send(f"SET_PORT|{board2.link}")
        move = bench.send("MOVEJOINT|80|-90|180|0|0|180|2|None")
        status, details = bench.acks.terminal(move)
        set_status, set_details = bench.acks.terminal(cid)
        acks = f"SET_PORT: {bench.acks.acks[cid]}, MOVEJOINT: {bench.acks.acks[move]}"
        assert "CANCELLED" not in bench.acks.statuses(move), _explain(bench, acks)
        if set_status == "FAILED":  # the move reached the tick first
            assert "busy" in set_details and status == "COMPLETED", acks
            assert abs(board2.positions_deg()[0] - 90) < 0.01, acks
        elif status == "FAILED":
            assert set_status == "COMPLETED" and "switching to" in details, acks
            assert abs(board2.positions_deg()[0] - 90) < 0.01, acks
        else:  # (held up in the server until the switch was complete: it runs on the new board)
            assert set_status == "COMPLETED" and status == "COMPLETED", acks
            assert abs(board2.positions_deg()[0] - 80) < 0.1, acks
    finally:
        board2.close()
