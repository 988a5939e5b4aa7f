"""A lost stop supervisor shows in the commander (issue 22, item 4).

The commander on a controller whose board is ``parolkit board-sim`` (a serial link: the
controller runs a stop supervisor): ``kill -9`` of the supervisor turns the header's state
chip to ERROR and puts the controller's reason in the event log, naming the supervisor's pid
and how it ended; when the controller's new supervisor is ready the log says so.  On the code
before this change the page stayed READY and logged nothing.
"""

from __future__ import annotations

import os
import signal

import pytest
from tests.browser.conftest import gui_on_controller
from tests.browser.helpers import log_text, recover, state, wait_linked, wait_ready, wait_until
from tests.conftest import child_pids, process_state
from tests.integration.boardsim import BoardSim

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    root = tmp_path_factory.mktemp("supervisor")
    board = BoardSim(root, frame_log=None)
    try:
        with gui_on_controller(root, ["--port", str(board.link)], []) as (controller, url, _):
            yield controller, url
    finally:
        board.close()


def _ready(page) -> None:
    """READY before the kill.  Beside two CPU hogs board-sim (its own process) left 50 frames
    unanswered three times in 10 s: each time the controller rightly lost the link and the
    state stays ERROR (latched) after the link is back.  Then Enable (``recover``), as a user
    would; any other reason not to be READY fails here."""
    for _ in range(3):
        try:
            wait_ready(page, 20)
            return
        except AssertionError:
            if "frames in a row unanswered" not in log_text(page):
                raise
        recover(page)
    wait_ready(page, 20)


def test_a_killed_stop_supervisor_turns_the_state_to_error_and_is_logged_until_a_new_one_took_over(browser, setup):
    controller, url = setup
    page = browser.new_page(viewport={"width": 1500, "height": 1000})
    try:
        page.goto(url)
        wait_linked(page)
        _ready(page)
        (pid,) = [k for k in child_pids(controller.proc.pid) if process_state(k) not in (None, "Z")]
        os.kill(pid, signal.SIGKILL)
        wait_until(lambda: state(page) == "ERROR", 15, what="the state chip ERROR", page=page)
        lost = f"robot error: the stop supervisor (pid {pid}) exited"
        wait_until(lambda: lost in log_text(page), 15, what="the loss in the log", page=page)
        wait_until(lambda: "a new stop supervisor is ready" in log_text(page), 20,
                   what="the new supervisor in the log", page=page)
        assert state(page) == "ERROR"  # latched until cleared
    finally:
        page.close()
