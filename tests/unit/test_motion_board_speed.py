"""Issue 12, item 4, planner side: what the planners hand the controller keeps the BOARD within
every joint's maximum speed, at 100 % speed and acceleration and at the shortest durations they
accept, and moves shorter than a tick are refused with the shortest possible duration.

Every plan is played tick by tick through the safety guard into the board emulator (virtual
clock, replies fed back), as the controller plays it: the guard must never replace a frame and
no stepper may start a period (the fastest it runs in it) above its maximum speed.  Before the
planners knew the board's GO TO loop, 100 % speed started the board at 1.27x its maximum every
period, and a MOVECART of 1e-9 s was one frame jumping up to 1.59 ticks of maximum travel."""

from __future__ import annotations

import re

import numpy as np
import pytest
from tests.unit.guard_bench import RATE, VMAX, GuardedBoard

from parolkit import kinematics as kin
from parolkit.motion import (
    ArcCenterMove,
    ArcParamMove,
    BlendMove,
    CartJog,
    CartMove,
    CartRelTRFMove,
    CircleMove,
    HelixMove,
    JointMove,
    LineSegment,
    PlanningError,
    PoseMove,
    Profile,
    SplineMove,
    Trajectory,
    plan,
)
from parolkit.protocol.frames import BoardCommand, CommandFrame
from parolkit.robot import PAROL6

STANDBY = list(PAROL6.standby_deg)
#: a comfortable start (wrist away from its singularity)
START = [90.0, -100.0, 150.0, 10.0, 40.0, 170.0]
P0 = np.asarray(kin.fk(START))


def _play(board: GuardedBoard, tr: Trajectory, settle: int = 30) -> None:
    """Play ``tr`` as the controller does (one sample per tick, then its target held with no
    feed-forward); every frame must pass the guard unchanged."""
    for pos, spd, cmd in zip(tr.positions.tolist(), tr.speeds.tolist(), tr.commands.tolist()):
        res = board.send(CommandFrame(positions=tuple(pos), speeds=tuple(spd), command=cmd))
        assert res.violation is None and not res.replaced, (tr.name, len(board.log), res.violation)
    if tr.commands[-1] == BoardCommand.GOTO:
        for _ in range(settle):
            board.goto(tr.positions[-1])


def _board_at(start_deg) -> GuardedBoard:
    """A homed board (at standby), moved to ``start_deg`` by a planned MoveJoint through the guard."""
    b = GuardedBoard(every_pass=False)
    if not np.allclose(start_deg, STANDBY):
        _play(b, plan(JointMove(start_deg, speed_pct=100, accel_pct=100), STANDBY, rate_hz=RATE))
    b.log.clear()
    return b


def _peak(board: GuardedBoard) -> np.ndarray:
    """Fastest each stepper ran over the played frames, as a fraction of its maximum."""
    return np.max([np.asarray(s.peak_speeds) / np.asarray(VMAX) for s in board.log], axis=0)


X, Y, Z, A, B, C = (float(v) for v in P0)

#: moves at 100 % speed (and acceleration where it applies), each from START
FULL_SPEED = {
    "MoveJoint trap, J1 leads": JointMove([-90, -100, 150, 10, 40, 170], speed_pct=100, accel_pct=100),
    "MoveJoint trap, all joints": JointMove([20, -60, 200, -60, -40, 60], speed_pct=100, accel_pct=100),
    "MoveJoint poly": JointMove([20, -60, 200, -60, -40, 60], speed_pct=100, accel_pct=100, profile=Profile.POLY),
    "MoveJoint ruckig": JointMove([20, -60, 200, -60, -40, 60], speed_pct=100, accel_pct=100,
                                  profile=Profile.RUCKIG),
    "MoveJoint toppra": JointMove([20, -60, 200, -60, -40, 60], speed_pct=100, accel_pct=100,
                                  profile=Profile.TOPPRA),
    "MovePose": PoseMove([X - 60, Y - 40, Z - 60, A, B, C], speed_pct=100, accel_pct=100),
    "MoveCart": CartMove([X - 60, Y - 40, Z - 60, A, B, C], speed_pct=100),
    "MoveCartRelTRF": CartRelTRFMove([0, 0, -60, 0, 0, 20], speed_pct=100),
    "Circle": CircleMove([X, Y, Z - 25], 25, "XZ", speed_pct=100),
    "ArcCenter": ArcCenterMove([X + 20, Y - 20, Z, A, B, C], [X, Y - 20, Z], speed_pct=100),
    "ArcParam": ArcParamMove([X + 20, Y - 20, Z, A, B, C], 20, 90, speed_pct=100),
    "Helix": HelixMove([X + 15, Y, Z], 15, 10, -20, speed_pct=100),
    "Spline": SplineMove([[X + 20, Y, Z - 10, A, B, C], [X + 40, Y + 10, Z - 20, A, B, C],
                          [X, Y + 20, Z - 20, A, B, C]], speed_pct=100),
    "Blend": BlendMove([LineSegment([X + 40, Y, Z, A, B, C]), LineSegment([X + 40, Y, Z - 40, A, B, C]),
                        LineSegment([X, Y, Z - 40, A, B, C])], blend_radius_mm=10, speed_pct=100),
    "CartJog": CartJog("WRF", "Z-", 100, 1.0),
    "CartJog rotation": CartJog("TRF", "RZ+", 100, 1.0),
}


@pytest.mark.parametrize("name", list(FULL_SPEED))
def test_a_move_at_full_speed_keeps_the_board_within_its_maximum(name):
    move = FULL_SPEED[name]
    tr = plan(move, START, rate_hz=RATE)
    b = _board_at(START)
    _play(b, tr)
    peak = _peak(b)
    assert np.all(peak <= 1.0), (name, peak)
    if name.startswith("MoveJoint"):
        # ... and it does run the leading joint near its maximum: 100 % means the fastest
        # the board can follow (0.763 x maximum commanded, the board starting each tick up to
        # 1.27x that)
        assert peak.max() > 0.85, (name, peak)


def _shortest(move, start) -> float:
    """The shortest duration the planner names when it refuses ``move`` (s)."""
    with pytest.raises(PlanningError) as ei:
        plan(move, start, rate_hz=RATE)
    msg = str(ei.value)
    m = re.search(r"(?:give t >= |give a duration of at least )([0-9.]+) s", msg)
    assert m, msg
    return float(m.group(1))


#: moves given a duration (1e-9 s first), each from START
TIMED = {
    "MoveJoint": lambda t: JointMove([-90, -100, 150, 10, 40, 170], duration_s=t),
    "MoveJoint trap": lambda t: JointMove([20, -60, 200, -60, -40, 60], duration_s=t, profile=Profile.TRAP),
    "MoveJoint J3 small": lambda t: JointMove([90, -100, 151, 10, 40, 170], duration_s=t),
    "MovePose": lambda t: PoseMove([X - 60, Y - 40, Z - 60, A, B, C], duration_s=t),
    "MoveCart": lambda t: CartMove([X - 60, Y - 40, Z - 60, A, B, C], duration_s=t),
    "MoveCart 5 mm": lambda t: CartMove([X + 5, Y, Z, A, B, C], duration_s=t),
    "MoveCartRelTRF": lambda t: CartRelTRFMove([0, 0, -60, 0, 0, 20], duration_s=t),
    "MoveCartRelTRF 5 mm": lambda t: CartRelTRFMove([5, 0, 5, 0, 0, 0], duration_s=t),
    "Circle": lambda t: CircleMove([X, Y, Z - 25], 25, "XZ", duration_s=t),
    "ArcCenter": lambda t: ArcCenterMove([X + 20, Y - 20, Z, A, B, C], [X, Y - 20, Z], duration_s=t),
    "Spline": lambda t: SplineMove([[X + 20, Y, Z - 10, A, B, C], [X + 40, Y + 10, Z - 20, A, B, C]],
                                   duration_s=t),
    "ArcParam": lambda t: ArcParamMove([X + 20, Y - 20, Z, A, B, C], 20, 90, duration_s=t),
    "Helix": lambda t: HelixMove([X + 15, Y, Z], 15, 10, -20, duration_s=t),
    "Blend": lambda t: BlendMove([LineSegment([X + 40, Y, Z, A, B, C]), LineSegment([X + 40, Y, Z - 40, A, B, C])],
                                 blend_radius_mm=10, duration_s=t),
}


@pytest.mark.parametrize("name", list(TIMED))
def test_a_sub_tick_duration_is_refused_and_the_shortest_it_names_keeps_the_board_within_its_maximum(name):
    """t = 1e-9 s: refused (issue 12: MOVECART / MOVECARTRELTRF played it as one frame at up
    to 1.59x the maximum) with the joint and the shortest duration; a move at that shortest
    duration is accepted and plays within every maximum."""
    make = TIMED[name]
    with pytest.raises(PlanningError) as ei:
        plan(make(1e-9), START, rate_hz=RATE)
    msg = str(ei.value)
    assert re.search(r"J[1-6]", msg) and ("give t >=" in msg or "give a duration of at least" in msg), msg
    shortest = _shortest(make(1e-9), START)
    tr = plan(make(shortest), START, rate_hz=RATE)
    b = _board_at(START)
    _play(b, tr)
    assert np.all(_peak(b) <= 1.0), (name, shortest, _peak(b))


def test_a_cartesian_move_without_duration_is_stretched_within_the_position_tracking_maximum():
    """The existing convention for Cartesian moves given a speed: a joint that cannot follow
    stretches the duration (noted), and the stretched plan keeps the board within its maximum."""
    start = [90.0, -90.0, 180.0, 0.0, 10.0, 180.0]  # wrist near its singularity: J6 cannot keep up
    p = np.asarray(kin.fk(start))
    tr = plan(CartMove(list(p + np.array([60, 0, 0, 0, 0, 0])), speed_pct=100), start, rate_hz=RATE)
    assert any("stretched" in n for n in tr.notes), tr.notes
    b = _board_at(start)
    _play(b, tr)
    assert np.all(_peak(b) <= 1.0), _peak(b)
