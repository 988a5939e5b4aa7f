"""The timing-under-load rig of issue 12: moves judged at the board while CPU hogs run.

Used by ``tests/integration/test_timing_under_load.py`` (which asserts) and
``bench/controller.py`` (which prints figures).  Real parts only:

* :class:`BusyProcesses` -- ``python -c "while True: pass"`` processes, one per core to burn;
* :class:`BoardSim` (:mod:`tests.integration.boardsim`) -- ``parolkit board-sim`` on a real pty: the
  board's frame log (receive time and command code of every frame) and its ``status`` (step
  counters) are the judges;
* :class:`Client` -- commands with IDs over UDP, acks on the controller's ack port, queries;
* :func:`run_scenario` -- timed MoveJoints (duration judged from the board's first to its
  last 156 frame), speed-only moves (MOVEJOINT with speed tracking) and JOGs with a distance
  (end position judged from the board's counters), with status queries in the background as a
  GUI would send them, for a given time; then the controller's loop statistics.
"""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
import threading
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from tests.integration.boardsim import BoardSim

from parolkit.client.launch import die_with_parent
from parolkit.robot import PAROL6

HOST = "127.0.0.1"
TERMINAL = ("COMPLETED", "FAILED", "CANCELLED", "INVALID")
#: board command code of GO TO (parolkit.protocol.BoardCommand.GOTO)
BOARD_GOTO = 156
SPD = tuple(float(v) for v in PAROL6.steps_per_deg)

#: the timed MoveJoint goes back and forth between these two poses (deg)
POSE_A = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)
POSE_B = (62.0, -76.0, 161.0, 22.0, -18.0, 152.0)
#: speed-only moves go from where the timed move ended to here and back
POSE_C = (76.0, -83.0, 170.0, 10.0, -8.0, 166.0)
MOVE_S = 4.0
SPEED_ONLY_S = 1.5
#: JOG with a distance: J1 at 40 % this far, out and back
JOG_DEG, JOG_PCT = 3.0, 40


class BusyProcesses:
    """``count`` processes that burn a CPU each until the block ends (killed, never left behind)."""

    def __init__(self, count: int) -> None:
        self.count = count
        self.procs: list[subprocess.Popen[bytes]] = []

    def __enter__(self) -> BusyProcesses:
        for _ in range(self.count):
            self.procs.append(subprocess.Popen([sys.executable, "-c", "while True: pass"],
                                               preexec_fn=die_with_parent))
        return self

    def __exit__(self, *exc: object) -> None:
        for p in self.procs:
            if p.poll() is None:
                p.kill()
        for p in self.procs:
            p.wait(10)

    def alive(self) -> bool:
        return bool(self.procs) and all(p.poll() is None for p in self.procs)


class Client:
    """Commands with IDs from one socket, acks on the controller's ack port, queries."""

    def __init__(self, port: int, ack_port: int) -> None:
        self.addr = (HOST, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(2.0)
        self.acks_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.acks_sock.bind((HOST, ack_port))
        self.acks_sock.settimeout(0.2)
        self.acks: dict[str, list[tuple[str, str]]] = defaultdict(list)
        self._cv = threading.Condition()
        self._n = 0
        self._stop = threading.Event()
        self._reader = threading.Thread(target=self._read_acks, daemon=True)
        self._reader.start()

    def _read_acks(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.acks_sock.recv(65535)
            except TimeoutError:
                continue
            except OSError:
                return
            p = data.decode(errors="replace").split("|", 3)
            if len(p) >= 3 and p[0] == "ACK":
                with self._cv:
                    self.acks[p[1]].append((p[2], p[3] if len(p) > 3 else ""))
                    self._cv.notify_all()

    def send(self, text: str) -> str:
        self._n += 1
        cid = f"l{self._n:07d}"  # an ID is 8 characters, not all upper-case
        self.sock.sendto(f"{cid}|{text}".encode(), self.addr)
        return cid

    def terminal(self, cid: str, timeout: float) -> tuple[str, str]:
        end = time.monotonic() + timeout
        with self._cv:
            while True:
                for status, details in self.acks.get(cid, []):
                    if status in TERMINAL:
                        return status, details
                left = end - time.monotonic()
                if left <= 0:
                    return "TIMEOUT", f"no terminal ack within {timeout:g} s: {self.acks.get(cid)}"
                self._cv.wait(left)

    def run(self, text: str, timeout: float = 30.0) -> tuple[str, str, float, float]:
        """Send ``text``, wait for its terminal ack: (status, details, sent at, ended at)."""
        t0 = time.monotonic()
        status, details = self.terminal(self.send(text), timeout)
        return status, details, t0, time.monotonic()

    def query(self, text: str, prefix: str, timeout: float = 2.0) -> str | None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.settimeout(timeout)
            for _ in range(3):
                s.sendto(text.encode(), self.addr)
                try:
                    while True:
                        reply = s.recv(65535).decode(errors="replace")
                        if reply.startswith(prefix):
                            return reply
                except TimeoutError:
                    continue
        return None

    def loop_stats(self) -> dict:
        reply = self.query("GET_LOOP_STATS", "LOOP_STATS|")
        return json.loads(reply.split("|", 1)[1]) if reply else {}

    def close(self) -> None:
        self._stop.set()
        self._reader.join(2.0)
        self.sock.close()
        self.acks_sock.close()


class Poller:
    """GET_STATUS at ``hz`` from its own socket, as a GUI polls (traffic, not judged)."""

    def __init__(self, port: int, hz: float = 20.0) -> None:
        self.addr, self.gap = (HOST, port), 1.0 / hz
        self.stop_ev = threading.Event()
        self.replies = 0
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.settimeout(0.5)
            while not self.stop_ev.wait(self.gap):
                s.sendto(b"GET_STATUS", self.addr)
                try:
                    s.recv(65535)
                    self.replies += 1
                except TimeoutError:
                    pass

    def stop(self) -> None:
        self.stop_ev.set()
        self.thread.join(2.0)


# ------------------------------------------------------------------------------------ results


@dataclass
class TimedMove:
    """A MoveJoint with a duration, judged by the board's 156 frames."""

    text: str
    status: str
    #: board receive times of its first and last 156 frame (monotonic s); nan if none
    first: float
    last: float
    frames: int

    @property
    def duration(self) -> float:
        return self.last - self.first

    @property
    def error(self) -> float:
        """Duration at the board minus the planned duration, s."""
        return self.duration - MOVE_S


@dataclass
class EndCheck:
    """A speed-only move or a JOG with a distance, judged by where the board's counters ended."""

    text: str
    status: str
    want_deg: tuple[float, ...]
    got_deg: tuple[float, ...]

    @property
    def error_deg(self) -> float:
        return max(abs(a - b) for a, b in zip(self.want_deg, self.got_deg))


@dataclass
class ScenarioRun:
    moves: list[TimedMove] = field(default_factory=list)
    ends: list[EndCheck] = field(default_factory=list)
    other: list[tuple[str, str, str]] = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    seconds: float = 0.0
    queries: int = 0
    #: board-sim's scheduling
    board: str = ""

    @property
    def failed(self) -> list[str]:
        """Every command that did not complete, with its ack."""
        out = [f"{m.text}: {m.status}" for m in self.moves if m.status != "COMPLETED"]
        out += [f"{e.text}: {e.status}" for e in self.ends if e.status != "COMPLETED"]
        out += [f"{t}: {s} {d}" for t, s, d in self.other if s != "COMPLETED"]
        return out


def _joint_text(pose: tuple[float, ...]) -> str:
    return "|".join(f"{v:g}" for v in pose)


def _goto_span(board: BoardSim, t_send: float, t_end: float) -> tuple[float, float, int]:
    """First and last 156 frame the board received between ``t_send`` and ``t_end``."""
    goto = [f for f in board.frames(t_send) if f[2] == BOARD_GOTO and f[1] <= t_end]
    if not goto:
        return math.nan, math.nan, 0
    return goto[0][1], goto[-1][1], len(goto)


def _settled(board: BoardSim) -> tuple[float, ...]:
    """The board's position once its speeds read zero (at most 1 s of waiting)."""
    end = time.monotonic() + 1.0
    while True:
        st = board.status()
        if not any(st["speeds"]) or time.monotonic() > end:
            return tuple(p / s for p, s in zip(st["positions"], SPD))
        time.sleep(0.02)


def run_scenario(client: Client, board: BoardSim, *, seconds: float, moves: int = 20,
                 pause_s: float = 0.3) -> ScenarioRun:
    """``moves`` cycles filling ``seconds`` (at least one of everything per cycle): a timed
    MoveJoint (A and B in turn, ``MOVE_S``), then until the cycle's share of the time is used:
    a speed-only move to C and back, a JOG of ``JOG_DEG`` out and back; pauses between
    commands (idle frames, which also separate the moves in the frame log)."""
    run = ScenarioRun(board=board.scheduling)
    poller = Poller(client.addr[1])
    t_start = time.monotonic()
    try:
        for i in range(moves):
            cycle_end = t_start + (i + 1) * seconds / moves
            pose = POSE_B if i % 2 == 0 else POSE_A
            text = f"MOVEJOINT|{_joint_text(pose)}|{MOVE_S:g}|None"
            status, _, t0, t1 = client.run(text, timeout=MOVE_S + 20)
            time.sleep(pause_s)
            first, last, n = _goto_span(board, t0, t1 + pause_s)
            run.moves.append(TimedMove(text, status, first, last, n))
            while True:
                for target in (POSE_C, pose):
                    text = f"MOVEJOINT|{_joint_text(target)}|{SPEED_ONLY_S:g}|None|None|None|speed"
                    status, _, _, _ = client.run(text, timeout=SPEED_ONLY_S + 20)
                    run.ends.append(EndCheck(text, status, target, _settled(board)))
                    time.sleep(pause_s)
                for joint in (0, 6):  # J1 out, J1 back
                    start = board.positions_deg()
                    text = f"JOG|{joint}|{JOG_PCT}|None|{JOG_DEG:g}"
                    status, _, _, _ = client.run(text, timeout=20)
                    want = (start[0] + (JOG_DEG if joint == 0 else -JOG_DEG),) + start[1:]
                    run.ends.append(EndCheck(text, status, want, _settled(board)))
                    time.sleep(pause_s)
                if time.monotonic() + 2 * SPEED_ONLY_S + 2.0 + 4 * pause_s > cycle_end:
                    break
            time.sleep(max(0.0, cycle_end - time.monotonic()))
    finally:
        poller.stop()
    run.seconds = time.monotonic() - t_start
    run.queries = poller.replies
    run.stats = client.loop_stats()
    return run


def report(run: ScenarioRun) -> list[str]:
    """The run's figures, one line each (the test's failure message, the bench's output)."""
    errs = [m.error for m in run.moves if not math.isnan(m.error)]
    ends = [e.error_deg for e in run.ends]
    speed_only = [e.error_deg for e in run.ends if e.text.startswith("MOVEJOINT")]
    jogs = [e.error_deg for e in run.ends if e.text.startswith("JOG")]
    st = run.stats
    lines = [
        f"{len(run.moves)} MoveJoint t={MOVE_S:g} s at the board (first to last 156 frame): error "
        + (f"mean {sum(errs) / len(errs) * 1e3:+.1f} ms, min {min(errs) * 1e3:+.1f} ms, max {max(errs) * 1e3:+.1f} ms "
           f"(max |error| {max(abs(e) for e in errs) / MOVE_S * 100:.2f} % of {MOVE_S:g} s)" if errs else "n/a"),
        f"end error (board counters against the target): {len(speed_only)} speed-only moves max "
        + (f"{max(speed_only):.3f} deg, mean {sum(speed_only) / len(speed_only):.3f} deg" if speed_only else "n/a")
        + f"; {len(jogs)} JOGs with a distance max "
        + (f"{max(jogs):.3f} deg, mean {sum(jogs) / len(jogs):.3f} deg" if jogs else "n/a")
        + (f"; over 0.1 deg: {sum(1 for v in ends if v > 0.1)}" if ends else ""),
        f"loop: scheduling {st.get('scheduling')}; tick lateness p50 {st.get('late_p50_ms')} ms, p99 "
        f"{st.get('late_p99_ms')} ms, max {st.get('late_max_ms')} ms; period p99 {st.get('period_p99_ms')} ms, "
        f"overruns {st.get('overruns')} of {st.get('ticks')} ticks",
        f"link: losses {st.get('link_losses')}, motion paused for missing replies {st.get('link_holds')} "
        f"times, longest run of unanswered frames {st.get('unanswered_max')}",
        f"{run.seconds:.0f} s; {run.queries} GET_STATUS answered in the background; board-sim {run.board}",
    ]
    if run.failed:
        lines.append("not COMPLETED: " + "; ".join(run.failed[:8]))
    return lines


def controller_env(repo: Path) -> dict[str, str]:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = str(repo / "src") + os.pathsep + env.get("PYTHONPATH", "")
    return env
