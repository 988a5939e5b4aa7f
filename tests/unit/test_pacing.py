"""Timing under late ticks: the loop plays the sample for the time it actually runs.

The pure pieces (``parolkit.controller.pacing``) are checked against the board emulator's own
behaviour; the activities are driven by the real loop against the virtual-clock emulator
(``tests/unit/test_controller_core.py``'s ``Rig``) with ticks that come late, irregularly,
or after a long stall, and judged by what the board did."""

from __future__ import annotations

import random

import numpy as np
import pytest
from tests.unit.test_controller_core import RATE, Rig

from parolkit.board import BoardEmulator
from parolkit.controller.pacing import SentLog, board_position, goto_fits, tracking_speed
from parolkit.protocol.commands import AckStatus
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.robot import PAROL6

PERIOD = 1.0 / RATE
VMAX = tuple(float(v) for v in PAROL6.max_speed_steps_s)
SPD = PAROL6.steps_per_deg


# ------------------------------------------------------------------------------ pure pieces


@pytest.mark.parametrize("dt", [0.004, 0.01, 0.027, 0.2])
def test_board_position_follows_the_emulated_firmware_for_goto_and_jog(dt):
    emu = BoardEmulator(clock="virtual", start_homed=True)
    start = emu.positions
    target = [p + d for p, d in zip(start, (400, -300, 250, 800, -600, 100))]
    ff = (3000, -2500, 1200, 9000, -4000, 0)
    emu.process_frame(CommandFrame(positions=tuple(target), speeds=ff, command=BoardCommand.GOTO))
    emu.advance(dt)
    for j in range(6):
        model = board_position(start[j], BoardCommand.GOTO, target[j], ff[j], dt)
        assert abs(model - emu.positions[j]) <= 2 + 0.03 * abs(model - start[j]), j
    here = emu.positions
    speeds = (1000, -2000, 0, 500, 7000, -3000)
    emu.process_frame(CommandFrame(positions=here, speeds=speeds, command=BoardCommand.JOG))
    emu.advance(dt)
    for j in range(6):
        assert abs(board_position(here[j], BoardCommand.JOG, 0, speeds[j], dt) - emu.positions[j]) <= 1
    assert board_position(5.0, BoardCommand.IDLE, 100, 100, dt) == 5.0


def test_goto_fits_bounds_the_step_since_the_last_frame_and_the_boards_speed():
    prev = (1000,) * 6
    here = (1000.0,) * 6
    zero = (0,) * 6
    step = int(VMAX[0] / 50) - 1  # the board's 50/s gain at maximum speed
    ok = (1000 + step,) + (1000,) * 5
    assert goto_fits(ok, zero, prev, 0.05, here, VMAX)
    # the same target needs more time than 1 ms since the previous frame for its step
    assert not goto_fits(ok, zero, prev, 0.001, here, VMAX)
    # the board would start faster than its maximum speed
    assert not goto_fits((1000 + step + 3,) + (1000,) * 5, zero, prev, 1.0, here, VMAX)
    # feed-forward counts half
    assert not goto_fits(ok, (int(VMAX[0] * 0.2),) + (0,) * 5, prev, 1.0, here, VMAX)


def test_tracking_speed_reaches_the_plan_within_its_bounds():
    assert tracking_speed(110.0, 100.0, 0.01, -5000, 5000) == 1000
    assert tracking_speed(1000.0, 0.0, 0.01, -5000, 5000) == 5000  # behind: catch up at the bound
    assert tracking_speed(90.0, 100.0, 0.01, 0, 5000) == 0  # a jog never turns back
    assert tracking_speed(-1000.0, 0.0, 0.01, -6500.5, 0) == -6500


def test_the_estimate_runs_the_frames_sent_since_the_one_the_status_answers():
    log = SentLog()
    st = StatusFrame(positions=(0,) * 6)
    assert log.estimate(st, 0.0) == [0.0] * 6  # nothing sent since
    log.record(0.00, BoardCommand.JOG, (0,) * 6, (1000, 0, 0, 0, 0, 0))
    log.record(0.01, BoardCommand.JOG, (0,) * 6, (2000, 0, 0, 0, 0, 0))
    # no new status: the old one still stands for the time before the first frame
    assert log.estimate(st, 0.02)[0] == pytest.approx(10 + 20)
    # a new status answers the newest frame: it shows the board when that frame arrived
    st2 = StatusFrame(positions=(12,) + (0,) * 5)
    assert log.estimate(st2, 0.015)[0] == pytest.approx(12 + 2000 * 0.005)
    log.record(0.02, BoardCommand.JOG, (0,) * 6, (0,) * 6)
    assert log.estimate(st2, 0.5)[0] == pytest.approx(12 + 20)  # then stopped


# ------------------------------------------------------------------------------ the loop


class TimedRig(Rig):
    """Records, for every tick, its time, the frame written and where the board really was."""

    def __init__(self, **kw) -> None:
        self.log: list[tuple[float, CommandFrame | None, tuple[int, ...]]] = []
        super().__init__(**kw)

    def tick(self, n: int = 1, dt: float = PERIOD) -> None:
        for _ in range(n):
            before = self.emu.positions
            k = len(self.frames)
            super().tick(1, dt)
            self.log.append((self.now - dt, self.frames[k] if len(self.frames) > k else None, before))

    def play(self, cid: str, dts, max_ticks: int = 5000) -> None:
        """Tick with the given gaps (cycled) until ``cid`` ends."""
        i = 0
        while self.terminal(cid) is None:
            self.tick(dt=dts[i % len(dts)])
            i += 1
            assert i < max_ticks, "the command never ended"


@pytest.fixture
def trig():
    r = TimedRig()
    yield r
    r.close()


def _start(r: TimedRig, text: str) -> int:
    """Submit ``text`` and tick until it runs; the index in ``r.log`` of its first frame."""
    r.submit("aaaa0001|" + text)
    r.run_until(lambda: AckStatus.EXECUTING in r.statuses("aaaa0001"))
    return len(r.log) - 1


def loop_gaps(rng: random.Random, count: int, *, jitter_s: float, stalls: dict[int, float]) -> list[float]:
    """Gaps between ticks as the real loop has them: each tick wakes up to ``jitter_s`` after
    its deadline; at tick ``k`` in ``stalls`` the machine stalls that long, after which the
    loop skips the deadlines it missed."""
    times = [0.0]
    k = 0
    for i in range(1, count):
        k += 1
        t = k * PERIOD + rng.uniform(0.0, jitter_s)
        if i in stalls:
            t = times[-1] + stalls[i]
            k = int(t / PERIOD)
        times.append(t)
    return [b - a for a, b in zip(times, times[1:])]


def _last_sample_time(r: TimedRig, first: int, final: tuple[int, ...]) -> float:
    return next(t for t, f, _ in r.log[first:] if f is not None and f.positions == final)


def test_a_timed_move_keeps_its_wall_clock_duration_when_ticks_come_late(trig):
    """Ticks 10-30 ms apart at random (nominal 10 ms): the move still reaches its last sample
    at its planned time (give or take the gap of the tick that plays it); one sample per tick
    would have stretched it about 2x."""
    first = _start(trig, "MOVEJOINT|50|-70|160|20|-20|160|3|None")
    n = trig.ex.activity.n
    final = tuple(trig.ex.activity.positions[-1])
    rng = random.Random(4)
    trig.play("aaaa0001", [rng.uniform(0.010, 0.030) for _ in range(997)])
    assert trig.terminal("aaaa0001") is AckStatus.COMPLETED
    took = _last_sample_time(trig, first, final) - trig.log[first][0]
    assert abs(took - (n - 1) * PERIOD) <= 0.030 + 0.5 * PERIOD
    assert np.allclose(np.asarray(trig.loop.status.positions) / SPD, [50, -70, 160, 20, -20, 160], atol=0.05)


def test_after_a_stall_the_move_catches_up_only_as_fast_as_the_board_can_follow(trig):
    """A 250 ms stall early in a move: the next targets advance only as far as keeps the
    board's speed (0.5 * v_ff + 50 * (target - position), from its true position) within the
    maximum, catching up over several ticks, and the move ends on time."""
    first = _start(trig, "MOVEJOINT|40|-90|180|0|0|180|2.5|None")
    n = trig.ex.activity.n
    final = tuple(trig.ex.activity.positions[-1])
    trig.tick(40)
    stall_at = len(trig.log)
    trig.tick(dt=0.25)
    trig.play("aaaa0001", [PERIOD])
    assert trig.terminal("aaaa0001") is AckStatus.COMPLETED
    caught = trig.log[stall_at + 1:stall_at + 30]
    leaps = 0
    for _, f, before in caught:
        assert f is not None and f.command == BoardCommand.GOTO
        for j in range(6):
            assert abs(0.5 * f.speeds[j] + 50 * (f.positions[j] - before[j])) <= VMAX[j] * 1.02, (j, f)
    for (_, a, _), (_, b, _) in zip(caught, caught[1:]):
        leaps += abs(b.positions[0] - a.positions[0]) > abs(b.speeds[0]) * PERIOD * 1.5
    assert leaps >= 3  # caught up over several ticks, each a bounded leap
    took = _last_sample_time(trig, first, final) - trig.log[first][0]
    assert took - (n - 1) * PERIOD <= 0.5 * PERIOD + 1e-9  # on time: the stall was made good


def test_a_speed_tracked_move_ends_where_planned_despite_irregular_ticks(trig):
    _start(trig, "MOVEJOINT|50|-80|170|10|-10|170|2|None|None|None|speed")
    rng = random.Random(7)
    trig.play("aaaa0001", [rng.uniform(0.008, 0.028) for _ in range(991)])
    assert trig.terminal("aaaa0001") is AckStatus.COMPLETED
    assert trig.frames[-1].command == BoardCommand.JOG and trig.frames[-1].speeds == (0,) * 6
    end = np.asarray(trig.emu.positions) / SPD
    assert np.abs(end - [50, -80, 170, 10, -10, 170]).max() <= 0.1, end


@pytest.mark.parametrize("text, joint, deg", [("JOG|0|40|None|6", 0, 6.0), ("JOG|11|50|None|60", 5, -60.0),
                                              ("JOG|3|100|0.9|None", 3, 0.9 * 7000 / SPD[3])])
def test_a_jog_covers_its_distance_within_a_tenth_of_a_degree_through_late_ticks(trig, text, joint, deg):
    """Ticks wake up to 1 ms late and the machine stalls 40-90 ms three times during the jog
    (each jog lasts more than a second; a stall that delays the final stop frame would overrun
    by speed x stall, which no controller can take back): the jog still covers speed x
    duration (its distance) within 0.1 deg, never faster than asked.  (Stalls stay under the
    93 ms after which the board's 16-bit ``timing`` field wraps: the integrity check unwraps
    it with the read times, which stand still on this rig's virtual clock.)"""
    start = np.asarray(trig.emu.positions) / SPD
    first = _start(trig, text)
    rng = random.Random(3)
    trig.play("aaaa0001", loop_gaps(rng, 4000, jitter_s=0.001, stalls={5: 0.04, 12: 0.09, 20: 0.07}))
    assert trig.terminal("aaaa0001") is AckStatus.COMPLETED
    moved = np.asarray(trig.emu.positions) / SPD - start
    assert abs(moved[joint] - deg) <= 0.1, moved
    assert np.abs(np.delete(moved, joint)).max() == 0
    jog = [f for _, f, _ in trig.log[first:] if f is not None and f.command == BoardCommand.JOG]
    assert max(abs(f.speeds[joint]) for f in jog) == abs(jog[0].speeds[joint])
    assert jog[-1].speeds == (0,) * 6
