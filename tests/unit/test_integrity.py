"""Board link integrity, tick by tick: the real controller core, its driver and StatusIntegrity
against the real board emulator on a virtual clock, with deliberate link faults injected on
the bytes between them (issue 12, items 5 and 7).

The faults are byte-level, like the ones a link without checksum suffers: a command frame
rewritten on its way to the board (the board executes what it receives), a reply byte changed
on its way back, random corruption at a fixed seed."""

from __future__ import annotations

import time
from collections.abc import Callable

import pytest
from tests.unit.test_controller_core import RATE, Rig

from parolkit.board.homing import HomingPhase
from parolkit.controller.integrity import BoardProbe, StatusIntegrity
from parolkit.protocol.commands import AckStatus
from parolkit.protocol.frames import BoardCommand, CommandFrame, IOBits, StatusFrame
from parolkit.robot import PAROL6
from parolkit.transport.base import Transport

STANDBY = PAROL6.standby_steps


class LinkFault(Transport):
    """Passes bytes between the controller and the emulator's link, changing them on request:
    :meth:`rewrite_next` changes the next command frame that ``match`` selects (as a corrupted
    byte would, before the board parses it); :meth:`corrupt_next_reply` sets one byte of the
    next status frame read (offset counted from the frame's first byte; the new value, or a
    function of the old one)."""

    def __init__(self, inner: Transport) -> None:
        self.inner = inner
        self._rewrite: tuple[Callable[[CommandFrame], bool], Callable[[CommandFrame], CommandFrame]] | None = None
        self._reply: tuple[int, int | Callable[[int], int]] | None = None
        self.rewritten: list[CommandFrame] = []

    @property
    def description(self) -> str:
        return "fault injector + " + self.inner.description

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    @property
    def simulated(self) -> bool:
        return True

    def open(self) -> None:
        self.inner.open()

    def close(self) -> None:
        self.inner.close()

    def rewrite_next(self, match: Callable[[CommandFrame], bool],
                     change: Callable[[CommandFrame], CommandFrame]) -> None:
        self._rewrite = (match, change)

    def corrupt_next_reply(self, offset: int, value: int | Callable[[int], int]) -> None:
        self._reply = (offset, value)

    def write(self, data: bytes) -> None:
        if self._rewrite is not None and len(data) == 56:
            match, change = self._rewrite
            frame = CommandFrame.decode(data)
            if match(frame):
                self._rewrite = None
                new = change(frame)
                self.rewritten.append(new)
                data = new.encode()
        self.inner.write(data)

    def read(self) -> bytes:
        data = self.inner.read()
        if self._reply is not None and len(data) >= 60 and data[:3] == b"\xff\xff\xff":
            offset, value = self._reply
            self._reply = None
            new = value(data[offset]) if callable(value) else value
            data = data[:offset] + bytes((new,)) + data[offset + 1:]
        return data


class Exchanges:
    """Every frame the board executed and the true status frame it answered, in order."""

    def __init__(self, rig: Rig) -> None:
        self.items: list[tuple[CommandFrame, StatusFrame]] = []
        rig.emu.add_exchange_listener(lambda f, r: self.items.append((f, r)))


@pytest.fixture
def faulty():
    r = Rig(wrap=LinkFault)
    yield r
    r.close()


def _status_changes(rig: Rig, ticks: int) -> list[StatusFrame]:
    seen = []
    for _ in range(ticks):
        rig.tick()
        st = rig.core.status
        if st is not None and (not seen or st is not seen[-1]):
            seen.append(st)
    return seen


# ------------------------------------------------------------------------------ the truth

def test_corrupted_replies_never_become_the_status_beyond_the_steppers_own_jitter():
    """1 % of the reply bytes corrupted while the robot moves and jogs: every status the loop
    takes is one the board sent, except that a moving joint may be off by the one or two
    steps a stepper's own sub-step phase makes indistinguishable; joints at rest are exact.
    Nothing is taken for motion nobody commanded."""
    r = Rig(seed=11)
    try:
        log = Exchanges(r)
        r.emu.set_faults(corrupt_rate=0.01, direction="from_board")
        r.core.link_timeout_ticks = 50  # lost replies are not the subject here
        moves = ["MOVEJOINT|60|-80|170|20|-20|150|None|100", "JOG|1|100|0.6|None",
                 "MOVEJOINT|90|-90|180|0|0|180|None|80", "JOG|9|70|0.5|None", "MULTIJOG|0,4|60,60|0.5",
                 "MOVEJOINT|70|-100|200|-30|30|120|1.5|None"]
        shown: list[StatusFrame] = []
        for i, text in enumerate(moves * 2):
            cid = f"m{i:07d}"
            r.submit(f"{cid}|{text}")
            ran, deadline = 0, time.monotonic() + 30
            while r.terminal(cid) is None:
                # ticks with the move running are counted; while the planner thread plans it
                # the test waits (a loaded machine once ran 400 idle ticks before a plan came,
                # queued the next moves behind it and saw a quarter of the statuses)
                assert ran < 600 and time.monotonic() < deadline, (cid, r.acks[-3:])
                if r.ex.active is None:
                    time.sleep(0.001)
                else:
                    ran += 1
                shown += _status_changes(r, 1)
            assert r.terminal(cid) is AckStatus.COMPLETED, (cid, r.acks[-3:])
        true = {tuple(rep.positions): rep for _, rep in log.items}
        exact = sum(tuple(s.positions) in true for s in shown)
        for s in shown:
            if tuple(s.positions) in true:
                continue
            # the true frame it stands for: the nearest one the board sent
            near = min(true.values(), key=lambda t: max(abs(a - b) for a, b in zip(t.positions, s.positions)))
            for j in range(6):
                off = abs(near.positions[j] - s.positions[j])
                assert off <= (2 if near.speeds[j] else 0), (j, s, near)
        assert len(shown) > 500 and exact >= 0.98 * len(shown), (exact, len(shown))
        assert r.ex.integrity.implausible > 50
        assert r.ex.integrity.uncommanded == 0 and r.ex.enabled
    finally:
        r.close()


def test_a_frame_off_the_board_s_own_account_is_held_back_and_the_next_true_one_shown():
    """StatusIntegrity alone: two agreeing frames start the truth; a flipped high byte is not
    the truth; the next good frame is; a power cycle (counters 0, homed 0x03) is reported."""
    integ = StatusIntegrity(PAROL6, RATE)
    at = StatusFrame(positions=STANDBY, homed=0xFF, timing=7031, xtr=255)
    assert not integ.accept(at, 0.00, 0)  # one frame proves nothing (and is not implausible)
    assert integ.accept(at, 0.01, 0)
    glitch = list(STANDBY)
    glitch[3] += 0x10000
    assert not integ.accept(StatusFrame(positions=tuple(glitch), homed=0xFF, timing=7031), 0.02, 0)
    assert integ.accept(at, 0.03, 0)  # back where the truth was, at rest: shown
    assert integ.ref is at and integ.implausible == 1  # the glitch
    bad_io = StatusFrame(positions=STANDBY, homed=0xFF, io=0x08, timing=7031)
    assert not integ.accept(bad_io, 0.04, 0)  # IO low bits are always 1
    reset = StatusFrame(positions=(0,) * 6, homed=0x03, timing=7031)
    assert not integ.accept(reset, 0.05, 0) and integ.take_fault() is None
    integ.accept(reset, 0.06, 0)  # the same fallen homed byte twice: not a corrupted byte
    fault = integ.take_fault()
    assert fault is not None and "no longer homed" in fault
    assert integ.take_fault() is None  # reported once


def test_the_first_frame_of_a_link_session_is_the_base_of_the_next_not_an_implausible_one():
    """StatusIntegrity alone: the first frame of a session has nothing to be judged against; it
    is not the truth (one frame proves nothing) and not implausible either (nothing says it is
    corrupted): the next frame is checked from it.  A new session (reset) starts so again."""
    integ = StatusIntegrity(PAROL6, RATE)
    at = StatusFrame(positions=STANDBY, homed=0xFF, timing=7031, xtr=255)
    for t0 in (0.0, 1.0):
        integ.reset()
        assert not integ.accept(at, t0, 0)
        assert integ.implausible == 0 and integ.ref is None
        assert integ.accept(at, t0 + 0.01, 0) and integ.ref is at
    assert integ.implausible == 0
    # a first frame that the next one does not follow from: one of the two is wrong (one count),
    # and the truth starts where two frames agree
    integ.reset()
    glitch = list(STANDBY)
    glitch[1] += 0x10000
    assert not integ.accept(StatusFrame(positions=tuple(glitch), homed=0xFF, timing=7031, xtr=255), 2.0, 0)
    assert not integ.accept(at, 2.01, 0) and integ.implausible == 1
    assert integ.accept(at, 2.02, 0) and integ.ref is at and integ.implausible == 1


def test_a_clean_link_counts_no_implausible_frame_from_start_up_through_homing_a_move_and_a_reconnect():
    """A perfect link (the emulator in lockstep with the frames) never yields a frame the check
    rejects: not the first frame of a link session, not the start-up probe's replies, not the
    homing's, not a move's, and not after the link comes up again (a new session).  The status
    (GET_STATUS ``IMPLAUSIBLE=``, ``integrity.implausible``) and the loop statistics
    (``implausible_frames``) say 0.  (A GUI on the simulated board logged "1 status frame(s)
    ignored as implausible" right after the link came up: the first frame of every session
    was counted.)"""
    r = Rig(homed=False, lockstep=True)
    try:
        r.submit("aaaa0001|HOME")
        r.run_until(lambda: r.terminal("aaaa0001") is not None, 3000)
        assert r.terminal("aaaa0001") is AckStatus.COMPLETED
        r.submit("aaaa0002|MOVEJOINT|80|-90|170|0|0|180|1|None")
        r.run_until(lambda: r.terminal("aaaa0002") is not None)
        assert r.terminal("aaaa0002") is AckStatus.COMPLETED
        assert r.core.counters.frames_received > 100
        r.emu.unplug()
        r.tick(3)
        assert not r.loop.link_up
        r.emu.replug()
        r.reconnect()
        received = r.core.counters.frames_received
        r.run_until(lambda: r.core.counters.frames_received >= received + 20)
        assert r.core.status is not None and tuple(r.core.status.positions) == tuple(r.emu.positions)
        integ = r.core.integrity
        assert integ.implausible == 0 and integ.uncommanded == 0
        snap = r.outputs[-1].snapshot
        assert "|IMPLAUSIBLE=0|" in snap.reply("GET_STATUS")
        assert snap.loop_view["implausible_frames"] == 0
    finally:
        r.close()


def test_a_jog_is_shown_only_where_its_own_speed_and_timing_take_it():
    integ = StatusIntegrity(PAROL6, RATE)
    a = StatusFrame(positions=STANDBY, homed=0xFF, timing=7031, xtr=123, speeds=(1000, 0, 0, 0, 0, 0))
    assert not integ.accept(a, 0.0, 0)
    moved = tuple(p + (10 if j == 0 else 0) for j, p in enumerate(STANDBY))  # 1000 steps/s for 10 ms
    b = StatusFrame(positions=moved, homed=0xFF, timing=7031, xtr=123, speeds=(1000, 0, 0, 0, 0, 0))
    assert integ.accept(b, 0.01, 0)
    for off in (3, -3):  # a corrupted low byte beyond the step jitter
        c = tuple(p + (20 + off if j == 0 else 0) for j, p in enumerate(STANDBY))
        assert not integ.accept(StatusFrame(positions=c, homed=0xFF, timing=7031, xtr=123,
                                            speeds=(1000, 0, 0, 0, 0, 0)), 0.02, 0)
    # a joint at speed 0 is exact: one step off is a corrupted byte
    integ = StatusIntegrity(PAROL6, RATE)
    integ.accept(a, 0.0, 0)
    integ.accept(b, 0.01, 0)
    c = tuple(p + (20 if j == 0 else 0) + (1 if j == 2 else 0) for j, p in enumerate(STANDBY))
    assert not integ.accept(StatusFrame(positions=c, homed=0xFF, timing=7031, xtr=123,
                                        speeds=(1000, 0, 0, 0, 0, 0)), 0.02, 0)
    # bytes lost in between (the parser dropped some): not adjacent, no link
    d = tuple(p + (30 if j == 0 else 0) for j, p in enumerate(STANDBY))
    assert not integ.accept(StatusFrame(positions=d, homed=0xFF, timing=7031, xtr=123,
                                        speeds=(1000, 0, 0, 0, 0, 0)), 0.03, 60)


# ------------------------------------------------------------------------------ uncommanded motion

def _disable_within(rig: Rig, frames_before: int, ticks: int) -> int:
    """Ticks until a DISABLE frame was written (at most ``ticks``)."""
    for k in range(1, ticks + 1):
        rig.tick()
        if any(f.command == BoardCommand.DISABLE for f in rig.frames[frames_before:]):
            return k
    raise AssertionError(f"no DISABLE within {ticks} ticks: {[int(f.command) for f in rig.frames[frames_before:]]}")


def test_a_corrupted_frame_that_jogs_a_joint_while_idle_disables_within_three_ticks_naming_it(faulty):
    faulty.tick(5)
    faulty.transport.rewrite_next(lambda f: f.command == BoardCommand.IDLE,
                                  lambda f: CommandFrame(positions=f.positions, speeds=(0, 5000, 0, 0, 0, 0),
                                                         command=BoardCommand.JOG))
    n = len(faulty.frames)
    faulty.tick()  # this tick's IDLE frame reaches the board as a JOG of J2
    assert faulty.transport.rewritten
    shown = len(faulty.frames)  # the reply to the next frame is the first to show the motion
    k = _disable_within(faulty, n, 5)
    assert len(faulty.frames) - shown <= 3, (k, [int(f.command) for f in faulty.frames[n:]])
    assert not faulty.ex.enabled and "J2 moved" in faulty.ex.error and "while idle" in faulty.ex.error
    assert faulty.ex.integrity.uncommanded == 1
    faulty.tick(5)
    assert all(f.command == BoardCommand.DISABLE for f in faulty.frames[-4:])
    snap = faulty.outputs[-1].snapshot
    assert "UNCOMMANDED=1" in snap.reply_status() and snap.as_dict()["integrity"]["uncommanded"] == 1
    # ENABLE clears it; the robot moves again
    faulty.send("ENABLE")
    faulty.tick(3)
    assert faulty.ex.enabled and faulty.ex.error is None
    faulty.submit("aaaa0001|MOVEJOINT|80|-90|180|0|0|180|1|None")
    faulty.run_until(lambda: faulty.terminal("aaaa0001") is not None)
    assert faulty.terminal("aaaa0001") is AckStatus.COMPLETED


def test_a_corrupted_target_that_makes_a_joint_race_disables_the_robot(faulty):
    faulty.submit("aaaa0001|MOVEJOINT|70|-90|180|0|0|180|2|None")
    faulty.run_until(lambda: AckStatus.EXECUTING in faulty.statuses("aaaa0001"))
    faulty.tick(20)
    faulty.transport.rewrite_next(lambda f: f.command == BoardCommand.GOTO,
                                  lambda f: CommandFrame(positions=(f.positions[0] + 0x3000, *f.positions[1:]),
                                                         speeds=f.speeds, command=f.command))
    n = len(faulty.frames)
    _disable_within(faulty, n, 4)
    assert faulty.terminal("aaaa0001") is AckStatus.CANCELLED
    assert "J1 moved" in faulty.ex.error and "uncommanded" in faulty.ex.error


def test_enable_turned_into_home_on_the_wire_disables_before_the_homing_goes_far(faulty):
    faulty.tick(5)
    faulty.transport.rewrite_next(lambda f: f.command == BoardCommand.ENABLE,
                                  lambda f: CommandFrame(positions=f.positions, command=BoardCommand.HOME))
    faulty.send("ENABLE")  # to an enabled board: the bit flip 0x65 -> 0x64 makes it home
    faulty.tick()
    n = len(faulty.frames)
    assert faulty.transport.rewritten and faulty.emu.homing_active
    _disable_within(faulty, n, 3)
    assert "homing without a HOME command" in faulty.ex.error
    faulty.tick(2)
    assert not faulty.emu.homing_active and not faulty.emu.enabled


# ------------------------------------------------------------------------------ the board's state

def test_home_at_standby_homes_for_real_then_a_move_runs():
    r = Rig()
    try:
        log = Exchanges(r)
        assert tuple(r.core.status.positions) == STANDBY and r.ex.homed
        r.submit("aaaa0001|HOME")
        phases = set()
        while r.terminal("aaaa0001") is None:
            r.tick()
            phases.add(r.emu.homing_phase)
            assert len(r.frames) < 3000
        assert r.terminal("aaaa0001") is AckStatus.COMPLETED
        assert HomingPhase.J123_REFERENCE in phases or HomingPhase.J4 in phases
        assert any(rep.homed != 0xFF for _, rep in log.items), "the board never reported homing"
        r.submit("aaaa0002|MOVEJOINT|80|-90|170|0|0|180|1|None")
        r.run_until(lambda: r.terminal("aaaa0002") is not None)
        assert r.terminal("aaaa0002") is AckStatus.COMPLETED
    finally:
        r.close()


def test_a_board_left_disabled_is_found_disabled_and_home_fails_fast_until_enable():
    r = Rig(board_disabled=True)
    try:
        assert not r.ex.enabled and r.ex.error == "the board was found disabled: send ENABLE"
        assert r.outputs[-1].snapshot.state.value == "DISABLED"
        r.submit("aaaa0001|HOME")
        assert r.terminal("aaaa0001") is AckStatus.FAILED
        assert "the board was found disabled" in [a for a in r.acks if a[0] == "aaaa0001"][-1][2]
        r.send("ENABLE")
        r.tick(3)
        assert r.emu.enabled and r.ex.enabled
        r.submit("aaaa0002|HOME")
        r.run_until(lambda: r.terminal("aaaa0002") is not None, max_ticks=5000)
        assert r.terminal("aaaa0002") is AckStatus.COMPLETED
    finally:
        r.close()


def test_home_sent_to_a_board_disabled_behind_the_controllers_back_fails_in_half_a_second():
    r = Rig()
    try:
        r.emu.process_frame(CommandFrame(command=BoardCommand.DISABLE))  # the controller never knew
        r.submit("aaaa0001|HOME")
        r.run_until(lambda: r.terminal("aaaa0001") is not None, max_ticks=200)
        assert r.terminal("aaaa0001") is AckStatus.FAILED
        details = [a for a in r.acks if a[0] == "aaaa0001"][-1][2]
        assert "did not start homing within 0.5 s" in details and "ENABLE" in details
    finally:
        r.close()


def test_the_probe_answers_enabled_and_disabled_and_asks_again_when_unclear():
    def run(disabled: bool, lose_reply: bool = False) -> tuple[bool | None, int]:
        r = Rig(board_disabled=disabled)
        try:
            return (r.ex.enabled, sum(f.command == BoardCommand.JOG and f.speeds[0] != 0 for f in r.frames))
        finally:
            r.close()

    assert run(False) == (True, 1)
    assert run(True) == (False, 1)
    r = Rig(board_disabled=True)
    try:  # the status says so while the answer is outstanding
        assert not r.outputs[0].snapshot.as_dict()["board"]["state_known"]
        assert r.outputs[-1].snapshot.as_dict()["board"]["state_known"]
        assert r.outputs[-1].snapshot.as_dict()["errors"]["message"] == "the board was found disabled: send ENABLE"
    finally:
        r.close()
    # the reply that would tell is damaged: the probe asks again
    probe = BoardProbe(attempts=2, wait_ticks=2)
    probe.start()
    frames = []
    for _ in range(12):
        code, speeds = probe.frame(None, PAROL6.limits_steps)
        frames.append((code, speeds))
        probe.sent(CommandFrame(command=code, speeds=speeds), len(frames))
    assert sum(c == BoardCommand.JOG and s[0] for c, s in frames) == 2  # two attempts
    assert probe.result is False and "taken as disabled" in probe.reason


def test_hardware_estop_disables_in_the_frame_after_the_first_status_showing_it():
    r = Rig()
    try:
        log = Exchanges(r)
        r.submit("aaaa0001|MOVEJOINT|60|-90|180|0|0|180|2|None")
        r.run_until(lambda: AckStatus.EXECUTING in r.statuses("aaaa0001"))
        r.tick(10)
        r.emu.set_estop(True)
        r.tick(4)
        first = next(i for i, (_, rep) in enumerate(log.items) if not rep.io & IOBits.ESTOP)
        assert log.items[first + 1][0].command == BoardCommand.DISABLE
        assert r.terminal("aaaa0001") is AckStatus.CANCELLED and r.ex.estop_latched
    finally:
        r.close()


def test_one_corrupted_io_byte_on_the_wire_does_not_latch_the_estop(faulty):
    faulty.tick(5)
    # IO byte (offset 4 + 37): ESTOP bit cleared AND another bit set: a corrupted byte
    faulty.transport.corrupt_next_reply(41, 0x0F & ~IOBits.ESTOP | IOBits.IN1)
    faulty.tick(5)
    assert not faulty.ex.estop_latched and not faulty.ex.estop_pressed
    assert all(f.command != BoardCommand.DISABLE for f in faulty.frames[-5:])


# ------------------------------------------------------------------------------ unhomed jogs

def test_an_unhomed_jog_press_is_capped_in_travel_and_says_so():
    r = Rig(homed=False)
    try:
        j1 = r.emu.positions[0]
        r.submit("aaaa0001|JOG|0|100|None|60")  # 60 deg asked; not homed: 20 deg per press
        r.run_until(lambda: r.terminal("aaaa0001") is not None)
        acks = [a for a in r.acks if a[0] == "aaaa0001"]
        assert acks[-1][1] is AckStatus.COMPLETED
        assert any(a[1] is AckStatus.EXECUTING and "jog travel limited to 20 deg per press (J1" in a[2] for a in acks)
        moved = (r.emu.positions[0] - j1) / PAROL6.steps_per_deg[0]
        assert 19.0 < moved <= 20.1, moved
        # a short jog is not limited
        r.submit("aaaa0002|JOG|6|100|0.2|None")
        r.run_until(lambda: r.terminal("aaaa0002") is not None)
        assert all("limited" not in a[2] for a in r.acks if a[0] == "aaaa0002")
    finally:
        r.close()


def test_a_held_streamed_jog_before_homing_stops_at_the_travel_cap():
    r = Rig(homed=False)
    try:
        r.send("STREAM|ON")
        r.tick()
        j2 = r.emu.positions[1]
        for i in range(400):  # an update every tick for 4 s at 100 % (J2: 8.4 deg/s, 34 deg)
            r.submit(f"s{i:07d}|JOG|1|100|0.05|None")
            r.tick()
        failed = sum(1 for a in r.acks if a[1] is AckStatus.FAILED and "used its 20 deg" in a[2])
        moved = (r.emu.positions[1] - j2) / PAROL6.steps_per_deg[1]
        assert 19.0 < moved <= 20.1, moved
        assert failed > 10
    finally:
        r.close()


def test_home_completes_only_after_the_board_rests_homed_even_when_its_homing_is_too_fast_to_show():
    """The controller was told the board homes in real time, but it homes 200x faster (a
    board-sim with --speedup on a serial link): its frames during the homing are not the
    truth; HOME still sees the homing (homed bits fallen in two frames) and completes only
    when a new true frame shows the board homed at standby, at rest."""
    r = Rig()
    try:
        r.ex.integrity.homing_speedup = 1.0
        r.submit("aaaa0001|HOME")
        r.submit("aaaa0002|MOVEJOINT|80|-90|170|0|0|180|1|None")
        homing_seen_active = False
        while r.terminal("aaaa0001") is None:
            r.tick()
            homing_seen_active |= r.emu.homing_active
            assert len(r.frames) < 3000
        assert r.terminal("aaaa0001") is AckStatus.COMPLETED and homing_seen_active
        assert not r.emu.homing_active and r.emu.homed == 0xFF
        r.run_until(lambda: r.terminal("aaaa0002") is not None)
        assert r.terminal("aaaa0002") is AckStatus.COMPLETED and r.ex.integrity.uncommanded == 0
    finally:
        r.close()


def test_a_corrupted_position_of_a_joint_at_rest_during_homing_is_never_shown(faulty):
    """While J1-J3 home, J5 rests: a reply whose J5 low byte was corrupted (145 steps off, far
    inside the homing reach of a moving joint) was taken for the truth, and the snapshot showed
    the false J5 for 100 ms while the homing's own jumps kept later frames from linking (the
    60 s corruption run).  A joint at rest in two frames stays put or has its counter zeroed /
    set to standby: nothing else links."""
    r = faulty
    r.emu.homing_speedup = r.ex.integrity.homing_speedup = 5.0  # slow enough to catch J1-J3's phase
    r.submit("aaaa0001|HOME")
    for _ in range(400):
        r.tick()
        if r.emu.homing_phase is HomingPhase.J123_REFERENCE and r.core.status is not None \
                and r.core.status.homed != 0xFF:
            break
    j5 = r.core.status.positions[4]
    low = j5 & 0xFF
    r.transport.corrupt_next_reply(18, low ^ 0x91)  # J5 low byte: a step change of 0x91 or so
    shown = []
    for _ in range(5):
        r.tick()
        if r.core.status is not None:
            shown.append(r.core.status.positions[4])
    assert r.emu.homing_phase is HomingPhase.J123_REFERENCE, "J5 must still rest for this test"
    assert all(v == j5 for v in shown), (j5, shown)
    assert r.terminal("aaaa0001") is None  # the homing goes on


def test_stop_during_homing_stops_the_board_and_a_later_enable_or_home_is_no_uncommanded_motion():
    """The firmware homes to the end whatever it gets but 101/102/103: STOP sent IDLE frames,
    the board homed on while the robot showed stopped, and the ENABLE that followed made the
    rest of the homing "uncommanded motion" (found by the commander's key tests).  STOP now
    sends ENABLE: every motor stops where it is (unhomed); ENABLE and HOME then work."""
    r = Rig()
    try:
        r.emu.homing_speedup = r.ex.integrity.homing_speedup = 1.0
        r.submit("aaaa0001|HOME")
        r.run_until(lambda: r.emu.homing_active)
        r.tick(20)
        r.send("bbbb0001|STOP")
        r.tick(3)
        assert not r.emu.homing_active and r.terminal("aaaa0001") is AckStatus.CANCELLED
        assert BoardCommand.ENABLE in [f.command for f in r.frames[-3:]]
        r.tick(30)
        assert not any(r.emu.speeds) and r.emu.homed != 0xFF and not r.ex.homed
        r.submit("cccc0001|ENABLE")
        r.tick(30)
        assert r.ex.error is None and r.ex.integrity.uncommanded == 0 and r.ex.enabled
        r.emu.homing_speedup = r.ex.integrity.homing_speedup = 50.0
        r.submit("dddd0001|HOME")
        r.run_until(lambda: r.terminal("dddd0001") is not None, max_ticks=5000)
        assert r.terminal("dddd0001") is AckStatus.COMPLETED and r.ex.homed
    finally:
        r.close()


def test_stop_frames_after_the_probes_jogs_never_make_an_enabled_board_look_disabled():
    """Replies late at start-up: the loop paused "motion" with zero-speed JOG frames after the
    probe's own two JOGs, and two replies to those (123 echoed twice, speeds 0) looked exactly
    like a disabled board's answer: a fresh, enabled board-sim was "found disabled" under load.
    Such an attempt can no longer say "disabled"; the board's later clear answer decides."""
    probe = BoardProbe(attempts=3, wait_ticks=4)
    probe.start()
    t = 0.0
    for _ in range(3):  # IDLE, JOG +-1, JOG 0
        code, speeds = probe.frame(None, PAROL6.limits_steps)
        t += 0.01
        probe.sent(CommandFrame(command=code, speeds=speeds), t)
    for _ in range(2):  # the loop's stop frames (replies missing): zero-speed JOGs
        probe.frame(None, PAROL6.limits_steps)
        t += 0.01
        probe.sent(CommandFrame(command=BoardCommand.JOG), t)
    # the replies to the stop frames arrive: 123 echoed twice, speeds 0, a loop pass apart
    still = StatusFrame(positions=STANDBY, homed=0xFF, timing=7031, xtr=int(BoardCommand.JOG))
    probe.observe(still, t + 0.001, True)
    probe.observe(still, t + 0.002, True)
    assert probe.result is None and probe.active  # not "disabled"
    # the next attempt's answer: J1 moving at the probe's 1 step/s: enabled
    for _ in range(12):
        code, speeds = probe.frame(None, PAROL6.limits_steps)
        t += 0.01
        probe.sent(CommandFrame(command=code, speeds=speeds), t)
        if code == BoardCommand.JOG and speeds[0]:
            sign = speeds[0]
    probe.observe(StatusFrame(positions=STANDBY, homed=0xFF, timing=7031, xtr=int(BoardCommand.JOG),
                              speeds=(sign, 0, 0, 0, 0, 0)), t + 0.001, True)
    assert probe.result is True


def test_a_stop_frame_between_the_probes_jogs_never_makes_an_enabled_board_look_disabled():
    """The loop paused with a zero-speed JOG written between the probe's +-1 JOG and its zero
    JOG (replies late at start-up), and the board took the +-1 JOG and that stop in the same
    instant (both frames in one read of a loaded tty: no loop pass between, so no reply shows
    the 1 step/s): the replies to the stop and to the probe's zero JOG (123 echoed twice,
    speeds 0, the second a loop pass later) looked like a disabled board's answer (seen in a
    clean run: an enabled board-sim "found disabled").  Such an attempt cannot say
    "disabled"."""
    probe = BoardProbe(attempts=3, wait_ticks=4)
    probe.start()
    t = 0.0
    for k in range(3):  # IDLE, JOG +-1, (the loop's stop frame), JOG 0
        code, speeds = probe.frame(None, PAROL6.limits_steps)
        t += 0.01
        probe.sent(CommandFrame(command=code, speeds=speeds), t)
        if k == 1:
            probe.sent(CommandFrame(command=BoardCommand.JOG), t + 0.005)
    still = StatusFrame(positions=STANDBY, homed=0xFF, timing=3867, xtr=int(BoardCommand.JOG))
    for dt in (0.001, 0.002, 0.003):  # the replies to the +-1 JOG, the stop, the zero JOG
        probe.observe(still, t + dt, True)
    assert probe.result is None and probe.active  # not "disabled": asked again


def test_after_a_lost_reply_the_frame_that_confirms_a_race_is_not_shown_until_checked_against_commands(faulty):
    """A race first seen after a lost reply is confirmed by the next frame linking to it; that
    frame follows by the board's own account alone (a joint at the speed clamp is not checked
    by its speed), so a corrupted low byte in it must not reach the status: only a frame that
    matches what was commanded is shown again (seen in the 60 s pty run: J2 shown 3 steps off
    while J4 and J5 raced)."""
    told = Exchanges(faulty)
    faulty.submit("aaaa0001|MOVEJOINT|70|-90|180|0|0|180|2|None")
    faulty.run_until(lambda: AckStatus.EXECUTING in faulty.statuses("aaaa0001"))
    faulty.tick(20)
    shown: list[StatusFrame] = []

    def tick() -> None:
        faulty.tick()
        st = faulty.core.status
        if st is not None and (not shown or st is not shown[-1]):
            shown.append(st)

    faulty.transport.rewrite_next(lambda f: f.command == BoardCommand.GOTO,
                                  lambda f: CommandFrame(positions=(f.positions[0] + 0x3000, *f.positions[1:]),
                                                         speeds=f.speeds, command=f.command))
    faulty.transport.corrupt_next_reply(0, 0x00)  # the reply that first shows the race is lost
    tick()
    tick()  # the next reply: after a gap, not adjacent to anything true
    faulty.transport.corrupt_next_reply(6, lambda b: b ^ 0x04)  # the one confirming it: J1 4 steps off
    tick()
    assert faulty.transport.rewritten
    for _ in range(10):
        tick()
    assert "J1 moved" in (faulty.ex.error or "") and not faulty.ex.enabled
    assert faulty.ex.integrity.uncommanded == 1
    true = {tuple(r.positions) for _, r in told.items}
    false = [s.positions for s in shown if tuple(s.positions) not in true]
    assert not false, false
    assert not any(faulty.emu.speeds) and tuple(shown[-1].positions) == tuple(told.items[-1][1].positions)


def _lockstep_move(stall_at: int | None = None, monkeypatch: pytest.MonkeyPatch | None = None
                   ) -> tuple[list[CommandFrame], list[tuple[int, ...]], int]:
    """A MoveJoint on a board in lockstep with the frames; with ``stall_at``, the PC's clock
    (``time.monotonic``, which the driver stamps writes and reads with) jumps 0.12 s ahead
    before that tick, as it does for a controller descheduled that long on a busy machine.
    Returns the frames written, the positions the core showed at each tick, the implausible
    count."""
    pc_clock = time.monotonic

    def stalled_clock() -> float:
        return pc_clock() + 0.12

    r = Rig(lockstep=True)
    try:
        r.submit("aaaa0003|MOVEJOINT|80|-90|170|0|0|180|1|None")
        shown: list[tuple[int, ...]] = []
        for k in range(400):
            if k == stall_at:
                assert monkeypatch is not None
                monkeypatch.setattr(time, "monotonic", stalled_clock)
            r.tick()
            shown.append(tuple(r.core.status.positions))
            if r.terminal("aaaa0003") is not None:
                break
        assert r.terminal("aaaa0003") is AckStatus.COMPLETED
        return r.frames, shown, r.core.integrity.implausible
    finally:
        r.close()


def test_a_wall_clock_stall_changes_nothing_on_a_board_in_lockstep_with_the_frames(monkeypatch):
    """A lockstep board's time is its frames (one period each), not the PC's clock: a controller
    stalled 0.12 s mid-move (longer than the board timer's 93 ms wrap) must judge the replies
    after the stall by board time.  Judged by the PC's read times, the check added a timer wrap
    that never happened, rejected the next true reply as implausible, and the status showed the
    joints one tick behind (a replayed recording then differed from its original by 24-33
    steps at that tick, test_record's round trip)."""
    frames, shown, implausible = _lockstep_move()
    frames_stalled, shown_stalled, implausible_stalled = _lockstep_move(40, monkeypatch)
    assert implausible == 0 and implausible_stalled == 0
    assert shown_stalled == shown
    assert [f.encode() for f in frames_stalled] == [f.encode() for f in frames]


def test_a_reply_held_back_in_the_pty_does_not_make_a_corrupted_frame_look_like_motion():
    """StatusIntegrity alone, a board at rest on a GO TO target, frames written every 10 ms.
    A reply is lost (bytes dropped), the next one has J1's low byte flipped (128 steps off: beyond
    anything commanded, a suspect), and the reply after it waits 85 ms in the pty on a busy
    machine (the kernel's flush ran late) while the controller goes on writing a frame every
    10 ms.  The board's own timing says 10 ms; the timer wraps every 93.2 ms, and the old check
    unwrapped it by the read times: 103 ms, time enough for the GO TO law to take any position
    to the target, so the true frame "linked" to the corrupted one and confirmed a motion that
    never happened (a fresh clone's test_controller_pty: "uncommanded motion: J1 moved -128
    steps beyond anything commanded" at load).  The write times show no pause: 10 ms it is,
    the corrupted frame stays a suspect nothing confirms, and no fault is raised."""
    integ = StatusIntegrity(PAROL6, RATE)
    target = tuple(int(v) for v in STANDBY)
    goto = CommandFrame(command=BoardCommand.GOTO, positions=target, speeds=(0,) * 6)
    at = StatusFrame(positions=target, homed=0xFF, io=0x0F, timing=7031, xtr=int(BoardCommand.GOTO))
    off = list(target)
    off[0] -= 128
    corrupted = StatusFrame(positions=tuple(off), homed=0xFF, io=0x0F, timing=7031, xtr=int(BoardCommand.GOTO))
    dropped = 0
    n = 0

    def write(t: float) -> int:
        nonlocal n
        n += 1
        integ.sent(goto, t, n)
        return n

    for k in range(10):  # the truth: the board at rest on the target
        write(k * 0.01)
        integ.accept(at, k * 0.01 + 0.001, dropped, n)
    assert integ.ref is not None
    write(0.10)
    dropped += 40  # its reply: a framing byte corrupted, the parser dropped it
    write(0.11)
    integ.accept(corrupted, 0.111, dropped, n)  # J1 128 steps off, after a lost reply
    first = n
    for k in range(2, 10):  # the next replies wait in the pty while frames go on
        write(0.10 + k * 0.01)
    for i, k in enumerate(range(first + 1, n + 1)):  # then arrive together, true
        integ.accept(at, 0.196 + 0.0001 * i, dropped, k)
    assert integ.take_fault() is None
    assert integ.uncommanded == 0


def test_a_pause_in_the_frames_written_unwraps_the_board_timer_by_whole_wraps():
    """The other side of the test above: the controller wrote nothing for 200 ms (a stalled PC),
    so the board ran its JOG that long and its timer wrapped twice (its timing field says
    13.6 ms).  The pause is in the write times: the reply is unwrapped to 200 ms, links, and is
    the truth; no fault."""
    integ = StatusIntegrity(PAROL6, RATE)
    v = 1000
    jog = CommandFrame(command=BoardCommand.JOG, positions=(0,) * 6, speeds=(v, 0, 0, 0, 0, 0))
    p = list(STANDBY)
    n = 0
    t = 0.0
    for k in range(12):
        wait = 0.2 if k == 10 else 0.01
        t += wait
        n += 1
        integ.sent(jog, t, n)
        p[0] += round(v * wait)
        ticks = round(wait * 703125) % 65536
        f = StatusFrame(positions=tuple(p), speeds=(v, 0, 0, 0, 0, 0), homed=0xFF, io=0x0F, timing=ticks,
                        xtr=int(BoardCommand.JOG))
        truth = integ.accept(f, t + 0.001, 0, n)
        assert k < 1 or truth, (k, integ.implausible)
    assert integ.take_fault() is None and integ.implausible == 0


def test_a_link_that_any_position_would_pass_confirms_nothing():
    """StatusIntegrity alone, a board at rest on a GO TO target, frames written every 10 ms.  On
    a busy machine the pty hands the board its frames in bursts, so its own timing between two
    frames is now and then 90 ms: the GO TO law closes 99 % of any gap in that time, so a frame
    with J1's position corrupted 226 steps off "links" to the true one before it, and the true
    one after it "links" to it too.  The second link said nothing: the true frame follows just
    as well from where the commands put the board.  It was taken as the confirmation of an
    uncommanded motion (two runs of test_controller_pty under two CPU hogs: "uncommanded
    motion: J1 moved 226 steps beyond anything commanded"); a link confirms only when it tells
    the suspect from the commanded hull."""
    integ = StatusIntegrity(PAROL6, RATE)
    target = tuple(int(v) for v in STANDBY)
    goto = CommandFrame(command=BoardCommand.GOTO, positions=target, speeds=(0,) * 6)
    slow = 9 * 7031  # 90 ms on the board's timer: its frames came in a burst after a pause

    def frame(j1_off: int, timing: int) -> StatusFrame:
        pos = list(target)
        pos[0] += j1_off
        return StatusFrame(positions=tuple(pos), homed=0xFF, io=0x0F, timing=timing, xtr=int(BoardCommand.GOTO))

    n = 0
    for k, (off, timing) in enumerate([(0, 7031)] * 10 + [(226, slow), (0, slow)] + [(0, 7031)] * 5):
        n += 1
        integ.sent(goto, k * 0.01, n)
        integ.accept(frame(off, timing), k * 0.01 + 0.001, 0, n)
    assert integ.take_fault() is None
    assert integ.uncommanded == 0

