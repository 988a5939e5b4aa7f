"""The board-sim control channel: text commands change the emulated board."""

from __future__ import annotations

import json
import os
import tempfile

import pytest

from parolkit.board import BoardEmulator
from parolkit.board.control_channel import ControlError, ControlServer, execute_control, send_control
from parolkit.errors import ParolkitValueError


@pytest.fixture
def emu() -> BoardEmulator:
    return BoardEmulator(clock="virtual", gripper_calibration_s=0.0)


def test_estop_and_inputs_commands_set_the_board_inputs(emu):
    assert execute_control(emu, "estop 1") == "ok"
    assert execute_control(emu, "in1 1") == "ok"
    assert execute_control(emu, "in2 0") == "ok"
    assert emu.estop_pressed and emu.inputs == (True, False)
    assert execute_control(emu, "estop 0") == "ok" and not emu.estop_pressed


def test_object_command_places_and_removes_an_object(emu):
    assert execute_control(emu, "object 30") == "ok"
    assert emu.gripper.object_width_mm == 30.0
    assert execute_control(emu, "object none") == "ok"
    assert emu.gripper.object_width_mm is None


def test_errors_commands_inject_and_clear_error_bits(emu):
    assert execute_control(emu, "errors temp J3 J4") == "ok"
    assert execute_control(emu, "errors pos j1") == "ok"
    assert emu.error_injection == (0x20 | 0x10, 0x80)
    assert execute_control(emu, "errors clear") == "ok"
    assert emu.error_injection == (0, 0)


def test_faults_unplug_replug_and_powercycle_commands(emu):
    assert execute_control(emu, "faults drop=0.5 corrupt=0.01 delay=0.02 dir=to_board") == "ok"
    to_board, from_board = emu.faults
    assert (to_board.drop_rate, to_board.corrupt_rate, to_board.delay_s) == (0.5, 0.01, 0.02)
    assert not from_board.active
    assert execute_control(emu, "faults silent=1") == "ok" and emu.faults[0].silent
    assert execute_control(emu, "faults clear") == "ok" and not emu.faults[0].active
    assert execute_control(emu, "unplug") == "ok" and not emu.plugged
    assert execute_control(emu, "replug") == "ok" and emu.plugged
    assert execute_control(emu, "powercycle") == "ok" and emu.homed == 0x03


def test_status_returns_json_with_positions_and_io(emu):
    reply = execute_control(emu, "status")
    assert reply.startswith("ok ")
    state = json.loads(reply[3:])
    assert state["positions"] == [0] * 6 and state["io"] == 0x0F and state["homed"] == 3


@pytest.mark.parametrize(
    "text, words",
    [
        ("", "empty"),
        ("fly", "unknown command 'fly'"),
        ("estop", "one argument"),
        ("estop maybe", "expected 0 or 1"),
        ("object wide", "number of mm"),
        ("object 99", "out of range"),
        ("errors temp J9", "J9"),
        ("errors", "usage"),
        ("faults drop=2", "drop_rate"),
        ("faults drop", "key=value"),
        ("faults speed=3", "unknown faults key"),
        ("faults dir=up", "direction"),
        ("unplug now", "no arguments"),
    ],
)
def test_bad_control_commands_get_an_error_reply_naming_the_problem(emu, text, words):
    reply = execute_control(emu, text)
    assert reply.startswith("error:") and words in reply


def test_control_server_answers_over_a_unix_datagram_socket(emu):
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "board.ctl")
        with ControlServer(emu, path):
            assert send_control(path, "in2 1") == "ok"
            assert emu.inputs == (False, True)
            assert send_control(path, "nonsense").startswith("error:")
        assert not os.path.exists(path)


def test_send_control_without_a_server_raises_control_error():
    with tempfile.TemporaryDirectory() as d:
        with pytest.raises(ControlError, match="no board-sim control socket"):
            send_control(os.path.join(d, "missing.ctl"), "status")
    with pytest.raises(ParolkitValueError, match="text"):
        send_control("/tmp/x.ctl", "  ")


def test_pty_and_control_servers_check_their_arguments(tmp_path):
    from parolkit.board import PtyBoardServer

    with pytest.raises(ParolkitValueError, match="emulator"):
        PtyBoardServer("board", tmp_path / "p6")  # type: ignore[arg-type]
    with pytest.raises(ParolkitValueError, match="link_path"):
        PtyBoardServer(BoardEmulator(clock="virtual"), "")
    with pytest.raises(ParolkitValueError, match="does not exist"):
        PtyBoardServer(BoardEmulator(clock="virtual"), tmp_path / "missing" / "p6")
    with pytest.raises(ParolkitValueError, match="emulator"):
        ControlServer(None, tmp_path / "c.ctl")  # type: ignore[arg-type]
    regular = tmp_path / "file.ctl"
    regular.write_text("x")
    with pytest.raises(ControlError, match="not a socket"):
        ControlServer(BoardEmulator(clock="virtual"), regular).start()


def test_control_server_replaces_a_stale_socket_but_not_a_live_one(tmp_path):
    import socket

    emu = BoardEmulator(clock="virtual")
    stale = tmp_path / "stale.ctl"
    s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    s.bind(str(stale))
    s.close()  # the file stays, nobody listens
    with ControlServer(emu, stale):
        assert send_control(stale, "estop 1") == "ok"
        with pytest.raises(ControlError, match="already answers"):
            ControlServer(emu, stale).start()
