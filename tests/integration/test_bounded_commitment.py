"""Bounded commitment: a controller killed with ``kill -9`` mid-motion leaves the board stopped.

The board firmware has no watchdog, and the emulator behaves the same (it keeps running its last
command when frames stop: proven first, below).  So the only thing that can stop the joints
after the controller dies is the stop supervisor (``parolkit.controller.supervisor``), a separate
process sharing the serial port.  Each run: ``parolkit board-sim`` on a real pty in its own
process (SCHED_FIFO where allowed, with a frame log of what arrives and when: the board's own
record, which a busy test process cannot hold up), ``parolkit serve`` on it, a speed-mode
motion started, then ``SIGKILL``; the next frame the board receives must be DISABLE (and it
stops), 5 times of 5 for a jog and 5 of 5 for a speed-only tracked move.

How soon is a figure of the machine as much as of the software: the kernel hands each frame
through a pty worker thread that two CPU hogs can hold back 50-180 ms.  So ``make test``
prints the times and judges the order of the frames; ``make soak`` (the tests marked soak)
judges the 100 ms as well (:data:`BOUND_S`).
"""

from __future__ import annotations

import json
import socket
import time

import pytest
from tests.conftest import start_controller, wait_until
from tests.integration.boardsim import BoardSim

from parolkit.board import BoardEmulator, PtyBoardServer
from parolkit.protocol.frames import BoardCommand, CommandFrame
from parolkit.robot import PAROL6

#: the most the board may wait for the supervisor's DISABLE, s (judged by make soak only)
BOUND_S = 0.100
#: the runs judged on time as well: make soak's (module docstring)
TIMED = [pytest.param(False, id="order"), pytest.param(True, id="timed", marks=pytest.mark.soak)]


class KillBench:
    """board-sim (its own process, with a frame log) + controller subprocess, for one kill."""

    def __init__(self, tmp_path, extra_config: str = "", *, exchange_log: bool = False) -> None:
        tmp_path.mkdir(parents=True, exist_ok=True)
        self.board = BoardSim(tmp_path, frame_log=5000, exchange_log=exchange_log)
        cfg = tmp_path / "controller.toml"
        cfg.write_text("[controller]\nlink_timeout_ticks = 50\n" + extra_config)
        self.ctl = start_controller(["--port", str(self.board.link), "--config", str(cfg)],
                                    log_dir=tmp_path, wait_homed=False)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        wait_until(lambda: (self.query("GET_STATUS") or "").endswith("|SERIAL=1"), 20, what="the board link")
        wait_until(lambda: self.status().get("loop", {}).get("supervisor") == "ready", 10,
                   what="the stop supervisor ready")
        # the start-up probe has told the controller that the board is enabled
        wait_until(lambda: (lambda s: s.get("board", {}).get("state_known") and s.get("enabled"))(self.status()),
                   10, what="the board's state known (enabled)")

    def status(self) -> dict:
        reply = self.query("GET_STATUS_JSON") or ""
        return json.loads(reply.split("|", 1)[1]) if reply.startswith("STATUS_JSON|") else {}

    def query(self, text: str) -> str | None:
        """The reply to ``text``, asked on a socket of its own: a reply to an earlier query that
        came after its timeout can never be taken for this one's."""
        return self.ctl.query(text)

    def send(self, text: str) -> None:
        self.sock.sendto(text.encode(), (self.ctl.host, self.ctl.port))

    def speeds(self) -> list[int]:
        """The board's joint speeds now, steps/s."""
        return self.board.status()["speeds"]

    def first_disable(self, since: float) -> tuple[float, float, int]:
        """The board's record of the first DISABLE frame it received after ``since``
        (monotonic s): (its arrival, the arrival of the frame before it, that frame's command)."""
        frames = self.board.frames(since)
        i = next((i for i, (_, _, cmd) in enumerate(frames) if cmd == BoardCommand.DISABLE), None)
        assert i is not None and i > 0, f"no DISABLE frame after a frame since {since}: {frames[-5:]}"
        return frames[i][1], frames[i - 1][1], frames[i - 1][2]

    def kill_and_time_the_stop(self) -> tuple[float, float]:
        """SIGKILL the controller mid-motion; returns the s from the kill and from the
        controller's last frame until the board received DISABLE (it stops on it), by the
        board's own record.  The next frame after the kill is the DISABLE: the controller's
        last one was a motion frame (GO TO), and nothing came between."""
        t_kill = time.monotonic()
        self.ctl.proc.kill()
        # (the board's speeds reach 0 by themselves, the last frames being GO TOs: the DISABLE
        # may come after that on a busy machine, so the wait is for the DISABLE itself)
        wait_until(lambda: any(cmd == BoardCommand.DISABLE for _, _, cmd in self.board.frames(t_kill - 1.0)), 5,
                   interval=0.005, what="the supervisor's DISABLE at the board")
        wait_until(lambda: not any(self.speeds()), 5, interval=0.002, what="board speeds 0 after the kill")
        t_disable, t_last, cmd_last = self.first_disable(t_kill - 1.0)
        # the supervisor writes DISABLE frames only (supervisor.py): a GO TO right before the
        # first DISABLE is the controller's, written before it died, so nothing came between.
        # (When it arrived says nothing: the pty's worker thread delivered it 5 ms after the
        # kill in a fresh clone's run, beside the rest of the suite)
        assert cmd_last == BoardCommand.GOTO, f"the frame before the DISABLE was command {cmd_last}, not a GO TO"
        return t_disable - t_kill, t_disable - t_last

    def running(self) -> None:
        """Assert that the board still moves (the motion has not ended), with the controller's
        log if not."""
        assert any(self.speeds()), f"the motion ended before the kill; controller log:\n{self.ctl.log()[-3000:]}"

    def close(self) -> None:
        self.ctl.stop()
        self.sock.close()
        self.board.close()


def test_the_emulated_board_keeps_running_its_last_jog_when_frames_stop(tmp_path):
    """The fault model is faithful: the firmware has no watchdog, neither has the emulator (on a
    pty, and after its in-process link is closed)."""
    emu = BoardEmulator(start_homed=True)
    with PtyBoardServer(emu, tmp_path / "p6"):
        import serial

        with serial.Serial(str(tmp_path / "p6"), 3_000_000, timeout=0) as port:
            jog = CommandFrame(positions=emu.positions, speeds=(2000, 0, 0, 0, 0, 0), command=BoardCommand.JOG)
            port.write(jog.encode())
            wait_until(lambda: emu.speeds[0] == 2000, 5, what="the jog to start")
        # the PC side closed the port and sends nothing: the board keeps jogging
        p0 = emu.positions[0]
        time.sleep(0.3)
        assert emu.speeds[0] == 2000 and emu.positions[0] - p0 >= 2000 * 0.2
    emu.stop()

    from parolkit.transport import EmulatorTransport

    link = EmulatorTransport(start_homed=True)
    link.open()
    link.write(CommandFrame(positions=link.emulator.positions, speeds=(0, 0, 0, 0, 0, -3000),
                            command=BoardCommand.JOG).encode())
    link.close()
    p0 = link.emulator.positions[5]
    time.sleep(0.2)
    assert link.emulator.speeds[5] == -3000 and p0 - link.emulator.positions[5] >= 3000 * 0.1


@pytest.mark.slow
@pytest.mark.parametrize("timed", TIMED)
@pytest.mark.parametrize("motion", [
    pytest.param("JOG|0|60|20|None", id="jog"),
    pytest.param("MOVEJOINT|10|-60|150|60|40|0|8|None|None|trap|speed", id="speed-only-move"),
])
def test_kill_9_mid_motion_stops_the_board_5_of_5(tmp_path, motion, timed):
    results = []
    for run in range(5):
        b = KillBench(tmp_path / f"run{run}")
        try:
            b.send(motion)
            wait_until(lambda b=b: any(b.speeds()), 10, interval=0.005, what="the motion to start")
            time.sleep(0.3)
            b.running()
            results.append(b.kill_and_time_the_stop())
            p = b.board.status()["positions"]
            time.sleep(0.2)
            st = b.board.status()
            assert st["positions"] == p, "the board moved after it reported speed 0"
            assert not st["enabled"] and st["command"] == BoardCommand.DISABLE
        finally:
            b.close()
    print(f"{motion}: DISABLE after the kill, ms: " + ", ".join(f"{a * 1000:.1f}" for a, _ in results))
    if timed:
        assert all(t_kill <= BOUND_S for t_kill, _ in results), results


def test_the_stop_frame_keeps_the_outputs_and_the_supervisor_leaves_quietly_on_a_clean_stop(tmp_path):
    b = KillBench(tmp_path)
    try:
        b.send("PNEUMATICGRIPPER|open|1")
        wait_until(lambda: b.board.status()["outputs"][0], 5, what="OUT1 on")
        b.send("JOG|1|40|20|None")
        wait_until(lambda: b.speeds()[1] != 0, 10, interval=0.005, what="the jog to start")
        b.kill_and_time_the_stop()
        # a part held by the pneumatic gripper is not dropped when the controller dies
        assert b.board.status()["outputs"] == [True, False]
    finally:
        b.close()


@pytest.mark.parametrize("timed", TIMED)
def test_a_frozen_controller_mid_jog_is_stopped_3_periods_after_its_last_frame_and_reports_it_when_it_resumes(
        tmp_path, timed):
    """``kill -STOP`` of the controller mid-jog, default settings: its process is stopped, so
    the supervisor disables the board 3 loop periods after the last frame (the issue: 995 ms,
    J6 +101 deg with the old 1 s limit): by the supervisor's own count, which the controller
    reports.  Judged by the board's own record: the next frame after the controller's last (a
    GO TO) is the DISABLE; make soak: it arrives within 100 ms of it."""
    import os
    import signal

    b = KillBench(tmp_path)
    try:
        b.send("JOG|5|60|20|None")
        wait_until(lambda: b.speeds()[5] != 0, 10, interval=0.005, what="the jog to start")
        t_sig = time.monotonic()
        os.kill(b.ctl.proc.pid, signal.SIGSTOP)
        try:
            wait_until(lambda: not any(b.speeds()), 3, interval=0.005, what="the supervisor's stop")
            assert not b.board.status()["enabled"]
        finally:
            os.kill(b.ctl.proc.pid, signal.SIGCONT)
        t_disable, t_last, cmd_last = b.first_disable(t_sig - 1.0)
        print(f"DISABLE {(t_disable - t_last) * 1000:.1f} ms after the controller's last frame")
        assert cmd_last == BoardCommand.GOTO, cmd_last
        if timed:
            assert t_disable - t_last <= BOUND_S, t_disable - t_last
        status = wait_until(lambda: (lambda r: r if r and "is stopped and wrote no frame" in r else None)(
            b.query("GET_STATUS")), 5, what="the controller reporting the supervisor's stop")
        assert "STATE=DISABLED" in status and "the stop supervisor disabled the board" in status, status
        assert b.status()["loop"]["supervisor_stopped_ms"] == 30.0  # 3 periods at 100 Hz
        # the controller agrees with the board: nothing moves until ENABLE
        time.sleep(0.2)
        assert not any(b.speeds())
    finally:
        b.close()


@pytest.mark.parametrize("jog", ["JOG|5|100|20|None", "JOG|0|100|20|None"], ids=["J6", "J1"])
def test_controller_and_supervisor_killed_together_mid_jog_at_full_speed_stop_within_20_ms_of_travel(
        tmp_path, jog):
    """The second line gone too: ``kill -9`` of the stop supervisor and the controller at once,
    mid-jog at full speed.  Nothing writes a stop frame; the board's last frame is a GO TO whose
    goal lies within 20 ms of maximum-speed travel of where the joint was as it arrived, so every
    joint stops by itself within that (on 1dfd036 a JOG frame ran on: J6 +304 deg in 3 s).
    Judged by the board's own exchange log: its position as the last frame arrived, and where
    it came to rest."""
    import os
    import signal

    b = KillBench(tmp_path, exchange_log=True)
    try:
        pid = b.status()["loop"]["supervisor_pid"]
        b.send(jog)
        joint = int(jog.split("|")[1])
        wait_until(lambda: abs(b.speeds()[joint]) > 1000, 10,
                   interval=0.005, what="the jog at speed")
        time.sleep(0.2)
        os.kill(pid, signal.SIGKILL)
        b.ctl.proc.kill()
        wait_until(lambda: not any(b.speeds()), 2, interval=0.005, what="the board at rest by itself")
        rest = b.board.status()["positions"]
        time.sleep(0.3)
        assert b.board.status()["positions"] == rest, "the board moved on"
        assert b.board.status()["enabled"], "something stopped it by DISABLE: nothing should be left to"
        ex = [json.loads(line) for line in b.board.record_path.read_text().splitlines()]
        last = [e for e in ex if e["k"] == "ex"][-1]
        assert last["cmd"] == BoardCommand.GOTO, last
        at = last["reply"]["p"]  # where the board was as the last frame arrived
        travel = [abs(r - a) for r, a in zip(rest, at)]
        ms = [t / v * 1e3 for t, v in zip(travel, PAROL6.max_speed_steps_s)]
        print(f"{jog}: travel after the last frame, ms at the maximum speed: " + ", ".join(f"{m:.1f}" for m in ms))
        assert all(m <= 20.0 + 1e3 / v for m, v in zip(ms, PAROL6.max_speed_steps_s)), (ms, rest, at)
        assert travel[joint] > 0  # it was moving
    finally:
        b.close()
