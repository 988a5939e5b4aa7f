"""The commander in a real headless Chromium against ``parolkit gui --sim``.

One GUI process and one page for the module; the tests run in file order (each leaves the
robot enabled, homed and idle for the next).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
from playwright.sync_api import expect
from tests.browser import helpers
from tests.browser.helpers import number, state, text

pytestmark = [pytest.mark.browser, pytest.mark.slow]

REPO_ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO_ROOT / "test-artifacts" / "browser"
# `make screenshot` (PAROLKIT_UPDATE_SCREENSHOT=1) writes the README's screenshot; a plain
# `make test` writes it under test-artifacts/ so a test run never modifies tracked files
README_IMAGE = (
    REPO_ROOT / "docs" / "images" / "commander.png"
    if os.environ.get("PAROLKIT_UPDATE_SCREENSHOT") == "1"
    else ARTIFACTS / "commander.png"
)


_PAGE = None  # the module's page, for the GUI log in failure messages


def wait_until(predicate, timeout: float = 15.0, interval: float = 0.1, what: str = "condition"):
    return helpers.wait_until(predicate, timeout, interval, what, page=_PAGE)


def wait_ready(page, timeout: float = 30.0) -> None:
    helpers.wait_ready(page, timeout)


def hold(page, testid: str, seconds: float) -> None:
    """Press and hold a jog button with the mouse; the GUI marks a held button (pk-held)."""
    button = page.get_by_test_id(testid)
    button.hover()
    page.mouse.down()
    try:
        wait_until(lambda: page.locator(f"[data-testid='{testid}'].pk-held").count() > 0, 12,
                   what=f"{testid} held")
        page.wait_for_timeout(int(seconds * 1000))
    finally:
        page.mouse.up()


def settled(page, testid: str, timeout: float = 8.0) -> float:
    """The readout once it stopped changing; fails if it keeps changing for ``timeout`` s
    (i.e. the robot did not stop)."""
    return helpers.settled(page, testid, timeout)


def test_page_loads_links_and_has_no_console_errors(page):
    global _PAGE
    _PAGE = page
    wait_until(lambda: "LINKED" in text(page, "link-chip"), 30, what="link up")
    wait_ready(page)
    assert "SIMULATOR" in text(page, "mode-chip")
    wait_until(lambda: re.search(r"\d", text(page, "angle-1")), 10, what="joint readout")
    assert number(page, "angle-1") == pytest.approx(90.0, abs=0.5)
    assert page.console_errors == []


def test_3d_view_is_rendered_and_not_blank(page):
    from PIL import Image, ImageStat

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    shot = ARTIFACTS / "scene.png"

    def variance() -> float:
        # a software-rendered canvas on a busy machine may need a few frames: retry
        page.locator("[data-testid=scene] canvas").first.screenshot(path=str(shot))
        img = Image.open(shot).convert("L")
        assert img.size[0] > 300, img.size
        return ImageStat.Stat(img).var[0]

    var = wait_until(lambda: (v := variance()) > 50.0 and v, 20, interval=0.5, what="a non-blank 3D view")
    assert var > 50.0, f"3D view looks blank (variance {var:.1f})"
    README_IMAGE.parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(README_IMAGE), full_page=True)  # the README's screenshot


def test_joint_jog_hold_moves_and_release_stops(page):
    wait_ready(page)
    before = settled(page, "angle-1")
    hold(page, "jog-j1+", 1.2)
    after = settled(page, "angle-1")  # release stops the joint
    assert after > before + 1.0, f"J1 did not move up: {before} -> {after}; log:\n{text(page, 'log')}"
    before3 = settled(page, "angle-3")
    hold(page, "jog-j3-", 1.0)
    after3 = settled(page, "angle-3")
    assert after3 < before3 - 0.5, f"J3 did not move down: {before3} -> {after3}; log:\n{text(page, 'log')}"


def test_cartesian_jog_in_wrf_and_trf_rotation(page):
    wait_ready(page)
    z0 = settled(page, "pose-z")
    hold(page, "jog-z+", 1.2)
    assert settled(page, "pose-z") > z0 + 2.0
    page.get_by_test_id("frame-toggle").get_by_text("TRF").click()
    wait_ready(page)
    before = [number(page, f"pose-{k}") for k in ("rx", "ry", "rz")]
    hold(page, "jog-rz+", 1.2)
    settled(page, "pose-rz")
    after = [number(page, f"pose-{k}") for k in ("rx", "ry", "rz")]
    assert max(abs(a - b) for a, b in zip(after, before)) > 1.0, f"TRF RZ did not rotate: {before} -> {after}"
    page.get_by_test_id("frame-toggle").get_by_text("WRF").click()
    page.wait_for_timeout(800)
    page.screenshot(path=str(README_IMAGE), full_page=True)  # the README's screenshot, arm moved


def test_home_returns_to_standby(page):
    page.get_by_test_id("btn-home").click()
    wait_until(lambda: state(page) == "READY" and abs(number(page, "angle-1") - 90.0) < 0.1, 40, what="homed standby")


def test_estop_latches_until_enable(page):
    page.get_by_test_id("btn-estop").click()
    wait_until(lambda: state(page) == "E-STOP", 10, what="E-STOP state")
    assert "LATCHED" in text(page, "btn-estop")
    assert page.get_by_test_id("jog-j1+").is_disabled()
    page.get_by_test_id("btn-enable").click()
    wait_ready(page, 20)
    assert "LATCHED" not in text(page, "btn-estop")


def test_keyboard_jogs_and_escape_is_estop(page):
    wait_ready(page)
    page.get_by_test_id("help-button").click()
    title = page.get_by_text("Keyboard shortcuts", exact=True)
    try:
        title.wait_for(timeout=15000)
        assert page.get_by_text("E-STOP (software stop, latched until Enable)").is_visible()
        page.keyboard.press("Escape")  # closes the dialog only (tests/browser/test_keys.py)
        title.wait_for(state="hidden", timeout=15000)
    finally:
        if title.is_visible():  # never leave the dialog over the page for the next tests
            page.get_by_test_id("help-close").click()
    # the page takes Esc for the dialog while the dialog is in the page at all, its fade-out
    # included (commander.js, OVERLAYS): a fresh clone at load 10 pressed it there, after the
    # title was hidden, and the page rightly only went on closing the dialog
    wait_until(lambda: page.evaluate("() => document.querySelector('.q-dialog') === null"), 15,
               what="the help dialog gone from the page")
    page.keyboard.press("Escape")  # no dialog open: E-STOP
    wait_until(lambda: state(page) == "E-STOP", 15, what="E-STOP from the Esc key")
    page.get_by_test_id("btn-enable").click()
    wait_ready(page, 20)
    page.mouse.click(5, 5)  # focus the page, not an input
    before = settled(page, "angle-2")
    page.keyboard.down("w")  # J2 +
    page.wait_for_timeout(1200)
    page.keyboard.up("w")
    after = settled(page, "angle-2")
    assert after > before + 1.0, f"key W did not jog J2 up: {before} -> {after}"


def test_outputs_toggle_and_io_readout_follows(page):
    page.get_by_test_id("tab-gripper").click()
    page.get_by_test_id("out1-high").click()
    wait_until(lambda: "HIGH" in text(page, "io-out1"), 10, what="OUT1 HIGH")
    page.get_by_test_id("out1-low").click()
    wait_until(lambda: "LOW" in text(page, "io-out1"), 10, what="OUT1 LOW")
    page.get_by_test_id("out2-high").click()
    wait_until(lambda: "HIGH" in text(page, "io-out2"), 10, what="OUT2 HIGH")
    page.get_by_test_id("out2-low").click()
    wait_until(lambda: "LOW" in text(page, "io-out2"), 10, what="OUT2 LOW")


def test_gripper_calibrate_and_move_changes_readout(page):
    page.get_by_test_id("grip-cal").click()
    wait_until(lambda: re.search(r"(?<!not )calibrated", text(page, "grip-readout")), 20, what="gripper calibrated")
    before = number(page, "grip-readout")
    page.get_by_test_id("grip-move").click()  # the position slider starts at 100
    wait_until(lambda: abs(number(page, "grip-readout") - 100) <= 3, 20, what="gripper at 100")
    assert before != number(page, "grip-readout") or before == 100


def _type_program(page, program: str) -> None:
    page.get_by_test_id("tab-program").click()
    content = page.locator("[data-testid=editor] .cm-content")
    # the page is shared by this module's tests: a program an earlier test left running keeps
    # the editor read-only (it shows the running program), and typing would change nothing
    page.get_by_test_id("prog-stop").click()
    expect(content).to_have_attribute("contenteditable", "true", timeout=10000)
    content.click()
    page.keyboard.press("Control+A")
    page.keyboard.press("Delete")
    page.keyboard.insert_text(program)
    page.wait_for_timeout(300)


def test_seed_program_runs_with_lines_highlighted(page):
    wait_ready(page)
    _type_program(page, "Begin()\nOutput(1,HIGH)\nDelay(1)\nOutput(1,LOW)\nDelay(1)\nLoop()\n")
    page.get_by_test_id("prog-run").click()
    seen_lines = set()

    def highlighted():
        line = page.evaluate("() => [...document.querySelectorAll('[data-testid=editor] .cm-line')]"
                             ".findIndex(e => e.classList.contains('rbt-current')) + 1")
        if line:
            seen_lines.add(line)
        return len(seen_lines) >= 2

    try:
        wait_until(highlighted, 20, what="two different executing lines highlighted")
    except AssertionError as exc:
        raise AssertionError(f"{exc}; status {text(page, 'prog-status')!r}; log:\n{text(page, 'log')}") from None
    wait_until(lambda: "HIGH" in text(page, "io-out1"), 10, what="program sets OUT1")
    wait_until(lambda: "LOW" in text(page, "io-out1"), 10, what="program clears OUT1")
    # only lines that run: Begin() is announced as each pass starts (a busy page can catch it),
    # Loop() is not (the interpreter goes back to Begin()), nor is the empty last line
    assert seen_lines <= {1, 2, 3, 4, 5}, seen_lines
    page.get_by_test_id("prog-stop").click()
    wait_until(lambda: page.locator(".cm-line.rbt-current").count() == 0, 10, what="highlight cleared on stop")


def test_broken_program_shows_error_at_its_line(page):
    _type_program(page, "Begin()\nDelay(1)\nMoveJoint(90,-90,180,0,0\nEnd()\n")
    page.get_by_test_id("prog-check").click()
    # diagnostics also come as you type: one made for a text still being typed may show first
    # (a stale "line 4"); the program's own diagnostic replaces it
    diag = page.get_by_test_id("diagnostic").first
    expect(diag).to_have_text(re.compile(r"^\S+\.rbt: Line 3 is missing its closing '\)'"), timeout=10000)
    err = page.locator(".cm-line.rbt-error")
    expect(err).to_have_count(1, timeout=10000)
    assert err.first.inner_text().startswith("MoveJoint")
    assert page.console_errors == []
