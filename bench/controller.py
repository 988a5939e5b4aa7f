"""Controller benchmark: loop timing at 100 and 250 Hz against the pty emulator, query round
trip, command-to-first-frame latency, start-up time to the first PONG, RSS, a flood phase
(issue 11: ESTOP-to-board latency, PING and lost replies while another client floods) and a
load phase (issue 12: tick lateness, link losses and move timing at the board while two
processes burn the CPU).

Every figure is printed next to a reference measured in the same run on the same machine:

* loop period: a bare deadline-sleeping Python loop (no work at all) running in its own
  process at the same rate, at the same time as the controller;
* query round trip: a minimal Python UDP echo server in its own process, queried the same way;
* command-to-first-frame: half a tick period (the expected wait for the next tick);
* start-up: ``python -c pass`` (the interpreter floor);
* flood: the same second client (ESTOP cycles, PINGs) for the same time without the flood;
* load: the same moves without the busy processes, and under them with the tick thread asked
  for nice -10 only (``realtime_priority = 0``) instead of SCHED_FIFO.

    python bench/controller.py [--duration 60] [--rates 100,250] [--phases startup,loop,flood,load]
                               [--flood-rate 20000] [--flood-duration 10] [--flood-estops 20]
                               [--load-seconds 60] [--load-moves 10] [--load-busy 2]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))
sys.path.insert(0, str(REPO))

# the flood and load rigs the acceptance tests use
from tests.integration import flood, load  # noqa: E402

from parolkit.board import BoardEmulator, PtyBoardServer  # noqa: E402

ENV = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO / "src"))

_BARE_LOOP = r"""
import sys, time, json
rate, duration = float(sys.argv[1]), float(sys.argv[2])
period = 1.0 / rate
t0 = time.monotonic(); k = 0; last = None; periods = []; overruns = 0
while time.monotonic() - t0 < duration:
    deadline = t0 + k * period
    now = time.monotonic()
    if now < deadline:
        time.sleep(deadline - now); now = time.monotonic()
    if now - deadline > period:
        overruns += 1; k += int((now - deadline) // period)
    if last is not None:
        periods.append(now - last)
    last = now; k += 1
periods.sort()
n = len(periods)
print(json.dumps({"p50": periods[n // 2] * 1e3, "p99": periods[int(n * 0.99)] * 1e3,
                  "max": periods[-1] * 1e3, "overruns": overruns}))
"""

_ECHO = r"""
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1], flush=True)
while True:
    data, addr = s.recvfrom(65535)
    if data == b"QUIT":
        break
    s.sendto(b"ANGLES|90.0000,-90.0000,180.0000,0.0000,0.0000,180.0000", addr)
"""


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(len(xs) * q / 100.0))] if xs else float("nan")


def query(sock: socket.socket, addr, text: bytes) -> tuple[bytes | None, float]:
    t = time.perf_counter()
    sock.sendto(text, addr)
    try:
        data = sock.recvfrom(65535)[0]
    except TimeoutError:
        return None, float("nan")
    return data, time.perf_counter() - t


def link_up(data: bytes | None) -> bool:
    """True for a GET_STATUS reply saying the board link is up (``...|SERIAL=1``)."""
    return bool(data) and data.startswith(b"STATUS|") and data.endswith(b"|SERIAL=1")


def rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


# ------------------------------------------------------------------------------ start-up


def bench_startup(runs: int = 5) -> None:
    print("== start-up: launch of `parolkit serve --sim --no-home` to the first PONG")
    floor = []
    for _ in range(runs):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "pass"], env=ENV, check=True)
        floor.append(time.perf_counter() - t)
    times, full = [], []
    for _ in range(runs):
        port, ack = free_port(), free_port()
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.settimeout(0.01)
        t = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "parolkit", "serve", "--sim", "--no-home", "--udp-port",
                                 str(port), "--ack-port", str(ack)], env=ENV, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        got = None
        while time.perf_counter() - t < 20:
            if got is None:
                data, _ = query(s, ("127.0.0.1", port), b"PING")
                if data == b"PONG":
                    got = time.perf_counter() - t
                continue
            data, _ = query(s, ("127.0.0.1", port), b"GET_STATUS")
            if link_up(data):
                full.append(time.perf_counter() - t)
                break
        proc.terminate()
        proc.wait(10)
        s.close()
        if got is not None:
            times.append(got)
    med, ref = statistics.median(times), statistics.median(floor)
    print(f"  first PONG: median {med * 1e3:.0f} ms, max {max(times) * 1e3:.0f} ms over {len(times)} launches "
          f"(target <= 1500 ms, aim 500 ms)")
    print(f"  reference `python -c pass`: median {ref * 1e3:.0f} ms  -> ratio {med / ref:.1f}x")
    if full:
        print(f"  first GET_STATUS with SERIAL=1 (board link up, everything loaded): median "
              f"{statistics.median(full) * 1e3:.0f} ms, max {max(full) * 1e3:.0f} ms")


# ------------------------------------------------------------------------------ loop phase


def bench_loop(rate: float, duration: float, tmp: Path) -> None:
    print(f"== loop at {rate:g} Hz for {duration:g} s against the pty emulator (moves every 2 s, "
          f"queries at 50 Hz)")
    emu = BoardEmulator(start_homed=True)
    link = tmp / f"p6-{int(rate)}"
    first_frame: list[float] = []
    waiting = {"since": None}
    orig_write = emu.write

    def write_hook(data: bytes) -> None:  # timestamps the first 156 frame after a MOVEJOINT
        since = waiting["since"]
        if since is not None and len(data) >= 41 and data[40] == 156:
            first_frame.append(time.perf_counter() - since)
            waiting["since"] = None
        orig_write(data)

    emu.write = write_hook  # type: ignore[method-assign]
    server = PtyBoardServer(emu, link).start()
    port, ack = free_port(), free_port()
    cfg = tmp / "bench.toml"
    cfg.write_text("[controller]\nlink_timeout_ticks = 50\n")
    ctl = subprocess.Popen([sys.executable, "-m", "parolkit", "serve", "--port", str(link), "--rate", str(rate),
                            "--udp-port", str(port), "--ack-port", str(ack), "--config", str(cfg)],
                           env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    echo = subprocess.Popen([sys.executable, "-c", _ECHO], env=ENV, stdout=subprocess.PIPE, text=True)
    echo_port = int(echo.stdout.readline())
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.settimeout(1.0)
    addr = ("127.0.0.1", port)
    end = time.monotonic() + 20
    while time.monotonic() < end:
        data, _ = query(s, addr, b"GET_STATUS")
        if link_up(data):
            break
        time.sleep(0.05)
    bare = subprocess.Popen([sys.executable, "-c", _BARE_LOOP, str(rate), str(duration)], env=ENV,
                            stdout=subprocess.PIPE, text=True)
    rtt, rtt_ref = [], []
    t0 = time.monotonic()
    next_move, flip = t0, False
    while time.monotonic() - t0 < duration:
        now = time.monotonic()
        if now >= next_move:
            flip = not flip
            j1 = 80 if flip else 100
            waiting["since"] = time.perf_counter()
            s.sendto(f"MOVEJOINT|{j1}|-90|180|0|0|180|1.5|None".encode(), addr)
            next_move = now + 2.0
        _, dt = query(s, addr, b"GET_ANGLES")
        rtt.append(dt)
        _, dt = query(s, ("127.0.0.1", echo_port), b"GET_ANGLES")
        rtt_ref.append(dt)
        time.sleep(0.02)
    ref = json.loads(bare.communicate(timeout=duration + 30)[0])
    data, _ = query(s, addr, b"GET_LOOP_STATS")
    stats = json.loads(data.split(b"|", 1)[1]) if data else {}
    rss = rss_kb(ctl.pid)
    s.sendto(b"QUIT", ("127.0.0.1", echo_port))
    ctl.terminate()
    ctl.wait(10)
    echo.wait(5)
    server.stop()
    emu.stop()
    period_ms = 1e3 / rate
    print(f"  period   p50 {stats.get('period_p50_ms', float('nan')):6.2f} ms  p99 "
          f"{stats.get('period_p99_ms', float('nan')):6.2f} ms  "
          f"max {stats.get('period_max_ms', float('nan')):7.2f} ms  "
          f"overruns {stats.get('overruns')}  ticks {stats.get('ticks')}")
    print(f"  bare deadline loop (reference, same time): p50 {ref['p50']:6.2f} ms  p99 {ref['p99']:6.2f} ms  "
          f"max {ref['max']:7.2f} ms  overruns {ref['overruns']}")
    if ref["p99"] > 0:
        print(f"  -> p99 jitter above nominal: controller {stats['period_p99_ms'] - period_ms:.2f} ms vs "
              f"reference {ref['p99'] - period_ms:.2f} ms")
    print(f"  serial round trip (write -> status frame): p50 {stats.get('rtt_p50_ms', float('nan')):.2f} ms  "
          f"p99 {stats.get('rtt_p99_ms', float('nan')):.2f} ms; frames sent {stats.get('frames_sent')}, "
          f"received {stats.get('frames_received')}")
    q50, q99 = pct(rtt, 50) * 1e3, pct(rtt, 99) * 1e3
    r50, r99 = pct(rtt_ref, 50) * 1e3, pct(rtt_ref, 99) * 1e3
    print(f"  query GET_ANGLES round trip: p50 {q50:.3f} ms  p99 {q99:.3f} ms  (n={len(rtt)}, target p99 <= 1 ms)")
    print(f"  reference raw UDP echo:      p50 {r50:.3f} ms  p99 {r99:.3f} ms  -> ratio p50 {q50 / r50:.1f}x, "
          f"p99 {q99 / r99:.1f}x")
    if first_frame:
        f50, fmax = pct(first_frame, 50) * 1e3, max(first_frame) * 1e3
        print(f"  command -> first 156 frame at the board: p50 {f50:.2f} ms  max {fmax:.2f} ms "
              f"(n={len(first_frame)}); reference half a period {period_ms / 2:.2f} ms -> ratio "
              f"{f50 / (period_ms / 2):.1f}x")
    print(f"  controller RSS {rss / 1024:.1f} MiB")


# ------------------------------------------------------------------------------ flood phase


def bench_flood(rate: float, duration: float, estops: int, seed: int, tmp: Path) -> None:
    """Issue 11's scenario, as tests/integration/test_flood_estop.py runs it, with figures only:
    ``board-sim --frame-log`` and the controller in their own processes, a flooder process
    (valid immediate commands, queries, garbage), the second client here (ESTOP at random
    moments, re-ENABLE and a new move after each, PINGs all the time).  The reference is the
    same second client for the same time and number of ESTOPs without the flood."""
    print(f"== flood: {rate:,.0f} datagrams/s for {duration:g} s from another process; the second "
          f"client sends ESTOP at {estops} random moments and PINGs throughout (reference: the "
          f"same without the flood, first)")
    link = tmp / "p6-flood"
    board = subprocess.Popen([sys.executable, "-m", "parolkit", "board-sim", "--link", str(link), "--start-homed",
                              "--frame-log", "50000"], env=ENV, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    ctl = rec = None
    try:
        end = time.monotonic() + 20
        while not link.exists() and time.monotonic() < end:
            time.sleep(0.02)
        port, ack = free_port(), free_port()
        cfg = tmp / "flood.toml"
        cfg.write_text("[controller]\nlink_timeout_ticks = 50\n")
        ctl = subprocess.Popen([sys.executable, "-m", "parolkit", "serve", "--port", str(link), "--udp-port",
                                str(port), "--ack-port", str(ack), "--config", str(cfg)],
                               env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.settimeout(0.5)
        addr = ("127.0.0.1", port)
        while time.monotonic() < end:
            data, _ = query(s, addr, b"GET_STATUS")
            if link_up(data):
                break
            time.sleep(0.05)
        rec = flood.AckRecorder(ack)
        run = flood.run_flood(port, rec, f"{link}.ctl", rate=rate, duration=duration, estops=estops,
                              reference_s=duration, reference_estops=estops, seed=seed)
        s.settimeout(2.0)
        data, _ = query(s, addr, b"GET_LOOP_STATS")
        stats = json.loads(data.split(b"|", 1)[1]) if data else {}
        s.close()
        for line in flood.report(run):
            print(" ", line)
        print(f"   controller after the run: datagrams received {stats.get('datagrams_received')}, invalid "
              f"{stats.get('datagrams_invalid')}; loop period p99 {stats.get('period_p99_ms')} ms, max "
              f"{stats.get('period_max_ms')} ms, overruns {stats.get('overruns')}")
    finally:
        if rec is not None:
            rec.kill()
        if ctl is not None:
            ctl.terminate()
            ctl.wait(10)
        board.terminate()
        board.wait(10)


# ------------------------------------------------------------------------------ load phase


def _load_run(tmp: Path, name: str, seconds: float, moves: int, busy: int, realtime_priority: int | None) -> None:
    """One run of the load scenario (tests/integration/load.py): board-sim (its own process,
    SCHED_FIFO where allowed, as a real board answers regardless of the PC's load), the
    controller, ``busy`` CPU-burning processes started first; figures printed."""
    d = tmp / name
    d.mkdir()
    cfg = d / "controller.toml"
    cfg.write_text("[controller]\n" + (f"realtime_priority = {realtime_priority}\n"
                                         if realtime_priority is not None else ""))
    with load.BusyProcesses(busy):
        board = load.BoardSim(d)
        ctl = client = None
        try:
            port, ack = free_port(), free_port()
            ctl = subprocess.Popen([sys.executable, "-m", "parolkit", "serve", "--port", str(board.link),
                                    "--udp-port", str(port), "--ack-port", str(ack), "--config", str(cfg)],
                                   env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.settimeout(0.5)
            end = time.monotonic() + 20
            while time.monotonic() < end:
                data, _ = query(s, ("127.0.0.1", port), b"GET_STATUS")
                if link_up(data):
                    break
                time.sleep(0.05)
            s.close()
            client = load.Client(port, ack)
            run = load.run_scenario(client, board, seconds=seconds, moves=moves)
        finally:
            if client is not None:
                client.close()
            if ctl is not None:
                ctl.terminate()
                ctl.wait(10)
            board.close()
    print(f"  -- {name}")
    for line in load.report(run):
        print("    " + line)


def bench_load(seconds: float, moves: int, busy: int, tmp: Path) -> None:
    print(f"== load: {moves} MoveJoint t={load.MOVE_S:g} s (each judged at the board by its first and "
          f"last 156 frame) with speed-only moves and JOGs with a distance between them, {seconds:g} s per "
          f"run, board-sim on a pty; machine load average {os.getloadavg()[0]:.1f}")
    _load_run(tmp, "reference: no busy process", seconds, moves, 0, None)
    _load_run(tmp, f"{busy} busy processes, default settings", seconds, moves, busy, None)
    _load_run(tmp, f"{busy} busy processes, tick thread at nice -10 only (realtime_priority = 0)", seconds,
              moves, busy, 0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per loop phase (default 60)")
    ap.add_argument("--rates", default="100,250", help="loop rates in Hz (default 100,250)")
    ap.add_argument("--startup-runs", type=int, default=5)
    ap.add_argument("--phases", default="startup,loop,flood,load",
                    help="which phases to run, comma-separated (default startup,loop,flood,load)")
    ap.add_argument("--flood-rate", type=float, default=20_000.0, help="flood datagrams/s (default 20000)")
    ap.add_argument("--flood-duration", type=float, default=10.0, help="flood seconds (default 10)")
    ap.add_argument("--flood-estops", type=int, default=20, help="ESTOPs per phase (default 20)")
    ap.add_argument("--flood-seed", type=int, default=11, help="seed of the flood mix and ESTOP moments")
    ap.add_argument("--load-seconds", type=float, default=60.0, help="seconds per load run (default 60)")
    ap.add_argument("--load-moves", type=int, default=10, help="timed MoveJoints per load run (default 10)")
    ap.add_argument("--load-busy", type=int, default=2, help="CPU-burning processes (default 2)")
    args = ap.parse_args()
    phases = {p.strip() for p in args.phases.split(",") if p.strip()}
    unknown = phases - {"startup", "loop", "flood", "load"}
    if unknown:
        ap.error(f"--phases: unknown {sorted(unknown)} (startup, loop, flood, load)")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start")
    if "startup" in phases:
        bench_startup(args.startup_runs)
    with tempfile.TemporaryDirectory() as d:
        if "loop" in phases:
            for r in args.rates.split(","):
                bench_loop(float(r), args.duration, Path(d))
        if "flood" in phases:
            bench_flood(args.flood_rate, args.flood_duration, args.flood_estops, args.flood_seed, Path(d))
        if "load" in phases:
            bench_load(args.load_seconds, args.load_moves, args.load_busy, Path(d))
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
