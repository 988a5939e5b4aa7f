"""The commander's access rules in a real headless Chromium: the login, the programs folder
and the control lease.

One controller process (``parolkit serve --sim``, lease timeout 3 s) and one
``parolkit gui --connect`` to it with a login password and a temporary programs folder; one
page for the module, tests in file order.  A second client (the client library's ``Robot``
on its own socket) competes for the lease.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from tests.browser.conftest import gui_on_controller
from tests.browser.helpers import wait_until

from parolkit.client import Robot
from parolkit.client.errors import CommandCancelled, CommandFailed

pytestmark = [pytest.mark.browser, pytest.mark.slow]

PASSWORD = "correct horse battery"
LEASE_TIMEOUT_S = 3.0


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    root = tmp_path_factory.mktemp("access")
    cfg = root / "parolkit.toml"
    cfg.write_text(f'[controller]\nlease_timeout_s = {LEASE_TIMEOUT_S}\n[gui]\npassword = "{PASSWORD}"\n')
    programs = root / "programs"
    with gui_on_controller(root, ["--config", str(cfg)],
                           ["--config", str(cfg), "--programs-dir", str(programs)]) as (controller, url, log_path):
        yield {"url": url, "controller": controller, "programs": programs, "root": root, "gui_log": log_path}


@pytest.fixture(scope="module")
def page(browser, setup):
    pg = browser.new_page(viewport={"width": 1500, "height": 1000})
    yield pg
    pg.close()


def text(page, testid: str) -> str:
    return page.get_by_test_id(testid).inner_text()


def badge(page) -> str:
    return text(page, "control-chip").strip().splitlines()[-1]  # after the chip's icon name


def log_text(page) -> str:
    return text(page, "log")


def test_the_commander_asks_for_the_password_first(page, setup):
    page.goto(setup["url"])
    page.wait_for_url("**/login?next=*", timeout=15000)
    page.get_by_test_id("login-password").fill("not the password")
    page.get_by_test_id("login-submit").click()
    assert page.get_by_test_id("login-error").inner_text(timeout=15000) == "Wrong password."
    page.get_by_test_id("login-password").fill(PASSWORD)
    page.get_by_test_id("login-submit").click()
    wait_until(lambda: "LINKED" in text(page, "link-chip"), 30, what="the commander, linked")
    assert PASSWORD not in setup["gui_log"].read_text(errors="replace")


def _file_status(page) -> str:
    return text(page, "file-status")


def _open(page, name: str) -> None:
    page.get_by_test_id("prog-name").fill(name)
    page.get_by_test_id("prog-open").click()


def _editor(page) -> str:
    return page.evaluate("() => [...document.querySelectorAll('[data-testid=editor] .cm-line')]"
                         ".map(e => e.textContent).join('\\n')")


def test_programs_are_saved_and_opened_only_inside_the_programs_folder(page, setup):
    programs: Path = setup["programs"]
    root: Path = setup["root"]
    page.get_by_test_id("tab-program").click()
    page.get_by_test_id("prog-name").fill("demo")
    page.get_by_test_id("prog-save").click()
    wait_until(lambda: "saved demo.rbt" in _file_status(page), what="saved")
    saved = (programs / "demo.rbt").read_text()
    assert saved.startswith("Begin()")
    outside = root / "outside.rbt"
    outside.write_text("Begin()\nOutput(2,HIGH)\nEnd()\n")
    os.symlink(outside, programs / "link.rbt")
    for name, rule in ((str(outside), "is an absolute path"), ("../outside", "contains a path separator"),
                       ("/etc/passwd", "is an absolute path"), ("..", "contains '..'"),
                       ("link", "outside the programs folder")):
        _open(page, name)
        wait_until(lambda n=name: f"cannot open {n!r}" in _file_status(page), what=f"{name} refused")
        assert rule in _file_status(page), _file_status(page)
        assert "Output(2,HIGH)" not in _editor(page)
    # saving through a path is refused too, and writes nothing outside
    page.get_by_test_id("prog-name").fill("../outside")
    page.get_by_test_id("prog-save").click()
    wait_until(lambda: "cannot save '../outside'" in _file_status(page), what="save refused")
    assert outside.read_text() == "Begin()\nOutput(2,HIGH)\nEnd()\n"
    assert {p.name for p in root.iterdir() if p.suffix != ".log"} == {"outside.rbt", "parolkit.toml", "programs"}
    # the list shows the folder's programs (not the link out of it); clicking one opens it
    (programs / "second.rbt").write_text("Begin()\nDelay(1)\nEnd()\n")
    page.get_by_test_id("prog-list").click()
    items = page.get_by_test_id("program-item")
    items.first.wait_for(timeout=10000)
    assert [t.strip() for t in items.all_inner_texts()] == ["demo.rbt", "second.rbt"]
    items.nth(1).click()
    wait_until(lambda: "opened second.rbt" in _file_status(page), what="opened from the list")
    assert "Delay(1)" in _editor(page)


def test_the_badge_shows_another_clients_control_and_take_control_works(page, setup):
    controller = setup["controller"]
    with Robot("127.0.0.1", controller.port, ack_port=0, timeout=2.0) as other:
        other.take_control()
        busy = other.delay(60, wait=False)  # a queued command keeps the lease whatever the silence
        who = f"127.0.0.1:{other.ack_port}"
        wait_until(lambda: badge(page) == f"Controlled by {who}", 10,
                   what=f"the other client's control shown (badge {badge(page)!r}, want {who})")
        # the commander's commands are refused with the controller's reason
        page.get_by_test_id("btn-home").click()
        wait_until(lambda: f"the robot is controlled by {who}" in log_text(page), 10, what="Home refused")
        page.get_by_test_id("btn-take-control").click()
        page.get_by_text("Take control of the robot?").wait_for(timeout=10000)
        assert who in page.get_by_text("controls it now").inner_text()
        page.get_by_test_id("confirm-take-control").click()
        wait_until(lambda: badge(page) == "You control the robot", 10, what="control taken")
        assert not page.get_by_test_id("btn-take-control").is_visible()
        with pytest.raises(CommandCancelled):
            busy.result(timeout=10)  # the controller cancelled the previous holder's commands
        with pytest.raises(CommandFailed, match="controlled by 127.0.0.1:"):
            other.take_control()  # a plain TAKE does not take it from the commander
        # idle, the commander does not keep the lease: it lapses after the controller's timeout
        wait_until(lambda: badge(page) == "Nobody controls the robot", LEASE_TIMEOUT_S + 6,
                   what="the idle commander's lease lapsing")
        other.take_control()  # free again for anyone
        busy = other.delay(60, wait=False)
        wait_until(lambda: badge(page) == f"Controlled by {who}", 10, what="the other client again")
        other.stop()  # STOP: open to every client
        with pytest.raises(CommandCancelled):
            busy.result(timeout=10)
    # Robot.close() gave it back
    wait_until(lambda: badge(page) == "Nobody controls the robot", 10, what="released on close")


def test_a_program_runs_after_the_commander_commanded_and_gives_the_lease_back(page, setup):
    page.get_by_test_id("btn-enable").click()  # the commander takes the lease with this command
    wait_until(lambda: badge(page) == "You control the robot", 10, what="the commander in control")
    page.get_by_test_id("tab-program").click()
    content = page.locator("[data-testid=editor] .cm-content")
    content.click()
    page.keyboard.press("Control+A")
    page.keyboard.press("Delete")
    page.keyboard.insert_text("Begin()\nOutput(1,HIGH)\nDelay(2)\nOutput(1,LOW)\nEnd()\n")
    page.get_by_test_id("prog-run").click()  # the runner is another client: the lease is handed over
    wait_until(lambda: badge(page) == "Your program controls the robot", 10, what="the program in control")
    wait_until(lambda: "HIGH" in text(page, "io-out1"), 10, what="the program sets OUT1")
    wait_until(lambda: "LOW" in text(page, "io-out1"), 10, what="the program clears OUT1")
    wait_until(lambda: badge(page) == "Nobody controls the robot", 10, what="the runner gives the lease back")
    assert "program not started" not in log_text(page)
