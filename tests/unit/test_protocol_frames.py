"""Board frame codec: every golden vector byte for byte, round trips, and refusals."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import DATA_DIR
from parolkit.errors import ParolkitValueError
from parolkit.protocol import (
    BoardCommand,
    CommandFrame,
    FrameError,
    GripperStatus,
    IOBits,
    StatusFrame,
    bits_to_byte,
    byte_to_bits,
)

GOLDEN = json.loads((DATA_DIR / "serial_frames.json").read_text())


def _command_from_fields(f: dict) -> CommandFrame:
    return CommandFrame(
        positions=f["position"], speeds=f["speed"], command=f["command"],
        affected=bits_to_byte(f["affected"]), io=bits_to_byte(f["inout"]), timeout=f["timeout"],
        gripper_position=f["g_pos"], gripper_speed=f["g_speed"], gripper_current=f["g_current"],
        gripper_command=f["g_command"], gripper_mode=f["g_mode"], gripper_id=f["g_id"],
    )


def _status_from_fields(f: dict) -> StatusFrame:
    return StatusFrame(
        positions=f["position"], speeds=f["speed"], homed=bits_to_byte(f["homed"]),
        io=bits_to_byte(f["io"]), temperature_error=bits_to_byte(f["temp_err"]),
        position_error=bits_to_byte(f["pos_err"]), timing=f["timing"],
        timeout_error=f["timeout_err"], xtr=f["xtr"], gripper_id=f["g_id"],
        gripper_position=f["g_pos"], gripper_speed=f["g_speed"], gripper_current=f["g_current"],
        gripper_status=f["g_status"], object_detection=f["obj"],
    )


@pytest.mark.parametrize("vec", GOLDEN["command_frames"], ids=lambda v: v["hex"][12:30])
def test_command_frame_golden_vector_encodes_and_decodes_byte_for_byte(vec):
    frame = _command_from_fields(vec["fields"])
    raw = bytes.fromhex(vec["hex"])
    assert frame.encode() == raw
    assert CommandFrame.decode(raw) == frame
    assert len(raw) == 56


@pytest.mark.parametrize("vec", GOLDEN["status_frames"], ids=lambda v: v["hex"][12:30])
def test_status_frame_golden_vector_encodes_and_decodes_byte_for_byte(vec):
    frame = _status_from_fields(vec["fields"])
    raw = bytes.fromhex(vec["hex"])
    assert frame.encode() == raw
    decoded = StatusFrame.decode(raw, check_crc=True)
    assert decoded == frame
    d = vec["decoded"]
    assert list(decoded.positions) == d["position"]
    assert [int(b) for b in byte_to_bits(decoded.homed)] == d["homed"]
    assert [int(b) for b in byte_to_bits(decoded.io)] == d["io"]
    assert decoded.timing == d["timing"] and decoded.xtr == d["xtr"]
    assert decoded.gripper_current == d["gripper_current"]


def test_status_views_decode_flags_like_the_board_means_them():
    idle = StatusFrame(homed=0xFF, io=0x0F)
    assert idle.all_homed and not idle.estop_pressed
    assert idle.inputs == (False, False) and idle.outputs == (False, False)
    pressed = StatusFrame(io=0x07 | IOBits.IN1 | IOBits.OUT2)
    assert pressed.estop_pressed and pressed.inputs == (True, False) and pressed.outputs == (False, True)
    assert StatusFrame(timing=7031).timing_s == pytest.approx(0.01, abs=2e-6)
    assert StatusFrame(homed=0x03).homed_joints == (False,) * 6


def test_gripper_status_byte_round_trips_every_value():
    for v in range(256):
        assert GripperStatus.from_byte(v).to_byte() == v
    s = GripperStatus.from_byte(0x80 | 0x40 | 0x10 | 0x01)
    assert s.activated and s.action and s.calibrated and s.object_code == 1 and s.object_detected


def test_known_and_unknown_command_codes():
    assert CommandFrame(command=156).command is BoardCommand.GOTO
    odd = CommandFrame(command=7)
    assert odd.command == 7 and CommandFrame.decode(odd.encode()).command == 7


frames_i24 = st.integers(-(1 << 23), (1 << 23) - 1)
six = st.lists(frames_i24, min_size=6, max_size=6)
u8 = st.integers(0, 255)
i16 = st.integers(-(1 << 15), (1 << 15) - 1)


@settings(max_examples=300, deadline=None)
@given(six, six, u8, u8, u8, u8, i16, i16, i16, u8, u8, u8, u8)
def test_any_command_frame_round_trips(p, s, cmd, aff, io, to, gp, gs, gc, gcmd, gm, gid, crc):
    f = CommandFrame(p, s, cmd, aff, io, to, gp, gs, gc, gcmd, gm, gid, crc)
    raw = f.encode()
    assert len(raw) == 56 and raw[:4] == b"\xff\xff\xff\x34" and raw[-2:] == b"\x01\x02"
    assert CommandFrame.decode(raw) == f


@settings(max_examples=300, deadline=None)
@given(six, six, u8, u8, u8, u8, st.integers(0, 65535), u8, u8, u8, i16, i16, i16, u8, u8)
def test_any_status_frame_round_trips(p, s, h, io, te, pe, tm, toe, x, gid, gp, gs, gc, gst, ob):
    f = StatusFrame(p, s, h, io, te, pe, tm, toe, x, gid, gp, gs, gc, gst, ob)
    raw = f.encode()
    assert len(raw) == 60 and raw[3] == 56
    assert StatusFrame.decode(raw) == f


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        ({"positions": [0] * 5}, "positions must have 6 values"),
        ({"positions": [0, 0, 1 << 23, 0, 0, 0]}, r"positions\[J3\] = 8388608 is out of range"),
        ({"speeds": [0, 0, 0, 0, 0, 1.5]}, r"speeds\[J6\] must be an integer"),
        ({"speeds": "abcdef"}, "speeds must be a sequence"),
        ({"command": 256}, "command = 256 is out of range 0..255"),
        ({"io": -1}, "io = -1"),
        ({"gripper_current": 40000}, "gripper_current = 40000 is out of range -32768..32767"),
        ({"gripper_mode": True}, "gripper_mode must be an integer, got a bool"),
        ({"gripper_id": None}, "gripper_id must be an integer"),
    ],
)
def test_command_frame_refuses_values_that_do_not_fit_the_wire(kwargs, fragment):
    with pytest.raises(ParolkitValueError, match=fragment):
        CommandFrame(**kwargs)


def test_status_frame_refuses_timing_outside_16_bits():
    with pytest.raises(ParolkitValueError, match="timing = 65536"):
        StatusFrame(timing=65536)


def test_decode_refuses_bad_envelopes_with_the_reason():
    good = StatusFrame().encode()
    with pytest.raises(FrameError, match="expected 60 bytes, got 59"):
        StatusFrame.decode(good[:-1])
    with pytest.raises(FrameError, match="end bytes"):
        StatusFrame.decode(good[:-1] + b"\x03")
    with pytest.raises(FrameError, match="LEN byte is 52"):
        StatusFrame.decode(good[:3] + b"\x34" + good[4:])
    with pytest.raises(FrameError, match="start bytes"):
        StatusFrame.decode(b"\x00" + good[1:])
    with pytest.raises(FrameError, match="CRC byte is 0"):
        StatusFrame.decode(good[:-3] + b"\x00\x01\x02", check_crc=True)
    with pytest.raises(FrameError, match="expected bytes"):
        CommandFrame.decode("not bytes")  # type: ignore[arg-type]


def test_bitfields_are_msb_first():
    assert bits_to_byte([1, 0, 0, 0, 0, 0, 0, 0]) == 0x80
    assert bits_to_byte([0, 0, 0, 0, 0, 0, 0, 1]) == 0x01
    assert byte_to_bits(0x0F) == (False,) * 4 + (True,) * 4
    with pytest.raises(ParolkitValueError, match="8 flags"):
        bits_to_byte([1, 0])
    with pytest.raises(ParolkitValueError, match="bit 2"):
        bits_to_byte([0, 0, 5, 0, 0, 0, 0, 0])
