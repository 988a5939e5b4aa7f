"""The collision world in the commander, in a real headless Chromium (issue 25, part 3: "a
student sees the collision before running").

One controller process (``parolkit serve --sim --config`` with keep-out zones: a box the J1
swing of the standby arm passes through, a box whose 60 mm margin the standby wrist is in, a
cylinder, and the default table) and one ``parolkit gui --connect`` to it.  The tests read the
page's three.js scene (NiceGUI's scene objects by id: the view names them in the scene
element's ``data-world-ids``, ``data-body-ids``, ``data-preview-id`` and
``data-preview-lines``) and ask the controller itself with a client of their own:

* the zones are drawn where GET_ZONES puts them (a box's mesh at its centre with its size and
  turn, its margin as an outline that much larger, its name as a label; the table as a quad on
  z = 0 with its forbidden side below; a cylinder along its axis), and an object ATTACHed by
  another client appears at the flange and goes with DETACH, without a reload;
* the J5 link, within the margin of the box beside the standby wrist, is drawn red (with that
  zone's margin outline) and back in its own colours once the arm moved out;
* Check on a program whose third line drives into the box marks line 3 with the pair's words
  and the time, and draws that line's part of the TCP path red (the other line's not).
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from playwright.sync_api import expect
from tests.browser.conftest import gui_on_controller
from tests.browser.helpers import show_tab, wait_linked, wait_ready, wait_until

from parolkit.client import Robot
from parolkit.gui.geometry import SCENE_SCALE
from parolkit.kinematics import fk_frames

pytestmark = [pytest.mark.browser, pytest.mark.slow]

RED = "ef4444"
#: scene units per mm
MM = 0.01
CONFIG = """
[[zones]]
name = "monitor"
kind = "box"
center = [141, 141, 334]
size = [40, 50, 60]
rpy = [0, 0, 30]
margin = 10

[[zones]]
name = "post"
kind = "box"
center = [-120, 200, 330]
size = [60, 60, 200]
margin = 60

[[zones]]
name = "camera mast"
kind = "cylinder"
center = [-250, -250, 150]
axis = [1, 0, 1]
radius = 20
height = 300
margin = 5
"""
#: out of the post's margin, clear of the monitor's
CLEAR = [80.0, -90.0, 180.0, 0.0, 0.0, 180.0]


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    root = tmp_path_factory.mktemp("collision-view")
    cfg = root / "zones.toml"
    cfg.write_text(CONFIG)
    with gui_on_controller(root, ["--stream-watchdog", "0.15", "--config", str(cfg)],
                           ["--programs-dir", str(root / "programs")]) as (controller, url, _):
        yield {"url": url, "controller": controller}


@pytest.fixture(scope="module")
def page(browser, world):
    pg = browser.new_page(viewport={"width": 1500, "height": 1000})
    pg.console_errors = []  # type: ignore[attr-defined]
    pg.on("console", lambda m: pg.console_errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: pg.console_errors.append(f"pageerror: {e}"))
    pg.goto(world["url"])
    wait_linked(pg)
    wait_ready(pg, 60)
    yield pg
    pg.close()


def _robot(world) -> Robot:
    return Robot("127.0.0.1", world["controller"].port, ack_port=0, timeout=5.0)


#: the scene objects named in the scene element's data attribute ``attr`` (a JSON tree whose
#: leaves are lists of object ids), each as {type, geometry parameters, world matrix, colour,
#: opacity, text, in the scene}
OBJECTS = """(attr) => {
  const host = document.querySelector('[data-testid=scene]');
  const comp = host && getElement(host.id.slice(1));
  if (!comp || !comp.objects) return null;
  const read = (id) => {
    const obj = comp.objects.get(id);
    const mesh = obj && obj.mesh;
    if (!mesh) return null;
    let root = mesh;
    for (let o = mesh; o; o = o.parent) root = o;
    mesh.updateWorldMatrix(true, false);
    const mat = mesh.material;
    return { type: mesh.type, params: mesh.geometry ? (mesh.geometry.parameters || null) : null,
             m: Array.from(mesh.matrixWorld.elements), inScene: root.isScene === true,
             color: mat && mat.color ? mat.color.getHexString() : null, opacity: mat ? mat.opacity : null,
             text: mesh.element ? mesh.element.textContent : null };
  };
  const walk = (v) => Array.isArray(v) ? v.map(read)
      : Object.fromEntries(Object.entries(v).map(([k, x]) => [k, walk(x)]));
  return walk(JSON.parse(host.dataset[attr] || '{}'));
}"""


def _objects(page, attr: str) -> dict:
    return page.evaluate(OBJECTS, attr) or {}


def _all_in_scene(tree) -> bool:
    if isinstance(tree, dict):
        return bool(tree) and all(_all_in_scene(v) for v in tree.values())
    return bool(tree) and all(o is not None and o["inScene"] for o in tree)


def _world(page, owner: str) -> dict:
    """The primitives drawn for ``owner`` ("zone 'monitor'", "held 'ball'"), once all are in the scene."""
    found: list[dict] = []

    def drawn() -> bool:
        tree = _objects(page, "worldIds").get(owner)
        found[:] = [tree] if tree else []
        return tree is not None and _all_in_scene(tree)

    wait_until(drawn, 20, what=f"{owner} drawn in the 3D view", page=page)
    return found[0]


def _pos(o: dict) -> list[float]:
    return o["m"][12:15]


def _axis(o: dict, k: int) -> list[float]:
    """Column ``k`` of the object's world rotation (its own x, y or z axis in the scene)."""
    return o["m"][4 * k:4 * k + 3]


def _close(a, b, tol=1e-4) -> bool:
    return all(abs(x - y) <= tol for x, y in zip(a, b, strict=True))


def test_the_zones_are_drawn_where_the_controller_says_and_follow_attach_and_detach(page, world):
    with _robot(world) as robot:
        info = robot.zones()
    assert [z.name for z in info.zones] == ["table", "monitor", "post", "camera mast"]
    # the box: its mesh at the centre, its size, turned 30 deg about z; the margin 10 mm larger
    # on every side; the name as a label above it
    monitor = _world(page, "zone 'monitor'")
    body = monitor["body"][0]
    assert body["type"] == "Mesh"
    assert _close(_pos(body), [1.41, 1.41, 3.34])
    assert _close([body["params"][k] for k in ("width", "height", "depth")], [0.40, 0.50, 0.60])
    c, s = 0.8660254, 0.5
    assert _close(_axis(body, 0), [c, s, 0.0]) and _close(_axis(body, 1), [-s, c, 0.0])
    assert body["opacity"] < 1.0  # translucent
    margin = monitor["margin"][0]
    assert margin["type"] == "LineSegments" and _close(_pos(margin), [1.41, 1.41, 3.34])
    assert _close([margin["params"]["geometry"]["parameters"][k] for k in ("width", "height", "depth")],
                  [0.60, 0.70, 0.80])
    assert [lab["text"] for lab in monitor["label"]] == ["monitor"]
    wait_until(lambda: "monitor" in page.get_by_test_id("scene").inner_text(), 10, what="the label shown",
               page=page)
    # the table: the floor zone, a quad on z = 0 with its forbidden side (a slab) below it
    table = _world(page, "zone 'table'")
    quad, slab = table["body"][0], table["forbidden"][0]
    assert abs(_pos(quad)[2]) < 1e-6 and _close(_axis(quad, 2), [0.0, 0.0, 1.0])
    assert quad["params"]["width"] >= 10.0  # 1 m and more: a floor
    assert _pos(slab)[2] < 0.0
    # the cylinder along its (tilted) axis: three.js's cylinder axis is its own y
    mast = _world(page, "zone 'camera mast'")
    r2 = 0.5 ** 0.5
    assert _close(_pos(mast["body"][0]), [-2.5, -2.5, 1.5])
    assert _close(_axis(mast["body"][0], 1), [r2, 0.0, r2])
    assert mast["body"][0]["params"]["radiusTop"] == pytest.approx(0.2)
    assert mast["margin"][0]["params"]["geometry"]["parameters"]["height"] == pytest.approx(3.1)
    # another client attaches a ball to the flange: drawn there without a reload, gone with DETACH
    with _robot(world) as robot:
        robot.take_control(force=True)
        try:
            robot.attach_sphere("ball", (0, 0, 170), 25, timeout=10)
            ball = _world(page, "held 'ball'")["body"][0]
            assert ball["params"]["radius"] == pytest.approx(0.25)
            # at the flange: 170 mm along the flange frame's z from the wrist centre
            flange = fk_frames(robot.angles(), tool="flange")[6]
            centre = flange @ np.array([0.0, 0.0, 0.170, 1.0])
            assert _close(_pos(ball), list(centre[:3] * SCENE_SCALE), 1e-3), (_pos(ball), centre)
            robot.detach("ball", timeout=10)
        finally:
            robot.release_control()
    wait_until(lambda: "held 'ball'" not in _objects(page, "worldIds"), 20, what="the ball gone", page=page)
    assert page.console_errors == []


def _colours(page, body: str) -> list[str]:
    objs = _objects(page, "bodyIds").get(body) or []
    return [o["color"] for o in objs if o is not None]


def test_the_link_within_a_zones_margin_is_red_and_not_once_it_moved_out(page, world):
    """At standby the wrist (the J5 link) is 39 mm from the box 'post', whose margin is 60 mm:
    drawn red with the zone's margin outline; the upper arm (J2 link) is not.  Another client
    turns J1 to 80 deg (out of the margin: motion away from a zone is allowed): back to normal."""
    wait_ready(page, 30)
    wait_until(lambda: _colours(page, "J5 link") and all(c == RED for c in _colours(page, "J5 link")), 20,
               what="the J5 link drawn red at standby", page=page)
    assert RED not in _colours(page, "J2 link")
    wait_until(lambda: _world(page, "zone 'post'")["margin"][0]["color"] == RED, 10,
               what="the post's margin outline red", page=page)
    with _robot(world) as robot:
        robot.take_control(force=True)
        try:
            robot.move_joints(CLEAR, duration=1.5, timeout=30)
        finally:
            robot.release_control()
    wait_until(lambda: RED not in _colours(page, "J5 link"), 20, what="the J5 link back to normal", page=page)
    assert _world(page, "zone 'post'")["margin"][0]["color"] != RED
    assert page.console_errors == []


def _type_program(page, text: str) -> None:
    show_tab(page, "tab-program")
    page.locator("[data-testid=editor] .cm-content").click()
    page.keyboard.press("Control+A")
    page.keyboard.press("Delete")
    page.keyboard.insert_text(text)


PREVIEW = """() => {
  const host = document.querySelector('[data-testid=scene]');
  const comp = getElement(host.id.slice(1));
  const obj = comp.objects.get(host.dataset.previewId);
  const g = obj && obj.mesh && obj.mesh.geometry;
  if (!g || !g.attributes.position) return null;
  const col = g.attributes.color ? Array.from(g.attributes.color.array) : [];
  return { lines: JSON.parse(host.dataset.previewLines || '[]'), count: g.attributes.position.count,
           colors: col, vertexColors: obj.mesh.material.vertexColors };
}"""


def test_a_program_whose_third_line_collides_shows_it_red_in_the_preview(page, world):
    """Acceptance (issue 25): the commander's preview shows it red.  Line 3 swings J1 through
    the box 'monitor': the diagnostic at line 3 names the pair and the time into the move, line
    3 is marked, and the preview's points of line 3 are red where it collides (line 2's none)."""
    with _robot(world) as robot:  # the start: clear of every margin (the last test left it there)
        robot.take_control(force=True)
        try:
            robot.move_joints(CLEAR, duration=1.5, timeout=30)
        finally:
            robot.release_control()
    wait_ready(page, 30)
    _type_program(page, "Begin()\nMoveJoint(80, -80, 170, 0, 10, 180, t=1.5)\n"
                        "MoveJoint(0, -90, 180, 0, 0, 180, t=4)\nEnd()\n")
    page.get_by_test_id("prog-check").click()
    diag = page.get_by_test_id("diagnostic").first
    expect(diag).to_have_text(re.compile(
        r"^\S+\.rbt: The [\w ]+ \(J\d\) would hit the zone 'monitor' \d+(\.\d+)? s into the move at line 3: go around "
        r"it"),
        timeout=15000)
    err = page.locator(".cm-line.rbt-error")
    expect(err).to_have_count(1, timeout=10000)
    assert err.first.inner_text().startswith("MoveJoint(0, -90, 180")
    found: list[dict] = []

    def drawn() -> bool:
        p = page.evaluate(PREVIEW)
        found[:] = [p] if p else []
        return bool(p) and p["count"] > 20 and [ln[0] for ln in p["lines"]] == [2, 3]

    wait_until(drawn, 20, what="the preview drawn, lines 2 and 3", page=page)
    p = found[0]
    assert p["vertexColors"] and len(p["colors"]) == 3 * p["count"]
    rgb = [tuple(p["colors"][3 * i:3 * i + 3]) for i in range(p["count"])]
    red = [abs(r - 0.937) < 0.01 and abs(g - 0.267) < 0.01 and abs(b - 0.267) < 0.01 for r, g, b in rgb]
    (line2, first2, n2, red2), (line3, first3, n3, red3) = p["lines"]
    assert red2 == 0 and not any(red[first2:first2 + n2])
    assert red3 > 0 and sum(red[first3:first3 + n3]) == red3
    # the red part is a stretch in the middle of the swing (it enters the box and leaves it),
    # neither its start nor its end
    seg = red[first3:first3 + n3]
    assert not seg[0] and not seg[-1]
    assert page.console_errors == []
