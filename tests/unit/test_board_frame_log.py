"""The board-sim frame log: which command frames arrived, when (monotonic) and with what code."""

from __future__ import annotations

import json

import pytest

from parolkit.board import BoardEmulator
from parolkit.board.control_channel import execute_control
from parolkit.board.pty_server import FRAME_QUERY_MAX, FrameLog, PtyBoardServer
from parolkit.errors import ParolkitValueError
from parolkit.protocol import BoardCommand, CommandFrame


def frame(cmd: BoardCommand) -> bytes:
    return CommandFrame(command=cmd).encode()


def test_frames_split_across_reads_and_wrapped_in_garbage_are_recorded_once_with_their_time():
    log = FrameLog(10)
    enable, disable = frame(BoardCommand.ENABLE), frame(BoardCommand.DISABLE)
    log.feed(b"\x00garbage\xff\xff" + enable[:20], 1.0)
    assert log.total == 0
    log.feed(enable[20:] + disable[:55], 2.0)  # the ENABLE completes at t=2
    log.feed(disable[55:] + b"\xff\xff\xff\x10junk", 3.0)
    got = log.query()["frames"]
    assert got == [[1, 2.0, 101], [2, 3.0, 102]]


def test_a_full_log_keeps_the_newest_frames_and_says_which_is_the_oldest():
    log = FrameLog(3)
    for i in range(5):
        log.feed(frame(BoardCommand.IDLE), float(i))
    r = log.query()
    assert r["total"] == 5 and r["oldest"] == 3 and r["size"] == 3
    assert [f[0] for f in r["frames"]] == [3, 4, 5]


def test_query_filters_by_time_sequence_last_and_limit():
    log = FrameLog(100)
    for i in range(10):
        log.feed(frame(BoardCommand.GOTO if i < 6 else BoardCommand.DISABLE), 100.0 + i * 0.01)
    assert [f[0] for f in log.query(since=100.045)["frames"]] == [6, 7, 8, 9, 10]
    assert [f[0] for f in log.query(after=8)["frames"]] == [9, 10]
    assert [f[0] for f in log.query(last=2)["frames"]] == [9, 10]
    r = log.query(since=100.0, limit=3)
    assert [f[0] for f in r["frames"]] == [2, 3, 4] and r["more"] is True
    assert log.query(after=10) == {"size": 100, "total": 10, "oldest": 1, "more": False, "frames": []}
    with pytest.raises(ParolkitValueError, match="limit"):
        log.query(limit=FRAME_QUERY_MAX + 1)
    with pytest.raises(ParolkitValueError, match="size"):
        FrameLog(0)


def test_frames_control_command_answers_json_and_names_bad_arguments():
    emu = BoardEmulator(clock="virtual")
    log = FrameLog(10)
    log.feed(frame(BoardCommand.ENABLE), 5.0)
    reply = execute_control(emu, "frames since=4.5", frame_log=log)
    assert reply.startswith("ok ")
    assert json.loads(reply[3:])["frames"] == [[1, 5.0, 101]]
    assert "frame log is off" in execute_control(emu, "frames")
    assert "--frame-log" in execute_control(emu, "frames")
    for bad, words in [("frames since=nan", "since"), ("frames after=-1", "after"),
                       ("frames last=x", "last"), ("frames limit=0", "limit"), ("frames 5", "since=S")]:
        r = execute_control(emu, bad, frame_log=log)
        assert r.startswith("error:") and words in r, (bad, r)


def test_pty_server_checks_the_frame_log_size(tmp_path):
    with pytest.raises(ParolkitValueError, match="frame_log_size"):
        PtyBoardServer(BoardEmulator(clock="virtual"), tmp_path / "p6", frame_log_size=-1)
    assert PtyBoardServer(BoardEmulator(clock="virtual"), tmp_path / "p6").frame_log is None
