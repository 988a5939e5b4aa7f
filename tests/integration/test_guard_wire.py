"""Issue 12, item 4, on the wire: the real controller process drives a simulated board in
lockstep with its frames (``sim://?clock=virtual&step=0.01``: every frame runs it exactly one
period, so what is judged is what the planners and the guard send, the same on a loaded
machine as on an idle one); a ``spy+`` link logs every frame both ways, and every frame is
checked.  (Frames delivered late or early by a real link: ``test_link_faults_pty.py``, the
pty tests, and the core's jittery-tick tests in tests/unit.)

The board's reply to a frame carries its step counters as that frame arrived (the firmware
copies them on the pass before it answers), so each GO TO frame and its reply give exactly the
speed the board started that period at: ``int(((target - position) / 0.01 + v_ff) / 2)``, its
fastest until the next frame (the GO TO loop only slows within a period).  That, every speed
field, every reported speed and every GO TO step are checked against the joints' maxima for
moves at 100 % speed and acceleration, after the robot was idle, and for moves shorter than a
tick (which must be refused at once, naming the shortest duration)."""

from __future__ import annotations

import json
import re
import socket
import time
from pathlib import Path

import pytest
from tests.conftest import start_controller, wait_until
from tests.integration.test_controller_pty import AckListener

from parolkit import kinematics as kin
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.record.replay import lockstep_board
from parolkit.robot import PAROL6

VMAX = [float(v) for v in PAROL6.max_speed_steps_s]
RATE = 100.0
PERIOD = 1.0 / RATE


class WireBench:
    """The controller on a simulated board in lockstep with its frames (each frame runs it one
    period: the frames and their replies are what the planners and the guard produce, not what
    a loaded machine's late ticks did to them), opened through ``spy+...?raw=1`` (every frame
    with its bytes); acks on a real UDP socket."""

    def __init__(self, tmp_path: Path) -> None:
        self.log_path = tmp_path / "frames.log"
        port = f"spy+{lockstep_board(RATE)}&homed=1&log={self.log_path}&raw=1"
        self.ctl = start_controller(["--port", port, "--no-home"], log_dir=tmp_path, wait_homed=False)
        self.acks = AckListener(self.ctl.ack_port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(1.0)
        self._n = 0
        wait_until(lambda: (self.query("GET_STATUS") or "").endswith("|SERIAL=1"), 20, what="board link up")
        wait_until(lambda: "HOMED=1,1,1,1,1,1" in (self.query("GET_STATUS") or ""), 20, what="homed status")
        wait_until(lambda: self.status()["board"]["state_known"] and self.status()["enabled"], 10,
                   what="the board's state known (enabled)")

    def send(self, text: str) -> str:
        self._n += 1
        cid = f"w{self._n:07d}"
        self.sock.sendto(f"{cid}|{text}".encode(), (self.ctl.host, self.ctl.port))
        return cid

    def query(self, text: str) -> str | None:
        """One query (retried on a busy machine); replies to an earlier retry are skipped."""
        want = {"PING": "PONG", "GET_STATUS": "STATUS|", "GET_ANGLES": "ANGLES|",
                "GET_LOOP_STATS": "LOOP_STATS|", "GET_STATUS_JSON": "STATUS_JSON|"}[text]
        for _ in range(5):
            self.sock.sendto(text.encode(), (self.ctl.host, self.ctl.port))
            try:
                while True:
                    r = self.sock.recvfrom(65535)[0].decode()
                    if r.startswith(want):
                        return r
            except TimeoutError:
                continue
        return None

    def status(self) -> dict:
        return json.loads((self.query("GET_STATUS_JSON") or "|{}").split("|", 1)[1])

    def close(self) -> None:
        self.ctl.stop()
        self.acks.close()
        self.sock.close()


@pytest.fixture
def bench(tmp_path):
    b = WireBench(tmp_path)
    yield b
    b.close()


_LINE = re.compile(r"^\S+ (?P<t>[0-9.]+) (?P<dir>PC>BOARD|BOARD>PC) (?P<kind>\w+) .* raw=(?P<raw>[0-9a-f]+)$")


def read_wire(path: Path) -> list[tuple[float, CommandFrame, StatusFrame | None]]:
    """Every command frame written (its time, s monotonic) with the board's reply to it
    (replies come in order, one per frame; None for the last ones if none came)."""
    sent: list[tuple[float, CommandFrame]] = []
    replies: list[StatusFrame] = []
    for line in path.read_text().splitlines():
        m = _LINE.match(line)
        if not m:
            assert " -- " in line, line  # (open / close events); a clean link has no garbage
            continue
        raw = bytes.fromhex(m["raw"])
        if m["dir"] == "PC>BOARD":
            sent.append((float(m["t"]), CommandFrame.decode(raw)))
        else:
            replies.append(StatusFrame.decode(raw))
    assert len(replies) <= len(sent)
    return [(t, f, replies[i] if i < len(replies) else None) for i, (t, f) in enumerate(sent)]


def board_start_speed(f: CommandFrame, position: float, j: int) -> int:
    """The speed (steps/s) joint ``j`` starts ``f`` at from ``position``: the firmware's law."""
    return int(((f.positions[j] - position) / 0.01 + f.speeds[j]) / 2)


def check_wire(wire) -> dict[str, object]:
    """Every frame against the maxima (module docstring).

    Every frame is a bounded commitment: its goal lies within 20 ms of maximum-speed travel of
    wherever the board may be when it arrives, whenever that is.  So every GO TO frame and its
    reply (the board's position as that frame arrived) must give a start speed within the
    maximum as delivered, with no allowance for frames the operating system delivered early
    or together (plus the guard's rounding allowance, 0.01 step = 0.5 steps/s); so must every
    speed a reply reports; and no JOG frame moves anything but the start-up probe's 1 step/s.

    Returns the peak start speeds (fraction of the maximum) and how many frames were judged."""
    peak = [0.0] * 6
    gotos = 0
    for k, (_t, f, reply) in enumerate(wire):
        where = f"frame {k} (command {f.command})"
        for j in range(6):
            assert abs(f.speeds[j]) <= VMAX[j], (where, "speed field", j, f.speeds)
        if f.command == BoardCommand.JOG:
            assert all(abs(v) <= 1 for v in f.speeds), (where, "a JOG frame with a speed", f.speeds)
        if reply is not None:  # (the speed the previous frame left)
            for j in range(6):
                assert abs(reply.speeds[j]) <= VMAX[j] + 1, (where, "reported speed", j, reply.speeds)
        if f.command == BoardCommand.GOTO and reply is not None:
            gotos += 1
            for j in range(6):
                u = board_start_speed(f, reply.positions[j], j)
                peak[j] = max(peak[j], abs(u) / VMAX[j])
                assert abs(u) <= VMAX[j] + 0.5, (where, f"J{j + 1} starts at {u} steps/s", f, reply.positions)
    assert gotos > 0
    return {"peak": [round(p, 3) for p in peak], "goto_frames": gotos}


def _goto_frames_between(wire, t0: float, t1: float) -> int:
    return sum(1 for t, f, _ in wire if t0 <= t <= t1 and f.command == BoardCommand.GOTO)


@pytest.mark.slow
def test_full_speed_moves_first_frames_after_idle_and_sub_tick_moves_on_the_wire(bench):
    run = []

    def move(text: str, want: str = "COMPLETED", timeout: float = 40.0) -> tuple[str, float, float]:
        t0 = time.monotonic()
        cid = bench.send(text)
        status, details = bench.acks.terminal(cid, timeout)
        t1 = time.monotonic()
        assert status == want, (text, status, details)
        run.append((text, status, details, t0, t1))
        return details, t0, t1

    # 100 % speed and acceleration trapezoids: J1 alone (the slowest joint, 180 deg), back,
    # then several joints; each from rest after idle frames (DELAY holds the robot still)
    move("MOVEJOINT|-90|-90|180|0|0|180|None|100|100")
    move("DELAY|0.3")
    move("MOVEJOINT|90|-90|180|0|0|180|None|100|100")
    move("MOVEJOINT|40|-60|220|-60|-40|90|None|100|100")
    move("DELAY|0.3")
    move("MOVEJOINT|90|-100|150|10|40|170|None|100|100|POLY")
    move("MOVEJOINT|60|-120|190|40|60|120|None|100|100|RUCKIG")
    # Cartesian at 100 % from a pose away from the wrist singularity
    move("MOVEJOINT|90|-100|150|10|40|170|2|None")
    x, y, z, a, b, c = (float(v) for v in kin.fk([90, -100, 150, 10, 40, 170]))
    move(f"MOVECART|{x - 60:.3f}|{y - 40:.3f}|{z - 60:.3f}|{a:.3f}|{b:.3f}|{c:.3f}|None|100")
    # sub-tick durations: refused at once, naming the shortest duration; nothing moves
    x, y, z = x - 60, y - 40, z - 60
    least = {}
    for text in (f"MOVECART|{x:.3f}|{y + 5:.3f}|{z:.3f}|{a:.3f}|{b:.3f}|{c:.3f}|1e-9|None",
                 "MOVECARTRELTRF|0|0|-10|0|0|0|1e-9|None",
                 "MOVEJOINT|80|-90|170|0|20|170|1e-9|None",
                 f"SMOOTH_CIRCLE|{x:.3f},{y:.3f},{z - 15:.3f}|15|XZ|WRF|CURRENT|DURATION|1e-9|0"):
        details, t0, t1 = move(text, "FAILED", timeout=10)
        assert re.search(r"J[1-6]", details), details
        m = re.search(r"(?:give t >=|give a duration of at least) ([0-9.]+) s", details)
        assert m, details
        least[text.split("|")[0]] = float(m[1])
        assert t1 - t0 < 5.0, (text, t1 - t0)
    # the refused moves sent no GO TO frame: the robot stayed where the MOVECART left it
    before = bench.query("GET_ANGLES")
    time.sleep(0.2)
    assert bench.query("GET_ANGLES") == before
    # the shortest duration a refusal names is accepted and plays within the maxima
    move(f"MOVECART|{x:.3f}|{y + 5:.3f}|{z:.3f}|{a:.3f}|{b:.3f}|{c:.3f}|{least['MOVECART']}|None")
    move(f"MOVEJOINT|80|-90|170|0|20|170|{least['MOVEJOINT']}|None")

    stats = json.loads(bench.query("GET_LOOP_STATS").split("|", 1)[1])
    assert stats["guard_violations"] == 0, stats
    assert stats["guard_replaced_frames"] == 0, stats

    wire = read_wire(bench.log_path)
    for text, status, _, t0, t1 in run:
        if status == "FAILED":
            assert _goto_frames_between(wire, t0, t1) == 0, text
    report = check_wire(wire)
    print("wire:", report)
    # the J1 trapezoids did run the board near its maximum: 100 % is the fastest the board
    # can follow, not 76 % of it
    assert report["peak"][0] > 0.9, report
