"""Controller core, tick by tick: the real core and its driver (planning inline), guard and
integrity check against the real board emulator on a virtual clock (deterministic board time)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from tests.conftest import wait_until

from parolkit.board import BoardEmulator
from parolkit.controller.activities import FrameRequest, TickContext
from parolkit.controller.core import ControllerCore, TickOutput
from parolkit.controller.driver import Driver
from parolkit.controller.messages import Submission
from parolkit.controller.planning import PlanRequest
from parolkit.controller.safety import SafetyState
from parolkit.controller.stats import Histogram
from parolkit.protocol import commands as C
from parolkit.protocol.commands import AckStatus, parse_datagram
from parolkit.protocol.frames import BoardCommand, CommandFrame, GripperMode, StatusFrame
from parolkit.robot import PAROL6
from parolkit.transport.emulated import EmulatorTransport

RATE = 100.0


class Rig:
    """One controller core and its driver: ticks are driven by the test; the board advances
    1/RATE per tick; plans are made inline (in the tick that asks, taken in by the next).
    ``zones`` / ``config``: the core's collision zones and configuration (default: the table)."""

    def __init__(self, *, homed: bool = True, queue_size: int = 16, board_disabled: bool = False,
                 wrap=None, lockstep: bool = False, link_timeout_ticks: int = 3, link_hold_frames: int = 2,
                 zones=None, config=None, **emu_kw) -> None:
        self.emu = BoardEmulator(clock="virtual", start_homed=homed, homing_speedup=200, **emu_kw)
        if board_disabled:  # left so by a previous controller
            self.emu.process_frame(CommandFrame(command=BoardCommand.DISABLE))
        # ``wrap(transport)``: a link fault injector around the emulator's link
        # ``lockstep``: the link itself runs the board one period per frame written
        # (sim://?clock=virtual&step=...), whatever time the test's ticks claim
        self.lockstep = lockstep
        base = EmulatorTransport(emulator=self.emu, step_s=1.0 / RATE if lockstep else None)
        self.transport = wrap(base) if wrap is not None else base
        self.transport.open()
        self.acks: list[tuple[str | None, AckStatus, str]] = []
        self.outputs: list[TickOutput] = []
        self.ex = self.core = ControllerCore(model=PAROL6, rate_hz=RATE, queue_size=queue_size, watchdog_s=0.02,
                                             homing_speedup=200, link_timeout_ticks=link_timeout_ticks,
                                             link_hold_frames=link_hold_frames, zones=zones, config=config)
        self.loop = Driver(self.core, self.transport, reply_wait_fraction=0.0, plan_inline=True)
        self.guard = self.core.guard
        self.frames: list[CommandFrame] = []
        self.now = 0.0
        # start-up: the first frames ask the board whether it is enabled (BoardProbe); two
        # status frames that agree are the first truth
        self.tick(2)
        for _ in range(20):
            if not self.core.probe.active and self.core.status is not None:
                break
            self.tick()
        self.tick()

    def close(self) -> None:
        self.transport.close()

    def step(self) -> None:
        """One tick of the driver at :attr:`now`, its output recorded; the caller moves the
        clock and the board on."""
        out = self.loop.tick(self.now)
        self.outputs.append(out)
        self._record(out.acks)
        if out.frame is not None:
            self.frames.append(out.frame)
        self.loop.tick_count += 1

    def tick(self, n: int = 1, dt: float = 1.0 / RATE) -> None:
        """``n`` ticks, each ``dt`` s of board time after the one before."""
        for _ in range(n):
            self.step()
            self.now += dt
            if self.emu.plugged and not self.lockstep:
                self.emu.advance(dt)

    def reconnect(self) -> None:
        """After ``emu.replug()``: the driver's reconnect starts at the next tick (in its own
        thread, joined here: the link is up when this returns, without a wall-clock wait)."""
        self.loop._next_reconnect = 0.0
        self.tick()  # starts it
        for thread in threading.enumerate():
            if thread.name == "parolkit-reconnect":
                thread.join(5.0)
        assert self.loop.link_up, "the replugged board's link did not come up"

    def _record(self, acks) -> None:
        self.acks.extend((a.command_id, a.status, a.details) for a in acks)

    def send(self, text: str, seq: int = 0, port: int = 1) -> None:
        """A datagram from 127.0.0.1:``port`` as the server hands it over: applied at the next
        tick."""
        p = parse_datagram(text)
        src = ("127.0.0.1", port)
        sub = Submission(p.command, p.command_id, (src,) if p.command_id else None, src, seq)
        if p.command.SAFETY:
            self.loop.inbox.put_safety(sub)
        else:
            self.loop.inbox.put(sub)

    def submit(self, text: str) -> None:
        """Apply a command now, between ticks (acks recorded at once)."""
        p = parse_datagram(text)
        self._record(self.core.apply(Submission(p.command, p.command_id, (("127.0.0.1", 1),), ("127.0.0.1", 1))))

    def statuses(self, cid: str) -> list[AckStatus]:
        return [a[1] for a in self.acks if a[0] == cid]

    def run_until(self, cond, max_ticks: int = 2000) -> None:
        """Tick until ``cond()`` (at most ``max_ticks``; plans are made inline: no waiting)."""
        for _ in range(max_ticks):
            if cond():
                return
            self.tick()
        assert cond(), f"condition not met; acks: {self.acks[-5:]}"

    def tick_of_ack(self, cid: str, status: AckStatus) -> int:
        """The index in :attr:`outputs` of the tick that sent ``cid``'s ``status`` ack."""
        return next(k for k, o in enumerate(self.outputs) if any(
            a.command_id == cid and a.status is status for a in o.acks))

    def terminal(self, cid: str) -> AckStatus | None:
        for s in self.statuses(cid):
            if s.terminal:
                return s
        return None

    @property
    def angles(self) -> np.ndarray:
        return np.asarray(self.core.status.positions) / PAROL6.steps_per_deg


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.close()


def test_movejoint_acks_queued_executing_completed_and_reaches_target(rig):
    rig.submit("aaaa0001|MOVEJOINT|90|-80|170|10|-10|170|1|None")
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.statuses("aaaa0001") == [AckStatus.QUEUED, AckStatus.EXECUTING, AckStatus.COMPLETED]
    assert np.allclose(rig.angles, [90, -80, 170, 10, -10, 170], atol=0.05)
    assert any(f.command == BoardCommand.GOTO for f in rig.frames)


def test_commands_run_in_order_each_planned_from_the_previous_end(rig):
    rig.submit("aaaa0001|MOVEJOINT|80|-90|180|0|0|180|0.5|None")
    rig.submit("aaaa0002|DELAY|0.1")
    rig.submit("aaaa0003|MOVEJOINT|80|-90|170|0|0|180|1.5|None")
    rig.run_until(lambda: rig.terminal("aaaa0003") is not None)
    done = [a[0] for a in rig.acks if a[1] is AckStatus.COMPLETED]
    assert done == ["aaaa0001", "aaaa0002", "aaaa0003"], rig.acks
    assert np.allclose(rig.angles, [80, -90, 170, 0, 0, 180], atol=0.05)


def _holds_still(rig) -> None:
    """After a STOP: 30 more ticks of IDLE frames and the arm where it stopped."""
    held = rig.angles.copy()
    rig.tick(30)
    assert np.allclose(rig.angles, held, atol=0.5)
    assert rig.frames[-1].command == BoardCommand.IDLE


def test_stop_mid_move_cancels_active_and_queued_and_holds(rig):
    rig.submit("aaaa0001|MOVEJOINT|60|-90|180|0|0|180|2|None")
    rig.submit("aaaa0002|MOVEJOINT|90|-90|180|0|0|180|2|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(50)
    rig.send("STOP")
    rig.tick(3)
    # the queue is cleared at once; the running move slows down on its path within the
    # acceleration limits (issue 24), then ends CANCELLED where it stands
    assert rig.terminal("aaaa0002") is AckStatus.CANCELLED
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None, 40)
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    _holds_still(rig)


def test_estop_press_cancels_sends_disable_every_tick_and_latches_until_release_and_enable(rig):
    rig.submit("aaaa0001|MOVEJOINT|60|-90|180|0|0|180|2|None")
    rig.submit("aaaa0002|DELAY|1")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(20)
    rig.emu.set_estop(True)
    rig.tick(3)
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert rig.terminal("aaaa0002") is AckStatus.CANCELLED
    rig.tick(10)
    assert all(f.command == BoardCommand.DISABLE for f in rig.frames[-10:])
    rig.submit("aaaa0003|DELAY|0.1")
    assert rig.terminal("aaaa0003") is AckStatus.FAILED
    rig.emu.set_estop(False)
    rig.tick(10)
    # released but not re-enabled: still latched, still DISABLE
    assert rig.ex.estop_latched
    assert all(f.command == BoardCommand.DISABLE for f in rig.frames[-5:])
    rig.send("ENABLE")
    rig.tick(3)
    assert not rig.ex.estop_latched
    assert any(f.command == BoardCommand.ENABLE for f in rig.frames[-3:])
    assert rig.frames[-1].command == BoardCommand.IDLE


def test_software_estop_latches_like_the_hardware_one(rig):
    rig.send("ESTOP")
    rig.tick(5)
    assert all(f.command == BoardCommand.DISABLE for f in rig.frames[-4:])
    rig.send("ENABLE")
    rig.tick(2)
    assert not rig.ex.estop_latched


def test_unplugged_link_cancels_motion_within_three_ticks_and_reconnects(rig):
    rig.submit("aaaa0001|MOVEJOINT|60|-90|180|0|0|180|2|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(10)
    rig.emu.unplug()
    rig.tick(3)
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert "link lost" in rig.acks[-1][2]
    assert not rig.loop.link_up and rig.ex.error
    rig.tick()
    rig.submit("aaaa0002|DELAY|0.1")  # refused while the link is down
    assert rig.terminal("aaaa0002") is AckStatus.FAILED
    rig.emu.replug()
    rig.reconnect()
    rig.tick(5)
    assert rig.ex.active is None  # never resumed


def test_silent_board_counts_as_link_loss_after_link_timeout_ticks(rig):
    rig.submit("aaaa0001|DELAY|2")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.emu.set_faults(silent=True)
    rig.tick(5)
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert "3 frames in a row unanswered" in rig.ex.error


def test_motion_is_refused_until_homed_but_jog_is_allowed():
    r = Rig(homed=False)
    try:
        r.submit("aaaa0001|MOVEJOINT|60|-90|180|0|0|180|1|None")
        r.submit("aaaa0002|JOG|0|20|0.2|None")
        r.run_until(lambda: r.terminal("aaaa0002") is not None)
        assert r.terminal("aaaa0001") is AckStatus.FAILED
        assert "not homed" in [a for a in r.acks if a[0] == "aaaa0001"][-1][2]
        assert r.terminal("aaaa0002") is AckStatus.COMPLETED
        # the jog goes out as GO TO frames (bounded commitments), J1 only, forward; no JOG frame
        # moves anything but the start-up probe's 1 step/s
        jog = [f for f in r.frames if f.command == BoardCommand.GOTO]
        assert jog and jog[-1].positions[0] > jog[0].positions[0]
        assert all(f.positions[1:] == jog[0].positions[1:] for f in jog)
        assert all(abs(v) <= 1 for f in r.frames if f.command == BoardCommand.JOG for v in f.speeds)
    finally:
        r.close()


def test_home_sends_100_once_then_idle_and_completes_at_standby():
    r = Rig(homed=False)
    try:
        r.submit("aaaa0001|HOME")
        r.run_until(lambda: r.terminal("aaaa0001") is not None, max_ticks=20000)
        assert r.terminal("aaaa0001") is AckStatus.COMPLETED
        assert sum(f.command == BoardCommand.HOME for f in r.frames) == 1
        assert tuple(r.core.status.positions) == PAROL6.standby_steps
    finally:
        r.close()


def test_speed_streams_end_with_a_zero_speed_frame(rig):
    rig.submit("aaaa0001|SPEEDJOINT|5|0|0|0|0|0|0.2")
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    jogs = [f for f in rig.frames if f.command == BoardCommand.JOG]
    assert jogs[-1].speeds == (0, 0, 0, 0, 0, 0)
    assert any(f.speeds[0] > 0 for f in jogs)


def test_a_speed_stream_lasts_its_duration_in_time_even_when_ticks_come_late(rig):
    """The board keeps the last speed until the next frame: with ticks 50 ms late (a stalled
    machine) a 0.4 s SPEEDJOINT must still end after about 0.4 s, not after 40 late ticks."""
    j1 = rig.emu.positions[0]
    rig.submit("aaaa0001|SPEEDJOINT|10|0|0|0|0|0|0.4")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    t0 = rig.now - 1.0 / RATE  # the tick that activated it sent the first speed frame
    late = 0.05
    n = len(rig.frames)
    while rig.terminal("aaaa0001") is None:
        rig.tick(dt=late)
        assert rig.now - t0 < 2.0, "the speed stream did not end"
    # the frame with the end target (zero feed-forward) ends the motion: the late ticks caught
    # up, each within what the guard allows (the ack follows once a status frame shows the
    # board on it and at rest)
    end = rig.frames[-1].positions
    first_end = next(i for i, f in enumerate(rig.frames[n:]) if f.positions == end and f.speeds == (0,) * 6)
    ended = (first_end + 1) * late
    assert 0.4 <= ended <= 0.4 + late + 1e-9
    assert abs((rig.emu.positions[0] - j1) / PAROL6.steps_per_deg[0] - 4.0) < 0.05  # 10 deg/s x 0.4 s
    assert all(f.command == BoardCommand.GOTO for f in rig.frames[n:])


def test_stop_during_a_jog_holds_the_board_still_from_the_next_frame(rig):
    rig.submit("aaaa0001|JOG|0|50|2|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(5)
    n = len(rig.frames)
    assert rig.frames[-1].command == BoardCommand.GOTO  # the jog: GO TO frames
    rig.send("STOP")
    rig.tick(3)
    after = rig.frames[n:]
    assert [f.command for f in after] == [BoardCommand.IDLE] * 3
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert rig.emu.speeds == (0,) * 6


def test_stream_jog_watchdog_stops_motion_within_two_ticks(rig):
    rig.send("STREAM|ON")
    rig.tick()
    rig.submit("aaaa0001|JOG|0|50|5|None")
    rig.tick(1)
    assert AckStatus.EXECUTING in rig.statuses("aaaa0001")
    # updates stop: rig.now advances 10 ms per tick, watchdog 20 ms
    rig.tick(3)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    assert rig.frames[-1].speeds == (0,) * 6


def test_newer_stream_jog_supersedes_the_previous_one(rig):
    rig.send("STREAM|ON")
    rig.tick()
    rig.submit("aaaa0001|JOG|0|50|5|None")
    rig.tick()
    rig.submit("aaaa0002|JOG|1|50|5|None")
    rig.tick()
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    assert AckStatus.EXECUTING in rig.statuses("aaaa0002")
    assert rig.frames[-1].speeds[1] != 0 and rig.frames[-1].speeds[0] == 0


def test_jog_stops_at_the_joint_limit(rig):
    rig.submit("aaaa0001|JOG|0|100|60|None")  # J1 positive for a minute: hits +123 deg
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None, max_ticks=6000)
    detail = [a for a in rig.acks if a[0] == "aaaa0001"][-1][2]
    assert "upper limit of J1" in detail
    assert rig.angles[0] <= PAROL6.limits_deg[0][1]
    assert rig.guard.violations == 0  # the jog stopped itself before the guard had to


def test_queue_full_refuses_with_failed_never_drops():
    r = Rig(queue_size=3)
    try:
        for i in range(5):
            r.submit(f"aaaa000{i}|DELAY|1")
        assert [r.terminal(f"aaaa000{i}") for i in range(5)][3:] == [AckStatus.FAILED, AckStatus.FAILED]
        assert "queue full" in r.acks[-1][2]
    finally:
        r.close()


def test_gripper_calibrate_is_sent_in_exactly_one_frame(rig):
    rig.submit("aaaa0001|ELECTRICGRIPPER|calibrate")
    rig.submit("aaaa0002|PNEUMATICGRIPPER|open|2")
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
    rig.tick(5)
    assert sum(f.gripper_mode == GripperMode.CALIBRATE for f in rig.frames) == 1
    assert rig.frames[-1].io & 0x10  # OUT2 on


def test_gripper_calibrate_fails_naming_the_cause_when_the_gripper_never_reports_calibrated():
    """A gripper that never reports calibrated (none connected, or one that takes longer than
    the timeout: this emulated one takes 60 s) fails the calibrate after 5 s instead of
    completing it, and the queue goes on."""
    r = Rig(gripper_calibration_s=60.0)
    try:
        n0 = len(r.outputs)
        r.submit("aaaa0001|ELECTRICGRIPPER|calibrate")
        r.submit("aaaa0002|DELAY|0.01")
        r.run_until(lambda: r.terminal("aaaa0002") is not None, max_ticks=600)
        assert r.terminal("aaaa0001") is AckStatus.FAILED
        details = next(d for c, s, d in r.acks if c == "aaaa0001" and s is AckStatus.FAILED)
        assert details == ("the gripper did not report calibrated within 5 s of the calibrate "
                           "(GET_GRIPPER status 0x00, bit 0x01 clear): is an SSG-48 connected?")
        cal_at = next(k for k, o in enumerate(r.outputs) if k >= n0 and o.frame is not None
                      and o.frame.gripper_mode == GripperMode.CALIBRATE)
        assert r.tick_of_ack("aaaa0001", AckStatus.FAILED) - cal_at == 500  # 5 s at 100 Hz
        assert r.terminal("aaaa0002") is AckStatus.COMPLETED
    finally:
        r.close()


def test_gripper_calibrate_takes_the_gripper_word_only_from_two_new_status_frames_in_a_row():
    """The link has no checksum: one status byte with the calibrated bit flipped neither starts
    nor ends the calibration, and a reply that did not come (the same frame seen again) is not
    a second one.  A gripper whose bit never clears fails, saying so."""
    from parolkit.controller.activities import GripperCalibrateActivity  # (issue 22: new with the fix)

    def run(act: GripperCalibrateActivity, bits: list[int | StatusFrame]) -> list[FrameRequest]:
        """Step ``act`` once per entry: a status frame, or a new one with these low bits."""
        out = []
        for i, b in enumerate(bits):
            st = b if isinstance(b, StatusFrame) else StatusFrame(gripper_status=0x80 | b)
            out.append(act.step(TickContext(tick=i, now=i / RATE, rate_hz=RATE, status=st, homed=True,
                                            stream_mode=False, watchdog_s=0.2, limits_steps=PAROL6.limits_steps)))
        return out

    # calibrated before; one corrupted frame clear; then calibrating; one corrupted frame set
    steps = run(GripperCalibrateActivity(timeout_ticks=100), [1, 1, 0, 1, 1, 0, 0, 0, 1, 0, 0, 1, 1])
    assert [s.done for s in steps] == [None] * 12 + [AckStatus.COMPLETED]
    assert steps[0].gripper_mode == GripperMode.CALIBRATE
    assert all(s.gripper_mode == GripperMode.OPERATE for s in steps[1:])
    cal, ok = StatusFrame(gripper_status=0x80), StatusFrame(gripper_status=0x81)
    steps = run(GripperCalibrateActivity(timeout_ticks=100), [ok, cal, cal, ok, ok])
    assert [s.done for s in steps] == [None] * 5  # the same frame twice is one frame
    steps = run(GripperCalibrateActivity(timeout_ticks=5), [1] * 6)
    assert [s.done for s in steps] == [None] * 5 + [AckStatus.FAILED]
    assert steps[-1].details == ("the gripper did not report calibrated within 0.05 s of the calibrate "
                                 "(GET_GRIPPER status 0x81, bit 0x01 never cleared: the gripper did not "
                                 "start calibrating)")


def test_get_gripper_object_detection_is_1_only_while_the_status_byte_reports_an_object(rig):
    """The board's own object-detection byte is a constant 1 (stock firmware): GET_GRIPPER's
    sixth field (and the status object's ``object_detection``) come from the status byte's
    object code instead (1 or 2: an object), so a gripper closed on nothing reads 0."""
    def gripper(cid: str, text: str, position: int, code: int) -> list[int]:
        rig.submit(f"{cid}|ELECTRICGRIPPER|{text}")
        rig.run_until(lambda: rig.terminal(cid) is not None)
        assert rig.terminal(cid) is AckStatus.COMPLETED
        rig.run_until(lambda: (rig.core.status.gripper_position, rig.core.status.gripper.object_code)
                      == (position, code), max_ticks=200)
        rig.tick()
        snap = rig.outputs[-1].snapshot
        reply = snap.reply("GET_GRIPPER")
        assert snap.as_dict()["gripper"]["object_detection"] == int(reply.rsplit(",", 1)[1])
        return [int(v) for v in reply.split("|")[1].split(",")]

    assert rig.core.status.object_detection == 1  # what the board sends, whatever the jaws do
    assert gripper("aaaa0001", "calibrate", 0, 3)[5] == 0  # open, at its position
    closed = gripper("aaaa0002", "move|255|255|400", 255, 3)  # closed on nothing
    assert closed[5] == 0 and closed[4] & 0x30 == 0x30
    gripper("aaaa0003", "move|0|255|400", 0, 3)
    rig.emu.place_object(24.0)
    held = gripper("aaaa0004", "move|255|255|400", 128, 1)  # stopped by the 24 mm object
    assert held[5] == 1 and held[4] & 0x30 == 0x10
    rig.emu.remove_object()
    rig.tick(2)
    assert gripper("aaaa0005", "move|0|255|400", 0, 3)[5] == 0


def test_output_completes_only_once_the_board_reports_the_new_level(rig):
    """COMPLETED means the board's status shows the output, so a GET_IO after the ack reads it."""
    for cid, action, want in (("aaaa0001", "open", (True, False)), ("aaaa0002", "close", (False, False))):
        rig.send(f"{cid}|PNEUMATICGRIPPER|{action}|1")
        rig.run_until(lambda cid=cid: rig.terminal(cid) is not None)
        # what the controller published with each ack: the tick's snapshot
        at_ack = {(a.command_id, a.status): (o.snapshot.seq, o.snapshot.status.outputs)
                  for o in rig.outputs for a in o.acks}
        assert rig.terminal(cid) is AckStatus.COMPLETED
        started, _ = at_ack[(cid, AckStatus.EXECUTING)]
        done, reported = at_ack[(cid, AckStatus.COMPLETED)]
        assert reported == want  # published with the COMPLETED ack: the board's report
        assert done > started  # never on the tick whose frame carries the new level


def test_output_fails_when_the_board_never_reports_it():
    from parolkit.controller.activities import OutputActivity, TickContext

    act = OutputActivity(2, True, timeout_ticks=5)
    silent = StatusFrame(positions=PAROL6.standby_steps, homed=0xFF, io=0x0F)  # OUT2 stays off
    ctx = TickContext(tick=0, now=0.0, rate_hz=RATE, status=silent, homed=True, stream_mode=False,
                      watchdog_s=0.02, limits_steps=PAROL6.limits_steps)
    steps = [act.step(ctx) for _ in range(6)]
    assert all(s.done is None for s in steps[:5])
    assert steps[5].done is AckStatus.FAILED
    assert steps[5].details == "the board did not report OUT2 = 1 within 0.05 s"


def test_plan_failure_is_reported_as_failed_when_its_turn_comes(rig):
    rig.submit("aaaa0001|MOVEPOSE|900|0|0|0|0|0|1|None")  # far out of reach
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.FAILED


# ------------------------------------------------------------------- timed joint paths

PATH_OFFSETS = [[8, -5, 6, 10, 8, -12], [15, -8, 10, 5, 15, -20], [20, -10, 12, 15, 20, -25]]
PATH_TIMES = [1.5, 3.0, 4.0]


def _path_datagram(cid: str, start: np.ndarray, offsets=PATH_OFFSETS, times=PATH_TIMES) -> tuple[str, list]:
    points = [start + np.array(o, dtype=float) for o in offsets]
    fields = [f"{cid}|MOVEJOINTPATH", str(len(points))]
    for t, q in zip(times, points):
        fields += [repr(float(t)), *(repr(float(v)) for v in q)]
    return "|".join(fields), points


def _run_logged(rig: Rig, cid: str) -> list[tuple[CommandFrame | None, np.ndarray]]:
    """Tick until ``cid`` ends: per tick, the frame sent and the board's steps the tick read."""
    log = []
    while rig.terminal(cid) is None:
        n = len(rig.frames)
        rig.tick()
        log.append((rig.frames[-1] if len(rig.frames) > n else None, np.asarray(rig.core.status.positions)))
        assert len(log) < 1000, rig.acks[-3:]
    return log


def test_a_three_point_path_commands_each_point_on_its_tick_and_the_board_ends_on_time(rig):
    """Issue 17's acceptance, tick by tick: a 3-point path over 4 s is one command whose last
    sample goes out 400 ticks after the start, and the board is within 1 step of the last point
    on that tick (the points are passed, not stopped at)."""
    start = rig.angles.copy()
    text, points = _path_datagram("aaaa0001", start)
    rig.submit(text)
    log = _run_logged(rig, "aaaa0001")
    assert rig.statuses("aaaa0001") == [AckStatus.QUEUED, AckStatus.EXECUTING, AckStatus.COMPLETED]
    first = next(i for i, (f, _) in enumerate(log) if f is not None and f.command == BoardCommand.GOTO)
    spd = PAROL6.steps_per_deg
    for q, t in zip(points, PATH_TIMES):  # sample k (from 1) goes out k - 1 ticks after the first
        frame, _ = log[first + round(t * RATE) - 1]
        assert frame.command == BoardCommand.GOTO
        assert np.array_equal(frame.positions, np.rint(q * spd)), t
    end = first + round(PATH_TIMES[-1] * RATE) - 1
    target = np.rint(points[-1] * spd)
    assert any(log[end - 1][0].speeds)  # still moving one tick before its end
    assert log[end][0].speeds == (0, 0, 0, 0, 0, 0)
    # the board as the last sample's frame arrived: its reply, read into the next tick
    assert np.abs(log[end + 1][1] - target).max() <= 1
    # between the points the path does not stop: every frame before the end moves
    assert all(any(f.speeds) for f, _ in log[first + 5:end - 5])
    assert np.abs(rig.angles - points[-1]).max() < 0.01


def test_a_path_is_planned_from_where_the_previous_command_ends_and_stop_cancels_it(rig):
    rig.submit("aaaa0001|MOVEJOINT|80|-90|180|0|0|180|0.5|None")
    text, points = _path_datagram("aaaa0002", np.array([80.0, -90.0, 180.0, 0.0, 0.0, 180.0]))
    rig.submit(text)
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0002"))
    rig.tick(100)
    rig.send("STOP")
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None, 40)  # it slows down on its path first
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    assert rig.terminal("aaaa0002") is AckStatus.CANCELLED
    _holds_still(rig)


def test_a_path_over_a_limit_fails_naming_the_joint_and_the_point_and_nothing_moves(rig):
    before = rig.angles.copy()
    text, _ = _path_datagram("aaaa0001", before, [[-5, 0, 0, 0, 0, 0], [-45, 0, 0, 0, 0, 0]], [1.0, 1.3])
    rig.submit(text)
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.FAILED
    details = [d for c, st, d in rig.acks if c == "aaaa0001" and st is AckStatus.FAILED][0]
    assert "MoveJointPath refused" in details and "too fast between the start and point 0" in details
    assert "J1 speed" in details
    assert not any(f.command == BoardCommand.GOTO for f in rig.frames)
    assert np.allclose(rig.angles, before)


# ---------------------------------------------------------------------------------- guard


def _status(pos=PAROL6.standby_steps, io=0x0F) -> StatusFrame:
    return StatusFrame(positions=tuple(pos), homed=0xFF, io=io)


# ---------------------------------------------------------------------------------- stats


def test_histogram_percentiles_match_numpy_within_one_bin():
    rng = np.random.default_rng(1)
    xs = rng.normal(0.010, 0.0005, 5000).clip(0.001)
    h = Histogram()
    for x in xs:
        h.add(float(x))
    p50, p99 = h.percentiles((50.0, 99.0))
    assert abs(p50 - np.percentile(xs, 50)) <= 2e-5
    assert abs(p99 - np.percentile(xs, 99)) <= 2e-5
    assert h.max == pytest.approx(xs.max())


def test_commands_sent_while_disabled_fail_until_enable(rig):
    rig.send("DISABLE")
    rig.tick(2)
    assert rig.frames[-1].command == BoardCommand.DISABLE
    rig.submit("aaaa0001|DELAY|0.1")
    assert rig.terminal("aaaa0001") is AckStatus.FAILED
    rig.send("ENABLE")
    rig.tick(2)
    rig.submit("aaaa0002|DELAY|0.05")
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
    assert rig.terminal("aaaa0002") is AckStatus.COMPLETED


def test_streamed_cartesian_jog_is_refused_before_homing():
    r = Rig(homed=False)
    try:
        r.send("STREAM|ON")
        r.tick()
        r.submit("aaaa0001|CARTJOG|WRF|Z+|20|0.5")
        assert r.terminal("aaaa0001") is AckStatus.FAILED
    finally:
        r.close()


def _hold_cartesian_jog(rig, ticks: int, burst: int = 1) -> list:
    """Hold a CARTJOG like the commander does: one update per tick (JOG_REPEAT_S).  With
    ``burst`` > 1 each tick's updates arrive together, before the plan the first asked for
    (planning takes at least the tick that asks).  Returns the motion frames."""
    rig.submit("aaaa0001|MOVEJOINT|60|-80|170|10|40|170|1|None")  # off the wrist singularity
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    rig.send("STREAM|ON")
    rig.tick()
    first = len(rig.frames)
    for k in range(ticks):
        for b in range(burst):
            rig.submit(f"{b:04d}{k:04d}|CARTJOG|WRF|Z-|50|0.2")
        rig.tick()
    return [f for f in rig.frames[first:] if f.command == BoardCommand.GOTO and any(f.speeds)]


def _tcp_z(frames) -> np.ndarray:
    from parolkit.kinematics import fk

    return np.array([fk(np.array(f.positions) / PAROL6.steps_per_deg)[2] for f in frames])


def test_a_held_streamed_cartesian_jog_continues_from_the_commanded_position(rig):
    """Each update of a held CARTJOG is planned from where the running jog last commanded the
    board, not from the measured joints (which lag behind the board's position loop): the
    commanded TCP moves down steadily, never steps back, and covers the jog speed's distance."""
    frames = _hold_cartesian_jog(rig, 60)
    dz = np.diff(_tcp_z(frames))
    v = PAROL6.cart_linear_speed_from_percent(50) / RATE  # mm per tick
    assert len(frames) >= 55  # from the tick after the first plan on
    assert dz.max() <= 0.05 * v, f"the commanded TCP stepped back by {dz.max():.3f} mm"
    assert -dz.sum() >= 0.9 * v * len(dz), f"covered {-dz.sum():.2f} mm in {len(dz)} ticks"


def test_a_held_cartesian_jog_keeps_moving_when_updates_come_faster_than_planning(rig):
    """Two updates arrive per tick before the planner can take the first: the second,
    repeating the jog still waiting for its plan, is merged into it instead of restarting
    the planning; every update resets the watchdog, so the held jog is never stopped, and
    whenever a plan is ready it takes over where the running one is."""
    frames = _hold_cartesian_jog(rig, 60, burst=2)
    second = [a for a in rig.acks if a[0] is not None and a[0].startswith("0001")]
    merged = [a for a in second if a[1] is AckStatus.COMPLETED
              and a[2] == "merged into the same jog waiting for its plan"]
    watchdog = [a for a in rig.acks if "watchdog" in a[2]]
    dz = np.diff(_tcp_z(frames))
    v = PAROL6.cart_linear_speed_from_percent(50) / RATE
    assert len(merged) == len(second) == 60 and not watchdog
    assert dz.max() <= 0.05 * v, f"the commanded TCP stepped back by {dz.max():.3f} mm"
    assert len(frames) >= 20  # it moved (on an idle machine: nearly every tick of the hold)


def test_a_corrupted_io_byte_does_not_latch_the_estop_but_a_clean_press_latches_at_once():
    """The safety state's account of the hardware E-stop, frame by frame (pure transitions)."""
    st = StatusFrame(positions=PAROL6.standby_steps, homed=0xFF, io=0x0F)
    s = SafetyState()
    s, pressed = s.hardware_estop(st, 0)
    assert not pressed
    # a corrupted IO byte that also flips other bits: indistinguishable from a press for one
    # frame, so it needs a second frame in a row
    s, pressed = s.hardware_estop(StatusFrame(positions=st.positions, homed=0xFF, io=0x07 | 0x40), 0)
    assert not pressed and not s.estop_pressed
    s, pressed = s.hardware_estop(st, 0)
    assert not pressed and not s.estop_pressed
    # exactly the E-stop bit cleared, outputs as commanded: a press, acted on at once
    s, pressed = s.hardware_estop(StatusFrame(positions=st.positions, homed=0xFF, io=0x07), 0)
    assert pressed and s.estop_pressed
    s = s.estop()
    assert s.frame_code(7, idle=True)[1] == BoardCommand.DISABLE
    # released: two frames in a row
    s, _ = s.hardware_estop(st, 0)
    assert s.estop_pressed
    s, _ = s.hardware_estop(st, 0)
    assert not s.estop_pressed and s.estop_latched  # still latched until ENABLE


def test_a_clean_estop_press_at_the_board_latches_in_the_tick_that_reads_it(rig):
    rig.tick(3)
    rig.emu.set_estop(True)
    rig.tick(1)  # the frame that reaches the board with the button down; its reply shows it
    assert not rig.core.estop_latched
    rig.tick(1)  # reads that reply: this tick's frame is DISABLE
    assert rig.core.estop_latched and rig.frames[-1].command == BoardCommand.DISABLE


def test_wait_input_completes_when_the_input_matches_and_fails_on_timeout(rig):
    rig.submit("aaaa0001|WAIT_INPUT|2|1|1")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(5)
    assert rig.terminal("aaaa0001") is None
    rig.emu.set_input(2, True)
    rig.tick(4)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    rig.submit("aaaa0002|WAIT_INPUT|1|1|0.1")
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
    assert rig.terminal("aaaa0002") is AckStatus.FAILED


# ---------------------------------------------------------------------------------- outbox


def test_outbox_sends_in_order_to_every_address_of_a_route():
    import socket

    from parolkit.controller.inbox import Ack
    from parolkit.controller.server import Outbox

    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(2.0)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    box = Outbox(tx)
    box.start()
    try:
        dest = rx.getsockname()
        box.put("ACK|a|QUEUED|", dest)
        box.send_acks([Ack("a", (dest, dest), AckStatus.EXECUTING), Ack("a", (dest,), AckStatus.COMPLETED, "x")])
        got = [rx.recvfrom(100)[0].decode() for _ in range(4)]
        assert got == ["ACK|a|QUEUED|", "ACK|a|EXECUTING|", "ACK|a|EXECUTING|", "ACK|a|COMPLETED|x"]
    finally:
        box.stop()
        tx.close()
        rx.close()


# ------------------------------------------------------------- ack after snapshot, safety lane


def _effect_shown(snap, cid: str, status: AckStatus, text: str) -> bool:
    """Does ``snap`` (published with the ack) show what ``status`` of command ``text`` reports?"""
    name = text.split("|")[1]
    cmd = snap.command
    if status is AckStatus.QUEUED:
        return snap.queue >= 1 or (cmd is not None and cmd.command_id == cid)
    if status is AckStatus.EXECUTING:
        return cmd is not None and cmd.command_id == cid
    if status is AckStatus.CANCELLED:
        return cmd is None or cmd.command_id != cid
    assert status is AckStatus.COMPLETED, (cid, status)
    if cmd is not None and cmd.command_id == cid:
        return False  # a finished command is no longer shown as active
    return {
        "ENABLE": lambda: snap.enabled and not snap.estop_latched,
        "DISABLE": lambda: not snap.enabled and snap.state.value == "DISABLED",
        "ESTOP": lambda: snap.estop_latched and snap.state.value == "ESTOP",
        "STOP": lambda: snap.queue == 0 and snap.command is None,
        "CLEAR_ERROR": lambda: snap.error is None,
        "STREAM": lambda: snap.stream_mode is (text.endswith("ON")),
        "PNEUMATICGRIPPER": lambda: snap.status.outputs[0] is text.split("|")[2].startswith("open"),
        "MOVEJOINT": lambda: np.allclose(snap.angles_deg, [float(v) for v in text.split("|")[2:8]], atol=0.05),
        "HOME": lambda: all(snap.homed) and np.allclose(snap.angles_deg, PAROL6.standby_deg, atol=0.05),
        "DELAY": lambda: True,
        "SPEEDJOINT": lambda: True,
        "JOG": lambda: True,
    }[name]()


def test_every_ack_leaves_with_the_snapshot_that_shows_its_effect():
    """By construction: a tick returns its acks together with the snapshot built after them, and
    the loop publishes that snapshot before it sends them.  Checked for every command kind."""
    r = Rig(homed=False)
    try:
        script = [
            "k0000001|HOME", "k0000002|MOVEJOINT|80|-90|170|5|5|175|1|None", "k0000003|DELAY|0.05",
            "k0000004|PNEUMATICGRIPPER|open|1", "k0000005|PNEUMATICGRIPPER|close|1",
            "k0000006|SPEEDJOINT|5|0|0|0|0|0|0.1", "k0000007|JOG|0|50|0.1|None", "k0000008|STREAM|ON",
            "k0000009|STREAM|OFF", "k0000010|CLEAR_ERROR", "k0000011|DISABLE", "k0000012|ENABLE",
            "k0000013|MOVEJOINT|90|-90|180|0|0|180|3|None", "k0000014|STOP",
            "k0000015|MOVEJOINT|90|-80|180|0|0|180|3|None", "k0000016|ESTOP", "k0000017|ENABLE",
        ]
        texts = {t.split("|")[0]: t for t in script}
        for text in script:
            cid = text.split("|")[0]
            r.send(text)
            r.run_until(lambda cid=cid, text=text: r.terminal(cid) is not None or (
                text.endswith("3|None") and AckStatus.EXECUTING in r.statuses(cid)), max_ticks=3000)
        r.tick(3)
        checked = 0
        for out in r.outputs:
            for a in out.acks:
                assert _effect_shown(out.snapshot, a.command_id, a.status, texts[a.command_id]), (
                    f"{a.command_id} {a.status.value} left with a snapshot that does not show it")
                checked += 1
        seen = {(a.command_id, a.status) for o in r.outputs for a in o.acks}
        assert ("k0000013", AckStatus.CANCELLED) in seen and ("k0000015", AckStatus.CANCELLED) in seen
        assert all((c, AckStatus.COMPLETED) in seen for c in texts if c not in ("k0000013", "k0000015"))
        assert checked >= 35  # every ack of the script above
    finally:
        r.close()


def test_estop_in_the_safety_lane_goes_out_in_the_next_frame_whatever_waits_beside_it(rig):
    rig.submit("aaaa0001|MOVEJOINT|90|-80|170|0|0|180|3|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    for k in range(300):  # a flood from ten sources, far more than a tick takes
        rig.send("STREAM|OFF", port=100 + k % 10)
    rig.send("bbbb0001|ESTOP")
    rig.tick()
    assert rig.frames[-1].command == BoardCommand.DISABLE
    assert rig.statuses("bbbb0001") == [AckStatus.COMPLETED]
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert len(rig.loop.inbox) == 300 - rig.loop.inbox.max_taken  # the rest waits its turn


def test_a_safety_command_arriving_while_the_frame_is_made_replaces_that_frame(rig):
    """The first frame written after ESTOP arrives carries it, even mid-tick."""
    rig.submit("aaaa0001|MOVEJOINT|90|-80|170|0|0|180|3|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    check = rig.core.guard.check
    arrived = []

    def check_then_estop_arrives(frame, *a, **kw):
        res = check(frame, *a, **kw)
        if not arrived:  # the datagram lands after the motion frame was composed and guarded
            arrived.append(frame)
            rig.send("bbbb0001|ESTOP")
        return res

    rig.core.guard.check = check_then_estop_arrives
    rig.tick()
    assert arrived[0].command == BoardCommand.GOTO
    assert rig.frames[-1].command == BoardCommand.DISABLE
    assert rig.statuses("bbbb0001") == [AckStatus.COMPLETED]


def test_a_command_received_before_a_stop_that_overtook_it_is_cancelled_by_it(rig):
    rig.send("cccc0001|STOP", seq=10)
    rig.send("aaaa0001|MOVEJOINT|90|-80|170|0|0|180|3|None", seq=9)  # sent first, arrives later
    rig.send("aaaa0002|ENABLE", seq=8)
    rig.send("aaaa0003|MOVEJOINT|90|-80|170|0|0|180|1|None", seq=11)  # after the STOP: runs
    rig.tick()
    assert rig.statuses("cccc0001") == [AckStatus.COMPLETED]
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert "STOP received after it" in [a for a in rig.acks if a[0] == "aaaa0001"][-1][2]
    assert rig.terminal("aaaa0002") is AckStatus.CANCELLED
    assert rig.statuses("aaaa0003") == [AckStatus.QUEUED]


def test_a_servo_target_received_before_a_stop_that_overtook_it_starts_no_stream(rig):
    """A teleop client's last targets and its STOP: the STOP comes through the safety lane
    ahead of the targets sent before it.  Those targets are cancelled by it, not taken as the
    start of a new stream after the stop (the arm moved again after a gamepad's deadman was
    released, at load 30-40)."""
    q = [90.0, -88.0, 180.0, 0.0, 0.0, 180.0]
    rig.send("sv000001|SERVOJ|" + "|".join(f"{v:.4f}" for v in q), seq=20)
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("sv000001"))
    rig.send("cccc0001|STOP", seq=30)
    for _ in range(6):  # the stop runs; the target sent before it is still on its way
        rig.tick()
    late = [v + 0.5 for v in q]
    rig.send("sv000002|SERVOJ|" + "|".join(f"{v:.4f}" for v in late), seq=29)  # sent first, arrives later
    rig.tick()
    assert rig.statuses("cccc0001") == [AckStatus.COMPLETED]
    assert rig.terminal("sv000002") is AckStatus.CANCELLED
    assert "STOP received after it" in [a for a in rig.acks if a[0] == "sv000002"][-1][2]
    for _ in range(40):
        rig.tick()
    assert rig.core.jobs.active is None  # no stream started after the stop
    assert not any(AckStatus.EXECUTING in rig.statuses(c) for c in ("sv000002",))


def test_command_inbox_takes_sources_in_turn_and_refuses_a_full_lane():
    from parolkit.controller.inbox import CommandInbox

    box = CommandInbox(max_waiting_per_source=3, max_taken_per_tick=4)
    a, b = ("127.0.0.1", 1), ("127.0.0.1", 2)
    mk = lambda src, n: Submission(C.Delay(0.1), f"id{n:06d}", ((src[0], 5002),), src, n)  # noqa: E731
    assert all(box.put(mk(a, n)) for n in range(3))
    assert not box.put(mk(a, 3)) and box.refused == 1
    assert box.put(mk(b, 4))
    box.put_safety(Submission(C.Stop(), None, None, b, 5))
    assert box.safety_waiting
    assert [s.seq for s in box.take_safety()] == [5] and not box.safety_waiting
    assert [s.seq for s in box.take()] == [0, 4, 1, 2]  # a, b, a, a: b is not behind a's backlog
    assert len(box) == 0


# ------------------------------------------------------------------------------ plan ahead


_AHEAD = iter(range(-1, -10**6, -1))


def _plan_ahead(rig, command) -> int:
    """As the server does for an idle robot: a plan from the latest snapshot, started now (the
    driver makes it inline; its result reaches the core with the next tick, by its key)."""
    snap = rig.outputs[-1].snapshot
    key = next(_AHEAD)
    rig.loop.plan_ahead(PlanRequest(key, command, tuple(snap.angles_deg), snap.tool, None, RATE, PAROL6,
                                    world=snap.collision.world))
    return key


def _send_planned_ahead(rig, text: str, seq: int) -> bool:
    """As the server does: start the plan while parsing, hand both to the next tick."""
    p = parse_datagram(text)
    key = _plan_ahead(rig, p.command)
    src = ("127.0.0.1", 1)
    rig.loop.inbox.put(Submission(p.command, p.command_id, (src,), src, seq, None, key))
    return True


def test_a_move_planned_ahead_starts_at_the_tick_that_takes_it_in(rig):
    """Idle robot: the server starts planning while it parses, so the move does not wait a tick
    for the planner (command -> first motion frame at the board)."""
    assert _send_planned_ahead(rig, "aaaa0001|MOVEJOINT|80|-90|170|0|0|180|1|None", 1)
    rig.tick()
    assert rig.statuses("aaaa0001") == [AckStatus.QUEUED, AckStatus.EXECUTING]
    assert rig.frames[-1].command == BoardCommand.GOTO


def test_moves_sent_together_while_idle_all_run_in_order_with_one_plan_ahead():
    r = Rig()
    try:
        ids = [f"t000000{i}" for i in range(6)]
        made = [_send_planned_ahead(r, f"{cid}|MOVEJOINT|{90 - 5 * (i % 2)}|-90|180|0|0|180|0.8|None", i + 1)
                for i, cid in enumerate(ids)]
        assert all(made)  # each from the same start: only the first can use its plan
        r.run_until(lambda: r.terminal(ids[-1]) is not None, max_ticks=3000)
        assert [a[0] for a in r.acks if a[1] is AckStatus.COMPLETED] == ids
    finally:
        r.close()


def test_a_plan_made_ahead_from_another_start_is_not_used(rig):
    """Planned ahead from where the robot was; another move got in first: planned again."""
    p = parse_datagram("aaaa0002|MOVEJOINT|80|-90|170|0|0|180|1|None")
    key = _plan_ahead(rig, p.command)
    rig.submit("aaaa0001|MOVEJOINT|70|-90|170|0|0|180|1.5|None")  # queued first, elsewhere
    src = ("127.0.0.1", 1)
    rig.loop.inbox.put(Submission(p.command, p.command_id, (src,), src, 2, None, key))
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None, max_ticks=3000)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED and rig.terminal("aaaa0002") is AckStatus.COMPLETED
    assert np.allclose(rig.angles, [80, -90, 170, 0, 0, 180], atol=0.05)


@pytest.mark.parametrize("text", ["ENABLE", "CLEAR_ERROR"])
def test_enable_or_clear_error_mid_move_leaves_the_motion_untouched(rig, text):
    """The board zeroes every speed on 101 / 103: sent mid-move they jerked a joint from full
    speed to 0 and back in one tick. They now go out once the move has ended."""
    rig.submit("aaaa0001|MOVEJOINT|60|-90|180|0|0|180|1.5|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    rig.tick(40)
    start = len(rig.frames)
    rig.send(f"bbbb0001|{text}")
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    rig.tick(2)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    assert rig.statuses("bbbb0001") == [AckStatus.COMPLETED]
    code = BoardCommand.ENABLE if text == "ENABLE" else BoardCommand.CLEAR_ERROR
    after = [f.command for f in rig.frames[start:]]
    first = after.index(code)
    last_goto = max(i for i, c in enumerate(after) if c == BoardCommand.GOTO)
    assert first > last_goto, "sent while the move was still running"
    assert all(c == BoardCommand.GOTO for c in after[:first])  # the move was never interrupted
    assert after.count(code) == 1


@pytest.mark.parametrize("disable", ["ESTOP", "DISABLE", "fault"])
def test_a_disable_is_written_before_an_enable_that_arrives_in_the_same_tick(rig, disable):
    """A client that re-enables at once (seeing DISABLED in the status stream) got its ENABLE
    applied in the same tick as the uncommanded-motion fault: the board got 101 and never the
    DISABLE (1 in ~250 faults in the 60 s corruption run).  The DISABLE owed goes out first,
    then the ENABLE; a STOP recomposing that tick's frame keeps it DISABLE."""
    rig.submit("aaaa0001|MOVEJOINT|90|-80|170|0|0|180|3|None")
    rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
    n = len(rig.frames)
    if disable == "fault":
        rig.core._fault("J2 moved 500 steps beyond anything commanded")  # as the integrity check reports one
    else:
        rig.submit(f"bbbb0001|{disable}")
    rig.submit("bbbb0002|ENABLE")
    rig.send("bbbb0003|STOP")  # the safety lane: this tick's frame is composed again
    rig.tick(3)
    sent = [f.command for f in rig.frames[n:]]
    assert sent[0] == BoardCommand.DISABLE, sent
    assert BoardCommand.ENABLE in sent[1:], sent
    assert rig.terminal("aaaa0001") is AckStatus.CANCELLED
    assert rig.ex.enabled


def test_full_speed_moves_under_jittery_ticks_never_meet_a_guard_refusal(rig):
    """Ticks late at random and the next one on its deadline (a loaded machine): a move
    catching up judged its targets by the pacing model's own estimate, while the guard judged
    by its prediction (the previous frame counted as running at least one period, both
    hypotheses when uncertain): moves at 100 % FAILED on "would start this frame at ... above
    its maximum" (the 10-minute load run, test_guard_wire).  Targets are now the ones the
    guard passes."""
    import random

    rnd = random.Random(7)
    moves = ["MOVEJOINT|40|-60|220|-60|-40|90|None|100|100", "MOVEJOINT|90|-90|180|0|0|180|None|100|100",
             "MOVEJOINT|90|-90|160|12|12|180|None|40", "MOVEJOINT|62|-76|161|22|-18|152|1.3|None",
             "MOVEJOINT|90|-90|180|0|0|180|None|100|100"]
    for k, text in enumerate(moves * 2):
        cid = f"j{k:07d}"
        rig.submit(f"{cid}|{text}")
        late = 0.0
        for _ in range(3000):
            # the loop keeps its deadlines: a tick late by L comes L after its deadline, the next
            # one on its own deadline (L early against the one before); later than a period:
            # the missed deadlines are skipped
            if late:
                gap, late = 0.010 - late, 0.0
            else:
                late = rnd.choice((0.0, 0.0, 0.0, 0.002, 0.004, 0.008, 0.0095))
                gap = 0.010 + late if rnd.random() < 0.9 else 0.020 + late
            rig.tick(dt=gap)
            if rig.terminal(cid) is not None:
                break
        assert rig.terminal(cid) is AckStatus.COMPLETED, (text, rig.acks[-3:])
    assert rig.guard.violations == 0, rig.guard.last_violation


def test_set_port_to_a_device_that_is_not_there_fails_and_reaches_no_tick():
    """The datagram fuzzer's SET_PORT|None switched a working board link to a port named
    'None' and lost it; the server refuses a device that does not exist (FAILED, the link
    stays as it is): nothing reaches the tick."""
    import socket

    from parolkit.controller.inbox import CommandInbox
    from parolkit.controller.server import Outbox, StatusStream, UdpServer

    srv_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    srv_sock.bind(("127.0.0.1", 0))
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.bind(("127.0.0.1", 0))
    client.settimeout(2.0)
    try:
        inbox = CommandInbox()
        outbox = Outbox(srv_sock)
        server = UdpServer(srv_sock, model=PAROL6, inbox=inbox, outbox=outbox, stream=StatusStream(srv_sock),
                           answerer=_Answers(), ack_port=client.getsockname()[1])
        outbox.start()
        for cid, port in (("aaaa0001", "None"), ("aaaa0002", "/dev/ttyACM-not-there")):
            server.handle(f"{cid}|SET_PORT|{port}".encode(), client.getsockname())
            ack = client.recv(65535).decode()
            assert ack.startswith(f"ACK|{cid}|FAILED|") and "no device at" in ack, ack
        assert not inbox.take() and not inbox.take_safety()
        outbox.stop()
    finally:
        srv_sock.close()
        client.close()


class _Answers:
    """The QueryAnswerer the server needs, for a server without a controller behind it."""

    def answer_query(self, name: str, viewer: str | None = None) -> str:
        return "PONG" if name == "PING" else "ERROR|not here"

    def resolve_tool(self, name: str) -> object:
        raise ValueError(name)

    def plan_ahead(self, command):
        return None

    def busy(self) -> bool:
        return False


def test_ack_here_routes_a_safety_command_read_in_the_same_drain():
    """ACK_HERE then an ID'd STOP, read by one drain of the socket (a busy server): the STOP
    skips the queue to the safety lane, so ACK_HERE must take effect when it is read, not
    when its turn to be served comes, or the STOP's acks never reach the socket that asked
    (the datagram fuzzer saw an ID'd STOP and DISABLE go unanswered under load)."""
    import socket

    from parolkit.controller.inbox import CommandInbox
    from parolkit.controller.server import Outbox, StatusStream, UdpServer

    srv_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    srv_sock.bind(("127.0.0.1", 0))
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.bind(("127.0.0.1", 0))
    try:
        inbox = CommandInbox()
        server = UdpServer(srv_sock, model=PAROL6, inbox=inbox, outbox=Outbox(srv_sock),
                           stream=StatusStream(srv_sock), answerer=_Answers(), ack_port=5002)
        dest = srv_sock.getsockname()
        for text in (b"ACK_HERE", b"stop0001|STOP", b"dis00001|DISABLE"):
            client.sendto(text, dest)
        wait_until(lambda: server._nowait.recv(65535, socket.MSG_PEEK) is not None, 2.0)
        time.sleep(0.05)  # all three have arrived
        server._drain()  # one drain reads all three, as a busy server does; nothing served yet
        me = client.getsockname()
        subs = inbox.take_safety()
        assert [s.command_id for s in subs] == ["stop0001", "dis00001"]
        for s in subs:
            assert me in s.route, (s.command_id, s.route)
            assert s.client == f"{me[0]}:{me[1]}", s.client
    finally:
        srv_sock.close()
        client.close()


def test_the_scheduling_shows_as_soon_as_the_tick_thread_sets_it_even_in_a_young_cached_view():
    """GET_STATUS right after the link came up said SCHED=not started: its loop view was a
    cached one (up to 0.25 s old) made before the tick thread set its scheduling."""
    from parolkit.controller.stats import LoopMetrics

    m = LoopMetrics(RATE)
    assert m.view(max_age_s=10.0, now=1.0).scheduling == "not started"
    m.scheduling = "fifo:10"
    assert m.view(max_age_s=10.0, now=1.01).scheduling == "fifo:10"


def test_with_a_board_in_lockstep_late_and_early_ticks_send_the_same_frames_as_punctual_ones():
    """A board that runs one period per frame (the replay's simulated board): the trajectory
    follows the tick count, not the wall clock, and the guard judges frame intervals the same
    way, so ticks 1-25 ms apart send exactly the frames of ticks 10 ms apart (a wall-clock
    schedule jumped ahead in the plan after a late tick while that board advanced 10 ms)."""
    def run(jitter: bool, tick_clock: bool = True) -> tuple[list[CommandFrame], list[tuple[int, ...]]]:
        rig = Rig(lockstep=True)
        rig.loop.lockstep = tick_clock  # False: the driver's clock is the (jittered) wall time
        rig.submit("aaaa0001|MOVEJOINT|70|-80|165|15|-15|160|1.2|None")
        rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))  # planned, first frame sent
        frames, seen = [rig.frames[-1]], []
        for k in range(400):
            rig.tick(dt=(0.03 if k % 5 == 1 else 0.0002 if k % 5 in (2, 3) else 1.0 / RATE) if jitter else 1.0 / RATE)
            frames.append(rig.frames[-1])
            seen.append(tuple(rig.core.status.positions))
            if rig.terminal("aaaa0001") is not None:
                break
        assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
        rig.close()
        return frames, seen

    punctual = run(jitter=False)
    assert run(jitter=True) == punctual
    assert run(jitter=True, tick_clock=False)[0] != punctual[0]  # the wall-clock schedule would differ
