"""Keys that do what they say (issue 15 items 1 and 2), in a real Chromium against
``parolkit gui --sim``: Space is STOP and Esc is E-STOP whatever has the focus; Esc in an open
dialog or menu only closes it; a clicked button never turns Space into "press it again"; Space
in a text field or the editor is STOP while something moves and types a space otherwise.

One GUI process and one page for the module; the tests run in file order and leave the robot
enabled, homed and idle.
"""

from __future__ import annotations

import contextlib
import re

import pytest
from tests.browser.helpers import (
    at_rest,
    count_since,
    log_mark,
    log_since,
    log_text,
    moving_attr,
    number,
    recover,
    show_tab,
    state,
    wait_linked,
    wait_ready,
    wait_until,
)

pytestmark = [pytest.mark.browser, pytest.mark.slow]

#: the J1 steps that Space must stop (the step field's maximum), run at the slowest jog speed
#: (:func:`slowest_jog`): it takes most of a minute, so it still runs after the clicks between
#: its start and the Space however loaded the machine
STEP_DEG = 45


def _slider_value(slider) -> int:
    """The value the server has given the slider (QSlider's aria-valuenow is its model-value
    prop, which the server sends back after each change)."""
    return round(float(slider.get_attribute("aria-valuenow")))


def _set_jog_speed(page, percent: int) -> None:
    """The jog speed slider to ``percent`` with its keys alone (PageUp / PageDown by 10, the
    arrows by 1), one key at a time: each waits until the server has sent the new value back,
    then the label must say it.

    Neither a click on the track nor keys without the slider's focus: commander.js takes the
    focus from a slider after a pointer press, and the arrows jog the robot then (after a
    click, arrows sent Cartesian step jogs); and the label lags behind the keys on a loaded
    machine, so keys counted from it overshot (with two CPU hogs: 20 "step WRF X+ 10 mm" and
    no 40 %).  The keys go to the slider's focusable track, and only once the page's focus is
    in the slider: commander.js leaves the keys of a focused slider to it."""
    show_tab(page, "tab-jog")
    mark = log_mark(page)
    slider = page.get_by_test_id("speed-slider")
    track = slider.locator("[tabindex]").first
    for _ in range(40):
        now = _slider_value(slider)
        if now == percent:
            break
        track.focus()
        assert track.evaluate("t => t.closest('[role=slider]').contains(document.activeElement)"), \
            "the jog speed slider did not take the focus: its keys would jog the robot"
        gap = percent - now
        page.keyboard.press(("PageUp" if gap > 0 else "PageDown") if abs(gap) >= 10 else
                            ("ArrowRight" if gap > 0 else "ArrowLeft"))
        wait_until(lambda now=now: _slider_value(slider) != now, 30,
                   what=f"the jog speed slider off {now} % (towards {percent} %)", page=page)
    wait_until(lambda: page.get_by_text(f"Speed {percent} %", exact=True).count() == 1, 30,
               what=f"the jog speed at {percent} %", page=page)
    jogs = [line for line in log_since(page, mark) if " jog " in line or "sent step" in line]
    assert not jogs, f"setting the jog speed jogged the robot: {jogs}"


@contextlib.contextmanager
def slowest_jog(page):
    """The jog speed at 1 % while the block runs, then back to what it was."""
    show_tab(page, "tab-jog")
    label = page.get_by_text(re.compile(r"^Speed \d+ %$"))
    before = int(re.search(r"\d+", label.inner_text()).group())
    _set_jog_speed(page, 1)
    try:
        yield
    finally:
        _set_jog_speed(page, before)


@pytest.fixture(scope="module")
def kpage(page):
    wait_linked(page)
    wait_ready(page, 60)
    return page


def test_space_after_clicking_home_sends_stop_not_home_again(kpage):
    """Item 1.  Failed on the old page: Quasar's button took Space (it stops the event) and
    clicked itself on keyup: a second 'sent Home', and no 'sent Stop' at all."""
    page = kpage
    mark = log_mark(page)
    page.get_by_test_id("btn-home").click()
    wait_until(lambda: count_since(page, mark, "sent Home") == 1, 30, what="Home sent", page=page)
    # let the homing finish (the board's homing sequence cannot be cut short by a STOP)
    wait_until(lambda: count_since(page, mark, "Home completed") == 1 and state(page) == "READY", 60,
               what="homed", page=page)
    page.keyboard.press("Space")
    wait_until(lambda: count_since(page, mark, "sent Stop") >= 1, 30, what="Space sent Stop", page=page)
    page.wait_for_timeout(1000)  # a second Home would be logged by now
    assert count_since(page, mark, "sent Home") == 1, f"Space pressed Home again:\n{log_text(page)}"
    assert count_since(page, mark, "sent Stop") == 1, f"one Space, more than one Stop:\n{log_text(page)}"
    recover(page)


def test_space_stops_a_step_jog_right_after_its_button_was_clicked(kpage):
    """Item 1, Step mode.  Failed on the old page: the clicked J1 − button kept the focus, took
    Space for itself, and the J1 step ran to completion (no STOP was sent)."""
    page = kpage
    step_input = _step_mode(page)
    try:
        with slowest_jog(page):
            start = at_rest(page, "angle-1")
            mark = log_mark(page)
            page.get_by_test_id("jog-j1-").click()
            _wait_step_moving(page, mark, start)
            page.keyboard.press("Space")
            _wait_space_stopped_the_step(page, mark, start)
    finally:
        step_input.fill("5")
        step_input.press("Tab")
        page.get_by_test_id("jog-mode").get_by_text("Continuous").click()
    recover(page)
    page.get_by_test_id("btn-home").click()
    wait_until(lambda: state(page) == "READY" and abs(number(page, "angle-1") - 90.0) < 0.1, 60,
               what="homed standby", page=page)


def _escape_only_closes(page, open_it, overlay: str, what: str) -> None:
    mark = log_mark(page)
    open_it()
    page.locator(overlay).first.wait_for(state="visible", timeout=30000)
    page.keyboard.press("Escape")
    page.locator(overlay).first.wait_for(state="hidden", timeout=30000)
    page.wait_for_timeout(500)  # an E-STOP would be logged by now
    assert count_since(page, mark, "software E-STOP sent") == 0, f"Esc in {what} latched E-STOP"
    assert state(page) != "E-STOP", f"Esc in {what} latched E-STOP"


def test_escape_in_a_dialog_or_menu_only_closes_it(kpage):
    """Item 2.  Failed on the old page: Esc used to close the Help dialog, the Examples menu,
    Save as… or the Programs list also latched E-STOP (4 of 4)."""
    page = kpage
    _escape_only_closes(page, lambda: page.get_by_test_id("help-button").click(), ".q-dialog", "Help")
    show_tab(page, "tab-program")
    _escape_only_closes(page, lambda: page.get_by_test_id("prog-examples").click(), ".q-menu", "Examples")
    _escape_only_closes(page, lambda: page.get_by_test_id("prog-insert").click(), ".q-menu", "Insert")
    _escape_only_closes(page, lambda: page.get_by_test_id("prog-save-as").click(), ".q-dialog", "Save as…")
    _escape_only_closes(page, lambda: page.get_by_test_id("prog-list").click(), ".q-dialog", "Programs")
    show_tab(page, "tab-jog")


def test_escape_is_estop_wherever_the_focus_is_and_space_types_in_the_editor(kpage):
    """Esc with no dialog open latches E-STOP from a focused button, a slider and the editor;
    Space in the editor types a space (a program needs them) instead of stopping."""
    page = kpage
    for focus in ("btn-home", "speed-slider", "editor"):
        wait_ready(page)
        if focus == "editor":
            show_tab(page, "tab-program")
            page.locator("[data-testid=editor] .cm-content").click()
        elif focus == "speed-slider":  # its track takes the focus (the slider's root cannot)
            page.get_by_test_id("speed-slider").locator("[tabindex]").first.focus()
            assert page.evaluate("() => !!document.activeElement.closest('[data-testid=speed-slider]')")
        else:
            page.get_by_test_id(focus).focus()
        mark = log_mark(page)
        page.keyboard.press("Escape")
        wait_until(lambda: state(page) == "E-STOP", 30, what=f"E-STOP from Esc with {focus} focused", page=page)
        wait_until(lambda mark=mark: count_since(page, mark, "software E-STOP sent") >= 1, 30,
                   what=f"E-STOP logged (Esc with {focus} focused)", page=page)
        assert count_since(page, mark, "software E-STOP sent") == 1, f"one Esc, more than one E-STOP:\n{log_text(page)}"
        if focus == "editor":
            mark = log_mark(page)
            page.keyboard.press("End")
            page.keyboard.type(" #x")
            # the editor shows it once the server has echoed the edit (no fixed instant)
            wait_until(lambda: " #x" in page.locator("[data-testid=editor] .cm-content").inner_text(), 30,
                       what="Space typed in the editor", page=page)
            page.wait_for_timeout(300)
            assert count_since(page, mark, "sent Stop") == 0, "Space in the editor sent Stop"
            show_tab(page, "tab-jog")
        recover(page)


# ---- Space is STOP in a text field while something moves (issue 15, keys) ----

EDITOR = "[data-testid=editor] .cm-content"


def _editor_text(page) -> str:
    return page.evaluate("() => window.pkEditorText ? window.pkEditorText() : null") or ""


def _step_mode(page):
    """Step mode with the J1 step at :data:`STEP_DEG`; returns the step field.  The settings
    reach the server before the jog button's press (one socket, in order): no wait here;
    :func:`_wait_step_moving` checks the step that was sent."""
    show_tab(page, "tab-jog")
    page.get_by_test_id("jog-mode").get_by_text("Step").click()
    step_input = page.locator("label.q-field", has_text="step °").locator("input")
    step_input.fill(str(STEP_DEG))
    step_input.press("Tab")
    return step_input


def _wait_step_moving(page, mark: list[str], start: float) -> None:
    """The J1 − button was clicked: the step of :data:`STEP_DEG` was sent and J1 moves."""
    wait_until(lambda: count_since(page, mark, "sent step J1") == 1, 30, what="the J1 step sent", page=page)
    assert count_since(page, mark, f"sent step J1 -{STEP_DEG}°") == 1, \
        f"not the {STEP_DEG}° step:\n{log_text(page)}"
    wait_until(lambda: number(page, "angle-1") < start - 0.3 and state(page) == "MOVING", 30,
               what="the J1 step moving", page=page)


def _wait_space_stopped_the_step(page, mark: list[str], start: float) -> None:
    """Space was pressed while the J1 step ran: STOP sent once, and the robot at rest well
    before the step's end."""
    wait_until(lambda: count_since(page, mark, "sent Stop") >= 1, 30, what="Space sent Stop", page=page)
    end = at_rest(page, "angle-1")
    assert count_since(page, mark, "sent Stop") == 1, f"one Space, more than one Stop:\n{log_text(page)}"
    assert end > start - (STEP_DEG - 1), \
        f"the {STEP_DEG}° step was not stopped: J1 {start} -> {end}\n{log_text(page)}"


def test_space_in_a_text_input_while_a_step_move_runs_stops_the_robot(kpage):
    """Failed on the old page: Space in a text field always typed a space there, so with the
    program name field focused the J1 step ran to completion and no STOP was sent.  The step
    is 45° at 1 % speed: long enough to still run after the tab switch and the click on a
    loaded machine."""
    page = kpage
    wait_ready(page)
    step_input = _step_mode(page)
    name = page.get_by_test_id("prog-name")
    try:
        with slowest_jog(page):
            start = at_rest(page, "angle-1")
            mark = log_mark(page)
            page.get_by_test_id("jog-j1-").click()
            _wait_step_moving(page, mark, start)
            show_tab(page, "tab-program")
            name.click()
            before = name.input_value()
            assert state(page) == "MOVING", f"the step ended before Space could be pressed: {state(page)}"
            page.keyboard.press("Space")
            _wait_space_stopped_the_step(page, mark, start)
            assert name.input_value() == before, "Space typed into the name field while the robot moved"
    finally:
        show_tab(page, "tab-jog")
        step_input.fill("5")
        step_input.press("Tab")
        page.get_by_test_id("jog-mode").get_by_text("Continuous").click()
    recover(page)


LONG = "Begin()\nDelay(120)\nEnd()\n"


def _editor_with_long_program(page) -> None:
    """The Program tab, the editor focused with a 120 s program, its status "✓ program OK" (the
    tests stop it; it must still be running after their waits of up to 30 s on a slow machine:
    a 30 s program could end before Space was pressed).  The tab is shown once its panel alone
    is in the page (:func:`show_tab`): a click on the editor while the panels still slid was
    caught by the leaving panel, and the editor was re-created under it (two CPU hogs)."""
    show_tab(page, "tab-program")
    page.locator(EDITOR).click()
    page.keyboard.press("Control+A")
    page.keyboard.press("Delete")
    page.keyboard.insert_text(LONG)
    wait_until(lambda: _editor_text(page) == LONG, 30, what="the program typed", page=page)
    page.get_by_test_id("prog-check").click()
    wait_until(lambda: page.get_by_test_id("prog-status").inner_text() == "✓ program OK", 30,
               what="the program checked", page=page)
    page.locator(EDITOR).click()
    page.keyboard.press("Control+End")


def test_space_in_the_editor_right_after_run_stops_the_program(kpage):
    """Run pressed without taking the focus from the editor (as a second tab would) and Space
    at once, in the editor: the program ends "stopped" and STOP is sent.  Failed on the old
    page: the editor was still editable (the server makes it read-only once the run begins),
    so Space typed a space there, no STOP was sent and the program ran on."""
    page = kpage
    wait_ready(page)
    _editor_with_long_program(page)
    mark = log_mark(page)
    page.get_by_test_id("prog-run").dispatch_event("click")  # the editor keeps the focus
    page.keyboard.press("Space")
    status = page.get_by_test_id("prog-status")
    wait_until(lambda: "stopped" in status.inner_text(), 30, what="the program stopped by Space", page=page)
    # the log and the status line are separate parts of the page: the Stop's entry is waited for
    wait_until(lambda: count_since(page, mark, "sent Stop") >= 1, 30, what="Space sent Stop", page=page)
    page.wait_for_timeout(1000)
    assert "stopped" in status.inner_text() and "running" not in status.inner_text(), status.inner_text()
    wait_until(lambda: moving_attr(page) == "0", 30, what="nothing moves", page=page)
    assert count_since(page, mark, "sent Stop") == 1, f"one Space, more than one Stop:\n{log_text(page)}"
    show_tab(page, "tab-jog")
    recover(page)


def test_space_in_the_editor_while_a_program_runs_stops_it(kpage):
    """A program started while the editor has the focus: once it runs, Space stops it
    ("stopped", STOP sent) and types nothing.  (It passed on the old page too: a running
    program's editor is not editable, so the old page did not take it for a text field.)"""
    page = kpage
    wait_ready(page)
    _editor_with_long_program(page)
    mark = log_mark(page)
    page.get_by_test_id("prog-run").dispatch_event("click")  # the editor keeps the focus
    wait_until(lambda: "running" in page.get_by_test_id("prog-status").inner_text(), 30,
               what="the program running", page=page)
    wait_until(lambda: moving_attr(page) == "1", 30, what="the page told that something moves", page=page)
    in_editor = page.evaluate("() => !!document.activeElement.closest('[data-testid=editor]')")
    page.keyboard.press("Space")
    wait_until(lambda: "stopped" in page.get_by_test_id("prog-status").inner_text(), 30,
               what=f"the program stopped by Space (focus in the editor: {in_editor})", page=page)
    # the log and the status line are separate parts of the page: the Stop's entry is waited for
    wait_until(lambda: count_since(page, mark, "sent Stop") >= 1, 30, what="Space sent Stop", page=page)
    wait_until(lambda: moving_attr(page) == "0", 30, what="nothing moves", page=page)
    assert count_since(page, mark, "sent Stop") == 1, f"one Space, more than one Stop:\n{log_text(page)}"
    assert _editor_text(page) == LONG, "Space typed into the running program"
    show_tab(page, "tab-jog")
    recover(page)


def test_space_in_the_editor_while_nothing_moves_types_a_space(kpage):
    """The other half of the rule (it passed on the old page too, which always typed): with
    the robot idle and no program running, Space in the editor types a space and sends no
    STOP, although the page now tells the server about it."""
    page = kpage
    wait_ready(page)
    show_tab(page, "tab-program")
    wait_until(lambda: moving_attr(page) == "0", 30, what="nothing moves", page=page)
    content = page.locator(EDITOR)
    content.click()
    page.keyboard.press("Control+End")
    mark = log_mark(page)
    page.keyboard.type("# a b")
    wait_until(lambda: _editor_text(page).endswith("# a b"), 30, what="the spaces typed", page=page)
    page.wait_for_timeout(800)  # a STOP would be logged by now
    assert count_since(page, mark, "sent Stop") == 0, "Space in the editor sent Stop while nothing moved"
    assert _editor_text(page).endswith("# a b")
    show_tab(page, "tab-jog")
