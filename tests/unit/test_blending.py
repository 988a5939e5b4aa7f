"""Blending across queued moves (issue 24, item 4): the planner of a blended chain
(:func:`parolkit.motion.blending.plan_blended`) and the controller playing one, judged on the
frames a simulated board in lockstep received (one period per frame)."""

from __future__ import annotations

import numpy as np
import pytest
from tests.unit.test_live_motion import Bench as LiveMotionBench

from parolkit.errors import ParolkitValueError
from parolkit.kinematics import fk, fk_batch
from parolkit.motion.blending import plan_blended
from parolkit.motion.errors import PlanningError
from parolkit.moves import CartMove, JointMove, PoseMove
from parolkit.protocol.frames import BoardCommand
from parolkit.robot import PAROL6

START = np.array([90.0, -90.0, 180.0, 0.0, 30.0, 180.0])  # off the wrist singularity
SPD = np.asarray(PAROL6.steps_per_deg, dtype=float)


def _zigzag(p0, n: int = 20, r: float = 10.0, side: float = 15.0, step: float = 4.0):
    """``n`` MoveCart targets zigzagging +-``side`` mm in X while advancing ``step`` mm in Y
    each, every one but the last blended with ``r``."""
    return [CartMove([p0[0] + (side if i % 2 == 0 else -side), p0[1] + step * (i + 1), p0[2], *p0[3:]],
                     speed_pct=60, blend=r if i < n - 1 else None) for i in range(n)]


def _tcp(q_deg) -> np.ndarray:
    return np.asarray(fk_batch(np.asarray(q_deg, dtype=float)), dtype=float)[:, :3]


# ------------------------------------------------------------------------------ the planner


def test_a_20_segment_zigzag_plans_as_one_trajectory_through_every_corner_within_r_without_stopping():
    moves = _zigzag(fk(START))
    bp = plan_blended(moves, START, model=PAROL6)
    tr = bp.trajectory
    tcp = _tcp(tr.planned_deg)
    assert len(bp.marks) == 19 and list(bp.marks) == sorted(bp.marks) and len(set(bp.marks)) == 19
    for k, mark in enumerate(bp.marks):
        corner = np.asarray(moves[k].pose[:3])
        # the path passes the corner within r, nearest at the mark
        assert np.linalg.norm(tcp[mark] - corner) <= 10.0 + 1e-6, k
        lo = bp.marks[k - 1] if k else 0
        hi = bp.marks[k + 1] if k + 1 < len(bp.marks) else len(tcp)
        local = np.min(np.linalg.norm(tcp[lo:hi] - corner, axis=1))  # (corner k+2 is 8 mm on)
        assert np.linalg.norm(tcp[mark] - corner) == pytest.approx(local, abs=0.5)
    speed = np.linalg.norm(np.diff(tcp, axis=0), axis=1) * tr.rate_hz  # mm/s
    assert speed[bp.marks[0]:bp.marks[-1]].min() > 1.0  # never stops between the first and last corner
    assert np.allclose(tcp[-1], moves[-1].pose[:3], atol=1e-6)
    assert "blended chain of 20 moves" in tr.notes[0]


def test_a_joint_space_chain_rounds_each_corner_within_its_radius_and_ends_on_the_last_target():
    targets = [[100, -85, 175, 0, 30, 180], [110, -80, 180, 5, 35, 180], [100, -75, 185, 0, 30, 170]]
    moves = [JointMove(targets[0], speed_pct=50, blend=4), PoseMove(fk(targets[1]), blend=3),
             JointMove(targets[2], speed_pct=50)]
    bp = plan_blended(moves, START, model=PAROL6)
    q = bp.trajectory.planned_deg
    assert np.allclose(q[-1], targets[2])
    for k, r in ((0, 4.0), (1, 3.0)):
        assert np.linalg.norm(q[bp.marks[k]] - np.asarray(targets[k])) <= r + 0.5
    v = np.linalg.norm(np.diff(q, axis=0), axis=1)
    assert v[bp.marks[0]:bp.marks[1]].min() > 0.0  # no stop at the corners
    assert bp.trajectory.speeds[-1].tolist() == [0] * 6


def test_a_chain_of_mixed_kinds_or_one_move_is_refused_and_an_unreachable_pose_is_named_with_its_place():
    p0 = fk(START)
    with pytest.raises(ParolkitValueError, match="all MoveCart or all MoveJoint/MovePose"):
        plan_blended([CartMove(p0, blend=5), JointMove(START)], START, model=PAROL6)
    with pytest.raises(ParolkitValueError, match="2..100 moves"):
        plan_blended([CartMove(p0)], START, model=PAROL6)
    with pytest.raises(PlanningError, match=r"move 2 \(MovePose\)"):
        plan_blended([JointMove([100, -85, 175, 0, 30, 180], blend=5), PoseMove([900, 0, 100, 0, 0, 0])],
                     START, model=PAROL6)


# ------------------------------------------------------------------------------ the controller


class Bench(LiveMotionBench):
    """:class:`tests.unit.test_live_motion.Bench` (an in-process controller, homed, on a
    simulated board in lockstep, and its frame log) that also keeps every ack with the tick it
    came in, in the order they came."""

    def __init__(self) -> None:
        self.order: list[tuple[str, str, str, int]] = []
        super().__init__()

    def _ack(self, cid: str, status: str, details: str) -> None:
        super()._ack(cid, status, details)
        self.order.append((cid, status, details, self.sim.ticks))

    def statuses(self, cid: str) -> list[str]:
        return [st for st, _ in self.acks.get(cid, [])]

    def tick_of(self, cid: str, status: str) -> int:
        return next(t for c, st, _, t in self.order if c == cid and st == status)


@pytest.fixture()
def bench():
    b = Bench()
    yield b
    b.close()


def _cart(pose, r: float | None) -> str:
    return "MOVECART|" + "|".join(f"{v:.4f}" for v in pose) + "|None|60" + (f"|r={r:g}" if r else "")


def test_twenty_blended_movecarts_run_as_one_motion_each_completing_as_the_arm_passes_its_corner(bench):
    bench.run_until_done(bench.send("MOVEJOINT|90|-90|180|0|30|180|1|None"))
    moves = _zigzag(fk(START))
    ids = [bench.send(_cart(m.pose, m.blend)) for m in moves]
    bench.run_until_done(ids[-1], limit=6000)
    assert [bench.statuses(c)[-1] for c in ids] == ["COMPLETED"] * 20, bench.order[-3:]
    done = [bench.tick_of(c, "COMPLETED") for c in ids]
    starts = [bench.tick_of(c, "EXECUTING") for c in ids]
    assert done == sorted(done) and all(s == d for s, d in zip(starts[1:], done[:-1]))  # handed over
    # the arm, from the frames the board received: never at rest between the first and the
    # last corner, every corner passed within 10 mm
    frames = [(t, f) for t, f in bench.frames()
              if f.command == BoardCommand.GOTO and starts[0] <= t <= done[-1]]
    q = np.array([f.positions for _, f in frames], dtype=float) / SPD
    tcp = _tcp(q)
    t_of = [t for t, _ in frames]
    k0, k1 = t_of.index(done[0]), t_of.index(done[-2])
    steps = np.linalg.norm(np.diff(tcp[k0:k1], axis=0), axis=1)
    assert steps.min() > 0.005, "the TCP stood still between two corners"
    for m in moves[:-1]:
        assert np.min(np.linalg.norm(tcp - np.asarray(m.pose[:3]), axis=1)) <= 10.0 + 0.05


def test_stop_in_a_blended_chain_stops_on_its_path_and_cancels_the_moves_not_yet_reached(bench):
    moves = _zigzag(fk(START), n=6)
    bench.run_until_done(bench.send("MOVEJOINT|90|-90|180|0|30|180|1|None"))
    ids = [bench.send(_cart(m.pose, m.blend)) for m in moves]
    bench.run(1)
    while bench.statuses(ids[2])[-1] != "EXECUTING":
        bench.run(1)
    bench.send("STOP")
    bench.run_until_done(ids[2])
    assert bench.statuses(ids[0])[-1] == bench.statuses(ids[1])[-1] == "COMPLETED"
    assert [bench.statuses(c)[-1] for c in ids[2:]] == ["CANCELLED"] * 4
