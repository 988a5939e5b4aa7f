"""Recorder benchmark: ``parolkit record``'s cost at 100 Hz and 250 Hz.

For each rate a simulated controller (``parolkit serve --sim --rate R``, a separate process)
is started and recorded by a :class:`parolkit.record.recorder.Recorder` in this process for
``--duration`` s (default 60; the issue's figure is 10 minutes: ``--duration 600``) while a
client moves the robot back and forth.  Printed per rate: ticks received, ticks dropped
(gaps in the tick numbers: lost by the controller's stream or by the recorder), the
recorder's CPU time as % of one core (this process's CPU time over the wall time: the
controller runs in its own process), and the file size per minute.

    .venv/bin/python bench/record.py [--duration S] [--rates 100,250]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

from parolkit.client.launch import SimController  # noqa: E402
from parolkit.client.robot import Robot  # noqa: E402
from parolkit.record.recorder import Recorder  # noqa: E402


def _mover(port: int, stop: threading.Event) -> None:
    """Keep the robot moving between two poses (so every channel carries changing values)."""
    poses = ([85.0, -100.0, 160.0, 10.0, 10.0, 170.0], [95.0, -85.0, 175.0, -10.0, -5.0, 185.0])
    with Robot("127.0.0.1", port) as robot:
        i = 0
        while not stop.is_set():
            robot.move_joints(poses[i % 2], duration=2.0, timeout=30)
            i += 1


def bench_rate(rate: float, duration: float) -> dict[str, float]:
    sim = SimController(["--rate", f"{rate:g}"])
    stop = threading.Event()
    try:
        sim.wait_ready()
        mover = threading.Thread(target=_mover, args=(sim.port, stop), daemon=True)
        mover.start()
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / f"bench-{rate:g}.mcap"
            rec = Recorder("127.0.0.1", sim.port, out)
            cpu0, wall0 = time.process_time(), time.monotonic()
            stats = rec.run(duration)
            cpu, wall = time.process_time() - cpu0, time.monotonic() - wall0
        stop.set()
        mover.join(10)
    finally:
        stop.set()
        sim.close()
    expected = (stats.last_tick or 0) - (stats.first_tick or 0) + 1
    return {"rate_hz": rate, "duration_s": stats.duration_s, "ticks": stats.statuses, "expected": expected,
            "dropped": stats.dropped_ticks, "cpu_pct": 100.0 * cpu / wall,
            "mb_per_min": stats.bytes / 1e6 / (stats.duration_s / 60.0)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per rate (default 60; issue: 600)")
    ap.add_argument("--rates", default="100,250", help="control rates, Hz (default 100,250)")
    args = ap.parse_args()
    if not args.duration > 0:
        ap.error(f"--duration must be > 0 s, got {args.duration}")
    print(f"{'rate':>6} {'time s':>7} {'ticks':>7} {'dropped':>8} {'CPU % core':>11} {'MB/min':>7}")
    for r in (float(x) for x in args.rates.split(",")):
        res = bench_rate(r, args.duration)
        print(f"{res['rate_hz']:6g} {res['duration_s']:7.1f} {res['ticks']:7.0f} {res['dropped']:8.0f} "
              f"{res['cpu_pct']:11.2f} {res['mb_per_min']:7.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
