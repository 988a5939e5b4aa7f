"""The emulated board behaves like the stock PAROL6 firmware (virtual clock, byte level)."""

from __future__ import annotations

import random
import types

import pytest

from parolkit.board import SWITCH_POSITIONS_STEPS, BoardEmulator, HomingPhase, LinkFaults
from parolkit.board import emulator as emulator_module
from parolkit.errors import ParolkitValueError
from parolkit.protocol import BoardCommand, CommandFrame, GripperStatus, StatusFrame, StatusParser
from parolkit.protocol.frames import TIMER_HZ
from parolkit.robot import PAROL6
from parolkit.transport.base import LinkLostError

STANDBY = (10240, -32000, 57905, 0, 0, 32000)


class PC:
    """A minimal PC side: encodes frames, feeds the board's bytes to a StatusParser."""

    def __init__(self, emu: BoardEmulator) -> None:
        self.emu = emu
        self.parser = StatusParser()

    def send_raw(self, data: bytes) -> list[StatusFrame]:
        self.emu.write(data)
        return self.parser.feed(self.emu.read())

    def send(self, **kw: object) -> StatusFrame:
        frames = self.send_raw(CommandFrame(**kw).encode())  # type: ignore[arg-type]
        assert len(frames) == 1, f"expected exactly one reply, got {len(frames)}"
        return frames[0]

    def tick(self, dt: float = 0.01, **kw: object) -> StatusFrame:
        self.emu.advance(dt)
        return self.send(**kw)


def make(**kw: object) -> tuple[BoardEmulator, PC]:
    emu = BoardEmulator(clock="virtual", **kw)  # type: ignore[arg-type]
    return emu, PC(emu)


def home(pc: PC, max_s: float = 120.0, period_s: float = 0.01) -> tuple[StatusFrame, float]:
    """ENABLE, HOME, then IDLE frames every ``period_s`` until homed; (last reply, seconds)."""
    pc.send(command=BoardCommand.ENABLE)
    pc.tick(command=BoardCommand.HOME)
    t = 0.0
    while t < max_s:
        st = pc.tick(period_s, command=BoardCommand.IDLE)
        t += period_s
        if st.homed == 0xFF:
            return st, t
    raise AssertionError("homing did not finish")


# ------------------------------------------------------------------------------------------
# power-up and constant fields
# ------------------------------------------------------------------------------------------

def test_power_up_reports_zero_counters_homed_0x03_enabled_and_stock_constants():
    emu, pc = make()
    st = pc.send(command=BoardCommand.IDLE)
    assert st.positions == (0, 0, 0, 0, 0, 0)
    assert st.homed == 0x03
    assert emu.enabled
    assert st.io == 0x0F  # nothing pressed, no outputs
    assert (st.temperature_error, st.position_error, st.timeout_error) == (0x03, 0x03, 100)
    assert (st.gripper_speed, st.object_detection, st.crc) == (1, 1, 212)


def test_xtr_echoes_every_command_code_including_unknown_ones():
    emu, pc = make()
    for code in (255, 101, 103, 42, 0, 200):
        assert pc.send(command=code).xtr == code


def test_timing_is_inter_frame_time_in_board_ticks_low_16_bits():
    emu, pc = make()
    pc.send()
    assert pc.tick(0.01).timing == 7031  # 10 ms = 7031.25 ticks
    assert pc.tick(0.004).timing == 2812
    assert pc.tick(0.1).timing == 70312 & 0xFFFF  # 100 ms wraps modulo 2**16


# ------------------------------------------------------------------------------------------
# homing
# ------------------------------------------------------------------------------------------

def test_real_time_homing_takes_tens_of_seconds_and_ends_homed_at_standby_counts():
    emu, pc = make(homing_speedup=1, pass_hz=1000)
    st, t = home(pc, period_s=0.05)
    assert st.positions == STANDBY
    assert st.speeds == (0, 0, 0, 0, 0, 0)
    assert emu.physical_positions == STANDBY
    assert 20.0 < t < 60.0, f"a real-time homing takes tens of seconds, took {t:.1f} s"


def test_enable_home_idle_frames_at_100hz_with_speedup_end_homed_0xff_at_standby_counts():
    emu, pc = make(homing_speedup=50)
    st, t = home(pc)
    assert st.positions == STANDBY and st.homed == 0xFF
    assert t < 1.0


def test_homing_finds_the_switches_from_any_power_up_pose():
    emu, pc = make(homing_speedup=100, power_up_steps=(0, -20000, 70000, -3000, 2000, 50000))
    st, _ = home(pc)
    assert st.positions == STANDBY
    assert emu.physical_positions == STANDBY


def test_switch_positions_match_the_spec_in_joint_degrees():
    deg = [s / k for s, k in zip(SWITCH_POSITIONS_STEPS, PAROL6.steps_per_deg)]
    assert deg == pytest.approx([-28.65, -145.09, 108.44, 143.44, -125.16, 180.0], abs=0.01)


def test_homing_sets_j1_to_j3_homed_bits_before_the_rest():
    emu, pc = make(homing_speedup=20)
    pc.send(command=BoardCommand.HOME)
    seen = set()
    for _ in range(1000):
        st = pc.tick(command=BoardCommand.IDLE)
        seen.add(st.homed)
        if st.homed == 0xFF:
            break
    assert 0x03 | 0xE0 in seen  # J1-J3 homed first
    assert 0x03 | 0xF0 in seen  # then J4
    assert st.homed == 0xFF


@pytest.mark.parametrize("code", [101, 102, 103, 123, 156])
def test_homing_is_aborted_by_enable_disable_clear_jog_and_goto(code):
    emu, pc = make(homing_speedup=10)
    pc.send(command=BoardCommand.HOME)
    pc.tick(0.2, command=BoardCommand.IDLE)
    assert emu.homing_active
    pc.tick(command=code)
    assert not emu.homing_active
    for _ in range(300):
        st = pc.tick(command=BoardCommand.IDLE)
    assert st.homed != 0xFF


def test_homing_continues_through_unknown_command_codes():
    emu, pc = make(homing_speedup=50)
    pc.send(command=BoardCommand.HOME)
    for _ in range(200):
        st = pc.tick(command=42)
        if st.homed == 0xFF:
            break
    assert st.homed == 0xFF and st.positions == STANDBY


def test_a_new_home_frame_restarts_homing_from_the_beginning():
    emu, pc = make(homing_speedup=20)
    pc.send(command=BoardCommand.HOME)
    for _ in range(150):
        pc.tick(command=BoardCommand.IDLE)
    assert emu.homing_phase is not HomingPhase.J123_REFERENCE
    pc.tick(command=BoardCommand.HOME)
    assert emu.homing_phase is HomingPhase.J123_REFERENCE
    assert emu.homed == 0x03


def test_home_is_ignored_while_disabled():
    emu, pc = make(homing_speedup=50)
    pc.send(command=BoardCommand.DISABLE)
    pc.tick(command=BoardCommand.HOME)
    assert not emu.homing_active


# ------------------------------------------------------------------------------------------
# GO TO and JOG
# ------------------------------------------------------------------------------------------

def test_goto_converges_exactly_on_its_target_without_feed_forward():
    emu, pc = make()
    target = (1000, -2000, 300, 0, 45, -7)
    pc.send(command=BoardCommand.GOTO, positions=target)
    emu.advance(1.0)
    assert emu.positions == target
    assert pc.send(command=BoardCommand.GOTO, positions=target).speeds == (0,) * 6


def test_goto_reports_the_firmware_p_loop_speed():
    emu, pc = make()
    frame = dict(command=BoardCommand.GOTO, positions=(100, -37, 0, 0, 0, 0),
                 speeds=(300, 0, -50, 0, 0, 0))
    pc.send(**frame)
    emu.advance(1 / emu.pass_hz)  # exactly one loop pass, evaluated at counters 0
    st = pc.send(**frame)
    # v = int(((target - current) / 0.01 + v_ff) / 2)
    assert st.speeds[:3] == (int((100 / 0.01 + 300) / 2), int((-37 / 0.01) / 2), -25)


def test_a_reply_carries_the_last_loop_pass_telemetry_so_a_command_shows_from_the_next_frame():
    emu, pc = make()
    first = pc.send(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0))
    assert first.speeds[0] == 0  # copied by the last pass, before this frame was handled
    assert emu.speeds[0] == 1000  # live value
    assert pc.tick(0.01, command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0)).speeds[0] == 1000


def test_goto_with_feed_forward_settles_where_error_is_minus_vff_over_100():
    emu, pc = make()
    pc.send(command=BoardCommand.GOTO, positions=(5000, 0, 0, 0, 0, 0), speeds=(1000, 0, 0, 0, 0, 0))
    emu.advance(2.0)
    assert emu.positions[0] == 5000 + 10  # error = target - current = -1000 / 100


def test_goto_speed_is_clamped_to_50000_steps_per_second():
    emu, pc = make()
    pc.send(command=BoardCommand.GOTO, positions=(2_000_000, 0, 0, 0, 0, 0))
    assert emu.speeds[0] == 50000
    emu.advance(0.5)
    assert abs(emu.positions[0] - 25000) <= 2


def test_jog_runs_at_the_frame_speed_and_steps_equal_speed_times_time():
    emu, pc = make()
    speeds = (1500, -3000, 3600, -7000, 7000, 18000)
    pc.send(command=BoardCommand.JOG, speeds=speeds)
    emu.advance(1.0)
    assert all(abs(p - s) <= 2 for p, s in zip(emu.positions, speeds))
    emu.advance(0.5)  # the last command is sticky: no further frames needed
    assert all(abs(p - 1.5 * s) <= 2 for p, s in zip(emu.positions, speeds))


def test_jog_speed_is_clamped_to_50000_and_no_joint_limit_is_enforced():
    emu, pc = make()
    pc.send(command=BoardCommand.JOG, speeds=(60000, -70000, 0, 0, 0, 0))
    emu.advance(1.0)
    assert emu.speeds[:2] == (50000, -50000)
    assert abs(emu.positions[0] - 50000) <= 2  # far past J1's 14000-step limit
    assert abs(emu.positions[1] + 50000) <= 2


def test_idle_holds_still():
    emu, pc = make()
    pc.send(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0))
    emu.advance(0.1)
    held = emu.positions
    pc.send(command=BoardCommand.IDLE)
    emu.advance(1.0)
    assert emu.positions == held


def test_unknown_command_idles_and_still_replies():
    emu, pc = make()
    pc.send(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0))
    emu.advance(0.1)
    held = emu.positions
    assert pc.send(command=77).xtr == 77
    emu.advance(1.0)
    assert emu.positions == held


# ------------------------------------------------------------------------------------------
# disable / enable / clear error
# ------------------------------------------------------------------------------------------

def test_disabled_board_ignores_jog_goto_and_joints_stop_dead():
    emu, pc = make()
    pc.send(command=BoardCommand.JOG, speeds=(2000, 0, 0, 0, 0, 0))
    emu.advance(0.5)
    pc.send(command=BoardCommand.DISABLE)
    assert emu.speeds == (0,) * 6
    held = emu.positions
    assert pc.tick(0.5, command=BoardCommand.JOG, speeds=(2000,) * 6).speeds == (0,) * 6
    pc.tick(0.5, command=BoardCommand.GOTO, positions=(0, 9000, 0, 0, 0, 0))
    emu.advance(0.5)
    assert emu.positions == held


def test_clear_error_does_not_enable_but_enable_does():
    emu, pc = make()
    pc.send(command=BoardCommand.DISABLE)
    pc.send(command=BoardCommand.CLEAR_ERROR)
    assert not emu.enabled
    pc.send(command=BoardCommand.ENABLE)
    assert emu.enabled
    pc.send(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0))
    emu.advance(0.1)
    assert emu.positions[0] == pytest.approx(100, abs=2)


# ------------------------------------------------------------------------------------------
# IO and E-stop
# ------------------------------------------------------------------------------------------

def test_output_bits_echo_in_the_io_byte():
    emu, pc = make()
    assert pc.send(io=0x20).io == 0x2F
    assert pc.send(io=0x10).io == 0x1F
    assert pc.send(io=0x30 | 0xC8).io == 0x3F  # input/E-stop bits from the PC are ignored
    assert emu.outputs == (True, True)
    assert pc.send(io=0).io == 0x0F


def test_inputs_and_estop_are_reported_and_estop_reads_zero_when_pressed():
    emu, pc = make()
    emu.set_input(1, True)
    assert pc.send().io == 0x8F
    emu.set_input(2, True)
    emu.set_input(1, False)
    assert pc.send().io == 0x4F
    emu.set_estop(True)
    st = pc.send()
    assert st.io == 0x47 and st.estop_pressed


def test_firmware_takes_no_action_on_estop():
    emu, pc = make(estop_pressed=True)
    pc.send(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0))
    emu.advance(1.0)
    assert emu.positions[0] == pytest.approx(1000, abs=2)
    assert emu.enabled


# ------------------------------------------------------------------------------------------
# error injection
# ------------------------------------------------------------------------------------------

def test_error_injection_sets_temperature_and_position_bits_opt_in():
    emu, pc = make()
    emu.inject_errors(temperature=["J3"], position=[1, 6])
    st = pc.send()
    assert st.temperature_error == 0x20 | 0x03
    assert st.position_error == 0x80 | 0x04 | 0x03
    emu.clear_errors()
    st = pc.send()
    assert (st.temperature_error, st.position_error) == (0x03, 0x03)


# ------------------------------------------------------------------------------------------
# the receiver
# ------------------------------------------------------------------------------------------

GOOD = CommandFrame(command=BoardCommand.IDLE).encode()


def test_a_frame_split_into_single_bytes_gets_exactly_one_reply():
    emu, pc = make()
    replies = []
    for b in GOOD:
        replies += pc.send_raw(bytes([b]))
    assert len(replies) == 1


def test_garbage_half_frames_wrong_end_bytes_and_wrong_len_get_no_reply():
    emu, pc = make()
    wrong_end = GOOD[:-2] + b"\x02\x01"
    wrong_len = GOOD[:3] + bytes([51]) + GOOD[4:]
    assert pc.send_raw(b"\x00\x01garbage\xff\xff") == []
    assert pc.send_raw(GOOD[:30]) == []
    assert pc.send_raw(wrong_end) == []
    assert pc.send_raw(wrong_len + b"\x00" * 10) == []
    assert emu.stats.frames_accepted == 0
    # the board has not crashed and resynchronises on the next good frame
    assert len(pc.send_raw(GOOD)) == 1


def test_a_good_frame_right_after_a_half_frame_is_still_found():
    emu, pc = make()
    assert len(pc.send_raw(GOOD[:30] + GOOD)) == 1


def test_random_garbage_never_crashes_the_board_nor_produces_a_reply():
    emu, pc = make()
    rng = random.Random(1234)
    for _ in range(200):
        junk = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 120)))
        if rng.random() < 0.3:
            junk = b"\xff\xff\xff\x34" + junk  # plausible starts
        assert pc.send_raw(junk.replace(b"\x01\x02", b"\x01\x03")) == []
    assert len(pc.send_raw(b"\x00" * 60 + GOOD)) == 1


# ------------------------------------------------------------------------------------------
# gripper
# ------------------------------------------------------------------------------------------

def _grip(pc: PC, **kw: object) -> StatusFrame:
    base = dict(gripper_command=0xD0, gripper_speed=255, gripper_current=500)
    base.update(kw)
    return pc.send(**base)  # type: ignore[arg-type]


def test_gripper_calibrate_sets_calibrated_and_activated_after_a_short_time():
    emu, pc = make(gripper_calibration_s=0.5)
    st = pc.send(gripper_mode=1)
    assert not st.gripper.calibrated
    emu.advance(0.6)
    g = pc.send().gripper
    assert g.calibrated and g.activated
    assert g.object_code == 3  # at position (fully open)


def test_gripper_moves_at_the_rate_set_by_the_speed_byte_and_reports_current():
    emu, pc = make(gripper_calibration_s=0.0)
    pc.send(gripper_mode=1)
    st = _grip(pc, gripper_position=200, gripper_speed=0)  # slowest: 20 units/s
    emu.advance(1.0)
    st = _grip(pc, gripper_position=200, gripper_speed=0)
    assert st.gripper_position == 20
    assert st.gripper_current == 500  # setpoint while moving
    assert st.gripper.object_code == 0 and st.gripper.action
    st = _grip(pc, gripper_position=200, gripper_speed=255)  # fastest: 500 units/s
    emu.advance(0.4)
    st = _grip(pc, gripper_position=200, gripper_speed=255)
    assert st.gripper_position == 200
    assert st.gripper.object_code == 3
    assert st.gripper_current == 20  # small at rest


def test_gripper_stops_on_a_placed_object_and_reports_object_found_while_closing():
    emu, pc = make(gripper_calibration_s=0.0)
    pc.send(gripper_mode=1)
    emu.place_object(30.0)
    _grip(pc, gripper_position=255)
    emu.advance(1.0)
    st = _grip(pc, gripper_position=255)
    assert st.gripper_position == round(255 * (1 - 30 / 48))
    assert st.gripper.object_code == 1 and st.gripper.object_detected
    assert st.gripper_status & 0x10 and not st.gripper_status & 0x20
    assert st.gripper_current == 500  # gripping


def test_gripper_estop_bit_raises_error_until_clear_error_mode():
    emu, pc = make(gripper_calibration_s=0.0)
    pc.send(gripper_mode=1)
    assert _grip(pc, gripper_command=0xF0).gripper.estop_error
    assert pc.send(gripper_mode=2).gripper.estop_error is False


def test_gripper_status_byte_round_trips_through_the_codec():
    emu, pc = make(gripper_calibration_s=0.0)
    pc.send(gripper_mode=1)
    st = _grip(pc, gripper_position=10)
    assert GripperStatus.from_byte(st.gripper_status).to_byte() == st.gripper_status
    assert st.gripper_status & 0x81 == 0x81


# ------------------------------------------------------------------------------------------
# link faults
# ------------------------------------------------------------------------------------------

def test_drop_all_bytes_means_no_reply_and_clearing_restores_the_link():
    emu, pc = make(seed=1)
    emu.set_faults(drop_rate=1.0)
    assert pc.send_raw(GOOD) == []
    emu.clear_faults()
    assert len(pc.send_raw(GOOD)) == 1


def test_corrupting_bytes_loses_some_frames_but_never_crashes_or_accepts_a_broken_one():
    emu, pc = make(seed=7)
    emu.set_faults(corrupt_rate=0.01)
    got = 0
    for _ in range(300):
        got += len(pc.send_raw(CommandFrame(command=BoardCommand.IDLE, io=0x20).encode()))
    assert 150 < got < 300
    assert emu.stats.bytes_corrupted_by_faults > 0
    assert pc.parser.stats.frames_rejected + pc.parser.stats.bytes_dropped > 0


def test_delay_holds_replies_back_for_the_given_time():
    emu, pc = make()
    emu.set_faults(delay_s=0.05, direction="from_board")
    assert pc.send_raw(GOOD) == []
    emu.advance(0.04)
    assert pc.parser.feed(emu.read()) == []
    emu.advance(0.02)
    assert len(pc.parser.feed(emu.read())) == 1


def test_silent_board_stops_answering_but_keeps_running_its_last_command():
    emu, pc = make()
    pc.send(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0))
    emu.set_faults(silent=True)
    assert pc.send_raw(CommandFrame(command=BoardCommand.IDLE).encode()) == []
    emu.advance(1.0)
    assert emu.positions[0] == pytest.approx(1000, abs=2)


def test_unplugged_board_raises_link_lost_and_replug_restores_it():
    emu, pc = make()
    emu.unplug()
    with pytest.raises(LinkLostError):
        emu.write(GOOD)
    with pytest.raises(LinkLostError):
        emu.read()
    emu.replug()
    assert len(pc.send_raw(GOOD)) == 1


# ------------------------------------------------------------------------------------------
# bad input to every public function
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(clock="sundial"), "clock"),
        (dict(homing_speedup=0), "homing_speedup"),
        (dict(homing_speedup="fast"), "homing_speedup"),
        (dict(pass_hz=100), "pass_hz"),
        (dict(power_up_steps=(1, 2, 3)), "power_up_steps"),
        (dict(power_up_steps=(0, 0, 0, 0, 0, 1.5)), r"power_up_steps\[J6\]"),
        (dict(j5_offset_steps=1234), "j5_offset_steps"),
        (dict(gripper_calibration_s=-1), "gripper_calibration_s"),
        (dict(estop_pressed="yes"), "estop_pressed"),
        (dict(in1=2), "in1"),
        (dict(start_homed=None), "start_homed"),
    ],
)
def test_bad_constructor_arguments_raise_an_error_naming_the_field(kwargs, field):
    with pytest.raises(ParolkitValueError, match=field):
        BoardEmulator(clock="virtual", **kwargs) if "clock" not in kwargs else BoardEmulator(**kwargs)


def test_bad_arguments_to_control_methods_raise_errors_naming_the_field():
    emu = BoardEmulator(clock="virtual")
    cases = [
        (lambda: emu.advance(-1), "seconds"),
        (lambda: emu.advance(float("nan")), "seconds"),
        (lambda: emu.set_input(3, True), "number"),
        (lambda: emu.set_input(1, "on"), "value"),
        (lambda: emu.set_estop(None), "pressed"),
        (lambda: emu.place_object(60), "object width"),
        (lambda: emu.place_object(0), "object width"),
        (lambda: emu.place_object("wide"), "object width"),
        (lambda: emu.inject_errors(temperature=[7]), "temperature"),
        (lambda: emu.inject_errors(position=["J0"]), "position"),
        (lambda: emu.write("text"), "data"),
        (lambda: emu.process_frame(b"\xff"), "frame"),
        (lambda: emu.set_faults(drop_rate=2), "drop_rate"),
        (lambda: emu.set_faults(corrupt_rate=-0.1), "corrupt_rate"),
        (lambda: emu.set_faults(delay_s=100), "delay_s"),
        (lambda: emu.set_faults(direction="sideways"), "direction"),
        (lambda: emu.start(), "realtime"),
        (lambda: emu.add_link_listener(42), "callback"),
    ]
    for call, field in cases:
        with pytest.raises(ParolkitValueError, match=field):
            call()


def test_advance_refuses_a_realtime_emulator():
    emu = BoardEmulator()
    with pytest.raises(ParolkitValueError, match="virtual"):
        emu.advance(0.1)


def test_object_wider_than_the_current_opening_is_refused():
    emu, pc = make(gripper_calibration_s=0.0)
    pc.send(gripper_mode=1)
    _grip(pc, gripper_position=200)
    emu.advance(1.0)
    with pytest.raises(ParolkitValueError, match="does not fit"):
        emu.place_object(40)


def test_link_faults_value_object_validates_every_field():
    with pytest.raises(ParolkitValueError, match="drop_rate"):
        LinkFaults(drop_rate=float("nan"))
    with pytest.raises(ParolkitValueError, match="silent"):
        LinkFaults(silent=1)  # type: ignore[arg-type]
    assert not LinkFaults().active and LinkFaults(delay_s=0.1).active


def test_unknown_fault_option_is_named():
    emu = BoardEmulator(clock="virtual")
    with pytest.raises(ParolkitValueError, match="jitter"):
        emu.set_faults(jitter=0.1)


def test_homing_ignores_the_estop():
    emu, pc = make(homing_speedup=50, estop_pressed=True)
    st, _ = home(pc)
    assert st.positions == STANDBY and st.estop_pressed


def test_ssg48_j5_offset_changes_only_the_final_j5_move():
    emu, pc = make(homing_speedup=100, j5_offset_steps=8035)
    st, _ = home(pc)
    assert st.positions == STANDBY
    assert emu.physical_positions[4] == -8900 + 8035


def test_start_homed_and_power_cycle():
    emu, pc = make(start_homed=True)
    st = pc.send()
    assert st.positions == STANDBY and st.homed == 0xFF
    emu.power_cycle()
    st = pc.send()
    assert st.positions == (0,) * 6 and st.homed == 0x03
    assert emu.physical_positions == STANDBY  # the arm did not move


def test_process_frame_is_the_decoded_path_of_write_and_read():
    emu, pc = make()
    st = emu.process_frame(CommandFrame(command=BoardCommand.JOG, speeds=(500, 0, 0, 0, 0, 0)))
    assert st.xtr == 123
    emu.advance(0.2)
    assert emu.status_frame().speeds[0] == 500
    assert emu.status_frame().positions[0] == pytest.approx(100, abs=1)


def test_gripper_setpoints_reach_the_gripper_as_the_board_packs_them():
    emu, pc = make(gripper_calibration_s=0.0)
    pc.send(gripper_mode=1)
    st = _grip(pc, gripper_position=256 + 40, gripper_current=5000)  # u8 position on CAN
    emu.advance(1.0)
    st = _grip(pc, gripper_position=256 + 40, gripper_current=5000)
    assert st.gripper_position == 40
    assert emu.gripper.setpoint == 40


def test_jaw_rate_mapping_and_its_argument_check():
    from parolkit.board import jaw_rate_units_s

    assert jaw_rate_units_s(0) == 20.0 and jaw_rate_units_s(255) == 500.0
    with pytest.raises(ParolkitValueError, match="speed"):
        jaw_rate_units_s(256)


def test_fault_injector_refuses_non_bytes():
    from parolkit.board import ByteFaultInjector

    with pytest.raises(ParolkitValueError, match="data"):
        ByteFaultInjector().push("text", 0.0)  # type: ignore[arg-type]
    with pytest.raises(ParolkitValueError, match="faults"):
        ByteFaultInjector().set_faults({"drop_rate": 1})  # type: ignore[arg-type]


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as hs  # noqa: E402

_garbage = hs.binary(max_size=80).map(lambda b: b.replace(b"\xff", b"\x00"))
_frames = hs.builds(
    lambda cmd, io, p: CommandFrame(command=cmd, io=io, positions=(p, -p, 0, 0, 0, p)),
    hs.integers(0, 255), hs.integers(0, 255), hs.integers(-(1 << 23) + 1, (1 << 23) - 1))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(hs.lists(hs.tuples(_garbage, _frames), min_size=1, max_size=6), hs.integers(1, 64))
def test_every_valid_frame_between_garbage_gets_exactly_one_reply_echoing_it(items, chunk):
    emu, pc = make()
    stream = b"".join(g + f.encode() for g, f in items)
    replies = []
    for i in range(0, len(stream), chunk):  # any USB packet size
        replies += pc.send_raw(stream[i:i + chunk])
    assert [r.xtr for r in replies] == [int(f.command) for _, f in items]
    assert [r.io & 0x30 for r in replies] == [f.io & 0x30 for _, f in items]


def test_an_exchange_listener_reads_the_time_of_its_exchange_however_long_it_takes(monkeypatch):
    """On the real-time clock ``time_s`` catches up with the wall clock, but not inside an
    exchange listener: the board does not run on while it tells its listeners.  (It did: a
    listener held up half a millisecond read the time of the next loop pass, and
    test_board_sim's timing check saw the field 351 ticks off on a busy machine.)  The wall
    clock is the emulator's ``time.monotonic``, moved on by the test: no wall-clock wait."""
    wall = [1000.0]
    monkeypatch.setattr(emulator_module, "time", types.SimpleNamespace(monotonic=lambda: wall[0]))
    emu = BoardEmulator(clock="realtime")
    seen: list[tuple[float, float]] = []

    def listener(frame: CommandFrame, reply: StatusFrame) -> None:
        first = emu.time_s
        wall[0] += 0.02  # the listener held up 20 ms: 20 board loop passes at its 1 kHz
        seen.append((first, emu.time_s))

    emu.add_exchange_listener(listener)
    pc = PC(emu)
    pc.send(command=BoardCommand.IDLE)
    pc.send(command=BoardCommand.IDLE)
    assert len(seen) == 2 and all(a == b for a, b in seen), seen
    # the second frame's timing field is the time between the two exchanges the listener saw
    reply = pc.send(command=BoardCommand.IDLE)
    assert emu.time_s >= seen[1][0] + 0.02 - 1e-9  # (outside a listener it catches up again)
    assert len(seen) == 3
    assert abs(reply.timing - round((seen[2][0] - seen[1][0]) * TIMER_HZ)) <= 1, reply.timing
