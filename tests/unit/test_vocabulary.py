"""One vocabulary: the words of motion (profiles, tracking modes, frames, planes, timing modes,
Cartesian jog axes) and the move value objects are defined once, in ``parolkit.moves``.

* Every layer uses those very objects (protocol, motion, RBTscript, GUI);
* the standard-library client keeps copies (it may not import the package): each copy agrees
  with its original, word for word;
* ``parolkit.moves`` stays import-light: the controller's start-up path parses datagrams
  without loading numpy-heavy motion code;
* no two classes of the package share a name unless they are the same thing (the explicit
  list below says which and why).
"""

from __future__ import annotations

import ast
import dataclasses
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

from parolkit import moves
from parolkit.client import core as client_core
from parolkit.client import robot_api
from parolkit.controller import snapshot as controller_state
from parolkit.protocol import commands as protocol
from parolkit.protocol.frames import BoardCommand

PACKAGE = Path(moves.__file__).resolve().parent


def _words(enum: type) -> tuple[str, ...]:
    return tuple(member.value for member in enum)


# ---- the stdlib client's copies agree with the originals ----------------------------------

@pytest.mark.parametrize("copy, original", [
    (robot_api.PROFILES, moves.Profile),
    (robot_api.TRACKING_MODES, moves.Tracking),
    (robot_api.FRAMES, moves.Frame),
    (robot_api.PLANES, moves.Plane),
    (robot_api.TIMING_MODES, moves.Timing),
    (robot_api.CARTESIAN_AXES, moves.CartAxis),
], ids=["PROFILES", "TRACKING_MODES", "FRAMES", "PLANES", "TIMING_MODES", "CARTESIAN_AXES"])
def test_robot_api_word_lists_are_the_vocabulary_words_in_order(copy, original):
    assert tuple(copy) == _words(original)


def test_robot_api_blend_segment_types_are_the_protocols():
    assert tuple(robot_api.SEGMENT_TYPES) == tuple(protocol.BLEND_SEGMENT_KINDS)


def test_robot_api_path_point_limit_is_the_moves():
    assert robot_api.MAX_PATH_POINTS == moves.MAX_PATH_POINTS


def test_robot_api_blend_limit_is_the_moves():
    assert robot_api.MAX_BLEND == moves.MAX_BLEND


def test_robot_api_terminal_statuses_are_the_protocols_terminal_acks():
    assert robot_api.TERMINAL_STATUSES == {s.value for s in protocol.AckStatus if s.terminal}


@pytest.mark.parametrize("copy, original", [
    (client_core.AckStatus, protocol.AckStatus),
    (client_core.RobotState, controller_state.RobotState),
], ids=["AckStatus", "RobotState"])
def test_client_core_enums_have_the_originals_names_and_wire_values(copy, original):
    assert [(m.name, m.value) for m in copy] == [(m.name, m.value) for m in original]


def test_client_ack_status_agrees_on_which_statuses_are_terminal():
    assert [s.terminal for s in client_core.AckStatus] == [s.terminal for s in protocol.AckStatus]


def test_client_board_info_has_every_field_of_the_controllers():
    ours = {f.name for f in dataclasses.fields(client_core.BoardInfo)}
    theirs = {f.name for f in dataclasses.fields(controller_state.BoardInfo)}
    assert theirs <= ours, f"client BoardInfo lacks {sorted(theirs - ours)}"


def test_tracking_streams_the_board_commands_of_the_frame_codec():
    assert moves.Tracking.POSITION.board_command == BoardCommand.GOTO
    assert moves.Tracking.SPEED.board_command == BoardCommand.JOG


# ---- one definition, used by every layer ----------------------------------------------------

def test_protocol_motion_script_and_gui_use_the_same_enum_objects():
    import parolkit.gui.jog as gui_jog
    import parolkit.motion as motion
    import parolkit.script as script

    for name in ("Profile", "Tracking", "Frame", "Plane", "Timing", "CartAxis"):
        original = getattr(moves, name)
        assert getattr(protocol, name) is original, f"protocol.{name}"
        if hasattr(motion, name):
            assert getattr(motion, name) is original, f"motion.{name}"
    assert script.Profile is moves.Profile and script.Tracking is moves.Tracking
    assert gui_jog.Frame is moves.Frame and gui_jog.CartAxis is moves.CartAxis


def test_motion_reexports_the_move_value_objects_themselves():
    import parolkit.motion as motion

    for name in ("JointMove", "PoseMove", "CartMove", "CartRelTRFMove", "SpeedJointMove", "JointJog",
                 "CartJog", "CircleMove", "ArcCenterMove", "ArcParamMove", "HelixMove", "SplineMove",
                 "LineSegment", "BlendMove"):
        assert getattr(motion, name) is getattr(moves, name), name


def test_a_datagram_and_a_program_line_carry_equal_moves():
    from parolkit.script import parse

    datagram = protocol.parse_datagram("MOVEJOINT|90|-90|180|0|0|180|None|50|30|trap|speed").command
    line = parse("MoveJoint(90, -90, 180, 0, 0, 180, v=50, a=30, trap, speed)").unwrap().commands[0]
    assert datagram.move == line.move
    datagram = protocol.parse_datagram("MOVECART|0|250|200|180|0|0|None|50|r=10").command
    line = parse("MoveCart(0, 250, 200, 180, 0, 0, v=50, r=10)").unwrap().commands[0]
    assert datagram.move == line.move and line.move.blend == 10.0


def test_the_vocabulary_imports_no_numpy_and_protocol_parsing_no_motion():
    code = (
        "import sys\n"
        "import parolkit.moves\n"
        "assert 'numpy' not in sys.modules, 'parolkit.moves imported numpy'\n"
        "from parolkit.protocol.commands import parse_datagram\n"
        "parse_datagram('SMOOTH_CIRCLE|0,250,150|20|XY|WRF|CURRENT|DURATION|3|0')\n"
        "heavy = sorted(m for m in sys.modules if m.startswith(('parolkit.motion', 'parolkit.kinematics')))\n"
        "assert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_the_stdlib_client_imports_nothing_else_of_the_package():
    code = (
        "import sys\n"
        "import parolkit.client.robot_api, parolkit.client.core\n"
        "assert 'numpy' not in sys.modules, 'the client imported numpy'\n"
        "others = sorted(m for m in sys.modules if m.startswith('parolkit.') and\n"
        "                not m.startswith('parolkit.client') and m != 'parolkit.errors')\n"
        "assert not others, others\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


# ---- no two classes with the same name for different things -------------------------------

#: Names defined in more than one module on purpose, with the modules and the reason.  A new
#: duplicate fails the test below; so does an entry here that is no longer a duplicate.
SAME_THING_TWICE: dict[str, tuple[frozenset[str], str]] = {
    # the standard-library client's copies (it may not import the package; checked above)
    "AckStatus": (frozenset({"parolkit.protocol.commands", "parolkit.client.core"}),
                  "the client's copy of the ack statuses"),
    "RobotState": (frozenset({"parolkit.controller.snapshot", "parolkit.client.core"}),
                   "the client's copy of the controller states"),
    "BoardInfo": (frozenset({"parolkit.controller.snapshot", "parolkit.client.core"}),
                  "the status's board object, as the controller sends it and as the client reads it"),
    "GripperState": (frozenset({"parolkit.board.gripper", "parolkit.client.core"}),
                     "the SSG-48's state, inside the emulated board and as the controller reports it"),
    # one command in its two notations: a datagram and a program line (the move statements of
    # both carry the same parolkit.moves value object)
    **{name: (frozenset({"parolkit.protocol.commands", "parolkit.script.program"}),
              "one command as a datagram and as an RBTscript line")
       for name in ("Command", "Delay", "Home", "MoveJoint", "MovePose", "MoveCart",
                    "MoveCartRelTRF", "SpeedJoint")},
}


def _class_modules() -> dict[str, set[str]]:
    found: dict[str, set[str]] = defaultdict(set)
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        module = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.ClassDef):
                found[node.name].add(module)
    return found


def test_no_two_classes_share_a_name_unless_they_are_the_same_thing():
    dupes = {name: mods for name, mods in _class_modules().items() if len(mods) > 1}
    unexpected = {n: sorted(m) for n, m in dupes.items()
                  if n not in SAME_THING_TWICE or SAME_THING_TWICE[n][0] != m}
    assert not unexpected, f"classes with the same name in several modules: {unexpected}"
    gone = sorted(set(SAME_THING_TWICE) - set(dupes))
    assert not gone, f"no longer duplicated, remove from SAME_THING_TWICE: {gone}"
