"""``parolkit plan`` and the trajectory plot."""

from __future__ import annotations

import numpy as np
import pytest

from parolkit.cli import main
from parolkit.motion import JointMove, SpeedJointMove, plan, plot_trajectory
from parolkit.robot import PAROL6


def test_plan_movejoint_prints_duration_and_peak_speeds(capsys):
    rc = main(["plan", "movejoint", "50", "-90", "180", "0", "0", "180", "--t", "2", "--profile", "trap"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "duration   2.000 s  (200 samples at 100 Hz, board command 156)" in out
    # J1: 40 deg in 2 s with 1/3 phases -> cruise 30 deg/s = 3413 steps/s
    j1 = next(line for line in out.splitlines() if line.startswith("J1"))
    assert "3413" in j1 and "30.00" in j1


def test_plan_refusal_exits_1_with_the_reason(capsys):
    rc = main(["plan", "movejoint", "0", "-90", "180", "0", "0", "180", "--t", "2", "--profile", "trap"])
    err = capsys.readouterr().err
    assert rc == 1
    # 90 deg of J1 (10240 steps) at 1.5 d / t within the maximum speed 6500 steps/s; up to
    # 3.15 s (within the position-tracking maximum 4884 steps/s) it would run stretched
    assert "MoveJoint refused" in err and "give t >= 2.37 s (a t below 3.15 s runs stretched to 3.15 s" in err


def test_plan_from_start_and_plot_and_csv(tmp_path, capsys):
    png = tmp_path / "out.png"
    csv = tmp_path / "out.csv"
    rc = main(["plan", "movecartreltrf", "0", "0", "-20", "0", "0", "0", "--from",
               "90", "-100", "150", "10", "40", "170", "--plot", str(png), "--csv", str(csv)])
    assert rc == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert data.shape[1] == 14 and np.all(data[:, -1] == 156)
    assert "MoveCartRelTRF" in capsys.readouterr().out


def test_plan_jog_and_bad_arguments(capsys):
    assert main(["plan", "jog", "7", "50", "--distance", "5"]) == 0
    assert "board command 123" in capsys.readouterr().out
    assert main(["plan", "movejoint", "1", "2", "3"]) == 1
    assert "needs 6 values" in capsys.readouterr().err
    assert main(["plan", "movejoint", "0", "-90", "180", "0", "0", "180", "--v", "150"]) == 1
    assert "speed_pct must be in 0..100" in capsys.readouterr().err


def test_plot_trajectory_draws_several_moves_into_one_png(tmp_path):
    start = np.array(PAROL6.standby_deg)
    a = plan(JointMove([60, -80, 170, 0, 10, 180], duration_s=2), start)
    b = plan(SpeedJointMove([5, 0, 0, 0, 0, 0], 0.5), a.final_deg)
    out = plot_trajectory([a, b], tmp_path / "two.png")
    assert out.exists() and out.stat().st_size > 10_000
    with pytest.raises(ValueError):
        plot_trajectory([], tmp_path / "none.png")
