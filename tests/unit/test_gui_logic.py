"""Fast tests of the commander's pure UI logic (no browser, no NiceGUI)."""

from __future__ import annotations

import json
import math

import pytest

from parolkit.client.core import GripperState, PlanInfo, Queries, RobotState, RobotStatus, parse_query_reply
from parolkit.client.errors import ReplyError
from parolkit.errors import ParolkitValueError
from parolkit.gui import geometry
from parolkit.gui.eventlog import EventLog, Level, level_of_ack
from parolkit.gui.highlight import TokenKind, line_decorations, mark_decorations, tokenize
from parolkit.gui.jog import (
    KEYMAP,
    cart_jog_blocked,
    cart_step_command,
    jog_command,
    jog_target_pose,
    joint_jog_blocked,
    joint_step_target,
    key_action,
    matrix_to_rpy,
    rpy_to_matrix,
)
from parolkit.gui.status import (
    POSE_LABELS,
    format_angles,
    format_gripper,
    format_loop,
    format_pose,
    gripper_summary,
    state_badge,
)
from parolkit.gui.templates import SEED_EXAMPLES, TEMPLATES, render_template
from parolkit.moves import CartAxis, CartJog, Frame, JointJog
from parolkit.robot import PAROL6

STATUS = {
    "seq": 1234, "time": 12.34, "state": "IDLE", "enabled": True, "homed": [True] * 6,
    "all_homed": True, "estop_pressed": False, "estop_latched": False,
    "angles": [90, -90, 180, 0, 0, 180], "pose": [0, 262.57, 288.75, -90, 0, -90],
    "speeds": [0] * 6, "speeds_deg_s": [0] * 6,
    "io": {"in1": 0, "in2": 1, "out1": 1, "out2": 0, "estop": 1},
    "gripper": {"id": 0, "position": 12, "speed": 1, "current": 300, "status": 0, "object_detection": 1,
                "activated": True, "calibrated": True, "object_code": 0, "object_detected": False, "error": False},
    "errors": {"temperature": [False] * 6, "position": [False, True, False, False, False, False],
               "timeout_error": 100, "message": None},
    "board": {"connected": True, "simulated": True, "port": "emulated board", "timing_ticks": 7031,
              "timing_ms": 10.0, "xtr": 255},
    "loop": {"rate_hz": 100.0, "ticks": 5000, "period_p50_ms": 10.0, "period_p99_ms": 10.4,
             "period_max_ms": 12.1, "overruns": 0},
    "command": {"id": "1a2b3c4d", "name": "MOVEJOINT", "progress": 0.42},
    "queue": 2, "stream_mode": False, "tool": "default", "plan_seq": 7,
}


# ---- the status the page reads (the client's RobotStatus) ----

def test_the_page_reads_the_clients_typed_status():
    st = parse_query_reply(Queries.status, "STATUS_JSON|" + json.dumps(STATUS))
    assert st.seq == 1234 and st.state is RobotState.IDLE and st.all_homed and st.can_move
    assert st.angles == (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)
    assert st.io.out1 and st.io.in2 and not st.io.estop_pressed
    assert st.errors.position[1] and st.errors.any
    assert st.command.name == "MOVEJOINT" and st.command.progress == pytest.approx(0.42)


def test_something_moves_is_a_jog_a_program_or_a_busy_controller(tmp_path):
    """Commander.moving (Space is STOP in a text field then): the client's wait-for-idle test
    on a live status, a program running or paused; nothing while the link is down."""
    import threading
    import time

    from parolkit.gui.commander import Commander
    from parolkit.gui.link import ControllerLink
    from parolkit.gui.programs import ProgramsFolder

    link = ControllerLink("127.0.0.1", 9, 9)
    c = Commander(link, mode_label="test", programs=ProgramsFolder(tmp_path))
    assert not c.moving  # no status yet
    idle = dict(STATUS, command=None, queue=0)
    for change, moves in (({}, False), ({"command": STATUS["command"]}, True), ({"queue": 1}, True),
                          ({"state": "MOVING"}, True), ({"state": "HOMING"}, True)):
        link.status, link.status_monotonic = RobotStatus.from_json(dict(idle, **change)), time.monotonic()
        assert c.moving is moves, change
    link.status_monotonic -= 60  # the link is down: its last status says nothing
    link.status = RobotStatus.from_json(dict(idle, state="MOVING"))
    assert not c.moving
    gate = threading.Event()
    c.program.thread = threading.Thread(target=gate.wait)  # a program's thread
    c.program.thread.start()
    try:
        for program_state, moves in (("running", True), ("paused", True), ("finished", False)):
            c.program.state = program_state  # finished: the thread still closes its client
            assert c.moving is moves and c.program.active is moves, program_state
    finally:
        gate.set()
        c.program.thread.join()


def test_a_status_still_showing_the_programs_last_command_after_its_end_keeps_program_running(tmp_path):
    """The header's state right after a program ended: the last line's ack came, but the
    newest status left the controller before it and still shows that line's command.  It
    says PROGRAM RUNNING for it (a run beside two CPU hogs showed PROGRAM RUNNING, MOVING,
    READY); a later command of anyone else's is MOVING again."""
    import threading

    from parolkit.gui.commander import Commander
    from parolkit.gui.link import ControllerLink
    from parolkit.gui.programs import ProgramsFolder
    from parolkit.gui.status import state_badge

    c = Commander(ControllerLink("127.0.0.1", 9, 9), mode_label="test", programs=ProgramsFolder(tmp_path))
    runner = c.program
    last = dict(STATUS, state="MOVING", command={"id": "prog0042", "name": "MOVEJOINT", "progress": 0.97})
    gate = threading.Event()
    runner.thread = threading.Thread(target=gate.wait)
    runner.thread.start()
    try:
        runner.state = "running"
        runner.follow(RobotStatus.from_json(last))  # the statuses during the run
    finally:
        gate.set()
        runner.thread.join()
    runner.state = "finished"

    def badge(status: dict) -> str:
        st = RobotStatus.from_json(status)
        return state_badge(st, True, "running" if runner.finishing(st) else None)[0]

    assert badge(last) == "PROGRAM RUNNING"  # stale: the program's own command
    other = dict(last, command={"id": "other001", "name": "MOVEJOINT", "progress": 0.1})
    assert badge(other) == "MOVING"
    assert badge(dict(STATUS, state="IDLE", command=None, queue=0)) == "READY"


def test_a_program_stopped_between_run_and_its_start_does_not_run(tmp_path):
    """Run pressed, the page's text still on its way: the program counts as moving (Space is
    STOP) and stop() cancels it; start() then runs nothing."""
    import asyncio

    from parolkit.gui.commander import Commander
    from parolkit.gui.link import ControllerLink
    from parolkit.gui.programs import ProgramsFolder

    c = Commander(ControllerLink("127.0.0.1", 9, 9), mode_label="test", programs=ProgramsFolder(tmp_path))
    runner = c.program
    runner.announce_start()
    assert c.moving and not runner.active
    runner.stop()
    assert runner.state == "stopped" and runner.message == "stopped"
    assert asyncio.run(runner.start("Begin()\nDelay(1)\nEnd()\n")) == []
    assert not runner.running and runner.thread is None and not runner.starting and not c.moving
    assert "program stopped before it started" in [e.text for e in c.log]


def test_a_malformed_status_is_a_reply_error_naming_the_field():
    with pytest.raises(ReplyError, match="angles must be a list of 6"):
        RobotStatus.from_json(dict(STATUS, angles=[1, 2, 3]))
    with pytest.raises(ReplyError, match="expected a STATUS_JSON"):
        parse_query_reply(Queries.status, "PONG|SERIAL=1")


def test_readout_formatting_units():
    assert format_angles([90, -90.1234])[:2] == ["+90.000°", "-90.123°"]
    pose = format_pose([0, 262.574, 288.75, -90, 0, -80])
    assert pose[1] == "+262.57 mm" and pose[3] == "-80.000°" and pose[5] == "-90.000°"  # RX = C, RZ = A
    assert format_loop(RobotStatus.from_json(STATUS).loop).startswith("100 Hz · p50 10.00 ms")
    # fields the controller did not send are left out, not shown as zeros
    assert format_loop(RobotStatus.from_json(dict(STATUS, loop={"rate_hz": 99.5})).loop) == "100 Hz"
    assert format_loop(RobotStatus.from_json(dict(STATUS, loop=None)).loop) == "n/a"


def test_pose_is_labelled_with_the_jog_axes_names():
    # the readout names the orientation as the Cartesian jog does (RX RY RZ)
    assert POSE_LABELS == ("X", "Y", "Z", "RX", "RY", "RZ")
    assert [a.value.rstrip("+-") for a in CartAxis][::2] == list(POSE_LABELS)


def _readout_changes(before, after) -> dict[str, float]:
    """|change| of each rotation readout (deg, across +-180)."""
    b, a = format_pose(before)[3:], format_pose(after)[3:]
    return {name: abs((float(y.rstrip("°")) - float(x.rstrip("°")) + 180) % 360 - 180)
            for name, x, y in zip(POSE_LABELS[3:], b, a)}


@pytest.mark.parametrize("joints", [PAROL6.standby_deg, (90, -80, 150, 0, -70, 180), (30, -60, 140, 40, -30, 100)])
def test_rotation_readouts_follow_the_jog_of_their_name_where_the_convention_says(joints):
    """Issue 22 item 8.  R = Rx(C)·Ry(B)·Rz(A): a WRF RX jog changes RX (= C) alone and a TRF RZ
    jog RZ (= A) alone, at any pose; with the tool pointing down (RX near +-180, RY near 0)
    WRF RY and RZ jogs change RY and RZ most.  Before, RX showed A: a WRF RX jog changed "RZ"."""
    from parolkit.kinematics import fk

    pose = fk(joints)
    rx = _readout_changes(pose, jog_target_pose(pose, Frame.WRF, CartAxis("RX+"), 2.0))
    assert rx["RX"] == pytest.approx(2.0, abs=1e-6) and rx["RY"] < 1e-6 and rx["RZ"] < 1e-6, rx
    rz = _readout_changes(pose, jog_target_pose(pose, Frame.TRF, CartAxis("RZ+"), 2.0))
    assert rz["RZ"] == pytest.approx(2.0, abs=1e-6) and rz["RX"] < 1e-6 and rz["RY"] < 1e-6, rz


def test_with_the_tool_down_every_world_rotation_jog_changes_its_own_readout_most():
    from parolkit.kinematics import fk

    pose = fk((90, -80, 150, 0, -70, 180))  # the tool down, tilted 20 deg: RX 160, RY 0, RZ -90
    for name in ("RX", "RY", "RZ"):
        change = _readout_changes(pose, jog_target_pose(pose, Frame.WRF, CartAxis(name + "+"), 2.0))
        assert max(change, key=lambda k: change[k]) == name, (name, change)


@pytest.mark.parametrize(("status_byte", "summary", "words"), [
    (0x00, "Gripper · not calibrated", "not calibrated"),
    (0x01, "Gripper 100 · moving", "calibrated · moving"),
    (0x31, "Gripper 100 · at its position, no object", "calibrated · at its position, no object"),
    (0x11, "Gripper 100 · holding an object", "holding an object (stopped on it while closing)"),
    (0x21, "Gripper 100 · holding an object", "holding an object (stopped on it while opening)"),
    (0x05, "Gripper 100 · error: timeout", "calibrated · error: timeout"),
    (0x0B, "Gripper 100 · error: E-stop, over-temperature", "error: E-stop, over-temperature"),
])
def test_gripper_status_reads_in_words(status_byte, summary, words):
    g = GripperState(position=100, speed=60, current=600, status_byte=status_byte, object_detection=1)
    assert gripper_summary(g) == summary
    full = format_gripper(g)
    assert full.startswith("position 100 · speed 60 · current 600 mA · ") and words in full
    assert "code" not in full and "object no" not in full


def test_state_badge_priorities():
    st = RobotStatus.from_json(STATUS)
    assert state_badge(st, True) == ("READY", "positive")
    assert state_badge(st, False)[0] == "NO LINK"
    latched = RobotStatus.from_json(dict(STATUS, estop_latched=True, state="ESTOP"))
    assert state_badge(latched, True) == ("E-STOP", "negative")
    assert not latched.can_move
    disabled = RobotStatus.from_json(dict(STATUS, enabled=False, state="DISABLED"))
    assert state_badge(disabled, True)[0] == "DISABLED"


def test_state_badge_says_program_running_or_paused_whatever_the_robot_does_between_lines():
    """Issue 22 item 8: the header follows the program runner, not the robot's MOVING flag
    (READY during a Delay / Output line, READY / MOVING flicker between moves before)."""
    idle, moving = RobotStatus.from_json(STATUS), RobotStatus.from_json(dict(STATUS, state="MOVING"))
    for st in (idle, moving):
        assert state_badge(st, True, "running") == ("PROGRAM RUNNING", "info")
        assert state_badge(st, True, "pausing") == ("PROGRAM RUNNING", "info")  # its move still runs
        assert state_badge(st, True, "paused") == ("PROGRAM PAUSED", "warning")
    # a fault, a latched E-stop, no link or a disabled robot say so first
    latched = RobotStatus.from_json(dict(STATUS, estop_latched=True, state="ESTOP"))
    assert state_badge(latched, True, "running")[0] == "E-STOP"
    assert state_badge(idle, False, "running")[0] == "NO LINK"
    assert state_badge(RobotStatus.from_json(dict(STATUS, enabled=False, state="DISABLED")), True, "paused")[0] \
        == "DISABLED"


# ---- jog logic ----

def test_joint_jog_wire_index_and_command():
    assert jog_command(JointJog.single(2, 1, 30, duration_s=0.2)) == "JOG|2|30|0.2|None"
    assert jog_command(JointJog.single(2, -1, 30, duration_s=0.2)) == "JOG|8|30|0.2|None"
    assert jog_command(JointJog.single(0, 1, 30, distance_deg=5)) == "JOG|0|30|None|5"
    assert jog_command(JointJog((0, 2), (1, -1), (30, 40.5), 0.2)) == "MULTIJOG|0,8|30,40.5|0.2"


@pytest.mark.parametrize("kwargs, msg", [
    (dict(joint=6, direction=1, speed_pct=10), r"joints\[0\] must be an integer 0..5"),
    (dict(joint=0, direction=0, speed_pct=10), r"directions\[0\] must be \+1 or -1"),
    (dict(joint=0, direction=1, speed_pct=120), r"speed_pct\[0\] must be in \(0, 100\]"),
])
def test_bad_jog_is_refused(kwargs, msg):
    with pytest.raises(ParolkitValueError, match=msg):
        JointJog.single(**kwargs, duration_s=0.2)


def test_cart_jog_command_in_both_frames():
    assert jog_command(CartJog(Frame.TRF, CartAxis.RZ_NEG, 50, 0.2)) == "CARTJOG|TRF|RZ-|50|0.2"
    assert jog_command(CartJog(Frame.WRF, CartAxis.X_POS, 5, 0.2)) == "CARTJOG|WRF|X+|5|0.2"


def test_jog_commands_parse_back_to_the_same_jog():
    from parolkit.protocol.commands import parse_datagram

    for jog in (JointJog.single(4, -1, 12.5, duration_s=0.2), JointJog((1, 3), (1, 1), (10, 20), 1.5),
                CartJog(Frame.TRF, CartAxis.RY_POS, 7, 0.3)):
        assert parse_datagram(jog_command(jog)).command.move == jog


def test_jog_buttons_blocked_at_limits_only_in_that_direction():
    lo, hi = PAROL6.safe_limits_deg[0]
    at_upper = [hi, -90, 180, 0, 0, 180]
    assert joint_jog_blocked(at_upper, 0, +1)
    assert not joint_jog_blocked(at_upper, 0, -1)
    at_lower = [lo, -90, 180, 0, 0, 180]
    assert joint_jog_blocked(at_lower, 0, -1) and not joint_jog_blocked(at_lower, 0, +1)
    assert not joint_jog_blocked(PAROL6.standby_deg, 3, 1)


def test_step_target_refuses_leaving_the_range():
    assert joint_step_target(PAROL6.standby_deg, 0, 5)[0] == pytest.approx(95)
    with pytest.raises(ParolkitValueError, match="J5 step to 95.000"):
        joint_step_target(PAROL6.standby_deg, 4, 95)


def test_rpy_matches_pose_convention_and_inverts():
    # R = Rx(C) Ry(B) Rz(A): for A=-90, B=0, C=-90 the tool z axis is the world -y... check by hand
    r = rpy_to_matrix(-90, 0, -90)
    assert r[0] == pytest.approx([0, 1, 0], abs=1e-12)
    for abc in [(10, 20, 30), (-90, 0, -90), (170, -45, 100)]:
        assert matrix_to_rpy(rpy_to_matrix(*abc)) == pytest.approx(abc, abs=1e-9)


def test_wrf_rotation_step_rotates_about_world_axis():
    cmd = cart_step_command([0, 262.57, 288.75, -90, 0, -90], Frame.WRF, CartAxis.RZ_POS, 10, 30)
    fields = cmd.split("|")
    assert fields[0] == "MOVECART" and fields[-2:] == ["None", "30"]
    x, y, z, a, b, c = map(float, fields[1:7])
    assert (x, y, z) == pytest.approx((0, 262.57, 288.75))
    # rotating 10 deg about world Z: new R = Rz(10) R_old
    expect = rpy_to_matrix(-90, 0, -90)
    rz = rpy_to_matrix(10, 0, 0)
    want = [[sum(rz[i][k] * expect[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    got = rpy_to_matrix(a, b, c)
    for i in range(3):
        assert got[i] == pytest.approx(want[i], abs=1e-4)


def test_trf_target_moves_along_the_tool_axis():
    from parolkit.kinematics import fk, ik

    joints = [90, -90, 180, 0, 0, 180]
    pose = fk(joints)
    target = jog_target_pose(pose, Frame.TRF, CartAxis.Z_POS, 10.0)
    # a 10 mm move along the tool z axis = the TCP of the joints solving it moved 10 mm
    q = ik(target, joints)
    moved = fk(q)
    assert math.dist(moved[:3], pose[:3]) == pytest.approx(10.0, abs=1e-3)
    r = rpy_to_matrix(*pose[3:])
    expect = [pose[i] + 10.0 * r[i][2] for i in range(3)]
    assert list(target[:3]) == pytest.approx(expect, abs=1e-9)


def test_cartesian_buttons_grey_where_ik_fails():
    from parolkit.kinematics import fk, ik

    # the arm stretched far out: moving further out along the reach is impossible
    joints = [90, -30, 200, 0, 0, 180]
    pose = fk(joints)
    blocked = {axis: cart_jog_blocked(pose, joints, Frame.WRF, axis, ik) for axis in CartAxis}
    assert not all(blocked.values()), "some direction must stay open"
    standby = list(PAROL6.standby_deg)
    home_pose = fk(standby)
    assert not any(cart_jog_blocked(home_pose, standby, Frame.WRF, a, ik) for a in CartAxis)
    assert not any(cart_jog_blocked(home_pose, standby, Frame.TRF, a, ik) for a in CartAxis)

    def unreachable(pose, seed):
        raise ParolkitValueError("out of reach")

    assert cart_jog_blocked(home_pose, standby, Frame.WRF, CartAxis.X_POS, unreachable)


def test_trf_step_is_relative_tool_move():
    assert cart_step_command([0] * 6, Frame.TRF, CartAxis.Y_NEG, 5, 20) == "MOVECARTRELTRF|0|-5|0|0|0|0|None|20"


def test_keyboard_map_is_unique_and_escape_is_estop():
    assert len({b.key for b in KEYMAP}) == len(KEYMAP)
    assert key_action("Escape").action == "estop"
    b = key_action("Q")
    assert b.action == "joint" and b.joint == 0 and b.direction == 1
    assert key_action("a").direction == -1
    assert key_action("ArrowUp").axis is CartAxis.Y_POS
    assert key_action("z") is None and key_action("") is None


# ---- log, acks, plans ----

def test_event_log_is_bounded_and_timestamped():
    t = iter(range(1000))
    log = EventLog(maxlen=3, clock=lambda: 1_700_000_000 + next(t) / 1000)
    for i in range(5):
        log.info(f"m{i}")
    log.error("boom")
    assert [e.text for e in log] == ["m3", "m4", "boom"]
    assert log.errors()[0].level is Level.ERROR
    assert ".00" in log.tail(1)[0].clock and "ERROR" in log.tail(1)[0].format()
    assert level_of_ack("INVALID") is Level.ERROR and level_of_ack("CANCELLED") is Level.WARNING


def test_the_plan_the_scene_draws_comes_from_the_clients_plan_query():
    plan = parse_query_reply(Queries.plan_info, 'PLAN|{"seq": 3, "command": "MOVEJOINT", '
                             '"target_angles": [1,2,3,4,5,6], "tcp_path": [[1,2,3],[4,5,6]]}')
    assert isinstance(plan, PlanInfo)
    assert plan.target_angles == (1, 2, 3, 4, 5, 6) and len(plan.tcp_path) == 2
    idle = parse_query_reply(Queries.plan_info,
                             'PLAN|{"seq": 0, "command": null, "target_angles": null, "tcp_path": null}')
    assert idle.target_angles is None and idle.tcp_path == ()


# ---- templates and highlighting ----

def test_templates_are_filled_with_current_values():
    line = render_template("MoveJoint", [90, -90, 180, 0, 0, 180], [0] * 6)
    assert line == "MoveJoint(90.000,-90.000,180.000,0.000,0.000,180.000,t=2)"
    assert render_template("MoveCart", [0] * 6, [1, 2, 3, 4, 5, 6]).startswith("MoveCart(1.000,2.000,3.000")
    with pytest.raises(ParolkitValueError, match="unknown template"):
        render_template("Fly", [0] * 6, [0] * 6)


def test_every_template_and_example_parses():
    from parolkit.script import parse

    for t in TEMPLATES:
        if t.name in ("Begin", "End", "Loop"):
            continue
        text = "Begin()\n" + render_template(t.name, PAROL6.standby_deg, [0, 262.57, 288.75, -90, 0, -90]) + "\nEnd()\n"
        assert parse(text).ok, (t.name, parse(text).errors)
    for name, text in SEED_EXAMPLES.items():
        assert parse(text).ok, name


def test_highlighting_tokens():
    text = "MoveJoint(1.5,-2,t=3) // go\nOutput(1,HIGH)"
    kinds = [(t.kind, text[t.start:t.end]) for t in tokenize(text)]
    assert (TokenKind.COMMAND, "MoveJoint") in kinds and (TokenKind.NUMBER, "-2") in kinds
    assert (TokenKind.PARAM, "t=") in kinds and (TokenKind.COMMENT, "// go") in kinds
    assert (TokenKind.KEYWORD, "HIGH") in kinds
    marks = mark_decorations(text)
    assert all(m["kind"] == "mark" and m["from"] < m["to"] for m in marks)


def test_line_decorations_mark_current_and_error_lines():
    decos = line_decorations("a\nb\nc", current_line=2, error_lines={3: "bad", 9: "beyond"})
    assert {"kind": "line", "line": 2, "class": "rbt-current"} in decos
    assert {"kind": "line", "line": 3, "class": "rbt-error"} in decos
    assert all(d["line"] <= 3 for d in decos)


# ---- geometry ----

def test_dh_frames_reach_the_documented_tcp():
    f = geometry.dh_frames([90, -90, 180, 0, 0, 180])
    assert [f[7][i][3] * 1000 for i in range(3)] == pytest.approx([0, 262.57, 288.75], abs=0.01)
    f = geometry.dh_frames([0, -90, 180, 0, 0, 180])
    assert [f[7][i][3] * 1000 for i in range(3)] == pytest.approx([262.57, 0, 288.75], abs=0.01)


def test_dh_frames_match_the_fk_reference_data():
    from pathlib import Path

    ref = json.loads((Path(__file__).resolve().parents[1] / "data" / "fk_reference.json").read_text())
    for case in ref["cases"]:
        f = geometry.dh_frames(case["joints_deg"])
        for i in range(3):
            assert f[7][i] == pytest.approx(case["tcp_matrix"][i], abs=1e-6)


def test_arm_solids_come_from_the_dh_table():
    solids = geometry.arm_solids()
    links = [s for s in solids if s.role == "link"]
    # every non-zero d and a of rows 1..5 gives one link cylinder with that length
    expected = sorted(abs(v) for row in PAROL6.dh[:5] for v in (row.d, row.a) if abs(v) > 1e-6)
    assert sorted(round(s.length, 6) for s in links) == pytest.approx(expected)
    tool = [s for s in solids if s.role == "tool" and s.shape == "cylinder"]
    assert sorted(round(s.length, 5) for s in tool) == pytest.approx(sorted([0.0628, 0.04525]))
    assert all(0 <= s.frame < geometry.N_FRAMES for s in solids)


def test_cylinder_rotation_maps_y_onto_segment():
    s = geometry.Solid(0, "cylinder", (0, 0, 0), (0.1, 0, 0), radius=0.01)
    r = s.rotation_y_to_axis()
    assert [r[i][1] for i in range(3)] == pytest.approx([1, 0, 0], abs=1e-12)
    s = geometry.Solid(0, "cylinder", (0, 0, 0), (0, 0, -0.1), radius=0.01)
    r = s.rotation_y_to_axis()
    assert [r[i][1] for i in range(3)] == pytest.approx([0, 0, -1], abs=1e-12)
    det = (r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
           + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]))
    assert math.isclose(det, 1.0, abs_tol=1e-12)


# ---- CLI ----

def test_gui_cli_flags_parse():
    import argparse

    from parolkit.gui import cli

    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    cli.register(sub, "gui")
    args = parser.parse_args(["gui", "--connect", "10.0.0.2:5001", "--http-port", "9000", "--no-browser"])
    assert args.connect == ("10.0.0.2", 5001) and args.http_port == 9000 and args.no_browser
    args = parser.parse_args(["gui", "--port", "/dev/ttyACM0"])
    assert args.port == "/dev/ttyACM0" and not args.sim and args.func is cli.main
    with pytest.raises(SystemExit):
        parser.parse_args(["gui", "--sim", "--port", "/dev/ttyACM0"])  # mutually exclusive


@pytest.mark.parametrize("text, msg", [
    ("localhost", "needs HOST:PORT"),
    ("host:abc", "integer 1..65535"),
    ("host:70000", "in 1..65535"),
])
def test_connect_address_errors_are_precise(text, msg):
    import argparse

    from parolkit.gui.cli import parse_host_port

    with pytest.raises(argparse.ArgumentTypeError, match=msg):
        parse_host_port(text)


def test_geometry_frames_agree_with_the_kinematics_package():
    import numpy as np

    from parolkit.kinematics import fk_frames

    for q in ([90, -90, 180, 0, 0, 180], [95, -89, 179.5, -31, -4, 202], [-100, -120, 250, 80, 60, 20]):
        assert np.allclose(np.array(geometry.dh_frames(q)), fk_frames(q), atol=1e-12)


# ---- the controller link (a thin layer over AsyncRobot), against a real UDP socket ----

def test_controller_link_logs_acks_tracks_the_plan_and_survives_bad_data_and_restarts():
    import asyncio
    import socket
    import time

    from tests.unit.test_client import STATUS_OBJECT, FakeController

    from parolkit.gui.link import ControllerLink

    fake = FakeController()

    async def until(cond, timeout=2.0, what="condition"):
        deadline = time.monotonic() + timeout
        while not cond():
            assert time.monotonic() < deadline, f"timed out waiting for {what}"
            await asyncio.sleep(0.01)

    async def main():
        events = EventLog()
        link = ControllerLink("127.0.0.1", fake.port, fake.ack_port, every_n_ticks=2, event_log=events)
        lines = lambda: [e.text for e in events.tail(200)]  # noqa: E731
        await link.start()
        try:
            # the fake answers SUBSCRIBE with its cookie and the echo with three statuses
            # (plan_seq 7): link up, plan fetched
            await until(lambda: link.link_up and link.plan is not None, what="link up and plan")
            assert link.status.seq == 2 and link.plan.command == "MOVECART" and len(link.history) == 3
            sub_port = link._sub.port
            assert f"SUBSCRIBE|{sub_port}|2" in fake.received and "ACK_HERE" in fake.received
            # acks come back to the link's own socket (ACK_HERE) and are logged by label
            fake.acks["MOVEPOSE"] = [("QUEUED", ""), ("FAILED", "IK failed: out of reach")]
            cid = link.send("MOVEPOSE|0|250|200|-90|0|-90|2|None", label="step X +5 mm")
            assert len(cid) == 8
            await until(lambda: "step X +5 mm failed: IK failed: out of reach" in lines(), what="failure logged")
            fake.acks["JOG"] = [("COMPLETED", "")]
            link.send("JOG|0|30|0.2|None", label="jog", quiet=True)  # quiet success: no line
            fake.acks["CARTJOG"] = [("INVALID", "speed% = 150 % is out of range")]
            link.send("CARTJOG|WRF|X+|150|0.2", label="jog", quiet=True)  # quiet refusal: logged
            await until(lambda: any(m.startswith("jog invalid") for m in lines()), what="refusal logged")
            assert "jog completed" not in lines()
            # one bad datagram is reported once; the next good status is taken
            # (from the controller's own address: the link's sockets are connected to it, so a
            # datagram from anywhere else never reaches them)
            junk = fake.sock
            count = link.status_count
            for _ in range(2):
                junk.sendto(b"STATUS_JSON|{oops", ("127.0.0.1", sub_port))
            junk.sendto(("STATUS_JSON|" + json.dumps(dict(STATUS_OBJECT, seq=99))).encode(),
                        ("127.0.0.1", sub_port))
            await until(lambda: link.status_count > count, what="the good status after the bad ones")
            assert link.status.seq == 99
            assert sum(m.startswith("bad status datagram") for m in lines()) == 1
            # the controller goes quiet: link lost, SUBSCRIBE + ACK_HERE retried every 0.25 s ...
            fake.silent = True
            await until(lambda: "controller link lost: no status for 1 s" in lines(), timeout=3,
                        what="link lost")
            assert not link.link_up
            fake.received.clear()
            await asyncio.sleep(0.8)
            assert fake.received.count(f"SUBSCRIBE|{sub_port}|2|{fake.COOKIE}") >= 2 and "ACK_HERE" in fake.received
            # ... so a restarted controller is picked up again at once
            fake.silent = False
            await until(lambda: link.link_up, what="link up again")
            assert sum(m.startswith("controller link up") for m in lines()) == 2
        finally:
            await link.close()
        assert fake.wait_for("UNSUBSCRIBE")[0] == f"UNSUBSCRIBE|{sub_port}"

    try:
        asyncio.run(main())
        # the link never occupied the controller's fixed ack port: it is free to bind
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind(("127.0.0.1", fake.ack_port))
    finally:
        fake.close()


def test_link_tasks_are_cancelled_again_until_they_end():
    """A task that swallows a cancellation (as asyncio.wait_for can on Python 3.11) still ends,
    and one that never ends does not hold the caller beyond the limit."""
    import asyncio

    from parolkit.gui.link import _cancel_all

    async def main():
        swallowed = []

        async def stubborn():
            while True:
                try:
                    await asyncio.sleep(10)
                except asyncio.CancelledError:
                    if not swallowed:
                        swallowed.append(True)  # the race: carry on as if nothing happened
                        continue
                    raise

        released = []

        async def immortal():  # ignores every cancellation until the test releases it
            while not released:
                try:
                    await asyncio.sleep(10)
                except asyncio.CancelledError:
                    continue

        a = asyncio.ensure_future(stubborn())
        await asyncio.sleep(0)
        await asyncio.wait_for(_cancel_all([a]), 2)
        assert a.cancelled() and swallowed
        b = asyncio.ensure_future(immortal())
        await asyncio.sleep(0)
        t0 = asyncio.get_running_loop().time()
        await _cancel_all([b], limit_s=0.3)
        assert not b.done() and asyncio.get_running_loop().time() - t0 < 2
        released.append(True)
        b.cancel()
        await asyncio.wait([b], timeout=2)
        assert b.done()

    asyncio.run(main())


def test_the_link_logs_uncommanded_motion_and_throttles_implausible_frames():
    from parolkit.gui.link import ControllerLink

    events = EventLog()
    link = ControllerLink("127.0.0.1", 9, 9, event_log=events)

    def status(implausible: int, uncommanded: int, last: str | None = None) -> RobotStatus:
        return RobotStatus.from_json(dict(STATUS, integrity={
            "implausible": implausible, "uncommanded": uncommanded, "status_age_ms": 0.0, "last": last}))

    link._log_transitions(status(0, 0), status(3, 0))
    link._log_transitions(status(3, 0), status(9, 0))  # within 5 s of the first line: not logged
    link._log_transitions(status(9, 0), status(9, 1, "J2 moved 1520 steps while idle"))
    lines = [(e.level, e.text) for e in events.tail(10)]
    assert (Level.WARNING, "board link: 3 status frame(s) ignored as implausible (corrupted?), 3 in all") in lines
    assert not any("9 in all" in t for _, t in lines)
    assert (Level.ERROR, "uncommanded motion #1, robot disabled: J2 moved 1520 steps while idle") in lines
    link._implausible_logged = (3, -1e9)  # 5 s later
    link._log_transitions(status(9, 1), status(12, 1))
    assert events.tail(1)[0].text == "board link: 9 status frame(s) ignored as implausible (corrupted?), 12 in all"
