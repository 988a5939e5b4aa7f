"""Link supervision, tick by tick: the link is judged by the frames the board left unanswered,
never by the controller's own late ticks, and when replies go bad every frame written is still
a bounded commitment: the board stops within 20 ms of travel of where the frames could take it.

The real controller core, its driver, guard and planner against the real board emulator on a
virtual clock (``tests/unit/test_controller_core.py``'s ``Rig``); link faults are the
emulator's own (``set_faults``), applied to the board's replies only."""

from __future__ import annotations

import time

import pytest
from tests.unit.test_controller_core import RATE, Rig

from parolkit.controller.core import ControllerCore
from parolkit.protocol.commands import AckStatus
from parolkit.protocol.frames import BoardCommand
from parolkit.robot import PAROL6, goto_goal

ZERO = (0, 0, 0, 0, 0, 0)
#: replies that never reach the controller whole: every byte changed, or every byte lost
BAD_REPLIES = {"corrupted": {"corrupt_rate": 1.0}, "lost": {"drop_rate": 1.0}}


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.close()


def _details(rig: Rig, cid: str) -> str:
    return [a for a in rig.acks if a[0] == cid][-1][2]


def test_late_ticks_of_a_stalled_controller_never_count_as_unanswered_frames(rig):
    """The controller stalls 0.3 s between ticks, again and again, mid-move: every reply is
    waiting when it resumes, so nothing was left unanswered."""
    rig.submit("aaaa0001|MOVEJOINT|60|-90|180|0|0|180|2|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    for _ in range(5):
        rig.tick(dt=0.3)
        rig.tick(3)
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    view = rig.core.counters
    assert view.link_losses == 0 and view.link_holds == 0 and view.unanswered_max == 0


def test_replies_read_a_tick_late_still_answer_their_frames(rig):
    """Replies 15 ms late (1.5 ticks, after the reply wait): each is read at the start of the
    tick after next and still answers its frame; a jog runs to its end, no hold, no loss."""
    rig.emu.set_faults(delay_s=0.015, direction="from_board")
    rig.tick(5)
    rig.submit("aaaa0001|JOG|0|50|0.5|None")
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED, _details(rig, "aaaa0001")
    view = rig.core.counters
    assert view.link_losses == 0 and view.link_holds == 0 and view.unanswered_max == 1


@pytest.mark.parametrize("fault", sorted(BAD_REPLIES))
def test_bad_replies_mid_jog_leave_the_board_within_bounded_travel_and_the_loss_writes_nothing(rig, fault):
    """Replies go bad mid-jog: the frames are GO TOs whose goals cannot run ahead of the last
    trusted reply (each within 20 ms of travel of where the board may be), so the board stops
    within two such distances of where that reply showed it, whatever happens next; the link
    is lost after 3 unanswered frames and nothing more is written (nothing needs stopping)."""
    rig.submit("aaaa0001|JOG|0|60|5|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(10)
    assert rig.emu.speeds[0] > 0
    trusted = rig.core.link.anchor.status.positions[0]
    rig.emu.set_faults(direction="from_board", **BAD_REPLIES[fault])
    n = len(rig.frames)
    rig.tick(6)
    after = rig.frames[n:]
    # 3 frames unanswered, then the one that ends the stream on its goal, in whole steps
    assert [f.command for f in after] == [BoardCommand.GOTO] * 4, [(f.command, f.speeds) for f in after]
    assert after[3].speeds == ZERO
    assert not rig.core.link_up
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert "board link lost: the board left 3 frames in a row unanswered" in _details(rig, "aaaa0001")
    view = rig.core.counters
    assert view.link_holds == 1 and view.link_losses == 1
    rig.tick(100)
    reach = PAROL6.max_speed_steps_s[0] / 50.0
    assert rig.emu.speeds == ZERO
    assert 0 < rig.emu.positions[0] - trusted <= 2 * reach + 1
    still = rig.emu.positions
    rig.tick(100)
    assert rig.emu.positions == still


def test_new_motion_is_queued_while_replies_are_missing_and_runs_when_they_return(rig):
    """Late replies (a loaded PC) do not refuse commands: the running motion holds by itself
    (its goals cannot run ahead of the last trusted reply) and what comes queues behind it."""
    rig = _loop(rig, 10)
    rig.submit("aaaa0001|JOG|0|60|0.3|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.emu.set_faults(drop_rate=1.0, direction="from_board")
    rig.tick(3)
    assert rig.core.holding and rig.core.link_up
    rig.submit("aaaa0002|JOG|1|60|0.2|None")
    assert rig.statuses("aaaa0002") == [AckStatus.QUEUED]
    rig.emu.clear_faults()
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED and rig.terminal("aaaa0002") is AckStatus.COMPLETED


def _loop(r: Rig, timeout: int, hold: int = 2) -> Rig:
    """A rig whose link is lost after ``timeout`` unanswered frames (held after ``hold``)."""
    r.close()
    return Rig(link_timeout_ticks=timeout, link_hold_frames=hold)


def test_a_jog_held_by_missing_replies_goes_on_when_they_come_back_and_covers_its_distance(rig):
    """Replies lost for 6 ticks (a loaded PC's tty layer can hold them back that long): the
    jog's goals cannot run further ahead of the last trusted reply than 20 ms of travel at the
    maximum speed beyond its first goal since (a slow jog goes on meanwhile, a fast one slows
    to that); it goes on when they return and still ends where its distance says; no loss
    (the threshold is 10 here)."""
    rig = _loop(rig, 10)
    start = rig.emu.positions[0]
    rig.submit("aaaa0001|JOG|0|60|None|4")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(15)
    rig.emu.set_faults(drop_rate=1.0, direction="from_board")
    n = len(rig.frames)
    trusted = rig.core.link.anchor.status.positions[0]
    rig.tick(6)
    rig.emu.clear_faults()
    held = rig.frames[n:n + 6]
    assert all(f.command == BoardCommand.GOTO for f in held)
    reach = PAROL6.max_speed_steps_s[0] / 50
    assert all(goto_goal(f.positions, f.speeds)[0] - trusted <= 2 * reach + 0.1 for f in held)
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED, _details(rig, "aaaa0001")
    assert abs((rig.emu.positions[0] - start) / PAROL6.steps_per_deg[0] - 4.0) <= 0.02
    view = rig.core.counters
    assert view.link_losses == 0 and view.link_holds == 1 and view.unanswered_max == 6


def test_a_position_move_paused_by_missing_replies_catches_up_and_keeps_its_time(rig):
    rig = _loop(rig, 10)
    rig.submit("aaaa0001|MOVEJOINT|60|-80|170|10|-10|170|2|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    act = rig.ex.activity
    final = tuple(act.positions[-1])
    first = len(rig.frames) - 1
    rig.tick(60)
    rig.emu.set_faults(drop_rate=1.0, direction="from_board")
    n = len(rig.frames)
    rig.tick(5)
    rig.emu.clear_faults()
    held = rig.frames[n:n + 5]
    assert all(f.command == BoardCommand.GOTO for f in held)
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    last = next(i for i, f in enumerate(rig.frames) if i > first and f.positions == final)
    assert last - first <= act.n  # the 30 ms pause was caught up: on time
    assert rig.core.counters.link_losses == 0


def test_lost_replies_mid_position_move_leave_the_board_settled_at_its_last_goal(rig):
    """A 156 stream whose replies go missing: its goals stay within reach of the last trusted
    reply; at the loss its last goal is written rounded to whole steps with no feed-forward,
    and the board settles exactly there and stays (a goal between two steps would keep it
    stepping to and fro)."""
    rig.submit("aaaa0001|MOVEJOINT|50|-90|180|0|0|180|2|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(60)  # mid-move, at speed
    rig.emu.set_faults(drop_rate=1.0, direction="from_board")
    n = len(rig.frames)
    rig.tick(5)
    after = rig.frames[n:]
    assert [f.command for f in after] == [BoardCommand.GOTO] * 4
    goal = goto_goal(after[2].positions, after[2].speeds)
    stop = after[3]  # written at the loss
    assert stop.command == BoardCommand.GOTO and stop.speeds == ZERO
    assert stop.positions == tuple(int(round(g)) for g in goal)
    assert not rig.core.link_up and rig.core.counters.link_holds == 1
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    rig.tick(50)
    assert rig.emu.positions == stop.positions
    still = rig.emu.positions
    rig.tick(50)
    assert rig.emu.positions == still


def test_the_loss_ends_a_go_to_stream_on_its_goal_in_whole_steps():
    """With the pause switched off (hold = loss threshold): the last frame is a GO TO, a
    bounded commitment; the frame written at the loss takes its goal in whole steps with no
    feed-forward, and the board stops exactly there."""
    r = Rig()
    try:
        r = _loop(r, 3, hold=3)
        r.submit("aaaa0001|JOG|0|60|5|None")
        r.run_until(lambda: AckStatus.EXECUTING in r.statuses("aaaa0001"))
        r.emu.set_faults(drop_rate=1.0, direction="from_board")
        n = len(r.frames)
        r.tick(5)
        assert len(r.frames) - n == 4 and all(f.command == BoardCommand.GOTO for f in r.frames[n:])
        stop = r.frames[-1]  # written at the loss
        goal = goto_goal(r.frames[-2].positions, r.frames[-2].speeds)
        assert stop.positions == tuple(int(round(g)) for g in goal) and stop.speeds == ZERO
        assert not r.core.link_up
        r.tick(20)
        assert r.emu.speeds == ZERO and r.emu.positions == stop.positions
    finally:
        r.close()


def test_a_silent_board_is_lost_after_the_configured_number_of_unanswered_frames():
    r = Rig()
    try:
        r = _loop(r, 5)
        r.submit("aaaa0001|DELAY|2")
        r.run_until(lambda: AckStatus.EXECUTING in r.statuses("aaaa0001"))
        r.emu.set_faults(silent=True)
        n = len(r.frames)
        r.tick(10)
        assert len(r.frames) - n == 5  # five frames left unanswered, then the link is lost
        assert all(f.command == BoardCommand.IDLE for f in r.frames[n:])
        assert r.terminal("aaaa0001") is AckStatus.CANCELLED
        assert "5 frames in a row unanswered" in r.ex.error
        assert r.core.counters.link_holds == 0  # nothing was streaming a speed
    finally:
        r.close()


def test_hold_frames_may_not_exceed_the_loss_threshold():
    with pytest.raises(ValueError, match="link_hold_frames must be 1..link_timeout_ticks"):
        ControllerCore(model=PAROL6, rate_hz=RATE, link_timeout_ticks=2, link_hold_frames=3)


def test_a_move_that_starts_while_replies_are_missing_starts_from_where_the_board_rests(rig):
    """A full-speed move planned and started while the motion was paused (replies missing: the
    stop frames went out instead of its first frames): its schedule ran on, and when replies
    came back its first target was the sample due by then, far from the board: the guard
    refused it and the move FAILED (test_guard_wire on a busy machine).  The first target is
    now the furthest one the guard passes from where the board rests; the move completes."""
    rig = _loop(rig, 60, hold=2)
    rig.submit("aaaa0001|MOVEJOINT|40|-60|200|-30|-20|120|None|100|100")
    rig.emu.set_faults(drop_rate=1.0, direction="from_board")
    for _ in range(40):  # the planner thread plans it meanwhile; the loop holds
        rig.tick()
        time.sleep(0.002)
    assert rig.core.holding and AckStatus.EXECUTING in rig.statuses("aaaa0001")
    rig.emu.clear_faults()
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED, _details(rig, "aaaa0001")
    assert rig.core.guard.violations == 0, rig.core.guard.last_violation
