"""Joint-space planning: the seed's timing rules, proved numerically on the planned samples."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from parolkit.errors import ParolkitValueError
from parolkit.motion import (
    JointJog,
    JointMove,
    PlanningError,
    Profile,
    SpeedJointMove,
    Tracking,
    Trajectory,
    plan,
)
from parolkit.robot import PAROL6, deg_to_steps

STANDBY = np.array(PAROL6.standby_deg)
SPD = PAROL6.steps_per_deg
VMAX = np.asarray(PAROL6.max_speed_steps_s, dtype=float)
#: the position-tracking maximum at 100 Hz (issue 12: the board's GO TO loop starts each tick
#: 1.27x faster than a stream moves)
VTRACK = PAROL6.max_tracked_speed_steps_s(100)
#: per-joint acceleration limits, steps/s^2 (3x the maximum speed per second)
AMAX = PAROL6.accel_limit_steps_s2


def _speeds_f(tr: Trajectory) -> np.ndarray:
    return tr.speeds.astype(float)


def test_sample_convention_first_tick_after_start_and_last_sample_exactly_on_target():
    target = [50, -80, 170, 10, -10, 200]
    tr = plan(JointMove(target, duration_s=3.0), STANDBY)
    assert tr.t[0] == pytest.approx(0.01)
    assert np.allclose(np.diff(tr.t), 0.01)
    assert len(tr) == 300 and tr.duration == pytest.approx(3.0)
    assert np.array_equal(tr.positions[-1], deg_to_steps(target))
    assert np.all(tr.speeds[-1] == 0)
    assert tr.positions.dtype == np.int64 and tr.speeds.dtype == np.int64
    assert tr.commands.dtype == np.uint8 and set(tr.commands.tolist()) == {156}


def test_trap_with_duration_has_three_equal_phases_of_one_third():
    tr = plan(JointMove([50, -90, 180, 0, 0, 180], duration_s=2.0, profile="trap"), STANDBY)
    v = np.abs(_speeds_f(tr)[:, 0])
    vc = v.max()
    # cruise speed 1.5 * distance / T
    dist = 40 * SPD[0]
    assert vc == pytest.approx(1.5 * dist / 2.0, abs=1)
    cruise = tr.t[np.abs(v - vc) <= 1]
    assert cruise[0] == pytest.approx(2 / 3, abs=0.01)
    assert cruise[-1] == pytest.approx(4 / 3, abs=0.01)
    # accelerating phase: speed grows linearly with t (constant acceleration 4.5 d / T^2)
    acc = tr.t < 0.66
    assert np.allclose(v[acc], 4.5 * dist / 4.0 * tr.t[acc], atol=1)
    assert tr.t[-1] == 2.0 and tr.positions[-1, 0] == deg_to_steps([50, -90, 180, 0, 0, 180])[0]


def test_poly_starts_and_ends_with_zero_speed_and_acceleration():
    tr = plan(JointMove([60, -70, 160, 20, 30, 150], duration_s=4.0, profile="poly"), STANDBY)
    v = tr.speeds_deg_s()
    dist = np.abs(np.array([60, -70, 160, 20, 30, 150]) - STANDBY)
    peak = 1.875 * dist / 4.0
    assert np.all(np.abs(v[0]) < 0.001 * peak + 1 / SPD)
    assert np.all(v[-1] == 0)
    acc = np.diff(v, axis=0) * 100
    peak_acc = 5.7735 * dist / 16.0
    # acceleration at the ends: a tiny fraction of the peak (zero in the limit)
    assert np.all(np.abs(acc[0]) < 0.02 * peak_acc + 2 / SPD * 100)
    assert np.all(np.abs(acc[-1]) < 0.02 * peak_acc + 2 / SPD * 100)
    assert np.allclose(np.abs(v).max(axis=0), peak, rtol=0.01, atol=0.02)


def test_speed_and_accel_percent_leading_joint_reaches_mapped_speed_and_all_finish_together():
    start = STANDBY
    target = np.array([80, -70, 170, 30, -20, 250])  # J6 travels the most steps
    tr = plan(JointMove(target, speed_pct=40, accel_pct=60), start)
    steps = np.abs((target - start) * SPD)
    lead = int(np.argmax(steps))
    assert lead == 5
    mapped = PAROL6.speed_from_percent(40)[lead]
    assert np.abs(tr.speeds[:, lead]).max() == pytest.approx(mapped, abs=1)
    # acceleration of the leading joint: the mapped 60 %
    acc = np.abs(np.diff(_speeds_f(tr)[:, lead])) * 100
    assert acc.max() == pytest.approx(PAROL6.accel_from_percent(60), rel=0.01)
    # synchronised: every joint's speed is the same fraction of its distance at every sample
    delta_steps = (target - start) * SPD
    lead_frac = tr.speeds[:, [lead]] / delta_steps[lead]
    assert np.allclose(tr.speeds, lead_frac * delta_steps, atol=1.0)
    # all joints reach their targets on the same (last) sample
    assert np.array_equal(tr.positions[-1], deg_to_steps(target))
    assert np.all(tr.speeds[-1] == 0) and np.all(tr.speeds[-2, steps > 100] != 0)


def test_other_joint_that_cannot_follow_slows_the_leader_and_says_so():
    target = np.array([0, -60, 150, 10, 20, 100])  # J1 (slowest joint) nearly as far as J6
    # the leader J6 is slowed so that J1 keeps within its maximum speed (a note: the seed's
    # "the algorithm selects appropriate values"), then the move runs stretched within J1's
    # position-tracking maximum (a warning: the speed asked is more than it)
    tr = plan(JointMove(target, speed_pct=100, accel_pct=100), STANDBY)
    assert np.abs(tr.speeds[:, 0]).max() <= VTRACK[0]
    assert np.abs(tr.speeds[:, 0]).max() == pytest.approx(VTRACK[0], abs=1)
    assert "leading joint J6 slowed from 22000 to 9028 steps/s: J1 speed limit 6500 steps/s" in tr.notes[0]
    assert tr.notes[-1].startswith("warning: J1 needs 6500 steps/s at v=100 %, above its position-tracking "
                                   "maximum 4884 steps/s")
    # speed only (123): the maximum speed itself, no warning
    fast = plan(JointMove(target, speed_pct=100, accel_pct=100, tracking="speed"), STANDBY)
    assert np.abs(fast.speeds[:, 0]).max() == pytest.approx(VMAX[0], abs=1)
    assert any("J1 speed limit 6500 steps/s" in n for n in fast.notes)
    assert not any(n.startswith("warning: ") for n in fast.notes)
    assert tr.notes[-1].endswith(f"the move runs stretched from {fast.duration:.2f} s to {tr.duration:.2f} s")


def test_only_targets_uses_the_conservative_default_trapezoid():
    target = np.array([70, -80, 170, 0, 0, 180])
    tr = plan(JointMove(target), STANDBY)
    lead = int(np.argmax(np.abs((target - STANDBY) * SPD)))
    # default MoveJoint: v=45 %, a=27 %
    assert np.abs(tr.speeds[:, lead]).max() <= PAROL6.speed_from_percent(45)[lead] + 1
    acc = np.abs(np.diff(_speeds_f(tr)[:, lead])) * 100
    assert acc.max() == pytest.approx(PAROL6.accel_from_percent(27), rel=0.02)


def test_duration_overrides_percentages():
    tr = plan(JointMove([70, -80, 170, 0, 0, 180], duration_s=3, speed_pct=100, accel_pct=100), STANDBY)
    assert tr.duration == 3.0
    assert any("overrides" in n for n in tr.notes)


def test_too_fast_for_duration_is_refused_naming_joint_time_value_and_minimum():
    with pytest.raises(PlanningError) as ei:
        plan(JointMove([0, -90, 180, 0, 0, 180], duration_s=2.0, profile="trap"), STANDBY)
    e = ei.value
    assert e.move == "MoveJoint" and e.joint == 0 and e.joint_name == "J1"
    assert e.value == pytest.approx(1.5 * 90 * SPD[0] / 2.0)
    assert e.time_s == pytest.approx(2 / 3)
    # over J1's maximum speed: the shortest t accepted (1.5 x 10240 steps / 6500 steps/s), and
    # up to which t the move runs stretched (1.5 x 10240 / 4884, the position-tracking maximum)
    assert str(e).endswith("J1 would need a speed of 7680 steps/s, above its maximum speed 6500 steps/s; "
                           "give t >= 2.37 s (a t below 3.15 s runs stretched to 3.15 s: J1 position-tracking "
                           "maximum 4884 steps/s).")
    # speed only (123): the maximum speed itself is the limit, nothing is stretched
    with pytest.raises(PlanningError) as ei:
        plan(JointMove([0, -90, 180, 0, 0, 180], duration_s=2.0, profile="trap", tracking="speed"), STANDBY)
    assert str(ei.value).endswith("J1 would need a speed of 7680 steps/s, above its maximum speed 6500 steps/s; "
                                  "give t >= 2.37 s.")


def test_speed_limit_refuses_a_short_move_with_the_minimum_duration():
    # 20 deg of J6 in 0.2 s: 1.875 * 3556 / 0.2 = 33333 steps/s, above J6's maximum speed 22000
    # steps/s: refused, naming J6 and the shortest t accepted (1.875 * 3556 / 22000 = 0.303 s)
    with pytest.raises(PlanningError, match=r"J6 would need a speed of 33333 steps/s, above its maximum speed "
                                            r"22000 steps/s; give t >= 0\.31 s \(a t below 0\.40 s runs "
                                            r"stretched to 0\.40 s"):
        plan(JointMove([90, -90, 180, 0, 0, 200], duration_s=0.2), STANDBY)
    # from 0.31 s it runs, stretched to 0.40 s (within the position-tracking maximum 16714);
    # from 0.40 s in the t given
    assert plan(JointMove([90, -90, 180, 0, 0, 200], duration_s=0.31), STANDBY).duration == 0.4
    assert plan(JointMove([90, -90, 180, 0, 0, 200], duration_s=0.4), STANDBY).duration == 0.4


def test_acceleration_over_the_limit_with_a_duration_runs_in_that_time_with_a_warning():
    # 2 deg of J6 in 0.1 s: speed fine (1.875 * 355.6 / 0.1 = 6667 steps/s), acceleration
    # 5.7735 * 355.6 / 0.01 = 205000 steps/s^2 > the 66000 limit: the seed's "t overrides a
    # and v": it runs in 0.1 s, and its notes carry the warning naming J6, the figure, the limit
    tr = plan(JointMove([90, -90, 180, 0, 0, 182], duration_s=0.1), STANDBY)
    assert tr.duration == pytest.approx(0.1)
    assert np.array_equal(tr.positions[-1], deg_to_steps([90, -90, 180, 0, 0, 182]))
    need = 10 / np.sqrt(3) * 2 * SPD[5] / 0.1**2  # the quintic's peak, steps/s^2
    assert tr.notes == (f"warning: J6 needs an acceleration of {need:.0f} steps/s^2, above its limit 66000 "
                        f"steps/s^2 ({need / SPD[5]:.0f} deg/s^2 > 371 deg/s^2): the move runs in the t=0.1 s "
                        f"given",)
    # within the limit: no warning
    assert plan(JointMove([90, -90, 180, 0, 0, 182], duration_s=0.3), STANDBY).notes == ()


def test_j5_59_deg_in_0_8_s_runs_as_in_the_original_commanders_programs():
    # the original's demo: J5 by 59 deg in 0.8 s (quintic peak 37850 steps/s^2: over the old
    # 32000 cap, within the 3x-max-speed limit 66000): runs in 0.8 s, no warning
    target = [90, -90, 180, 0, 59, 180]
    tr = plan(JointMove(target, duration_s=0.8), STANDBY)
    assert tr.duration == 0.8 and tr.notes == ()
    # twice as fast: within the speed limit (1.875 * 4196 / 0.5 = 15733 < 16790), over the
    # acceleration limit (96900 > 66000): runs in 0.5 s with the warning
    tr = plan(JointMove(target, duration_s=0.5), STANDBY)
    assert tr.duration == 0.5
    need = 10 / np.sqrt(3) * 59 * SPD[4] / 0.5**2
    assert tr.notes == (f"warning: J5 needs an acceleration of {need:.0f} steps/s^2, above its limit 66000 "
                        f"steps/s^2 ({need / SPD[4]:.0f} deg/s^2 > 928 deg/s^2): the move runs in the t=0.5 s "
                        f"given",)
    # a lower configured limit (accel_factor 1.5: 33000 steps/s^2 on J5) warns at 0.8 s too
    slow = PAROL6.with_changes(accel_factor=1.5)
    tr = plan(JointMove(target, duration_s=0.8), STANDBY, model=slow)
    assert tr.duration == 0.8 and len(tr.notes) == 1 and "limit 33000 steps/s^2" in tr.notes[0]


def test_target_outside_joint_range_is_refused_before_planning():
    with pytest.raises(PlanningError) as ei:
        plan(JointMove([0, -150, 180, 0, 0, 180]), STANDBY)
    assert ei.value.joint == 1 and "J2 = -150.000 deg is outside the joint range" in str(ei.value)


def test_speed_tracking_streams_command_123_and_ends_with_zero_speed():
    tr = plan(JointMove([70, -80, 170, 0, 0, 180], duration_s=2, tracking="speed"), STANDBY)
    assert set(tr.commands.tolist()) == {Tracking.SPEED.board_command} == {123}
    assert np.all(tr.speeds[-1] == 0)


@pytest.mark.parametrize("profile", [Profile.RUCKIG, Profile.TOPPRA])
def test_ruckig_and_toppra_joint_moves_stay_inside_limits_and_end_on_target(profile):
    target = np.array([40, -60, 150, 30, 20, 120])
    tr = plan(JointMove(target, profile=profile), STANDBY)
    assert np.array_equal(tr.positions[-1], deg_to_steps(target))
    assert np.all(np.abs(tr.speeds) <= VMAX)
    acc = np.abs(np.diff(np.vstack([np.zeros(6), _speeds_f(tr)]), axis=0)) * 100
    assert np.all(acc <= AMAX * 1.02)
    timed = plan(JointMove(target, duration_s=tr.duration + 1.0, profile=profile), STANDBY)
    assert timed.duration == pytest.approx(tr.duration + 1.0, abs=0.011)
    with pytest.raises(PlanningError, match="too fast"):
        plan(JointMove(target, duration_s=tr.duration * 0.3, profile=profile), STANDBY)


def test_ruckig_profile_is_jerk_limited():
    tr = plan(JointMove([40, -60, 150, 30, 20, 120], profile="ruckig"), STANDBY)
    acc = np.diff(np.vstack([np.zeros(6), _speeds_f(tr)]), axis=0) * 100
    jerk = np.abs(np.diff(acc, axis=0)) * 100
    # full acceleration takes >= 0.1 s: jerk <= 32000 / 0.1 (plus rounding of steps/s)
    assert jerk.max() <= 32000 / 0.1 * 1.05 + 2e4


def test_zero_length_move_is_one_sample_at_target_or_holds_for_its_duration():
    tr = plan(JointMove(STANDBY), STANDBY)
    assert len(tr) == 1 and np.all(tr.speeds == 0)
    # the seed's program: MoveJoint(90,-90,180.001,0,0,180,t=4) from standby takes 4 s
    held = plan(JointMove([90, -90, 180.001, 0, 0, 180], duration_s=4), STANDBY)
    assert held.duration == 4.0 and np.all(held.speeds == 0)
    assert np.all(held.positions == deg_to_steps(STANDBY)) and "holding" in held.notes[0]


def test_speed_joint_streams_constant_speed_then_zero():
    tr = plan(SpeedJointMove([5, 0, 0, 0, 0, -10], 1.234), STANDBY)
    assert set(tr.commands.tolist()) == {123}
    v = tr.speeds_deg_s()
    assert np.allclose(v[:123, 0], 5, atol=0.01) and np.allclose(v[:123, 5], -10, atol=0.01)
    assert np.all(tr.speeds[-1] == 0)
    # the last partial tick makes the travelled distance exact
    assert tr.final_deg[0] == pytest.approx(90 + 5 * 1.234, abs=0.01)
    assert tr.final_deg[5] == pytest.approx(180 - 10 * 1.234, abs=0.01)


def test_speed_joint_refuses_leaving_the_range_and_says_how_long_is_allowed():
    with pytest.raises(PlanningError) as ei:
        plan(SpeedJointMove([50, 0, 0, 0, 0, 0], 2.0), STANDBY)
    e = ei.value
    assert e.joint == 0 and e.time_s == pytest.approx((123.046875 - 90) / 50, abs=0.002)
    assert "longest allowed duration is 0.66 s" in str(e)
    with pytest.raises(PlanningError, match="maximum speed"):
        plan(SpeedJointMove([0, 0, 0, 0, 0, 200], 0.5), STANDBY)


def test_joint_jog_by_distance_is_exact_and_uses_jog_speed():
    tr = plan(JointJog.from_index(9, 50, distance_deg=10), STANDBY)  # J4 negative
    assert set(tr.commands.tolist()) == {123}
    assert tr.speeds[0, 3] == -round(PAROL6.max_jog_speed_steps_s[3] * 0.5)
    assert tr.final_deg[3] == pytest.approx(-10, abs=1 / SPD[3])
    assert np.all(tr.speeds[-1] == 0)


def test_multi_joint_jog_moves_every_named_joint_at_its_jog_speed():
    tr = plan(JointJog((0, 2, 5), (1, -1, 1), (10, 20, 30), duration_s=0.5), STANDBY)
    jog = np.asarray(PAROL6.max_jog_speed_steps_s)
    assert tr.speeds[0, 0] == round(jog[0] * 0.1)
    assert tr.speeds[0, 2] == -round(jog[2] * 0.2)
    assert tr.speeds[0, 5] == round(jog[5] * 0.3)
    assert tr.speeds[0, 1] == 0 and len(tr) == 51


def test_jog_toward_a_limit_stops_exactly_at_it_and_says_so():
    tr = plan(JointJog.from_index(0, 100, duration_s=10), STANDBY)
    hi = PAROL6.safe_limits_deg[0, 1]
    assert tr.final_deg[0] == pytest.approx(hi, abs=1 / SPD[0])
    assert tr.positions[:, 0].max() <= PAROL6.limits_steps[0][1]
    assert tr.duration == pytest.approx((hi - 90) / (1500 / SPD[0]), abs=0.021)  # + the zero-speed tick
    assert np.all(tr.speeds[-1] == 0)
    assert any("stopped at the upper limit of J1" in n for n in tr.notes)
    # already at the limit: nothing moves
    at = STANDBY.copy()
    at[0] = hi
    tr2 = plan(JointJog.from_index(0, 50, duration_s=1), at)
    assert len(tr2) == 1 and np.all(tr2.speeds == 0) and "stopped" in tr2.notes[0]
    # jogging away from the limit is fine
    assert plan(JointJog.from_index(6, 50, duration_s=0.5), at).final_deg[0] < hi


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(target_deg=[0, 0, 0]), "target_deg"),
        (dict(target_deg=[0, 0, 0, 0, 0, float("nan")]), "target_deg[5]"),
        (dict(target_deg=[0] * 6, duration_s=-1), "duration_s"),
        (dict(target_deg=[0] * 6, speed_pct=101), "speed_pct"),
        (dict(target_deg=[0] * 6, accel_pct=-1), "accel_pct"),
        (dict(target_deg=[0] * 6, profile="cubic"), "profile"),
        (dict(target_deg=[0] * 6, tracking="torque"), "tracking"),
    ],
)
def test_bad_move_fields_are_rejected_naming_the_field(kwargs, field):
    with pytest.raises(ParolkitValueError, match=field.replace("[", r"\[").replace("]", r"\]")):
        JointMove(**kwargs)


def test_bad_jogs_are_rejected_naming_the_field():
    with pytest.raises(ParolkitValueError, match="joint index"):
        JointJog.from_index(12, 50, 1.0)
    with pytest.raises(ParolkitValueError, match="must not repeat"):
        JointJog((0, 0), (1, -1), (10, 10), 1.0)
    with pytest.raises(ParolkitValueError, match=r"speed_pct\[0\]"):
        JointJog((0,), (1,), (0,), 1.0)
    with pytest.raises(ParolkitValueError, match="duration_s and/or distance_deg"):
        JointJog((0,), (1,), (10,))


_lim = PAROL6.safe_limits_deg
_angles = st.tuples(*[st.floats(float(lo), float(hi)) for lo, hi in _lim])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(start=_angles, target=_angles,
       timing=st.one_of(st.none(), st.floats(0.5, 8.0),
                        st.tuples(st.floats(0, 100), st.floats(0, 100))),
       profile=st.sampled_from([None, "poly", "trap"]))
def test_property_no_sample_ever_exceeds_limits_or_misses_the_target(start, target, timing, profile):
    kw: dict = {"profile": profile}
    if isinstance(timing, float):
        kw["duration_s"] = timing
    elif isinstance(timing, tuple):
        kw["speed_pct"], kw["accel_pct"] = timing
    try:
        tr = plan(JointMove(target, **kw), np.array(start))
    except PlanningError as e:
        # only a too-short duration may be refused, and the message says the minimum
        assert isinstance(timing, float) and "too fast" in str(e)
        return
    lim = PAROL6.limits_steps_array
    assert np.all(tr.positions >= lim[:, 0]) and np.all(tr.positions <= lim[:, 1])
    assert np.all(np.abs(tr.speeds) <= VMAX)
    acc = np.abs(np.diff(np.vstack([np.zeros(6), _speeds_f(tr)]), axis=0)) * 100
    if not any(n.startswith("warning: ") for n in tr.notes):  # a duration may need more, with a warning
        assert np.all(acc <= AMAX * 1.02 + 100)  # + rounding of the integer speeds
    assert np.array_equal(tr.positions[-1], deg_to_steps(target))


def test_profile_and_tracking_accept_words_and_other_layers_enums():
    from enum import Enum

    class WireProfile(str, Enum):  # the shape of the protocol / script layers' enums
        TRAP = "trap"

    class WireTracking(Enum):
        SPEED = "speed"

    m = JointMove(STANDBY, profile=WireProfile.TRAP, tracking=WireTracking.SPEED)
    assert m.profile is Profile.TRAP and m.tracking is Tracking.SPEED
    assert JointMove(STANDBY, profile="POLY", tracking="position").profile is Profile.POLY
    assert JointMove(STANDBY, profile="none").profile is None
