"""Tick-rate benchmark: what 250 Hz costs and gains against 100 Hz (issue 23, item 4: "measure
whether 250 Hz can be the default").

Every motion frame is a GO TO frame whose goal leads the joint by at most 20 ms of travel at
its maximum speed; within a tick the board's speed decays as ``v0 exp(-50 t)``, so a GO TO
stream averages at most 78.7 % of its peak at 100 Hz and 90.6 % at 250 Hz: moves could run
faster at 250 Hz, for 2.5x the ticks.  This script runs the real parts at each rate over the
same work and prints the gain and the price; the first rate (100 Hz) is the reference, every
other rate's figure is printed with its ratio to it.  Figures, never a pass/fail.

Per run (one rate, quiet or with ``--hogs`` CPU-burning processes started first): ``parolkit
board-sim`` on a pty (its own process, SCHED_FIFO where allowed, pre-homed, ``--exchange-log``:
every frame received and every status frame it answered with, with times), ``parolkit serve
--port PTY --rate R`` (its stop supervisor included), one status-stream subscriber at every
tick (as the recorder subscribes), then

* ``--idle`` s without commands: controller and supervisor CPU (process time over wall, % of
  one core);
* ``--cycles`` x (a long MoveJoint at 100 % speed that moves J1, J2, J3 and J6 by distances in
  proportion to their maximum speeds, so that all four cruise at the same fraction of their
  maximum; a JOG of J6 at 100 % (18,000 steps/s, 82 % of its maximum) over 150 deg; the jog
  back; the move back): CPU during motion; each move's duration at the board (first to last
  GO TO frame between the command and its COMPLETED) and each joint's cruise speed (the
  largest mean speed over 0.5 s, from the board's own position reports) as % of the joint's
  maximum, from the commands before the first that did not complete; the highest speed the
  board reported, as % of the maximum;
* the loop's GET_LOOP_STATS (period p50/p99/max, overruns, tick work, serial round trip,
  link holds and losses), the integrity counters (IMPLAUSIBLE / UNCOMMANDED: false faults on
  a link without faults), every command that did not complete, every "ran stretched" warning;
* serial bytes/s each way, counted at the board (exchange log), against what the link
  carries: 3,000,000 baud (``serial.baud``, docs/transport.md) = 300,000 bytes/s each way at
  10 bits a byte;
* the status stream's datagrams and bytes per second and the ticks it skipped.

    python bench/tick_rate.py [--rates 100,250] [--hogs 2] [--idle 6] [--cycles 2] [--repeats 1]
                              [--same-time-limits] [--keep DIR]

``--hogs 0`` runs the quiet runs only.  ``--same-time-limits``: the link's hold and loss
rules count frames (``link_hold_frames`` 2, ``link_timeout_ticks`` 50: 20 ms and 0.5 s at 100
Hz, 8 ms and 0.2 s at 250 Hz); with it the other rates get counts that last as long as the
defaults at the first rate.  The whole script (two rates, quiet and with hogs)
takes about 2 minutes (106-123 s on the shared 2-core machine).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO))

# the rigs the integration tests and bench/controller.py use
from tests.integration import load  # noqa: E402
from tests.integration.boardsim import BoardSim  # noqa: E402

from parolkit.client.launch import stop_process  # noqa: E402
from parolkit.config import ControllerSettings, SerialSettings  # noqa: E402
from parolkit.robot import GOTO_GAIN_PER_S, PAROL6, goto_tracking_factor  # noqa: E402

HOST = "127.0.0.1"
#: the link's nominal rate (``serial.baud``, 3,000,000: both sides open the port at it; over USB
#: CDC it is nominal), bytes/s each way at 10 bits a byte (8N1)
LINK_BYTES_S = SerialSettings().baud / 10
BOARD_GOTO = load.BOARD_GOTO
VMAX = tuple(float(v) for v in PAROL6.max_speed_steps_s)
SPD = load.SPD
STANDBY = tuple(float(v) for v in PAROL6.standby_deg)
#: the long move: J1, J2, J3 and J6 each move this many seconds of travel at their maximum
#: speed (J1 80 deg, J2 71, J3 87, J6 173), so they cruise at the same fraction of it
LONG_MOVE_S = 1.4
LONG_SIGNS = (-1, 1, 1, 0, 0, -1)
FAR = tuple(s + sign * v / spd * LONG_MOVE_S for s, sign, v, spd in zip(STANDBY, LONG_SIGNS, VMAX, SPD))
MOVED = (0, 1, 2, 5)
#: the jog: J6 at 100 % (its jog maximum, 18,000 steps/s) this far, out and back
JOG_JOINT, JOG_PCT, JOG_DEG = 5, 100, 150.0
#: window of the cruise speed: the largest mean speed over this long, s
CRUISE_WINDOW_S = 0.5
PAUSE_S = 0.3


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind((HOST, 0))
        return int(s.getsockname()[1])


def cpu_s(pid: int | None) -> float:
    """User + system CPU time of a process (all its threads, those that ended too), s."""
    if pid is None:
        return math.nan
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return math.nan
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class CpuMeter:
    """CPU time of some processes over a stretch of wall time, % of one core."""

    def __init__(self, pids: dict[str, int | None]) -> None:
        self.pids = pids
        self.t0 = time.monotonic()
        self.c0 = {name: cpu_s(pid) for name, pid in pids.items()}

    def percent(self) -> dict[str, float]:
        wall = time.monotonic() - self.t0
        return {name: 100.0 * (cpu_s(pid) - self.c0[name]) / wall for name, pid in self.pids.items()}


class StreamCounter:
    """One status-stream subscriber at every tick (``SUBSCRIBE|port|1`` with the cookie echo,
    renewed every 5 s): datagrams, bytes and the ticks it did not get (gaps in ``seq``)."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((HOST, 0))
        self.sock.settimeout(0.2)
        self.addr = (HOST, port)
        self.me = self.sock.getsockname()[1]
        self.datagrams = self.bytes = self.skipped = 0
        self.last_seq: int | None = None
        self._counting = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _subscribe(self, cookie: str | None) -> None:
        tail = f"|{cookie}" if cookie else ""
        self.sock.sendto(f"SUBSCRIBE|{self.me}|1{tail}".encode(), self.addr)

    def _run(self) -> None:
        self._subscribe(None)
        renew = time.monotonic() + 5.0
        while not self._stop.is_set():
            if time.monotonic() > renew:
                self._subscribe(None)
                renew = time.monotonic() + 5.0
            try:
                data = self.sock.recv(65535)
            except TimeoutError:
                continue
            except OSError:
                return
            if data.startswith(b"COOKIE|"):
                self._subscribe(data[7:].decode())
            elif data.startswith(b"STATUS_JSON|") and self._counting:
                seq = int(json.loads(data[12:])["seq"])
                if self.last_seq is not None and seq > self.last_seq + 1:
                    self.skipped += seq - self.last_seq - 1
                self.last_seq = seq
                self.datagrams += 1
                self.bytes += len(data)

    def start_counting(self) -> float:
        self._counting = True
        return time.monotonic()

    def close(self) -> None:
        self._stop.set()
        try:
            self.sock.sendto(f"UNSUBSCRIBE|{self.me}".encode(), self.addr)
        except OSError:
            pass
        self._thread.join(2.0)
        self.sock.close()


@dataclass
class Command:
    kind: str  # "move" or "jog"
    text: str
    status: str
    details: str
    sent: float
    ended: float
    acks: list[tuple[str, str]]


@dataclass
class Run:
    rate: float
    hogs: int
    load_start: float = 0.0
    cpu_idle: dict[str, float] = field(default_factory=dict)
    cpu_motion: dict[str, float] = field(default_factory=dict)
    commands: list[Command] = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    integrity: dict = field(default_factory=dict)
    #: the controller's latched error at the end (a false fault, a stop by the supervisor)
    error: str = ""
    exchange: list[dict] = field(default_factory=list)
    window: tuple[float, float] = (0.0, 0.0)
    stream: tuple[int, int, int, float] = (0, 0, 0, 0.0)
    board_scheduling: str = ""
    #: (link_timeout_ticks, link_hold_frames) when not the defaults
    limits: tuple[int, int] | None = None

    # ------------------------------------------------------------------ figures from the log

    def serial_bytes_s(self) -> tuple[float, float]:
        """Bytes/s PC -> board (frames received by the board) and board -> PC (bytes it wrote)
        over the run's idle and motion time."""
        t0, t1 = self.window
        def count(kind: str) -> int:
            return sum(len(e["raw"]) // 2 for e in self.exchange if e["k"] == kind and t0 <= e["t"] <= t1)
        return count("in") / (t1 - t0), count("out") / (t1 - t0)

    def executed(self, t0: float, t1: float) -> list[dict]:
        return [e for e in self.exchange if e["k"] == "ex" and t0 <= e["t"] <= t1]

    def move_duration(self, c: Command) -> float:
        """First to last GO TO frame at the board between the command and its end, s."""
        goto = [e["t"] for e in self.executed(c.sent, c.ended + PAUSE_S) if e["cmd"] == BOARD_GOTO]
        return goto[-1] - goto[0] if goto else math.nan

    def cruise_pct(self, c: Command, joint: int) -> float:
        """The joint's largest mean speed over CRUISE_WINDOW_S, from the board's position
        reports, as % of its maximum."""
        ex = self.executed(c.sent, c.ended)
        best, k = 0.0, 0
        for e in ex:
            while k < len(ex) and ex[k]["t"] - e["t"] < CRUISE_WINDOW_S:
                k += 1
            if k >= len(ex):
                break
            dt = ex[k]["t"] - e["t"]
            best = max(best, abs(ex[k]["reply"]["p"][joint] - e["reply"]["p"][joint]) / dt)
        return 100.0 * best / VMAX[joint]

    def peak_reported_pct(self) -> tuple[float, int]:
        """The highest speed the board reported during motion as % of the joint's maximum, and
        how many status frames reported a joint above its maximum."""
        t0, t1 = self.motion_window()
        peak, over = 0.0, 0
        for e in self.executed(t0, t1):
            v = e["reply"]["v"]
            pct = max(abs(v[j]) / VMAX[j] for j in range(6)) * 100.0
            peak = max(peak, pct)
            over += pct > 100.0
        return peak, over

    def motion_window(self) -> tuple[float, float]:
        return self.commands[0].sent, self.commands[-1].ended

    def stretched(self) -> list[str]:
        return [f"{c.kind} {c.text}: {d}" for c in self.commands for _, d in c.acks if "stretched" in d]

    def not_completed(self) -> list[str]:
        return [f"{c.text}: {c.status} {c.details}" for c in self.commands if c.status != "COMPLETED"]


def _joints(pose: tuple[float, ...]) -> str:
    return "|".join(f"{v:.4f}" for v in pose)


def _link_up(client: load.Client) -> bool:
    reply = client.query("GET_STATUS", "STATUS|", timeout=0.5)
    return bool(reply) and reply.endswith("|SERIAL=1")


def _command(client: load.Client, kind: str, text: str) -> Command:
    t0 = time.monotonic()
    cid = client.send(text)
    status, details = client.terminal(cid, 30.0)
    t1 = time.monotonic()
    time.sleep(PAUSE_S)  # idle frames between commands
    return Command(kind, text, status, details, t0, t1, list(client.acks.get(cid, [])))


def link_limits(rate: float, ref_rate: float) -> tuple[int, int]:
    """``link_timeout_ticks`` and ``link_hold_frames`` at ``rate`` that last as long as the
    defaults at ``ref_rate`` (the defaults count frames, so at 250 Hz they last 0.4x as long)."""
    d = ControllerSettings()
    return round(d.link_timeout_ticks * rate / ref_rate), round(d.link_hold_frames * rate / ref_rate)


def run_once(rate: float, hogs: int, idle_s: float, cycles: int, tmp: Path,
             limits: tuple[int, int] | None = None) -> Run:
    """One run (module docstring); ``limits``: (link_timeout_ticks, link_hold_frames) in the
    controller's config instead of the defaults."""
    d = tmp / f"{rate:g}hz-{hogs}hogs-{time.monotonic_ns()}"
    d.mkdir()
    run = Run(rate, hogs, load_start=os.getloadavg()[0], limits=limits)
    cfg = d / "controller.toml"
    cfg.write_text("[controller]\n" + (f"link_timeout_ticks = {limits[0]}\nlink_hold_frames = {limits[1]}\n"
                                        if limits else ""))
    env = load.controller_env(REPO)
    with load.BusyProcesses(hogs):
        board = BoardSim(d, frame_log=None, exchange_log=True, env=env)
        run.board_scheduling = board.scheduling
        ctl = client = stream = None
        log = open(d / "controller.log", "wb")
        try:
            port, ack = free_port(), free_port()
            ctl = subprocess.Popen([sys.executable, "-m", "parolkit", "serve", "--port", str(board.link),
                                    "--rate", f"{rate:g}", "--udp-port", str(port), "--ack-port", str(ack),
                                    "--config", str(cfg)],
                                   env=env, stdout=log, stderr=subprocess.STDOUT)
            client = load.Client(port, ack)
            end = time.monotonic() + 30
            while not _link_up(client):
                if ctl.poll() is not None or time.monotonic() > end:
                    raise RuntimeError(f"the controller at {rate:g} Hz did not bring the link up: "
                                       f"{(d / 'controller.log').read_text(errors='replace')[-2000:]}")
                time.sleep(0.05)
            sup = client.loop_stats().get("supervisor_pid")
            pids = {"controller": ctl.pid, "supervisor": sup, "board-sim": board.proc.pid}
            stream = StreamCounter(port)
            time.sleep(1.0)  # the link's first second (the probe, the supervisor's start) is not idle
            t_idle = stream.start_counting()
            meter = CpuMeter(pids)
            time.sleep(idle_s)
            run.cpu_idle = meter.percent()
            meter = CpuMeter(pids)
            far, back = f"MOVEJOINT|{_joints(FAR)}|None|100", f"MOVEJOINT|{_joints(STANDBY)}|None|100"
            for _ in range(cycles):
                run.commands.append(_command(client, "move", far))
                run.commands.append(_command(client, "jog", f"JOG|{JOG_JOINT}|{JOG_PCT}|None|{JOG_DEG:g}"))
                run.commands.append(_command(client, "jog", f"JOG|{JOG_JOINT + 6}|{JOG_PCT}|None|{JOG_DEG:g}"))
                run.commands.append(_command(client, "move", back))
            run.cpu_motion = meter.percent()
            t_end = time.monotonic()
            run.window = (t_idle, t_end)
            run.stream = (stream.datagrams, stream.bytes, stream.skipped, t_end - t_idle)
            run.stats = client.loop_stats()
            reply = client.query("GET_STATUS_JSON", "STATUS_JSON|")
            status = json.loads(reply.split("|", 1)[1]) if reply else {}
            run.integrity = status.get("integrity", {})
            run.error = (status.get("errors") or {}).get("message") or ""
        finally:
            if stream is not None:
                stream.close()
            if client is not None:
                client.close()
            if ctl is not None:
                stop_process(ctl)
            log.close()
            board.close()
    with open(board.record_path, encoding="utf-8") as f:
        run.exchange = [json.loads(line) for line in f if line.strip()]
    return run


# ------------------------------------------------------------------------------ printing


def _fmt(v: float, spec: str = ".1f") -> str:
    return "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def _ratio(v: float, ref: float) -> str:
    if not ref or math.isnan(v) or math.isnan(ref):
        return ""
    return f" ({v / ref:.2f}x)"


def summarize(run: Run) -> dict[str, float]:
    # speeds and durations from the commands before the first that failed (after it, the next
    # ones start from wherever the robot stopped)
    fine = run.commands[:next((i for i, c in enumerate(run.commands) if c.status != "COMPLETED"), None)]
    moves = [c for c in fine if c.kind == "move"]
    jogs = [c for c in fine if c.kind == "jog"]
    out: dict[str, float] = {
        "cpu_idle": run.cpu_idle.get("controller", math.nan),
        "cpu_motion": run.cpu_motion.get("controller", math.nan),
        "sup_idle": run.cpu_idle.get("supervisor", math.nan),
        "sup_motion": run.cpu_motion.get("supervisor", math.nan),
        "board_motion": run.cpu_motion.get("board-sim", math.nan),
        "move_s": statistics.mean(run.move_duration(c) for c in moves) if moves else math.nan,
        "jog_s": statistics.mean(run.move_duration(c) for c in jogs) if jogs else math.nan,
        "jog_pct": statistics.mean(run.cruise_pct(c, JOG_JOINT) for c in jogs) if jogs else math.nan,
    }
    for j in MOVED:
        out[f"move_pct_{j}"] = statistics.mean(run.cruise_pct(c, j) for c in moves) if moves else math.nan
    out["peak_pct"], out["over_max"] = run.peak_reported_pct()
    out["to_board"], out["to_pc"] = run.serial_bytes_s()
    n, nbytes, skipped, secs = run.stream
    out["stream_hz"], out["stream_kb_s"], out["stream_skipped"] = n / secs, nbytes / secs / 1e3, skipped
    st = run.stats
    for k in ("period_p50_ms", "period_p99_ms", "period_max_ms", "overruns", "ticks", "late_p99_ms", "late_max_ms",
              "tick_work_p99_ms", "tick_work_max_ms", "rtt_p50_ms", "rtt_p99_ms", "link_losses", "link_holds",
              "unanswered_max"):
        out[k] = float(st.get(k, math.nan))
    out["implausible"] = float(run.integrity.get("implausible", math.nan))
    out["uncommanded"] = float(run.integrity.get("uncommanded", math.nan))
    out["stretched"] = float(len(run.stretched()))
    out["not_completed"] = float(len(run.not_completed()))
    return out


def print_run(run: Run, s: dict[str, float], ref: dict[str, float] | None) -> None:
    r = ref or {}
    period = 1e3 / run.rate
    what = f"{run.hogs} CPU hogs" if run.hogs else "quiet"
    print(f"== {run.rate:g} Hz, {what} (load average {run.load_start:.1f} at the start; board-sim "
          f"{run.board_scheduling}; controller {run.stats.get('scheduling')}"
          + (f"; link_timeout_ticks {run.limits[0]}, link_hold_frames {run.limits[1]}" if run.limits else "")
          + ")"
          + ("" if ref is None else "; ratios against 100 Hz in the same conditions"))
    print(f"  controller CPU, % of one core: idle {_fmt(s['cpu_idle'])}{_ratio(s['cpu_idle'], r.get('cpu_idle', 0))}, "
          f"motion {_fmt(s['cpu_motion'])}{_ratio(s['cpu_motion'], r.get('cpu_motion', 0))}; stop supervisor idle "
          f"{_fmt(s['sup_idle'])}, motion {_fmt(s['sup_motion'])}; board-sim (with its exchange log) "
          f"{_fmt(s['board_motion'])}")
    print(f"  loop period p50 / p99 / max {_fmt(s['period_p50_ms'], '.2f')} / {_fmt(s['period_p99_ms'], '.2f')} / "
          f"{_fmt(s['period_max_ms'], '.1f')} ms (nominal {period:.1f}), overruns {s['overruns']:.0f} of "
          f"{s['ticks']:.0f} ticks; lateness p99 {_fmt(s['late_p99_ms'], '.2f')} ms, max "
          f"{_fmt(s['late_max_ms'], '.1f')} ms; tick work p99 {_fmt(s['tick_work_p99_ms'], '.2f')} ms, max "
          f"{_fmt(s['tick_work_max_ms'], '.1f')} ms ({s['tick_work_p99_ms'] / period * 100:.0f} % of a period)")
    print(f"  serial: PC->board {s['to_board']:,.0f} B/s, board->PC {s['to_pc']:,.0f} B/s; the link carries "
          f"{LINK_BYTES_S:,.0f} B/s each way: headroom {LINK_BYTES_S / s['to_board']:.0f}x / "
          f"{LINK_BYTES_S / s['to_pc']:.0f}x; round trip (write -> reply, pty) p50 {_fmt(s['rtt_p50_ms'], '.2f')} / "
          f"p99 {_fmt(s['rtt_p99_ms'], '.2f')} ms = {s['rtt_p99_ms'] / period * 100:.0f} % of a period")
    print(f"  status stream (1 subscriber, every tick): {s['stream_hz']:.0f} datagrams/s, "
          f"{s['stream_kb_s']:.0f} kB/s{_ratio(s['stream_kb_s'], r.get('stream_kb_s', 0))}, "
          f"{s['stream_skipped']:.0f} ticks skipped")
    law = (1 - math.exp(-GOTO_GAIN_PER_S / run.rate)) / (GOTO_GAIN_PER_S / run.rate) * 100
    cap = goto_tracking_factor(run.rate) * 100
    moved = ", ".join(f"J{j + 1} {_fmt(s[f'move_pct_{j}'])}" for j in MOVED)
    print(f"  long MoveJoint at 100 %: cruise {moved} % of each joint's maximum (planners' cap "
          f"{cap:.1f} %, the law's ceiling {law:.1f} %); at the board {_fmt(s['move_s'], '.3f')} s"
          f"{_ratio(s['move_s'], r.get('move_s', 0))}")
    print(f"  JOG J6 at 100 % ({PAROL6.max_jog_speed_steps_s[JOG_JOINT]:,.0f} steps/s = "
          f"{PAROL6.max_jog_speed_steps_s[JOG_JOINT] / VMAX[JOG_JOINT] * 100:.1f} % of its maximum) over "
          f"{JOG_DEG:g} deg: cruise {_fmt(s['jog_pct'])} %, {_fmt(s['jog_s'], '.3f')} s at the board"
          f"{_ratio(s['jog_s'], r.get('jog_s', 0))}")
    print(f"  board's highest reported speed {_fmt(s['peak_pct'])} % of a joint's maximum, status frames over "
          f"it {s['over_max']:.0f}; integrity: implausible {s['implausible']:.0f}, uncommanded "
          f"{s['uncommanded']:.0f}; link holds {s['link_holds']:.0f}, losses {s['link_losses']:.0f}, longest "
          f"unanswered run {s['unanswered_max']:.0f}; 'ran stretched' warnings {s['stretched']:.0f} of "
          f"{len(run.commands)} commands; not COMPLETED {s['not_completed']:.0f}")
    if run.error:
        print(f"    the controller's error at the end: {run.error[:200]}")
    for line in (run.stretched() + run.not_completed())[:6]:
        print(f"    {line[:200]}")


TABLE = (
    ("controller CPU idle, % core", "cpu_idle", ".1f"),
    ("controller CPU motion, % core", "cpu_motion", ".1f"),
    ("period p99, ms", "period_p99_ms", ".2f"),
    ("period max, ms", "period_max_ms", ".1f"),
    ("overruns", "overruns", ".0f"),
    ("PC->board B/s (headroom)", "to_board", ",.0f"),
    ("status stream kB/s", "stream_kb_s", ".0f"),
    ("move cruise J1, % max", "move_pct_0", ".1f"),
    ("move at the board, s", "move_s", ".3f"),
    ("jog J6 cruise, % max", "jog_pct", ".1f"),
    ("board peak, % max", "peak_pct", ".1f"),
    ("stretched / not completed", "stretched", ".0f"),
    ("implausible / uncommanded", "implausible", ".0f"),
    ("link holds / losses", "link_holds", ".0f"),
)


def print_table(rows: list[tuple[str, list[dict[str, float]]]]) -> None:
    """One column per (rate, load), min-max over the repeats."""
    print("== summary (min-max over the repeats)")
    print(f"{'':32}" + "".join(f"{name:>22}" for name, _ in rows))
    pair = {"stretched": "not_completed", "implausible": "uncommanded", "link_holds": "link_losses"}
    for label, key, spec in TABLE:
        cells = []
        for _, runs in rows:
            vals = [r[key] for r in runs]
            lo, hi = min(vals), max(vals)
            cell = format(lo, spec) if lo == hi else f"{format(lo, spec)}-{format(hi, spec)}"
            if key in pair:
                other = [r[pair[key]] for r in runs]
                cell += f" / {max(other):.0f}"
            if key == "to_board":
                cell += f" ({LINK_BYTES_S / hi:.0f}x)"
            cells.append(cell)
        print(f"{label:32}" + "".join(f"{c:>22}" for c in cells))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", default="100,250", help="loop rates in Hz, the first is the reference (default 100,250)")
    ap.add_argument("--hogs", type=int, default=2, help="CPU-burning processes of the loaded runs (default 2; 0: "
                    "quiet runs only)")
    ap.add_argument("--idle", type=float, default=6.0, help="seconds of the idle CPU measurement (default 6)")
    ap.add_argument("--cycles", type=int, default=2, help="move, jog, jog back, move back: how many times (default 2)")
    ap.add_argument("--repeats", type=int, default=1, help="runs of each rate and load, interleaved (default 1)")
    ap.add_argument("--same-time-limits", action="store_true",
                    help="give the other rates link_timeout_ticks and link_hold_frames that last as long as the "
                    "defaults at the first rate (default: the defaults, which count frames)")
    ap.add_argument("--keep", metavar="DIR", default=None,
                    help="keep each run's controller log and board-sim exchange log under DIR (default: a "
                    "temporary folder, removed)")
    args = ap.parse_args()
    try:
        rates = [float(r) for r in args.rates.split(",")]
    except ValueError:
        ap.error(f"--rates must be numbers of Hz separated by commas, got {args.rates!r}")
    if not rates or not all(0 < r <= 1000 for r in rates):
        ap.error(f"--rates must be in (0, 1000] Hz, got {args.rates!r}")
    for name, v, lo in (("--hogs", args.hogs, 0), ("--cycles", args.cycles, 1), ("--repeats", args.repeats, 1)):
        if v < lo:
            ap.error(f"{name} must be an integer >= {lo}, got {v}")
    if not args.idle > 0:
        ap.error(f"--idle must be > 0 s, got {args.idle}")
    loads = [0] + ([args.hogs] if args.hogs else [])
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start; reference: "
          f"{rates[0]:g} Hz; {args.cycles} cycles of (MoveJoint, JOG, JOG back, MoveJoint back) per run")
    results: dict[tuple[float, int], list[dict[str, float]]] = {(r, h): [] for h in loads for r in rates}
    t_start = time.monotonic()
    if args.keep:
        Path(args.keep).mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        tmp = args.keep or scratch
        for _ in range(args.repeats):
            for hogs in loads:
                ref: dict[str, float] | None = None
                for rate in rates:
                    limits = link_limits(rate, rates[0]) if args.same_time_limits and rate != rates[0] else None
                    run = run_once(rate, hogs, args.idle, args.cycles, Path(tmp), limits)
                    s = summarize(run)
                    print_run(run, s, ref)
                    ref = ref or s
                    results[(rate, hogs)].append(s)
    rows = [(f"{r:g} Hz {'quiet' if h == 0 else f'{h} hogs'}", results[(r, h)]) for h in loads for r in rates]
    print_table(rows)
    print(f"load average {os.getloadavg()[0]:.1f} at the end; {time.monotonic() - t_start:.0f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
