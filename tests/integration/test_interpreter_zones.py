"""The interpreter's check before a run uses the controller's collision world (issue 25, part 3):
against a real controller process (``parolkit serve --sim --config`` with a box zone and a
tool with a shape), over UDP.

* A program whose third line drives into the config's box is refused at line 3 (and 4, which
  swings back through it), naming the pair, before anything moves: no command reaches the
  controller (its plan counter and the joints stay as they were).  Before, the check knew
  only the default table, and the program ran until the controller refused line 3.
* The tool's shape counts: with the pen selected, a move that takes the pen (not the arm) into
  the table is refused at its line.
* A controller that does not answer ``GET_ZONES`` (an older one): the check falls back to the
  default table with a warning in the result; the controller still refuses the move itself.
"""

from __future__ import annotations

import re

import pytest

from conftest import start_controller
from parolkit.client.core import Queries, ZonesInfo, parse_query_reply
from parolkit.client.robot import Robot
from parolkit.collision import BoxZone
from parolkit.script import Interpreter, InterpreterState, parse

STANDBY = [90.0, -90.0, 180.0, 0.0, 0.0, 180.0]
CONFIG = """
[[zones]]
name = "monitor"
kind = "box"
center = [141, 141, 334]
size = [40, 40, 40]
margin = 10

[tools.pen]
pose = [0, 0, 150, 0, 0, 0]
shape = { radius = 8 }
"""
#: line 3 swings J1 from 80 to 0 deg: the wrist goes through the box at 45 deg
SWING = ("Begin()\n"
         "MoveJoint(80, -90, 180, 0, 0, 180, t=1.5)\n"
         "MoveJoint(0, -90, 180, 0, 0, 180, t=4)\n"
         "MoveJoint(90, -90, 180, 0, 0, 180, t=4)\n"
         "End()\n")
#: line 3 takes the wrist low in front of the arm, the flange pointing down: clear for the arm,
#: not for a 150 mm pen
LOW_WRIST = ("Begin()\n"
             "MoveJoint(90, -90, 180, 0, 0, 180, t=1)\n"
             "MoveJoint(90, -20, 200, 0, -60, 180, t=4)\n"
             "End()\n")


@pytest.fixture(scope="module")
def controller(tmp_path_factory):
    root = tmp_path_factory.mktemp("interp-zones")
    cfg = root / "zones.toml"
    cfg.write_text(CONFIG)
    cp = start_controller(["--config", str(cfg)], log_dir=root)
    try:
        yield cp
    finally:
        cp.stop()


@pytest.fixture
def robot(controller):
    with Robot(controller.host, controller.port, ack_port=0, timeout=2.0) as r:
        r.take_control(force=True)
        r.set_tool("default")
        if max(abs(a - b) for a, b in zip(r.angles(), STANDBY)) > 0.05:
            r.move_joints(STANDBY, duration=3.0, timeout=30)
        yield r
        r.release_control()


def _program(text: str):
    return parse(text, "prog.rbt").unwrap()


def test_a_program_into_the_controllers_box_is_refused_at_line_3_before_anything_moves(robot):
    before_angles = robot.angles()
    before_plan = robot.status().plan_seq
    it = Interpreter(_program(SWING), robot)
    result = it.run()
    assert result.state is InterpreterState.FAILED and result.commands_executed == 0, result.message
    assert [e.line for e in result.errors] == [3, 4]  # (and line 4 swings back through it)
    assert re.match(r"MoveJoint would collide: J\d link vs zone 'monitor' at \d+\.\d\d s into the move \(",
                    result.errors[0].message), result.errors[0].message
    assert not any("GET_ZONES" in w.message for w in result.warnings)
    # the check used the controller's world, and nothing reached the controller
    monitor = BoxZone("monitor", (141, 141, 334), (40, 40, 40), margin=10)
    assert it.collision is not None and monitor in it.collision.zones
    st = robot.status()
    assert st.plan_seq == before_plan and st.command is None and st.queue == 0
    assert max(abs(a - b) for a, b in zip(robot.angles(), before_angles)) < 0.01


def test_the_selected_tools_shape_is_checked_too(robot):
    robot.set_tool("pen")
    try:
        result = Interpreter(_program(LOW_WRIST), robot).run()
    finally:
        robot.set_tool("default")
    assert result.state is InterpreterState.FAILED and result.commands_executed == 0, result.message
    assert [e.line for e in result.errors] == [3]
    assert result.errors[0].message.startswith("MoveJoint would collide: tool 'pen' vs zone 'table' at ")
    # without the pen the same program is clear (and runs)
    result = Interpreter(_program(LOW_WRIST), robot).run()
    assert result.ok, result.message


class _OlderController(Robot):
    """A client of a controller that does not know GET_ZONES: the answer an older parolkit
    controller gives to a query it does not know, through the client's own reply parser."""

    def zones(self) -> ZonesInfo:  # type: ignore[override]
        return parse_query_reply(Queries.zones, "ERROR|unknown command 'GET_ZONES'")


def test_without_get_zones_the_check_falls_back_to_the_table_with_a_warning(controller):
    with _OlderController(controller.host, controller.port, ack_port=0, timeout=2.0) as robot:
        robot.take_control(force=True)
        try:
            robot.move_joints(STANDBY, duration=3.0, timeout=30)
            it = Interpreter(_program(SWING), robot)
            result = it.run()
        finally:
            robot.move_joints(STANDBY, duration=3.0, timeout=30)
            robot.release_control()
    assert it.collision is None
    warned = [w for w in result.warnings if "GET_ZONES" in w.message]
    assert len(warned) == 1 and "default table only" in warned[0].message, result.warnings
    # the check let it through (the table alone): line 2 ran, and the controller itself refused line 3
    assert result.state is InterpreterState.FAILED and result.commands_executed >= 1, result.errors
    assert [e.line for e in result.errors] == [3]
    assert "would collide: J" in result.errors[0].message and "zone 'monitor'" in result.errors[0].message
    assert not result.errors[0].message.startswith("MoveJoint would collide")  # the controller's words
