"""Issue 24, item 7: the seed's speed rule in the joint-space planners.

The seed refuses a move that exceeds a joint's MAXIMUM speed.  Position-tracked plans keep to the
position-tracking maximum (75-76 % of it at 100 Hz: the margin of the bounded GO TO frames).  A
move that needs more than that margin allows but no more than the maximum runs STRETCHED to the
shortest duration within it (rounded up to 0.01 s) with a warning naming the joint, the speed it
needed, the position-tracking maximum and the stretched duration; it is never refused.  These
tests prove it on the planned samples and, through the guard, on the board emulator."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tests.unit.guard_bench import GuardedBoard

from parolkit import kinematics as kin
from parolkit.motion import JointMove, PlanningError, PoseMove, plan, validate
from parolkit.protocol.frames import CommandFrame
from parolkit.robot import PAROL6, deg_to_steps

STANDBY = np.array(PAROL6.standby_deg)
SPD = PAROL6.steps_per_deg
VMAX = np.asarray(PAROL6.max_speed_steps_s, dtype=float)
VTRACK = PAROL6.max_tracked_speed_steps_s(100)
#: J1 from standby (90 deg) by 102.62 deg: 11676 steps; in t=4 with the quintic 1.875 d / t =
#: 5473 steps/s, within J1's maximum 6500, over its position-tracking maximum 4884
J1_TARGET = [-12.62, -90.0, 180.0, 0.0, 0.0, 180.0]
J1_STEPS = abs(-12.62 - 90.0) * SPD[0]
#: the position-tracking maximum's text for J1 (validate.SpeedLimits.describe)
J1_TRACK = ("position-tracking maximum 4884 steps/s (75 % of its maximum speed 6500 steps/s: the board's "
            "GO TO loop starts each tick up to 1.33x faster than the stream moves)")


def _warnings(tr) -> list[str]:
    return [n for n in tr.notes if n.startswith(validate.WARNING_PREFIX)]


def _stretch_up(seconds: float) -> float:
    return math.ceil(seconds * 100.0 - 1e-9) / 100.0


def test_the_seeds_t_over_the_tracking_margin_runs_stretched_with_the_warning_and_ends_on_target():
    assert 1.875 * J1_STEPS / 4.0 == pytest.approx(5473, abs=0.5)
    tr = plan(JointMove(J1_TARGET, duration_s=4.0), STANDBY)
    stretched = _stretch_up(1.875 * J1_STEPS / VTRACK[0])
    assert stretched == 4.49
    assert tr.duration == pytest.approx(stretched)
    assert tr.notes == (f"warning: J1 needs 5473 steps/s to finish in the t=4 s given, above its {J1_TRACK}: "
                        f"the move runs stretched to 4.49 s",)
    # within the position-tracking maximum on every sample, near it at the peak, on target at rest
    peak = np.abs(tr.speeds).max(axis=0)
    assert np.all(peak <= VTRACK) and peak[0] > 0.99 * VTRACK[0]
    assert np.array_equal(tr.positions[-1], deg_to_steps(J1_TARGET)) and np.all(tr.speeds[-1] == 0)
    # the stretched move is the one the stretched t plans, without a warning
    same = plan(JointMove(J1_TARGET, duration_s=4.49), STANDBY)
    assert same.notes == () and np.array_equal(same.positions, tr.positions)
    assert np.array_equal(same.speeds, tr.speeds)


def test_j5_needing_20805_of_its_22000_steps_s_runs_stretched():
    start = STANDBY.copy()
    start[4] = -78.02
    target = STANDBY.copy()
    target[4] = 78.02
    tr = plan(JointMove(target, duration_s=1.0), start)
    (w,) = _warnings(tr)
    assert w.startswith("warning: J5 needs 20805 steps/s to finish in the t=1 s given, above its position-tracking "
                        "maximum 16714 steps/s (76 % of its maximum speed 22000 steps/s")
    assert w.endswith("the move runs stretched to 1.25 s")
    assert tr.duration == pytest.approx(1.25)
    assert np.all(np.abs(tr.speeds).max(axis=0) <= VTRACK)


@pytest.mark.parametrize("profile, k", [("poly", 1.875), ("trap", 1.5)])
def test_between_the_tracking_margin_and_the_maximum_every_t_runs_and_above_the_maximum_it_is_refused(profile, k):
    target = [90, -90, 180, 0, 80, 180]  # J5 by 80 deg: 5689 steps
    d = 80 * SPD[4]
    t_full = k * d / VMAX[4]  # the shortest t within J5's maximum speed
    t_track = _stretch_up(k * d / VTRACK[4])  # the shortest within its position-tracking maximum
    for t in (_stretch_up(t_full), 0.5 * (t_full + t_track), t_track - 0.01):
        tr = plan(JointMove(target, duration_s=t, profile=profile), STANDBY)
        assert tr.duration == pytest.approx(t_track), t
        stretch = [w for w in _warnings(tr) if "runs stretched" in w]
        assert stretch == [f"warning: J5 needs {k * d / t:.0f} steps/s to finish in the t={t:g} s given, above "
                           f"its {validate.speed_limits(PAROL6, 100.0, True).describe(4)}: the move runs "
                           f"stretched to {t_track:.2f} s"]
        assert np.all(np.abs(tr.speeds) <= VTRACK)
        assert np.array_equal(tr.positions[-1], deg_to_steps(target))
    # from the position-tracking maximum on: in the t given, no stretch
    tr = plan(JointMove(target, duration_s=t_track, profile=profile), STANDBY)
    assert tr.duration == pytest.approx(t_track) and not any("stretched" in w for w in _warnings(tr))
    # over the maximum speed: refused, naming the joint, the speed, the maximum, the shortest t
    # accepted and up to which t it runs stretched; nothing is planned
    t = 0.9 * t_full
    with pytest.raises(PlanningError) as ei:
        plan(JointMove(target, duration_s=t, profile=profile), STANDBY)
    e = ei.value
    assert e.joint == 4 and e.value == pytest.approx(k * d / t)
    assert str(e).endswith(f"J5 would need a speed of {k * d / t:.0f} steps/s, above its maximum speed 22000 "
                           f"steps/s; give t >= {_stretch_up(t_full):.2f} s (a t below {t_track:.2f} s runs "
                           f"stretched to {t_track:.2f} s: J5 position-tracking maximum 16714 steps/s).")


def test_speed_tracking_keeps_the_maximum_itself_and_nothing_is_stretched():
    tr = plan(JointMove(J1_TARGET, duration_s=4.0, tracking="speed"), STANDBY)
    assert tr.duration == pytest.approx(4.0) and tr.notes == ()
    assert np.abs(tr.speeds[:, 0]).max() == pytest.approx(5473, abs=1)
    with pytest.raises(PlanningError) as ei:
        plan(JointMove(J1_TARGET, duration_s=3.0, tracking="speed"), STANDBY)
    assert str(ei.value).endswith("J1 would need a speed of 7297 steps/s, above its maximum speed 6500 steps/s; "
                                  "give t >= 3.37 s.")


def test_a_stretched_move_and_the_shortest_t_refusals_name_keep_the_board_within_its_maximum():
    """Played tick by tick through the guard into the board emulator, as the controller does:
    no frame replaced, no stepper starting a period over its maximum speed."""
    for move in (JointMove(J1_TARGET, duration_s=4.0), JointMove([90, -90, 180, 0, 80, 180], duration_s=0.49),
                 JointMove([90, -90, 180, 0, 80, 180], duration_s=0.35, profile="ruckig")):
        tr = plan(move, STANDBY)
        assert any("runs stretched" in w for w in _warnings(tr)), tr.notes
        board = GuardedBoard(every_pass=False)
        for pos, spd, cmd in zip(tr.positions.tolist(), tr.speeds.tolist(), tr.commands.tolist()):
            res = board.send(CommandFrame(positions=tuple(pos), speeds=tuple(spd), command=cmd))
            assert res.violation is None and not res.replaced
        for _ in range(30):
            board.goto(tr.positions[-1])
        peak = np.max([np.asarray(s.peak_speeds) / VMAX for s in board.log], axis=0)
        assert np.all(peak <= 1.0), peak
        assert peak.max() > 0.9  # the board did run near the maximum, not at 76 % of it
        assert tuple(board.emu.positions) == tuple(tr.positions[-1].tolist())


@pytest.mark.parametrize("profile", ["ruckig", "toppra"])
def test_jerk_limited_and_time_optimal_profiles_are_stretched_too(profile):
    target = [90, -90, 180, 0, 59, 180]  # J5 by 59 deg
    with pytest.raises(PlanningError) as ei:
        plan(JointMove(target, duration_s=0.15, profile=profile), STANDBY)
    msg = str(ei.value)
    assert ei.value.joint == 4 and "maximum speed 22000 steps/s" in msg
    least = float(msg.split("give t >= ")[1].split(" s")[0])
    stretched = float(msg.split("runs stretched to ")[1].split(" s")[0])
    assert least < stretched
    tr = plan(JointMove(target, duration_s=least, profile=profile), STANDBY)
    assert tr.duration == pytest.approx(stretched, abs=0.011)
    (w,) = [w for w in _warnings(tr) if "runs stretched" in w]
    needed = int(w.split("needs ")[1].split(" ")[0])
    assert VTRACK[4] < needed <= VMAX[4]
    assert w.startswith(f"warning: J5 needs {needed} steps/s to finish in the t={least:g} s given, above its "
                        f"position-tracking maximum 16714 steps/s")
    assert w.endswith(f"the move runs stretched to {stretched:.2f} s")
    assert np.all(np.abs(tr.speeds) <= VTRACK)
    assert np.array_equal(tr.positions[-1], deg_to_steps(target))
    # the acceleration warning names the stretched duration and the t given
    accel = [w for w in _warnings(tr) if "acceleration" in w]
    assert all(a.endswith(f"(stretched from the t={least:g} s given)") for a in accel)


def test_movepose_over_the_tracking_margin_runs_stretched():
    target = STANDBY + np.array([0, 0, 0, 0, 50, 0])  # J5 by 50 deg: 3556 steps
    pose = kin.fk(target)
    tr = plan(PoseMove(pose, duration_s=0.35), STANDBY)  # 1.875 x 3556 / 0.35 = 19048 steps/s
    stretched = _stretch_up(1.875 * 50 * SPD[4] / VTRACK[4])
    (w,) = [w for w in _warnings(tr) if "runs stretched" in w]
    assert w.startswith("warning: J5 needs 19048 steps/s to finish in the t=0.35 s given")
    assert w.endswith(f"the move runs stretched to {stretched:.2f} s")
    assert tr.duration == pytest.approx(stretched)
    assert np.array_equal(tr.positions[-1], deg_to_steps(kin.ik(pose, seed_deg=STANDBY)))


@pytest.mark.parametrize("profile", ["trap", "poly", "ruckig", "toppra"])
def test_100_percent_speed_runs_stretched_from_the_speed_asked_with_the_warning(profile):
    move = JointMove([-30, -90, 180, 0, 0, 180], speed_pct=100, accel_pct=100, profile=profile)
    tr = plan(move, STANDBY)
    asked = plan(JointMove([-30, -90, 180, 0, 0, 180], speed_pct=100, accel_pct=100, profile=profile,
                           tracking="speed"), STANDBY)  # (speed tracking: the maximum itself)
    (w,) = [w for w in _warnings(tr) if "runs stretched" in w]
    needed = int(w.split("needs ")[1].split(" ")[0])
    assert w.startswith(f"warning: J1 needs {needed} steps/s at v=100 %, above its {J1_TRACK}: the move runs "
                        f"stretched from ")
    assert VTRACK[0] < needed <= VMAX[0]
    assert needed == pytest.approx(np.abs(asked.speeds[:, 0]).max(), abs=2)
    assert w.endswith(f"from {_stretch_up(asked.duration - 1e-6):.2f} s to {_stretch_up(tr.duration - 1e-6):.2f} s")
    assert tr.duration > asked.duration
    assert np.all(np.abs(tr.speeds) <= VTRACK)


def test_a_percentage_within_the_tracking_margin_or_a_short_triangle_is_not_stretched():
    tr = plan(JointMove([-30, -90, 180, 0, 0, 180], speed_pct=70, accel_pct=100), STANDBY)
    assert not _warnings(tr)  # 70 % of 100..6500 = 4580 steps/s < 4884
    # 1 deg of J1 at 100 %: a triangle peaking far below the position-tracking maximum
    tr = plan(JointMove([89, -90, 180, 0, 0, 180], speed_pct=100, accel_pct=100), STANDBY)
    assert not _warnings(tr) and any("triangular profile" in n for n in tr.notes)


def test_the_tracking_margin_depends_on_the_rate():
    # 5200 steps/s on J1 (80 %): over the position-tracking maximum at 100 Hz (4884), within it
    # at 250 Hz (5605: the board's GO TO loop overshoots less per tick)
    t = 1.875 * J1_STEPS / 5200
    assert PAROL6.max_tracked_speed_steps_s(250)[0] > 5200 > VTRACK[0]
    assert _warnings(plan(JointMove(J1_TARGET, duration_s=t), STANDBY, rate_hz=100))
    tr = plan(JointMove(J1_TARGET, duration_s=t), STANDBY, rate_hz=250)
    assert not _warnings(tr) and tr.duration == pytest.approx(t, abs=1 / 250)


def test_validate_helpers_name_the_durations_and_limits_exactly():
    lim = validate.speed_limits(PAROL6, 100.0, True)
    assert np.array_equal(lim.full, VMAX) and np.array_equal(lim.array, VTRACK)
    assert lim.describe_full(0) == "maximum speed 6500 steps/s"
    assert lim.stretch_hint(2.37, 3.15, 0) == ("give t >= 2.37 s (a t below 3.15 s runs stretched to 3.15 s: "
                                               "J1 position-tracking maximum 4884 steps/s)")
    assert lim.stretch_hint(3.15, 3.15, 0) == "give t >= 3.15 s"
    speed_only = validate.speed_limits(PAROL6, 100.0, False)
    assert speed_only.stretch_hint(2.37, 3.15, 0) == "give t >= 2.37 s"
    # durations rounded UP to 0.01 s, a float a hair over a whole 0.01 s not a step up
    assert validate.round_up_duration(4.4825) == 4.49
    assert validate.round_up_duration(0.47) == 0.47
    assert validate.round_up_duration(0.47 * (1 + 1e-12)) == 0.47
    assert validate.round_up_duration(0.4700001) == 0.48
    assert validate.stretch_warning(lim, 0, 6500.0, "at v=100 %", 2.344, from_s=1.901) == (
        f"warning: J1 needs 6500 steps/s at v=100 %, above its {J1_TRACK}: the move runs stretched from "
        f"1.91 s to 2.35 s")
    peaks = [0.0, 0.0, 0.0, 0.0, 70000.0, 0.0]
    assert validate.accel_warning(peaks, PAROL6, 0.48, 0.4).endswith(
        "the move runs in 0.48 s (stretched from the t=0.4 s given)")
    assert validate.accel_warning(peaks, PAROL6, 0.4, 0.4).endswith("the move runs in the t=0.4 s given")
