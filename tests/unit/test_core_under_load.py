"""Correct under load (issue 23, item 5), as a property: the real core and driver against the
board emulator, with every tick late or early at random (the board runs as long as the tick
took: a busy PC) and the board's replies held back by a random 0-40 ms (changing from tick to
tick, delivered in order), while moves, jogs and Cartesian moves run.  Now and then the board
stalls: it reads nothing for up to 15 periods (the frames written meanwhile wait in its input,
in order) and then answers the whole backlog at once, one reply per frame, all with the
telemetry of that one pass (the stock firmware drains its serial input once a pass); and now
and then the PC is held up between writing a frame and reading its reply (a preempted tick
thread), so such a backlog's replies are read in the reply wait of a newer frame.

For every example:

* the board never runs a joint above its maximum speed (read at every 0.5 ms of board time,
  plus the guard's rounding allowance of a hundredth of a step = 0.5 steps/s);
* no uncommanded-motion fault (the late replies are true ones);
* every command COMPLETES (a Cartesian move that the jogs before it left at the wrist
  singularity may be refused before it starts, naming it) and the last one ends exactly at
  its target;
* what the lateness cost shows, if anywhere, as a move that ran stretched (a warning in its
  ack), never as a refusal.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from unittest import mock

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from tests.unit.test_controller_core import RATE, Rig

from parolkit.board.emulator import BoardEmulator
from parolkit.controller import driver
from parolkit.protocol.commands import AckStatus
from parolkit.robot import PAROL6
from parolkit.transport.base import Transport
from parolkit.transport.emulated import EmulatorTransport

VMAX = [float(v) for v in PAROL6.max_speed_steps_s]
PERIOD = 1.0 / RATE
SUB = 0.0005

_move = st.one_of(
    st.tuples(st.just("joint"), st.floats(60, 120), st.floats(-110, -70), st.floats(150, 200),
              st.sampled_from(["3", "None|100|100", "None|60|40"])),
    st.tuples(st.just("jog"), st.integers(0, 5), st.sampled_from([-1, 1]), st.integers(20, 100)),
    st.tuples(st.just("cart"), st.floats(-20, 20), st.floats(-20, 20), st.floats(-20, 20)),
)
#: how long each tick ran, in periods: mostly on time, some late, some early (after a late one)
_dt = st.sampled_from([1.0, 1.0, 1.0, 1.0, 0.2, 0.5, 1.5, 2.0, 3.0, 5.0])
_delay = st.sampled_from([0.0, 0.0, 0.002, 0.008, 0.015, 0.025, 0.04])
#: how long the board leaves the frame written in a tick unread, in periods (the frames written
#: after it wait behind it: a stall, then the whole backlog at once), and how much of the tick
#: the PC spends between writing its frame and reading the reply
_stall = st.sampled_from([0.0] * 8 + [0.5, 1.5, 3.0, 4.5, 6.0, 9.0, 12.0, 15.0])
_held = st.sampled_from([0.0] * 4 + [0.3, 0.6, 0.95])
_board = st.tuples(_stall, _held)


class _BoardClock:
    """The driver's ``time`` module in this test: its monotonic clock is the test's clock (the
    ticks' times), plus the time the PC was held up within the tick (:class:`_HeldUp`)."""

    def __init__(self) -> None:
        self.emu: BoardEmulator | None = None
        self.rig: Rig | None = None
        self.held = 0.0

    def monotonic(self) -> float:
        if self.rig is not None:
            return self.rig.now + self.held
        assert self.emu is not None  # (while the rig starts up: the board's time is the ticks')
        return self.emu.time_s + self.held

    perf_counter = staticmethod(time.perf_counter)
    sleep = staticmethod(time.sleep)


class _HeldUp(Transport):
    """The emulator's link, with the PC held up for :attr:`hold` s (the board running) after it
    wrote a frame and stamped it, as its reply wait starts reading (``used``: how long it was
    held up in this tick); ``run(s)`` runs the board.

    Time passes inside a tick here, which a virtual clock rules out (the driver stamps what it
    reads with the tick's time): the link says it is a real one, and the driver's monotonic
    clock (:class:`_BoardClock`) has the hold in it, so replies are stamped when they are read,
    as on a real link."""

    def __init__(self, inner: EmulatorTransport, run: Callable[[float], None], clock: _BoardClock) -> None:
        self.inner = inner
        self.run = run
        self.clock = clock
        self.hold = 0.0
        self.used = 0.0
        self._due = False
        self.simulated = True
        self.virtual_clock = False
        self.step_s = None

    @property
    def description(self) -> str:
        return "held up + " + self.inner.description

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def open(self) -> None:
        self.inner.open()

    def close(self) -> None:
        self.inner.close()

    def write(self, data: bytes) -> None:
        self.inner.write(data)
        self._due = self.hold > self.used

    def read(self) -> bytes:
        if self._due:  # the reply wait's first read: the PC was held up until now
            self._due = False
            self.run(self.hold - self.used)
            self.used = self.clock.held = self.hold
        return self.inner.read()


def _text(cid: str, m: tuple) -> str:
    if m[0] == "joint":
        _, j1, j2, j3, timing = m
        return f"{cid}|MOVEJOINT|{j1:.3f}|{j2:.3f}|{j3:.3f}|0|30|180|{timing}" + ("" if "|" in timing else "|None")
    if m[0] == "jog":
        _, joint, sign, pct = m
        return f"{cid}|JOG|{joint + (6 if sign < 0 else 0)}|{pct}|0.25|None"
    _, dx, dy, dz = m
    return f"{cid}|MOVECARTRELTRF|{dx:.2f}|{dy:.2f}|{dz:.2f}|0|0|0|1|None"


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
# found by Hypothesis once board stalls of 9-15 periods were drawn: two 15-period stalls while
# J2 held goals between two whole steps; the guard took the joint to stand no further than its
# goal, but it steps back and forth across a fractional one, and a frame at the box's edge
# started J2 at 18,027 steps/s (its maximum 18,000)
@example(moves=[('joint', 119.0, -90.0, 180.0, '3'),
                ('cart', -18.822913978273697, 3.434465520312436, 10.986571461178212),
         ('joint', 67.7729002312607, -71.90177286816298, 180.0, 'None|100|100'), ('joint', 90.29684288587539,
         -101.54193327985782, 199.99999999999997, 'None|60|40')], timing=[(3.0, 0.0), (1.0, 0.0), (2.0, 0.0), (5.0,
         0.0), (1.0, 0.0), (1.0, 0.0), (5.0, 0.015), (1.0, 0.008), (1.5, 0.04), (0.5, 0.0), (5.0, 0.0), (2.0, 0.0),
         (3.0, 0.04), (0.5, 0.0), (1.5, 0.0), (1.0, 0.0), (1.5, 0.025), (0.2, 0.04), (0.5, 0.04), (5.0, 0.008),
         (5.0, 0.008), (1.0, 0.0), (1.5, 0.015), (1.0, 0.04), (1.0, 0.008), (1.0, 0.0), (1.0, 0.04), (3.0, 0.008),
         (1.0, 0.008), (1.0, 0.0), (0.2, 0.0), (1.0, 0.025), (1.0, 0.0), (1.0, 0.0), (5.0, 0.04), (1.0, 0.015),
         (3.0, 0.015), (1.0, 0.015), (1.0, 0.002), (0.2, 0.025), (0.5, 0.0), (1.0, 0.015), (3.0, 0.008), (2.0, 0.0),
         (1.0, 0.015), (1.0, 0.002), (5.0, 0.0), (1.0, 0.0), (1.0, 0.008), (1.0, 0.025), (1.0, 0.002), (1.0, 0.0),
         (5.0, 0.002), (1.0, 0.015), (0.2, 0.04), (1.0, 0.025)], board=[(1.5, 0.0), (0.0, 0.0), (0.0, 0.3), (15.0,
         0.0), (15.0, 0.0), (0.0, 0.0), (0.0, 0.6), (0.0, 0.3), (0.0, 0.0)])
# found by Hypothesis beside two CPU hogs: J5 jogged from 30 deg to the wrist singularity, then a
# 1 s Cartesian move from there, rightly refused (with the duration that would do)
@example(moves=[("jog", 4, -1, 80), ("jog", 0, -1, 20), ("cart", 19.06, 15.49, 0.0),
                ("joint", 63.3, -87.83, 150.0, "3")], timing=[(1.0, 0.0)] * 20, board=[(0.0, 0.0)])
# found by Hypothesis in a full run: from J1 at 120 deg, 8 mm along -y (tool frame) needs J1 at
# 123.0 deg, past its range: refused before it starts, naming the joint and its range
@example(moves=[("joint", 120.0, -108.0, 150.0, "3"), ("cart", 0.0, -8.0, 0.0)], timing=[(1.0, 0.0)] * 20,
         board=[(0.0, 0.0)])
# issue 23's false "uncommanded motion: J1 moved 41 steps where 53 were commanded" (a controller
# and board-sim over a pty at load 10-17): the board stalls for 6 periods, then takes the first
# three frames of its backlog in one pass while the PC, held up after writing the sixth, reads
# their replies in that frame's reply wait; the other three come two periods later.  Those replies
# were taken as the answers to the newest frames, and the next true one judged against frames it
# could not have answered
@example(moves=[("joint", 60.0, -90.0, 180.0, "None|30|100")], timing=[(1.0, 0.0)] * 20,
         board=[(0.0, 0.0)] * 60 + [(5.5, 0.0), (4.5, 0.0), (3.5, 0.0), (4.5, 0.0), (3.5, 0.0), (2.5, 0.95)]
         + [(0.0, 0.0)] * 20)
@given(moves=st.lists(_move, min_size=1, max_size=4), timing=st.lists(st.tuples(_dt, _delay), min_size=20,
                                                                      max_size=400),
       board=st.lists(_board, min_size=1, max_size=400))
def test_late_ticks_and_late_replies_never_overspeed_fault_or_lose_a_move(moves, timing, board):
    peak = [0.0] * 6

    def run(seconds: float) -> None:  # the board runs, its speeds read every 0.5 ms
        left = seconds
        while left > 1e-12:
            step = min(SUB, left)
            rig.emu.advance(step)
            left -= step
            for j, v in enumerate(rig.emu.speeds):
                peak[j] = max(peak[j], abs(v))

    held: list[_HeldUp] = []
    clock = _BoardClock()

    def wrap(inner: EmulatorTransport) -> _HeldUp:
        clock.emu = inner.emulator
        held.append(_HeldUp(inner, run, clock))
        return held[0]

    with mock.patch.object(driver, "time", clock):
        rig = Rig(link_timeout_ticks=40, link_hold_frames=2, wrap=wrap)
        clock.rig = rig
        try:
            _run_moves(rig, moves, timing, board, held[0], run, peak)
        finally:
            rig.close()


def _run_moves(rig: Rig, moves: list, timing: list, board: list, held: _HeldUp, run: Callable[[float], None],
               peak: list[float]) -> None:
    # off the standby pose's wrist singularity, so every Cartesian move is well-posed
    rig.submit("prep0001|MOVEJOINT|90|-90|180|0|30|180|1|None")
    rig.run_until(lambda: rig.terminal("prep0001") is not None)
    ids = [f"m{i:07d}" for i in range(len(moves))]
    for cid, m in zip(ids, moves):
        rig.send(_text(cid, m))
    peak[:] = [0.0] * 6
    k = 0
    while any(rig.terminal(cid) is None for cid in ids):
        assert k < 3000, rig.acks[-5:]
        dt, delay = timing[k % len(timing)]
        stall, hold = board[k % len(board)]
        k += 1
        rig.emu.set_faults(delay_s=delay, direction="from_board")
        rig.emu.set_faults(delay_s=stall * PERIOD, direction="to_board")
        held.hold = hold * dt * PERIOD
        held.used = held.clock.held = 0.0
        rig.step()
        run(dt * PERIOD - held.used)  # the board runs as long as the tick took
        rig.now += dt * PERIOD
    held.hold = held.used = held.clock.held = 0.0
    rig.emu.clear_faults()
    rig.tick(10)
    over = [(j, peak[j], VMAX[j]) for j in range(6) if peak[j] > VMAX[j] + 0.5]
    assert not over, over
    assert rig.core.integrity.uncommanded == 0, rig.core.integrity.last_fault
    done = {cid: rig.terminal(cid) for cid in ids}
    # a Cartesian move planned from where the moves before it left the arm may be refused
    # before it starts: its path passes the wrist singularity (J5 jogged to 0), or leaves a
    # joint's range (from J1 at 120 deg, 8 mm along -y needs J1 at 123.0: "allowed -123 ..
    # 123 deg"), with the reason: geometry, not lateness; every other command completes
    refused = {c for c, s, d in rig.acks if c in ids and s is AckStatus.FAILED
               and "refused" in d and ("singularity" in d or "(allowed " in d)}
    started = {c for c, s, _ in rig.acks if s is AckStatus.EXECUTING}
    assert not refused & started, (refused, rig.acks[-6:])
    assert all(s is AckStatus.COMPLETED or c in refused for c, s in done.items()), (done, rig.acks[-6:])
    details = [d for c, s, d in rig.acks if c in ids and s is AckStatus.COMPLETED]
    assert all("finished successfully" in d or "stopped at the" in d for d in details), details
    # at rest exactly on the last move's final target (COMPLETED says the board reported it)
    last = next(f for f in reversed(rig.frames) if f.command == 156)
    assert tuple(rig.emu.positions) == tuple(last.positions) and not any(last.speeds)
    assert rig.emu.speeds == (0,) * 6


# derandomized: the same 40 examples every run.  What is left is a documented limit (docs/
# protocol.md): two replies in a row with the same position byte corrupted to values that agree
# with each other read as motion, about twice in 10^7 pairs of replies at 1 % corruption, so a
# random 40 (12,000 pairs) would fail about one run in 400.  Hunted with 6,000 random examples
# at a time while these checks were written (each find is pinned below).
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
# found by Hypothesis: replies 15 ms late for one tick, then a tick 1.5 periods long
@example(seed=307325, timing=[(1.0, 0.0)] * 16 + [(1.0, 0.015), (1.5, 0.0), (1.0, 0.0), (1.0, 0.0)])
# two replies in a row with J6's low byte corrupted, both beyond the hull: they contradict each other
@example(seed=13373098, timing=[(1.0, 0.0)] * 32 + [(5.0, 0.0)] + [(1.0, 0.0)] * 5)
# J6 shown 7 steps off after a 30 ms interval: the next reply's link forgives that much
@example(seed=3073977, timing=[(1.0, 0.0)] * 2 + [(3.0, 0.0)] * 2 + [(1.0, 0.0)] * 17)
# two replies in a row with J6's middle byte corrupted alike (-21504 steps in 20 ms): no board
# gets there that fast
@example(seed=42779, timing=[(1.0, 0.0)] * 20)
# after a 50 ms interval two replies in a row with J1's low byte corrupted (109 and 131 steps off,
# at rest both times) link to each other: a third reply must show it too
@example(seed=4523, timing=[(1.0, 0.0)] * 3 + [(5.0, 0.0)] + [(1.0, 0.0)] * 16)
# a suspect (J1 22 steps off after 50 ms) "confirmed" beyond the hull by a later reply whose J1 is
# garbage (6825984 steps): a confirmation must lie where the board can have gone from the suspect
@example(seed=43026, timing=[(1.0, 0.0)] * 38 + [(5.0, 0.0)])
# a reply beyond the hull (J1 108 steps off) "linked" by the next one only through that one's
# corrupted timing field (50 ms), which is back within the hull: no excursion shown twice
@example(seed=126332, timing=[(1.0, 0.0)] * 21 + [(2.0, 0.0), (0.5, 0.0), (1.5, 0.0), (5.0, 0.0), (5.0, 0.0),
                                                (5.0, 0.04), (5.0, 0.04), (5.0, 0.0), (5.0, 0.0), (1.0, 0.0),
                                                (1.0, 0.0), (1.0, 0.002), (1.0, 0.015)] + [(1.0, 0.0)] * 19
         + [(1.0, 0.04)])
@given(seed=st.integers(0, 2**31 - 1), timing=st.lists(st.tuples(_dt, _delay), min_size=20, max_size=400))
def test_corrupted_late_replies_never_read_as_uncommanded_motion(seed, timing):
    """1 % of the reply bytes corrupted while the replies come late and bunched (a busy PC):
    a reply lost to corruption shifts which frame a late reply answers; the moves must still
    run without a false uncommanded-motion fault.  (Found beside two CPU hogs: 'J1 moved 33
    steps where 24 were commanded' in test_controller_pty's 1 % corruption run.)"""
    rig = Rig(link_timeout_ticks=150, link_hold_frames=2, seed=seed)
    try:
        ids = [f"c{i:07d}" for i in range(4)]
        for i, cid in enumerate(ids):
            rig.send(f"{cid}|MOVEJOINT|{90 - 5 * (i % 2)}|-90|180|0|0|180|0.8|None")
        k = 0
        while any(rig.terminal(cid) is None for cid in ids) and k < 1500:
            dt, delay = timing[k % len(timing)]
            k += 1
            rig.emu.set_faults(corrupt_rate=0.01, delay_s=delay, direction="from_board")
            rig.step()
            rig.emu.advance(dt * PERIOD)
            rig.now += dt * PERIOD
        assert rig.core.integrity.uncommanded == 0, rig.core.integrity.last_fault
    finally:
        rig.close()
