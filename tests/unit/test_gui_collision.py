"""The commander's view of the collision world, without a browser (issue 25, part 3): the
world read from the controller's GET_ZONES as the check takes it, the primitives the 3D view
draws for it, which drawn solid stands for which collision body, the bodies within a margin
at a pose, the path preview's red samples, and the watch that follows the controller's world
(a fake link: statuses in, GET_ZONES answers out)."""

from __future__ import annotations

import asyncio
import json
import math

import numpy as np
import pytest

from parolkit.client.core import Queries, RobotStatus, ZonesInfo, parse_query_reply
from parolkit.client.errors import ReplyError
from parolkit.collision import TABLE_ZONE, BoxZone, CollisionModel, CylinderZone, Scene, ToolShape, held_object
from parolkit.collision.model import held_body
from parolkit.config import load_config
from parolkit.errors import ParolkitValueError
from parolkit.gui import geometry
from parolkit.gui.collision import DEFAULT_WORLD, CollisionWatch, _colliding_samples, bodies_within_margin, path_preview
from parolkit.gui.eventlog import EventLog
from parolkit.gui.zone_shapes import MM, held_shapes, tool_shapes, zone_shapes
from parolkit.kinematics import fk_frames
from parolkit.script import dry_run, parse
from parolkit.script.interpreter import collision_setup

STANDBY = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)
#: a box the J1 swing of the standby arm passes through; one whose 60 mm margin the standby wrist is in
MONITOR = BoxZone("monitor", center=(141.0, 141.0, 334.0), size=(40.0, 50.0, 60.0), rpy=(0.0, 0.0, 30.0), margin=10.0)
POST = BoxZone("post", center=(-120.0, 200.0, 330.0), size=(60.0, 60.0, 200.0), margin=60.0)
MAST = CylinderZone("camera mast", center=(-250.0, -250.0, 150.0), axis=(1.0, 0.0, 1.0), radius=20.0, height=300.0,
                    margin=5.0)
ZONES_JSON = {
    "seq": 3, "ready": True, "units": "mm, deg",
    "zones": [
        {"name": "table", "kind": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "margin": 0},
        {"name": "monitor", "kind": "box", "center": [141, 141, 334], "size": [40, 50, 60], "rpy": [0, 0, 30],
         "margin": 10},
        {"name": "post", "kind": "box", "center": [-120, 200, 330], "size": [60, 60, 200], "rpy": [0, 0, 0],
         "margin": 60},
        {"name": "camera mast", "kind": "cylinder", "center": [-250, -250, 150], "axis": [1, 0, 1], "radius": 20,
         "height": 300, "margin": 5}],
    "tool": {"name": "pen", "shape": {"kind": "capsule", "start": [0, 0, 0], "end": [0, 0, 120], "radius": 8}},
    "held": [{"name": "ball", "kind": "sphere", "center": [0, 0, 170], "radius": 25},
             {"name": "rod", "kind": "capsule", "start": [0, 30, 10], "end": [0, 30, 170], "radius": 8}],
    "self_margin": 0,
}


def _zones_info(d: dict | None = None) -> ZonesInfo:
    return parse_query_reply(Queries.zones, "ZONES|" + json.dumps(d or ZONES_JSON))


def _close(a, b, tol=1e-9) -> bool:
    return all(abs(x - y) <= tol for x, y in zip(a, b, strict=True))


# ---- the world as the check takes it ---------------------------------------------------------


@pytest.mark.parametrize("start, end", [((0, 30, 10), (0, 30, 170)), ((10, -20, 5), (-40, 60, 90)),
                                        ((0, 0, 0), (100, 0, 0)), ((0, 0, 0), (-100, 0, 0)),
                                        ((5, 5, 5), (5, -95, 5)), ((1, 2, 3), (1, 2, 3))])
def test_held_object_puts_a_capsule_between_the_two_points_it_is_given(start, end):
    """parolkit.collision.held_object (added for the GUI and the interpreter): a held object as
    ATTACH and GET_ZONES give it, two points and a radius, placed so that the model's body runs
    between exactly those points."""
    body = held_body(held_object("rod", start, end, 8.0))
    assert body.name == "held 'rod'" and body.radius == 8.0 and body.frame == 6
    assert _close(body.start, start, 1e-9) and _close(body.end, end, 1e-9)


def test_held_object_puts_a_sphere_at_its_centre_and_refuses_other_kinds():
    body = held_body(held_object("ball", (0, 0, 170), (0, 0, 170), 25.0, "sphere"))
    assert body.start == body.end == (0.0, 0.0, 170.0) and body.radius == 25.0
    with pytest.raises(ParolkitValueError, match="kind must be"):
        held_object("box", (0, 0, 0), (0, 0, 1), 5.0, "box")


def test_the_controllers_world_becomes_the_zones_tool_and_held_objects_the_config_would_make():
    setup = collision_setup(_zones_info())
    cfg = load_config(None, {"zones": [{"name": "monitor", "kind": "box", "center": [141, 141, 334],
                                        "size": [40, 50, 60], "rpy": [0, 0, 30], "margin": 10},
                                       {"name": "post", "kind": "box", "center": [-120, 200, 330],
                                        "size": [60, 60, 200], "margin": 60},
                                       {"name": "camera mast", "kind": "cylinder", "center": [-250, -250, 150],
                                        "axis": [1, 0, 1], "radius": 20, "height": 300, "margin": 5}]},
                      search_default_paths=False)
    assert setup.zones == tuple(cfg.zones) == (TABLE_ZONE, MONITOR, POST, MAST)
    assert setup.tool_shape == ToolShape("pen", 8.0, (0.0, 0.0, 0.0), (0.0, 0.0, 120.0))
    assert [h.name for h in setup.held] == ["ball", "rod"]
    rod = held_body(setup.held[1])
    assert _close(rod.start, (0, 30, 10), 1e-9) and _close(rod.end, (0, 30, 170), 1e-9)
    # the check takes it as it is (a scene of every body and zone)
    scene = Scene(zones=setup.zones, tool=setup.tool_shape, held=setup.held)
    assert {b.name for b in scene.bodies} >= {"tool 'pen'", "held 'ball'", "held 'rod'"}


def test_a_zone_out_of_range_is_refused_naming_it():
    bad = json.loads(json.dumps(ZONES_JSON))
    bad["zones"][1]["margin"] = 5000
    with pytest.raises(ParolkitValueError, match="monitor.*margin"):
        collision_setup(_zones_info(bad))


# ---- what the 3D view draws ----------------------------------------------------------------


def test_a_box_zone_is_drawn_at_its_centre_with_its_size_turn_margin_and_name():
    info = _zones_info()
    shapes = zone_shapes(info.zones[1])
    body = next(s for s in shapes if s.part == "body")
    margin = next(s for s in shapes if s.part == "margin")
    label = next(s for s in shapes if s.part == "label")
    assert body.owner == margin.owner == "zone 'monitor'" and body.kind == "box" and body.opacity < 1.0
    assert _close(body.position, (1.41, 1.41, 3.34)) and _close(body.args, (0.40, 0.50, 0.60))
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    assert _close([r[0] for r in body.rotation], (c, s, 0.0)) and _close([r[1] for r in body.rotation], (-s, c, 0.0))
    assert margin.wireframe and margin.position == body.position and margin.rotation == body.rotation
    assert _close(margin.args, (0.60, 0.70, 0.80))
    assert label.kind == "text" and label.args[0] == "monitor" and label.position[2] > body.position[2]


def test_a_cylinder_zone_is_drawn_along_its_axis():
    shapes = zone_shapes(_zones_info().zones[3])
    body = next(s for s in shapes if s.part == "body")
    r2 = math.sqrt(0.5)
    # three.js's cylinder runs along its own y: the rotation's second column is the axis
    assert _close([r[1] for r in body.rotation], (r2, 0.0, r2)) and _close(body.position, (-2.5, -2.5, 1.5))
    assert _close(body.args, (0.2, 3.0))
    assert _close(next(s for s in shapes if s.part == "margin").args, (0.25, 3.1))


def test_a_plane_is_a_large_square_with_its_forbidden_side_and_normal_shown():
    table = zone_shapes(_zones_info().zones[0])
    parts = {s.part: s for s in table}
    assert set(parts) == {"body", "forbidden", "normal", "label"}  # margin 0: no outline
    quad, slab, normal = parts["body"], parts["forbidden"], parts["normal"]
    assert _close(quad.position, (0.0, 0.0, 0.0)) and quad.args[0] >= 10.0 and quad.args[2] < 0.01
    assert _close([r[2] for r in quad.rotation], (0.0, 0.0, 1.0))
    assert slab.position[2] < 0.0  # below the table: the forbidden side
    assert normal.kind == "line" and normal.args[1][2] > 0.0  # out of the forbidden side
    # a wall beside the arm: drawn where it is nearest the middle of the arm's reach, its
    # forbidden side behind it, its margin in front
    wall = zone_shapes(_zones_info({**ZONES_JSON, "zones": [
        {"name": "wall", "kind": "plane", "point": [0, -300, 0], "normal": [0, 1, 0], "margin": 15}]}).zones[0])
    parts = {s.part: s for s in wall}
    assert _close(parts["body"].position, (0.0, -3.0, 2.5))
    assert parts["forbidden"].position[1] < -3.0 < parts["margin"].position[1]
    assert parts["margin"].position[1] == pytest.approx(-3.0 + 15 * MM)


def test_the_tool_shape_and_held_objects_are_capsules_and_spheres_in_the_flange_frame():
    info = _zones_info()
    tool = tool_shapes(info.tool, info.tool_shape)
    assert {s.owner for s in tool} == {"tool 'pen'"} and [s.kind for s in tool] == ["sphere", "cylinder", "sphere"]
    cyl = tool[1]
    assert _close(cyl.position, (0.0, 0.0, 0.6)) and _close(cyl.args, (0.08, 1.2))
    assert _close([r[1] for r in cyl.rotation], (0.0, 0.0, 1.0))
    held = held_shapes(info.held)
    ball = [s for s in held if s.owner == "held 'ball'"]
    assert len(ball) == 1 and ball[0].kind == "sphere" and _close(ball[0].position, (0.0, 0.0, 1.7))
    assert tool_shapes("default", None) == []


def test_every_link_of_the_collision_model_is_drawn_and_each_solid_names_the_body_it_stands_for():
    """The live arm is coloured by the collision check's body names: every drawn solid names
    one (the model's links, the base, the tool), and lies on that body: its centre within 10 mm
    of the body's capsule at any pose (the J1 housing, on the table, is 5 mm below the J1
    link's capsule, which starts on top of the base).  A solid named after a body away from
    its joint fails this; one at a joint belongs to either link there (their capsules meet)."""
    solids = geometry.arm_solids()
    model = CollisionModel()
    links = {b.name: b for b in model.bodies if b.role.value == "link"}
    assert {s.body for s in solids} == {"base", "tool", *links}
    rng = np.random.default_rng(25)
    lim = np.array([[-120, 120], [-150, -30], [120, 250], [-180, 180], [-120, 120], [-180, 180]], dtype=float)
    for q in rng.uniform(lim[:, 0], lim[:, 1], size=(30, 6)):
        draw = geometry.dh_frames(list(q))
        fk = fk_frames(q, tool="flange")
        for s in solids:
            if s.body not in links:
                continue
            t = np.array(draw[s.frame])
            c = (t @ np.array([*s.center, 1.0]))[:3] * 1000.0
            b = links[s.body]
            p = (fk[b.frame] @ np.array([*(v / 1000 for v in b.start), 1.0]))[:3] * 1000.0
            e = (fk[b.frame] @ np.array([*(v / 1000 for v in b.end), 1.0]))[:3] * 1000.0
            u = np.clip(np.dot(c - p, e - p) / max(np.dot(e - p, e - p), 1e-12), 0.0, 1.0)
            assert np.linalg.norm(c - (p + u * (e - p))) <= b.radius + 10.0, (s, q)


# ---- the bodies within a margin --------------------------------------------------------------


def test_the_bodies_within_a_margin_are_the_pairs_within_theirs_and_none_when_clear():
    scene = Scene(zones=(TABLE_ZONE, MONITOR, POST))
    assert bodies_within_margin(scene, np.radians(STANDBY)) == {"J5 link", "zone 'post'"}
    assert bodies_within_margin(scene, np.radians([80, -90, 180, 0, 0, 180])) == frozenset()
    inside = bodies_within_margin(scene, np.radians([45, -90, 180, 0, 0, 180]))
    assert {"J4 link", "J5 link", "J6 link", "zone 'monitor'"} <= inside
    # the wrist folded into the arm's own base: a self pair
    assert "base" in bodies_within_margin(scene, np.radians([90, -33, 115, 0, -52, 180]))


# ---- the path preview ------------------------------------------------------------------------

PROGRAM = ("Begin()\nMoveJoint(80, -80, 170, 0, 10, 180, t=1.5)\nOutput(1, HIGH)\n"
           "MoveJoint(0, -90, 180, 0, 0, 180, t=4)\nEnd()\n")


def test_the_preview_marks_red_the_samples_of_the_line_that_collides():
    zones = (TABLE_ZONE, MONITOR, POST)
    report = dry_run(parse(PROGRAM).program, (80, -90, 180, 0, 0, 180), zones=zones)
    assert [e.line for e in report.errors] == [4]
    preview = path_preview(report, zones, max_points=300)
    assert [s.line for s in preview.segments] == [2, 4]
    assert [s.collides for s in preview.segments] == [False, True]
    line2, line4 = preview.segments
    assert not any(line2.red)
    # the stretch through the box is red, the start and the end of the swing are not
    assert any(line4.red) and not line4.red[0] and not line4.red[-1]
    assert preview.points <= 300 + len(preview.segments)
    # thinned, every red sample is still shown: the red stretch drawn covers the samples'
    traj = report.segments[1][1]
    scene = Scene(zones=zones)
    every = _colliding_samples(scene, traj.positions_deg(), traj.rate_hz)
    full = path_preview(report, zones, max_points=10_000).segments[1]
    assert list(full.red) == every and len(full.rows_deg) == len(traj)
    first_red = next(k for k, r in enumerate(every) if r)
    step = len(traj) // (len(line4.rows_deg) - 1)
    assert line4.red[first_red // step] or line4.red[min(len(line4.red) - 1, first_red // step + 1)]


def test_a_collision_only_between_two_samples_still_shows_a_red_point():
    """Two samples either side of the box (the sweep finds it between them): the sample after it red."""
    scene = Scene(zones=(TABLE_ZONE, MONITOR))
    red = _colliding_samples(scene, [[80, -90, 180, 0, 0, 180], [10, -90, 180, 0, 0, 180]], 1.0)
    assert red == [False, True]


def test_a_program_checked_against_the_default_table_draws_its_path_without_red():
    report = dry_run(parse(PROGRAM).program, (80, -90, 180, 0, 0, 180))
    assert report.ok
    preview = path_preview(report)
    assert [s.line for s in preview.segments] == [2, 4] and not any(any(s.red) for s in preview.segments)


# ---- following the controller ----------------------------------------------------------------

STATUS = {
    "seq": 1, "time": 5.0, "state": "IDLE", "enabled": True, "homed": [True] * 6, "all_homed": True,
    "angles": list(STANDBY), "pose": [0, 262.57, 288.75, -90, 0, -90], "io": {}, "gripper": {}, "errors": {},
    "board": {}, "loop": {}, "command": None, "queue": 0, "tool": "pen", "plan_seq": 0,
}


def _status(seq: int, *, collision: int | None = 0, angles=STANDBY, time_s: float = 5.0, tool: str = "pen"):
    d = {**STATUS, "seq": seq, "time": time_s, "angles": list(angles), "tool": tool}
    if collision is not None:
        d["collision"] = {"seq": collision, "ready": True, "held": [], "waiting": None}
    return RobotStatus.from_json(d)


class _FakeRobot:
    def __init__(self) -> None:
        self.answers: list[object] = []
        self.asked = 0

    async def zones(self) -> ZonesInfo:
        self.asked += 1
        a = self.answers.pop(0) if len(self.answers) > 1 else self.answers[0]
        if isinstance(a, Exception):
            raise a
        assert isinstance(a, ZonesInfo)
        return a


class _FakeLink:
    def __init__(self) -> None:
        self.robot = _FakeRobot()
        self.log = EventLog()
        self.listeners: list = []

    def add_listener(self, f) -> None:
        self.listeners.append(f)

    def remove_listener(self, f) -> None:
        self.listeners.remove(f)

    def feed(self, st: RobotStatus) -> None:
        for f in self.listeners:
            f(st)


def _world(seq: int, *, held: list | None = None, zones: list | None = None) -> ZonesInfo:
    d = {**ZONES_JSON, "seq": seq, "held": held or [], "tool": {"name": "pen", "shape": None}}
    if zones is not None:
        d["zones"] = zones
    return _zones_info(d)


async def _settle(watch: CollisionWatch, version: int, timeout: float = 10.0) -> None:
    deadline = asyncio.get_running_loop().time() + timeout
    while watch.version < version:
        assert asyncio.get_running_loop().time() < deadline, f"version {watch.version}, waiting for {version}"
        await asyncio.sleep(0.01)


def test_the_watch_fetches_the_world_when_the_controller_says_it_changed_and_checks_each_new_pose():
    async def run() -> None:
        link = _FakeLink()
        watch = CollisionWatch(link)  # type: ignore[arg-type]
        link.robot.answers = [_world(0)]
        link.feed(_status(1))
        await _settle(watch, 1)
        assert [z.name for z in watch.info.zones] == ["table", "monitor", "post", "camera mast"]
        assert watch.within == {"J5 link", "zone 'post'"} and watch.unavailable is None
        # the same world, a new pose: checked, not fetched again
        link.feed(_status(2, angles=(80, -90, 180, 0, 0, 180)))
        assert watch.within == frozenset() and link.robot.asked == 1 and watch.version == 1
        # an ATTACH: the status's collision.seq moves on, the world is fetched again
        link.robot.answers = [_world(1, held=[{"name": "ball", "kind": "sphere", "center": [0, 0, 170],
                                               "radius": 25}])]
        link.feed(_status(3, collision=1, angles=(80, -90, 180, 0, 0, 180)))
        await _settle(watch, 2)
        assert [h.name for h in watch.info.held] == ["ball"] and "held 'ball'" in {b.name for b in watch.scene.bodies}
        # a restarted controller counts from 0 again: fetched again although the seq is an old one
        link.robot.answers = [_world(0)]
        link.feed(_status(1, collision=0, time_s=0.5, angles=STANDBY))
        await _settle(watch, 3)
        assert watch.info.held == () and watch.within == {"J5 link", "zone 'post'"}
        assert watch.check_count >= 4 and watch.check_seconds > 0.0
        await watch.close()
        assert link.listeners == []

    asyncio.run(run())


def test_an_older_controller_without_get_zones_gets_the_default_table_said_once_in_the_log():
    async def run() -> None:
        link = _FakeLink()
        watch = CollisionWatch(link)  # type: ignore[arg-type]
        link.robot.answers = [ReplyError("ERROR|unknown command 'GET_ZONES'")]
        link.feed(_status(1, collision=None))  # no collision object in its status
        await _settle(watch, 1)
        assert watch.info is DEFAULT_WORLD and watch.unavailable and "GET_ZONES" in watch.unavailable
        assert [z.name for z in watch.setup.zones] == ["table"]
        link.feed(_status(2, collision=None, angles=(90, -3.4, 200, 0, 0, 180)))  # the forearm through the table
        assert "zone 'table'" in watch.within
        warned = [e.text for e in link.log if "GET_ZONES" in e.text]
        assert len(warned) == 1 and "default table" in warned[0]
        setup, why = await watch.for_check()
        assert setup is None and why is not None and "GET_ZONES" in why
        await watch.close()

    asyncio.run(run())


def test_a_controller_with_a_world_that_misses_one_answer_is_asked_again():
    async def run() -> None:
        link = _FakeLink()
        watch = CollisionWatch(link)  # type: ignore[arg-type]
        link.robot.answers = [ReplyError("no ZONES reply"), _world(0)]
        link.feed(_status(1))
        await _settle(watch, 1)
        assert link.robot.asked == 2 and watch.unavailable is None and watch.info is not DEFAULT_WORLD
        setup, why = await watch.for_check()
        assert why is None and setup is not None and MONITOR in setup.zones
        await watch.close()

    asyncio.run(run())
