"""Simulate first (issue 26 item 3), in a real headless Chromium against a real controller.

One controller process (``parolkit serve`` on a simulated board in lockstep with its frames,
so a move's length is counted in ticks, and a box zone 'monitor' in its config) and one
``parolkit gui --connect`` to it.  The tests ask the controller itself: its every status
(``tests.integration.status_log``: one per tick), ``GET_CONTROL`` and ``GET_STATUS``.

* Simulate plays the program on the ghost arm (the 3D view's ``data-sim-ids``) and not on the
  robot: while the test's own client holds the control lease, so that any motion command from
  the commander would be refused and counted, the simulation plays lines 2 and 3 with the line
  highlighted, the ghost red while line 3 (which drives into the box) plays, line 3 marked as
  Check marks it, the ghost ending on the dry run's end pose; the controller refused nothing,
  ran no command, started no motion (its plan sequence) and its joints never changed.  Stop
  simulation hides the ghost mid-play.
* Run speed: the same program run at 100 % and at 30 %: every move takes 1 / 0.3 as many ticks
  at 30 %, a Speed(50) line runs at 15 %, and the override is given back when it ends.
* "Go to start pose" is hold-to-move: held, the arm moves towards the first move's target;
  let go, it stops short of it and stays; greyed while the robot cannot move; held to the
  end, the arm reaches the pose and the button greys ("at the start pose").
"""

from __future__ import annotations

import math
import re

import pytest
from playwright.sync_api import expect
from tests.browser.conftest import _stop, start_gui
from tests.browser.helpers import (
    log_mark,
    log_since,
    show_tab,
    state,
    text,
    wait_linked,
    wait_ready,
    wait_until,
)
from tests.conftest import frames_pass, start_controller
from tests.integration.status_log import StatusLog, command_runs

from parolkit.client import Robot
from parolkit.gui import geometry
from parolkit.gui.simulate import SimTimeline
from parolkit.kinematics import fk_frames
from parolkit.script import dry_run, parse

pytestmark = [pytest.mark.browser, pytest.mark.slow]

RED = "ef4444"
CONFIG = """
[[zones]]
name = "monitor"
kind = "box"
center = [141, 141, 334]
size = [40, 50, 60]
rpy = [0, 0, 30]
margin = 10
"""
STANDBY = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)
#: line 3 swings J1 from 80 to 0 deg through the box 'monitor' (J4 link at 1.27 s into the move)
COLLIDING = "Begin()\nMoveJoint(80, -80, 170, 0, 10, 180, t=1.5)\nMoveJoint(0, -90, 180, 0, 0, 180, t=4)\nEnd()\n"
#: two 1 s moves, the second after Speed(50)
TIMED = "Begin()\nMoveJoint(80, -90, 180, 0, 0, 180, t=1)\nSpeed(50)\nMoveJoint(90, -90, 180, 0, 0, 180, t=1)\nEnd()\n"
#: the first move's target, away from the box (J1 120 deg)
START = (120.0, -100.0, 190.0, 0.0, -20.0, 180.0)
START_PROGRAM = "Begin()\nMoveJoint(120, -100, 190, 0, -20, 180, t=2)\nMoveJoint(90, -90, 180, 0, 0, 180, t=2)\nEnd()\n"


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    root = tmp_path_factory.mktemp("simulate")
    cfg = root / "zones.toml"
    cfg.write_text(CONFIG)
    controller = start_controller(["--stream-watchdog", "0.15", "--config", str(cfg)], log_dir=root, lockstep=True)
    try:
        proc, url, _ = start_gui(["--connect", f"127.0.0.1:{controller.port}",
                                  "--programs-dir", str(root / "programs")])
        try:
            yield {"url": url, "controller": controller}
        finally:
            _stop(proc)
    finally:
        controller.stop()


@pytest.fixture(scope="module")
def page(browser, world):
    pg = browser.new_page(viewport={"width": 1500, "height": 1100})
    pg.console_errors = []  # type: ignore[attr-defined]
    pg.on("console", lambda m: pg.console_errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: pg.console_errors.append(f"pageerror: {e}"))
    pg.goto(world["url"])
    wait_linked(pg)
    wait_ready(pg, 60)
    yield pg
    pg.close()


@pytest.fixture
def robot(world):
    """A client of the controller of its own (the test's eyes and, when asked, its lease)."""
    r = Robot("127.0.0.1", world["controller"].port, ack_port=0, timeout=5.0)
    yield r
    r.close()


def _type_program(page, program: str) -> None:
    show_tab(page, "tab-program")
    page.locator("[data-testid=editor] .cm-content").click()
    page.keyboard.press("Control+A")
    page.keyboard.press("Delete")
    page.keyboard.insert_text(program)
    wait_until(lambda: page.evaluate("() => window.pkEditorText ? window.pkEditorText() : null") == program, 10,
               what="the program typed", page=page)
    page.evaluate("() => document.activeElement && document.activeElement.blur()")


def _move_to(robot: Robot, joints, duration: float = 1.5) -> None:
    robot.take_control(force=True)
    try:
        robot.move_joints(list(joints), duration=duration, timeout=30)
    finally:
        robot.release_control()


#: the simulation's ghost as the page draws it: visible, its TCP frame's place (scene units),
#: the colour of its solids, and the editor line highlighted as simulated (None: none)
GHOST = """() => {
  const host = document.querySelector('[data-testid=scene]');
  const comp = host && getElement(host.id.slice(1));
  if (!comp || !comp.objects) return null;
  const ids = JSON.parse(host.dataset.simIds || '{}');
  const tcp = comp.objects.get(ids.groups[7]);
  const solid = comp.objects.get(ids.solids[0]);
  if (!tcp || !tcp.mesh || !solid || !solid.mesh) return null;
  tcp.mesh.updateWorldMatrix(true, false);
  const e = tcp.mesh.matrixWorld.elements;
  const lines = Array.from(document.querySelectorAll('[data-testid=editor] .cm-line'));
  const sim = lines.findIndex((l) => l.classList.contains('rbt-sim'));
  return { visible: tcp.mesh.visible, pos: [e[12], e[13], e[14]], color: solid.mesh.material.color.getHexString(),
           line: sim < 0 ? null : sim + 1 };
}"""


#: records the ghost every 20 ms in the page itself (the test process may be starved on a busy
#: machine; the page's own timer is not held up by it)
RECORD = f"""() => {{
  const read = {GHOST};
  window.pkSimSeen = [];
  window.pkSimRecorder = setInterval(() => {{ const g = read(); if (g) window.pkSimSeen.push(g); }}, 20);
}}"""
RECORDED = "() => { clearInterval(window.pkSimRecorder); return window.pkSimSeen; }"


def _ghost(page) -> dict:
    g = page.evaluate(GHOST)
    assert g is not None, "the simulation's ghost is not in the scene"
    return g


def _tcp_in_scene(joints) -> list[float]:
    return geometry.frame_pose_for_scene(fk_frames(list(joints), None)[-1])[0]


def _nearest_on_path(pos, path, times) -> tuple[float, float]:
    """(distance, time) of the point of the polyline ``path`` (sampled at ``times``) nearest ``pos``."""
    best = (math.inf, 0.0)
    for (a, ta), (b, tb) in zip(zip(path, times), zip(path[1:], times[1:])):
        ab = [y - x for x, y in zip(a, b)]
        n2 = sum(v * v for v in ab)
        w = 0.0 if n2 == 0 else max(0.0, min(1.0, sum((p - x) * v for p, x, v in zip(pos, a, ab)) / n2))
        d = math.dist(pos, [x + w * v for x, v in zip(a, ab)])
        best = min(best, (d, ta + w * (tb - ta)))
    return best


def _close(a, b, tol: float) -> bool:
    return all(abs(x - y) <= tol for x, y in zip(a, b, strict=True))


def test_simulate_plays_the_program_on_the_ghost_marks_the_colliding_line_and_never_moves_the_robot(
        page, world, robot):
    wait_ready(page, 30)
    _type_program(page, COLLIDING)
    page.get_by_test_id("sim-speed").get_by_text("1x").click()
    joints = robot.angles()
    assert _close(joints, STANDBY, 0.05)
    plan = SimTimeline.from_report(dry_run(parse(COLLIDING, "x").program, joints))
    expected_end = plan.at(plan.duration_s).joints_deg
    #: the planned TCP path, every 10 ms of the run (line 2 until 1.5 s, then line 3 until 5.5 s)
    times = [k / 100 for k in range(int(plan.duration_s * 100) + 1)]
    path = [_tcp_in_scene(plan.at(t).joints_deg) for t in times]
    before = robot.status()
    robot.take_control(force=True)  # a motion command from the commander would now be refused (and counted)
    refused = robot.control()["refused"]
    statuses = StatusLog(robot)
    mark = log_mark(page)
    try:
        page.evaluate(RECORD)
        page.get_by_test_id("prog-simulate").click()
        wait_until(lambda: "simulation finished" in text(page, "sim-status"), 120,
                   what="the simulation played to its end", page=page)
        seen = page.evaluate(RECORDED)
        frames_pass(world["controller"].loop_stats, 5)
        ticks = statuses.snapshot()
        assert robot.control()["refused"] == refused, "the commander sent a motion command during the simulation"
    finally:
        statuses.close()
        robot.release_control()
    # the robot: no command ran at any tick, no motion started, the joints never changed
    assert len(ticks) > 100
    assert all(st.command is None and st.queue == 0 for st in ticks), [st.command for st in ticks if st.command]
    assert {st.plan_seq for st in ticks} == {before.plan_seq}
    assert all(_close(st.angles, joints, 1e-6) for st in ticks)
    assert not [line for line in log_since(page, mark) if re.search(r"\bsent\b", line)]
    # the ghost: shown, along the planned path, through lines 2 and 3 in order (the highlight),
    # red exactly where it plays line 3 (each place it was seen at: the time on the plan nearest it)
    playing = [g for g in seen if g["visible"]]
    assert playing, seen
    lines = [g["line"] for g in playing if g["line"] is not None]
    assert lines == sorted(lines) and set(lines) == {2, 3}, lines
    at = []
    for g in playing:
        d, t = _nearest_on_path(g["pos"], path, times)
        assert d < 3e-3, f"the ghost left the plan: {g['pos']} is {d} from it"
        at.append((t, g["color"] == RED))
    assert any(0.1 < t < 1.4 for t, _ in at) and any(1.6 < t < 5.4 for t, _ in at), f"it did not play both lines: {at}"
    assert all(red for t, red in at if t > 1.55) and not any(red for t, red in at if t < 1.45), at
    # line 3 is marked as Check marks it, with the zone's name
    err = page.locator(".cm-line.rbt-error")
    expect(err).to_have_count(1, timeout=10000)
    assert err.first.inner_text().startswith("MoveJoint(0, -90, 180")
    assert any("3" in d and "monitor" in d for d in page.get_by_test_id("diagnostic").all_inner_texts())
    # it ends on the dry run's end pose (the robot stayed at standby)
    end = _ghost(page)
    assert end["visible"] and end["line"] == 3
    assert _close(end["pos"], _tcp_in_scene(expected_end), 1e-3), (end["pos"], expected_end)
    assert _close(expected_end, (0.0, -90.0, 180.0, 0.0, 0.0, 180.0), 0.01)
    assert not _close(end["pos"], _tcp_in_scene(joints), 0.1)
    assert "the robot did not move" in text(page, "sim-status")
    page.get_by_test_id("sim-stop").click()
    wait_until(lambda: not _ghost(page)["visible"] and _ghost(page)["line"] is None, 10, what="the ghost hidden",
               page=page)
    assert page.console_errors == []


def test_stop_simulation_ends_it_mid_play(page, world):
    _type_program(page, COLLIDING.replace("End()", "Delay(10)\nEnd()"))  # 15.5 s: 7.75 s at 2x
    page.get_by_test_id("sim-speed").get_by_text("2x").click()
    page.get_by_test_id("prog-simulate").click()
    wait_until(lambda: "simulating line" in text(page, "sim-status") and "at 2x" in text(page, "sim-status")
               and _ghost(page)["visible"], 30, what="the simulation playing at 2x", page=page)
    page.get_by_test_id("sim-stop").click()
    wait_until(lambda: not _ghost(page)["visible"], 10, what="the ghost hidden", page=page)
    assert _ghost(page)["line"] is None
    assert "simulat" not in text(page, "sim-status")
    expect(page.get_by_test_id("sim-stop")).to_be_disabled()


def _set_run_speed(page, pct: int) -> None:
    """The run speed slider by keyboard, an arrow (5 %) at a time until it shows ``pct``."""
    slider = page.get_by_test_id("run-speed")
    slider.locator(".q-slider__track-container").focus()
    for _ in range(40):
        now = int(float(slider.get_attribute("aria-valuenow")))
        if now == pct:
            break
        page.keyboard.press("ArrowRight" if now < pct else "ArrowLeft")
        wait_until(lambda n=now: int(float(slider.get_attribute("aria-valuenow"))) != n, 10,
                   what="the slider taking the key", page=page)
    wait_until(lambda: text(page, "run-speed-value").strip() == f"Run speed {pct} %", 30,
               what=f"the run speed at {pct} %", page=page)
    page.evaluate("() => document.activeElement && document.activeElement.blur()")


def _run_ticks(page, robot: Robot) -> tuple[list[int], list[float]]:
    """Run the program shown; the ticks of each MOVEJOINT and the speed overrides seen while one ran."""
    statuses = StatusLog(robot)

    def ran() -> bool:  # both moves ran and ended (the page's "finished" may still be the last run's)
        ticks = statuses.snapshot()
        moves = [r for r in command_runs(ticks) if r.name == "MOVEJOINT"]
        return len(moves) == 2 and ticks[-1].command is None and "finished" in text(page, "prog-status")

    try:
        page.get_by_test_id("prog-run").click()
        wait_until(ran, 90, what="the program run to its end", page=page)
        ticks = statuses.snapshot()
    finally:
        statuses.close()
    runs = [r for r in command_runs(ticks) if r.name == "MOVEJOINT"]
    overrides = [float(st.speed_pct) for st in ticks if st.command is not None and st.command.name == "MOVEJOINT"]
    return [r.ticks for r in runs], overrides


def test_a_program_run_at_30_percent_takes_1_over_0_3_as_many_ticks_and_the_override_is_given_back(
        page, world, robot):
    wait_ready(page, 30)
    _move_to(robot, STANDBY)
    assert robot.status().speed_pct == 100.0
    _type_program(page, TIMED)
    assert "sets the speed override to this for the program" in text(page, "run-speed-note")
    _set_run_speed(page, 100)
    full, full_overrides = _run_ticks(page, robot)
    assert len(full) == 2 and set(full_overrides) == {100.0, 50.0}, (full, set(full_overrides))
    # planned: 1 s and, after Speed(50), 2 s: 100 and 200 ticks (the board's end: a few more)
    assert 98 <= full[0] <= 106 and 196 <= full[1] <= 206, full
    wait_ready(page, 30)
    _set_run_speed(page, 30)
    slow, slow_overrides = _run_ticks(page, robot)
    assert len(slow) == 2 and set(slow_overrides) == {30.0, 15.0}, (slow, set(slow_overrides))
    for a, b in zip(slow, full, strict=True):
        assert b / 0.3 * 0.97 <= a <= b / 0.3 * 1.03, (slow, full)
    # the override the controller had before Run, again
    wait_until(lambda: robot.status().speed_pct == 100.0, 20, what="the override back at 100 %", page=page)
    wait_ready(page, 30)


def test_go_to_start_pose_moves_while_held_and_stops_when_let_go(page, world, robot):
    controller = world["controller"]
    wait_ready(page, 30)
    _move_to(robot, STANDBY)
    _type_program(page, START_PROGRAM)
    button = page.get_by_test_id("prog-start-pose")
    wait_until(lambda: "line 2's MoveJoint target (120, -100, 190, 0, -20, 180)" in text(page, "start-pose-note"), 20,
               what="the start pose of the program typed", page=page)
    expect(button).to_be_enabled(timeout=10000)
    # slow (5 % override), so the arm is still on its way when it is let go, however slow the machine
    robot.take_control(force=True)
    robot.set_speed(5, timeout=5)
    robot.release_control()
    try:
        start = robot.angles()
        box = button.bounding_box()
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.mouse.down()
        try:
            wait_until(lambda: abs(robot.angles()[0] - start[0]) > 0.5, 30, what="the arm moving while held",
                       page=page)
            assert robot.status().command is not None
        finally:
            page.mouse.up()
        wait_until(lambda: robot.status().command is None and not any(robot.status().speeds_deg_s), 30,
                   what="the arm at rest after letting go", page=page)
        stopped = robot.angles()
        assert 90.5 < stopped[0] < 119.0, f"not stopped on the way: {stopped}"
        frames_pass(controller.loop_stats, 50)
        assert _close(robot.angles(), stopped, 1e-6), "the arm moved on after it was let go"
        expect(button).to_be_enabled()  # not there yet
        # greyed while the robot cannot move
        page.get_by_test_id("btn-disable").click()
        wait_until(lambda: state(page) == "DISABLED", 20, what="disabled", page=page)
        expect(button).to_be_disabled(timeout=10000)
        assert "cannot move" in text(page, "start-pose-note")
        page.get_by_test_id("btn-enable").click()
        wait_ready(page, 30)
        expect(button).to_be_enabled(timeout=10000)
    finally:
        robot.take_control(force=True)
        robot.set_speed(100, timeout=5)
        robot.release_control()
    # held to the end: the arm reaches the first move's target, the button greys
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.down()
    try:
        wait_until(lambda: _close(robot.angles(), START, 0.05), 60, what="the arm at the start pose", page=page)
        expect(button).to_be_disabled(timeout=10000)
    finally:
        page.mouse.up()
    wait_until(lambda: "at the start pose" in text(page, "start-pose-note"), 10, what="the note", page=page)
    wait_ready(page, 30)
    _move_to(robot, STANDBY)
    assert page.console_errors == []


def test_the_simulate_row_fits_a_phone(page):
    """At 390 px (a phone) the Program tab's Simulate row, the run speed and the start pose
    button are on the screen and nothing scrolls sideways."""
    page.set_viewport_size({"width": 390, "height": 844})
    try:
        show_tab(page, "tab-program")
        wait_until(lambda: page.evaluate("() => document.documentElement.scrollWidth - window.innerWidth") <= 0, 10,
                   what="nothing wider than the screen", page=page)
        for testid in ("prog-simulate", "sim-speed", "sim-stop", "run-speed", "prog-start-pose", "start-pose-note"):
            b = page.get_by_test_id(testid).bounding_box()
            assert b is not None and b["x"] >= 0 and b["x"] + b["width"] <= 390.5, (testid, b)
    finally:
        page.set_viewport_size({"width": 1500, "height": 1100})
