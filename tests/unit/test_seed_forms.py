"""The seed's forms at every entry point (issue 14): the gripper current range 0..1300 mA and
the signature's explicit ``v=0, a=0, t=0`` meaning "not given", in RBTscript, the UDP protocol and
the client."""

from __future__ import annotations

import pytest

from parolkit.client import robot_api
from parolkit.protocol import commands as C
from parolkit.protocol.commands import DatagramError, parse_datagram
from parolkit.protocol.frames import CommandFrame
from parolkit.script.dryrun import effective_timing
from parolkit.script.parser import parse

STANDBY = "90, -90, 180, 0, 0, 180"


# ---------------------------------------------------------------------------- gripper current


@pytest.mark.parametrize("current", [0, 150, 1000, 1300])
def test_gripper_current_0_to_1300_ma_is_accepted_by_script_udp_and_client(current):
    res = parse(f"Gripper(100, 60, {current})")
    assert not res.errors, res.errors
    assert res.program.commands[0].current_ma == current
    cmd = parse_datagram(f"aaaa0001|ELECTRICGRIPPER|move|100|60|{current}").command
    assert isinstance(cmd, C.ElectricGripper) and cmd.current_ma == current
    wire = robot_api.build_electric_gripper("move", 100, 60, current)
    assert wire == f"ELECTRICGRIPPER|move|100|60|{current}"
    # and the board frame carries it (u16 field)
    assert CommandFrame.decode(CommandFrame(gripper_current=current).encode()).gripper_current == current


@pytest.mark.parametrize("current", [-1, 1301])
def test_gripper_current_outside_0_to_1300_ma_is_refused_everywhere_naming_the_range(current):
    res = parse(f"Gripper(100, 60, {current})")
    assert res.program is None
    assert any("allowed 0 .. 1300 mA" in e.message for e in res.errors), res.errors
    with pytest.raises(DatagramError, match=r"current \(mA\) = .* is out of range 0\.\.1300"):
        parse_datagram(f"aaaa0001|ELECTRICGRIPPER|move|100|60|{current}")
    with pytest.raises(ValueError, match=r"current must be in 0\.\.1300"):
        robot_api.build_electric_gripper("move", 100, 60, current)


# ------------------------------------------------------------------ v=0, a=0, t=0: not given


def test_script_signature_zeros_mean_not_given():
    res = parse(f"MoveJoint({STANDBY}, v=0, a=0, t=0)\nMovePose(0, 262.57, 288.75, -90, 0, -90, v=0, a=0, t=0)\n"
                f"MoveCart(0, 262.57, 280, -90, 0, -90, t=0)\nMoveJoint({STANDBY}, v=30, a=0, t=0)\n"
                f"MoveJoint({STANDBY}, v=0, a=0, t=2)")
    assert not res.errors, res.errors
    moves = [c.move for c in res.program.commands]
    assert [(m.duration_s, m.speed_pct, getattr(m, "accel_pct", None)) for m in moves] == [
        (None, None, None), (None, None, None), (None, None, None), (None, 30.0, None), (2.0, None, None)]
    # resolved like an unwritten option: the language's defaults
    assert effective_timing(res.program.commands[0]) == effective_timing(parse(f"MoveJoint({STANDBY})")
                                                                        .program.commands[0])
    # and no "t= overrides v=" warning for a v=0 next to a t
    assert not [w for w in res.warnings if "overrides" in w.message], res.warnings


def test_script_negative_values_are_still_errors():
    res = parse(f"MoveJoint({STANDBY}, t=-1)")
    assert res.program is None and "t = -1 s is out of range (allowed >0 .. 3600 s)" in res.errors[0].message


@pytest.mark.parametrize("fields,want", [
    ("0|50", (None, 50.0, None)),
    ("2|0", (2.0, None, None)),
    ("0.0|50|0", (None, 50.0, None)),
    ("2|0|0|poly|position", (2.0, None, None)),
    ("None|40|0", (None, 40.0, None)),
])
def test_udp_zero_duration_speed_and_accel_mean_not_given(fields, want):
    cmd = parse_datagram(f"aaaa0001|MOVEJOINT|90|-90|180|0|0|180|{fields}").command
    assert (cmd.move.duration_s, cmd.move.speed_pct, cmd.move.accel_pct) == want
    cart = parse_datagram(f"aaaa0002|MOVECART|0|262|280|-90|0|-90|{fields.split('|', 2)[0]}|"
                          f"{fields.split('|')[1]}").command
    assert (cart.move.duration_s, cart.move.speed_pct) == want[:2]


def test_udp_zeros_in_both_timing_fields_say_neither_was_given():
    with pytest.raises(DatagramError, match=r"neither was given \(0 means not given\)"):
        parse_datagram("aaaa0001|MOVEJOINT|90|-90|180|0|0|180|0|0")


def test_client_zero_duration_speed_and_accel_mean_not_given():
    assert robot_api.build_move_joint([90, -90, 180, 0, 0, 180], duration=0, speed_percentage=50) == \
        robot_api.build_move_joint([90, -90, 180, 0, 0, 180], speed_percentage=50)
    assert robot_api.build_move_joint([90, -90, 180, 0, 0, 180], duration=2, speed_percentage=0,
                                      accel_percentage=0) == robot_api.build_move_joint([90, -90, 180, 0, 0, 180],
                                                                                       duration=2)
    assert robot_api.build_move_joint([90, -90, 180, 0, 0, 180], duration=0, speed_percentage=50).endswith(
        "|None|50")
    assert robot_api.build_move_cart([0, 262, 280, -90, 0, -90], duration=0, speed_percentage=40) == \
        robot_api.build_move_cart([0, 262, 280, -90, 0, -90], speed_percentage=40)
    with pytest.raises(ValueError, match="got neither"):
        robot_api.build_move_pose([0, 262, 280, -90, 0, -90], duration=0, speed_percentage=0)
