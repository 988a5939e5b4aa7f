"""`parolkit board-sim --frame-log N` on a real pty: another process learns which command frames
the board received and when (CLOCK_MONOTONIC, the same clock in every process)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import serial

from parolkit.board.control_channel import send_control
from parolkit.client.launch import die_with_parent
from parolkit.protocol import BoardCommand, CommandFrame, StatusParser

REPO = Path(__file__).resolve().parents[2]


def test_board_sim_frame_log_reports_each_received_frame_with_its_monotonic_receive_time(tmp_path):
    link = tmp_path / "p6"
    proc = subprocess.Popen(
        [sys.executable, "-m", "parolkit", "board-sim", "--link", str(link), "--frame-log", "100"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO, preexec_fn=die_with_parent)
    try:
        deadline = time.monotonic() + 10.0
        while not link.exists() and time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.02)
        ser = serial.Serial(str(link), 3_000_000, timeout=0)
        parser = StatusParser()
        sent = []
        for cmd in (BoardCommand.ENABLE, BoardCommand.GOTO, BoardCommand.DISABLE):
            before = time.monotonic()
            ser.write(b"\x00\xff" + CommandFrame(command=cmd).encode())  # junk first: not a frame
            end = time.monotonic() + 2.0
            while not parser.feed(ser.read(4096)):  # the reply proves the board has the frame
                assert time.monotonic() < end, "no reply from board-sim"
                time.sleep(0.001)
            sent.append((before, time.monotonic(), int(cmd)))
        reply = send_control(f"{link}.ctl", f"frames since={sent[0][0] - 0.001:.6f}")
        assert reply.startswith("ok "), reply
        got = json.loads(reply[3:])
        assert [f[2] for f in got["frames"]] == [101, 156, 102]
        assert [f[0] for f in got["frames"]] == [1, 2, 3] and got["total"] == 3
        for (before, after, _), (_, t, _) in zip(sent, got["frames"]):
            assert before <= t <= after
        last = json.loads(send_control(f"{link}.ctl", "frames last=1")[3:])["frames"]
        assert last == got["frames"][-1:]
        ser.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
