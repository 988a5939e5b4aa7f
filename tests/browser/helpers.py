"""Helpers of the browser tests: waiting on a condition, reading the page's readouts and log,
screenshots, layout boxes.  Timing comes from what the page shows (readouts, the event log),
never from fixed sleeps alone: the machine is shared and slow at times."""

from __future__ import annotations

import math
import os
import re
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO_ROOT / "test-artifacts" / "browser"
#: axe-core from npm, installed by scripts/ensure-axe.sh (make test runs it)
AXE_JS = REPO_ROOT / "build" / "npm" / "node_modules" / "axe-core" / "axe.min.js"

#: the axe-core rule sets the tests run
AXE_TAGS = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa", "best-practice"]


def axe_violations(page, axe_js: str) -> list[dict]:
    """axe-core's serious and critical violations of the page as it is now."""
    if not page.evaluate("() => typeof window.axe !== 'undefined'"):
        page.add_script_tag(content=axe_js)
    result = page.evaluate("""async (tags) => {
        const r = await axe.run(document, {runOnly: {type: 'tag', values: tags}, resultTypes: ['violations']});
        return r.violations.map(v => ({id: v.id, impact: v.impact, help: v.help,
                                       nodes: v.nodes.slice(0, 6).map(n => n.target.join(' ') + ' :: '
                                              + (n.failureSummary || '').replace(/\\s+/g, ' ').slice(0, 160))}));
    }""", AXE_TAGS)
    return [v for v in result if v["impact"] in ("serious", "critical")]


def axe_report(violations: list[dict]) -> str:
    return "\n".join(f"{v['impact']} {v['id']}: {v['help']}\n    " + "\n    ".join(v["nodes"]) for v in violations)


def image_path(name: str) -> Path:
    """Where a documentation screenshot goes: docs/images under `make screenshot`
    (PAROLKIT_UPDATE_SCREENSHOT=1), else test-artifacts (a test run never changes tracked files)."""
    folder = REPO_ROOT / "docs" / "images" if os.environ.get("PAROLKIT_UPDATE_SCREENSHOT") == "1" else ARTIFACTS
    folder.mkdir(parents=True, exist_ok=True)
    return folder / name


def wait_until(predicate, timeout: float = 15.0, interval: float = 0.1, what: str = "condition", page=None):
    deadline = time.monotonic() + timeout
    last = None
    while time.monotonic() < deadline:
        last = predicate()
        if last:
            return last
        time.sleep(interval)
    log = ""
    if page is not None:
        try:
            log = "\nGUI log (newest first):\n" + log_text(page)
        except Exception as exc:  # the page may be gone
            log = f"\n(GUI log unavailable: {exc})"
    raise AssertionError(f"timed out after {timeout} s waiting for {what} (last value {last!r}){log}")


def text(page, testid: str) -> str:
    return page.get_by_test_id(testid).inner_text()


#: what a joint readout shows while the board homes (parolkit.gui.components.telemetry.HOMING_TEXT)
HOMING_TEXT = "homing…"


def number(page, testid: str) -> float:
    """The number a readout shows; NaN while the board homes (a joint readout says "homing…"
    then: the board's counters are not angles), so a wait for a value goes on waiting."""
    shown = text(page, testid)
    if shown.strip() in (HOMING_TEXT, "—") and testid.startswith(("angle-", "pose-", "jog-angle-", "jog-pose-")):
        return math.nan
    m = re.search(r"[-+]?\d+(?:\.\d+)?", shown)
    assert m, f"{testid} shows no number: {shown!r}"
    return float(m.group())


def state(page) -> str:
    return text(page, "state-chip").strip()


def log_text(page) -> str:
    return page.get_by_test_id("log").inner_text()


def log_lines(page) -> list[str]:
    """The event log, oldest first (the page shows the newest 80 entries, newest first)."""
    return [line for line in reversed(log_text(page).splitlines()) if line.strip()]


def log_mark(page) -> list[str]:
    """The event log as the page shows it now: the point :func:`log_since` counts from."""
    return log_lines(page)


def log_since(page, mark: list[str]) -> list[str]:
    """The log lines that came after ``mark`` (:func:`log_mark`), oldest first.  The log shown
    now continues the mark: its first lines are the mark's last ones (all of them until the
    page's 80 entries are full, fewer after: the oldest drop off), the lines after them are
    the new ones.  Each line carries its time to the millisecond, so the overlap is the
    mark's.  Fails if so many entries came that none of the mark's is shown any more."""
    now = log_lines(page)
    for new in range(len(now) + 1):
        kept = len(now) - new
        if kept <= len(mark) and now[:kept] == mark[len(mark) - kept:]:
            if kept == 0 and mark and now:
                raise AssertionError(f"the log scrolled past the mark: {len(now)} new lines or more\n"
                                     + log_text(page))
            return now[kept:]
    raise AssertionError("unreachable: no new line at all matches when the log shows nothing")


def count_since(page, mark: list[str], needle: str) -> int:
    """How many log lines that came after ``mark`` (:func:`log_mark`) contain ``needle``."""
    return sum(needle in line for line in log_since(page, mark))


def moving_attr(page) -> str | None:
    """The server's word on "something moves" (the robot, a program, a held jog): the
    data-moving attribute ("1" or "0") that commander.js reads at each key."""
    return page.locator(".pk-motion").get_attribute("data-moving")


def at_rest(page, testid: str, timeout: float = 60.0) -> float:
    """The readout ``testid`` once the robot is at rest, judged on what the server says: the
    state READY and nothing moving (data-moving 0); the readouts and the state come from the
    same status.  (:func:`settled` judges it on the readout holding still for 0.4 s, which a
    starved page can also do while the robot moves.)"""
    wait_until(lambda: state(page) == "READY" and moving_attr(page) == "0", timeout,
               what=f"the robot at rest (for {testid})", page=page)
    return number(page, testid)


#: true once one tab panel is in the page and no panel transition runs (Quasar keeps the panel
#: it leaves in the page until its slide ends)
_ONE_PANEL = """() => document.querySelectorAll('.q-tab-panel').length === 1
    && !document.querySelector('.q-tab-panels [class*="-leave-active"], .q-tab-panels [class*="-enter-active"]')"""


def show_tab(page, testid: str, timeout: float = 15.0) -> None:
    """Click the tab ``testid`` and wait until its panel alone is in the page: judged on the
    page's own state, not a fixed wait (on a loaded machine the slide took longer than 500 ms,
    and axe-core judged the program tab's editor while it was leaving)."""
    page.get_by_test_id(testid).click()
    wait_until(lambda: page.get_by_test_id(testid).get_attribute("aria-selected") == "true"
               and page.evaluate(_ONE_PANEL), timeout, what=f"{testid}'s panel alone in the page", page=page)


def wait_linked(page, timeout: float = 40.0) -> None:
    wait_until(lambda: "LINKED" in text(page, "link-chip"), timeout, what="link up", page=page)


def wait_ready(page, timeout: float = 40.0) -> None:
    wait_until(lambda: state(page) == "READY", timeout, what="state READY", page=page)


def settled(page, testid: str, timeout: float = 10.0) -> float:
    """The readout once it stopped changing (two reads 0.4 s apart agree)."""
    prev = number(page, testid)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        page.wait_for_timeout(400)
        cur = number(page, testid)
        if abs(cur - prev) < 0.02:
            return cur
        prev = cur
    raise AssertionError(f"{testid} still changing after {timeout} s ({prev})")


def box(page, testid: str) -> dict:
    b = page.get_by_test_id(testid).bounding_box()
    assert b is not None, f"{testid} is not rendered"
    return b


def inside_viewport(page, b: dict) -> bool:
    vw, vh = page.evaluate("() => [window.innerWidth, window.innerHeight]")
    return b["x"] >= 0 and b["y"] >= 0 and b["x"] + b["width"] <= vw + 0.5 and b["y"] + b["height"] <= vh + 0.5


def recover(page) -> None:
    """Leave the robot enabled, homed and idle for the next test: Enable (ends an E-STOP
    latch), then Home unless READY; and the gripper's error an E-stop leaves (it stays until the
    gripper is told to clear it, as on the board) cleared with Clear error."""
    grip = page.get_by_test_id("grip-compact")
    if grip.count() and "error" in grip.inner_text():
        if state(page) == "E-STOP":
            page.get_by_test_id("btn-enable").click()
            wait_until(lambda: state(page) != "E-STOP", 20, what="the E-stop latch ended", page=page)
        page.get_by_test_id("btn-clear").click()
        wait_until(lambda: "error" not in grip.inner_text(), 20, what="the gripper's error cleared", page=page)
    if state(page) == "READY":
        return
    page.get_by_test_id("btn-enable").click()
    try:
        wait_until(lambda: state(page) in ("READY", "NOT HOMED"), 20, what="enabled", page=page)
    except AssertionError:
        pass
    if state(page) != "READY":
        page.get_by_test_id("btn-home").click()
    wait_ready(page, 60)
