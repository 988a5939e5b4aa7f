"""The commander's margin check: the GUI server's extra CPU per status, in one run.

At every status whose joints changed (the link's status stream: every 3rd tick, ~33 a second
at 100 Hz, while the arm moves; nothing while it stands still) the commander checks the pose
against the controller's collision world and keeps the bodies within a margin, which every
page's 3D view draws red (``parolkit.gui.collision.CollisionWatch.on_status``).  Measured here
through that very listener (a fake link feeding it typed statuses; no sockets), on the world
of tests/browser/test_collision_view.py plus a pen and a held ball (the table, two boxes, a
cylinder; 44 pairs):

* poses clear of every margin (random joint vectors within the limits, the clear ones: the
  usual case, one kernel check);
* poses within a margin (the wrist in the 60 mm margin of the box beside it, the arm folded
  into its base: every pair's clearance then, to name every body within its margin);
* for reference: the client parsing one status datagram (``RobotStatus.from_json`` of the
  decoded JSON), which the link already does for every status.

Figures are medians of CPU time per status (``time.process_time``, loops of >= 5 ms, 15
rounds), and the share of one core at 33 statuses a second.

Usage: ``python bench/gui_collision.py [--rounds N]``
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
from collections.abc import Callable

import numpy as np

from _measure import machine_line, per_call_s

STATUS_RATE_HZ = 100.0 / 3


def _per_call_us(fn: Callable[[], object], min_s: float = 0.005) -> float:
    return per_call_s(fn, min_s) * 1e6


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    args = ap.parse_args()
    print(machine_line())

    from parolkit.client.core import Queries, RobotStatus, parse_query_reply
    from parolkit.collision import kernel_name
    from parolkit.gui.collision import CollisionWatch
    from parolkit.gui.eventlog import EventLog
    from parolkit.robot import PAROL6

    world = {
        "seq": 0, "ready": True, "units": "mm, deg",
        "zones": [
            {"name": "table", "kind": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "margin": 0},
            {"name": "monitor", "kind": "box", "center": [141, 141, 334], "size": [40, 50, 60], "rpy": [0, 0, 30],
             "margin": 10},
            {"name": "post", "kind": "box", "center": [-120, 200, 330], "size": [60, 60, 200], "rpy": [0, 0, 0],
             "margin": 60},
            {"name": "camera mast", "kind": "cylinder", "center": [-250, -250, 150], "axis": [1, 0, 1],
             "radius": 20, "height": 300, "margin": 5}],
        "tool": {"name": "pen", "shape": {"kind": "capsule", "start": [0, 0, 0], "end": [0, 0, 120], "radius": 8}},
        "held": [{"name": "ball", "kind": "sphere", "center": [0, 0, 170], "radius": 25}],
        "self_margin": 0,
    }
    info = parse_query_reply(Queries.zones, "ZONES|" + json.dumps(world))

    class Robot:
        async def zones(self) -> object:
            return info

    class Link:
        robot = Robot()
        log = EventLog()
        listeners: list[Callable[[RobotStatus], None]] = []

        def add_listener(self, f: Callable[[RobotStatus], None]) -> None:
            self.listeners.append(f)

        def remove_listener(self, f: Callable[[RobotStatus], None]) -> None:
            self.listeners.remove(f)

    base = {"seq": 1, "time": 1.0, "state": "MOVING", "enabled": True, "homed": [True] * 6, "all_homed": True,
            "angles": list(PAROL6.standby_deg), "pose": [0, 262.57, 288.75, -90, 0, -90], "io": {}, "gripper": {},
            "errors": {}, "board": {}, "loop": {}, "command": None, "queue": 0, "tool": "pen", "plan_seq": 0,
            "collision": {"seq": 0, "ready": True, "held": ["ball"], "waiting": None}}

    def status(k: int, angles: list[float]) -> RobotStatus:
        return RobotStatus.from_json({**base, "seq": k, "angles": angles})  # (one time: no restart seen)

    link = Link()
    watch = CollisionWatch(link)  # type: ignore[arg-type]

    async def fetch() -> None:
        watch.on_status(status(0, list(PAROL6.standby_deg)))
        while watch.version < 1:
            await asyncio.sleep(0.001)

    asyncio.run(fetch())
    scene = watch.scene
    assert scene is not None
    lim = np.asarray(PAROL6.safe_limits_deg, dtype=float)
    rng = np.random.default_rng(3)
    clear_poses: list[list[float]] = []
    while len(clear_poses) < 200:
        q = rng.uniform(lim[:, 0], lim[:, 1])
        if scene.check(np.radians(q)).clear:
            clear_poses.append([float(v) for v in q])
    inside = [list(PAROL6.standby_deg), [90.0, -33.0, 115.0, 0.0, -52.0, 180.0]]
    print(f"kernel: {kernel_name()}; {len(scene.pairs)} pairs")
    for what, q in zip(("standby", "folded"), inside):
        watch.on_status(status(1, q))
        assert watch.within, q
        print(f"within a margin {what}: {', '.join(sorted(watch.within))}")
    clear_st = [status(k, q) for k, q in enumerate(clear_poses)]
    inside_st = [status(k, inside[k % 2]) for k in range(200)]
    raw = [{**base, "seq": k, "angles": q} for k, q in enumerate(clear_poses)]

    def feeder(items: list, fn: Callable[[object], object]) -> Callable[[], object]:
        it = iter(())

        def call() -> object:
            nonlocal it
            try:
                x = next(it)
            except StopIteration:
                it = iter(items)
                x = next(it)
            return fn(x)
        return call

    cases: dict[str, Callable[[], object]] = {
        "margin check, clear pose": feeder(clear_st, watch.on_status),
        "margin check, within a margin": feeder(inside_st, watch.on_status),
        "parse one status (reference)": feeder(raw, RobotStatus.from_json),
    }
    samples: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(args.rounds):
        for name, fn in cases.items():
            samples[name].append(_per_call_us(fn))
    med = {k: statistics.median(v) for k, v in samples.items()}
    ref = med["parse one status (reference)"]
    print(f"\n{'':32} {'median us':>10} {'this / parse':>13} {'one core at 33 statuses/s':>27}")
    for name, us in med.items():
        ratio = "" if name.startswith("parse") else f"{us / ref:12.2f}x"
        print(f"{name:32} {us:10.1f} {ratio:>13} {100 * us * 1e-6 * STATUS_RATE_HZ:26.3f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
