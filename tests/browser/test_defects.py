"""The rest of the defects found (issue 26 item 8), in a real Chromium against a real controller
(``parolkit serve --sim`` and ``parolkit gui --connect`` to it; what the robot did is asked of
the controller itself): OUT1 / OUT2 drawn in the state they are in, each gripper slider's
label above its own slider, Enter on a focused jog button, tab names without an icon's
ligature text, ``t=`` on an error-marked line at >= 4.5:1, axe-core clean right after leaving
the Program tab, no implausible-frame warning at a connection, and no joint angle outside the
limits shown while the board homes.

Each fails on the page before this change: HIGH was always the filled button; each gripper
label sat under its slider, above the next one; Enter on a jog button did nothing; the tabs
read "open_with Jog"; ``t=`` was #0f766e on the error line's red tint (4.3:1); axe-core found
the leaving editor's scroller (scrollable-region-focusable) for 1-3 s; the homing showed J2
+55.1° and J4 -143.4° (the board's counters, which count from the limit switches then).
"""

from __future__ import annotations

import os
import re
import signal
import time

import pytest
from tests.browser.helpers import (
    axe_report,
    axe_violations,
    box,
    count_since,
    log_mark,
    log_since,
    log_text,
    show_tab,
    state,
    text,
    wait_linked,
    wait_ready,
    wait_until,
)
from tests.browser.screens_helpers import (
    controller_at_rest,
    controller_status,
    parse_rgb,
    text_contrast,
)

from parolkit.robot import PAROL6

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture(scope="module")
def page(browser, controller_gui):
    """One 1280 x 900 page on the controller, linked, the robot homed and idle."""
    pg = browser.new_page(viewport={"width": 1280, "height": 900})
    pg.goto(controller_gui["url"])
    wait_linked(pg)
    wait_ready(pg, 60)
    yield pg
    pg.close()


def _outputs(controller) -> tuple[int, int]:
    io = controller_status(controller)["io"]
    return int(io["out1"]), int(io["out2"])


def _filled(page, testid: str) -> bool:
    """The button is drawn filled (an opaque background), not outlined."""
    bg = parse_rgb(page.get_by_test_id(testid).evaluate("(e) => getComputedStyle(e).backgroundColor"))
    return bg[3] > 0.5


def _shows(page, n: int, level: str) -> bool:
    other = "low" if level == "high" else "high"
    return (page.get_by_test_id(f"out{n}-{level}").get_attribute("aria-pressed") == "true"
            and page.get_by_test_id(f"out{n}-{other}").get_attribute("aria-pressed") == "false"
            and _filled(page, f"out{n}-{level}") and not _filled(page, f"out{n}-{other}")
            and text(page, f"out{n}-state") == f"is {level.upper()}")


def test_the_outputs_are_drawn_in_the_state_they_are_in(page, controller_gui):
    controller = controller_gui["controller"]
    show_tab(page, "tab-gripper")
    try:
        assert _outputs(controller) == (0, 0)
        wait_until(lambda: _shows(page, 1, "low") and _shows(page, 2, "low"), 15, what="both outputs LOW", page=page)
        page.get_by_test_id("out1-high").click()
        wait_until(lambda: _outputs(controller) == (1, 0), 15, what="OUT1 HIGH at the controller", page=page)
        wait_until(lambda: _shows(page, 1, "high"), 15, what="OUT1 drawn HIGH", page=page)
        assert _shows(page, 2, "low")  # OUT2 untouched, still drawn LOW
        page.get_by_test_id("out1-low").click()
        wait_until(lambda: _outputs(controller) == (0, 0), 15, what="OUT1 LOW at the controller", page=page)
        wait_until(lambda: _shows(page, 1, "low"), 15, what="OUT1 drawn LOW again", page=page)
    finally:
        show_tab(page, "tab-jog")


def test_each_gripper_slider_has_its_label_above_it(page):
    show_tab(page, "tab-gripper")
    try:
        names = ("position", "speed", "current")
        sliders = {n: box(page, f"grip-{'pos' if n == 'position' else n}") for n in names}
        for i, name in enumerate(names):
            label, slider = box(page, f"grip-{name}-label"), sliders[name]
            assert text(page, f"grip-{name}-label").startswith(name)
            assert label["y"] + label["height"] <= slider["y"] + 1, f"{name}'s label is not above its slider"
            gap_own = slider["y"] - (label["y"] + label["height"])
            if i > 0:  # nearer its own slider than the one above it
                prev = sliders[names[i - 1]]
                assert gap_own < label["y"] - (prev["y"] + prev["height"]), (name, label, slider, prev)
        # the label follows its own slider
        before = text(page, "grip-speed-label")
        page.locator("[data-testid=grip-speed] .q-slider__track-container").focus()
        page.keyboard.press("ArrowRight")
        wait_until(lambda: text(page, "grip-speed-label") != before, 10, what="the speed label following", page=page)
        assert int(re.search(r"\d+", text(page, "grip-speed-label")).group()) == \
            int(re.search(r"\d+", before).group()) + 1  # type: ignore[union-attr]
        page.keyboard.press("ArrowLeft")
    finally:
        page.evaluate("() => document.activeElement && document.activeElement.blur()")
        show_tab(page, "tab-jog")


def test_enter_on_a_focused_jog_button_moves_one_step(page, controller_gui):
    controller = controller_gui["controller"]
    show_tab(page, "tab-jog")
    step = float(page.get_by_test_id("step-deg").input_value())
    before = controller_at_rest(controller)["angles"]
    page.get_by_test_id("jog-j2-").focus()
    page.keyboard.press("Enter")
    wait_until(lambda: abs(controller_status(controller)["angles"][1] - before[1]) > 0.5, 20,
               what="J2 stepping at the controller", page=page)
    after = controller_at_rest(controller)["angles"]
    assert after[1] - before[1] == pytest.approx(-step, abs=0.01), (before, after)
    assert after[0] == pytest.approx(before[0], abs=0.01) and after[2:] == pytest.approx(before[2:], abs=0.01)
    page.keyboard.press("Enter")  # the focus stayed: Enter again, one more step
    wait_until(lambda: abs(controller_status(controller)["angles"][1] - after[1]) > 0.5, 20,
               what="the second step", page=page)
    assert controller_at_rest(controller)["angles"][1] == pytest.approx(before[1] - 2 * step, abs=0.01)
    page.get_by_test_id("jog-j2+").focus()
    for k in (1, 0):  # each step from where the last one ended
        page.keyboard.press("Enter")
        wait_until(lambda k=k: controller_status(controller)["angles"][1] > before[1] - (k + 1) * step + 0.5, 20,
                   what="the step back", page=page)
        assert controller_at_rest(controller)["angles"][1] == pytest.approx(before[1] - k * step, abs=0.01)
    page.evaluate("() => document.activeElement && document.activeElement.blur()")


def test_tab_names_are_their_labels_and_the_icons_are_drawn(page):
    for testid, label in (("tab-jog", "Jog"), ("tab-gripper", "IO · Gripper"), ("tab-program", "Program"),
                          ("tab-record", "Record")):
        tab = page.get_by_test_id(testid)
        assert tab.inner_text().strip() == label
        assert tab.evaluate("(e) => e.textContent.replace(/\\s+/g, ' ').trim()") == label
        assert page.get_by_role("tab", name=label, exact=True).count() == 1
        icon = tab.locator(".pk-tab-icon")
        glyph = icon.evaluate("""(e) => { const s = getComputedStyle(e, '::before');
            return [s.content, s.fontFamily, e.getBoundingClientRect().width, e.getAttribute('aria-hidden')]; }""")
        assert glyph[0].strip('"') == icon.get_attribute("data-icon") and "Material Icons" in glyph[1], glyph
        assert 12 <= glyph[2] <= 30, f"{testid}'s icon is {glyph[2]} px wide: not drawn as one glyph"
        assert glyph[3] == "true"


def test_a_parameter_on_an_error_marked_line_is_readable(page):
    show_tab(page, "tab-program")
    content = page.locator("[data-testid=editor] .cm-content")
    try:
        content.click()
        page.keyboard.press("Control+A")
        page.keyboard.press("Delete")
        page.keyboard.insert_text("Begin()\nMoveJoint(500, -90, 180, 0, 0, 180, t=2)\nEnd()\n")
        param = page.locator(".cm-line.rbt-error .rbt-param").first
        wait_until(lambda: param.count() == 1, 20, what="the error-marked line with its t=", page=page)
        assert param.inner_text().startswith("t")
        ratio = text_contrast(param)
        assert ratio >= 4.5, f"t= on the error line at {ratio:.2f}:1"
    finally:
        content.click()
        page.keyboard.press("Control+A")
        page.keyboard.press("Delete")
        page.keyboard.insert_text("Begin()\nEnd()\n")
        show_tab(page, "tab-jog")


def test_axe_finds_nothing_while_and_right_after_leaving_the_program_tab(page, axe_js):
    show_tab(page, "tab-program")
    page.locator("[data-testid=editor] .cm-scroller").wait_for(state="visible", timeout=15000)
    page.get_by_test_id("tab-jog").click()
    # the Program panel leaves at once (no sliding panel kept in the page)
    wait_until(lambda: page.get_by_test_id("tab-jog").get_attribute("aria-selected") == "true", 15,
               what="Jog selected", page=page)
    runs = []
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline or len(runs) < 3:
        panels = page.evaluate("() => document.querySelectorAll('.q-tab-panel').length")
        editor = page.locator("[data-testid=editor]").count()
        runs.append((panels, editor, axe_violations(page, axe_js)))
    bad = [(p, e, axe_report(v)) for p, e, v in runs if p != 1 or e or v]
    assert not bad, f"{len(bad)} of {len(runs)} looks after leaving the Program tab: {bad[:2]}"


def test_a_connection_logs_no_implausible_frames(page, controller_gui):
    """The commander linking to the controller (at its start, and again after the controller
    stood still for 2 s: link lost, link up) reports no implausible status frames: the
    simulator sends none, and what a controller counted before a connection is not news."""
    controller = controller_gui["controller"]
    assert "implausible" not in log_text(page)
    assert controller_status(controller)["integrity"]["implausible"] == 0
    mark = log_mark(page)
    os.kill(controller.proc.pid, signal.SIGSTOP)
    try:
        wait_until(lambda: "NO LINK" in text(page, "link-chip"), 20, what="the link lost", page=page)
    finally:
        os.kill(controller.proc.pid, signal.SIGCONT)
    wait_linked(page, 30)
    wait_until(lambda: count_since(page, mark, "controller link up") == 1, 15, what="the link-up line", page=page)
    ticks = controller.loop_stats()["frames_sent"]
    # 200 frames (2 s of the controller's ticks) after the link came up: a count would show
    wait_until(lambda: controller.loop_stats().get("frames_sent", 0) >= ticks + 200, 60, what="200 more frames")
    page.wait_for_timeout(500)  # the page's log follows every 0.1 s
    assert count_since(page, mark, "implausible") == 0, log_since(page, mark)
    assert controller_status(controller)["integrity"]["implausible"] == 0
    wait_ready(page, 60)


def _limits_ok(values: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """The (joint, text) pairs whose number lies outside that joint's limits."""
    out = []
    for j, shown in values:
        m = re.search(r"[-+]?\d+(?:\.\d+)?", shown)
        if m is None:
            continue
        lo, hi = PAROL6.limits_deg[j]
        if not lo - 0.01 <= float(m.group()) <= hi + 0.01:
            out.append((j, shown))
    return out


def test_homing_shows_no_joint_angle_outside_the_limits(page, controller_gui):
    controller = controller_gui["controller"]
    show_tab(page, "tab-jog")
    # every text the joint readouts (the card's and the jog panel's), the pose and the 3D
    # view's line show from here on
    page.evaluate("""() => { window.pkSeen = [];
        const watch = (e, id) => new MutationObserver(() => window.pkSeen.push([id, e.textContent]))
            .observe(e, {childList: true, characterData: true, subtree: true});
        for (let j = 1; j <= 6; j++) { for (const id of [`angle-${j}`, `jog-angle-${j}`])
            watch(document.querySelector(`[data-testid=${id}]`), id); }
        watch(document.querySelector('[data-testid=pose-y]'), 'pose-y');
        watch(document.querySelector('[aria-label="3D view"] .pk-title').parentElement, 'view'); }""")
    page.get_by_test_id("btn-home").click()
    homing: list[list[float]] = []
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        st = controller_status(controller)
        if st["state"] == "HOMING":
            homing.append(st["angles"])
        elif homing and st["state"] == "IDLE":
            break
    assert homing, "the controller was never seen homing"
    # the board's counters do leave the limits while it homes (as the firmware's do)
    counted = [(j, f"{a[j]:+.3f}") for a in homing for j in range(6)]
    assert _limits_ok(counted), "the homing this test watched never counted outside the limits"
    wait_ready(page, 60)
    seen = page.evaluate("() => window.pkSeen")
    shown = [(int(i[-1]) - 1, t) for i, t in seen if re.fullmatch(r"(jog-)?angle-\d", i)]
    assert _limits_ok(shown) == [], f"joint angles outside the limits shown while homing: {_limits_ok(shown)}"
    assert any("homing" in t for i, t in seen if i == "angle-2"), "the readout never said it is homing"
    assert any(t.strip() == "—" for i, t in seen if i == "pose-y"), "the TCP pose was shown while homing"
    assert any("homing" in t for i, t in seen if i == "view"), "the 3D view never said it is homing"
    assert text(page, "angle-2").startswith("-90.0")  # and the standby pose after it
    assert state(page) == "READY"
