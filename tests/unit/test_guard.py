"""The safety guard's rules, one by one, each against the real board emulator where the rule is
about what the board does (issue 12, item 4: no frame may command more than a joint's maximum
speed, nor a position step larger than the maximum speed allows in one period)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from tests.unit.guard_bench import PERIOD, RATE, VMAX, GuardedBoard

from parolkit.controller.guard import (
    ROUNDING_STEPS,
    SafetyGuard,
    goto_position_after,
    goto_start_speed,
    max_goto_step,
)
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.robot import GOTO_GAIN_PER_S, PAROL6, goto_tracking_factor

STANDBY = PAROL6.standby_steps
TICK = [v * PERIOD for v in VMAX]  # steps one period at the maximum speed covers


def _moved(base, joint: int, by: float) -> list[float]:
    out = [float(p) for p in base]
    out[joint] += by
    return out


def _staircase(board: GuardedBoard, joint: int, speed: float, ticks: int, *, feed_forward: bool = True):
    """Step ``joint``'s target ``speed x period`` every tick from where the board is (the
    planners' stream at a constant speed); returns the results."""
    start = board.positions
    out = []
    for k in range(1, ticks + 1):
        tgt = _moved(start, joint, speed * PERIOD * k)
        ff = [0.0] * 6
        if feed_forward:
            ff[joint] = speed
        out.append(board.goto(tgt, ff))
    return out


# ------------------------------------------------------------------- the board's GO TO law


def test_the_guards_go_to_law_is_the_boards():
    """goto_start_speed / goto_position_after against the emulator's firmware loop: the start
    speed exactly, the position a period later within the emulator's pass discretisation."""
    b = GuardedBoard()
    p0 = b.positions[0]
    b.goto(_moved(b.positions, 0, 60), _moved([0] * 6, 0, 1000))
    assert b.log[-1].start_speeds[0] == int(goto_start_speed(p0 + 60, 1000, p0))  # 50*60 + 500
    predicted = goto_position_after(p0, p0 + 60, 1000, PERIOD)
    assert abs(b.positions[0] - predicted) <= 1.0
    # the board's speed decays within the period: the status answering the next frame shows
    # the speed of the pass before it (the end of the period), not the start
    b.goto(_moved(b.log[-1].asked.positions, 0, 0))
    assert b.status.speeds[0] < 0.7 * b.log[-2].start_speeds[0]


def test_tracking_factor_is_what_the_board_needs():
    """The factor is derived, not tuned: a staircase at goto_tracking_factor(rate, 0) of the
    maximum makes the continuous board model start every period at exactly the maximum."""
    f = goto_tracking_factor(RATE, 0.0)
    assert 1 / f == pytest.approx(1.2707, abs=1e-4)
    a = math.exp(-GOTO_GAIN_PER_S * PERIOD)
    step = f * VMAX[0] * PERIOD
    assert GOTO_GAIN_PER_S * step / (1 - a) == pytest.approx(VMAX[0])
    # with the default 1 ms of arrival jitter the stream is a little slower
    assert goto_tracking_factor(RATE) == pytest.approx(0.7632, abs=1e-4)
    assert list(PAROL6.max_tracked_speed_steps_s(RATE)) == [4960, 13737, 15264, 16790, 16790, 16790]


# ------------------------------------------------------------------- rules 1-5


def test_rule1_estop_sends_disable_whatever_was_asked():
    b = GuardedBoard(estop=True)
    res = b.goto(STANDBY)
    assert res.frame.command == BoardCommand.DISABLE and res.replaced and res.violation is None
    assert not b.emu.enabled


def test_rule2_only_known_board_codes():
    b = GuardedBoard()
    res = b.send(CommandFrame(positions=STANDBY, command=77))
    assert res.frame.command == BoardCommand.IDLE and "board command 77" in res.violation


def test_rule3_home_is_never_sent_twice_in_a_row():
    b = GuardedBoard(homed=False)
    assert b.send(CommandFrame(command=BoardCommand.HOME)).violation is None
    res = b.send(CommandFrame(command=BoardCommand.HOME))
    assert res.frame.command == BoardCommand.IDLE and "one frame only" in res.violation


def test_rule4_every_speed_field_within_the_maximum():
    b = GuardedBoard()
    over = [0, 0, 0, 0, 0, 0]
    over[2] = int(VMAX[2]) + 1
    res = b.goto(STANDBY, over)
    assert res.frame.command == BoardCommand.IDLE
    assert "J3 speed 20001 steps/s exceeds the maximum 20000" in res.violation
    res = b.send(CommandFrame(positions=STANDBY, speeds=tuple(over), command=BoardCommand.IDLE))
    assert res.replaced and "J3 speed" in res.violation
    res = b.send(CommandFrame(positions=STANDBY, speeds=tuple(over), command=BoardCommand.JOG))
    assert res.frame.command == BoardCommand.JOG and res.frame.speeds == (0,) * 6
    # not homed: the maximum JOG speed
    b = GuardedBoard(homed=False)
    jog = [0, 0, 0, 0, 0, 0]
    jog[0] = int(PAROL6.max_jog_speed_steps_s[0]) + 1
    res = b.send(CommandFrame(positions=b.positions, speeds=tuple(jog), command=BoardCommand.JOG))
    assert "maximum jog speed (not homed) 1500" in res.violation


def test_rule5_go_to_needs_homing_a_known_position_and_targets_inside_the_limits():
    b = GuardedBoard(homed=False)
    assert "until the robot is homed" in b.goto(b.positions).violation
    g = SafetyGuard(PAROL6, RATE)
    res = g.check(CommandFrame(positions=STANDBY, command=BoardCommand.GOTO), None, estop=False, homed=True)
    assert "position is unknown" in res.violation and res.frame.command == BoardCommand.IDLE
    b = GuardedBoard()
    bad = list(STANDBY)
    bad[1] = PAROL6.limits_steps[1][1] + 5
    res = b.goto(bad)
    assert res.frame.command == BoardCommand.IDLE and "J2 target" in res.violation
    assert "outside the limits" in res.violation


def test_rule5_no_go_to_while_the_board_may_be_homing():
    """HOME makes the board move on its own until it reports every joint homed and still
    (IDLE frames let homing go on): a GO TO meanwhile is refused, the first one after it is
    judged from where homing left the board.  (Homed as the controller passes it: HOME at
    standby, where the board still reported homed before it started.)"""
    b = GuardedBoard()
    b.send(CommandFrame(command=BoardCommand.HOME))
    b.idle()
    res = b.goto(b.positions)
    assert "while the board may be homing" in res.violation
    while not (b.status.all_homed and not any(b.status.speeds)):
        b.idle(0.05)
        assert b.now < 30, "homing did not finish"
    b.idle()
    assert b.positions == STANDBY
    assert b.goto(_moved(STANDBY, 0, 20)).violation is None


# ------------------------------------------------------------------- rule 6: steps


def test_rule6_first_go_to_after_idle_leading_by_three_ticks_of_travel_is_replaced():
    """Issue 12: the first frame after idle may not lie further from the board than one period
    of maximum-speed travel (three ticks: the board would start at 1.5x its maximum)."""
    b = GuardedBoard()
    b.idle()
    res = b.goto(_moved(b.positions, 0, 3 * TICK[0]))
    assert res.replaced and res.frame.command == BoardCommand.IDLE
    assert "J1 target is 195 steps from where the board is" in res.violation
    assert "allows 66 steps" in res.violation
    assert b.emu.speeds == (0,) * 6 and not b.over_max()


def test_rule6_a_sub_tick_jump_is_replaced_first_frame_or_mid_stream():
    """A move played as one frame (MOVECART t=1e-9 measured J3 at 1.59x): the target jumps
    1.59 ticks of maximum-speed travel in one period."""
    b = GuardedBoard()
    b.idle()
    res = b.goto(_moved(b.positions, 2, 1.59 * TICK[2]))
    assert res.replaced and "J3 target is 318 steps from where the board is" in res.violation
    b = GuardedBoard()
    _staircase(b, 2, 0.3 * VMAX[2], 5)
    last = b.log[-1].asked.positions
    res = b.goto(_moved(last, 2, 1.59 * TICK[2]))
    assert res.replaced and "J3 target moves 318 steps from the previous one in 10.0 ms" in res.violation
    assert "allows 201 steps" in res.violation
    assert not b.over_max()


def test_rule6_a_late_frame_may_step_as_far_as_the_time_since_the_previous_one_allows():
    """Two periods since the previous frame: twice the step (the board had twice as long),
    when the board can follow within its maximum speed."""
    b = GuardedBoard()
    _staircase(b, 1, 0.3 * VMAX[1], 10)
    last = b.log[-1].asked.positions
    step = 1.5 * TICK[1]  # more than one period allows, less than two
    ff = _moved([0] * 6, 1, 0.3 * VMAX[1])
    b.now += PERIOD  # the loop ran a period late: this frame comes two periods after the last
    b.emu.advance(PERIOD)
    res = b.goto(_moved(last, 1, step), ff)
    assert res.violation is None, res.violation
    # the same step one period after the previous frame: refused
    b2 = GuardedBoard()
    _staircase(b2, 1, 0.3 * VMAX[1], 10)
    res = b2.goto(_moved(b2.log[-1].asked.positions, 1, step), ff)
    assert res.replaced and "J2 target moves 270 steps from the previous one in 10.0 ms" in res.violation
    assert not b.over_max() and not b2.over_max()


# ------------------------------------------------------------------- rule 7: start speed


def test_rule7_a_staircase_at_the_tracking_factor_passes_and_the_board_stays_within_its_maximum():
    """Issue 12: 100 % speed peaked at 1.27x the maximum on the board.  A stream at
    1 / 1.2707 of the maximum (the derived factor, no jitter margin) starts every period at
    the maximum: accepted on every joint at once, and no stepper ever runs faster."""
    b = GuardedBoard()
    start = b.positions
    f = goto_tracking_factor(RATE, 0.0)
    for k in range(1, 31):
        tgt = [p + f * v * PERIOD * k for p, v in zip(start, VMAX)]
        tgt[1] = start[1] - f * VMAX[1] * PERIOD * k  # (J2 down: it starts near its upper limit)
        ff = [f * v for v in VMAX]
        ff[1] = -ff[1]
        res = b.goto(tgt, ff)
        assert res.violation is None, (k, res.violation)
    assert not b.over_max()
    peak = max(s.start_speeds[0] for s in b.log) / VMAX[0]
    assert 0.97 < peak <= 1.0  # the board does run at (just under) its maximum


def test_rule7_a_staircase_at_the_maximum_speed_is_replaced_before_the_board_exceeds_it():
    """The same stream at 1.0x the maximum: rule 6 allows its steps (one period of travel
    each), but the board would start every period at 1.27x: replaced as soon as the board's
    lag would push it past the maximum; no accepted frame made a stepper run faster."""
    b = GuardedBoard()
    results = _staircase(b, 0, VMAX[0], 20)
    bad = [k for k, r in enumerate(results) if r.violation]
    assert bad and bad[0] <= 4, [r.violation for r in results[:6]]
    assert "J1 would start this frame at" in results[bad[0]].violation
    assert "above its maximum 6500 steps/s" in results[bad[0]].violation
    assert not b.over_max()


def test_rule7_a_late_frame_that_would_need_the_board_to_run_faster_is_replaced():
    """Catching up after a late tick: allowed exactly when the board can do it within its
    maximum speed; max_goto_step says how far that is."""
    f = goto_tracking_factor(RATE, 0.0)
    ff = _moved([0] * 6, 0, f * VMAX[0])

    def stream_then_late(step_ticks: float):
        b = GuardedBoard()
        _staircase(b, 0, f * VMAX[0], 30)
        prev = b.log[-1].asked
        lag = prev.positions[0] + prev.speeds[0] / 100.0 - b.status.positions[0]
        b.now += PERIOD
        b.emu.advance(PERIOD)
        room = max_goto_step(lag, 2 * PERIOD, VMAX[0])
        res = b.goto(_moved(prev.positions, 0, step_ticks * f * VMAX[0] * PERIOD), ff)
        return b, res, room

    # at the tracking factor the board covers 1.33 samples' worth in the two periods: two
    # samples' step (a full catch-up) would need 1.14x its maximum
    b, res, room = stream_then_late(2.0)
    assert res.replaced and "J1 would start this frame at" in res.violation
    assert room < 2.0 * f * VMAX[0] * PERIOD
    b, res, room = stream_then_late(room / (f * VMAX[0] * PERIOD) - 0.05)
    assert res.violation is None, res.violation
    assert not b.over_max()
    # at half that speed a full catch-up (two samples' step after two periods) is allowed
    b = GuardedBoard()
    _staircase(b, 0, 0.5 * f * VMAX[0], 30)
    prev = b.log[-1].asked
    b.now += PERIOD
    b.emu.advance(PERIOD)
    res = b.goto(_moved(prev.positions, 0, 2 * 0.5 * f * VMAX[0] * PERIOD), prev.speeds)
    assert res.violation is None, res.violation
    assert not b.over_max()


def test_the_guard_follows_the_board_through_late_and_lost_replies():
    """The status a frame's check sees may answer an older frame (a late reply) or none may
    come for a while (lost replies): matched to the frame it answers, no false refusal of a
    stream at the tracking factor, and the prediction stays on the board."""
    b = GuardedBoard()
    start = b.positions
    f = goto_tracking_factor(RATE)
    for k in range(1, 120):
        tgt = _moved(start, 0, -f * VMAX[0] * PERIOD * k)
        reply = k % 7 not in (3, 4, 5)  # three replies in a row lost every 7 ticks
        res = b.goto(tgt, _moved([0] * 6, 0, -f * VMAX[0]), reply=reply)
        assert res.violation is None, (k, res.violation)
    predicted = b.guard.predicted_arrival(b.now)
    assert predicted is not None and abs(predicted[0] - b.positions[0]) <= 2.0
    assert not b.over_max()


def test_a_single_corrupted_reply_does_not_stop_a_stream():
    """The link has no checksum: one flipped bit in a reply moved J2 by 512 steps (seen in the
    1 % corruption test on the pty).  One reply that matches no prediction is ignored; the
    stream at the planners' speed goes on."""
    b = GuardedBoard()
    start = b.positions
    f = goto_tracking_factor(RATE)
    for k in range(1, 60):
        if k in (10, 30, 31 + 10):
            pos = list(b.status.positions)
            pos[1] += 512
            pos[0] -= 64 if k == 30 else 0
            b.status = replace(b.status, positions=tuple(pos))
        res = b.goto(_moved(start, 0, -f * VMAX[0] * PERIOD * k), _moved([0] * 6, 0, -f * VMAX[0]))
        assert res.violation is None, (k, res.violation)
    assert not b.over_max()


def test_a_board_that_does_not_follow_is_caught():
    """The board stops following the stream (here a DISABLE the guard never saw reaches it, as
    a corrupted frame could; later an ENABLE): its replies match no predicted position, so the
    guard also checks "it has not moved since", and refuses the frame that would make it jump
    once it follows again.  No stepper ever runs faster than its maximum."""
    b = GuardedBoard()
    start = b.positions
    v = 0.5 * VMAX[0]
    violations = []
    for k in range(1, 30):
        if k == 5:
            b.emu.process_frame(CommandFrame(positions=b.positions, command=BoardCommand.DISABLE))
        if k == 12:
            b.emu.process_frame(CommandFrame(positions=b.positions, command=BoardCommand.ENABLE))
        res = b.goto(_moved(start, 0, v * PERIOD * k), _moved([0] * 6, 0, v))
        if res.violation:
            violations.append((k, res.violation))
    assert violations and 5 < violations[0][0] <= 10, violations
    assert "J1 would start this frame at" in violations[0][1]
    assert not b.over_max()


# ------------------------------------------------------------------- JOG and the stream end


def test_rule8_a_jog_may_not_reach_a_limit_within_the_lookahead():
    b = GuardedBoard()
    g = b.guard
    st = StatusFrame(positions=(PAROL6.limits_steps[0][1] - 100, *STANDBY[1:]), homed=0xFF, io=0x0F)
    res = g.check(CommandFrame(positions=st.positions, speeds=(5000, 0, 0, 0, 0, 0), command=BoardCommand.JOG),
                  st, estop=False, homed=True)
    assert res.frame.speeds == (0,) * 6 and "would pass its upper limit 14000 steps" in res.violation


def test_rule9_a_speed_stream_is_always_ended_by_a_zero_speed_frame():
    b = GuardedBoard()
    b.send(CommandFrame(positions=b.positions, speeds=(1000, 0, 0, 0, 0, 0), command=BoardCommand.JOG))
    res = b.goto(b.positions)
    assert res.frame.command == BoardCommand.JOG and res.frame.speeds == (0,) * 6 and res.violation is None
    assert b.emu.speeds == (0,) * 6


def test_a_second_check_at_the_same_time_replaces_the_first():
    """The loop's safety pre-emption: only the second frame of a tick is written, so the guard
    judges the next tick's frame against it, not against the frame that never went out."""
    g = SafetyGuard(PAROL6, RATE)
    st = StatusFrame(positions=STANDBY, homed=0xFF, io=0x0F)
    g.check(CommandFrame(positions=STANDBY, command=BoardCommand.IDLE), st, estop=False, homed=True, now=0.0)
    g.check(CommandFrame(command=BoardCommand.HOME), st, estop=False, homed=True, now=0.01)
    g.check(CommandFrame(positions=STANDBY, command=BoardCommand.IDLE), st, estop=False, homed=True, now=0.01)
    # the HOME never went out: a HOME now is not "twice in a row"
    res = g.check(CommandFrame(command=BoardCommand.HOME), st, estop=False, homed=True, now=0.02)
    assert res.violation is None


def test_rounding_allowance_is_one_step():
    assert ROUNDING_STEPS == 1.0
    b = GuardedBoard()
    b.idle()
    assert b.goto(_moved(b.positions, 0, TICK[0] + 1)).violation is None  # 66 steps: 65 + rounding
    b = GuardedBoard()
    b.idle()
    assert b.goto(_moved(b.positions, 0, TICK[0] + 2)).violation is not None
