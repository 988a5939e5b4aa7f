"""A class at the commander in a real headless Chromium against a real controller (issue 26,
item 1): the teacher and two students, each in a browser context of their own (their own
session cookie).

One controller process (``parolkit serve --sim``) and one ``parolkit gui --connect`` to it with
``gui.teacher_password`` and a temporary programs folder; the pages live for the module and the
tests build on each other in file order.  What the robot does is asked of the controller
itself (``GET_STATUS``), never judged on the pages alone.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.browser.conftest import gui_on_controller
from tests.browser.helpers import log_text, show_tab, state, text, wait_linked, wait_until

pytestmark = [pytest.mark.browser, pytest.mark.slow]

TEACHER_PASSWORD = "a teacher's long secret"
#: a bound on waiting for a page or the controller (a loaded machine), s: never a figure judged
WAIT_S = 60.0
WAIT_MS = int(WAIT_S * 1000)
#: a 20 s move of J1 (from the pre-homed standby pose): long enough to be taken back in the middle
LONG_PROGRAM = "Begin()\nMoveJoint(60,-90,180,0,0,180,t=20)\nEnd()\n"


def _status(controller) -> dict[str, str]:
    """The controller's own GET_STATUS as a dict (empty when no reply came)."""
    reply = controller.query("GET_STATUS", 0.5) or ""
    return dict(part.split("=", 1) for part in reply.split("|")[1:] if "=" in part)


def _j1(controller) -> float:
    return float(_status(controller).get("ANGLES", "nan").split(",")[0])


@pytest.fixture(scope="module")
def klass(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    root = tmp_path_factory.mktemp("classroom")
    cfg = root / "parolkit.toml"
    cfg.write_text(f'[gui]\nteacher_password = "{TEACHER_PASSWORD}"\n')
    programs = root / "programs"
    with gui_on_controller(root, ["--stream-watchdog", "0.15"],
                           ["--config", str(cfg), "--programs-dir", str(programs)]) as (controller, url, log_path):
        yield {"url": url, "controller": controller, "programs": programs, "gui_log": log_path}


def _page(browser, klass):
    context = browser.new_context(viewport={"width": 1500, "height": 1000})
    page = context.new_page()
    page.set_default_timeout(WAIT_MS)  # a loaded machine starves a page's renderer for seconds
    page.goto(klass["url"])
    page.wait_for_url("**/login?next=*")
    return page


@pytest.fixture(scope="module")
def pages(browser, klass):
    """The teacher's, Alice's and Bob's pages (not logged in yet), each in its own context."""
    made = {who: _page(browser, klass) for who in ("teacher", "alice", "bob")}
    yield made
    for page in made.values():
        page.context.close()


def _log_in(page, name: str = "", password: str = "") -> None:
    if name:
        page.get_by_test_id("login-name").fill(name)
    if password:
        page.get_by_test_id("login-password").fill(password)
    page.get_by_test_id("login-submit").click()


def chip(page) -> str:
    return text(page, "class-chip").strip().splitlines()[-1]  # after the chip's icon name


def _wait_chip(page, want: str, timeout: float = WAIT_S) -> None:
    wait_until(lambda: chip(page) == want, timeout, what=f"the class chip {want!r} (it shows {chip(page)!r})",
               page=page)


def _locked(page, testid: str) -> bool:
    """The control is greyed for this page: inert (no click, tap, key or focus) and disabled
    for assistive technology, itself or through the area it is in."""
    return page.get_by_test_id(testid).evaluate(
        "el => !!el.closest('[inert]') && !!el.closest('[aria-disabled=true]') && !!el.closest('.pk-locked')")


SCENE_OBJECTS = """() => {
  const host = document.querySelector('[data-testid=scene]');
  const comp = host && typeof getElement === 'function' && getElement(host.id.replace(/^c/, ''));
  return comp && comp.objects ? comp.objects.size : -1;
}"""


def _queue(page) -> list[str]:
    return [n for n in page.locator("[data-testid=class-queue-item]").evaluate_all(
        "els => els.map(e => e.dataset.name)")]


def test_the_login_takes_a_students_name_or_the_teachers_password(pages, klass):
    teacher, alice, bob = pages["teacher"], pages["alice"], pages["bob"]
    _log_in(alice, name="../Alice")
    assert "contains a path separator" in alice.get_by_test_id("login-error").inner_text(timeout=WAIT_MS)
    _log_in(alice, name="Alice", password="not the teacher's")
    assert alice.get_by_test_id("login-error").inner_text(timeout=WAIT_MS) == "Wrong password."
    _log_in(alice, name="Alice")
    _log_in(teacher, password=TEACHER_PASSWORD)
    _log_in(bob, name="Bob")
    for page in (teacher, alice, bob):
        wait_linked(page)
    _wait_chip(teacher, "Teacher · you have the robot")
    _wait_chip(alice, "Alice · watching · the teacher has the robot")
    _wait_chip(bob, "Bob · watching · the teacher has the robot")
    assert TEACHER_PASSWORD not in klass["gui_log"].read_text(errors="replace")
    # a watching page sees the arm as the teacher does: its 3D view got its objects
    wait_until(lambda: teacher.evaluate(SCENE_OBJECTS) > 10, WAIT_S, what="the teacher's 3D view", page=teacher)
    wait_until(lambda: alice.evaluate(SCENE_OBJECTS) == teacher.evaluate(SCENE_OBJECTS), WAIT_S,
               what="Alice's 3D view with the teacher's objects", page=alice)
    # the name is Alice's while her page is open
    other = _page(alice.context.browser, klass)
    try:
        _log_in(other, name="alice")
        assert "'Alice' is in use on another page" in other.get_by_test_id("login-error").inner_text(timeout=WAIT_MS)
    finally:
        other.context.close()


def test_a_watchers_controls_are_greyed_and_a_forged_action_is_refused_by_the_server(pages, klass):
    """Alice watches: Home, Enable, Disable, the speed override, the jog and IO buttons and
    Run are greyed (inert and aria-disabled), Stop and E-STOP are not.  A forged Disable (the
    page's own button made clickable again and clicked) and a forged jog key reach the server
    and are refused there: the log says so and the controller stays enabled and still."""
    teacher, alice = pages["teacher"], pages["alice"]
    controller = klass["controller"]
    wait_until(lambda: state(teacher) == "READY", 60, what="READY", page=teacher)
    for testid in ("btn-home", "btn-enable", "btn-disable", "btn-clear", "override-slider", "jog-j1+"):
        assert _locked(alice, testid), testid
        assert not _locked(teacher, testid), testid
    show_tab(alice, "tab-gripper")
    assert _locked(alice, "out1-high")
    show_tab(alice, "tab-program")
    assert _locked(alice, "prog-run")
    show_tab(alice, "tab-jog")
    for testid in ("btn-stop", "btn-estop", "class-action"):
        assert alice.get_by_test_id(testid).evaluate("el => !el.closest('[inert]')"), testid
    assert alice.get_by_test_id("btn-disable").is_disabled()
    j1 = _j1(controller)
    # forged: the page's Disable made clickable again, then clicked (the click reaches the server)
    alice.get_by_test_id("btn-disable").evaluate(
        "el => { for (let e = el; e; e = e.parentElement) { e.removeAttribute('inert'); "
        "e.removeAttribute('aria-disabled'); } el.click(); }")
    wait_until(lambda: "btn-disable (click) refused: Alice is watching: the teacher has the robot"
               in log_text(teacher), WAIT_S, what="the forged Disable refused", page=teacher)
    # forged: a jog key sent as the page's key event
    alice.evaluate("() => window.emitEvent('pk_key', {key: 'arrowright', down: true, typed: false})")
    wait_until(lambda: "key arrowright refused: Alice is watching" in log_text(teacher), WAIT_S,
               what="the forged jog key refused", page=teacher)
    alice.evaluate("() => window.emitEvent('pk_key', {key: 'arrowright', down: false, typed: false})")
    st = _status(controller)
    assert st["STATE"] == "IDLE" and st["CMD"] == "None", st  # enabled, nothing runs
    assert abs(_j1(controller) - j1) < 1e-3
    assert "sent Disable" not in log_text(teacher)


def test_the_teacher_hands_the_robot_over_from_the_queue(pages, klass):
    teacher, alice, bob = pages["teacher"], pages["alice"], pages["bob"]
    alice.get_by_test_id("class-action").click()  # Ask for a turn
    wait_until(lambda: _queue(teacher) == ["Alice"], WAIT_S, what="Alice in the queue", page=teacher)
    _wait_chip(alice, "Alice · watching · the teacher has the robot · number 1 in the queue")
    assert alice.get_by_test_id("class-action").inner_text().strip().endswith("Leave the queue")
    bob.get_by_test_id("class-action").click()
    wait_until(lambda: _queue(teacher) == ["Alice", "Bob"], WAIT_S, what="Bob after Alice", page=teacher)
    wait_until(lambda: _queue(bob) == ["Alice", "Bob"], WAIT_S, what="the queue on Bob's page", page=bob)
    # the teacher orders the queue: Bob first; his row is the same row, moved (its buttons keep
    # their ids: a press on one while the queue changes is never lost to a row made anew)
    bob_hand_over = teacher.locator("[data-testid=class-queue-item][data-name=Bob] [data-testid=class-hand-over]")
    bob_id = bob_hand_over.get_attribute("id")
    teacher.locator("[data-testid=class-queue-item][data-name=Bob] [data-testid=class-up]").click()
    wait_until(lambda: _queue(teacher) == ["Bob", "Alice"], WAIT_S, what="Bob moved up", page=teacher)
    assert bob_hand_over.get_attribute("id") == bob_id
    wait_until(lambda: "Hand over to Bob" in text(teacher, "class-action"), WAIT_S, what="the teacher's next",
               page=teacher)
    # ... and hands the robot to Alice, second in the queue
    teacher.locator("[data-testid=class-queue-item][data-name=Alice] [data-testid=class-hand-over]").click()
    _wait_chip(alice, "Alice · your turn")
    _wait_chip(bob, "Bob · watching · Alice has the robot · number 1 in the queue")
    _wait_chip(teacher, "Teacher · Alice has the robot")
    wait_until(lambda: not _locked(alice, "btn-home"), WAIT_S, what="Alice's controls", page=alice)
    assert _locked(teacher, "btn-home") and _locked(bob, "btn-home")
    assert teacher.get_by_test_id("class-action").inner_text().strip().endswith("Take back")
    # Alice moves the robot: a step jog of J1
    controller = klass["controller"]
    j1 = _j1(controller)
    alice.get_by_test_id("jog-mode").get_by_text("Step").click()
    alice.get_by_test_id("jog-j1+").click()
    wait_until(lambda: _j1(controller) > j1 + 0.5, WAIT_S, what="Alice's step jog at the controller", page=alice)
    # (the page's log shows the jog's line a moment after the controller has moved: a clean
    # clone at 04:16 UTC read it before it came)
    wait_until(lambda: "J1" in log_text(alice) or "jog" in log_text(alice), WAIT_S, what="the jog in Alice's log",
               page=alice)


def test_a_students_programs_are_in_their_own_folder_and_the_teacher_sees_them(pages, klass):
    alice, teacher = pages["alice"], pages["teacher"]
    programs: Path = klass["programs"]
    show_tab(alice, "tab-program")
    alice.get_by_test_id("prog-name").fill("mine")
    alice.get_by_test_id("prog-save").click()
    wait_until(lambda: "saved mine.rbt" in text(alice, "file-status"), WAIT_S, what="saved", page=alice)
    assert (programs / "students" / "Alice" / "mine.rbt").is_file()
    assert not (programs / "mine.rbt").exists()
    (programs / "students" / "Alice" / "long.rbt").write_text(LONG_PROGRAM)
    alice.get_by_test_id("prog-list").click()
    items = alice.get_by_test_id("program-item")
    items.first.wait_for(timeout=WAIT_MS)
    assert [t.strip() for t in items.all_inner_texts()] == ["long.rbt", "mine.rbt"]  # her folder only
    alice.keyboard.press("Escape")  # closes the list (Esc with a dialog open only closes it)
    alice.locator(".q-dialog").first.wait_for(state="detached", timeout=WAIT_MS)
    teacher.get_by_test_id("class-programs").click()
    wait_until(lambda: sorted(t.strip() for t in teacher.get_by_test_id("class-program-item").all_inner_texts())
               == ["long.rbt", "mine.rbt"], 15, what="Alice's programs in the teacher's list", page=teacher)
    teacher.keyboard.press("Escape")
    teacher.locator(".q-dialog").first.wait_for(state="detached", timeout=WAIT_MS)


def test_take_back_stops_the_students_running_program(pages, klass):
    """Alice runs a 20 s move; the teacher takes the robot back in its middle: the controller's
    move ends at once (no command, J1 short of 60 deg and still), Alice's page is greyed."""
    alice, teacher = pages["alice"], pages["teacher"]
    controller = klass["controller"]
    alice.get_by_test_id("prog-name").fill("long")
    alice.get_by_test_id("prog-open").click()
    wait_until(lambda: "opened long.rbt" in text(alice, "file-status"), WAIT_S, what="long.rbt opened", page=alice)
    alice.get_by_test_id("prog-run").click()
    wait_until(lambda: _status(controller).get("CMD", "None") != "None", WAIT_S,
               what="the program's move running at the controller", page=alice)
    teacher.get_by_test_id("class-action").click()  # Take back
    wait_until(lambda: _status(controller).get("CMD") == "None" and _status(controller).get("QUEUE") == "0", WAIT_S,
               what="the move ended at the controller", page=teacher)
    stopped_at = _j1(controller)
    assert stopped_at > 62.0  # short of the target: taken back in the middle (it started at 90)
    wait_until(lambda: abs(_j1(controller) - stopped_at) < 0.05 and _status(controller).get("STATE") == "IDLE", WAIT_S,
               what="J1 at rest where it stopped", page=teacher)
    _wait_chip(alice, "Alice · watching · the teacher has the robot")
    wait_until(lambda: "stopped" in text(alice, "prog-status"), WAIT_S, what="the program stopped", page=alice)
    wait_until(lambda: _locked(alice, "btn-home"), WAIT_S, what="Alice's controls greyed", page=alice)
    assert "the teacher has the robot (the teacher took the robot back)" in log_text(teacher)


def test_a_watchers_estop_reaches_the_controller(pages, klass):
    """Bob watches; his E-STOP latches the controller's E-stop all the same."""
    bob, teacher = pages["bob"], pages["teacher"]
    controller = klass["controller"]
    assert _locked(bob, "btn-enable")
    bob.get_by_test_id("btn-estop").click()
    wait_until(lambda: _status(controller).get("STATE") == "ESTOP" and _status(controller).get("ESTOP") == "1", WAIT_S,
               what="the controller's E-stop latched from Bob's page", page=bob)
    wait_until(lambda: state(teacher) == "E-STOP", WAIT_S, what="E-STOP on the teacher's page", page=teacher)
    teacher.get_by_test_id("btn-enable").click()  # the teacher has the robot: Enable ends the latch
    wait_until(lambda: _status(controller).get("STATE") == "IDLE", WAIT_S, what="enabled again", page=teacher)


def test_a_turn_with_a_time_limit_ends_and_the_robot_is_stopped(pages, klass):
    """Bob runs a 20 s move in his turn; the teacher sets 0.1 min (6 s) a turn, which counts
    for the turn in progress from its start: when the time is up the move ends at the controller
    and the robot is the teacher's again."""
    teacher, bob = pages["teacher"], pages["bob"]
    controller = klass["controller"]
    wait_until(lambda: _queue(teacher) == ["Bob"], WAIT_S, what="Bob waiting", page=teacher)
    (klass["programs"] / "students" / "Bob").mkdir(parents=True, exist_ok=True)
    (klass["programs"] / "students" / "Bob" / "long.rbt").write_text(LONG_PROGRAM.replace("60,", "120,"))
    teacher.get_by_test_id("class-action").click()  # Hand over to Bob
    _wait_chip(bob, "Bob · your turn")
    show_tab(bob, "tab-program")
    bob.get_by_test_id("prog-name").fill("long")
    bob.get_by_test_id("prog-open").click()
    wait_until(lambda: "opened long.rbt" in text(bob, "file-status"), WAIT_S, what="long.rbt opened", page=bob)
    bob.get_by_test_id("prog-run").click()
    wait_until(lambda: _status(controller).get("CMD", "None") != "None", WAIT_S, what="Bob's move running", page=bob)
    teacher.get_by_test_id("class-limit").fill("0.1")
    teacher.get_by_test_id("class-limit-set").click()
    wait_until(lambda: "Bob's time is up (0.1 min)" in log_text(teacher), WAIT_S, what="the turn's end", page=teacher)
    wait_until(lambda: _status(controller).get("CMD") == "None" and _status(controller).get("QUEUE") == "0", WAIT_S,
               what="the move ended at the controller", page=teacher)
    assert _j1(controller) < 119.0  # stopped short of the target
    _wait_chip(bob, "Bob · watching · the teacher has the robot")
    _wait_chip(teacher, "Teacher · you have the robot")
    assert "a turn lasts 0.1 min" in text(teacher, "class-state")
