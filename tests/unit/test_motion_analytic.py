"""The fast joint-space path validates analytically (monotonic profile, closed-form peaks):
these tests prove it agrees with a brute-force, sample-by-sample scan of the same arrays."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from parolkit.motion import JointMove, PlanningError, Trajectory, plan, validate
from parolkit.motion.joint import sample_times
from parolkit.motion.profiles import ScalarProfile, quintic
from parolkit.robot import PAROL6

SPD = PAROL6.steps_per_deg
#: per-joint acceleration limits (steps/s^2): a move with a duration over them runs, with a warning
AMAX = PAROL6.accel_limit_steps_s2
_safe = PAROL6.safe_limits_deg
_pub = PAROL6.limits_deg_array
# targets inside the safe range; starts up to 1 deg beyond the published range on either side
# (so the sample-by-sample fallback for a start outside the limits is exercised too)
_targets = st.tuples(*[st.floats(float(lo), float(hi)) for lo, hi in _safe])
_starts = st.tuples(*[st.floats(float(lo) - 1.0, float(hi) + 1.0) for lo, hi in _pub])


def _brute_force(start, target, kind, T, rate):
    """The arrays the straightforward way (evaluate the profile at every tick, broadcast),
    and the verdict of the full scans in :mod:`parolkit.motion.validate` (None = accepted,
    else the PlanningError message)."""
    t = sample_times(T, rate)
    s, sd, _ = ScalarProfile(kind, T, T / 3.0 if kind == "trap" else 0.0)(t)
    delta = target - start
    q = start + s[:, None] * delta
    q[-1] = target
    qd = sd[:, None] * delta
    qd[-1] = 0.0
    pos = np.rint(q * SPD).astype(np.int64)
    sp_f = qd * SPD
    try:
        validate.check_positions("MoveJoint", t, pos, PAROL6)
        validate.check_speeds("MoveJoint", t, sp_f, PAROL6, limits=validate.speed_limits(PAROL6, rate, True))
    except PlanningError as exc:
        return t, pos, np.rint(sp_f).astype(np.int64), str(exc)
    return t, pos, np.rint(sp_f).astype(np.int64), None


def _continuous_overload(start, target, kind, T, rate, *, accel: bool = False, full: bool = False) -> float:
    """Largest peak speed / position-tracking max speed (``full``: / the maximum speed;
    ``accel``: peak |accel| / the joint's acceleration limit) over the joints, from the profile
    evaluated on a dense grid (20001 points), not from the closed-form peaks."""
    tt = np.linspace(0.0, T, 20001)
    if kind == "poly":
        _, sd, sdd = quintic(tt, T)
    else:
        _, sd, sdd = ScalarProfile("trap", T, T / 3.0)(tt)
    dist = np.abs((target - start) * SPD)
    vlim = np.asarray(PAROL6.max_speed_steps_s, dtype=float) if full else PAROL6.max_tracked_speed_steps_s(rate)
    if accel:
        return float(np.max(np.abs(sdd).max() * dist / AMAX))
    return float(np.max(np.abs(sd).max() * dist / vlim))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(start=_starts, target=_targets, duration=st.floats(0.02, 6.0),
       kind=st.sampled_from(["poly", "trap"]), rate=st.sampled_from([100.0, 250.0, 40.0]))
def test_analytic_validation_agrees_with_a_brute_force_scan(start, target, duration, kind, rate):
    start = np.array(start)
    target = np.array(target)
    if np.abs((target - start) * SPD).max() < 0.5:
        return  # a hold, not a move (tested elsewhere)
    move = JointMove(target, duration_s=duration, profile=kind)
    # over a joint's position-tracking maximum (but within its maximum speed) the move runs
    # stretched to the shortest duration within it, rounded up to 0.01 s
    over_track = _continuous_overload(start, target, kind, duration, rate)
    stretch = max(validate.round_up_duration(duration * over_track), duration * over_track)
    T = duration if over_track <= 1.0 else stretch
    t, pos, sp, verdict = _brute_force(start, target, kind, T, rate)
    try:
        tr = plan(move, start, rate_hz=rate)
    except PlanningError as exc:
        msg = str(exc)
        if "too fast" in msg:
            # refused from the closed-form peaks: the continuous profile does exceed a joint's
            # maximum speed (the samples may straddle the peak, so the scan need not see it)
            assert _continuous_overload(start, target, kind, duration, rate, full=True) > 1.0 - 1e-6
            assert "above its maximum speed" in msg
        elif abs(over_track - 1.0) > 1e-6:
            # a position outside the range: exactly the scan's first offending sample
            assert msg == verdict
        return
    assert _continuous_overload(start, target, kind, duration, rate, full=True) <= 1.0 + 1e-6
    stretched = [n for n in tr.notes if "runs stretched" in n]
    if abs(over_track - 1.0) <= 1e-6:
        return  # on the edge of the position-tracking maximum (either way is right)
    if over_track > 1.0:
        assert len(stretched) == 1 and stretched[0].endswith(f"the move runs stretched to {stretch:.2f} s")
        assert stretched[0].startswith("warning: J") and f"to finish in the t={duration:g} s given" in stretched[0]
    else:
        assert not stretched
    # accepted: the scan of the same samples finds nothing either ...
    assert verdict is None, verdict
    assert _continuous_overload(start, target, kind, T, rate) <= 1.0 + 1e-6
    # ... and the arrays are the brute-force ones (the matrix product may round differently
    # in the last ulp, which can move a sample that sits on a half step by one step)
    assert np.array_equal(tr.t, t)
    assert np.abs(tr.positions - pos).max() <= 1 and np.abs(tr.speeds - sp).max() <= 1
    assert np.array_equal(tr.positions[-1], pos[-1]) and np.all(tr.speeds[-1] == 0)
    lim = PAROL6.limits_steps_array
    assert np.all(tr.positions >= lim[:, 0]) and np.all(tr.positions <= lim[:, 1])
    assert np.all(np.abs(tr.speeds) <= PAROL6.max_tracked_speed_steps_s(rate))  # position-tracked
    # (and every tick's target step within what that speed covers in a tick, rounding aside)
    steps = np.abs(np.diff(np.vstack([np.rint(start * SPD), tr.positions]), axis=0))
    assert np.all(steps <= PAROL6.max_tracked_speed_steps_s(rate) / rate + 1)
    # accelerations: a duration given runs in its time (or stretched); over a joint's
    # acceleration limit the notes carry the warning (from the closed-form peak), within it not
    warned = [n for n in tr.notes if n.startswith(validate.WARNING_PREFIX) and "acceleration" in n]
    over_a = _continuous_overload(start, target, kind, T, rate, accel=True)
    if over_a > (1 + validate.ACCEL_TOLERANCE) * (1 + 1e-6):
        assert len(warned) == 1 and f"t={duration:g} s" in warned[0]
        if T != duration:
            assert f"runs in {T:.2f} s (stretched from the t={duration:g} s given)" in warned[0]
    elif over_a < (1 + validate.ACCEL_TOLERANCE) * (1 - 1e-6):
        assert not warned
        acc = np.abs(np.diff(np.vstack([np.zeros(6), tr.speeds.astype(float)]), axis=0)) * rate
        assert np.all(acc <= AMAX * (1 + validate.ACCEL_TOLERANCE) + rate)  # + integer rounding
    lo, hi = np.minimum(start, target), np.maximum(start, target)
    span = np.abs(target - start) * 1e-12 + 1e-9
    assert np.all(tr.planned_deg >= lo - span) and np.all(tr.planned_deg <= hi + span)
    assert np.array_equal(tr.planned_deg[-1], target)


def test_start_outside_the_range_is_refused_at_the_first_offending_sample_as_before():
    start = np.array(PAROL6.standby_deg, dtype=float)
    start[1] = PAROL6.limits_deg_array[1, 0] - 0.5  # J2 below its lower limit
    target = start.copy()
    target[1] = PAROL6.safe_limits_deg[1, 0] + 0.5  # 1 deg up, back inside
    with pytest.raises(PlanningError, match=r"J2 = .* deg .* is below the lower limit") as info:
        plan(JointMove(target, duration_s=2.0), start)
    assert info.value.time_s == pytest.approx(0.01)


def test_planned_arrays_are_read_only_and_shared_caches_cannot_be_changed():
    start = np.array(PAROL6.standby_deg, dtype=float)
    a = plan(JointMove([60, -80, 170, 10, 5, 170], duration_s=2.0), start)
    b = plan(JointMove([70, -85, 175, 0, 0, 160], duration_s=2.0), start)
    for arr in (a.t, a.positions, a.speeds, a.commands, a.planned_deg, a.start_deg):
        assert not arr.flags.writeable
        with pytest.raises(ValueError):
            arr[0] = 0
    # a second plan of the same duration has its own positions, the same (read-only) times
    assert not np.array_equal(a.positions, b.positions) and np.array_equal(a.t, b.t)
    # the caller's start array is not frozen by planning
    assert start.flags.writeable


def test_user_built_trajectory_is_still_converted_and_checked():
    tr = Trajectory(t=[0.01, 0.02], positions=[[0] * 6, [1] * 6], speeds=[[0] * 6] * 2,
                    commands=[156, 156], rate_hz=100.0, move="test")
    assert tr.positions.dtype == np.int64 and tr.commands.dtype == np.uint8
    with pytest.raises(ValueError, match="inconsistent trajectory arrays"):
        Trajectory(t=[0.01], positions=[[0] * 6] * 2, speeds=[[0] * 6] * 2, commands=[156] * 2,
                   rate_hz=100.0, move="test")


def test_move_already_at_its_target_with_a_duration_takes_exactly_that_long():
    start = np.array(PAROL6.standby_deg, dtype=float)
    for duration in (0.5, 1.234, 4.0):
        tr = plan(JointMove(start, duration_s=duration), start)
        assert tr.duration == pytest.approx(duration, abs=0.01 - 1e-9)
        assert tr.duration >= duration - 1e-9 and np.all(tr.speeds == 0)


def test_long_moves_are_planned_without_the_basis_cache_and_end_on_target():
    from parolkit.motion.profiles import BASIS_CACHE_MAX_SAMPLES

    start = np.array(PAROL6.standby_deg, dtype=float)
    target = [60, -80, 170, 10, 5, 170]
    duration = 1.5 * BASIS_CACHE_MAX_SAMPLES / 100.0
    tr = plan(JointMove(target, duration_s=duration, profile="trap"), start)
    assert len(tr) == round(duration * 100) and tr.duration == pytest.approx(duration)
    assert np.array_equal(tr.positions[-1], np.rint(np.array(target) * SPD).astype(np.int64))
    assert not tr.t.flags.writeable and not tr.commands.flags.writeable
