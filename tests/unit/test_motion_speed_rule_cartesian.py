"""Issue 24, item 7: the seed's speed rule for Cartesian moves and smooth paths with a duration.

A Cartesian path given a duration that needs more than a joint's position-tracking maximum
(75-76 % of its maximum at 100 Hz: the margin of the bounded GO TO frames) but no more than its
maximum speed runs stretched to the shortest duration within the position-tracking maxima
(rounded up to 0.01 s), with a warning naming the joint, the speed it needed, that maximum and
the stretched duration.  Over a joint's maximum speed (or the wrist's singular-area bounds) it
is refused, naming the shortest duration accepted and up to which duration it runs stretched."""

from __future__ import annotations

import numpy as np
import pytest

from parolkit import kinematics as kin
from parolkit.motion import CartMove, HelixMove, PlanningError, plan, validate
from parolkit.robot import PAROL6

#: a start away from the wrist singularity
START = np.array([90.0, -100.0, 150.0, 10.0, 40.0, 170.0])
P0 = np.asarray(kin.fk(START))
#: 60 mm back, 40 mm left, 60 mm down: J1 and J3 do most of the work
TARGET = list(P0 + np.array([-60.0, -40.0, -60.0, 0.0, 0.0, 0.0]))
VMAX = np.asarray(PAROL6.max_speed_steps_s, dtype=float)
VTRACK = PAROL6.max_tracked_speed_steps_s(100)


def _stretch(tr) -> list[str]:
    return [n for n in tr.notes if n.startswith(validate.WARNING_PREFIX) and "runs stretched" in n]


def _refusal(move) -> tuple[str, float, float]:
    with pytest.raises(PlanningError) as ei:
        plan(move, START)
    msg = str(ei.value)
    least = float(msg.split("give a duration of at least ")[1].split(" s")[0])
    stretched = float(msg.split("runs stretched to ")[1].split(" s")[0])
    return msg, least, stretched


def test_a_movecart_over_the_tracking_margin_runs_stretched_and_over_the_maximum_is_refused():
    msg, least, stretched = _refusal(CartMove(TARGET, duration_s=0.5))
    assert "exceeds the maximum speed" in msg and least < stretched
    assert msg.endswith(f"give a duration of at least {least:.2f} s (a duration below {stretched:.2f} s runs "
                        f"stretched to {stretched:.2f} s, within the position-tracking maxima).")
    # the shortest duration accepted, and one between it and the stretched one: both run,
    # stretched, within the position-tracking maxima, on the line to the target
    for t in (least, round(0.5 * (least + stretched), 2)):
        tr = plan(CartMove(TARGET, duration_s=t), START)
        assert tr.duration == pytest.approx(stretched, abs=0.011), t
        (w,) = _stretch(tr)
        j = int(w.split("warning: J")[1][0]) - 1
        needed = int(w.split("needs ")[1].split(" ")[0])
        assert VTRACK[j] < needed <= VMAX[j]
        assert w.startswith(f"warning: J{j + 1} needs {needed} steps/s to finish in the t={t:g} s given, above its "
                            f"position-tracking maximum {VTRACK[j]:.0f} steps/s")
        assert w.endswith(f"the move runs stretched to {tr.duration:.2f} s")
        assert np.all(np.abs(tr.speeds) <= VTRACK)
        assert np.allclose(kin.fk(tr.final_deg)[:3], TARGET[:3], atol=0.02)  # (whole steps)
    # from the stretched duration on: in the duration given, no warning
    tr = plan(CartMove(TARGET, duration_s=stretched), START)
    assert tr.duration == pytest.approx(stretched) and not _stretch(tr)


def test_speed_tracking_keeps_the_maximum_and_refuses_without_a_stretch():
    tr = plan(CartMove(TARGET, duration_s=0.9, tracking="speed"), START)
    assert tr.duration == pytest.approx(0.9) and not _stretch(tr)
    assert np.abs(tr.speeds[:, 0]).max() > VTRACK[0]  # over the position-tracking maximum, within the maximum
    with pytest.raises(PlanningError, match=r"exceeds the maximum speed 6500 steps/s; give a duration of at least "
                                            r"\d\.\d\d s\.$"):
        plan(CartMove(TARGET, duration_s=0.7, tracking="speed"), START)


def test_time_optimal_cartesian_paths_are_stretched_too():
    tr = plan(CartMove(TARGET, duration_s=0.5, profile="toppra"), START)
    (w,) = _stretch(tr)
    assert w.startswith("warning: J") and "to finish in the t=0.5 s given" in w
    assert tr.duration > 0.5 and w.endswith(f"the move runs stretched to {tr.duration:.2f} s")
    assert np.all(np.abs(tr.speeds) <= VTRACK)
    accel = [n for n in tr.notes if "acceleration" in n]
    assert all(a.endswith("(stretched from the t=0.5 s given)") for a in accel)


def test_a_smooth_path_over_the_maximum_names_both_durations_and_runs_at_the_least():
    x, y, z = P0[:3]
    helix = HelixMove([x, y - 20, z], 20, 10, 20, duration_s=1.0)
    msg, least, stretched = _refusal(helix)
    assert msg.startswith("SmoothHelix refused") and "exceeds the maximum speed" in msg
    tr = plan(HelixMove([x, y - 20, z], 20, 10, 20, duration_s=least), START)
    assert tr.duration == pytest.approx(stretched, abs=0.011) and len(_stretch(tr)) == 1


def test_the_wrist_bound_refuses_as_before_with_the_shortest_duration_that_fits():
    standby = np.array(PAROL6.standby_deg)
    p = kin.fk(standby)
    with pytest.raises(PlanningError, match=r"wrist singularity.*give a duration of at least 1\.59 s\.$"):
        plan(CartMove(p + np.array([50, 0, 0, 0, 0, 0]), duration_s=1.0), standby)
