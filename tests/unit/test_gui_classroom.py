"""A class at the commander without a browser: roles, names, the queue and turns as plain state
transitions with a clock passed in (gui/classroom.py); the login that opens a teacher's or a
student's session (gui/security.py); the [gui] keys; and the glue (gui/class_service.py): a
change of turn stops the robot (a real controller process) and gives the driver their own
programs folder, and an action for a page that watches is refused."""

from __future__ import annotations

import asyncio
import time

import pytest

from parolkit.config import GuiSettings, load_config
from parolkit.errors import ParolkitValueError
from parolkit.gui.classroom import (
    PRESENCE_GRACE_S,
    TEACHER,
    Classroom,
    ClassroomError,
    Role,
    student_name,
    turn_limit_s,
)
from parolkit.gui.security import LoginGate, WrongPassword, session_key

T = "teacher-key"


def room_with(*students: str, limit_s: float | None = None, now: float = 0.0) -> Classroom:
    """A class with the teacher (key ``T``) and the students (keys = their names)."""
    room = Classroom(limit_s)
    room.join_teacher(T, now)
    for s in students:
        room.join_student(s, s, now)
        room.page_opened(s, now)
    return room


# ---- names and limits ----


@pytest.mark.parametrize("text, rule", [
    ("", "no student name given"),
    ("../alice", "contains a path separator"),
    ("/home/alice", "is an absolute path"),
    ("al..ice", "contains '..'"),
    (".alice", "starts with '.'"),
    ("alice*", "contains '*'"),
    ("a" * 101, "101 characters long"),
    ("Teacher", "the teacher's name"),
    ("the teacher", "the teacher's name"),
])
def test_a_student_name_follows_the_programs_folders_name_rules(text, rule):
    with pytest.raises(ClassroomError, match=rule.replace(".", r"\.").replace("*", r"\*")) as exc:
        student_name(text)
    if "teacher" not in rule:
        assert "letters, digits, spaces" in str(exc.value) and "is added" not in str(exc.value)


def test_a_good_student_name_is_kept_as_typed_without_an_extension():
    assert student_name("  Ada Lovelace-2 ") == "Ada Lovelace-2"
    assert student_name("bob.smith") == "bob.smith"


def test_a_turns_time_limit_is_minutes_in_the_configs_range_or_none():
    assert turn_limit_s(None) is None and turn_limit_s(0) is None
    assert turn_limit_s(5) == 300.0 and turn_limit_s(0.1) == pytest.approx(6.0)
    for bad in (0.05, 241, -1, float("nan"), True, "5"):
        with pytest.raises(ClassroomError, match=r"0\.1\.\.240 minutes, or 0 for no limit"):
            turn_limit_s(bad)  # type: ignore[arg-type]


# ---- members ----


def test_a_name_in_use_is_refused_until_its_student_is_gone_then_taken_over_with_its_place_and_turn():
    room = room_with("Alice", "Bob")
    room.ask("Bob", 1.0)
    room.hand_over(T, "Bob", 2.0)
    room.ask("Alice", 3.0)
    with pytest.raises(ClassroomError, match="'Alice' is in use on another page"):
        room.join_student("other", "alice", 4.0)  # the same name, whatever its case
    room.page_closed("Alice", 10.0)
    room.page_closed("Bob", 10.0)
    with pytest.raises(ClassroomError, match="in use"):
        room.join_student("other", "ALICE", 10.0 + PRESENCE_GRACE_S - 1)  # a reload is not leaving
    room.join_student("alice-again", "ALICE", 10.0 + PRESENCE_GRACE_S)
    room.join_student("bob-again", "Bob", 10.0 + PRESENCE_GRACE_S)
    assert room.member("Alice") is None and room.member("alice-again").name == "Alice"  # her spelling
    assert room.queue == ["Alice"] and room.holder(50.0) == "Bob"
    assert room.may_drive("bob-again", 50.0) and not room.may_drive("Bob", 50.0)  # the old session: gone


def test_leaving_takes_a_student_out_of_the_queue_and_ends_their_turn():
    room = room_with("Alice", "Bob")
    room.ask("Alice", 1.0)
    room.ask("Bob", 1.0)
    room.hand_over(T, None, 2.0)
    assert room.leave("Bob", 3.0) is None and room.queue == []
    end = room.leave("Alice", 4.0)
    assert end is not None and end.name == "Alice" and end.reason == "Alice logged out" and end.at == 4.0
    assert room.turn is None and room.may_drive(T, 4.0)
    assert room.leave("nobody", 5.0) is None


# ---- who may drive ----


def test_the_teacher_drives_until_a_turn_is_handed_over_then_only_that_student():
    room = room_with("Alice", "Bob")
    assert room.may_drive(T, 0.0) and not room.may_drive("Alice", 0.0) and not room.may_drive("Bob", 0.0)
    assert not room.may_drive("unknown", 0.0) and not room.may_drive(None, 0.0)
    room.ask("Alice", 1.0)
    room.hand_over(T, None, 2.0)
    assert room.holder(2.0) == "Alice"
    assert room.may_drive("Alice", 2.0) and not room.may_drive(T, 2.0) and not room.may_drive("Bob", 2.0)
    end = room.take_back(T, 3.0)
    assert end.reason == "the teacher took the robot back" and room.may_drive(T, 3.0)
    assert not room.may_drive("Alice", 3.0)


def test_only_the_teacher_orders_hands_over_and_takes_back_and_only_students_queue():
    room = room_with("Alice", "Bob")
    room.ask("Alice", 0.0)
    for action, what in ((lambda: room.hand_over("Bob", "Alice", 1.0), "hand over: only the teacher"),
                         (lambda: room.take_back("Bob", 1.0), "take back: only the teacher"),
                         (lambda: room.move("Bob", "Alice", 1), "reorder the queue: only the teacher"),
                         (lambda: room.dequeue("Bob", "Alice"), "remove from the queue: only the teacher"),
                         (lambda: room.set_limit("Bob", 5), "set the time limit: only the teacher"),
                         (lambda: room.ask(T, 1.0), "ask for a turn: only a student"),
                         (lambda: room.end_turn(T, 1.0), "end the turn: only a student"),
                         (lambda: room.ask("gone", 1.0), "this page is logged out")):
        with pytest.raises(ClassroomError, match=what):
            action()
    assert room.queue == ["Alice"] and room.turn is None


def test_the_queue_is_ordered_by_asking_and_by_the_teacher():
    room = room_with("Alice", "Bob", "Carol")
    assert [room.ask(s, 1.0) for s in ("Bob", "Alice", "Carol")] == [1, 2, 3]
    assert room.ask("Bob", 2.0) == 1  # asking again keeps the place
    room.move(T, "Carol", -2)
    assert room.queue == ["Carol", "Bob", "Alice"]
    with pytest.raises(ClassroomError, match="Carol is number 1 of 3 and cannot move -1"):
        room.move(T, "Carol", -1)
    with pytest.raises(ClassroomError, match="'Dave' is not in the queue \\(waiting: Carol, Bob, Alice\\)"):
        room.move(T, "Dave", 1)
    room.dequeue(T, "Bob")
    room.withdraw("Alice")
    assert room.queue == ["Carol"]
    with pytest.raises(ClassroomError, match="leave the queue: you are not in it"):
        room.withdraw("Alice")
    view = room.view("Carol", 3.0)
    assert view is not None and view.place == 1 and view.queue == ("Carol",) and not view.may_drive


def test_a_hand_over_takes_the_first_or_the_named_student_and_ends_the_turn_in_progress():
    room = room_with("Alice", "Bob", "Carol")
    with pytest.raises(ClassroomError, match="nobody is waiting"):
        room.hand_over(T, None, 0.0)
    for s in ("Alice", "Bob", "Carol"):
        room.ask(s, 0.0)
    assert room.hand_over(T, "Bob", 1.0) is None  # by name, not only the first
    assert room.queue == ["Alice", "Carol"] and room.holder(1.0) == "Bob"
    with pytest.raises(ClassroomError, match="ask for a turn: you have the robot now"):
        room.ask("Bob", 1.5)
    end = room.hand_over(T, None, 2.0)  # from Bob straight to the first waiting
    assert end is not None and end.name == "Bob" and end.reason == "handed over to Alice"
    assert room.holder(2.0) == "Alice" and room.queue == ["Carol"]
    assert room.end_turn("Alice", 3.0).reason == "Alice ended the turn"
    with pytest.raises(ClassroomError, match="end the turn: you do not have the robot"):
        room.end_turn("Alice", 3.0)
    with pytest.raises(ClassroomError, match="no student has the robot"):
        room.take_back(T, 3.0)


def test_a_turn_with_a_time_limit_ends_when_it_runs_out_even_before_the_tick():
    room = room_with("Alice", "Bob", limit_s=60.0)
    room.ask("Alice", 0.0)
    room.hand_over(T, None, 10.0)
    assert room.turn is not None and room.turn.left_s(40.0) == 30.0
    view = room.view("Bob", 40.0)
    assert view is not None and view.holder == "Alice" and view.left_s == 30.0
    assert room.tick(69.9) is None and room.may_drive("Alice", 69.9)
    # ran out: nobody but the teacher may act, though the tick has not ended it yet
    assert not room.may_drive("Alice", 70.0) and room.may_drive(T, 70.0) and room.holder(70.0) is None
    end = room.tick(70.2)
    assert end is not None and end.reason == "Alice's time is up (1 min)" and room.turn is None
    assert room.tick(71.0) is None and room.last_end == end


def test_the_teachers_limit_applies_to_the_next_turns_and_the_one_in_progress():
    room = room_with("Alice", "Bob")
    room.ask("Alice", 0.0)
    room.hand_over(T, None, 0.0)
    assert room.turn is not None and room.turn.left_s(100.0) is None  # no limit
    room.set_limit(T, 2)
    assert room.turn.left_s(100.0) == 20.0  # counted from the turn's start
    with pytest.raises(ClassroomError, match=r"0\.1\.\.240 minutes"):
        room.set_limit(T, 500)
    assert room.limit_s == 120.0
    room.set_limit(T, 0)
    assert room.limit_s is None and room.turn.limit_s is None


def test_a_take_back_or_hand_over_after_the_time_ran_out_reports_the_time_limit():
    room = room_with("Alice", "Bob", limit_s=6.0)
    room.ask("Alice", 0.0)
    room.ask("Bob", 0.0)
    room.hand_over(T, None, 0.0)
    end = room.hand_over(T, None, 7.0)
    assert end is not None and end.reason == "Alice's time is up (0.1 min)"
    assert room.take_back(T, 20.0).reason == "Bob's time is up (0.1 min)"


def test_every_change_counts_in_the_version_and_the_view_lists_who_is_here():
    room = room_with("Bob", "alice")
    v = room.version
    room.ask("Bob", 0.0)
    assert room.version > v
    room.page_closed("Bob", 1.0)
    view = room.view(T, 1.0 + PRESENCE_GRACE_S)
    assert view is not None and view.role is Role.TEACHER and view.name == TEACHER
    assert view.students == ("alice",) and view.may_drive and view.holder is None and view.place is None
    assert room.view("nobody", 0.0) is None


# ---- the login ----


def test_a_class_login_opens_a_teacher_or_a_named_student_and_never_shows_the_passwords():
    room = Classroom()
    gate = LoginGate(None, teacher_password="the teachers secret", classroom=room)
    t = gate.log_in("the teachers secret", "whatever name")
    teacher = gate.member(t)
    assert teacher is not None and teacher.role is Role.TEACHER
    s = gate.log_in("", "Alice")
    alice = gate.member(s)
    assert alice is not None and alice.role is Role.STUDENT and alice.name == "Alice"
    assert room.member(session_key(s)) is alice
    with pytest.raises(WrongPassword):
        gate.log_in("wrong teacher password", "Bob")  # a name and a password: a wrong teacher's
    with pytest.raises(ClassroomError, match="type your name"):
        gate.log_in("", "  ")
    with pytest.raises(ClassroomError, match="contains a path separator"):
        gate.log_in("", "../x")
    with pytest.raises(ClassroomError, match="in use"):
        gate.log_in("", "alice")
    assert len(gate._sessions) == 2  # the refused names opened no session
    gate.close_session(s)
    assert not gate.valid(s) and room.member(session_key(s)) is None  # logged out of the class too
    assert "secret" not in repr(gate)


def test_a_class_with_a_class_password_asks_students_for_it():
    room = Classroom()
    gate = LoginGate("class password", teacher_password="the teachers secret", classroom=room)
    with pytest.raises(WrongPassword):
        gate.log_in("", "Alice")
    with pytest.raises(WrongPassword):
        gate.log_in("class passwor", "Alice")
    s = gate.log_in("class password", "Alice")
    assert gate.member(s) is not None and gate.member(s).role is Role.STUDENT
    assert gate.member(gate.log_in("the teachers secret")).role is Role.TEACHER


def test_a_session_whose_student_was_replaced_is_no_longer_valid():
    room = Classroom()
    gate = LoginGate(None, teacher_password="the teachers secret", classroom=room)
    old = gate.log_in("", "Alice", now=0.0)
    new = gate.log_in("", "Alice", now=PRESENCE_GRACE_S + 1)  # no page for the grace time
    assert gate.valid(new, now=PRESENCE_GRACE_S + 2) and not gate.valid(old, now=PRESENCE_GRACE_S + 2)


def test_a_login_gate_without_a_class_is_unchanged_and_a_class_needs_both_parts():
    gate = LoginGate("correct horse")
    with pytest.raises(WrongPassword):
        gate.log_in("wrong", "Alice")
    token = gate.log_in("correct horse")
    assert gate.valid(token) and gate.member(token) is None
    with pytest.raises(ValueError, match="needs both"):
        LoginGate(None, teacher_password="the teachers secret")
    with pytest.raises(ValueError, match="needs the password"):
        LoginGate(None)


# ---- the [gui] keys ----


def test_the_class_keys_load_and_are_checked_naming_the_key(tmp_path):
    cfg = tmp_path / "parolkit.toml"
    cfg.write_text('[gui]\nteacher_password = "the teachers secret"\nturn_minutes = 5\n')
    gui = load_config(cfg).gui
    assert gui.teacher_password == "the teachers secret" and gui.turn_minutes == 5
    assert "the teachers secret" not in repr(gui) and "teacher_password='***'" in repr(gui)
    assert GuiSettings().teacher_password is None and GuiSettings().turn_minutes == 0  # no limit
    for text, fragment in (('teacher_password = "short"', "gui.teacher_password must be 8..256 printable"),
                           ("teacher_password = 12345678", "got a int"),
                           ('password = "same secret"\nteacher_password = "same secret"',
                            "gui.teacher_password must differ from gui.password"),
                           ("turn_minutes = 0.05", r"gui.turn_minutes must be 0 \(no limit\) or a number of "
                                                   r"minutes in \[0.1, 240\], got 0.05"),
                           ("turn_minutes = 241", "gui.turn_minutes"),
                           ('turn_minutes = "5"', "gui.turn_minutes")):
        cfg.write_text(f"[gui]\n{text}\n")
        with pytest.raises(ParolkitValueError, match=fragment):
            load_config(cfg)


# ---- the glue: the robot and the folders follow the turn ----


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def service_for(tmp_path, link=None):
    from parolkit.gui.class_service import ClassService
    from parolkit.gui.commander import Commander
    from parolkit.gui.link import ControllerLink
    from parolkit.gui.programs import ProgramsFolder

    folder = ProgramsFolder(tmp_path / "programs")
    folder.create()
    c = Commander(link or ControllerLink("127.0.0.1", 9, 9), mode_label="test", programs=folder)
    clock = Clock()
    room = Classroom()
    svc = ClassService(room, c, clock)
    c.classroom = svc
    room.join_teacher(T, clock.now)
    for s in ("Alice", "Bob"):
        room.join_student(s, s, clock.now)
        room.page_opened(s, clock.now)
    return svc, c, clock, folder


def test_each_driver_gets_their_own_programs_folder_and_their_program_back(tmp_path):
    svc, c, clock, folder = service_for(tmp_path)
    root = folder.root
    c.doc.edit("Begin()\nDelay(1)\nEnd()\n")  # the teacher's program
    svc.ask("Alice")
    svc.hand_over(T)
    assert folder.root == root / "students" / "Alice"
    assert c.doc.text == "Begin()\nDelay(1)\nEnd()\n"  # a first turn starts from the teacher's program
    c.doc.edit("Begin()\nDelay(2)\nEnd()\n")  # Alice's edits, kept in her folder
    assert (root / "students" / "Alice" / ".autosave" / c.doc.name).read_text() == "Begin()\nDelay(2)\nEnd()\n"
    folder.write("mine", "Begin()\nDelay(3)\nEnd()\n")
    svc.ask("Bob")
    svc.hand_over(T)  # Alice -> Bob: Bob starts from the teacher's program, not Alice's
    assert folder.root == root / "students" / "Bob" and c.doc.text == "Begin()\nDelay(1)\nEnd()\n"
    svc.take_back(T)
    assert folder.root == root and c.doc.text == "Begin()\nDelay(1)\nEnd()\n"
    assert folder.names() == []  # Alice's program is in her folder only
    svc.ask("Alice")
    svc.hand_over(T)  # Alice again: her own kept edits
    assert c.doc.text == "Begin()\nDelay(2)\nEnd()\n"
    svc.take_back(T)
    assert svc.student_programs() == {"Alice": ["mine.rbt"], "Bob": []}
    name = svc.open_student_program(T, "Alice", "mine.rbt")  # the teacher sees all
    assert name == "Alice mine.rbt" and c.doc.text == "Begin()\nDelay(3)\nEnd()\n" and c.doc.dirty
    with pytest.raises(ClassroomError, match="only the teacher"):
        svc.open_student_program("Bob", "Alice", "mine.rbt")
    with pytest.raises(ClassroomError, match="contains a path separator"):
        svc.open_student_program(T, "../Alice", "mine.rbt")


def test_an_action_for_a_page_that_watches_is_refused_and_logged_and_stop_is_not(tmp_path):
    from parolkit.gui.class_service import ACTING

    svc, c, clock, _ = service_for(tmp_path)
    token = ACTING.set("Bob")
    try:
        assert svc.refuse("Home")
        c.command("HOME", "Home")  # refused before the link is asked
        c.jog_press(lambda: "JOG")
        assert not c.jogging
        assert asyncio.run(c.set_speed(50)) is False
        c.command("STOP", "Stop")  # STOP and E-STOP: from every page
    finally:
        ACTING.reset(token)
    texts = [e.text for e in c.log]
    assert "Home refused: Bob is watching: the teacher has the robot" in texts
    assert "jog refused: Bob is watching: the teacher has the robot" in texts
    assert "speed override refused: Bob is watching: the teacher has the robot" in texts
    assert not any(t.startswith("Stop refused") for t in texts)
    assert not svc.refuse("Home")  # outside a page's event: the commander's own actions
    token = ACTING.set(T)
    try:
        assert not svc.refuse("Home")  # the teacher drives
    finally:
        ACTING.reset(token)


def test_a_take_back_and_a_turn_that_runs_out_stop_a_running_move_of_a_real_controller(tmp_path, controller):
    """The robot follows the turn: the student's move (a 20 s MOVEJOINT) ends at once when the
    teacher takes the robot back, and again when a turn's time runs out (the service's tick)."""
    from parolkit.gui.class_service import ACTING
    from parolkit.gui.link import ControllerLink

    async def main() -> None:
        link = ControllerLink(controller.host, controller.port, controller.ack_port, every_n_ticks=1)
        await link.start()
        svc, c, clock, _ = service_for(tmp_path, link)
        try:
            deadline = time.monotonic() + 20
            while link.status is None or not link.link_up:
                assert time.monotonic() < deadline, "no status from the controller"
                await asyncio.sleep(0.05)

            async def student_moves(name: str) -> None:
                token = ACTING.set(name)
                try:
                    target = list(link.status.angles)
                    target[0] += 30.0
                    c.command("MOVEJOINT|" + "|".join(f"{v:.3f}" for v in target) + "|20|None", "move")
                finally:
                    ACTING.reset(token)
                deadline = time.monotonic() + 20
                while link.status.command is None:
                    assert time.monotonic() < deadline, "the student's move did not start"
                    await asyncio.sleep(0.02)

            async def stopped(what: str) -> None:
                deadline = time.monotonic() + 20
                while link.status.command is not None or link.status.queue:
                    assert time.monotonic() < deadline, f"the move still runs after {what}"
                    await asyncio.sleep(0.02)

            svc.ask("Alice")
            svc.hand_over(T)
            await student_moves("Alice")
            svc.take_back(T)
            await stopped("the take back")
            assert "the teacher has the robot (the teacher took the robot back)" in [e.text for e in c.log]
            svc.set_limit(T, 0.1)
            svc.ask("Bob")
            svc.hand_over(T)
            await student_moves("Bob")
            clock.now += 6.0  # the turn ran out: the next tick ends it
            svc.follow()
            await stopped("the time ran out")
            assert "the teacher has the robot (Bob's time is up (0.1 min))" in [e.text for e in c.log]
        finally:
            await link.close()

    asyncio.run(main())
