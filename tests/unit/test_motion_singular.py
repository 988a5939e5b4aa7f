"""The wrist's singular-area policy (parolkit.motion.singular, kinematics.wrist): TCP position
exact, orientation deviation bounded and reported; the seed's Cartesian example programs run
every command on its own time from the standby pose."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from parolkit import kinematics as kin
from parolkit.kinematics.wrist import solve_with_j4
from parolkit.motion import CartJog, CartMove, CartRelTRFMove, PlanningError, plan, singular
from parolkit.robot import PAROL6

REPO = Path(__file__).resolve().parents[2]
STANDBY = np.array(PAROL6.standby_deg)


def test_solve_with_j4_reproduces_the_exact_solution_and_keeps_the_tcp_exact_with_another_j4():
    qs = np.array([[60, -80, 170, 10, 40, 170], [10, -100, 200, -30, -50, 100.0]])
    m = kin.fk_batch(qs, None, as_matrix=True)
    pos, rots = m[:, :3, 3] * 1e3, m[:, :3, :3]
    exact = solve_with_j4(pos, rots, qs[:, 3], qs)
    assert np.abs(exact.q_deg - qs).max() < 1e-9 and exact.deviation_deg.max() < 1e-5  # (arccos near 1)
    off = solve_with_j4(pos, rots, qs[:, 3] + 10, qs)
    assert off.position_error_mm < 1e-6  # the TCP exactly
    # the orientation error is at most the tilt J4 does not point at: |J5| sin(10 deg)
    assert np.all(off.deviation_deg <= np.abs(qs[:, 4]) * math.sin(math.radians(10)) + 1e-6)
    assert np.all(off.deviation_deg > 0.1)


@pytest.mark.parametrize("move", [
    CartMove([0.0, 263.23, 161.241, -90.0, 0.0, -89.499], duration_s=2.0),
    CartRelTRFMove([-80, 0, 0, 0, 0, 0], duration_s=2.0),
    CartRelTRFMove([0, -30, 0, 0, 0, 0], duration_s=2.0),  # needs J4 at +90 deg
])
def test_timed_cartesian_moves_from_standby_take_exactly_t_on_the_straight_line(move):
    tr = plan(move, STANDBY)
    assert tr.duration == pytest.approx(2.0, abs=1e-9)
    q = np.vstack([STANDBY, tr.planned_deg])
    m = kin.fk_batch(q, None, as_matrix=True)
    pos = m[:, :3, 3] * 1e3
    a, b = pos[0], pos[-1]
    u = (b - a) / np.linalg.norm(b - a)
    rel = pos - a
    assert np.linalg.norm(rel - np.outer(rel @ u, u), axis=1).max() <= 1e-3
    assert np.all(np.diff(rel @ u) >= -1e-9)
    want = kin.fk_matrix(STANDBY)[:3, :3] @ kin.pose_to_matrix(move.delta)[:3, :3] if isinstance(
        move, CartRelTRFMove) else kin.pose_to_matrix(move.pose)[:3, :3]
    end_err = math.degrees(math.acos(np.clip((np.trace(m[-1, :3, :3].T @ want) - 1) / 2, -1, 1)))
    assert end_err <= singular.END_DEVIATION_DEG + 1e-6  # ends on its pose


def test_a_move_too_short_for_the_wrist_turn_is_refused_with_the_shortest_duration():
    p = kin.fk(STANDBY)
    with pytest.raises(PlanningError, match=r"wrist singularity.*give a duration of at least (\d+\.\d+) s") as ei:
        plan(CartMove(p + np.array([50, 0, 0, 0, 0, 0]), duration_s=1.0), STANDBY)
    least = float(str(ei.value).split("at least ")[1].split(" s")[0])
    assert 1.0 < least < 3.0
    tr = plan(CartMove(p + np.array([50, 0, 0, 0, 0, 0]), duration_s=least), STANDBY)
    assert tr.duration == pytest.approx(least)


def test_a_jog_update_continues_the_turn_of_the_jog_it_replaces():
    """Planned from the commanded sample of the running jog with its JogStart (path orientation
    and speeds), the update goes on turning J4 at its speed and keeps the original orientation
    as its path's; replanned every tick, a held X+ jog still ends with the tool's orientation
    of the press (the deviation is not frozen in)."""

    r0 = kin.fk_matrix(STANDBY)[:3, :3]
    q, js = STANDBY.copy(), None
    for _ in range(150):  # 1.5 s, one update per tick
        tr = plan(CartJog("WRF", "X+", 50, 0.2), q, jog_start=js)
        q, js = tr.planned_deg[0], tr.jog_start(0)
    dev = math.degrees(math.acos(np.clip((np.trace(kin.fk_matrix(q)[:3, :3].T @ r0) - 1) / 2, -1, 1)))
    assert kin.fk(q)[0] - kin.fk(STANDBY)[0] == pytest.approx(PAROL6.cart_linear_speed_from_percent(50) * 1.5,
                                                              abs=0.05)
    assert q[3] < -80 and dev < 0.5  # J4 turned on (not restarted each tick); orientation back


def test_a_jog_beyond_the_deviation_bound_stops_with_the_reason():
    tr = plan(CartJog("WRF", "RZ+", 100, 2.0), STANDBY)
    assert any(n.startswith("stopped after") and "orientation would deviate" in n for n in tr.notes)
    assert tr.duration < 2.0


@pytest.mark.parametrize("program", ["cartesian_trf.rbt", "cartesian_relative_trf.rbt"])
def test_the_seed_cartesian_programs_run_every_command_on_its_own_time(program):
    """The seed's example programs 2 and 3 (MoveJoint to standby, then MoveCart): each
    Cartesian move lasts its path length / the 50 % speed (the original's timing), not longer
    (no wrist turn first, no stretch)."""
    from parolkit.script import load
    from parolkit.script.dryrun import dry_run

    report = dry_run(load(REPO / "examples" / program))
    assert report.ok, [e.format() for e in report.errors]
    v = PAROL6.cart_linear_speed_from_percent(50)
    w = PAROL6.cart_angular_speed_from_percent(50)
    rows = [r for r in report.rows if r.command.startswith("MoveCart")]
    assert rows
    prev = None
    for r in report.rows:
        if r.command.startswith("MoveCart"):
            assert "stretched" not in r.note and "first" not in r.note, r.note
            a = kin.fk_matrix(prev)
            b = kin.fk_matrix(r.target_deg)
            dist = np.linalg.norm(b[:3, 3] - a[:3, 3]) * 1e3
            ang = math.degrees(math.acos(np.clip((np.trace(a[:3, :3].T @ b[:3, :3]) - 1) / 2, -1, 1)))
            assert r.duration_s == pytest.approx(max(dist / v, ang / w), abs=0.011), r.command
        if r.target_deg is not None:
            prev = r.target_deg
