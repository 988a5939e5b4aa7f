"""board-test against the emulated board: in-process (--sim, and a BoardTester on an
emulator the test controls) and through a real pty served by ``parolkit board-sim``."""

from __future__ import annotations

import io

import pytest
from tests.integration.boardsim import BoardSim

from parolkit.board import BoardEmulator
from parolkit.boardtest import BoardTester, BoardTestError
from parolkit.cli import main as cli_main
from parolkit.transport import EmulatorTransport


def test_sim_jog_moves_the_joint_and_reports_the_steps(capsys):
    assert cli_main(["board-test", "--sim", "jog", "--joint", "3", "--speed", "1000",
                     "--seconds", "0.5"]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("J3: "))
    moved = int(line.split("moved ")[1].split()[0])
    assert 400 <= moved <= 750  # 1000 steps/s for 0.5 s (+ the stop frame's delay on a busy machine)


def test_sim_homing_outputs_and_gripper(capsys):
    assert cli_main(["board-test", "--sim", "--speedup", "200", "home", "--timeout", "20"]) == 0
    out = capsys.readouterr().out
    assert "homed in" in out and "[10240, -32000, 57905, 0, 0, 32000]" in out
    assert cli_main(["board-test", "--sim", "out", "2", "on"]) == 0
    assert "board reports OUT2=1" in capsys.readouterr().out
    assert cli_main(["board-test", "--sim", "gripper", "calibrate", "--seconds", "1.5"]) == 0
    assert "calibrated=True" in capsys.readouterr().out


def test_a_bad_argument_exits_2_with_the_reason(capsys):
    assert cli_main(["board-test", "--sim", "jog", "--joint", "1", "--speed", "99999"]) == 2
    assert "speed (steps/s) must be in -6500..6500" in capsys.readouterr().err


def test_estop_blocks_jogging_and_stops_a_running_jog():
    emu = BoardEmulator()
    link = EmulatorTransport(emulator=emu)
    link.open()
    out = io.StringIO()
    try:
        t = BoardTester(link, out=out)
        emu.set_estop(True)
        with pytest.raises(BoardTestError, match="E-stop is pressed"):
            t.jog(1, 500, 0.5)
        emu.set_estop(False)
        t.idle(0.05)
        import threading

        threading.Timer(0.2, emu.set_estop, args=(True,)).start()
        with pytest.raises(BoardTestError, match="E-stop pressed during the jog"):
            t.jog(1, 500, 3.0)
        assert not emu.enabled  # the tool sent DISABLE
        assert t.status.speeds == (0, 0, 0, 0, 0, 0)
    finally:
        link.close()


def test_inputs_and_gripper_move_on_a_controlled_emulator():
    emu = BoardEmulator(gripper_calibration_s=0.2)
    link = EmulatorTransport(emulator=emu)
    link.open()
    out = io.StringIO()
    try:
        t = BoardTester(link, out=out)
        emu.set_input(2, True)
        st = t.read_inputs()
        assert st.inputs == (False, True)
        assert "IN1=0 IN2=1 ESTOP=released" in out.getvalue()
        t.gripper_calibrate(0.5)
        st = t.gripper_move(180, 255, 400, seconds=1.0)
        assert st.gripper_position == 180 and st.gripper.object_code == 3
        t.monitor(0.3, live=False)
        text = out.getvalue()
        assert "--- final" in text and "timing:" in text and "gripper: id=" in text
    finally:
        link.close()


def test_board_test_over_a_real_pty(tmp_path, capsys):
    # board-sim in its own process (as a real board, it answers whatever the test process's
    # load): an emulator sharing this process took frames in bursts on a loaded machine
    board = BoardSim(tmp_path, name="parol6", start_homed=False, frame_log=None, speedup=200)
    link = board.link
    try:
        assert cli_main(["board-test", "--port", str(link), "monitor", "--seconds", "0.5"]) == 0
        out = capsys.readouterr().out
        assert f"board-test on {link}" in out
        final = out.split("--- final")[1]
        assert "without a reply" in final
        sent = int(final.split("link: ")[1].split()[0])
        missed = int(final.split("sent, ")[1].split()[0])
        # ~50 frames at 100 Hz; on a loaded machine fewer, and late replies count as missed
        assert sent >= 10 and sent - missed >= 5
        ticks = int(final.split("timing: ")[1].split()[0])
        timing_ms = float(final.split("ticks = ")[1].split()[0])
        assert ticks > 0 and timing_ms == pytest.approx(ticks / 703.125, abs=1e-3)
        assert cli_main(["board-test", "--port", str(link), "out", "1", "on"]) == 0
        assert board.status()["outputs"] == [True, False]
        assert cli_main(["board-test", "--port", str(link), "home", "--timeout", "20"]) == 0
        assert board.status()["homed"] == 0xFF
    finally:
        board.close()


def test_interactive_menu_reads_actions_from_stdin():
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "parolkit", "board-test", "--sim"],
                          input="inputs\nout 2 on\nstatus\nquit\n", capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "board test: type an action" in proc.stdout
    assert "IN1=0 IN2=0 ESTOP=released" in proc.stdout
    assert "board reports OUT2=1" in proc.stdout
    assert "timing:" in proc.stdout
