"""A planned move checked for collisions where a student sees it: the shared check
(``parolkit.collision.check_trajectory``, samples in degrees at a rate, swept) and its one-line
message, the dry run reporting a collision at the program line, and ``parolkit check`` run as
a real command on programs whose third line drives into a box, folds the arm into itself or
goes through the table."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from parolkit.collision import (
    TABLE_ZONE,
    BoxZone,
    PairKind,
    PathStatus,
    Scene,
    ToolShape,
    TrajectoryVerdict,
    check_path,
    check_trajectory,
    collision_message,
)
from parolkit.collision.scene import Pair, PairDistance
from parolkit.config import Config, ToolSettings, default_zones, load_config
from parolkit.errors import ParolkitValueError
from parolkit.motion import plan
from parolkit.moves import JointMove
from parolkit.robot import PAROL6
from parolkit.script import load, parse
from parolkit.script.dryrun import dry_run

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples").glob("*.rbt"))
STANDBY = np.array(PAROL6.standby_deg, dtype=float)
#: a box the wrist passes through when J1 swings from 90 to 0 deg at the standby pose
MONITOR = BoxZone("monitor", center=(141.0, 141.0, 334.0), size=(40.0, 40.0, 40.0), margin=10.0)
SWING = (0.0, -90.0, 180.0, 0.0, 0.0, 180.0)
#: the wrist folded back into the arm's own base (within the joint limits)
FOLD = (90.0, -33.0, 115.0, 0.0, -52.0, 180.0)
#: the forearm pointing down through the table in front of the arm
THROUGH_TABLE = (90.0, -3.4, 200.0, 0.0, 0.0, 180.0)
#: the wrist low in front of the arm, the flange pointing down: clear, but not with a 150 mm pen
LOW_WRIST = (90.0, -20.0, 200.0, 0.0, -60.0, 180.0)


def _joints(q: tuple[float, ...]) -> str:
    return ", ".join(f"{v:g}" for v in q)


def _program(*moves: tuple[float, ...], head: str = "Begin()\nDelay(0.5)\n", tail: str = "End()\n") -> str:
    """Begin(), Delay(0.5), then one MoveJoint per target from line 3 on."""
    return head + "".join(f"MoveJoint({_joints(q)})\n" for q in moves) + tail


def _swing() -> tuple[np.ndarray, float]:
    traj = plan(JointMove(SWING), STANDBY)
    return traj.positions_deg(), traj.rate_hz


# ---- the shared check ------------------------------------------------------------------------


def test_a_move_into_a_box_is_refused_at_the_first_pose_within_the_margin_with_its_time():
    qs, rate = _swing()
    scene = Scene(zones=(TABLE_ZONE, MONITOR))
    v = check_trajectory(qs, rate, scene, start_deg=STANDBY)
    assert isinstance(v, TrajectoryVerdict) and not v.clear
    assert v.pair is not None and v.pair.pair.b == "zone 'monitor'" and v.pair.pair.kind is PairKind.ARM_ZONE
    assert v.status in (PathStatus.AT_SAMPLE, PathStatus.BETWEEN_SAMPLES)
    # the time is the path's position in the rows checked (the start at 0 s, sample k at (k + 1) / rate)
    assert v.path.position is not None and v.time_s == pytest.approx(v.path.position / rate)
    # every sample before that time is clear, the pose there is within the margin (+ the sweep's 0.01 mm)
    rows = np.vstack([STANDBY, qs])
    k = int(v.path.position)
    for q in rows[: k + 1]:
        assert scene.check(np.radians(q)).clear
    frac = v.path.position - k
    q_at = rows[k] + frac * (rows[k + 1] - rows[k])
    d = scene.distances(np.radians(q_at))[0][scene.pairs.index(v.pair.pair)]
    assert d <= MONITOR.margin + 0.01
    # the move goes deeper after that: the deepest sample is later and its clearance smaller
    assert v.deepest is not None and v.deepest_time_s is not None
    assert v.deepest_time_s >= v.time_s and v.deepest.distance_mm < v.pair.distance_mm
    assert re.fullmatch(r"J\d link vs zone 'monitor' at \d+\.\d\d s into the move \(enters its 10 mm margin; "
                        r"deepest \d+\.\d mm overlap at \d+\.\d\d s\)", v.message), v.message
    assert str(v) == v.message


def test_the_samples_are_degrees_and_the_check_is_the_packages_swept_path_check():
    qs, rate = _swing()
    zones = (TABLE_ZONE, MONITOR)
    v = check_trajectory(qs, rate, zones=zones, start_deg=STANDBY)
    ref = check_path(np.radians(np.vstack([STANDBY, qs])), zones)
    assert (v.path.status, v.path.index, v.path.fraction, v.path.pair) == (ref.status, ref.index, ref.fraction,
                                                                          ref.pair)
    # without start_deg the first sample is at 1 / rate s (a Trajectory's t)
    w = check_trajectory(qs, rate, zones=zones)
    assert w.path.position is not None and w.time_s == pytest.approx((w.path.position + 1) / rate)
    assert w.time_s == pytest.approx(v.time_s, abs=1e-4)  # the sweep stops within 0.01 mm of the margin
    # samples only: the first violating sample, at or after the swept check's time
    s = check_trajectory(qs, rate, zones=zones, start_deg=STANDBY, swept=False)
    assert s.status is PathStatus.AT_SAMPLE and s.time_s is not None and s.time_s >= v.time_s - 1e-12


def test_the_deepest_sample_is_the_pairs_smallest_clearance_after_the_violation():
    from parolkit.collision.trajectory import _pair_clearances

    qs, rate = _swing()
    scene = Scene(zones=(TABLE_ZONE, MONITOR), tool=ToolShape("pen", 8, end=(0.0, 0.0, 60.0)))
    rad = np.radians(qs)
    full = scene.distances_batch(rad)[0]
    for k in range(len(scene.pairs)):  # one pair alone, as the whole scene computes it
        np.testing.assert_allclose(_pair_clearances(scene, k, rad), full[:, k], rtol=0, atol=1e-9)
    v = check_trajectory(qs, rate, scene, start_deg=STANDBY)
    assert v.pair is not None and v.deepest is not None and v.deepest_time_s is not None
    k = scene.pairs.index(v.pair.pair)
    after = full[int(v.path.position):, k]  # sample j of qs is row j + 1 of the path
    assert v.deepest.distance_mm == pytest.approx(after.min(), abs=1e-9)
    assert v.deepest_time_s == pytest.approx((int(v.path.position) + int(np.argmin(after)) + 1) / rate)


def test_a_clear_move_is_clear_with_no_time_and_no_message():
    traj = plan(JointMove((80.0, -80.0, 170.0, 10.0, 10.0, 170.0)), STANDBY)
    v = check_trajectory(traj.positions_deg(), traj.rate_hz, Scene(zones=(TABLE_ZONE, MONITOR)), start_deg=STANDBY)
    assert v.clear and v.time_s is None and v.pair is None and v.message == "" and str(v) == "clear"
    empty = check_trajectory(np.zeros((0, 6)), 100.0, zones=(TABLE_ZONE,))
    assert empty.clear and empty.path.evaluations == 0


def test_a_move_that_starts_in_collision_is_refused_at_0_s():
    bad_start = np.array(THROUGH_TABLE)
    v = check_trajectory(np.vstack([bad_start, bad_start]), 100.0, zones=(TABLE_ZONE,), start_deg=bad_start)
    assert v.status is PathStatus.AT_SAMPLE and v.time_s == 0.0
    assert v.message.startswith("J6 link vs zone 'table' at 0.00 s into the move (") or \
        v.message.startswith("J5 link vs zone 'table' at 0.00 s into the move ("), v.message


def test_a_self_collision_names_the_two_parts_of_the_arm():
    traj = plan(JointMove(FOLD), STANDBY)
    v = check_trajectory(traj.positions_deg(), traj.rate_hz, zones=(), start_deg=STANDBY)
    assert not v.clear and v.pair is not None and v.pair.pair.kind is PairKind.SELF
    assert re.fullmatch(r"(base|J\d link) vs J\d link at \d+\.\d\d s into the move \(comes into contact; "
                        r"deepest \d+\.\d mm overlap at \d+\.\d\d s\)", v.message), v.message


def test_the_check_refuses_a_scene_together_with_zones_and_a_bad_rate():
    qs, rate = _swing()
    with pytest.raises(ParolkitValueError, match="a scene or zones"):
        check_trajectory(qs, rate, Scene(), zones=(TABLE_ZONE,))
    for bad in (0, -1.0, float("nan"), True, "100"):
        with pytest.raises(ParolkitValueError, match="rate_hz"):
            check_trajectory(qs, bad, zones=())  # type: ignore[arg-type]
    with pytest.raises(ParolkitValueError, match="positions_deg"):
        check_trajectory(np.zeros((3, 5)), rate)
    with pytest.raises(ParolkitValueError, match="start_deg"):
        check_trajectory(qs, rate, start_deg=[1.0, 2.0])


def _pd(distance: float, margin: float, a: str = "J5 link", b: str = "zone 'monitor'") -> PairDistance:
    kind = PairKind.ARM_ZONE if b.startswith("zone") else PairKind.SELF
    return PairDistance(Pair(a, b, kind, margin), distance)


@pytest.mark.parametrize(("found", "time_s", "deepest", "expected"), [
    (_pd(7.9, 10), 1.234, None, "J5 link vs zone 'monitor' at 1.23 s into the move (2.1 mm inside its 10 mm margin)"),
    (_pd(10.004, 10), 1.0, None, "J5 link vs zone 'monitor' at 1.00 s into the move (at its 10 mm margin)"),
    (_pd(-3.21, 10), 0.5, None, "J5 link vs zone 'monitor' at 0.50 s into the move (in contact, 3.2 mm overlap; "
                                "margin 10 mm)"),
    (_pd(-4.2, 0, "J2 link", "J6 link"), 0.84, None, "J2 link vs J6 link at 0.84 s into the move (in contact, "
                                                     "4.2 mm overlap)"),
    (_pd(0.003, 0, "base", "J6 link"), 3.09, None, "base vs J6 link at 3.09 s into the move (touching)"),
    (_pd(-0.01, 0, "tool 'pen'", "zone 'table'"), 2.0, None, "tool 'pen' vs zone 'table' at 2.00 s into the move "
                                                             "(touching)"),
    (_pd(7.9, 10), None, None, "J5 link vs zone 'monitor' (2.1 mm inside its 10 mm margin)"),
    (_pd(float("nan"), 10), 1.5, None, "J5 link vs zone 'monitor' at 1.50 s into the move (not proven clear: the "
                                       "check gave up after its most evaluations)"),
    (_pd(10.0, 10), 0.92, _pd(-26.0, 10), "J5 link vs zone 'monitor' at 0.92 s into the move (enters its 10 mm "
                                          "margin; deepest 26.0 mm overlap at 1.31 s)"),
    (_pd(10.0, 10), 0.92, _pd(4.0, 10), "J5 link vs zone 'monitor' at 0.92 s into the move (enters its 10 mm "
                                        "margin; deepest 6.0 mm inside it at 1.31 s)"),
    (_pd(0.004, 0, "base", "J6 link"), 3.09, _pd(-4.0, 0, "base", "J6 link"),
     "base vs J6 link at 3.09 s into the move (comes into contact; deepest 4.0 mm overlap at 1.31 s)"),
    (_pd(-2.0, 0, "base", "J6 link"), 0.0, _pd(-4.0, 0, "base", "J6 link"),
     "base vs J6 link at 0.00 s into the move (in contact; deepest 4.0 mm overlap at 1.31 s)"),
    (_pd(7.9, 10), 1.234, _pd(7.88, 10), "J5 link vs zone 'monitor' at 1.23 s into the move (2.1 mm inside its 10 mm "
                                         "margin)"),
])
def test_the_message_names_the_pair_the_time_and_how_deep(found, time_s, deepest, expected):
    assert collision_message(found, time_s, deepest, 1.31 if deepest is not None else None) == expected


# ---- the dry run -----------------------------------------------------------------------------


def test_the_dry_run_reports_a_collision_at_its_line_naming_the_pair_and_checks_the_lines_after_it():
    text = _program(SWING, (0.0, -60.0, 150.0, 0.0, 0.0, 180.0), THROUGH_TABLE, STANDBY)
    report = dry_run(parse(text).program, zones=(TABLE_ZONE, MONITOR))
    # line 6 starts where line 5 ended, in the table: reported too (at 0 s), every line that collides at once
    assert [e.line for e in report.errors] == [3, 5, 6]
    box, table, out = report.errors
    assert re.fullmatch(r"MoveJoint would collide: J\d link vs zone 'monitor' at \d+\.\d\d s into the move "
                        r"\(enters its 10 mm margin; deepest .*\)", box.message), box.message
    assert re.match(r"MoveJoint would collide: J\d link vs zone 'table' at ", table.message), table.message
    assert re.match(r"MoveJoint would collide: J\d link vs zone 'table' at 0\.00 s into the move \(in contact, ",
                    out.message), out.message
    assert box.headline().startswith("<script>:3:1: error: MoveJoint would collide: ")
    # the rows: the colliding ones marked, the timeline continuous (the run goes on from each move's end)
    rows = {r.line: r for r in report.rows}
    assert rows[3].failed and rows[5].failed and rows[6].failed and not rows[4].failed
    assert rows[3].note.startswith("collides")
    assert rows[4].start_s == pytest.approx(rows[3].end_s) and rows[4].duration_s > 0
    np.testing.assert_allclose(report.final_deg, STANDBY, atol=0.01)
    # the time in the message is the one the shared check gives for that planned move
    traj = plan(JointMove(SWING), STANDBY)
    v = check_trajectory(traj.positions_deg(), traj.rate_hz, zones=(TABLE_ZONE, MONITOR), start_deg=STANDBY)
    assert box.message == f"MoveJoint would collide: {v.message}"


def test_the_dry_run_checks_the_table_by_default_and_the_arm_against_itself_always():
    through = parse(_program(THROUGH_TABLE)).program
    fold = parse(_program(FOLD)).program
    default = dry_run(through)
    assert [e.line for e in default.errors] == [3] and "vs zone 'table'" in default.errors[0].message
    assert dry_run(through, zones=()).ok  # no zones: the table switched off
    assert dry_run(through, zones=Config().zones).errors == default.errors
    for zones in (None, ()):
        r = dry_run(fold, zones=zones)
        assert [e.line for e in r.errors] == [3]
        assert re.match(r"MoveJoint would collide: (base|J\d link) vs J\d link at ", r.errors[0].message)


def test_the_dry_run_checks_the_tools_shape_from_its_config_entry():
    program = parse(_program(LOW_WRIST, STANDBY)).program
    assert dry_run(program).ok  # the arm alone stays clear of the table
    pen = load_config(None, overrides={"tools": {"pen": {"pose": [0, 0, 150, 0, 0, 0],
                                                          "shape": {"radius": 8}}}}).tools[0]
    assert isinstance(pen, ToolSettings) and pen.shape is not None
    for shape in (pen, pen.shape):
        r = dry_run(program, tool_shape=shape)
        assert [e.line for e in r.errors] == [3, 4]  # line 4 starts with the pen in the table
        assert re.match(r"MoveJoint would collide: tool 'pen' vs zone 'table' at \d+\.\d\d s into the move "
                        r"\(comes into contact; deepest \d+\.\d mm overlap at ", r.errors[0].message)


def test_the_time_into_the_move_is_the_time_at_the_speed_override_in_force():
    plain = dry_run(parse(_program(SWING)).program, zones=(MONITOR,))
    slow = dry_run(parse(_program(SWING, head="Begin()\nSpeed(50)\n")).program, zones=(MONITOR,))
    times = [[float(t) for t in re.findall(r"(\d+\.\d\d) s", r.errors[0].message)] for r in (plain, slow)]
    assert len(times[0]) == 2 and times[1] == pytest.approx([2 * t for t in times[0]], abs=0.011)


def test_a_collision_in_a_loop_is_reported_once():
    program = parse(_program(SWING, STANDBY, tail="Loop()\n")).program  # there through the box and back
    r = dry_run(program, zones=(MONITOR,), loops=3)
    assert [e.line for e in r.errors] == [3, 4]
    assert not any("loop iteration" in e.message for e in r.errors)


def test_the_stock_poses_the_examples_and_the_test_programs_are_clear_of_the_default_zones():
    # the table plane must not flag the arm where it stands: the standby pose (where homing
    # ends), the zero pose and every sampled joint vector near standby
    from parolkit.collision import check

    for q in (PAROL6.standby_deg, (0.0,) * 6, (0.0, -90.0, 180.0, 0.0, 0.0, 0.0)):
        assert check(np.radians(q), default_zones()).clear, q
    for path in EXAMPLES:
        report = dry_run(load(path), zones=Config().zones)
        assert report.ok, [e.format() for e in report.errors]


# ---- `parolkit check`, the real command --------------------------------------------------------


def _parolkit_check(tmp_path: Path, program: str, *args: str) -> subprocess.CompletedProcess[str]:
    """Run ``python -m parolkit check prog.rbt ARGS`` in ``tmp_path`` (no config file found
    there or in its HOME unless the test writes one)."""
    (tmp_path / "prog.rbt").write_text(program)
    env = {**os.environ, "HOME": str(tmp_path), "PYTHONPATH": str(REPO / "src")}
    return subprocess.run([sys.executable, "-m", "parolkit", "check", "prog.rbt", *args], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=60)


ZONES_TOML = """\
[[zones]]
name = "monitor"
kind = "box"
center = [141, 141, 334]
size = [40, 40, 40]
margin = 10
"""


def test_parolkit_check_names_line_3_and_the_pair_of_a_move_into_a_box_zone_of_the_config(tmp_path):
    (tmp_path / "cfg.toml").write_text(ZONES_TOML)
    run = _parolkit_check(tmp_path, _program(SWING), "--config", "cfg.toml")
    assert run.returncode == 1, run.stdout + run.stderr
    first = run.stdout.splitlines()[0]
    assert re.fullmatch(r"prog\.rbt:3:1: error: MoveJoint would collide: J\d link vs zone 'monitor' at "
                        r"\d+\.\d\d s into the move \(enters its 10 mm margin; deepest .*\)", first), run.stdout
    assert "prog.rbt: 1 error(s), 0 warning(s)" in run.stdout
    # without that config the box is not there: the same program checks clean
    clean = _parolkit_check(tmp_path, _program(SWING))
    assert clean.returncode == 0 and "prog.rbt: OK" in clean.stdout, clean.stdout + clean.stderr


def test_parolkit_check_names_line_3_and_the_two_parts_of_an_arm_folded_into_itself(tmp_path):
    run = _parolkit_check(tmp_path, _program(FOLD))
    assert run.returncode == 1, run.stdout + run.stderr
    assert re.fullmatch(r"prog\.rbt:3:1: error: MoveJoint would collide: (base|J\d link) vs J\d link at "
                        r"\d+\.\d\d s into the move \(comes into contact; deepest .*\)",
                        run.stdout.splitlines()[0]), run.stdout


def test_parolkit_check_names_line_3_and_the_table_of_a_move_through_it_with_the_default_config(tmp_path):
    run = _parolkit_check(tmp_path, _program(THROUGH_TABLE))
    assert run.returncode == 1, run.stdout + run.stderr
    assert re.match(r"prog\.rbt:3:1: error: MoveJoint would collide: J\d link vs zone 'table' at \d+\.\d\d s "
                    r"into the move", run.stdout.splitlines()[0]), run.stdout
    # a config that switches the table off (the default file in the working folder) lets it through
    (tmp_path / "parolkit.toml").write_text('[[zones]]\nname = "table"\nenabled = false\n')
    assert _parolkit_check(tmp_path, _program(THROUGH_TABLE)).returncode == 0


def test_parolkit_check_tool_checks_that_tools_shape_and_refuses_an_unknown_tool(tmp_path):
    (tmp_path / "cfg.toml").write_text('[tools.pen]\npose = [0, 0, 150, 0, 0, 0]\nshape = { radius = 8 }\n')
    program = _program(LOW_WRIST, STANDBY)
    assert _parolkit_check(tmp_path, program, "--config", "cfg.toml").returncode == 0
    run = _parolkit_check(tmp_path, program, "--config", "cfg.toml", "--tool", "pen")
    assert run.returncode == 1 and re.match(r"prog\.rbt:3:1: error: MoveJoint would collide: tool 'pen' vs zone "
                                            r"'table' at ", run.stdout), run.stdout + run.stderr
    bad = _parolkit_check(tmp_path, program, "--tool", "no-such-tool")
    assert bad.returncode == 2 and "no-such-tool" in bad.stderr


def test_run_dry_run_checks_collisions_and_tool_needs_dry_run(tmp_path, capsys):
    from parolkit.cli import main

    prog = tmp_path / "prog.rbt"
    prog.write_text(_program(THROUGH_TABLE))
    assert main(["run", str(prog), "--dry-run"]) == 1
    err = capsys.readouterr().err
    assert re.search(r"prog\.rbt:3:1: error: MoveJoint would collide: J\d link vs zone 'table'", err), err
    assert main(["run", str(prog), "--tool", "default"]) == 2
    assert "--tool applies to --dry-run" in capsys.readouterr().err
