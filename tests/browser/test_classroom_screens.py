"""Screens of a classroom (issue 26 item 6), in a real Chromium against a real controller
(``parolkit serve --sim`` and ``parolkit gui --connect`` to it): a 1024x768 projector shows the
3D view and every jog button at once, without scrolling; a phone shows each joint's angle and
each TCP coordinate beside its jog buttons and a visible label on every header icon; a tap
leaves no tooltip behind; a short tap on a jog button moves one step (judged at the
controller's joints); greyed controls are plainly different; and with the controller stopped
the values left on the page are marked stale with their age.

Each fails on the page before this change: at 1024x768 the Jog tab began at y = 1066 (below the
readout card, one column); a phone's jog buttons had no value beside them and its header
buttons showed bare icons; a tap on a desktop browser's touch screen left the tooltip open; a
short tap jogged for as long as the finger happened to be down (0.37° once) instead of a step;
a greyed jog button was the same colour at 60 % opacity; nothing said the values were stale.
"""

from __future__ import annotations

import os
import re
import signal
import time

import pytest
from tests.browser.helpers import (
    box,
    count_since,
    log_mark,
    number,
    recover,
    show_tab,
    state,
    text,
    wait_linked,
    wait_ready,
    wait_until,
)
from tests.browser.screens_helpers import (
    JOG_BUTTONS,
    contrast,
    controller_at_rest,
    controller_status,
    in_viewport,
    text_contrast,
)

pytestmark = [pytest.mark.browser, pytest.mark.slow]

#: a phone that reports a touch screen but a desktop browser (Chrome's "desktop site", a
#: touch laptop): Quasar then shows tooltips on mouseenter, which a tap emulates
PHONE = {"viewport": {"width": 390, "height": 844}, "has_touch": True}
#: a phone that says it is one (its own user agent): Quasar's touch handling of tooltips
IPHONE_UA = ("Mozilla/5.0 (iPhone; CPU iPhone OS 17_0 like Mac OS X) AppleWebKit/605.1.15 "
             "(KHTML, like Gecko) Version/17.0 Mobile/15E148 Safari/604.1")


@pytest.fixture(scope="module")
def ready(browser, controller_gui):
    """The controller homed and idle, the GUI linked, before the pages of this module."""
    pg = browser.new_page(viewport={"width": 1280, "height": 800})
    pg.goto(controller_gui["url"])
    wait_linked(pg)
    wait_ready(pg, 60)
    pg.close()
    return controller_gui


def _open(browser, url: str, **context):
    ctx = browser.new_context(**context)
    page = ctx.new_page()
    page.goto(url)
    wait_linked(page)
    wait_ready(page, 60)
    wait_until(lambda: re.search(r"\d", text(page, "jog-angle-1")), 20, what="the jog panel's J1 value", page=page)
    return ctx, page


@pytest.mark.parametrize(("width", "height"), [(1024, 768), (1280, 720)], ids=["1024x768", "1280x720"])
def test_a_projector_shows_the_3d_view_and_every_jog_button_without_scrolling(ready, browser, width, height):
    ctx, page = _open(browser, ready["url"], viewport={"width": width, "height": height})
    try:
        page.evaluate("() => document.fonts.ready")
        assert page.evaluate("() => window.scrollY") == 0
        assert page.get_by_test_id("tab-jog").get_attribute("aria-selected") == "true"  # the page opens on Jog
        scene = box(page, "scene")
        assert in_viewport(page, scene) and scene["height"] >= 240, f"3D view {scene} not wholly in view"
        outside = {t: box(page, t) for t in JOG_BUTTONS if not in_viewport(page, box(page, t))}
        assert not outside, f"jog buttons outside the {width}x{height} screen: {outside}"
        # and beside each other, not over each other: the view left, the buttons right of it
        assert all(box(page, t)["x"] >= scene["x"] + scene["width"] for t in JOG_BUTTONS)
        assert in_viewport(page, box(page, "speed-slider"))
    finally:
        ctx.close()


def test_a_phone_shows_the_values_beside_the_jog_buttons_and_labels_its_header_icons(ready, browser):
    ctx, page = _open(browser, ready["url"], **PHONE)
    try:
        page.get_by_test_id("jog-j1+").scroll_into_view_if_needed()
        for j in range(1, 7):
            value, minus = box(page, f"jog-angle-{j}"), box(page, f"jog-j{j}-")
            # on the button's row (centres within a few px), left of it, wholly on the screen
            assert abs((value["y"] + value["height"] / 2) - (minus["y"] + minus["height"] / 2)) < 6, (j, value, minus)
            assert value["x"] + value["width"] <= minus["x"] + 0.5 and value["x"] >= 0
            assert number(page, f"jog-angle-{j}") == pytest.approx(number(page, f"angle-{j}"), abs=0.002)
        for axis in ("x", "y", "z", "rx", "ry", "rz"):
            value, minus = box(page, f"jog-pose-{axis}"), box(page, f"jog-{axis}-")
            assert abs((value["y"] + value["height"] / 2) - (minus["y"] + minus["height"] / 2)) < 6, (axis, value)
            assert value["x"] + value["width"] <= minus["x"] + 0.5 and value["x"] >= 0
            assert number(page, f"jog-pose-{axis}") == pytest.approx(number(page, f"pose-{axis}"), abs=0.01)
        clipped = page.evaluate("""() => [...document.querySelectorAll(
                '[data-testid^=jog-angle-], [data-testid^=jog-pose-]')]
            .filter(e => e.scrollWidth > e.clientWidth + 1).map(e => e.dataset.testid)""")
        assert clipped == [], f"values cut off: {clipped}"
        # every header icon button: a visible short label (no hover on a phone) and a name
        # that says the same
        page.evaluate("() => window.scrollTo(0, 0)")
        for testid in ("btn-home", "btn-enable", "btn-disable", "btn-clear", "btn-stop", "help-button"):
            button = page.get_by_test_id(testid)
            label = button.evaluate("""(b) => {
                const shown = [...b.querySelectorAll('.block, .pk-short')].filter(e => {
                    const r = e.getBoundingClientRect(), s = getComputedStyle(e);
                    return r.width > 8 && r.height > 6 && s.visibility !== 'hidden' && parseFloat(s.fontSize) >= 10; });
                return shown.map(e => e.innerText.trim()).join(' '); }""")
            name = button.get_attribute("aria-label") or ""
            assert label, f"{testid} shows no label on a phone"
            assert label.lower() in name.lower(), f"{testid}: label {label!r} is not in its name {name!r}"
            assert in_viewport(page, box(page, testid))
    finally:
        ctx.close()


#: tooltips open on the page (Quasar's are fixed: no offsetParent; judged by their box)
_TOOLTIPS = """() => [...document.querySelectorAll('.q-tooltip')].filter(t => {
    const r = t.getBoundingClientRect(); return r.width > 0 && r.height > 0; }).length"""


@pytest.mark.parametrize("context", [PHONE, dict(PHONE, is_mobile=True, user_agent=IPHONE_UA)],
                         ids=["desktop-browser-touch", "phone-browser"])
def test_a_tap_leaves_no_tooltip_open(ready, browser, context):
    ctx, page = _open(browser, ready["url"], **context)
    try:
        for testid in ("btn-stop", "grip-compact"):
            mark = log_mark(page)
            page.get_by_test_id(testid).tap()
            if testid == "btn-stop":  # the tap reached the server
                wait_until(lambda m=mark: count_since(page, m, "sent Stop") > 0, 15, what="the tap's Stop", page=page)
            page.wait_for_timeout(1000)  # a tooltip shown by the tap is open by now (no show delay)
            assert page.evaluate(_TOOLTIPS) == 0, f"a tooltip stays open after a tap on {testid}"
    finally:
        ctx.close()
    # the same page with a mouse does show the tooltip on hover (the check above can see one)
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    try:
        page.goto(ready["url"])
        wait_linked(page)
        page.get_by_test_id("btn-stop").hover()
        wait_until(lambda: page.evaluate(_TOOLTIPS) == 1, 10, what="the tooltip on a mouse hover", page=page)
        page.mouse.move(5, 600)
        wait_until(lambda: page.evaluate(_TOOLTIPS) == 0, 10, what="the tooltip gone with the mouse", page=page)
    finally:
        page.close()


def _touch(cdp, kind: str, x: float = 0.0, y: float = 0.0, at: float | None = None) -> None:
    """One touch event through Chromium's input pipeline; ``at``: the input's own time (s since
    the epoch; the events' timeStamp), as a real touch screen stamps it."""
    params: dict = {"type": kind, "touchPoints": [] if kind == "touchEnd" else [{"x": x, "y": y}]}
    if at is not None:
        params["timestamp"] = at
    cdp.send("Input.dispatchTouchEvent", params)


def test_a_short_tap_on_a_jog_button_moves_one_step_and_a_hold_still_jogs(ready, browser):
    controller = ready["controller"]
    ctx, page = _open(browser, ready["url"], **PHONE)
    try:
        assert page.get_by_test_id("jog-mode").get_by_role("button", name="Continuous") \
            .get_attribute("aria-pressed") == "true"
        step = float(page.get_by_test_id("step-deg").input_value())
        button = page.get_by_test_id("jog-j1+")
        button.scroll_into_view_if_needed()
        b = button.bounding_box()
        assert b is not None
        x, y = b["x"] + b["width"] / 2, b["y"] + b["height"] / 2
        cdp = ctx.new_cdp_session(page)
        # a finger down for 60 ms by the touch's own clock (however late a busy machine delivers
        # the two events): one step of J1, nothing else moves
        before = controller_at_rest(controller)["angles"]
        t = time.time()
        _touch(cdp, "touchStart", x, y, at=t)
        _touch(cdp, "touchEnd", at=t + 0.06)
        wait_until(lambda: abs(controller_status(controller)["angles"][0] - before[0]) > 0.5, 20,
                   what="the tap's step at the controller", page=page)
        after = controller_at_rest(controller)["angles"]
        assert after[0] - before[0] == pytest.approx(step, abs=0.01), (before, after)
        assert after[1:] == pytest.approx(before[1:], abs=0.01)
        # a mouse click on J1- is a tap too: one step back
        page.get_by_test_id("jog-j1-").click()
        wait_until(lambda: abs(controller_status(controller)["angles"][0] - after[0]) > 0.5, 20,
                   what="the click's step at the controller", page=page)
        back = controller_at_rest(controller)["angles"]
        assert back[0] == pytest.approx(before[0], abs=0.01)
        # held past the tap time it jogs for as long as it is held, and stops when lifted
        _touch(cdp, "touchStart", x, y)
        try:
            wait_until(lambda: controller_status(controller)["angles"][0] > back[0] + step + 1.0, 20,
                       what="J1 jogging under the held finger", page=page)
        finally:
            _touch(cdp, "touchEnd")
        rest = controller_at_rest(controller)["angles"]
        assert rest[0] > back[0] + step + 1.0  # further than a step: it was a jog
    finally:
        ctx.close()


def _mean_colour(locator, path) -> tuple[float, ...]:
    from PIL import Image, ImageStat

    locator.screenshot(path=str(path))
    return tuple(ImageStat.Stat(Image.open(path).convert("RGB")).mean)


def test_greyed_controls_are_plainly_different_and_still_legible(ready, browser, tmp_path):
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    try:
        page.goto(ready["url"])
        wait_linked(page)
        wait_ready(page, 60)
        button = page.get_by_test_id("jog-j2+")
        assert button.is_enabled()
        page.mouse.move(5, 700)  # no hover on it
        enabled = _mean_colour(button, tmp_path / "enabled.png")
        page.get_by_test_id("btn-estop").click()
        wait_until(lambda: state(page) == "E-STOP" and button.is_disabled(), 15, what="the jog greyed by E-STOP",
                   page=page)
        page.wait_for_timeout(300)
        disabled = _mean_colour(button, tmp_path / "disabled.png")
        style = button.evaluate("(b) => { const s = getComputedStyle(b); return [s.opacity, s.borderStyle]; }")
        # what the eye sees: the two looks differ by far more than a shade (Quasar's own greyed
        # button was the same blue-grey at 60 % opacity: 1.3:1 against the enabled one)
        assert contrast(enabled, disabled) >= 1.8, (enabled, disabled)
        assert float(style[0]) == 1.0 and style[1] == "dashed", style
        # its sign is still readable: the icon against the card at >= 4.5:1
        assert text_contrast(button.locator(".q-icon")) >= 4.5
    finally:
        recover(page)
        page.close()


def test_stale_values_are_dimmed_and_marked_with_their_age_while_the_controller_is_stopped(ready, browser):
    controller = ready["controller"]
    page = browser.new_page(viewport={"width": 1024, "height": 768})
    try:
        page.goto(ready["url"])
        wait_linked(page)
        wait_ready(page, 60)
        stale = page.get_by_test_id("stale")
        assert not stale.is_visible()
        value = page.get_by_test_id("angle-1")
        assert float(value.evaluate("(e) => getComputedStyle(e).opacity")) == 1.0
        shown = text(page, "angle-1")
        os.kill(controller.proc.pid, signal.SIGSTOP)
        try:
            wait_until(lambda: stale.is_visible(), 20, what="the stale marker", page=page)
            first = int(re.search(r"(\d+) s ago", stale.inner_text()).group(1))  # type: ignore[union-attr]
            assert "stale" in stale.inner_text() and first >= 1
            wait_until(lambda: page.evaluate("() => document.querySelector('.pk-main').classList.contains('pk-stale')"),
                       10, what="the page marked stale", page=page)
            look = value.evaluate("(e) => { const s = getComputedStyle(e); return [s.opacity, s.textDecorationLine]; }")
            assert float(look[0]) <= 0.6 and "line-through" in look[1], look
            assert text(page, "angle-1") == shown  # the last value, marked, not blanked
            jog_look = page.get_by_test_id("jog-angle-1").evaluate("(e) => getComputedStyle(e).opacity")
            assert float(jog_look) <= 0.6
            # the age follows the clock
            wait_until(lambda: int(re.search(r"(\d+) s ago", stale.inner_text()).group(1)) >= first + 2, 20,
                       what="the age growing", page=page)
        finally:
            os.kill(controller.proc.pid, signal.SIGCONT)
        wait_until(lambda: not stale.is_visible(), 30, what="the stale marker gone with the link back", page=page)
        wait_until(lambda: not page.evaluate("() => document.querySelector('.pk-main').classList.contains('pk-stale')")
                   and float(value.evaluate("(e) => getComputedStyle(e).opacity")) == 1.0, 15,
                   what="the values no longer dimmed", page=page)
        # the readouts are live again
        show_tab(page, "tab-jog")
    finally:
        recover(page)
        page.close()
