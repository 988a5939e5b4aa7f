"""A board that stalls and then answers its backlog of frames late (issue 23): which reply
answers which frame, and the integrity check's judgement of them.

The stock firmware drains its serial input once per loop pass and answers every frame it
accepts, in order, each reply carrying the telemetry copied before the pass took the frames in
(docs/board-emulator.md; /work/shared/spec/board-firmware.md): after a stall the replies to the
oldest frames come first, several with the same positions, the first with the stall's length in
its ``timing`` field and the others with 0.  A reply read right after a frame was written is not
necessarily the answer to that frame.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from tests.unit.test_controller_core import RATE, Rig
from tests.unit.test_integrity import LinkFault

from parolkit.controller import integrity
from parolkit.controller.core import ControllerCore, ReplyBatch, TickInput, Written
from parolkit.controller.link import LinkHistory
from parolkit.controller.messages import LinkEvent, LinkEventKind
from parolkit.protocol.commands import AckStatus
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.robot import PAROL6, goto_goal

_GOTO = int(BoardCommand.GOTO)
#: the joints the logged move left alone (J1 moved)
_REST = (-32000, 57905, 0, 0, 32000)

# /work/notes/logs/integrity-false-alarm-controller.log, lines 177-200 (a controller driving a
# board-sim process over a pty at load 10-17): the frames written (number, time, J1 target,
# J1 feed-forward) ...
_LOG_FRAMES = [
    (66, 24085.2207, 9777, 2091), (67, 24085.2307, 9798, 2073), (68, 24085.2410, 9818, 2051),
    (69, 24085.2509, 9839, 2026), (70, 24085.2606, 9859, 1998), (71, 24085.2710, 9879, 1966),
    (72, 24085.2806, 9898, 1932), (73, 24085.2906, 9917, 1895), (74, 24085.3006, 9936, 1855),
]
# ... and the replies read after each (read time, J1 position, J1 speed, timing): one per frame
# up to 68; none while the board-sim process stalled (~60 ms); then, after frame 74 was written,
# three read together in its reply wait and two more 0.5 ms later at the next tick's start.
# The board answered 69, 70 and 71 in one pass (the same positions: it ran 68's goal through the
# stall; timing 60 ms, then 0, 0) and 72, 73 in the next one 21 ms later (it ran 71's goal).
_LOG_REPLIES: dict[int, list[list[tuple[float, int, int, int]]]] = {
    66: [[(24085.2215, 9742, 1803, 7031)]],
    67: [[(24085.2313, 9764, 1745, 7031)]],
    68: [[(24085.2414, 9786, 1686, 7031)]],
    74: [[(24085.3222, 9836, 125, 42188), (24085.3222, 9836, 125, 0), (24085.3222, 9836, 125, 0)],
         [(24085.3227, 9877, 1133, 14766), (24085.3227, 9877, 1133, 0)]],
}


def _goto(j1: int, ff: int) -> CommandFrame:
    return CommandFrame(command=BoardCommand.GOTO, positions=(j1, *_REST), speeds=(ff, 0, 0, 0, 0, 0))


def _status(j1: int, v: int, timing: int) -> StatusFrame:
    return StatusFrame(positions=(j1, *_REST), speeds=(v, 0, 0, 0, 0, 0), homed=0xFF, io=0x0F, timing=timing,
                       xtr=_GOTO)


def test_the_logged_backlog_answered_late_is_judged_against_the_frames_it_answers():
    """The log's frames and replies, replayed into a controller core as its driver handed them
    over (tick by tick: the frame written, then the replies read after it, the reply wait's
    batch first).  The five late replies answer frames 69-73, the oldest unanswered (the board
    answers in order); taken as answers to 72, 73, 74 and 74 again, the fourth (J1 41 steps on
    in 21 ms under frame 71's goal) was judged against frames 72-74 ('J1 moved 41 steps where
    53 were commanded') and the robot was disabled."""
    core = ControllerCore(model=PAROL6, rate_hz=RATE, link_timeout_ticks=150)
    t0 = _LOG_FRAMES[0][1] - 0.01
    core.update(TickInput(0, t0, t0, links=(LinkEvent(LinkEventKind.UP, description="board-sim pty"),)))
    core.probe.cancel()  # (the replayed frames are not the probe's: what it would conclude is not tested here)
    shown = []
    for tick, (n, t, j1, ff) in enumerate(_LOG_FRAMES, start=1):
        batches = tuple(ReplyBatch(tuple(_status(p, v, timing) for _, p, v, timing in batch), batch[0][0],
                                   batch[0][0], k == 0) for k, batch in enumerate(_LOG_REPLIES.get(n, [])))
        core.update(TickInput(tick, t + 0.0001, t + 0.0001, written=Written(_goto(j1, ff), t, t), replies=batches))
        shown.append(core.status.positions[0] if core.status is not None else None)
    assert core.integrity.uncommanded == 0, core.integrity.last_fault
    assert core.safety.error is None, core.safety.error
    # every reply is true (each follows from the one before under the frame it answered); the
    # status shows the newest: J1 at 9877
    assert core.integrity.implausible == 0
    assert shown[-1] == 9877


def test_the_link_record_numbers_a_late_backlog_in_order():
    """LinkHistory alone, the same sequence: the replies read after frame 74 was written answer
    69, 70, 71 (the reply wait's three) and 72, 73 (the two read at the next tick's start); each
    one could at most answer the newest frame less the replies read after it."""
    link = LinkHistory()
    ranges = []
    for n, t, j1, ff in _LOG_FRAMES:
        assert link.sent(_goto(j1, ff), t) == n - 65
        for k, batch in enumerate(_LOG_REPLIES.get(n, [])):
            for i in range(len(batch)):
                lo, hi = link.answered_range(len(batch), i, after_write=k == 0)
                ranges.append((lo + 65, hi + 65))
    assert ranges == [(66, 66), (67, 67), (68, 68), (69, 72), (70, 73), (71, 74), (72, 73), (73, 74)]
    assert link.unanswered == 0


#: a MoveJoint at 30 % of the maximum speeds: J1 runs at about 2,000 steps/s, as in the log (its
#: goals keep advancing for a few frames of a stall before the guard's box holds them)
MOVE = "None|30|100"


def _stalled_move(*, rewrite_at: int | None = None) -> Rig:
    """A MoveJoint (:data:`MOVE`) on a board in lockstep with the frames; 20 ticks into it the
    board stops reading its input for six frames (a board-sim process descheduled, a USB link
    held up) and then takes the first three in one pass, while the PC waits for the reply to the
    sixth (so they reach it in that frame's reply wait), the other three two periods later with
    the seventh and eighth.  ``rewrite_at``: the frame (counted from the stall's first) that reaches the board
    with J1's target 0x3000 steps further (a corrupted byte: a real uncommanded motion)."""
    r = Rig(lockstep=True, link_timeout_ticks=40, wrap=LinkFault)
    r.submit(f"aaaa0001|MOVEJOINT|60|-90|180|0|0|180|{MOVE}")
    r.run_until(lambda: AckStatus.EXECUTING in r.statuses("aaaa0001"))
    r.tick(20)
    period = 1.0 / RATE
    start = r.emu.time_s  # the board's time as the stall's first frame is written (lockstep)
    for k in range(8):
        # frames 0-2 arrive together half a period after frame 5 was written, 3-5 (and 6, 7 behind
        # them) two periods later: the board answers each batch in one pass
        due = start + (5.5 if k < 3 else 7.5) * period
        r.emu.set_faults(delay_s=max(0.0, due - r.emu.time_s), direction="to_board")
        if k == rewrite_at:
            r.transport.rewrite_next(lambda f: f.command == BoardCommand.GOTO,
                                     lambda f: CommandFrame(positions=(f.positions[0] + 0x3000, *f.positions[1:]),
                                                            speeds=f.speeds, command=f.command))
        r.tick()
    r.emu.clear_faults()
    return r


def test_a_board_that_stalls_and_answers_part_of_its_backlog_in_a_reply_wait_is_no_uncommanded_motion():
    """The log's situation on the board emulator: the reply wait of the stall's sixth frame
    reads the replies to its first three (the board took them in one pass); they answer those
    three, not the newest ones, and the next replies (the board ran the third frame's goal in
    between) follow from them.  The move completes without a fault."""
    r = _stalled_move()
    try:
        r.run_until(lambda: r.terminal("aaaa0001") is not None)
        assert r.core.integrity.uncommanded == 0, r.core.integrity.last_fault
        assert r.terminal("aaaa0001") is AckStatus.COMPLETED, r.acks[-3:]
    finally:
        r.close()


def test_a_real_uncommanded_motion_inside_a_late_backlog_is_still_caught():
    """The other side: the same stall, but the backlog's third frame reaches the board with J1's
    target 0x3000 steps off (a corrupted byte).  J1 races there from the pass that takes the
    backlog in, so the replies after it show motion no frame written could produce, whichever
    frame of the backlog they answer: DISABLE within three frames of the first reply showing it,
    as without a stall (test_integrity's corrupted-target tests)."""
    r = _stalled_move(rewrite_at=2)
    try:
        assert r.transport.rewritten
        # the race first shows in the replies read with the stall's seventh frame (the last
        # tick of _stalled_move); the frames written after it:
        n = len(r.frames)
        r.tick(3)
        assert any(f.command == BoardCommand.DISABLE for f in r.frames[n:]), [int(f.command) for f in r.frames[n:]]
        assert r.core.integrity.uncommanded == 1 and "J1 moved" in (r.core.safety.error or "")
        assert r.terminal("aaaa0001") is AckStatus.CANCELLED
    finally:
        r.close()


def test_after_a_reply_lost_without_a_trace_the_count_is_set_right_by_the_motion_and_a_race_is_caught():
    """A reply that never reaches the PC leaves no dropped byte behind (the board never took the
    frame in, or the link lost the whole reply): from then on the count of replies lags one
    frame behind the frames they answer, and nothing in the count says so.  Each reply is judged
    against every frame it can answer (from the count's up to the newest written less the
    replies after it); the board's motion soon shows which one (the board ran the frame the
    reply before answered), and the integrity check's count is right again.  A corrupted target
    after that is caught as fast as on a clean link: DISABLE within three frames."""
    r = Rig(wrap=LinkFault)
    try:
        r.submit(f"aaaa0001|MOVEJOINT|60|-90|180|0|0|180|{MOVE}")
        r.run_until(lambda: AckStatus.EXECUTING in r.statuses("aaaa0001"))
        r.tick(20)
        r.emu.set_faults(drop_rate=1.0, direction="from_board")  # this frame's reply: gone
        r.tick()
        r.emu.clear_faults()
        r.tick(5)
        integ = r.core.integrity
        last = integ.frames_written  # the last reply read answers the newest frame written
        assert (integ._recent[-1].n, integ._recent[-1].hi) == (last, last)
        # (the reply after the lost one spans two frames' motion: not within the board's own
        # precision of either, so not shown, and no fault either)
        assert integ.uncommanded == 0 and integ.implausible <= 1
        r.transport.rewrite_next(lambda f: f.command == BoardCommand.GOTO,
                                 lambda f: CommandFrame(positions=(f.positions[0] + 0x3000, *f.positions[1:]),
                                                        speeds=f.speeds, command=f.command))
        n = len(r.frames)
        r.tick()  # this frame reaches the board with J1's target 0x3000 steps off
        shown = len(r.frames)
        r.tick(3)
        assert any(f.command == BoardCommand.DISABLE for f in r.frames[n:shown + 3]), \
            [int(f.command) for f in r.frames[n:]]
        assert integ.uncommanded == 1 and "J1 moved" in (r.core.error or "")
    finally:
        r.close()


def test_the_integrity_check_takes_the_go_to_law_from_robot_py():
    """The GO TO law's constants (its gain, 50/s, and the feed-forward's weight, 1/2, so the goal
    lies v_ff / 100 ahead of the target) are robot.py's alone: integrity.py writes none of its
    own, and its model of a GO TO frame settles exactly where robot.goto_goal says."""
    source = Path(integrity.__file__).read_text()
    literals = {node.value for node in ast.walk(ast.parse(source))
                if isinstance(node, ast.Constant) and type(node.value) in (int, float)}
    assert not literals & {50, 100, 0.02}, sorted(literals & {50, 100, 0.02})
    integ = integrity.StatusIntegrity(PAROL6, RATE)
    frame = _goto(9936, 1855)
    pred, _ = integ._predict((9836, *_REST), frame, 1.0)  # a second: settled on the goal
    assert pred == pytest.approx(goto_goal(frame.positions, frame.speeds), abs=1e-6)
