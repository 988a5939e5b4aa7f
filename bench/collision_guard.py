"""What the controller's per-tick collision check costs, against one pose's check and the tick it
runs in, in one run.

Every tick a jog (JOG, MULTIJOG, SPEEDJOINT, CARTJOG) or a servo stream runs, before its frame
goes out, the core checks where a controlled stop begun at the next tick would come to rest
(``parolkit.controller.world``: the stop built from its parameters, a handful of poses swept by
the C kernel).  Measured here, in the scene of the table, a wall, a box and a cylinder:

* the check alone (``path_stop`` / ``joint_stop`` + ``stop_check``) for a joint jog (a straight
  joint line: its rest is enough), a Cartesian jog (5 poses along its stop), a servo stream
  (5 poses of the joints' own stops) and a jog that starts inside a margin (the pairs there
  checked against where they are: a distance pass and a relaxed scene, kept);
* for reference: one pose's ``Scene.check`` (the issue's 10 us target is for that);
* the whole tick (``ControllerCore.update``) in the lockstep rig (the real core, driver and
  emulated board): a Cartesian jog toward the wall (checked every tick) against a planned
  MoveJoint of the same length (checked once, by the planner, off the tick), p50 / p99.

Figures: medians of CPU time per call (``time.process_time``, loops of >= 2 ms) for the
checks; wall time per update (``time.perf_counter``) for the ticks.  Benchmarks print, they
never fail on timing.

Usage: ``python bench/collision_guard.py [--rounds N]``
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable

from _measure import machine_line, per_call_s


def _per_call_us(fn: Callable[[], object], min_s: float = 0.002) -> float:
    return per_call_s(fn, min_s) * 1e6


def _median(fn: Callable[[], object], rounds: int) -> float:
    return statistics.median(_per_call_us(fn) for _ in range(rounds))


def _ticks(zones: tuple[object, ...], text: str, rate: float = 100.0) -> list[float]:
    """Wall time (us) of every update while ``text`` runs, in a fresh lockstep rig."""
    from parolkit.board import BoardEmulator
    from parolkit.controller import core as core_mod
    from parolkit.controller.core import ControllerCore
    from parolkit.controller.driver import Driver
    from parolkit.controller.messages import Submission
    from parolkit.protocol.commands import parse_datagram
    from parolkit.robot import PAROL6
    from parolkit.transport.emulated import EmulatorTransport

    emu = BoardEmulator(clock="virtual", start_homed=True)
    tr = EmulatorTransport(emulator=emu)
    tr.open()
    core = ControllerCore(model=PAROL6, rate_hz=rate, zones=zones)
    loop = Driver(core, tr, reply_wait_fraction=0.0, plan_inline=True)
    times: list[float] = []
    update = core.update

    def timed_update(inp: core_mod.TickInput) -> core_mod.TickOutput:
        t = time.perf_counter()
        out = update(inp)
        times.append((time.perf_counter() - t) * 1e6)
        return out

    core.update = timed_update  # type: ignore[method-assign]
    now = 0.0
    for _ in range(30):  # the probe, the first truth, the scene
        loop.tick(now)
        loop.tick_count += 1
        now += 1.0 / rate
        emu.advance(1.0 / rate)
    p = parse_datagram(text)
    loop.inbox.put(Submission(p.command, p.command_id, (("127.0.0.1", 1),), ("127.0.0.1", 1)))
    times.clear()
    for _ in range(400):
        out = loop.tick(now)
        loop.tick_count += 1
        now += 1.0 / rate
        emu.advance(1.0 / rate)
        if any(a.status.terminal for a in out.acks):
            break
    tr.close()
    return times[2:]  # (the tick that takes the command in plans it inline: not a tick's work)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    args = ap.parse_args()
    print(machine_line())

    from parolkit.collision import TABLE_ZONE, BoxZone, CylinderZone, PlaneZone, kernel_name
    from parolkit.controller.activities import speed_samples
    from parolkit.controller.world import CollisionWorld, joint_stop, path_stop, scene_for, stop_check
    from parolkit.robot import PAROL6, goto_goal

    wall = PlaneZone("wall", point=(0, 330, 0), normal=(0, -1, 0), margin=10)
    zones = (TABLE_ZONE, wall, BoxZone("monitor", center=(300, -250, 200), size=(400, 60, 300), margin=10),
             CylinderZone("post", center=(-200, 200, 150), axis=(0, 0, 1), radius=20, height=300, margin=5))
    scene = scene_for(CollisionWorld(zones))
    print(f"kernel: {kernel_name()}; scene: {len(scene.pairs)} pairs")
    spd = PAROL6.steps_per_deg
    acc = tuple(float(a) for a in PAROL6.accel_limit_steps_s2)
    rad = tuple(math.pi / 180.0 / s for s in spd)
    start = [d * s for d, s in zip(PAROL6.standby_deg, spd)]
    pos, sp, _ = speed_samples(start, [0, 3000, -2000, 0, 1500, 0], 2.0, 100.0)
    i = 40
    goal = goto_goal(pos[i], sp[i])
    floors: dict[int, float] = {}

    def joint_jog() -> object:
        return stop_check(scene, pos[i - 1], goal, path_stop(pos, sp, float(i), 1.0, acc, 100.0, straight=True),
                          rad, floors)

    def cart_jog() -> object:
        return stop_check(scene, pos[i - 1], goal, path_stop(pos, sp, float(i), 1.0, acc, 100.0), rad, floors)

    def servo() -> object:
        return stop_check(scene, pos[i - 1], goal, joint_stop(pos[i], sp[i], acc, 100.0), rad, floors)

    # inside a margin: a held-like wall close enough that the J6 link starts within it
    near = scene_for(CollisionWorld((TABLE_ZONE, PlaneZone("near", point=(0, 245, 0), normal=(0, -1, 0),
                                                           margin=10))))
    back, back_sp, _ = speed_samples(start, [0, -3000, 0, 0, 0, 0], 2.0, 100.0)  # J2 back: away from it
    inside_floors: dict[int, float] = {}

    def inside() -> object:
        return stop_check(near, back[i - 1], goto_goal(back[i], back_sp[i]),
                          path_stop(back, back_sp, float(i), 1.0, acc, 100.0, straight=True), rad, inside_floors)

    q = [d * math.pi / 180 for d in PAROL6.standby_deg]
    rows = [("one pose, Scene.check (reference)", _median(lambda: scene.check(q), args.rounds)),
            ("joint jog: stop + check (rest only)", _median(joint_jog, args.rounds)),
            ("Cartesian jog: stop + check (5 poses)", _median(cart_jog, args.rounds)),
            ("servo stream: stop + check (5 poses)", _median(servo, args.rounds)),
            ("jog starting inside a margin", _median(inside, args.rounds))]
    ref = rows[0][1]
    print("\nthe per-tick check (median CPU time per call):")
    for name, us in rows:
        print(f"  {name:42s} {us:7.1f} us   {us / ref:4.1f}x one pose")

    jog = _ticks(zones, "aaaa0001|CARTJOG|WRF|Y+|50|5")
    move = _ticks(zones, "aaaa0002|MOVEJOINT|90|-70|180|0|0|180|3|None")

    def pct(xs: list[float], p: float) -> float:
        s = sorted(xs)
        return s[min(len(s) - 1, int(round(p * (len(s) - 1))))]

    print("\nthe whole tick (ControllerCore.update, wall time, lockstep rig):")
    for name, xs in (("Cartesian jog, checked every tick", jog), ("planned MoveJoint (checked by the planner)", move)):
        print(f"  {name:42s} p50 {statistics.median(xs):7.1f} us   p99 {pct(xs, 0.99):7.1f} us   ({len(xs)} ticks)")
    print(f"  ratio jog / move (p50): {statistics.median(jog) / statistics.median(move):.2f}; "
          f"the check's share of a jog tick: {rows[2][1] / statistics.median(jog) * 100:.0f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
