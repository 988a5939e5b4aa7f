"""The emulated board on a real pty, driven by plain pyserial (issue 2's acceptance checks)."""

from __future__ import annotations

import math
import os
import select
import signal
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import serial

from parolkit.board import BoardEmulator, PtyBoardServer
from parolkit.client.launch import die_with_parent
from parolkit.protocol import BoardCommand, CommandFrame, StatusFrame, StatusParser
from parolkit.protocol.frames import STATUS_FRAME_SIZE, TIMER_HZ
from parolkit.transport import LinkLostError, SerialTransport

STANDBY = (10240, -32000, 57905, 0, 0, 32000)
REPO = Path(__file__).resolve().parents[2]


def _replies(read: Callable[[], bytes], fd: int | None, parser: StatusParser, timeout: float = 5.0
             ) -> list[StatusFrame]:
    """The status frames of the board's reply, as soon as they have come: ``read()`` until
    ``parser`` makes whole frames of it, waiting on the descriptor ``fd`` in between (a busy
    machine may run the board's thread late: how late is not what these tests judge)."""
    deadline = time.monotonic() + timeout
    while True:
        frames = parser.feed(read())
        if frames:
            return frames
        left = deadline - time.monotonic()
        if left <= 0 or fd is None:
            raise AssertionError(f"no reply from the board within {timeout} s")
        select.select([fd], [], [], left)


class Link:
    """A plain pyserial PC side."""

    def __init__(self, path: str | Path) -> None:
        self.ser = serial.Serial(str(path), 3_000_000, timeout=0)
        self.parser = StatusParser()

    def exchange(self, timeout: float = 10.0, **kw: object) -> StatusFrame:
        """Write a frame and return the board's reply to it (``timeout``: s; board-sim beside two
        CPU hogs once took over 1 s to answer: how late is not what these tests judge)."""
        self.ser.write(CommandFrame(**kw).encode())  # type: ignore[arg-type]
        frames = _replies(lambda: self.ser.read(4096), self.ser.fileno(), self.parser, timeout)
        assert len(frames) == 1
        return frames[0]

    def silence(self, wait: float = 0.2) -> list[StatusFrame]:
        time.sleep(wait)
        return self.parser.feed(self.ser.read(4096))

    def run_100hz(self, seconds: float, **kw: object) -> list[StatusFrame]:
        out = []
        next_t = time.monotonic()
        end = next_t + seconds
        while next_t < end:
            out.append(self.exchange(**kw))
            next_t += 0.01
            time.sleep(max(0.0, next_t - time.monotonic()))
        return out

    def close(self) -> None:
        self.ser.close()


@pytest.fixture
def board(tmp_path):
    emu = BoardEmulator(homing_speedup=50, gripper_calibration_s=0.1)
    link = tmp_path / "p6"
    with PtyBoardServer(emu, link) as server:
        pc = Link(link)
        yield emu, server, pc
        pc.close()
    assert not link.exists()


def test_enable_home_idle_at_100hz_ends_homed_at_standby_with_timing_of_the_frame_interval(board):
    emu, server, pc = board
    assert pc.exchange(command=BoardCommand.ENABLE).xtr == 101
    assert pc.exchange(command=BoardCommand.HOME).xtr == 100
    homed = None
    next_t = time.monotonic()
    timings, board_t = [], []
    emu.add_exchange_listener(lambda frame, reply: board_t.append(emu.time_s))
    for _ in range(500):
        st = pc.exchange(command=BoardCommand.IDLE)
        timings.append(st.timing)
        if st.homed == 0xFF:
            homed = st
            break
        next_t += 0.01
        time.sleep(max(0.0, next_t - time.monotonic()))
    assert homed is not None, "not homed within 5 s at speedup 50"
    assert homed.positions == STANDBY and homed.xtr == 255
    # the timing field is the time since the previous frame in the board's timer ticks
    # (703,125 Hz: 10 ms = 7031), judged against the board's own clock at each exchange (an
    # exchange listener), not against 10 ms nor this process's clock: a busy machine runs this
    # loop late and the pty hands frames over late, and the board reports when it got them
    # (once, beside two CPU hogs, 7031 where this process had written them 8.5 ms apart)
    assert len(board_t) == len(timings), (len(board_t), len(timings))
    intervals = [(b - a) * TIMER_HZ for a, b in zip(board_t, board_t[1:])]
    off = [abs(t - i) for t, i in zip(timings[1:], intervals) if i < 65536]
    assert len(off) >= len(intervals) // 2 and statistics.median(off) <= 0.02 * TIMER_HZ / 100, \
        (statistics.median(off), timings[1:6], [round(i) for i in intervals[:5]])


def test_goto_frame_converges_on_its_target(board):
    emu, server, pc = board
    target = (1200, -800, 500, 300, -200, 1000)
    frames = pc.run_100hz(0.3, command=BoardCommand.GOTO, positions=target)
    assert frames[-1].positions == target
    assert frames[-1].speeds == (0,) * 6


def test_jog_runs_at_the_given_speed(board):
    """Judged on the board's own clock: each exchange's board time (the emulator's clock as it
    answers the frame, read by an exchange listener under the board's lock), so the positions
    of two replies must differ by speed x the board time between them, however late a busy
    machine ran this process or the board's loop.  Frames go back to back until the board's
    clock says half a second has passed (no pacing by this process's clock).  (The reply's
    16-bit timing field wraps after 93 ms: unwrapping it with this process's clock guessed a
    whole wrap wrong once beside two CPU hogs, 407 steps for 500.)"""
    emu, server, pc = board
    speeds = (1000, -2000, 3000, 0, 500, -4000)
    seen: list[tuple[float, tuple[int, ...]]] = []
    emu.add_exchange_listener(lambda frame, reply: seen.append((emu.time_s, tuple(reply.positions))))
    first = pc.exchange(command=BoardCommand.JOG, speeds=speeds)
    for _ in range(1000):  # the reply shows the telemetry of the last loop pass: once one ran
        first = pc.exchange(command=BoardCommand.JOG, speeds=speeds)
        if first.speeds == speeds:
            break
    assert first.speeds == speeds
    t_first, at = seen[-1]  # (the exchange this reply answered: the last one the board took)
    assert at == tuple(first.positions)
    frames = 0
    while True:
        last = pc.exchange(command=BoardCommand.JOG, speeds=speeds)
        t_last, at = seen[-1]
        assert at == tuple(last.positions)
        frames += 1
        assert frames < 100_000, "the board's clock did not advance"
        if t_last - t_first >= 0.5:
            break
    board_s = t_last - t_first
    for p0, p1, v in zip(first.positions, last.positions, speeds):
        assert p1 - p0 == pytest.approx(v * board_s, abs=0.002 * abs(v) + 2), (p1 - p0, v * board_s)


def test_outputs_echo_in_the_io_byte_and_inputs_estop_follow_the_emulator(board):
    emu, server, pc = board
    assert pc.exchange(io=0x20).io == 0x2F
    assert pc.exchange(io=0x30).io == 0x3F
    emu.set_input(1, True)
    emu.set_estop(True)
    st = pc.exchange(io=0x00)
    assert st.io == 0x87 and st.estop_pressed and st.inputs == (True, False)


def test_garbage_half_frames_and_wrong_end_bytes_get_no_reply_and_the_board_survives(board):
    emu, server, pc = board
    good = CommandFrame().encode()
    pc.ser.write(os.urandom(500).replace(b"\x01\x02", b"\x01\x01"))
    pc.ser.write(good[:25])
    pc.ser.write(b"\x00" * 40)
    pc.ser.write(good[:-2] + b"\x00\x00")
    pc.ser.write(good[:3] + b"\x30" + good[4:])
    assert pc.silence(0.3) == []
    assert pc.exchange(command=42).xtr == 42


def test_one_percent_corruption_loses_frames_without_breaking_the_board(board):
    """1 % of the bytes corrupted both ways (each byte replaced with probability 0.01): a frame
    is lost where a byte its receiver checks is hit, and the stream parsers on both ends find
    the next frame after a damaged one.  The board's rule checks 6 of a command frame's 56 bytes
    (start, LEN, end), the PC's 7 of a status frame's 60 (those and the CRC byte): about 6 % of
    the frames and 7 % of the replies go, each judged against that, per frame written and per
    reply sent.  Counted by frames, not in a wall-clock window: each frame is written once the
    board has taken the one before (its parser's byte count), and the replies are counted once
    the PC has read every byte the board sent (beside two CPU hogs the board's thread ran late,
    and a window of 100 x 2 ms + 0.1 s caught 29 replies)."""
    emu, server, pc = board
    n = 200
    frame = CommandFrame(io=0x10).encode()
    fd = pc.ser.fileno()
    replies: list[StatusFrame] = []

    def pump(done: Callable[[], bool], what: str) -> None:
        """Read the replies until ``done()``, an event (the 10 s limit only ends a hang)."""
        deadline = time.monotonic() + 10.0
        while True:
            replies.extend(pc.parser.feed(pc.ser.read(4096)))
            if done():
                return
            if time.monotonic() > deadline:
                raise AssertionError(f"{what}: not within 10 s")
            select.select([fd], [], [], 0.002)

    start = emu.stats
    taken0, answered0, read0 = start.parser["bytes_in"], start.replies_sent, pc.parser.stats.bytes_in
    emu.set_faults(corrupt_rate=0.01)
    for k in range(1, n + 1):
        pc.ser.write(frame)
        pump(lambda k=k: emu.stats.parser["bytes_in"] - taken0 >= k * len(frame), f"the board taking frame {k}")
    answered = emu.stats.replies_sent - answered0
    # corruption changes bytes and drops none: every reply the board sent is 60 bytes at the PC
    pump(lambda: pc.parser.stats.bytes_in - read0 >= answered * STATUS_FRAME_SIZE, "every reply read")
    emu.clear_faults()
    assert pc.parser.stats.bytes_in - read0 == answered * STATUS_FRAME_SIZE and server.bytes_discarded == 0
    got = len(replies)
    assert emu.stats.bytes_corrupted_by_faults > 0
    # what 1 % byte corruption loses: binomial, judged within 5 standard deviations, and never
    # nothing (0.94^200: one run in 180,000)
    for what, sent, received, checked in (("frames to the board", n, answered, 6),
                                          ("replies to the PC", answered, got, 7)):
        p_lost = 1 - 0.99 ** checked
        mean, sd = sent * p_lost, math.sqrt(sent * p_lost * (1 - p_lost))
        lost = sent - received
        assert 0 < lost <= mean + 5 * sd, f"{what}: {lost} of {sent} lost, {mean:.1f} +- {sd:.1f} expected"
    assert pc.exchange(io=0x10).io == 0x1F


def test_unplug_closes_the_pty_so_the_pc_sees_link_lost_and_replug_reconnects(board, tmp_path):
    emu, server, pc = board
    link = tmp_path / "p6"
    t = SerialTransport(str(link))
    t.open()
    t.write(CommandFrame().encode())
    assert len(_replies(t.read, t.fileno(), StatusParser())) == 1
    emu.unplug()
    deadline = time.monotonic() + 10.0
    with pytest.raises(LinkLostError):
        while time.monotonic() < deadline:
            t.read()
            t.write(CommandFrame().encode())
            time.sleep(0.01)
    assert not t.is_open
    assert not link.exists()
    emu.replug()
    deadline = time.monotonic() + 10.0
    while not link.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    t.open()
    t.write(CommandFrame(command=77).encode())
    frames = _replies(t.read, t.fileno(), StatusParser())
    assert len(frames) == 1 and frames[0].xtr == 77
    t.close()


def test_gripper_calibrate_and_grip_an_object_over_serial(board):
    emu, server, pc = board
    pc.exchange(gripper_mode=1)
    time.sleep(0.15)
    emu.place_object(24.0)
    frames = pc.run_100hz(0.8, gripper_command=0xD0, gripper_position=255, gripper_speed=255,
                          gripper_current=400)
    st = frames[-1]
    assert st.gripper.calibrated and st.gripper.activated and st.gripper.object_detected
    assert st.gripper_position == round(255 * (1 - 24 / 48))
    assert st.gripper_current == 400


def test_pty_server_refuses_to_replace_a_regular_file(tmp_path):
    from parolkit.board.pty_server import PtyServerError

    f = tmp_path / "not-a-link"
    f.write_text("keep me")
    with pytest.raises(PtyServerError, match="not a symlink"):
        PtyBoardServer(BoardEmulator(clock="virtual"), f).start()
    assert f.read_text() == "keep me"


# ------------------------------------------------------------------------------------------
# the real command, as a subprocess
# ------------------------------------------------------------------------------------------

def _parolkit(*args: str, **kw: object) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "parolkit", *args], capture_output=True,
                          text=True, timeout=20, cwd=REPO, **kw)


def test_board_sim_command_serves_a_plain_pyserial_script_and_obeys_ctl_and_sigterm(tmp_path):
    link = tmp_path / "p6"
    proc = subprocess.Popen(
        [sys.executable, "-m", "parolkit", "board-sim", "--link", str(link), "--speedup", "50",
         "--in2", "1"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO,
        preexec_fn=die_with_parent)
    try:
        deadline = time.monotonic() + 10.0
        while not link.exists() and time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.02)
        pc = Link(link)
        pc.exchange(command=BoardCommand.ENABLE)
        pc.exchange(command=BoardCommand.HOME)
        st = None
        for _ in range(600):
            st = pc.exchange(command=BoardCommand.IDLE)
            if st.homed == 0xFF:
                break
            time.sleep(0.01)
        assert st is not None and st.homed == 0xFF and st.positions == STANDBY
        assert st.inputs == (False, True)
        ctl = _parolkit("board-sim", "--link", str(link), "--ctl", "estop 1")
        assert ctl.returncode == 0 and ctl.stdout.strip() == "ok"
        assert pc.exchange().estop_pressed
        bad = _parolkit("board-sim", "--link", str(link), "--ctl", "estop maybe")
        assert bad.returncode == 1 and "expected 0 or 1" in bad.stdout
        pc.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert "board-sim: PAROL6 board on" in out
    assert not link.exists() and not Path(f"{link}.ctl").exists()


def test_board_sim_rejects_bad_flags_with_the_flag_named(tmp_path):
    r = _parolkit("board-sim", "--link", str(tmp_path / "p"), "--speedup", "0")
    assert r.returncode == 2 and "--speedup" in r.stderr
    r = _parolkit("board-sim", "--link", str(tmp_path / "p"), "--in1", "5")
    assert r.returncode == 2 and "--in1" in r.stderr
    r = _parolkit("board-sim", "--link", str(tmp_path / "p"), "--gripper-object", "80")
    assert r.returncode == 2 and "--gripper-object" in r.stderr
    r = _parolkit("board-sim", "--link", str(tmp_path / "nope" / "p"))
    assert r.returncode == 2 and "does not exist" in r.stderr
    r = _parolkit("board-sim", "--link", str(tmp_path / "p"), "--ctl", "status")
    assert r.returncode == 1 and "no board-sim control socket" in r.stderr
