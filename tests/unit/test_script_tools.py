"""RBTscript formatter, dry run (per-line table, loops, Home, defaults, plot) and the
``parolkit check`` / ``fmt`` / ``run --dry-run`` commands (no robot needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from parolkit.cli import main
from parolkit.motion.cartesian import DEFAULT_CART_SPEED_PCT
from parolkit.script import ProgramError, load, parse
from parolkit.script.dryrun import dry_run, effective_timing
from parolkit.script.formatter import format_program

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples").glob("*.rbt"))
STANDBY = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)


# ---- formatter ------------------------------------------------------------------------------


def test_formatter_writes_the_canonical_form_and_keeps_comments():
    text = (
        "\n\n  begin()  # start here\n"
        "\n\n\n"
        "// move\n"
        "MOVEJOINT(90.0,-90.0,180.001,0.0,0.0,180.0,  T=4 , func=TRAP,speed)\n"
        "movecart(0,250.0,200,180,0,0, R=10.0,v=50)\n"
        "output(2,1)\n"
        "Input( 1 , low , 2.50 )\n"
        "gripper_CAL()\n"
        "Delay(3.)\n"
        "End()   \n\n"
    )
    assert format_program(text) == (
        "Begin()  # start here\n"
        "\n"
        "// move\n"
        "MoveJoint(90, -90, 180.001, 0, 0, 180, t=4, trap, speed)\n"
        "MoveCart(0, 250, 200, 180, 0, 0, v=50, r=10)\n"
        "Output(2, HIGH)\n"
        "Input(1, LOW, t=2.5)\n"
        "Gripper_cal()\n"
        "Delay(3)\n"
        "End()\n"
    )


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_formatting_preserves_meaning_and_is_idempotent(path):
    text = path.read_text()
    once = format_program(text)
    assert format_program(once) == once
    a = [c.to_source() for c in parse(text).program.commands]
    b = [c.to_source() for c in parse(once).program.commands]
    assert a == b


def test_formatter_refuses_a_program_with_errors():
    with pytest.raises(ProgramError) as info:
        format_program("Begin()\nDelay(\nEnd()")
    assert info.value.errors[0].line == 2


# ---- dry run --------------------------------------------------------------------------------


def test_dry_run_table_has_start_end_duration_and_targets_per_line():
    report = dry_run(load(REPO / "examples" / "cartesian_trf.rbt"))
    assert report.ok, [e.format() for e in report.errors]
    assert report.iterations == 1
    rows = report.rows
    assert [r.line for r in rows] == list(range(1, 18))
    # the timeline is continuous: every row starts where the previous one ended
    for prev, row in zip(rows, rows[1:]):
        assert row.start_s == pytest.approx(prev.end_s)
    delays = [r for r in rows if r.command.startswith("Delay")]
    assert all(r.duration_s == 1.0 for r in delays)
    joint = rows[2]
    assert joint.command.startswith("MoveJoint") and joint.target_deg is not None
    carts = [r for r in rows if r.command.startswith("MoveCart")]
    assert len(carts) == 6 and all(r.duration_s > 0 and r.target_deg is not None for r in carts)
    assert report.total_s == pytest.approx(sum(r.duration_s for r in rows))
    # the last MoveCart ends where the program's last target is (FK of the predicted joints)
    from parolkit.kinematics import fk

    np.testing.assert_allclose(fk(report.final_deg)[:3], [82.89, 191.698, 162.369], atol=0.01)
    table = report.table()
    assert "line" in table.splitlines()[0] and "joints at end" in table
    assert f"total {report.total_s:.2f} s" in table


def test_dry_run_of_a_loop_program_plans_two_passes_by_default_or_n():
    program = load(REPO / "examples" / "simple_joint_move.rbt")
    two = dry_run(program)
    assert two.iterations == 2
    assert [r.iteration for r in two.rows].count(2) == len(program)
    five = dry_run(program, loops=5)
    assert five.iterations == 5
    one_pass = two.total_s / 2
    # passes after the first start from the end of the previous pass: the first move differs
    assert five.total_s == pytest.approx(two.total_s + 3 * (two.total_s - dry_run(program, loops=1).total_s), rel=1e-9)
    assert one_pass > 0


def test_a_billion_passes_of_a_program_that_repeats_itself_are_checked_in_two_planned_passes():
    # `parolkit check --loops 1000000000` once planned every pass: minutes with no output
    program = load(REPO / "examples" / "simple_joint_move.rbt")
    two, one = dry_run(program), dry_run(program, loops=1)
    huge = dry_run(program, loops=1_000_000_000)
    assert huge.planned_iterations == 2 and huge.repeats == (3, 2)
    assert [r.iteration for r in huge.rows] == [r.iteration for r in two.rows]
    assert huge.iterations == huge.counted_iterations == 1_000_000_000
    pass_s = two.total_s - one.total_s  # passes after the first start where the previous ended
    assert huge.total_s == pytest.approx(one.total_s + (1_000_000_000 - 1) * pass_s, rel=1e-12)
    assert huge.final_deg == two.final_deg
    assert "passes 3..1000000000 repeat pass 2" in huge.table()


def test_passes_that_go_round_a_cycle_of_earlier_passes_are_counted_with_their_own_times():
    from parolkit.script.dryrun import repeated_passes

    # passes of 1, 2 and 3 s; pass 4 starts where pass 2 started: 2, 3, 2, 3, ... follow
    starts = [0.0, 1.0, 3.0, 6.0]
    assert [repeated_passes(n, (4, 2), starts) for n in (4, 5, 6, 7)] == [(8, 2), (11, 3), (13, 2), (16, 3)]


def test_a_program_that_drifts_is_planned_for_at_most_100_passes_and_says_so():
    from parolkit.script.dryrun import MAX_DRY_RUN_PASSES

    program = parse("Begin()\nMoveCartRelTRF(0, 0, 0.1, 0, 0, 0, t=0.5)\nLoop()").unwrap()
    report = dry_run(program, [90, -100, 160, 0, 30, 180], loops=1_000_000_000)
    assert report.ok and report.repeats is None
    assert report.planned_iterations == report.counted_iterations == MAX_DRY_RUN_PASSES == 100
    assert report.total_s == pytest.approx(100 * 0.5)
    (w,) = [w for w in report.warnings if "were not" in w.message]
    assert w.line == 3 and "passes 1..100 were planned, passes 101..1000000000 were not" in w.message
    assert "for the first 100 of 1000000000 loop iterations" in report.table()


def test_dry_run_starts_from_the_given_joints_and_home_returns_to_standby():
    program = parse("Begin()\nMoveJoint(80, -95, 175, 5, 5, 170, t=2)\nHome()\nEnd()").unwrap()
    report = dry_run(program, [70, -100, 170, 10, 10, 160])
    assert report.ok
    assert report.start_deg == (70, -100, 170, 10, 10, 160)
    home = report.rows[2]
    assert home.exact is False and home.target_deg == STANDBY
    assert report.final_deg == STANDBY
    assert report.has_waits and "+ waits" in report.table()


def test_dry_run_reports_every_failing_line_and_continues():
    program = parse(
        "Begin()\n"
        "MovePose(0, 900, 100, -90, 0, -90)\n"
        "MoveJoint(-110, -90, 180, 0, 0, 180, t=0.5)\n"
        "Delay(1)\n"
        "End()"
    ).unwrap()
    report = dry_run(program)
    assert [(e.line, e.col) for e in report.errors] == [(2, 1), (3, 1)]
    assert "MovePose cannot be planned" in report.errors[0].message
    assert "J1" in report.errors[1].message
    assert [r.failed for r in report.rows] == [False, True, True, False, False]


def test_loop_wrap_around_path_is_checked():
    # the second pass starts at the end of the first: a speed-limited jump back is found there
    program = parse(
        "Begin()\nMoveJoint(90, -90, 180, 0, 0, 180, t=0.3)\nMoveJoint(60, -90, 180, 0, 0, 180, t=8)\nLoop()"
    ).unwrap()
    report = dry_run(program)
    (err,) = report.errors
    assert (err.line, err.col) == (2, 1) and err.message.endswith("(loop iteration 2)")


def test_effective_timing_applies_the_seed_defaults_once():
    def cmd(text):
        return parse(text).unwrap().commands[0]

    t = effective_timing(cmd("MoveJoint(90,-90,180,0,0,180)"))
    assert (t.duration_s, t.speed_pct, t.accel_pct) == (None, 45.0, 27.0)
    t = effective_timing(cmd("MovePose(0,250,300,-90,0,-90)"))
    assert (t.duration_s, t.speed_pct, t.accel_pct) == (None, 50.0, 30.0)
    t = effective_timing(cmd("MoveJoint(90,-90,180,0,0,180,v=80,a=60,t=3)"))
    assert (t.duration_s, t.speed_pct, t.accel_pct) == (3.0, None, None)
    t = effective_timing(cmd("MoveCart(0,250,300,-90,0,-90)"))
    assert (t.duration_s, t.speed_pct, t.accel_pct) == (None, DEFAULT_CART_SPEED_PCT, None)
    t = effective_timing(cmd("MoveJoint(90,-90,180,0,0,180,v=70)"))
    assert (t.speed_pct, t.accel_pct) == (70.0, 27.0)


def test_plot_series_covers_the_whole_program_with_positions_and_speeds():
    report = dry_run(load(REPO / "examples" / "simple_joint_move.rbt"))
    t, q, v = report.series()
    assert t[0] == 0 and t[-1] == pytest.approx(report.total_s)
    assert np.all(np.diff(t) >= -1e-9)
    assert q.shape == v.shape == (len(t), 6)
    np.testing.assert_allclose(q[0], STANDBY)
    # the first move (line 3) starts after Delay(1) and ends on its target
    moving = t[np.abs(v).max(axis=1) > 0]
    assert moving[0] > 1.0
    np.testing.assert_allclose(q[-1], report.final_deg)
    assert np.abs(v).max() > 1.0


# ---- commands -------------------------------------------------------------------------------


def test_run_dry_run_prints_the_table_and_exits_zero(capsys, tmp_path):
    png = tmp_path / "p.png"
    rc = main(["run", str(REPO / "examples" / "cartesian_relative_trf.rbt"), "--dry-run", "--plot", str(png)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "MoveCartRelTRF(-80, 0, 0, 0, 0, 0)" in out
    assert "final joints:" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def test_check_of_a_billion_passes_answers_with_the_total_and_the_passes_that_repeat(capsys):
    rc = main(["check", "--loops", "1000000000", str(REPO / "examples" / "simple_joint_move.rbt")])
    out = capsys.readouterr().out
    assert rc == 0
    assert "OK, 7 commands, planned 7610000000.00 s for 1000000000 passes; passes 3..1000000000 repeat pass 2" in out


def test_run_dry_run_exits_non_zero_on_a_planning_error(capsys, tmp_path):
    prog = tmp_path / "far.rbt"
    prog.write_text("Begin()\nMovePose(0, 900, 100, -90, 0, -90)\nEnd()\n")
    rc = main(["run", str(prog), "--dry-run"])
    captured = capsys.readouterr()
    assert rc == 1
    assert f"{prog}:2:1: error: MovePose cannot be planned" in captured.err


def test_run_refuses_a_syntax_error_before_connecting(capsys, tmp_path):
    prog = tmp_path / "bad.rbt"
    prog.write_text("Begin()\nDelay(1\nEnd()\n")
    # port 9 (discard) is never a controller: the error must come before any connection
    rc = main(["run", str(prog), "--port", "9"])
    assert rc == 1
    err = capsys.readouterr().err
    assert f"{prog}:2:8: error: missing ')'" in err and "nothing was run" in err


def test_check_passes_the_examples_and_fails_on_errors(capsys, tmp_path):
    assert main(["check", *map(str, EXAMPLES)]) == 0
    out = capsys.readouterr().out
    assert out.count(": OK,") == 5
    bad = tmp_path / "bad.rbt"
    bad.write_text("Begin()\nOutput(3, HIGH)\nEnd()\n")
    assert main(["check", str(bad), "--no-plan"]) == 1
    assert f"{bad}:2:8: error: output number must be 1 or 2" in capsys.readouterr().out


def test_check_strict_turns_warnings_into_failures(capsys, tmp_path):
    prog = tmp_path / "warn.rbt"
    prog.write_text("Begin()\nGripper(10, 60, 120)\nEnd()\n")
    assert main(["check", str(prog)]) == 0
    assert main(["check", str(prog), "--strict"]) == 1
    assert "too weak" in capsys.readouterr().out


def test_fmt_rewrites_files_and_check_mode_reports_them(capsys, tmp_path):
    prog = tmp_path / "p.rbt"
    prog.write_text("begin()\ndelay(1.50)\nend()")
    assert main(["fmt", str(prog), "--check"]) == 1
    assert prog.read_text() == "begin()\ndelay(1.50)\nend()"
    assert main(["fmt", str(prog)]) == 0
    assert prog.read_text() == "Begin()\nDelay(1.5)\nEnd()\n"
    assert main(["fmt", str(prog), "--check"]) == 0
    bad = tmp_path / "bad.rbt"
    bad.write_text("Begin(\n")
    assert main(["fmt", str(bad)]) == 1
    assert bad.read_text() == "Begin(\n"
