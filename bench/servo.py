"""Servo benchmark (issue 24): target-to-board-frame latency of SERVOJ, and the stream's own
rate, at 100 and 250 Hz.

A controller (``parolkit serve``, its own process) drives the board emulator over a real pty
(the emulator runs in this process, so every frame it receives is timestamped the moment it
arrives).  This process streams SERVOJ targets over UDP at the control rate: J6 held still,
then every 0.4 s a step of 1 deg, alternately up and down.  The latency of a step is the time
from the datagram leaving this process to the first GO TO frame reaching the board whose J6
feed-forward moves toward the new target.

Printed next to the references measured in the same run, or published:

* half a control period: the expected wait for the next tick (a target is taken in by the
  tick after it arrives and is in that tick's frame);
* the watchdogs other stacks stop a silent stream after: the incumbent PAROL6 Python API's
  servo timeout (250 ms) and MoveIt Servo's default incoming-command timeout (100 ms).
  parolkit's is ``servo.timeout_s`` (50 ms); a latency far under these is what lets a stream
  use them.

    python bench/servo.py [--steps 40] [--rates 100,250]
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

from parolkit.board import BoardEmulator, PtyBoardServer  # noqa: E402
from parolkit.protocol.frames import COMMAND_FRAME_SIZE, BoardCommand, CommandFrame  # noqa: E402
from parolkit.robot import PAROL6  # noqa: E402

ENV = dict(os.environ, PYTHONPATH=str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
#: published stream watchdogs, ms: the incumbent PAROL6 Python API, MoveIt Servo's default
INCUMBENT_WATCHDOG_MS = 250.0
MOVEIT_SERVO_WATCHDOG_MS = 100.0


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def pct(values: list[float], p: float) -> float:
    v = sorted(values)
    return v[min(len(v) - 1, int(round(p / 100.0 * (len(v) - 1))))]


def bench_rate(rate: float, steps: int, tmp: Path) -> None:
    period = 1.0 / rate
    print(f"== SERVOJ at {rate:g} Hz: {steps} steps of 1 deg on J6, targets streamed at {rate:g} Hz")
    emu = BoardEmulator(start_homed=True)
    lock = threading.Lock()
    pending: dict[str, float | int | None] = {"since": None, "direction": 0}
    latencies: list[float] = []
    orig_write = emu.write

    def write_hook(data: bytes) -> None:
        now = time.perf_counter()
        with lock:
            since, direction = pending["since"], pending["direction"]
        if since is not None:
            try:
                f = CommandFrame.decode(bytes(data[:COMMAND_FRAME_SIZE])) if len(data) >= COMMAND_FRAME_SIZE else None
            except ValueError:  # not a whole frame at the start: the emulator's own parser sees it
                f = None
            if f is not None and f.command == BoardCommand.GOTO and f.speeds[5] * int(direction) > 0:
                with lock:
                    if pending["since"] is since:
                        latencies.append(now - float(since))
                        pending["since"] = None
        orig_write(data)

    emu.write = write_hook  # type: ignore[method-assign]
    link = tmp / f"p6-servo-{int(rate)}"
    server = PtyBoardServer(emu, link).start()
    port, ack = free_port(), free_port()
    ctl = subprocess.Popen([sys.executable, "-m", "parolkit", "serve", "--port", str(link), "--rate", str(rate),
                            "--udp-port", str(port), "--ack-port", str(ack)],
                           env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.settimeout(0.5)
    addr = ("127.0.0.1", port)
    try:
        end = time.monotonic() + 30
        while time.monotonic() < end:
            s.sendto(b"GET_STATUS", addr)
            try:
                data = s.recv(65536)
            except TimeoutError:
                continue
            if data.endswith(b"|SERIAL=1") and b"HOMED=1,1,1,1,1,1" in data and b"STATE=IDLE" in data:
                break
            time.sleep(0.05)
        else:
            raise SystemExit("the controller's board link did not come up")
        s.sendto(b"GET_ANGLES", addr)
        angles = [float(v) for v in s.recv(65536).decode().split("|", 1)[1].split(",")]
        base = angles[5]
        j6 = base
        sent = 0
        next_t = time.perf_counter()
        next_step = next_t + 0.5
        done_steps = 0
        up = True
        while done_steps < steps:
            now = time.perf_counter()
            if now >= next_step:
                j6 = base + (1.0 if up else 0.0)
                with lock:
                    pending["since"], pending["direction"] = None, (1 if up else -1) * _sign(5)
                up = not up
                marked = True
                next_step = now + 0.4
                done_steps += 1
            else:
                marked = False
            text = "SERVOJ|" + "|".join(f"{v:.4f}" for v in (*angles[:5], j6))
            t_send = time.perf_counter()
            if marked:
                with lock:
                    pending["since"] = t_send
            s.sendto(text.encode(), addr)
            sent += 1
            next_t += period
            time.sleep(max(0.0, next_t - time.perf_counter()))
        time.sleep(0.2)
        s.sendto(b"STOP", addr)
    finally:
        ctl.terminate()
        ctl.wait(10)
        server.stop()
        s.close()
    if not latencies:
        print("  no step reached the board")
        return
    p50, p99 = pct(latencies, 50) * 1e3, pct(latencies, 99) * 1e3
    half = period / 2 * 1e3
    print(f"  target-to-board-frame latency: p50 {p50:.2f} ms, p99 {p99:.2f} ms, max {max(latencies) * 1e3:.2f} ms "
          f"(n={len(latencies)} of {steps} steps; {sent} targets sent)")
    print(f"  reference half a period {half:.2f} ms -> ratio p50 {p50 / half:.2f}x; a period {period * 1e3:.2f} ms")
    print(f"  published stream watchdogs: incumbent PAROL6 API {INCUMBENT_WATCHDOG_MS:.0f} ms -> p99 is "
          f"{INCUMBENT_WATCHDOG_MS / p99:.0f}x shorter; MoveIt Servo {MOVEIT_SERVO_WATCHDOG_MS:.0f} ms -> "
          f"{MOVEIT_SERVO_WATCHDOG_MS / p99:.0f}x shorter (parolkit's watchdog: servo.timeout_s = 50 ms)")


def _sign(joint: int) -> int:
    """+1 when a positive angle is a positive step count on ``joint``, else -1."""
    return 1 if PAROL6.steps_per_deg[joint] > 0 else -1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--rates", default="100,250")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        for r in args.rates.split(","):
            bench_rate(float(r), args.steps, Path(d))


if __name__ == "__main__":
    main()
