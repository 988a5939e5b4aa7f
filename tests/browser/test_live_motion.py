"""The commander's speed override and Pause on the path (issue 24 items 2 and 3), in a real
headless Chromium against a real controller.

One controller process (``parolkit serve --sim``) and one ``parolkit gui --connect`` to it: the
tests ask the controller itself (``GET_STATUS``: ``SPEED=``, ``PAUSED=``, ``ANGLES=``, ``CMD=``)
and count its frames (``frames_pass``), never the wall clock.  A second client (the client
library's ``Robot`` on its own socket) pauses the arm or holds the control lease.

* The speed override slider sends ``SPEED`` once, when it is let go: never while it is
  dragged, and it stays under the pointer that drags it while statuses come in.
* Its arrow keys change the override by 1 % and do not jog.  Failed before: a slider's track
  has the keyboard focus (not the element named ``role=slider``), so the arrows adjusted the
  slider AND jogged the arm (Cartesian X / Y).
* Another client's override shows on the slider; while another client controls the robot a
  change is refused (the controller's reason in the log), the slider goes back to the
  controller's value and the line under it says who controls the robot.
* Another client's PAUSE of the commander's own move: PAUSED in the header, the arm holds
  short of the move's end, and the header's Resume lets the move finish.
* Step while a program is paused on its path: the arm finishes that line, the next one runs,
  and the program pauses before the one after it; Run finishes it.  While the program runs
  the slider's SPEED goes through the program's client (it holds the control lease then).

The tests run in file order; each leaves the robot enabled, homed and idle at 100 %.
"""

from __future__ import annotations

import pytest
from tests.browser.helpers import (
    count_since,
    log_mark,
    log_text,
    number,
    recover,
    state,
    text,
    wait_ready,
    wait_until,
)
from tests.conftest import frames_pass

from parolkit.client import Robot

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def _status(controller) -> dict[str, str]:
    """The controller's GET_STATUS as a dict (empty when no reply came)."""
    reply = controller.query("GET_STATUS", 0.5) or ""
    return dict(part.split("=", 1) for part in reply.split("|")[1:] if "=" in part)


def _speed(controller) -> str | None:
    return _status(controller).get("SPEED")


def _j1(st: dict[str, str]) -> float:
    return float(st["ANGLES"].split(",")[0])


def _slider(page):
    return page.get_by_test_id("override-slider")


def _shown(page) -> int:
    """The override the slider shows (its aria-valuenow)."""
    return int(_slider(page).get_attribute("aria-valuenow"))


def _wait_speed(page, controller, value: int, what: str) -> None:
    wait_until(lambda: _speed(controller) == str(value), 10, what=f"the controller's override at {value} % ({what})",
               page=page)


def _keys_on_slider(page, *keys: str) -> None:
    """Keys on the slider as the keyboard reaches it (Tab puts the focus on its track)."""
    page.locator("[data-testid=override-slider] .q-slider__track-container").focus()
    for key in keys:
        page.keyboard.press(key)


def test_the_slider_sends_the_override_once_when_let_go_never_while_dragged(controller_page, controller_gui):
    page, controller = controller_page, controller_gui["controller"]
    wait_ready(page)
    assert _speed(controller) == "100" and _shown(page) == 100
    mark = log_mark(page)
    thumb = page.locator("[data-testid=override-slider] .q-slider__thumb").bounding_box()
    track = page.locator("[data-testid=override-slider] .q-slider__track").bounding_box()
    assert thumb and track
    y = thumb["y"] + thumb["height"] / 2
    page.mouse.move(thumb["x"] + thumb["width"] / 2, y)
    page.mouse.down()
    try:
        page.mouse.move(track["x"] + 0.3 * track["width"], y, steps=8)
        wait_until(lambda: 25 <= _shown(page) <= 35, 10, what="the slider under the pointer near 30 %", page=page)
        dragged = _shown(page)
        assert text(page, "override-value") == f"{dragged} %"
        # held for 30 of the controller's frames (about 10 statuses reach the page): nothing
        # was sent, and the statuses (still 100 %) did not pull the slider from under the pointer
        frames_pass(controller.loop_stats, 30)
        assert _speed(controller) == "100", "SPEED was sent while the slider was dragged"
        assert _shown(page) == dragged, f"the slider moved under the pointer: {dragged} -> {_shown(page)}"
    finally:
        page.mouse.up()
    _wait_speed(page, controller, dragged, "let go")
    wait_until(lambda: count_since(page, mark, "SPEED completed") == 1, 10, what="the SPEED ack logged", page=page)
    frames_pass(controller.loop_stats, 30)
    assert count_since(page, mark, "SPEED completed") == 1, f"more than one SPEED for one drag:\n{log_text(page)}"
    assert _shown(page) == dragged and text(page, "override-value") == f"{dragged} %"


def test_the_arrow_keys_on_the_slider_change_the_override_and_do_not_jog(controller_page, controller_gui):
    """Failed before: the keyboard focus is on the slider's track, which commander.js did not
    take for a slider: ArrowLeft also sent "jog WRF X-" (and ArrowUp Y+)."""
    page, controller = controller_page, controller_gui["controller"]
    wait_ready(page)
    before = int(_speed(controller) or 0)
    angles = _status(controller)["ANGLES"]
    mark = log_mark(page)
    _keys_on_slider(page, "ArrowLeft")
    _wait_speed(page, controller, before - 1, "ArrowLeft")
    _keys_on_slider(page, "ArrowUp")  # up is more, as Quasar's sliders have it
    _wait_speed(page, controller, before, "ArrowUp")
    frames_pass(controller.loop_stats, 30)
    assert _status(controller)["ANGLES"] == angles, "an arrow key on the slider moved the arm"
    assert count_since(page, mark, "jog ") == 0, f"an arrow key on the slider jogged:\n{log_text(page)}"
    # back to 100 % with PageUp (10 % a press) for the next tests
    while int(_speed(controller) or 0) < 100:
        now = int(_speed(controller) or 0)
        _keys_on_slider(page, "PageUp")
        _wait_speed(page, controller, min(100, now + 10), "PageUp")
    page.evaluate("() => document.activeElement && document.activeElement.blur()")


def test_another_clients_override_shows_and_a_change_is_refused_while_it_controls_the_robot(
        controller_page, controller_gui):
    page, controller = controller_page, controller_gui["controller"]
    wait_ready(page)
    with Robot("127.0.0.1", controller.port, ack_port=0, timeout=2.0) as other:
        other.take_control(force=True)  # the commander may hold it from the tests before
        other.set_speed(55)
        wait_until(lambda: _shown(page) == 55 and text(page, "override-value") == "55 %", 10,
                   what="the other client's 55 % on the slider", page=page)
        who = f"127.0.0.1:{other.ack_port}"
        wait_until(lambda: who in text(page, "override-note") and "refused" in text(page, "override-note"), 10,
                   what="the note naming the client in control", page=page)
        mark = log_mark(page)
        _keys_on_slider(page, "ArrowRight")
        wait_until(lambda: count_since(page, mark, f"the robot is controlled by {who}") > 0, 10,
                   what="the change refused with the controller's reason", page=page)
        wait_until(lambda: _shown(page) == 55, 10, what="the slider back at the controller's 55 %", page=page)
        assert _speed(controller) == "55"
        other.set_speed(100)  # and back, shown again
        wait_until(lambda: _shown(page) == 100, 10, what="the other client's 100 % on the slider", page=page)
    # Robot.close() gave the lease back: the note says what the slider does again
    wait_until(lambda: "refused" not in text(page, "override-note"), 10, what="the note without the refusal",
               page=page)
    page.evaluate("() => document.activeElement && document.activeElement.blur()")


def test_another_clients_pause_shows_paused_and_the_headers_resume_finishes_the_move(
        controller_page, controller_gui):
    """The commander's own step move (J1 -40 deg), paused by another client (PAUSE is open to
    every client): PAUSED in the header with Resume, the arm holding short of the target while
    the move is still the controller's command; Resume (the commander holds the lease) lets
    it finish."""
    page, controller = controller_page, controller_gui["controller"]
    wait_ready(page)
    page.get_by_test_id("tab-jog").click()
    page.get_by_test_id("jog-mode").get_by_text("Step").click()
    page.locator("label.q-field", has_text="step °").locator("input").fill("40")
    start = _j1(_status(controller))
    try:
        with Robot("127.0.0.1", controller.port, ack_port=0, timeout=2.0) as other:
            page.get_by_test_id("jog-j1-").click()
            wait_until(lambda: _status(controller).get("CMD", "None").startswith("MOVEJOINT"), 15,
                       what="the step move running", page=page)
            other.pause()
            wait_until(lambda: state(page) == "PAUSED", 10, what="PAUSED in the header", page=page)
            resume = page.get_by_test_id("btn-resume")
            assert resume.is_visible() and resume.get_attribute("aria-label") == "Resume"
            wait_until(lambda: _status(controller).get("SPEEDS") == "0,0,0,0,0,0", 10, what="the arm at rest",
                       page=page)
            held = _status(controller)
            frames_pass(controller.loop_stats, 40)
            now = _status(controller)
            assert now["ANGLES"] == held["ANGLES"], "paused: the arm did not hold"
            assert now["PAUSED"] == "1" and now["CMD"].startswith("MOVEJOINT"), now
            assert start - 39.5 < _j1(now) < start, f"not held on the way: J1 {start} -> {_j1(now)}"
        resume.click()
        wait_until(lambda: _status(controller).get("PAUSED") == "0", 10, what="resumed", page=page)
        wait_until(lambda: _status(controller).get("CMD") == "None", 30, what="the move finished", page=page)
        assert abs(_j1(_status(controller)) - (start - 40)) < 0.01
        wait_ready(page)
        assert not resume.is_visible()
        assert "RESUME completed: resumed" in log_text(page)
    finally:
        page.get_by_test_id("btn-stop").click()  # STOP also ends a pause left by a failure
        wait_until(lambda: _status(controller).get("PAUSED") == "0", 10, what="not paused", page=page)
        page.get_by_test_id("jog-mode").get_by_text("Continuous").click()
        recover(page)
        page.get_by_test_id("btn-home").click()
        wait_until(lambda: state(page) == "READY" and abs(number(page, "angle-1") - 90.0) < 0.1, 60,
                   what="homed standby", page=page)


#: line 2 lasts 12 s (J1 90 -> 40), line 3 one (-> 50), line 4 three (-> 90)
STEP_PROGRAM = ("Begin()\nMoveJoint(40,-90,180,0,0,180,t=12)\nMoveJoint(50,-90,180,0,0,180,t=1)\n"
                "MoveJoint(90,-90,180,0,0,180,t=3)\nEnd()\n")


#: the GUI's log line when Pause found the program in a line (the line's number follows)
PAUSED_AT = "pause: the arm slows down on its path and holds at line"


def _pauses(page, mark: list[str]) -> int:
    """How many Pause clicks the GUI logged after ``mark`` (in a line, or after the program)."""
    return count_since(page, mark, PAUSED_AT) + count_since(page, mark, "pause: no program is running")


def _type_program(page, program: str) -> None:
    page.get_by_test_id("tab-program").click()
    page.locator("[data-testid=editor] .cm-content").click()
    page.keyboard.press("Control+A")
    page.keyboard.press("Delete")
    page.keyboard.insert_text(program)
    wait_until(lambda: page.evaluate("() => window.pkEditorText ? window.pkEditorText() : null") == program, 10,
               what="the program typed", page=page)


def _stop_program(page) -> None:
    if "PROGRAM" in state(page):
        page.get_by_test_id("tab-program").click()
        page.get_by_test_id("prog-stop").click()
    wait_ready(page)


def test_step_while_paused_on_the_path_finishes_the_line_runs_the_next_and_pauses(controller_page, controller_gui):
    page, controller = controller_page, controller_gui["controller"]
    wait_ready(page)
    try:
        for _attempt in range(3):
            # the GUI logs where the click found the program: at line 2 (what this test is
            # about), or later (a loaded machine: the click came after line 2): then again
            mark = log_mark(page)
            _type_program(page, STEP_PROGRAM)
            page.get_by_test_id("prog-run").click()
            wait_until(lambda: "line 2" in text(page, "prog-status") and abs(number(page, "speed-1")) > 1.0, 20,
                       what="line 2's move under way", page=page)
            page.get_by_test_id("prog-pause").click()
            wait_until(lambda m=mark: _pauses(page, m) > 0, 30, what="the pause logged", page=page)
            if count_since(page, mark, f"{PAUSED_AT} 2") > 0:
                break
            _stop_program(page)
        else:
            raise AssertionError(f"3 pause clicks arrived after line 2's move\n{log_text(page)}")
        wait_until(lambda: "paused on the path at line 2" in text(page, "prog-status"), 15,
                   what="paused on the path at line 2", page=page)
        paused_at = _j1(_status(controller))
        assert 40.5 < paused_at < 89.5, f"not paused on line 2's way: J1 {paused_at}"
        # while the program runs its client holds the control lease: the slider's SPEED goes
        # through it (through the commander's link it would be refused)
        mark = log_mark(page)
        _keys_on_slider(page, "ArrowLeft")
        _wait_speed(page, controller, 99, "set while the program runs")
        _keys_on_slider(page, "ArrowRight")
        _wait_speed(page, controller, 100, "set back while the program runs")
        page.evaluate("() => document.activeElement && document.activeElement.blur()")
        wait_until(lambda: count_since(page, mark, "SPEED completed (through the program's client)") == 2, 10,
                   what="both SPEEDs logged as sent through the program's client", page=page)
        assert count_since(page, mark, "SPEED failed") == 0, log_text(page)
        page.get_by_test_id("prog-step").click()
        # line 2 finishes (J1 40), line 3 runs (J1 50), and the program pauses before line 4
        wait_until(lambda: "paused before line 4" in text(page, "prog-status"), 40,
                   what="paused before line 4 after the step", page=page)
        wait_until(lambda: _status(controller).get("CMD") == "None", 10, what="line 3 ended", page=page)
        st = _status(controller)
        # (line 4 waits at the controller, held: the program's lines are queued ahead)
        assert abs(_j1(st) - 50.0) < 0.01 and st["PAUSED"] == "0" and st["QUEUE"] == "1", st
        frames_pass(controller.loop_stats, 40)
        assert _status(controller)["ANGLES"] == st["ANGLES"], "line 4 ran while the program was paused"
        assert state(page) == "PROGRAM PAUSED"
        page.get_by_test_id("prog-run").click()
        wait_until(lambda: "finished" in text(page, "prog-status"), 30, what="the program finished", page=page)
        wait_ready(page)
        assert abs(_j1(_status(controller)) - 90.0) < 0.01
    finally:
        _stop_program(page)
        page.get_by_test_id("tab-jog").click()
