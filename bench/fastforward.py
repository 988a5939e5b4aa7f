"""Fast-forward benchmark: how much faster than real time ``parolkit run PROG --sim --fast``
runs each example, and where a tick's time goes.

For every program in examples/ (``Loop()`` programs: ``--loops`` passes) it runs the program
the way ``parolkit run --sim --fast`` does (the interpreter, ``Robot(channel=...)``, the
in-process controller on a lockstep simulated board; the real codec, guard, integrity check
and emulator) and prints:

* ticks/s and the ratio to real time (board seconds / wall seconds), the best and the median
  of ``--repeats`` runs, next to the reference: real time itself (the controller's rate, 1x);
  also the ratio on CPU time (``time.process_time``: what one core gives when the machine is
  busy with other work);
* the per-tick cost split, from one more run of the same program in the same process with
  timers around the parts: core (``ControllerCore.update`` less the guard), guard
  (``SafetyGuard.check`` and ``goal_box``), codec on the PC side (encoding each frame, parsing
  the replies), emulator (the board: decoding the frame, its passes, encoding the reply) and
  the rest (driver, runner, UDP-server code, client, interpreter).  The timers cost time of
  their own: the split is a proportion, the speed figures come from the untimed runs.

    python bench/fastforward.py [--repeats 3] [--loops 2] [PROGRAM.rbt ...]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

from parolkit.client.robot import Robot  # noqa: E402
from parolkit.config import Config, load_config  # noqa: E402
from parolkit.controller.fastforward import InProcessController  # noqa: E402
from parolkit.protocol.frames import CommandFrame  # noqa: E402
from parolkit.script.interpreter import Interpreter  # noqa: E402
from parolkit.script.parser import parse_file  # noqa: E402
from parolkit.script.program import Program  # noqa: E402

PARTS = ("core", "guard", "codec", "emulator")


def _run(program: Program, cfg: Config, loops: int,
         timers: dict[str, float] | None = None) -> tuple[int, float, float, float]:
    """One fast-forwarded run; (ticks, board s, wall s, cpu s) of the program's part (the
    board's homing before the first command not counted)."""
    sim = InProcessController(cfg, paced=False)
    sim.start()
    encode = CommandFrame.encode
    if timers is not None:
        _instrument(sim, timers)
    robot = Robot(channel=sim)
    try:
        interp = Interpreter(program, robot, loops=loops, model=cfg.robot, rate_hz=cfg.controller.rate_hz)
        k0, w0, c0 = sim.ticks, time.perf_counter(), time.process_time()
        result = interp.run()
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        if not result.ok:
            raise SystemExit(f"{program.source_name}: {result.message}")
        ticks = sim.ticks - k0
        return ticks, ticks * sim.period, wall, cpu
    finally:
        CommandFrame.encode = encode  # type: ignore[method-assign]
        robot.close()
        sim.close()


def _timed(fn: Callable[..., Any], timers: dict[str, float], part: str) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            timers[part] += time.perf_counter() - t0
    return wrapper


def _instrument(sim: InProcessController, timers: dict[str, float]) -> None:
    """Timers around the parts of one tick (instance attributes: this run only)."""
    core = sim.controller.core
    guard = core.guard
    driver = sim.driver
    board = sim.transport
    emu = board.emulator  # type: ignore[attr-defined]
    update = core.update

    def core_update(inp: Any) -> Any:
        g0 = timers["guard"]
        t0 = time.perf_counter()
        out = update(inp)
        timers["core"] += time.perf_counter() - t0 - (timers["guard"] - g0)
        return out

    core.update = core_update  # type: ignore[method-assign]
    guard.check = _timed(guard.check, timers, "guard")  # type: ignore[method-assign]
    guard.goal_box = _timed(guard.goal_box, timers, "guard")  # type: ignore[method-assign]
    driver.parser.feed = _timed(driver.parser.feed, timers, "codec")  # type: ignore[method-assign]
    emu.write = _timed(emu.write, timers, "emulator")
    emu.advance = _timed(emu.advance, timers, "emulator")
    emu.read = _timed(emu.read, timers, "emulator")
    encode = CommandFrame.encode

    def timed_encode(frame: CommandFrame) -> bytes:
        t0 = time.perf_counter()
        data = encode(frame)
        timers["codec"] += time.perf_counter() - t0
        return data

    CommandFrame.encode = timed_encode  # type: ignore[method-assign,assignment]  # (_run restores it)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("programs", nargs="*", help="programs (default: every examples/*.rbt)")
    ap.add_argument("--repeats", type=int, default=3, help="untimed runs per program (best and median)")
    ap.add_argument("--loops", type=int, default=2, help="passes of a Loop() program")
    args = ap.parse_args()
    cfg = load_config(None)
    rate = cfg.controller.rate_hz
    paths = [Path(p) for p in args.programs] or sorted((REPO / "examples").glob("*.rbt"))
    print(f"fast-forward vs real time ({rate:g} ticks/s = 1x), {args.repeats} runs each; "
          "best / median; cpu: on process time")
    print(f"{'program':28} {'ticks':>6} {'ticks/s best':>12} {'median':>8} {'x real best':>11} "
          f"{'median':>7} {'x cpu':>6}   per tick (us): " + " ".join(f"{p:>8}" for p in (*PARTS, "rest")))
    totals: dict[str, list[float]] = {"ratio": [], "cpu": []}
    for path in paths:
        result = parse_file(str(path))
        if result.program is None:
            raise SystemExit(f"{path}: {len(result.errors)} error(s)")
        program = result.program
        runs = [_run(program, cfg, args.loops) for _ in range(args.repeats)]
        ticks = runs[0][0]
        if any(r[0] != ticks for r in runs):
            raise SystemExit(f"{path.name}: the runs took different numbers of ticks: {[r[0] for r in runs]}")
        rates = sorted((r[0] / r[2] for r in runs), reverse=True)
        cpu_ratio = max(r[1] / r[3] for r in runs)
        timers = dict.fromkeys(PARTS, 0.0)
        t_ticks, _, t_wall, _ = _run(program, cfg, args.loops, timers)
        per_tick = {p: timers[p] / t_ticks * 1e6 for p in PARTS}
        rest = t_wall / t_ticks * 1e6 - sum(per_tick.values())
        best, median = rates[0], statistics.median(rates)
        totals["ratio"].append(best / rate)
        totals["cpu"].append(cpu_ratio)
        print(f"{path.name:28} {ticks:6d} {best:12.0f} {median:8.0f} {best / rate:10.1f}x {median / rate:6.1f}x "
              f"{cpu_ratio:5.1f}x   {'':15}" + " ".join(f"{per_tick[p]:8.0f}" for p in PARTS) + f" {rest:8.0f}")
    print(f"lowest ratio (best run): {min(totals['ratio']):.1f}x real time wall, {min(totals['cpu']):.1f}x on CPU time "
          f"(target >= 50x)")

if __name__ == "__main__":
    main()
