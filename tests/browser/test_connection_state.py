"""Honest connection state (issue 15 item 6).

When the controller dies the page says so in a banner, greys Home / Enable / jog / IO / Run,
its LEDs go dark, and a Home or a jog is not logged as "sent"; the banner offers to restart
the controller this GUI started (``parolkit gui --sim``) and the page comes back to life.
When the GUI's own server exits the page shows DISCONNECTED over everything instead of
LINKED / READY behind a small toast.

Each check fails on the code before this change: the buttons stayed enabled, the LEDs
green, Home and jog logged "sent", nothing offered a restart, and a dead server left the page
reading LINKED / READY.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from tests.browser.conftest import _stop, start_gui
from tests.browser.helpers import count_since, log_mark, log_text, state, text, wait_linked, wait_ready, wait_until
from tests.conftest import child_pids

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def _controller_pid(gui_pid: int) -> int:
    for pid in child_pids(gui_pid):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"serve" in cmd:
            return pid
    raise AssertionError(f"no `parolkit serve` child of the GUI process {gui_pid}")


@pytest.fixture(scope="module")
def gui(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    proc, url, _ = start_gui(["--sim", "--programs-dir", str(tmp_path_factory.mktemp("programs"))])
    yield proc, url
    _stop(proc)


def test_a_dead_controller_greys_the_controls_and_the_page_restarts_it(browser, gui):
    proc, url = gui
    page = browser.new_page(viewport={"width": 1500, "height": 1000})
    page.goto(url)
    wait_linked(page)
    wait_ready(page, 60)
    banner = page.get_by_test_id("link-banner")
    assert not banner.is_visible()
    assert page.locator("[data-testid=io-estop] .pk-led.on").count() == 1  # lit while linked
    os.kill(_controller_pid(proc.pid), signal.SIGKILL)
    wait_until(lambda: banner.is_visible(), 15, what="the no-link banner", page=page)
    wait_until(lambda: "stopped" in text(page, "link-banner-text"), 10, what="banner says the controller stopped",
               page=page)
    assert "NO LINK" in text(page, "link-chip") and state(page) == "NO LINK"
    for testid in ("btn-home", "btn-enable", "jog-j1-", "jog-j1+"):
        assert page.get_by_test_id(testid).is_disabled(), f"{testid} enabled with no controller"
    # no LED stays lit
    lit = page.evaluate("() => document.querySelectorAll('[data-testid^=io-] .pk-led.on, "
                        "[data-testid^=homed-] .pk-led.on').length")
    assert lit == 0, f"{lit} LEDs still lit with no controller"
    # neither a (forced) Home click nor a jog key is logged as sent
    mark = log_mark(page)
    page.get_by_test_id("btn-home").click(force=True)
    page.locator("body").click(position={"x": 5, "y": 400})
    page.keyboard.down("q")  # J1 + (a jog key)
    page.wait_for_timeout(400)
    page.keyboard.up("q")
    page.wait_for_timeout(500)
    assert count_since(page, mark, "sent Home") == 0, log_text(page)
    assert "jog not sent: no link to the controller" in log_text(page)
    # the page restarts the controller this GUI started
    page.get_by_test_id("link-restart").click()
    wait_until(lambda: "LINKED" in text(page, "link-chip"), 60, what="link back after the restart", page=page)
    wait_until(lambda: not banner.is_visible(), 10, what="banner gone", page=page)
    wait_until(lambda: "controller restarted" in log_text(page), 30, what="the restart logged", page=page)
    wait_until(lambda: page.get_by_test_id("btn-home").is_enabled(), 10, what="Home enabled again", page=page)
    page.close()


def test_the_page_says_disconnected_when_the_gui_server_exits(browser, gui):
    proc, url = gui
    page = browser.new_page(viewport={"width": 1500, "height": 1000})
    page.goto(url)
    wait_linked(page, 60)
    assert not page.get_by_test_id("server-banner").count()
    _stop(proc)
    server_banner = page.get_by_test_id("server-banner")
    wait_until(lambda: server_banner.count() == 1 and server_banner.is_visible(), 15,
               what="the DISCONNECTED banner")
    assert "DISCONNECTED" in server_banner.inner_text()
    chip = text(page, "link-chip")
    assert "LINKED" not in chip and "DISCONNECTED" in chip, chip
    assert "READY" not in state(page)
    page.close()
