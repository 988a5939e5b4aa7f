"""The robot model: published numbers, exact conversions, limit checks that name the joint."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from parolkit.errors import JointLimitError, ParolkitValueError
from parolkit.robot import (
    PAROL6,
    check_joint_limits_deg,
    check_joint_limits_steps,
    check_joint_speeds_steps_s,
    deg_s_to_steps_s,
    deg_to_steps,
    rad_to_steps,
    steps_s_to_deg_s,
    steps_to_deg,
    steps_to_rad,
)


def test_steps_per_degree_match_the_published_table():
    assert PAROL6.steps_per_deg == pytest.approx(
        [113.7778, 355.5556, 321.6931, 71.1111, 71.1111, 177.7778], abs=1e-4
    )


def test_standby_pose_converts_to_the_counts_the_firmware_writes_after_homing():
    assert deg_to_steps(PAROL6.standby_deg).tolist() == [10240, -32000, 57905, 0, 0, 32000]
    assert list(PAROL6.standby_steps) == [10240, -32000, 57905, 0, 0, 32000]


def test_published_degree_limits_convert_to_the_published_step_limits_by_truncation():
    spd = PAROL6.steps_per_deg
    trunc = np.trunc(PAROL6.limits_deg_array * spd[:, None]).astype(int)
    assert trunc.tolist() == [list(p) for p in PAROL6.limits_steps]


def test_safe_limits_always_round_to_counts_inside_the_step_limits():
    lim = PAROL6.safe_limits_deg
    steps = deg_to_steps(lim.T)
    check_joint_limits_steps(steps)
    # and they are never wider than the published degree limits
    assert np.all(lim[:, 0] >= PAROL6.limits_deg_array[:, 0])
    assert np.all(lim[:, 1] <= PAROL6.limits_deg_array[:, 1])


def test_rounding_is_to_nearest_step():
    spd = PAROL6.steps_per_deg[0]
    assert deg_to_steps([0.4 / spd, 0, 0, 0, 0, 0])[0] == 0
    assert deg_to_steps([0.6 / spd, 0, 0, 0, 0, 0])[0] == 1
    assert deg_to_steps([-0.6 / spd, 0, 0, 0, 0, 0])[0] == -1


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(-8_000_000, 8_000_000), min_size=6, max_size=6))
def test_steps_to_degrees_and_back_is_exact(steps):
    assert deg_to_steps(steps_to_deg(steps)).tolist() == steps
    assert rad_to_steps(steps_to_rad(steps)).tolist() == steps
    assert deg_s_to_steps_s(steps_s_to_deg_s(steps)).tolist() == steps


def test_conversions_are_vectorised_over_batches():
    q = np.tile(PAROL6.standby_deg, (5, 1))
    out = deg_to_steps(q)
    assert out.shape == (5, 6) and out.dtype == np.int64
    assert steps_to_deg(out).shape == (5, 6)


@pytest.mark.parametrize(
    "bad, fragment",
    [
        ([1, 2, 3], "6 values"),
        ([[1, 2, 3, 4, 5]], "shape"),
        ([0, 0, float("nan"), 0, 0, 0], "J3 is not a finite number"),
        ([0, 0, 0, 0, float("inf"), 0], "J5"),
        (["a", 0, 0, 0, 0, 0], "numbers"),
        (None, "6 values"),
    ],
)
def test_bad_joint_arrays_are_refused_with_the_field_named(bad, fragment):
    with pytest.raises(ParolkitValueError, match=fragment):
        deg_to_steps(bad)


def test_limit_check_names_joint_value_and_bound():
    q = list(PAROL6.standby_deg)
    q[4] = 97.2
    with pytest.raises(JointLimitError) as exc:
        check_joint_limits_deg(q)
    err = exc.value
    assert err.joint == 4 and err.joint_name == "J5" and err.value == pytest.approx(97.2)
    assert "J5 = 97.2 deg" in str(err) and "upper limit 90" in str(err)


def test_limit_check_reports_the_sample_of_a_batch():
    q = np.tile(PAROL6.standby_deg, (4, 1))
    q[2, 1] = -150
    with pytest.raises(JointLimitError, match=r"sample 2.*J2 = -150") as exc:
        check_joint_limits_deg(q)
    assert exc.value.sample == 2


def test_a_limit_error_survives_pickling_whole():
    """An error raised in a worker process (the commander's teach process) reaches the caller
    as itself: before, unpickling failed on the keyword-only arguments."""
    import pickle

    q = np.tile(PAROL6.standby_deg, (4, 1))
    q[2, 1] = -150
    with pytest.raises(JointLimitError) as exc:
        check_joint_limits_deg(q)
    back = pickle.loads(pickle.dumps(exc.value))
    assert type(back) is JointLimitError and str(back) == str(exc.value)
    assert (back.joint, back.value, back.sample, back.unit) == (1, -150, 2, exc.value.unit)


def test_step_limits_and_speed_limits():
    check_joint_limits_steps(PAROL6.standby_steps)
    with pytest.raises(JointLimitError, match="J1 = 14001 steps"):
        check_joint_limits_steps([14001, -32000, 57905, 0, 0, 32000])
    check_joint_speeds_steps_s([6500, -18000, 20000, 0, 0, 0])
    with pytest.raises(JointLimitError, match="J1 = 6501 steps/s"):
        check_joint_speeds_steps_s([6501, 0, 0, 0, 0, 0])
    with pytest.raises(JointLimitError, match="J6 = 18001"):
        check_joint_speeds_steps_s([0, 0, 0, 0, 0, 18001], jog=True)


def test_percent_maps_follow_the_original_software():
    assert PAROL6.speed_from_percent(0).tolist() == [100] * 6
    assert PAROL6.speed_from_percent(100).tolist() == list(PAROL6.max_speed_steps_s)
    assert PAROL6.accel_from_percent(50) == pytest.approx(100 + 0.5 * 31900)
    assert PAROL6.jog_speed_from_percent(100).tolist() == list(PAROL6.max_jog_speed_steps_s)
    assert PAROL6.cart_linear_speed_from_percent(100) == 60
    assert PAROL6.cart_angular_speed_from_percent(0) == pytest.approx(0.7)
    for bad in (-1, 100.5, float("nan"), "fast", None):
        with pytest.raises(ParolkitValueError, match="0..100"):
            PAROL6.speed_from_percent(bad)


def test_model_variants_are_validated():
    fast = PAROL6.with_changes(max_speed_steps_s=(15000, 25000, 32000, 10000, 10000, 27000))
    assert fast.max_speed_steps_s[0] == 15000 and PAROL6.max_speed_steps_s[0] == 6500
    with pytest.raises(ParolkitValueError, match="6 values"):
        PAROL6.with_changes(gear_ratios=(1, 2, 3))
    with pytest.raises(ParolkitValueError, match="J2 limits"):
        PAROL6.with_changes(limits_deg=((-1, 1), (5, -5), (0, 1), (0, 1), (0, 1), (0, 1)))
    with pytest.raises(ParolkitValueError, match="J1 speeds"):
        PAROL6.with_changes(min_speed_steps_s=(0, 100, 100, 100, 100, 100))


def test_dh_table_is_the_published_one():
    d = [r.d for r in PAROL6.dh]
    a = [r.a for r in PAROL6.dh]
    alpha = [r.alpha for r in PAROL6.dh]
    assert d == [0.1105, 0, 0, -0.17635, 0, -0.0628]
    assert a == [0.02342, 0.18, -0.0435, 0, 0, -0.04525]
    assert alpha == pytest.approx([-math.pi / 2, math.pi, math.pi / 2, -math.pi / 2, math.pi / 2, math.pi])
