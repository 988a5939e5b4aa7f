"""RBTscript parser: typed commands with positions, original spellings, every error at once."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from parolkit.script import (
    Begin,
    Delay,
    End,
    Gripper,
    GripperCalibrate,
    Home,
    Input,
    Loop,
    MoveCart,
    MoveCartRelTRF,
    MoveJoint,
    MovePose,
    Output,
    Profile,
    ProgramError,
    Severity,
    SpeedJoint,
    Tracking,
    load,
    parse,
    parse_file,
)

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples").glob("*.rbt"))


def only(text: str):
    result = parse(text)
    assert result.ok, [e.format() for e in result.errors]
    cmds = [c for c in result.program.commands if not isinstance(c, (Begin, End, Loop))]
    assert len(cmds) == 1
    return cmds[0]


def errors_of(text: str) -> list[tuple[int, int, str]]:
    return [(e.line, e.col, e.message) for e in parse(text).errors]


# ---- the five seed examples -----------------------------------------------------------------


def test_the_five_seed_examples_are_in_examples():
    names = {p.name for p in EXAMPLES}
    assert names == {
        "simple_joint_move.rbt",
        "cartesian_trf.rbt",
        "cartesian_relative_trf.rbt",
        "ssg48_gripper_test.rbt",
        "output_click.rbt",
    }


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_seed_examples_parse_unchanged_without_errors(path):
    result = parse_file(path)
    assert result.ok, [e.format() for e in result.errors]
    program = result.program
    assert isinstance(program.commands[0], Begin)
    assert isinstance(program.commands[-1], (End, Loop))
    assert program.source_name == str(path)
    # one command per non-blank line, in order, with its line number
    lines = [i for i, t in enumerate(path.read_text().split("\n"), 1) if t.strip()]
    assert list(program.lines) == lines


def test_seed_cartesian_example_values_are_exact():
    program = load(REPO / "examples" / "cartesian_trf.rbt")
    move = program.commands[2]
    assert isinstance(move, MoveJoint)
    assert move.move.target_deg == (90.0, -90.0, 180.001, 0.0, 0.0, 180.0)
    assert move.move.duration_s == 4.0 and move.move.profile is None
    assert move.move.tracking is Tracking.POSITION
    cart = program.commands[4]
    assert isinstance(cart, MoveCart)
    assert cart.move.pose == (0.0, 263.23, 161.241, -90.0, 0.0, -89.499)
    assert (cart.line, cart.col) == (5, 1)
    assert cart.text == "MoveCart(0.0,263.23,161.241,-90.0,0.0,-89.499)"


# ---- each command ---------------------------------------------------------------------------


def test_movejoint_seed_forms():
    m = only("MoveJoint(0,-90,180,0,0,180,t=4)").move
    assert m.target_deg[1] == -90 and m.duration_s == 4 and m.speed_pct is None
    m = only("MoveJoint(0,-90,180,0,0,180,v=50,a=50)").move
    assert (m.speed_pct, m.accel_pct, m.duration_s) == (50, 50, None)
    m = only("MoveJoint(0,-90,180,0,0,180)").move
    assert (m.speed_pct, m.accel_pct, m.duration_s, m.profile) == (None, None, None, None)
    m = only("MoveJoint(0,-90,180,0,0,180,speed)").move
    assert m.tracking is Tracking.SPEED


def test_move_profile_words_func_keyword_and_quotes():
    assert only("MoveJoint(0,-90,180,0,0,180,t=2,trap)").move.profile is Profile.TRAP
    assert only('MoveJoint(0,-90,180,0,0,180,t=2,"poly")').move.profile is Profile.POLY
    assert only("MoveJoint(0,-90,180,0,0,180,t=2,func=trap)").move.profile is Profile.TRAP
    assert only("MovePose(0,250,300,-90,0,-90,t=2,ruckig,speed)").move.profile is Profile.RUCKIG
    s = only("MovePose(0, 250, 300, -90, 0, -90, v=20, a=10, trap, speed)")
    assert isinstance(s, MovePose) and s.move.pose == (0, 250, 300, -90, 0, -90)
    m = s.move
    assert (m.speed_pct, m.accel_pct, m.profile, m.tracking) == (20, 10, Profile.TRAP, Tracking.SPEED)


def test_cartesian_moves_take_duration_speed_profile_and_tracking():
    m = only("MoveCart(0,263,161,-90,0,-89.5,t=9,trap)")
    assert isinstance(m, MoveCart) and m.move.duration_s == 9 and m.move.profile is Profile.TRAP
    m = only("MoveCartRelTRF(-80,0,0,0,0,0)")
    assert isinstance(m, MoveCartRelTRF) and m.move.delta == (-80, 0, 0, 0, 0, 0)
    assert m.move.duration_s is None
    m = only("MoveCartRelTRF(0,0,0,0,45,0,v=30,speed)")
    assert m.move.speed_pct == 30 and m.move.tracking is Tracking.SPEED


def test_blend_radius_r_is_the_moves_blend_in_mm_or_deg():
    m = only("MoveCart(0, 250, 200, 180, 0, 0, v=50, r=10)")
    assert isinstance(m, MoveCart) and (m.move.speed_pct, m.move.blend) == (50, 10.0)  # mm
    m = only("MoveJoint(90, -90, 180, 0, 0, 180, r=5)")
    assert isinstance(m, MoveJoint) and m.move.blend == 5.0  # deg
    m = only("MovePose(0, 250, 200, 180, 0, 0, t=2, R=2.5, trap, speed)")  # any order among the options, any case
    assert isinstance(m, MovePose) and (m.move.duration_s, m.move.blend, m.move.profile) == (2, 2.5, Profile.TRAP)
    assert only("MoveJoint(90, -90, 180, 0, 0, 180, r=100)").move.blend == 100.0
    # r=0 is no blending, as on the wire; without r= the move stops at its target
    assert only("MoveCart(0, 250, 200, 180, 0, 0, v=50, r=0)").move.blend is None
    assert only("MoveCart(0, 250, 200, 180, 0, 0, v=50)").move.blend is None
    # the canonical form keeps it (after t=, before the profile word)
    assert only("MovePose(0, 250, 200, 180, 0, 0, trap, r=2.50, t=2)").to_source() == \
        "MovePose(0, 250, 200, 180, 0, 0, t=2, r=2.5, trap)"


@pytest.mark.parametrize("line, col, message", [
    ("MoveCart(0, 250, 200, 180, 0, 0, v=50, r=200)", 42, "r = 200 mm is out of range (allowed 0 .. 100 mm)"),
    ("MoveJoint(90, -90, 180, 0, 0, 180, r=-1)", 38, "r = -1 deg is out of range (allowed 0 .. 100 deg)"),
    ("MovePose(0, 250, 200, 180, 0, 0, r=100.5)", 36, "r = 100.5 deg is out of range (allowed 0 .. 100 deg)"),
    ("MoveJoint(90, -90, 180, 0, 0, 180, r=abc)", 38, "r must be a number, got 'abc'"),
    ("MoveJoint(90, -90, 180, 0, 0, 180, r=nan)", 38, "r must be a number, got 'nan'"),
    ("MoveJoint(90, -90, 180, 0, 0, 180, r=)", 38, "missing value after 'r='"),
    ("MoveCart(0, 250, 200, 180, 0, 0, r=5, v=50, r=6)", 45, "MoveCart: r= is given twice (first at column 34)"),
    ("MoveCartRelTRF(0, 0, 10, 0, 0, 0, r=5)", 35,
     "MoveCartRelTRF has no option r=: allowed t=, v=, a profile (poly, trap, ruckig, toppra) and speed "
     "(MoveCartRelTRF does not blend: r= is for MoveJoint, MovePose and MoveCart)"),
    ("MoveJoint(90, -90, 180, 0, 0, 180, blend)", 36,
     "MoveJoint: unknown option 'blend': expected t=, v=, a=, r=, poly, trap, ruckig, toppra or speed"),
])
def test_a_bad_blend_radius_is_an_error_at_its_line_and_column(line, col, message):
    assert errors_of(f"Begin()\n{line}\nEnd()") == [(2, col, message)]


def test_io_gripper_delay_home_speedjoint():
    assert only("Delay(1.5)") == Delay(seconds=1.5, line=1, col=1)
    o = only("Output(2, LOW)")
    assert isinstance(o, Output) and (o.port, o.state) == (2, False)
    assert only("Output(1,HIGH)").state is True
    assert only("output(1, 1)").state is True
    i = only("Input(2, HIGH, 5)")
    assert isinstance(i, Input) and (i.port, i.state, i.timeout_s) == (2, True, 5.0)
    i = only("Input(1, LOW)")
    assert i.timeout_s is None and i.state is False
    assert only("Input(1, LOW, t=2.5)").timeout_s == 2.5
    g = only("Gripper(120, 30, 500)")
    assert isinstance(g, Gripper) and (g.position, g.speed, g.current_ma) == (120, 30, 500)
    assert isinstance(only("Gripper_cal()"), GripperCalibrate)
    assert isinstance(only("Home()"), Home)
    s = only("SpeedJoint(5, 0, 0, 0, 0, -5, t=2)")
    assert isinstance(s, SpeedJoint) and s.move.speeds_deg_s == (5, 0, 0, 0, 0, -5)
    assert s.move.duration_s == 2


def test_whitespace_comments_blank_lines_and_case_are_allowed():
    text = (
        "\n"
        "  Begin()   # start\n"
        "\n"
        "// a comment line\n"
        "\tmovejoint( 90 , -90 , 180 , 0 , 0 , 180 , T = 3 )  // trailing\n"
        "DELAY(1)#tight comment\n"
        "gripper_CAL()\n"
        "Delay(2)\n"
        "end()\r\n"
    )
    result = parse(text, "demo.rbt")
    assert result.ok, [e.format() for e in result.errors]
    kinds = [type(c).__name__ for c in result.program.commands]
    assert kinds == ["Begin", "MoveJoint", "Delay", "GripperCalibrate", "Delay", "End"]
    move = result.program.commands[1]
    assert (move.line, move.col, move.move.duration_s) == (5, 2, 3.0)


# ---- errors ---------------------------------------------------------------------------------


def test_seed_typo_is_an_error_not_a_different_move():
    text = "Begin()\nMoveCart(81.565,262.804,161.047,-90.135,-0.029,141.983.t=9)\nEnd()\n"
    result = parse(text, "typo.rbt")
    assert result.program is None
    (err,) = result.errors
    assert (err.line, err.col) == (2, 55)
    assert "after the number 141.983" in err.message
    shown = err.format().splitlines()
    assert shown[0].startswith("typo.rbt:2:55: error: unexpected '.'")
    assert shown[1].strip() == "MoveCart(81.565,262.804,161.047,-90.135,-0.029,141.983.t=9)"
    assert shown[2].index("^") == shown[1].index("141.983.") + len("141.983")


def test_all_errors_of_a_file_are_reported_at_once():
    text = "Begin()\nFoo(1)\nMoveJoint(1,2)\nDelay(0)\nOutput(1 HIGH)\nEnd()\n"
    errs = errors_of(text)
    assert [e[0] for e in errs] == [2, 3, 4, 5]
    assert "unknown command 'Foo'" in errs[0][2]
    assert "takes 6 joint values" in errs[1][2]
    assert "Delay = 0 s is out of range" in errs[2][2]
    assert errs[3][1] == 10 and "expected ',' or ')'" in errs[3][2]


def test_unknown_command_suggests_the_closest_name():
    (e,) = errors_of("Begin()\nGriper(1,2,150)\nEnd()")
    assert e[:2] == (2, 1) and "did you mean Gripper?" in e[2]
    (e,) = errors_of("Begin()\nFrobnicate()\nEnd()")
    assert "known: Begin, End, Loop" in e[2]


def test_output_2_is_supported_and_output_3_is_rejected():
    assert only("Output(2,HIGH)").port == 2
    (e,) = errors_of("Output(3,HIGH)")
    assert e[:2] == (1, 8) and "must be 1 or 2" in e[2]


def test_joint_limit_error_names_joint_value_and_range():
    (e,) = errors_of("MoveJoint(130, -90, 180, 0, 0, 180)")
    assert e[:2] == (1, 11)
    assert e[2].startswith("J1 = 130 deg is outside the joint limits (-123.0")


def test_t_overrides_v_and_a_with_a_warning():
    result = parse("MoveJoint(90,-90,180,0,0,180,v=50,a=50,t=3)")
    assert result.ok
    (w,) = [w for w in result.warnings if w.line == 1 and w.col == 40]
    assert w.severity is Severity.WARNING and "t= overrides v= and a=" in w.message


def test_gripper_current_warnings_follow_the_seed():
    assert any("too weak" in w.message for w in parse("Gripper(10, 10, 120)").warnings)
    assert any("dangerous" in w.message for w in parse("Gripper(10, 200, 800)").warnings)
    assert not [w for w in parse("Gripper(10, 60, 500)").warnings if "gripper" in w.message]


def test_structure_warnings_do_not_stop_a_program():
    result = parse("Delay(1)\nGripper_cal()\nGripper(1,2,300)")
    assert result.ok
    msgs = [w.message for w in result.warnings]
    assert any("does not start with Begin()" in m for m in msgs)
    # Gripper_cal() completes when the gripper reports calibrated: no Delay needed after it
    assert not any("Gripper_cal" in m for m in msgs)
    assert any("no End() or Loop()" in m for m in msgs)


def test_huge_numbers_are_an_error_not_infinity():
    (e,) = errors_of("Delay(1e999)")
    assert "too large" in e[2]


@pytest.mark.parametrize("line, col, what, char", [
    ("MoveJoint(٨٠, -90, 180, 0, 0, 180)", 11, "J1", "U+0668 ARABIC-INDIC DIGIT EIGHT"),
    ("MoveJoint(８０, -90, 180, 0, 0, 180)", 11, "J1", "U+FF18 FULLWIDTH DIGIT EIGHT"),
    ("MoveJoint(𝟖𝟎, -90, 180, 0, 0, 180)", 11, "J1", "U+1D7D6 MATHEMATICAL BOLD DIGIT EIGHT"),
    ("MoveJoint(80, -90, 180, 0, 0, 180, v=٥٠)", 38, "v", "U+0665 ARABIC-INDIC DIGIT FIVE"),
    ("Output(١, HIGH)", 8, "output number", "U+0661 ARABIC-INDIC DIGIT ONE"),
    ("Gripper(200, 100, ４００)", 19, "gripper current", "U+FF14 FULLWIDTH DIGIT FOUR"),
])
def test_look_alike_digits_are_refused_naming_the_argument_and_the_character(line, col, what, char):
    # float() reads all of these as plain numbers (float("٨٠") == 80.0): the program moved the arm
    (err,) = errors_of(line)
    assert err[:2] == (1, col)
    assert err[2].startswith(f"{what} must be a decimal number, got ")
    assert f"({char}) is not ASCII" in err[2]


@pytest.mark.parametrize("line, col, char", [
    ("Delay(\x001)", 7, "U+0000"),
    ("MoveJoint(80\x00, -90, 180, 0, 0, 180)", 13, "U+0000"),
    ("Delay(\u00a01)", 7, "U+00A0 NO-BREAK SPACE"),
    ("Delay(1)\x0b", 9, "U+000B"),
])
def test_control_characters_and_foreign_spaces_are_refused_naming_the_character(line, col, char):
    (err,) = errors_of(line)
    assert err[:2] == (1, col)
    assert f"({char})" in err[2]


def test_unwrap_raises_program_error_with_every_error():
    result = parse("Foo()\nBar()")
    with pytest.raises(ProgramError) as info:
        result.unwrap()
    assert len(info.value.errors) == 2
    assert "2 errors" in str(info.value)


def test_unreadable_and_non_utf8_files_are_reported(tmp_path):
    missing = parse_file(tmp_path / "nope.rbt")
    assert not missing.ok and "cannot read" in missing.errors[0].message
    bad = tmp_path / "bad.rbt"
    bad.write_bytes(b"Begin()\nDelay(\xff)\n")
    result = parse_file(bad)
    assert not result.ok and result.errors[0].line == 2 and "not UTF-8" in result.errors[0].message


# ---- random text never crashes the parser ---------------------------------------------------

_ALPHABET = st.sampled_from(
    list("()=,.#/-+ \t\n\r\"'0123456789eE;xX_")
    + ["MoveJoint", "MoveCart", "Delay", "Output", "HIGH", "t=", "v=", "r=", "Begin()", "End()", "Loop()", "//"]
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(st.text(max_size=200), st.lists(_ALPHABET, max_size=60).map("".join)))
def test_random_text_gives_a_program_or_errors_never_an_exception(text):
    result = parse(text, "fuzz.rbt")
    assert (result.program is None) == bool(result.errors)
    n_lines = text.count("\n") + 1
    for d in result.errors + result.warnings:
        assert 1 <= d.line <= n_lines
        assert d.col >= 1
        assert d.message
        d.format()
    if result.program is not None:
        for cmd in result.program.commands:
            assert cmd.line >= 1 and cmd.col >= 1
