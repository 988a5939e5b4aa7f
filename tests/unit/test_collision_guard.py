"""The collision guard in the controller (issue 25, part 2b), tick by tick in the lockstep rig
(the real core, driver and emulated board on a virtual clock; plans and scenes made inline).

* Plan admission: a planned move that would bring a pair within its margin is FAILED with
  collision_message's words and nothing of it reaches the board (no GO TO frame after the
  mark); ATTACH / DETACH and SET_TOOL change the verdict of the moves queued after them.
* The per-tick stop: a jog or a servo stream whose controlled stop, begun at the next tick,
  would end within a margin stops now, under control; the final pose keeps at least the
  margin (judged with parolkit.collision.check on the joints the board reports); a jog further
  in is refused before it moves, one away runs; a motion that starts inside a margin may leave.
* Motion that needs the check waits while the scene of a new world is built, and says so.

Judged on the frames the board received, the acks and the board's own positions; never on the
wall clock.
"""

from __future__ import annotations

import json
import math

import numpy as np
from tests.unit.test_controller_core import Rig

from parolkit.collision import TABLE_ZONE, BoxZone, PlaneZone, Scene, ToolShape, held_object
from parolkit.config import Config, ToolSettings
from parolkit.controller.activities import speed_samples
from parolkit.controller.messages import Submission
from parolkit.controller.world import (
    INSIDE_SLACK_MM,
    CollisionWorld,
    joint_stop,
    path_stop,
    scene_for,
)
from parolkit.kinematics import fk
from parolkit.kinematics.tools import get_tool
from parolkit.protocol.commands import AckStatus, parse_datagram
from parolkit.protocol.frames import BoardCommand
from parolkit.robot import PAROL6

STANDBY = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)
#: a box the arm sweeps through when J1 turns from 90 to 0 deg
BOX = BoxZone("box", center=(250, 150, 250), size=(60, 60, 300), margin=10)
#: a wall in front of the arm (the standby TCP is at y = 262.6 mm), its forbidden side y >= 330
WALL = PlaneZone("wall", point=(0, 330, 0), normal=(0, -1, 0), margin=10)
#: a shelf beyond the arm's own reach at its height: only a long tool or held rod sweeps it
#: when J1 turns from 90 to 30 deg (at standby the flange's z axis points along world +y from
#: (0, 199.8, 334) mm: a 250 mm rod on it reaches 450 mm from the J1 axis)
SHELF = BoxZone("shelf", center=(300, 300, 330), size=(60, 60, 60), margin=10)
SWING = (30.0, -90.0, 180.0, 0.0, 0.0, 180.0)
SPD = np.asarray(PAROL6.steps_per_deg, dtype=float)
ACCEL = np.asarray(PAROL6.accel_limit_steps_s2, dtype=float)


def _move(angles, t: float = 3.0) -> str:
    return "MOVEJOINT|" + "|".join(f"{v:g}" for v in angles) + f"|{t:g}|None"


def _run(rig: Rig, cid: str, text: str, max_ticks: int = 3000) -> tuple[AckStatus, str]:
    rig.send(f"{cid}|{text}")
    rig.run_until(lambda: rig.terminal(cid) is not None, max_ticks)
    return next((s, d) for c, s, d in rig.acks if c == cid and s.terminal)


def _pair_clearance(zones, angles_deg, pair: str, tool=None, held=()) -> float:
    """The clearance (mm) of ``pair`` (its words) at ``angles_deg``."""
    sc = Scene(zones=zones, tool=tool, held=held)
    d, _, _ = sc.distances(np.radians(angles_deg))
    return float(d[[str(p) for p in sc.pairs].index(pair)])


def _held(world: CollisionWorld) -> tuple:
    return tuple(held_object(h.name, h.start, h.end, h.radius, h.kind) for h in world.held)


def _gotos_after(rig: Rig, mark: int) -> list:
    return [f for f in rig.frames[mark:] if f.command == BoardCommand.GOTO]


# ------------------------------------------------------------------------ plan admission


def test_a_movejoint_into_a_box_is_failed_naming_the_pair_and_the_time_and_nothing_reaches_the_board():
    rig = Rig(zones=(TABLE_ZONE, BOX))
    try:
        mark = len(rig.frames)
        status, details = _run(rig, "aaaa0001", _move((0, -90, 180, 0, 0, 180), 5))
        assert status is AckStatus.FAILED
        assert details.startswith("would collide: J6 link vs zone 'box' at ")
        assert "s into the move (enters its 10 mm margin; deepest" in details, details
        assert not _gotos_after(rig, mark), "a refused move sent GO TO frames"
        # the robot stands where it was, and the next move runs
        assert np.allclose(rig.angles, STANDBY, atol=0.01)
        assert _run(rig, "aaaa0002", _move((60, -90, 180, 0, 0, 180), 2))[0] is AckStatus.COMPLETED
    finally:
        rig.close()


def test_a_movecart_into_a_box_is_refused_before_anything_moves():
    x, y, z = fk(list(STANDBY))[:3]
    box = BoxZone("crate", center=(x, y, z - 80), size=(80, 80, 30), margin=5)  # under the TCP
    rig = Rig(zones=(TABLE_ZONE, box))
    try:
        pose = fk(list(STANDBY))
        target = (pose[0], pose[1], pose[2] - 130, pose[3], pose[4], pose[5])
        mark = len(rig.frames)
        status, details = _run(rig, "aaaa0001", "MOVECART|" + "|".join(f"{v:.4f}" for v in target) + "|2|None")
        assert status is AckStatus.FAILED and details.startswith("would collide: "), details
        assert "vs zone 'crate' at " in details
        assert not _gotos_after(rig, mark)
    finally:
        rig.close()


#: a clear pose, and from it a J2 swing that folds the wrist into the base (a self pair)
FOLD_START = (119.0, -90.0, 108.0, 3.0, 5.0, 187.0)
FOLD_TARGET = (119.0, -33.0, 108.0, 3.0, 5.0, 187.0)


def test_a_joint_target_that_folds_the_arm_into_itself_is_refused():
    rig = Rig()  # the table only
    try:
        assert _run(rig, "aaaa0001", _move(FOLD_START, 4))[0] is AckStatus.COMPLETED
        mark = len(rig.frames)
        status, details = _run(rig, "aaaa0002", _move(FOLD_TARGET, 3))
        assert status is AckStatus.FAILED
        assert details.startswith("would collide: base vs J6 link at "), details
        assert not _gotos_after(rig, mark)
    finally:
        rig.close()


def test_a_joint_path_into_a_box_is_refused_as_a_ros2_trajectory_arrives():
    """A ROS 2 JointTrajectory reaches the controller as one MOVEJOINTPATH: checked whole."""
    rig = Rig(zones=(TABLE_ZONE, BOX))
    try:
        mark = len(rig.frames)
        text = "MOVEJOINTPATH|2|2|45|-90|180|0|0|180|4|0|-90|180|0|0|180"
        status, details = _run(rig, "aaaa0001", text)
        assert status is AckStatus.FAILED and details.startswith("would collide: J6 link vs zone 'box' at "), details
        assert not _gotos_after(rig, mark)
    finally:
        rig.close()


def test_a_blended_chain_is_checked_as_the_one_trajectory_it_plays():
    """Three MoveJoints blended into one trajectory (r=): the chain is refused as a whole when
    its path enters the box, though its first move alone would be clear, and nothing of it
    reaches the board."""
    rig = Rig(zones=(TABLE_ZONE, BOX))
    try:
        assert _run(rig, "aaaa0000", _move((60, -90, 180, 0, 0, 180), 2))[0] is AckStatus.COMPLETED
        mark = len(rig.frames)
        rig.send("aaaa0001|MOVEJOINT|50|-90|180|0|0|180|None|30|r=5")
        rig.send("aaaa0002|MOVEJOINT|35|-90|180|0|0|180|None|30|r=5")
        rig.send("aaaa0003|MOVEJOINT|20|-90|180|0|0|180|None|30")
        rig.run_until(lambda: all(rig.terminal(c) is not None for c in ("aaaa0001", "aaaa0002", "aaaa0003")))
        ends = {c: d for c, s, d in rig.acks if s.terminal}
        assert rig.terminal("aaaa0001") is AckStatus.FAILED, ends
        assert ends["aaaa0001"].startswith("would collide: ") and "vs zone 'box'" in ends["aaaa0001"]
        # what is left of the chain is planned on its own from where the arm is: each of the
        # other two moves into the box is refused by itself
        assert all(rig.terminal(c) is AckStatus.FAILED and ends[c].startswith("would collide: ")
                   for c in ("aaaa0002", "aaaa0003")), ends
        assert not _gotos_after(rig, mark)
        # the head alone is clear: it runs
        assert _run(rig, "aaaa0004", _move((50, -90, 180, 0, 0, 180), 2))[0] is AckStatus.COMPLETED
    finally:
        rig.close()


def test_attach_and_detach_change_the_verdict_of_the_moves_queued_after_them_in_order():
    """ATTACH, a move, DETACH, the same move: queued together, each takes effect where it
    stands in the queue (the first move is checked with the rod, the second without)."""
    rig = Rig(zones=(TABLE_ZONE, SHELF))
    try:
        target = SWING
        rig.send("aaaa0001|ATTACH|rod|CAPSULE|0,0,0|0,0,250|20")
        rig.send("aaaa0002|" + _move(target, 3))
        rig.send("aaaa0003|DETACH|rod")
        rig.send("aaaa0004|" + _move(target, 3))
        rig.run_until(lambda: rig.terminal("aaaa0004") is not None)
        acks = {c: (s, d) for c, s, d in rig.acks if s.terminal}
        assert acks["aaaa0001"][0] is AckStatus.COMPLETED
        assert acks["aaaa0001"][1].startswith("attached 'rod': capsule, radius 20 mm")
        assert acks["aaaa0002"][0] is AckStatus.FAILED
        assert acks["aaaa0002"][1].startswith("would collide: held 'rod' vs zone 'shelf' at "), acks["aaaa0002"]
        assert acks["aaaa0003"] == (AckStatus.COMPLETED, "detached 'rod'")
        assert acks["aaaa0004"][0] is AckStatus.COMPLETED
        order = [c for c, s, _ in rig.acks if s.terminal]
        assert order == ["aaaa0001", "aaaa0002", "aaaa0003", "aaaa0004"]
        snap = rig.outputs[-1].snapshot
        assert snap.collision.world.held == () and snap.collision.seq == 2
    finally:
        rig.close()


def _set_tool(rig: Rig, cid: str, name: str) -> None:
    """SET_TOOL as the server hands it over: with the tool resolved off the tick."""
    p = parse_datagram(f"{cid}|SET_TOOL|{name}")
    src = ("127.0.0.1", 1)
    rig._record(rig.core.apply(Submission(p.command, p.command_id, (src,), src,
                                          tool=get_tool(name, rig.core.config))))
    assert rig.terminal(cid) is AckStatus.COMPLETED, rig.acks[-1]


def test_the_tool_shape_counts_once_set_tool_selects_it():
    pen = ToolSettings("pen", (0, 0, 250, 0, 0, 0), shape=ToolShape("pen", radius=20, end=(0, 0, 250)))
    rig = Rig(config=Config(tools=(pen,), zones=(TABLE_ZONE, SHELF)))
    try:
        _set_tool(rig, "aaaa0001", "pen")
        status, details = _run(rig, "aaaa0002", _move(SWING, 3))
        assert status is AckStatus.FAILED and details.startswith("would collide: tool 'pen' vs zone 'shelf'"), details
        _set_tool(rig, "aaaa0003", "default")
        assert _run(rig, "aaaa0004", _move(SWING, 3))[0] is AckStatus.COMPLETED
    finally:
        rig.close()


def test_a_move_out_of_a_margin_is_admitted_and_one_further_in_is_refused():
    """After an ATTACH that puts the held object within the wall's margin, a move away from the
    wall runs; one that takes it further in is refused."""
    rig = Rig(zones=(TABLE_ZONE, WALL))
    try:
        # a ball 95 mm along the flange's z (world +y here) reaches to y = 325: within the
        # wall's margin
        rig.send("aaaa0001|ATTACH|ball|SPHERE|-45,0,95|30")
        rig.tick(2)
        world = rig.core.world
        sc = scene_for(world)
        v = sc.check(np.radians(rig.angles))
        assert not v.clear and v.worst.pair.b == "zone 'wall'", v
        further = (90.0, -80.0, 180.0, 0.0, 0.0, 180.0)
        away = (90.0, -100.0, 180.0, 0.0, 0.0, 180.0)
        assert all(fk(list(further))[1] > fk(list(STANDBY))[1] > fk(list(away))[1] for _ in (0,))
        status, details = _run(rig, "aaaa0002", _move(further, 2))
        assert status is AckStatus.FAILED and "held 'ball' vs zone 'wall'" in details, details
        assert _run(rig, "aaaa0003", _move(away, 2))[0] is AckStatus.COMPLETED
    finally:
        rig.close()


# ------------------------------------------------------------------------ the per-tick stop


def _final_clearance(rig: Rig, zones, pair: str) -> float:
    rig.tick(40)  # the board settles on the stop's last target
    return _pair_clearance(zones, rig.angles, pair)


def test_a_cartesian_jog_toward_a_wall_stops_at_least_the_margin_short_and_may_jog_out():
    zones = (TABLE_ZONE, WALL)
    rig = Rig(zones=zones)
    try:
        mark = len(rig.frames)
        status, details = _run(rig, "aaaa0001", "CARTJOG|WRF|Y+|50|5")
        assert status is AckStatus.FAILED
        assert details.startswith("jog stopped: J6 link ") and "from zone 'wall' (margin 10 mm)" in details, details
        gotos = _gotos_after(rig, mark)
        assert len(gotos) > 20, "the jog ran before it stopped"
        # the stop is under control: no joint's feed-forward changes faster than its limit
        for a, b in zip(gotos, gotos[1:]):
            dv = np.abs(np.subtract(b.speeds, a.speeds))
            assert np.all(dv <= ACCEL / 100.0 * 1.1 + 2), (a.speeds, b.speeds)
        d = _final_clearance(rig, zones, "J6 link vs zone 'wall'")
        assert 10.0 <= d < 20.0, d
        # further in: refused before it moves
        mark = len(rig.frames)
        status, details = _run(rig, "aaaa0002", "CARTJOG|WRF|Y+|20|1")
        assert status is AckStatus.FAILED and details.startswith("jog refused: J6 link "), details
        assert all(f.speeds == (0,) * 6 for f in _gotos_after(rig, mark)), "a refused jog moved"
        # out: it runs
        assert _run(rig, "aaaa0003", "CARTJOG|WRF|Y-|50|0.5")[0] is AckStatus.COMPLETED
        assert _final_clearance(rig, zones, "J6 link vs zone 'wall'") > d + 10
    finally:
        rig.close()


def test_a_joint_jog_and_a_held_streamed_jog_stop_short_the_same_way():
    zones = (TABLE_ZONE, WALL)
    rig = Rig(zones=zones)
    try:
        # J2 + swings the arm forward into the wall
        status, details = _run(rig, "aaaa0001", "JOG|1|60|None|60")
        assert status is AckStatus.FAILED and details.startswith("jog stopped: "), details
        assert _final_clearance(rig, zones, "J6 link vs zone 'wall'") >= 10.0
        assert _run(rig, "aaaa0002", "JOG|7|60|None|10")[0] is AckStatus.COMPLETED  # back out
        # a streamed jog, its updates sent every tick as a held button does
        rig.submit("aaaa0003|STREAM|ON")
        for k in range(400):
            rig.send(f"st{k:06d}|JOG|1|60|0.1|None")
            rig.tick()
            if any(d.startswith("jog stopped: ") for c, s, d in rig.acks if c.startswith("st")):
                break
        failed = [d for c, s, d in rig.acks if s is AckStatus.FAILED and c.startswith("st")]
        # one update stopped short; the ones that came while the arm stopped were refused
        assert failed and failed[-1].startswith("jog stopped: "), failed[-3:]
        assert all(d.startswith("jog refused: the arm is stopping short of a collision") for d in failed[:-1])
        assert _final_clearance(rig, zones, "J6 link vs zone 'wall'") >= 10.0
    finally:
        rig.close()


def test_a_servoj_stream_into_a_zone_stops_short_and_its_further_targets_are_refused():
    zones = (TABLE_ZONE, WALL)
    rig = Rig(zones=zones)
    try:
        a0 = np.array(STANDBY)
        first = None
        for i in range(300):
            q = a0 + np.array([0, 60, 0, 0, 0, 0]) * min(1.0, i / 150)
            cid = f"sv{i:06d}"
            first = first or cid
            rig.send(cid + "|SERVOJ|" + "|".join(f"{v:.4f}" for v in q))
            rig.tick()
            if rig.terminal(first) is not None:
                break
        status, details = next((s, d) for c, s, d in rig.acks if c == first and s.terminal)
        assert status is AckStatus.FAILED
        assert details.startswith("servo stream stopped: J6 link "), details
        assert _final_clearance(rig, zones, "J6 link vs zone 'wall'") >= 10.0
        # a new stream further in does not get any closer: it ends at once, refused (or
        # stopped within its first ticks: a stream starts from rest, its first stops are short)
        q = a0 + np.array([0, 60, 0, 0, 0, 0])
        status, details = _run(rig, "sv999999", "SERVOJ|" + "|".join(f"{v:.4f}" for v in q))
        assert status is AckStatus.FAILED and details.startswith(("servo stream refused: ", "servo stream stopped: "))
        assert _final_clearance(rig, zones, "J6 link vs zone 'wall'") >= 10.0
    finally:
        rig.close()


def test_a_jog_that_starts_inside_a_margin_may_leave_but_not_go_further_in():
    zones = (TABLE_ZONE, WALL)
    rig = Rig(zones=zones)
    try:
        rig.send("aaaa0001|ATTACH|ball|SPHERE|-45,0,95|30")
        rig.tick(2)
        status, details = _run(rig, "aaaa0002", "CARTJOG|WRF|Y+|20|1")
        assert status is AckStatus.FAILED and details.startswith("jog refused: held 'ball' "), details
        assert _run(rig, "aaaa0003", "CARTJOG|WRF|Y-|20|0.5")[0] is AckStatus.COMPLETED
        world = rig.core.world
        zones = world.zones
        out = _pair_clearance(zones, rig.angles, "held 'ball' vs zone 'wall'", held=_held(world))
        # sideways along the wall, inside its margin: it runs, no closer than it was
        assert _run(rig, "aaaa0004", "CARTJOG|WRF|X+|20|0.5")[0] is AckStatus.COMPLETED
        rig.tick(30)
        assert _pair_clearance(zones, rig.angles, "held 'ball' vs zone 'wall'", held=_held(world)) >= \
            out - INSIDE_SLACK_MM - 0.5
    finally:
        rig.close()


def test_a_jog_waits_while_the_scene_of_a_new_world_is_built_and_the_status_says_so():
    rig = Rig(zones=(TABLE_ZONE, WALL))
    held: list = []
    real = rig.loop._build_scenes
    rig.loop._build_scenes = lambda reqs: held.extend(reqs)  # the planner pool is busy
    try:
        rig.send("aaaa0001|ATTACH|cup|SPHERE|0,0,150|20")
        rig.send("aaaa0002|JOG|0|30|0.5|None")
        mark = len(rig.frames)
        rig.tick(20)
        assert held, "no scene was asked for the new world"
        assert rig.statuses("aaaa0002")[-1] is AckStatus.EXECUTING
        assert not any(any(f.speeds) for f in rig.frames[mark:]), "the jog moved before its check was ready"
        status = json.loads(rig.outputs[-1].snapshot.reply_status_json().split("|", 1)[1])["collision"]
        assert status["ready"] is False and status["held"] == ["cup"]
        assert "JOG waits for the collision check" in status["waiting"]
        rig.loop._build_scenes = real
        real(tuple(held))
        rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
        assert rig.terminal("aaaa0002") is AckStatus.COMPLETED
        assert rig.outputs[-1].snapshot.collision.ready
    finally:
        rig.close()


# ------------------------------------------------------------------------ GET_ZONES


def test_get_zones_answers_the_world_in_force_as_docs_protocol_md_shows():
    pen = ToolSettings("pen", (0, 0, 120, 0, 0, 0), shape=ToolShape("pen", radius=8, end=(0, 0, 120)))
    rig = Rig(config=Config(tools=(pen,), zones=(TABLE_ZONE, BOX)))
    try:
        _set_tool(rig, "aaaa0001", "pen")
        rig.send("aaaa0002|ATTACH|ball|SPHERE|0,0,170|25")
        rig.send("aaaa0003|ATTACH|rod|CAPSULE|0,30,10|0,30,170|8")
        rig.tick(3)
        text = rig.outputs[-1].snapshot.reply_zones()
        head, _, body = text.partition("|")
        assert head == "ZONES"
        z = json.loads(body)
        assert z["seq"] == 3 and z["ready"] is True and z["units"] == "mm, deg" and z["self_margin"] == 0
        assert z["zones"] == [
            {"name": "table", "kind": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "margin": 0},
            {"name": "box", "kind": "box", "center": [250, 150, 250], "size": [60, 60, 300], "rpy": [0, 0, 0],
             "margin": 10}]
        assert z["tool"] == {"name": "pen", "shape": {"kind": "capsule", "start": [0, 0, 0], "end": [0, 0, 120],
                                                       "radius": 8}}
        assert z["held"] == [{"name": "ball", "kind": "sphere", "center": [0, 0, 170], "radius": 25},
                             {"name": "rod", "kind": "capsule", "start": [0, 30, 10], "end": [0, 30, 170],
                              "radius": 8}]
    finally:
        rig.close()


def test_attach_refuses_a_seventeenth_object_and_detach_all_says_what_it_let_go():
    rig = Rig(queue_size=64)
    try:
        for i in range(17):
            rig.send(f"at{i:06d}|ATTACH|o{i}|SPHERE|0,0,{100 + i}|5")
        rig.send("aaaa0001|DETACH")
        rig.send("aaaa0002|DETACH")
        rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
        acks = {c: (s, d) for c, s, d in rig.acks if s.terminal}
        assert all(acks[f"at{i:06d}"][0] is AckStatus.COMPLETED for i in range(16))
        assert acks["at000016"][0] is AckStatus.FAILED
        assert acks["at000016"][1].startswith("ATTACH: at most 16 objects may be held ('o0', 'o1', ")
        assert acks["aaaa0001"][1].startswith("detached 16 objects: 'o0', ")
        assert acks["aaaa0002"] == (AckStatus.COMPLETED, "nothing was held")
    finally:
        rig.close()


# ------------------------------------------------------------------------ the stop's model


def test_a_path_stop_is_the_ramp_of_stop_and_pause_tick_by_tick():
    """The closed form of :func:`path_stop` is the tick-by-tick ramp: the path speed drops by
    the same step every tick, each tick moves that many samples on, never past the end."""
    pos, spd, _ = speed_samples([0] * 6, [0, -3000, 2000, 0, 1000, 0], 0.3, 100.0)
    for s, k in [(5.0, 1.0), (20.0, 1.0), (27.0, 0.6), (28.5, 1.0), (29.0, 1.0), (0.0, 0.0), (10.5, 0.37)]:
        stop = path_stop(pos, spd, s, k, tuple(ACCEL), 100.0)
        per_tick = 0.9 * min(ACCEL[j] / abs(v) for j, v in enumerate(spd[0]) if v) / 100.0
        want, kk, x = [], k, s
        while kk > 0 and x < 29.0:
            kk = max(0.0, kk - per_tick)
            x = min(29.0, x + kk)
            want.append(x)
        coords = [stop._coord(i) for i in range(stop.ticks)] if want else []
        assert np.allclose(coords, want), (s, k)
        p, v, _ = stop.samples()
        assert v[-1] == [0] * 6 and len(p) == stop.ticks


def test_a_joint_stop_slows_every_joint_at_its_limit_to_rest():
    v0 = [1000.0, -4000.0, 3000.0, 20000.0, 0.0, -500.0]
    stop = joint_stop([0.0] * 6, v0, tuple(ACCEL), 100.0)
    p, v, _ = stop.samples()
    speeds = np.array([v0] + [stop.speed(i) for i in range(stop.ticks)])
    assert np.all(np.abs(np.diff(speeds, axis=0)) <= ACCEL / 100.0 + 1e-6)
    assert np.all(np.sign(speeds[:-1]) * np.sign(v0) >= 0), "a joint turned back"
    rest = np.array(stop.position(stop.ticks - 1))
    assert np.allclose(rest, np.sign(v0) * np.square(v0) / (2 * ACCEL), atol=1e-6)
    assert v[-1] == [0] * 6


def test_the_tick_check_costs_a_few_kernel_calls():
    """The check sweeps only a handful of poses: the origin, the goal and the stop's."""
    sc = scene_for(CollisionWorld((TABLE_ZONE, WALL)))
    pos, spd, _ = speed_samples([d * s for d, s in zip(STANDBY, SPD)], [0, 3000, 0, 0, 0, 0], 2.0, 100.0)
    stop = path_stop(pos, spd, 50.0, 1.0, tuple(ACCEL), 100.0, straight=True)
    assert len(stop.poses()) == 1
    cart = path_stop(pos, spd, 50.0, 1.0, tuple(ACCEL), 100.0)
    assert len(cart.poses()) <= 5 and cart.poses()[-1] == cart.position(cart.ticks - 1)
    assert sc.path_raw([x * math.pi / 180 / s for p in pos[:3] for x, s in zip(p, SPD)])[0] == 0


# ------------------------------------------------------------------------ from a program


def test_a_program_whose_third_line_collides_fails_at_that_line_naming_the_pair():
    """The controller refuses the move (its config's box; the interpreter's own check before
    the run is off here, so the controller's refusal is what is judged) and the interpreter's
    error names the program's line 3 and the pair."""
    from parolkit.client.robot import Robot
    from parolkit.config import load_config
    from parolkit.controller.fastforward import InProcessController
    from parolkit.script import Interpreter, parse

    zone = {"name": "box", "kind": "box", "center": [250, 150, 250], "size": [60, 60, 300], "margin": 10}
    cfg = load_config(None, {"zones": [zone]}, search_default_paths=False)
    sim = InProcessController(cfg, paced=False)
    sim.start()
    try:
        robot = Robot(channel=sim)
        text = ("Begin()\n"
                "MoveJoint(60, -90, 180, 0, 0, 180, t=3)\n"
                "MoveJoint(0, -90, 180, 0, 0, 180, t=4)\n"
                "MoveJoint(90, -90, 180, 0, 0, 180, t=4)\n"
                "End()\n")
        result = Interpreter(parse(text).program, robot, check=False).run()
        assert not result.ok and result.commands_executed == 2, result
        err = result.errors[0]
        assert err.line == 3, err
        assert "would collide: J6 link vs zone 'box' at " in err.message, err.message
        robot.close()
    finally:
        sim.close()
