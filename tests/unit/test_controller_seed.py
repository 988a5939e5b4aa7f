"""The seed's details at the controller (issue 14), tick by tick on a controller core driving
the board emulator (virtual clock: the board advances one period per tick): Output() in one
tick, Gripper_cal() holding the queue until the gripper reports calibrated, position-tracked
moves ending exactly on the target, SPEEDJOINT refused at a joint limit, explicit zeros as "not
given", and the limits' warnings and refusals in the acks."""

from __future__ import annotations

import numpy as np
import pytest
from tests.unit.test_controller_core import RATE, Rig

from parolkit.controller.activities import TickContext, TrajectoryActivity
from parolkit.moves import SpeedJointMove
from parolkit.protocol.commands import AckStatus
from parolkit.protocol.frames import BoardCommand, GripperCommandBits, GripperMode, IOBits, StatusFrame
from parolkit.robot import PAROL6, deg_to_steps


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.close()


def _details(rig: Rig, cid: str, status: AckStatus) -> str:
    return next(d for c, s, d in rig.acks if c == cid and s is status)


def _fmt(values) -> str:
    return "|".join(f"{v:.3f}" for v in values)


def test_queued_outputs_change_the_level_on_consecutive_frames_one_tick_each(rig):
    n0 = len(rig.frames)
    rig.submit("aaaa0001|PNEUMATICGRIPPER|open|1")
    rig.submit("aaaa0002|PNEUMATICGRIPPER|close|1")
    rig.submit("aaaa0003|PNEUMATICGRIPPER|open|1")
    rig.run_until(lambda: rig.terminal("aaaa0003") is not None)
    assert [rig.terminal(f"aaaa000{i}") for i in (1, 2, 3)] == [AckStatus.COMPLETED] * 3
    out1 = [bool(f.io & IOBits.OUT1) for f in rig.frames[n0:]]
    first = out1.index(True)
    # each Output() holds OUT1 for exactly one frame before the next one's level goes out
    assert out1[first:first + 3] == [True, False, True], out1


def test_gripper_cal_completes_when_the_gripper_reports_calibrated_and_a_move_sent_right_after_is_not_lost(rig):
    """Issue 22 item 9: the calibrate ack came with its one frame, the move queued behind it
    reached the SSG-48 during its 1 s calibration, which ignores moves, and was lost for good.
    Now COMPLETED waits for the status to show the calibration ran and ended (an already
    calibrated gripper, second round, reports "calibrated" until the frame is taken: that is
    not the end), and the move goes out after it and reaches the jaws."""
    for cal, move, position in (("aaaa0001", "aaaa0002", 180), ("aaaa0003", "aaaa0004", 90)):  # first, again
        n0 = len(rig.outputs)
        rig.submit(f"{cal}|ELECTRICGRIPPER|calibrate")
        rig.submit(f"{move}|ELECTRICGRIPPER|move|{position}|255|400")
        rig.run_until(lambda move=move: rig.terminal(move) is not None)
        assert rig.terminal(cal) is AckStatus.COMPLETED and rig.terminal(move) is AckStatus.COMPLETED
        cal_at = [k for k, o in enumerate(rig.outputs) if k >= n0 and o.frame is not None
                  and o.frame.gripper_mode == GripperMode.CALIBRATE]
        assert len(cal_at) == 1
        done_at = rig.tick_of_ack(cal, AckStatus.COMPLETED)
        # the emulated SSG-48 calibrates for 1 s = 100 board periods; the ack follows within 3
        # more: the reply that shows it calibrated and a second one in a row
        assert 100 <= done_at - cal_at[0] <= 103, (cal_at, done_at)
        assert rig.outputs[done_at].snapshot.status.gripper.calibrated
        # the move's setpoints went out in that same tick, never during the calibration
        moved = [k for k, o in enumerate(rig.outputs) if k >= n0 and o.frame is not None
                 and o.frame.gripper_command & GripperCommandBits.MOVE and o.frame.gripper_position == position]
        assert moved[0] == done_at, (moved[:3], done_at)
        rig.run_until(lambda position=position: rig.emu.gripper.position == position, max_ticks=100)


def test_100_random_position_tracked_moves_end_exactly_on_their_target_at_the_board(rig):
    rng = np.random.default_rng(14)
    for k in range(100):
        target = np.round(np.array(PAROL6.standby_deg) + rng.uniform(-5.0, 5.0, 6), 3)
        cid = f"bbbb{k:04d}"
        rig.submit(f"{cid}|MOVEJOINT|{_fmt(target)}|{rng.uniform(0.8, 1.5):.2f}|None")
        rig.run_until(lambda cid=cid: rig.terminal(cid) is not None)
        assert rig.terminal(cid) is AckStatus.COMPLETED, rig.acks[-3:]
        # at the board, when the COMPLETED ack goes out: exactly the target, at rest
        assert rig.emu.positions == tuple(deg_to_steps(target).tolist()), k
        assert rig.emu.speeds == (0,) * 6


#: the goals the guard would allow around the test's target (the board a few steps from it)
_BOX = [(p - 100.0, p + 100.0) for p in (10240, -32000, 57905, 100, 0, 32000)]


def test_a_board_that_does_not_reach_the_target_fails_the_move_naming_the_joints():
    target = [10240, -32000, 57905, 100, 0, 32000]
    act = TrajectoryActivity(([target], [[0] * 6], [BoardCommand.GOTO]), settle_ticks=10)
    short = StatusFrame(positions=(10240, -32000, 57905, 98, 0, 32000), homed=0xFF, io=0x0F)
    steps = []
    for i in range(12):
        ctx = TickContext(tick=i, now=i / RATE, rate_hz=RATE, status=short, homed=True, stream_mode=False,
                          watchdog_s=0.2, limits_steps=PAROL6.limits_steps, box=_BOX)
        steps.append(act.step(ctx))
    # the target goes out every tick with zero feed-forward until the end
    assert all(s.command == BoardCommand.GOTO and s.positions == tuple(target) and not any(s.speeds)
               for s in steps[:11])
    assert all(s.done is None for s in steps[:10])
    assert steps[10].done is AckStatus.FAILED
    assert steps[10].details == ("the board did not reach the exact target within 0.10 s of the move's end: "
                                 "J4 at 98 steps, +2 from the target 100")
    # on target but still moving is not the end either
    act = TrajectoryActivity(([target], [[0] * 6], [BoardCommand.GOTO]), settle_ticks=3)
    moving = StatusFrame(positions=tuple(target), speeds=(0, 0, 0, 50, 0, 0), homed=0xFF, io=0x0F)
    ctx = TickContext(tick=0, now=0.0, rate_hz=RATE, status=moving, homed=True, stream_mode=False,
                      watchdog_s=0.2, limits_steps=PAROL6.limits_steps, box=_BOX)
    act.step(ctx)  # the (only) sample
    assert [act.step(ctx).done for _ in range(2)] == [None, None]
    last = act.step(ctx)
    assert last.done is AckStatus.FAILED and last.details.endswith("every joint on target but still moving (J4)")
    at_rest = StatusFrame(positions=tuple(target), homed=0xFF, io=0x0F)
    act = TrajectoryActivity(([target], [[0] * 6], [BoardCommand.GOTO]), settle_ticks=3)
    ctx = TickContext(tick=0, now=0.0, rate_hz=RATE, status=at_rest, homed=True, stream_mode=False,
                      watchdog_s=0.2, limits_steps=PAROL6.limits_steps, box=_BOX)
    act.step(ctx)
    assert act.step(ctx).done is AckStatus.COMPLETED


def test_speedjoint_over_udp_is_refused_at_a_joint_limit_like_the_script_form(rig):
    from parolkit import motion

    start = rig.angles.copy()
    rig.submit("aaaa0001|SPEEDJOINT|20|0|0|0|0|0|3")
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.FAILED
    # the same words as the planner's refusal of the script's SpeedJoint from the same joints
    with pytest.raises(motion.PlanningError) as ei:
        motion.plan(SpeedJointMove((20, 0, 0, 0, 0, 0), 3.0), start, model=PAROL6, rate_hz=RATE)
    assert _details(rig, "aaaa0001", AckStatus.FAILED) == str(ei.value)
    assert "J1 would reach" in str(ei.value) and "the longest allowed duration is 1.65 s" in str(ei.value)
    assert np.allclose(rig.angles, start, atol=1e-9)  # nothing moved
    # within the range it runs
    rig.submit("aaaa0002|SPEEDJOINT|20|0|0|0|0|0|1")
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
    assert rig.terminal("aaaa0002") is AckStatus.COMPLETED
    assert rig.angles[0] == pytest.approx(start[0] + 20, abs=0.05)


def test_explicit_zero_duration_speed_and_accel_over_udp_mean_not_given(rig):
    rig.submit("aaaa0001|MOVEJOINT|90|-85|175|0|0|180|0|50|0")  # t=0 v=50 a=0: v=50 %, default a
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    rig.submit("aaaa0002|MOVEJOINT|90|-90|180|0|0|180|1.5|0|0")  # t=1.5, v=0, a=0
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
    assert rig.terminal("aaaa0002") is AckStatus.COMPLETED
    assert rig.emu.positions == PAROL6.standby_steps


def test_move_over_the_acceleration_limit_completes_in_its_time_with_the_warning_in_its_ack(rig):
    n0 = len(rig.frames)
    rig.submit("aaaa0001|MOVEJOINT|90|-90|180|0|59|180|0.5|None")  # J5 by 59 deg in 0.5 s
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    done = _details(rig, "aaaa0001", AckStatus.COMPLETED)
    assert done.startswith("MoveJoint finished successfully; warning: J5 needs an acceleration of ")
    assert "above its limit 66000 steps/s^2" in done and "the move runs in the t=0.5 s given" in done
    assert done.endswith(_details(rig, "aaaa0001", AckStatus.EXECUTING))  # the warning, at the start too
    gotos = [f for f in rig.frames[n0:] if f.command == BoardCommand.GOTO]
    # 50 samples in 0.5 s, then a few ticks while the board closes its last steps
    assert 50 <= len(gotos) <= 50 + 10
    assert rig.emu.positions == tuple(deg_to_steps([90, -90, 180, 0, 59, 180]).tolist())


def test_move_over_a_speed_limit_is_refused_with_the_minimum_t(rig):
    rig.submit("aaaa0001|MOVEJOINT|90|-90|180|0|59|180|0.3|None")
    rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
    assert rig.terminal("aaaa0001") is AckStatus.FAILED
    msg = _details(rig, "aaaa0001", AckStatus.FAILED)
    # over J5's maximum speed (22000 steps/s): the shortest t accepted, and the t from which it
    # runs as given (within the position-tracking maximum)
    assert "J5 would need a speed of 26222 steps/s, above its maximum speed 22000 steps/s" in msg
    assert msg.endswith("give t >= 0.36 s (a t below 0.48 s runs stretched to 0.48 s: J5 position-tracking "
                        "maximum 16714 steps/s).")
    # the shortest t named runs, stretched to 0.48 s, and its acks say so
    n0 = len(rig.frames)
    rig.submit("aaaa0002|MOVEJOINT|90|-90|180|0|59|180|0.36|None")
    rig.run_until(lambda: rig.terminal("aaaa0002") is not None)
    assert rig.terminal("aaaa0002") is AckStatus.COMPLETED
    done = _details(rig, "aaaa0002", AckStatus.COMPLETED)
    assert ("MoveJoint finished successfully; warning: J5 needs 21852 steps/s to finish in the t=0.36 s given, "
            "above its position-tracking maximum 16714 steps/s") in done
    assert "the move runs stretched to 0.48 s" in done
    gotos = [f for f in rig.frames[n0:] if f.command == BoardCommand.GOTO]
    assert 48 <= len(gotos) <= 48 + 10  # 48 samples, then the board's last steps
    assert rig.emu.positions == tuple(deg_to_steps([90, -90, 180, 0, 59, 180]).tolist())
    rig.submit("aaaa0003|MOVEJOINT|90|-90|180|0|0|180|0.48|None")
    rig.run_until(lambda: rig.terminal("aaaa0003") is not None)
    assert rig.terminal("aaaa0003") is AckStatus.COMPLETED
    assert "runs stretched" not in _details(rig, "aaaa0003", AckStatus.COMPLETED)


def test_plan_warnings_join_any_other_detail_of_the_terminal_ack():
    from parolkit.controller.activities import WARNING_PREFIX
    from parolkit.controller.jobs import Job
    from parolkit.motion import validate
    from parolkit.protocol.commands import parse_datagram

    job = Job(seq=1, command=parse_datagram("aaaa0001|DELAY|1").command, command_id="aaaa0001", ack_addr=None,
              notes=("duration given: it overrides speed and acceleration percentages",
                                      "warning: J5 needs more", "warning: J6 needs more"))
    assert job.ack_details(AckStatus.COMPLETED, "done") == "done; warning: J5 needs more; warning: J6 needs more"
    assert job.ack_details(AckStatus.EXECUTING, "") == "warning: J5 needs more; warning: J6 needs more"
    assert job.ack_details(AckStatus.FAILED, "no") == "no"
    job.notes = ()
    assert job.ack_details(AckStatus.COMPLETED, "done") == "done"
    assert WARNING_PREFIX == validate.WARNING_PREFIX


@pytest.mark.parametrize("rate", [100.0, 250.0, 50.0])
def test_a_trajectory_plays_one_sample_a_tick_whatever_tick_it_starts_on(rate):
    """On a board in lockstep with the frames the schedule's time is the tick count x period,
    and the floating-point products are not exact (457 x 0.01 - 0.01 x 456 is not 0.01): the
    sample due was 0.999999... of a sample, played as the one before.  So a move started on
    some ticks stalled a tick and jumped two later, and ended a tick late: a fresh clone's
    recorded run and its replay differed by one tick in the second command's start.  Every
    start tick now plays sample k on the k-th tick and ends on the n-th."""
    n = 40
    samples = ([[10240 + 10 * i, -32000, 57905, 100, 0, 32000] for i in range(n)], [[1000, 0, 0, 0, 0, 0]] * n,
               [BoardCommand.GOTO] * n)
    box = [(-1e9, 1e9)] * 6
    late = []
    for start in range(0, 2000, 7):
        t0 = start * (1.0 / rate)
        act = TrajectoryActivity(samples, settle_ticks=10, started=t0, schedule_start=t0)
        played = []
        for k in range(n):
            ctx = TickContext(tick=start + k, now=(start + k) * (1.0 / rate), rate_hz=rate, status=None, homed=True,
                              stream_mode=False, watchdog_s=0.2, limits_steps=PAROL6.limits_steps, box=box)
            req = act.step(ctx)
            played.append((req.positions[0] - 10240) / 10)
        if played != list(range(n)) or act.i != act.n:
            late.append((start, [p for k, p in enumerate(played) if p != k][:3]))
    assert not late, late
