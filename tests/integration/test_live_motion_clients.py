"""SPEED, PAUSE, RESUME and CHECKPOINT through the real controller process and both clients
(issue 24), on a simulated board in lockstep with the frames: a pause is judged by the status
the controller reports (paused, the arm at rest on its way, the move still running), not by
the clock.  Who may send them: PAUSE any client (it only slows the robot, like STOP); SPEED
and RESUME only the holder of the control lease."""

from __future__ import annotations

import pytest
from tests.conftest import frames_pass, start_controller, wait_until

from parolkit.client.errors import CommandFailed
from parolkit.client.robot import Robot
from parolkit.errors import ParolkitValueError

TARGET = [60, -80, 170, 10, -10, 170]


@pytest.fixture()
def served(tmp_path):
    ctl = start_controller(log_dir=tmp_path, lockstep=True)
    yield ctl
    ctl.stop()


def _at_rest(r: Robot) -> bool:
    st = r.status()
    return st.paused and not any(st.speeds)


def test_robot_pauses_a_move_on_its_way_resumes_it_and_waits_for_a_checkpoint(served):
    with Robot(port=served.port, ack_port=0, timeout=2.0) as r:
        move = r.move_joints(TARGET, duration=4, wait=False)
        r.checkpoint("reached-target", wait=False)
        frames_pass(served.loop_stats, 100)
        assert r.pause().details.startswith("paused")
        wait_until(lambda: _at_rest(r), 20, what="the arm at rest, paused")
        held = r.angles()
        frames_pass(served.loop_stats, 30)
        assert r.angles() == held, "paused: the arm holds where it stopped"
        assert not move.done() and held != pytest.approx(TARGET, abs=0.5), "paused on the way, the move running"
        assert "PAUSED=1" in served.query("GET_STATUS")
        r.set_speed(50)
        assert r.status().speed_pct == 50.0
        r.resume()
        res = r.wait_checkpoint("reached-target", timeout=30)
        assert res.ok and res.details == "checkpoint reached-target"
        assert move.done() and move.result().ok
        assert r.angles() == pytest.approx(TARGET, abs=0.01)
        with pytest.raises(ParolkitValueError, match="no checkpoint 'never' was queued"):
            r.wait_checkpoint("never")
        with pytest.raises(ParolkitValueError, match="label must be 1..64 characters"):
            r.checkpoint("two words")
        with pytest.raises(ParolkitValueError, match="percent"):
            r.set_speed(0)


def test_robot_api_speed_pause_resume_and_checkpoints(served):
    from parolkit.client import robot_api

    before = robot_api.configure()
    robot_api.configure(port=served.port, ack_port=served.ack_port)
    try:
        assert robot_api.set_speed_override(40, wait_for_ack=True)["status"] == "COMPLETED"
        cid = robot_api.move_robot_joints(TARGET, duration=3, wait_for_ack=True, non_blocking=True)
        robot_api.checkpoint("one")
        assert robot_api.pause_robot(wait_for_ack=True)["status"] == "COMPLETED"
        st = robot_api.get_robot_status()
        assert st is not None and st["paused"] is True and st["speed_pct"] == 40.0
        assert robot_api.resume_robot(wait_for_ack=True)["details"] == "resumed"
        rec = robot_api.wait_checkpoint("one", timeout=30)
        assert rec["status"] == "COMPLETED" and rec["details"] == "checkpoint one"
        assert robot_api.check_command_status(cid)["status"] == "COMPLETED"
        with pytest.raises(ValueError, match="no checkpoint 'other'"):
            robot_api.wait_checkpoint("other")
        with pytest.raises(ValueError, match="percent"):
            robot_api.set_speed_override(101)
    finally:
        robot_api.configure(**{k: before[k] for k in ("host", "port", "ack_port")})


def test_any_client_may_pause_only_the_lease_holder_may_resume_or_change_the_speed(served):
    with Robot(port=served.port, ack_port=0, timeout=2.0) as owner, \
            Robot(port=served.port, ack_port=0, timeout=2.0) as other:
        owner.take_control()
        move = owner.move_joints(TARGET, duration=4, wait=False)
        frames_pass(served.loop_stats, 50)
        other.pause()  # anyone may slow the robot down
        wait_until(lambda: _at_rest(owner), 20, what="the arm at rest, paused")
        with pytest.raises(CommandFailed, match="RESUME refused"):
            other.resume()
        with pytest.raises(CommandFailed, match="SPEED refused"):
            other.set_speed(100)
        owner.resume()
        assert move.result(timeout=30).ok
        owner.release_control()


def _stream_to(port: int, send, start, end, steps: int, hold_until) -> None:
    """Stream targets from ``start`` to ``end`` (deg or pose) in ``steps``, one per status the
    controller publishes (one per tick: paced by its ticks, not by this process's sleeps),
    then the last one until ``hold_until()`` (a user holding a teleop device still)."""
    import threading

    ticks = threading.Semaphore(0)
    with Robot(port=port, ack_port=0, timeout=2.0) as watcher:
        sub = watcher.subscribe(1, callback=lambda _st: ticks.release())
        try:
            for k in range(1, steps + 1):
                assert ticks.acquire(timeout=10), "no status from the controller"
                send([a + (b - a) * k / steps for a, b in zip(start, end)])
            for _ in range(2000):  # 20 s of ticks at most
                if hold_until():
                    return
                assert ticks.acquire(timeout=10), "no status from the controller"
                send(list(end))
            raise AssertionError("the stream's last target was not reached in 2000 ticks")
        finally:
            sub.close()


def _at_rest_on(read, goal: float, tol: float):
    """``hold_until`` for :func:`_stream_to`: the value ``read()`` is within ``tol`` of ``goal``
    and has not changed since the last call (one tick), i.e. the arm has arrived, not passing
    through on its way (a stream that then ends stops from the speed it has: a follower still
    catching up after late ticks ended 0.018 deg past its target once)."""
    last: list[float] = []

    def settled() -> bool:
        v = read()
        still = bool(last) and abs(v - last[-1]) < 1e-3
        last[:] = [v]
        return still and abs(v - goal) < tol
    return settled


def test_servo_streams_from_robot_and_robot_api_reach_their_last_target_and_stop(served):
    from parolkit.client import robot_api

    with Robot(port=served.port, ack_port=0, timeout=2.0) as r:
        a0 = list(r.angles())
        end = a0[:5] + [a0[5] + 10.0]
        _stream_to(served.port, r.servo_j, a0, end, 100, _at_rest_on(lambda: r.angles()[5], end[5], 0.01))
        wait_until(lambda: r.status().command is None, 10, what="the stream's end (0.05 s of silence)")
        assert r.angles() == pytest.approx(end, abs=0.01)
        with pytest.raises(ParolkitValueError, match="angles"):
            r.servo_j([1, 2, 3])
        p0 = list(r.pose())
        goal = [p0[0], p0[1], p0[2] - 8.0, *p0[3:]]
        _stream_to(served.port, r.servo_l, p0, goal, 50, _at_rest_on(lambda: r.pose()[2], goal[2], 0.02))
        wait_until(lambda: r.status().command is None, 10, what="the stream's end")
        assert list(r.pose())[:3] == pytest.approx(goal[:3], abs=0.05)

    before = robot_api.configure()
    robot_api.configure(port=served.port, ack_port=served.ack_port)
    try:
        a1 = robot_api.get_robot_joint_angles()
        back = a1[:5] + [a1[5] - 10.0]
        _stream_to(served.port, robot_api.servo_joints, a1, back, 100,
                   _at_rest_on(lambda: robot_api.get_robot_joint_angles()[5], back[5], 0.01))
        wait_until(lambda: robot_api.get_robot_status()["command"] is None, 10, what="the stream's end")
        with pytest.raises(ValueError, match="frame"):
            robot_api.servo_pose([0, 262, 250, -90, 0, -90], frame="XYZ")
    finally:
        robot_api.configure(**{k: before[k] for k in ("host", "port", "ack_port")})
