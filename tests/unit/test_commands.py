"""The controller's text-command parser: every command, the ID rules, precise INVALID texts."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from parolkit import moves
from parolkit.protocol import commands as C
from parolkit.protocol.commands import AckStatus, DatagramError, parse_datagram


def parse(text):
    return parse_datagram(text)


VALID = [
    ("MOVEJOINT|90|-90|160|12|12|180|5.5|None", C.MoveJoint),
    ("MOVEJOINT|90|-90|160|12|12|180|None|50|30|trap|speed", C.MoveJoint),
    ("MOVEPOSE|7|250|200|-100|0|-90|5.5|None", C.MovePose),
    ("MOVECART|7|250|150|-100|0|-90|None|50", C.MoveCart),
    ("MOVECARTRELTRF|0|0|-10|0|0|0|1|None|poly|position", C.MoveCartRelTRF),
    ("MOVECART|0|250|200|180|0|0|None|50|r=10", C.MoveCart),
    ("MOVEJOINT|90|-90|180|0|0|180|None|50|r=5", C.MoveJoint),
    ("MOVEPOSE|0|250|200|180|0|0|2|None|30|trap|speed|r=5", C.MovePose),
    ("JOG|7|50|1|None", C.Jog),
    ("JOG|0|50|None|10", C.Jog),
    ("MULTIJOG|0,7,2|50,40,30|1.5", C.MultiJog),
    ("CARTJOG|TRF|RZ-|20|0.5", C.CartJogCommand),
    ("HOME", C.Home),
    ("DELAY|0.2", C.Delay),
    ("PNEUMATICGRIPPER|open|1", C.PneumaticGripper),
    ("ELECTRICGRIPPER|move|100|150|200", C.ElectricGripper),
    ("ELECTRICGRIPPER|calibrate", C.ElectricGripper),
    ("ELECTRICGRIPPER|None|10|20|300", C.ElectricGripper),
    ("SPEEDJOINT|5|0|0|0|0|-5|2", C.SpeedJoint),
    ("WAIT_INPUT|1|1|None", C.WaitInput),
    ("SMOOTH_CIRCLE|0,250,150|20|XY|WRF|CURRENT|DURATION|3|0", C.SmoothCircle),
    ("SMOOTH_ARC_CENTER|10,250,150,-90,0,-90|0,250,150|WRF|NONE|SPEED|40|1", C.SmoothArcCenter),
    ("SMOOTH_ARC_PARAM|10,250,150,-90,0,-90|30|90|TRF|CURRENT|DURATION|2|0", C.SmoothArcParam),
    ("SMOOTH_SPLINE|2|WRF|CURRENT|DURATION|3|0,250,150,-90,0,-90|10,260,150,-90,0,-90", C.SmoothSpline),
    ("SMOOTH_HELIX|0,250,150|20|5|15|WRF|CURRENT|DURATION|4|1", C.SmoothHelix),
    ("SMOOTH_BLEND|2|0.5|WRF|CURRENT|DURATION|None|LINE|0,250,150,-90,0,-90|1||"
     "ARC|10,250,150,-90,0,-90|5,250,150|1|0", C.SmoothBlend),
    ("MOVEJOINTPATH|2|1.5|95|-90|170|0|0|180|3|100|-85|160|5|5|170", C.MoveJointPath),
    ("MOVEJOINTPATH|2|1.5|95|-90|170|0|0|180|0|0|-3|0|0|3|4|100|-85|160|5|5|170|0|0|0|0|0|0", C.MoveJointPath),
    ("STOP", C.Stop),
    ("ENABLE", C.Enable),
    ("DISABLE", C.Disable),
    ("CLEAR_ERROR", C.ClearError),
    ("ESTOP", C.EStop),
    ("STREAM|ON", C.StreamMode),
    ("SET_PORT|/dev/ttyACM0", C.SetPort),
    ("SET_TOOL|flange", C.SetTool),
    ("SUBSCRIBE|6000|5", C.Subscribe),
    ("UNSUBSCRIBE|6000", C.Unsubscribe),
    ("ATTACH|ball|SPHERE|0,0,170|25", C.Attach),
    ("ATTACH|rod|capsule|0,30,10|0,30,170|8", C.Attach),
    ("DETACH|ball", C.Detach),
    ("DETACH", C.Detach),
]


@pytest.mark.parametrize("text,cls", VALID, ids=[v[0].split("|")[0] + str(i) for i, v in enumerate(VALID)])
def test_every_command_of_the_table_parses_to_its_typed_object(text, cls):
    p = parse(text)
    assert isinstance(p.command, cls)
    assert p.command_id is None


@pytest.mark.parametrize("name", C.QUERY_NAMES)
def test_every_query_parses_and_is_answered_immediately(name):
    p = parse(name.lower())
    assert p.kind is C.CommandKind.QUERY and p.command.name == name


def test_movejoint_fields_keep_edge_units_and_extensions():
    p = parse("1a2b3c4d|movejoint|90|-90|160|12|12|180|None|50|30|trap|speed")
    c = p.command
    assert p.command_id == "1a2b3c4d"
    m = c.move
    assert isinstance(m, moves.JointMove)
    assert m.target_deg == (90, -90, 160, 12, 12, 180)
    assert (m.duration_s, m.speed_pct, m.accel_pct) == (None, 50, 30)
    assert m.profile is moves.Profile.TRAP and m.tracking is moves.Tracking.SPEED


def test_movejointpath_carries_points_times_and_velocities_in_edge_units():
    m = parse("1a2b3c4d|movejointpath|2|1.5|95|-90|170|0|0|180|0|0|-3|0|0|3|"
              "4|100|-85|160|5|5|170|0|0|0|0|0|0").command.move
    assert isinstance(m, moves.JointPathMove)
    assert m.points_deg == ((95, -90, 170, 0, 0, 180), (100, -85, 160, 5, 5, 170))
    assert m.times_s == (1.5, 4.0)
    assert m.velocities_deg_s == ((0, 0, -3, 0, 0, 3), (0,) * 6)
    assert parse("MOVEJOINTPATH|1|2|95|-90|170|0|0|180").command.move.velocities_deg_s is None


def test_a_movejointpath_of_200_points_with_velocities_fits_in_one_datagram():
    fields = ["MOVEJOINTPATH", "200"]
    for k in range(200):
        angles = [90.123456789012345, -90.12345678901234, 170.12345678901234, 0.123456789012345678,
                  -0.123456789012345678, 170.12345678901234]
        fields += [repr(0.01 * (k + 1) + 1e-13), *[repr(a - 1e-3 * k) for a in angles],
                   *([repr(-12.345678901234567)] * 6 if k < 199 else ["0"] * 6)]
    text = "|".join(fields)
    assert len(text) <= C.MAX_DATAGRAM_BYTES
    assert len(parse(text).command.move.points_deg) == 200


def test_jog_index_rule_maps_6_to_11_to_negative_directions():
    assert parse("JOG|7|50|1|None").command.move.joints == (1,)
    assert parse("JOG|7|50|1|None").command.move.directions == (-1,)
    assert parse("JOG|5|50|1|None").command.move.directions == (1,)
    assert parse("JOG|7|50|1|None").command.move.wire_indices == (7,)


def test_blend_segments_are_split_on_empty_fields():
    c = parse(next(t for t, cls in VALID if cls is C.SmoothBlend)).command
    assert [type(s) for s in c.move.segments] == [moves.LineSegment, moves.ArcCenterMove]
    assert c.move.duration_s == pytest.approx(2.0)  # None = sum of segment durations
    assert c.move.speed_pct is None and c.move.frame is moves.Frame.WRF


def test_every_motion_command_carries_the_move_the_planner_gets():
    """The executor plans ``command.move`` as it is: no field-by-field conversion."""
    expected = {
        C.MoveJoint: moves.JointMove, C.MoveJointPath: moves.JointPathMove, C.MovePose: moves.PoseMove,
        C.MoveCart: moves.CartMove,
        C.MoveCartRelTRF: moves.CartRelTRFMove, C.Jog: moves.JointJog, C.MultiJog: moves.JointJog,
        C.CartJogCommand: moves.CartJog, C.SpeedJoint: moves.SpeedJointMove,
        C.SmoothCircle: moves.CircleMove, C.SmoothArcCenter: moves.ArcCenterMove,
        C.SmoothArcParam: moves.ArcParamMove, C.SmoothSpline: moves.SplineMove,
        C.SmoothHelix: moves.HelixMove, C.SmoothBlend: moves.BlendMove,
    }
    seen = set()
    for text, cls in VALID:
        cmd = parse(text).command
        if cls in expected:
            assert cmd.is_motion and isinstance(cmd.move, expected[cls]), text
            seen.add(cls)
    assert seen == set(expected)


def test_smooth_timing_becomes_the_moves_duration_or_speed():
    circle = parse("SMOOTH_CIRCLE|0,250,150|20|XZ|TRF|CURRENT|DURATION|3|1").command.move
    assert (circle.duration_s, circle.speed_pct) == (3.0, None)
    assert circle.plane is moves.Plane.XZ and circle.frame is moves.Frame.TRF and circle.clockwise
    arc = parse("SMOOTH_ARC_CENTER|10,250,150,-90,0,-90|0,250,150|WRF|NONE|SPEED|40|1").command.move
    assert (arc.duration_s, arc.speed_pct, arc.start_pose) == (None, 40.0, None)


def test_cartjog_carries_the_canonical_axis_and_frame():
    jog = parse("CARTJOG|trf|rz-|20|0.5").command.move
    assert jog.frame is moves.Frame.TRF and jog.axis is moves.CartAxis.RZ_NEG
    assert (jog.speed_pct, jog.duration_s) == (20.0, 0.5)


def test_an_id_is_8_chars_not_all_upper_case():
    assert C.is_command_id("1a2b3c4d")
    assert C.is_command_id("12345678")
    assert not C.is_command_id("MOVEPOSE")
    assert not C.is_command_id("1a2b3c4")
    assert not C.is_command_id("1a2b_c4d")
    # an upper-case 8-letter name is the command, not an ID
    assert isinstance(parse("MOVEPOSE|7|250|200|-100|0|-90|5.5|None").command, C.MovePose)


INVALID = [
    ("MOVEJOINT|190|-90|160|12|12|180|1|None", "J1 angle = 190 deg is out of range"),
    ("MOVEJOINT|90|-90|160|12|12|180|None|None", "neither was given"),
    ("MOVEJOINT|90|-90|160|12|12|180|1|50", "both were given"),
    ("MOVEJOINT|90|-90|160|12|12|180|-1|None", "duration = -1 s is out of range [1e-09, 3600] s"),
    ("MOVEJOINT|90|-90|160|12|12|180|0|None", "neither was given (0 means not given)"),
    ("MOVEJOINT|90|-90|nan|12|12|180|1|None", "J3 angle (deg) must be a decimal number"),
    ("MOVEJOINT|90|-90|inf|12|12|180|1|None", "must be a decimal number"),
    ("MOVEJOINT|90|-90|160|12|12|1|None", "MOVEJOINT takes 8..11 arguments, got 7"),
    ("MOVEJOINT|90|-90|160|12|12|180|1|None|50|cubic", "profile must be one of poly|trap|ruckig|toppra"),
    ("MOVEJOINTPATH", "MOVEJOINTPATH takes n|time|j1..j6[|v1..v6]|... (n = 1..200 points), got no arguments"),
    ("MOVEJOINTPATH|0", "MOVEJOINTPATH: n (points) = 0 is out of range 1..200"),
    ("MOVEJOINTPATH|201", "n (points) = 201 is out of range 1..200"),
    ("MOVEJOINTPATH|two|1|90|-90|180|0|0|180", "n (points) must be an integer in 1..200, got 'two'"),
    ("MOVEJOINTPATH|2|1|90|-90|180|0|0|180",
     "n = 2 points announced, 7 fields given (expected 14: time|j1..j6 per point, or 26: time|j1..j6|v1..v6"),
    ("MOVEJOINTPATH|1|0|90|-90|180|0|0|180", "point 0 time (s) = 0 s is out of range [1e-09, 3600] s"),
    ("MOVEJOINTPATH|1|4000|90|-90|180|0|0|180", "point 0 time (s) = 4000 s is out of range [1e-09, 3600] s"),
    ("MOVEJOINTPATH|2|1|90|-90|180|0|0|180|2|90|-90|180|0|x|180", "point 1 J5 angle (deg) must be a decimal number"),
    ("MOVEJOINTPATH|2|1|90|-90|180|0|0|180|2|190|-90|180|0|0|180",
     "point 1 J1 angle = 190 deg is out of range [-123.0469, 123.0469] deg"),
    ("MOVEJOINTPATH|1|1|90|-90|180|0|0|180|0|0|0|0|999|0",
     "point 0 J5 velocity (deg/s) = 999 deg/s is out of range [-309.375, 309.375] deg/s"),
    ("MOVEJOINTPATH|2|2|90|-90|180|0|0|180|1|95|-90|180|0|0|180",
     "MOVEJOINTPATH: times_s[1] = 1 s must be greater than times_s[0] = 2 s (times strictly increasing)"),
    ("MOVEJOINTPATH|1|1|90|-90|180|0|0|180|0|0|0|0|0|1",
     "MOVEJOINTPATH: velocities_deg_s[0][5] must be 0 deg/s (the path ends at rest on its last point), got 1.0"),
    ("MOVEPOSE|7|250|200|-100|0|-90|None|150", "speed% = 150 % is out of range (0, 100] %"),
    ("MOVECART|20000|250|200|-100|0|-90|1|None", "x = 20000 mm is out of range"),
    ("MOVECART|0|250|200|180|0|0|None|50|r=abc",
     "MOVECART: r (blend radius, 0..100 mm) must be a decimal number, got 'abc'"),
    ("MOVECART|0|250|200|180|0|0|None|50|r=-1", "MOVECART: r (blend radius) = -1 mm is out of range [0, 100] mm"),
    ("MOVECART|0|250|200|180|0|0|None|50|r=200", "r (blend radius) = 200 mm is out of range [0, 100] mm"),
    ("MOVECART|0|250|200|180|0|0|None|50|r=", "r= (blend radius) needs a number in 0..100 mm, got nothing"),
    ("MOVECART|0|250|200|180|0|0|None|50|r= ", "r= (blend radius) needs a number in 0..100 mm, got nothing"),
    ("MOVECART|0|250|200|180|0|0|None|50|r=nan", "r (blend radius, 0..100 mm) must be a decimal number, got 'nan'"),
    ("MOVECART|0|250|200|180|0|0|None|50|r=inf", "r (blend radius, 0..100 mm) must be a decimal number, got 'inf'"),
    ("MOVEJOINT|90|-90|180|0|0|180|None|50|r=100.5",
     "MOVEJOINT: r (blend radius) = 100.5 deg is out of range [0, 100] deg"),
    ("MOVEPOSE|0|250|200|180|0|0|None|50|r=-0.1", "MOVEPOSE: r (blend radius) = -0.1 deg is out of range [0, 100] deg"),
    ("MOVECART|0|250|200|180|0|0|None|r=5|50", "r= (blend radius) must be the last field, but it is field 8 of 9"),
    ("MOVEJOINT|90|-90|180|0|0|180|None|50|r=5|trap",
     "r= (blend radius) must be the last field, but it is field 9 of 10"),
    ("MOVECART|0|250|200|180|0|0|None|50|r=5|r=6", "r= (blend radius) is given 2 times (fields 9 and 10)"),
    ("MOVEJOINT|90|-90|180|0|0|180|None|50|30|trap|speed|x|r=5", "MOVEJOINT takes 8..11 arguments before r=, got 12"),
    ("MOVECART|0|250|200|180|0|0|r=5", "MOVECART takes 8..10 arguments before r=, got 6"),
    ("MOVECARTRELTRF|0|0|10|0|0|0|None|50|r=5", "MOVECARTRELTRF takes no r= (blend radius): only MOVEJOINT, MOVEPOSE"),
    ("JOG|12|50|1|None", "joint_index = 12 is out of range 0..11"),
    ("JOG|1|50|None|None", "neither was given"),
    ("MULTIJOG|0,6|50,50|1", "J1 is given both + and -"),
    ("MULTIJOG|0,1|50|1", "speeds must have one value per joint index (2), got 1"),
    ("SMOOTH_ARC_PARAM|10,250,150,-90,0,-90|30|-90|WRF|CURRENT|DURATION|2|0",
     "angle (deg) = -90 deg is out of range (0, 360) deg"),
    ("SMOOTH_HELIX|0,250,150|20|1|500|WRF|CURRENT|DURATION|4|1",
     "SMOOTH_HELIX: height_mm / pitch_mm must be at most 100 turns, got 500"),
    ("CARTJOG|WRF|Q+|50|1", "axis must be one of"),
    ("CARTJOG|BASE|X+|50|1", "frame must be one of WRF|TRF"),
    ("PNEUMATICGRIPPER|open|3", "port = 3 is out of range 1..2"),
    ("ELECTRICGRIPPER|move|100|150|1301", "current (mA) = 1301 is out of range 0..1300"),
    ("ELECTRICGRIPPER|move|100|150|-1", "current (mA) = -1 is out of range 0..1300"),
    ("ELECTRICGRIPPER|squeeze|100|150|200", "action must be move|calibrate|clear_error|None"),
    ("SPEEDJOINT|500|0|0|0|0|0|1", "J1 speed (deg/s) = 500 deg/s is out of range"),
    ("SMOOTH_CIRCLE|0,250|20|XY|WRF|CURRENT|DURATION|3|0", "center must be 3 comma-separated numbers, got 2"),
    ("SMOOTH_CIRCLE|0,250,150|20|XW|WRF|CURRENT|DURATION|3|0", "plane must be one of XY|XZ|YZ"),
    ("SMOOTH_SPLINE|3|WRF|CURRENT|DURATION|3|0,250,150,-90,0,-90|10,260,150,-90,0,-90",
     "n = 3 waypoints announced, 2 fields given (expected 3 poses x,y,z,A,B,C or 18 single numbers)"),
    ("SMOOTH_BLEND|3|0.5|WRF|CURRENT|DURATION|None|LINE|0,250,150,-90,0,-90|1", "3 segments announced, 1 given"),
    ("DELAY|-1", "seconds = -1 s is out of range [0, 3600] s"),
    ("STREAM|MAYBE", "STREAM takes ON|OFF"),
    ("SUBSCRIBE|70000", "port = 70000 is out of range 1..65535"),
    ("GET_ANGLES|1", "GET_ANGLES takes no arguments, got 1"),
    ("FROBNICATE|1", "unknown command 'FROBNICATE'"),
    ("", "empty datagram"),
    ("ATTACH|ball|SPHERE|0,0,170|0", "ATTACH: radius = 0 mm is out of range (0, 500] mm"),
    ("ATTACH|ball|SPHERE|0,0,170|501", "ATTACH: radius = 501 mm is out of range (0, 500] mm"),
    ("ATTACH|ball|SPHERE|0,1200,170|5", "ATTACH: center: y = 1200 mm is out of range [-1000, 1000] mm"),
    ("ATTACH|ball|SPHERE|0,170|5", "ATTACH: center must be 3 comma-separated numbers, got 2"),
    ("ATTACH|ball|SPHERE|0,nan,170|5", "ATTACH: center[1] must be a decimal number, got 'nan'"),
    ("ATTACH|rod|CAPSULE|0,0,0|0,0,-1001|5", "ATTACH: end: z = -1001 mm is out of range [-1000, 1000] mm"),
    ("ATTACH|rod|CAPSULE|-1000,0,0|1000,0,1000|5",
     "ATTACH: the capsule's length (start to end) = 2236.07 mm is out of range [0, 2000] mm"),
    ("ATTACH|box|BOX|0,0,0|5", "ATTACH: shape must be one of SPHERE|CAPSULE, got 'BOX'"),
    ("ATTACH|ball|SPHERE|0,0,170", "ATTACH: a SPHERE takes NAME|SPHERE|x,y,z|radius (4 fields), got 3"),
    ("ATTACH|rod|CAPSULE|0,0,0|5", "ATTACH: a CAPSULE takes NAME|CAPSULE|x1,y1,z1|x2,y2,z2|radius (5 fields), got 4"),
    ("ATTACH|ball", "ATTACH takes NAME|SPHERE|x,y,z|radius or NAME|CAPSULE|x1,y1,z1|x2,y2,z2|radius, got 1 field"),
    ("ATTACH|_ball|SPHERE|0,0,170|5", "ATTACH: object name must be 1..64 characters: letters, digits, spaces"),
    ("ATTACH|" + "b" * 65 + "|SPHERE|0,0,170|5", "ATTACH: object name must be 1..64 characters"),
    ("DETACH|a|b", "DETACH takes 0..1 arguments, got 2"),
    ("DETACH|#1", "DETACH: object name must be 1..64 characters"),
    ("GET_ZONES|1", "GET_ZONES takes no arguments, got 1"),
]


@pytest.mark.parametrize("text,needle", INVALID, ids=[f"invalid{i}" for i in range(len(INVALID))])
def test_invalid_datagrams_name_the_field_and_the_allowed_range(text, needle):
    with pytest.raises(DatagramError) as ei:
        parse(text)
    assert needle in str(ei.value)


def test_the_blend_radius_is_the_moves_blend_in_edge_units_and_0_means_none():
    assert parse("MOVECART|0|250|200|180|0|0|None|50|r=10").command.move.blend == 10.0  # mm
    m = parse("MOVEJOINT|90|-90|180|0|0|180|None|50|30|trap|speed|r=5").command.move
    assert (m.speed_pct, m.accel_pct, m.profile, m.tracking, m.blend) == (
        50, 30, moves.Profile.TRAP, moves.Tracking.SPEED, 5.0)  # deg, after every extension field
    assert parse("MOVEPOSE|0|250|200|180|0|0|2|None|r=100").command.move.blend == 100.0
    assert parse("movecart|0|250|200|180|0|0|None|50|R = 2.5|").command.move.blend == 2.5  # any case, trailing |
    for zero in ("r=0", "r=0.0", "r=-0"):
        assert parse(f"MOVECART|0|250|200|180|0|0|None|50|{zero}").command.move.blend is None
    # without r= nothing changes: the same command as before
    plain = parse("MOVECART|0|250|200|180|0|0|None|50").command
    assert plain.move.blend is None and parse("MOVECART|0|250|200|180|0|0|None|50|r=0").command == plain


def test_a_bad_blend_radius_with_an_id_carries_the_id_for_the_ack():
    with pytest.raises(DatagramError) as ei:
        parse("abcd1234|MOVECART|0|250|200|180|0|0|None|50|r=200")
    assert (ei.value.command_id, ei.value.name) == ("abcd1234", "MOVECART")


def test_invalid_datagram_with_an_id_carries_the_id_for_the_ack():
    with pytest.raises(DatagramError) as ei:
        parse("abcd1234|MOVEJOINT|190|-90|160|12|12|180|1|None")
    assert ei.value.command_id == "abcd1234"
    assert ei.value.name == "MOVEJOINT"


def test_non_utf8_and_oversized_datagrams_are_refused():
    with pytest.raises(DatagramError, match="not ASCII text"):
        parse_datagram(b"\xff\xfeMOVE")
    with pytest.raises(DatagramError, match="at most 65000"):
        parse_datagram(b"A" * 65_001)


def test_ack_format_keeps_the_separator_out_of_details():
    assert C.format_ack("1a2b3c4d", AckStatus.FAILED, "a|b\nc") == "ACK|1a2b3c4d|FAILED|a/b c"
    assert AckStatus.CANCELLED.terminal and not AckStatus.EXECUTING.terminal


def test_format_floats_prints_no_negative_zero():
    assert C.format_floats([-0.00001, 1.23456], 4) == "0.0000,1.2346"


_fields = st.sampled_from(list(C.COMMAND_NAMES) + ["1a2b3c4d", "None", "", "nan", "1e999", "-5", "0,1,2",
                                                  "r=5", "r=", "R=1e999", "r=nan"])


@settings(max_examples=150, deadline=None)
@given(st.lists(st.one_of(_fields, st.text(max_size=12)), min_size=0, max_size=14))
def test_no_datagram_makes_the_parser_raise_anything_but_command_error(parts):
    try:
        parse_datagram("|".join(parts))
    except DatagramError:
        pass


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=200))
def test_random_bytes_never_crash_the_parser(data):
    try:
        parse_datagram(data)
    except DatagramError:
        pass


def test_spline_waypoints_may_also_come_as_six_separate_fields_each():
    from parolkit.protocol.commands import parse_datagram

    joined = parse_datagram("SMOOTH_SPLINE|2|WRF|CURRENT|DURATION|3|10,250,200,-90,0,-90|20,240,210,-90,0,-90")
    split = parse_datagram("SMOOTH_SPLINE|2|WRF|CURRENT|DURATION|3|10|250|200|-90|0|-90|20|240|210|-90|0|-90")
    assert joined.command == split.command


def test_spline_with_the_wrong_number_of_waypoint_fields_names_both_forms():
    import pytest

    from parolkit.protocol.commands import DatagramError, parse_datagram

    with pytest.raises(DatagramError, match="2 waypoints announced, 3 fields given"):
        parse_datagram("SMOOTH_SPLINE|2|WRF|CURRENT|DURATION|3|1,2,3,4,5,6|1,2,3,4,5,6|1,2,3,4,5,6")


def test_the_original_clients_blend_forms_parse_like_ours():
    """SMOOTH_BLEND as the original client sent it: ``DEFAULT`` timing without a value field
    and SPLINE segments as ``n|x,y,z,A,B,C;x,y,...|duration``, lower-case frame."""
    a, b, c = "0,250,200,-90,0,-90", "10,250,200,-90,0,-90", "20,260,200,-90,0,-90"
    original = parse(f"SMOOTH_BLEND|2|0.5|wrf|CURRENT|DEFAULT|LINE|{a}|2.0||SPLINE|2|{b};{c}|3.0").command
    ours = parse(f"SMOOTH_BLEND|2|0.5|WRF|CURRENT|DURATION|None|LINE|{a}|2.0||SPLINE|3.0|{b}|{c}").command
    assert original == ours
    assert original.move.duration_s == pytest.approx(5.0)  # DEFAULT: the segments' own durations
    timed = parse(f"SMOOTH_BLEND|1|0.5|WRF|CURRENT|SPEED|40|SPLINE|2|{b};{c}|3").command.move
    assert timed.speed_pct == 40.0 and timed.segments[0].waypoints == (
        (10, 250, 200, -90, 0, -90), (20, 260, 200, -90, 0, -90))


@pytest.mark.parametrize("text,needle", [
    ("SMOOTH_BLEND|1|0.5|WRF|CURRENT|DEFAULT|SPLINE|3|0,250,200,-90,0,-90;1,250,200,-90,0,-90|3",
     "segment 1 SPLINE: n = 3 waypoints announced, 2 given (separated by ';')"),
    ("SMOOTH_BLEND|1|0.5|WRF|CURRENT|DEFAULT|SPLINE|1|0,250,200,-90,0,-90|3",
     "segment 1 SPLINE n (waypoints) = 1 is out of range 2..500"),
    ("SMOOTH_BLEND|1|0.5|WRF|CURRENT|FAST|LINE|0,250,200,-90,0,-90|3",
     "timing must be one of DURATION|SPEED|DEFAULT, got 'FAST'"),
    ("SMOOTH_BLEND|1|0.5|WRF|CURRENT|DEFAULT", "or DEFAULT timing without a value"),
])
def test_the_original_blend_forms_are_checked_as_precisely_as_ours(text, needle):
    with pytest.raises(C.DatagramError) as info:
        parse(text)
    assert needle in str(info.value)


@pytest.mark.parametrize("original,ours", [
    ("MOVECART|0|250|200|-90|0|-90|NONE|50.0", "MOVECART|0|250|200|-90|0|-90|None|50"),
    ("CARTJOG|wrf|x+|50|1.0", "CARTJOG|WRF|X+|50|1"),
    ("SMOOTH_CIRCLE|0,250,200|20|xy|trf|CURRENT|DURATION|4.0|0",
     "SMOOTH_CIRCLE|0,250,200|20|XY|TRF|CURRENT|DURATION|4|0"),
    ("SMOOTH_SPLINE|2|wrf|CURRENT|SPEED|40|0|250|200|-90|0|-90|10|250|200|-90|0|-90",
     "SMOOTH_SPLINE|2|WRF|CURRENT|SPEED|40|0,250,200,-90,0,-90|10,250,200,-90,0,-90"),
    ("PNEUMATICGRIPPER|Open|1", "PNEUMATICGRIPPER|open|1"),
])
def test_the_original_clients_wire_forms_mean_the_same_as_ours(original, ours):
    assert parse(original).command == parse(ours).command


def test_ack_details_name_the_command_and_carry_the_warnings():
    from parolkit.controller.jobs import Job

    job = Job(1, parse("MOVEJOINT|90|-90|180|0|0|180|1|None").command, "abcd1234", None)
    assert job.ack_details(C.AckStatus.COMPLETED, "") == "MoveJoint finished successfully"
    assert job.ack_details(C.AckStatus.COMPLETED, "stopped at the upper limit") == "stopped at the upper limit"
    assert job.ack_details(C.AckStatus.FAILED, "no") == "no"
    job.notes = ("duration stretched", "warning: J5 acceleration 41000 steps/s^2 over its limit")
    assert job.ack_details(C.AckStatus.COMPLETED, "") == (
        "MoveJoint finished successfully; warning: J5 acceleration 41000 steps/s^2 over its limit")
    assert job.ack_details(C.AckStatus.EXECUTING, "") == job.warnings[0]
    assert job.ack_details(C.AckStatus.CANCELLED, "STOP received") == "STOP received"
    jog = Job(2, parse("CARTJOG|WRF|X+|50|1").command, "abcd1234", None)
    assert jog.ack_details(C.AckStatus.COMPLETED, "") == "CartJog finished successfully"


def test_attach_and_detach_carry_the_shape_in_flange_frame_mm_and_queue_in_order_with_moves():
    a = parse("ATTACH| rod |Capsule|0,30,10|0,30,170|8").command
    assert a == C.Attach("rod", "capsule", (0.0, 30.0, 10.0), (0.0, 30.0, 170.0), 8.0)
    s = parse("ATTACH|ball|sphere|1,2,3|4.5").command
    assert (s.shape, s.start_mm, s.end_mm, s.radius_mm) == ("sphere", (1.0, 2.0, 3.0), (1.0, 2.0, 3.0), 4.5)
    assert parse("DETACH").command == C.Detach(None) and parse("detach|ball").command == C.Detach("ball")
    for cmd in (a, s, C.Detach(None)):
        # queued (in order with the moves), not motion, only for the lease holder, checked by nothing
        assert cmd.KIND is C.CommandKind.QUEUED and cmd.EXECUTION is C.Execution.HELD
        assert not cmd.is_motion and not cmd.OPEN and cmd.COLLISION is C.CollisionCheck.NONE


def test_every_command_that_moves_declares_how_its_motion_is_checked_for_collisions():
    """Planned moves are checked whole before they run; jogs and servo streams every tick;
    HOME (the board homes by itself) and what moves nothing are not."""
    classes = [c for c in vars(C).values() if isinstance(c, type) and issubclass(c, C.Command) and c.NAME]
    for cls in classes:
        want = (C.CollisionCheck.TICK if cls.STREAMABLE or cls.EXECUTION is C.Execution.SPEED
                or cls in (C.ServoJ, C.ServoL)
                else C.CollisionCheck.PLAN if cls.EXECUTION is C.Execution.PLANNED else C.CollisionCheck.NONE)
        assert cls.COLLISION is want, cls.__name__
