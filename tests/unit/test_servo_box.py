"""The servo stream's frames against the guard's box (issue 24: a frame the guard refused ended a stream)."""

from __future__ import annotations

from parolkit.controller.activities import ServoActivity, TickContext
from parolkit.protocol.frames import BoardCommand
from parolkit.robot import PAROL6, goto_goal


def test_a_servo_frame_held_back_by_the_guards_box_stays_inside_it_to_the_hundredth():
    """When late replies narrow the box the guard lets a GO TO goal lie in, the servo stream's
    frame is the box's nearest point, carried in whole steps plus the feed-forward's hundredths;
    dropping those hundredths put the goal up to half a step outside (the guard then refused
    the frame and the stream FAILED: 'J1 goal ... is 130.1 steps from where the board may be')."""
    lim = [(float(lo), float(hi)) for lo, hi in PAROL6.limits_steps]
    act = ServoActivity([20000.0] * 6, 0, rate_hz=100.0, max_speed_steps_s=PAROL6.max_speed_steps_s,
                        max_accel_steps_s2=PAROL6.accel_limit_steps_s2, jerk_time_s=0.05, timeout_ticks=5,
                        limits_steps=lim)
    origin = [float(lo + hi) / 2 for lo, hi in PAROL6.limits_steps]
    for tick in range(1, 30):
        # the box (late replies: where the board may be has moved on) lies 0.6..0.9 steps beyond
        # the last goal: its nearest point is a fraction of a step that rounds the other way
        box = [(o + 0.6, o + 0.9) for o in origin]
        ctx = TickContext(tick, tick / 100.0, 100.0, None, True, False, 1.0, PAROL6.limits_steps, box, origin)
        act.set_target([o + 5000.0 for o in origin], tick)
        req = act.step(ctx)
        assert req.command == BoardCommand.GOTO
        goal = goto_goal(req.positions, req.speeds)
        for j, (g, (lo, hi)) in enumerate(zip(goal, box)):
            assert lo - 1e-9 <= g <= hi + 1e-9, (tick, j, g, lo, hi)
        origin = list(goal)
