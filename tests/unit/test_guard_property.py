"""Property test of the safety guard: random frame sequences through the guard into the real
board emulator (virtual clock), with random timing of everything the PC does not control:
frames written one to three periods apart or delivered together (the operating system holding
one back), replies lost or read up to 40 ms late, the E-stop.  Every frame that goes out is
checked, and so is the board at every firmware pass.

What may be random: the board command (GO TO near the board, a stream stepping at a random
fraction of the maximum speed, GO TO anywhere, JOG, IDLE, HOME, ENABLE, DISABLE, CLEAR_ERROR,
codes the controller never sends), targets, feed-forwards and JOG speeds, the E-stop, whether
the board starts homed, and the timing above.  ``homed`` is what the controller passes: the
newest status says every joint is homed.

Checked for every frame written:

* E-stop -> DISABLE; HOME never twice in a row; JOG speeds only the probe's 1 step/s;
* every GO TO's goal within reach (vmax / 50 + rounding) of where the board really is as it
  arrives (unless the board is disabled: it ignores GO TO): the board starts it within its
  maximum speed, and stops within 20 ms of travel if no frame followed;
* the board's speeds at every firmware pass until the next frame within the maximum + the
  rounding allowance.
"""

from __future__ import annotations

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from tests.unit.guard_bench import PERIOD, VMAX, GuardedBoard

from parolkit.controller.guard import ROUNDING_STEPS
from parolkit.protocol.frames import BoardCommand, CommandFrame
from parolkit.robot import GOTO_GAIN_PER_S, PAROL6, goto_goal, goto_reach_steps

LO = [lo for lo, _ in PAROL6.limits_steps]
HI = [hi for _, hi in PAROL6.limits_steps]
REACH = goto_reach_steps(VMAX)
TICK = [v * PERIOD for v in VMAX]
#: what a stepper may run at: the maximum + the rounding allowance (50 steps/s per step of goal)
BOARD_MAX = [v + GOTO_GAIN_PER_S * ROUNDING_STEPS + 1 for v in VMAX]

_ff = st.floats(-1.0, 1.0) | st.floats(-1.3, 1.3) | st.just(0.0)
_ff6 = st.lists(_ff, min_size=6, max_size=6)
_lead6 = st.lists(st.just(0.0) | st.floats(-2.5, 2.5), min_size=6, max_size=6)
_action = st.one_of(
    st.tuples(st.just("near"), _lead6, _ff6),  # lead (ticks of max travel), feed-forward (x max)
    # a staircase on one joint at a fraction of its maximum speed (the planners' streams)
    st.tuples(st.just("stream"), st.floats(-1.2, 1.2) | st.floats(0.6, 1.05) | st.floats(-1.05, -0.6),
              st.integers(0, 5), st.integers(1, 40)),
    st.tuples(st.just("far"), st.lists(st.floats(0, 1), min_size=6, max_size=6), _ff6),
    st.tuples(st.just("jog"), st.lists(st.just(0.0) | st.just(1.0) | st.floats(-1.2, 1.2), min_size=6,
                                       max_size=6)),
    st.tuples(st.sampled_from(["idle", "home", "enable", "disable", "clear", "unknown"])),
)
_step = st.tuples(
    _action,
    # periods until the next frame: on time, late, or delivered together with it
    st.sampled_from([1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 3.0, 0.0, 0.1]),
    st.integers(0, 19).map(lambda n: n == 0),  # E-stop pressed (1 frame in 20)
    st.integers(0, 9),  # 0: this frame's reply is lost
    st.sampled_from([0.0, 0.0, 0.0, 0.001, 0.004, 0.015, 0.04]),  # the reply is read this late, s
)


def _frame(board: GuardedBoard, action: tuple, prev_target: list[float] | None) -> list[CommandFrame]:
    kind = action[0]
    pos = board.positions
    if kind == "near":
        _, lead, ff = action
        tgt = [p + f * t for p, f, t in zip(pos, lead, TICK)]
        return [CommandFrame(positions=tuple(int(round(x)) for x in tgt),
                             speeds=tuple(int(round(f * v)) for f, v in zip(ff, VMAX)), command=BoardCommand.GOTO)]
    if kind == "stream":
        _, frac, joint, n = action
        base = list(prev_target) if prev_target is not None else [float(p) for p in pos]
        out = []
        for k in range(1, n + 1):
            tgt = list(base)
            tgt[joint] += frac * TICK[joint] * k
            ff = [0] * 6
            ff[joint] = int(round(frac * VMAX[joint]))
            out.append(CommandFrame(positions=tuple(int(round(x)) for x in tgt), speeds=tuple(ff),
                                    command=BoardCommand.GOTO))
        return out
    if kind == "far":
        _, where, ff = action
        tgt = [lo + w * (hi - lo) for lo, hi, w in zip(LO, HI, where)]
        return [CommandFrame(positions=tuple(int(round(x)) for x in tgt),
                             speeds=tuple(int(round(f * v)) for f, v in zip(ff, VMAX)), command=BoardCommand.GOTO)]
    if kind == "jog":
        speeds = tuple(int(round(f)) if abs(f) == 1.0 else int(round(f * v)) for f, v in zip(action[1], VMAX))
        return [CommandFrame(positions=pos, speeds=speeds, command=BoardCommand.JOG)]
    code = {"idle": BoardCommand.IDLE, "home": BoardCommand.HOME, "enable": BoardCommand.ENABLE,
            "disable": BoardCommand.DISABLE, "clear": BoardCommand.CLEAR_ERROR, "unknown": 7}[kind]
    return [CommandFrame(positions=pos, command=code)]


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(start_homed=st.integers(0, 4).map(bool), steps=st.lists(_step, min_size=1, max_size=40))
def test_every_frame_the_guard_lets_out_is_a_bounded_commitment_whatever_the_timing(start_homed, steps):
    b = GuardedBoard(homed=start_homed)
    prev_out: CommandFrame | None = None
    prev_goto_target: list[float] | None = None
    for action, periods, estop, reply_no, reply_delay in steps:
        for frame in _frame(b, action, prev_goto_target):
            b.estop = estop
            b.homed = b.status.all_homed
            arrival = b.positions  # where the board really is as the frame arrives
            enabled = b.emu.enabled
            res = b.send(frame, periods * PERIOD, reply=reply_no != 0, reply_delay=reply_delay)
            out = res.frame
            ctx = (action[0], len(b.log), out, res.violation)
            if estop:
                assert out.command == BoardCommand.DISABLE, ctx
            assert not (out.command == BoardCommand.HOME and prev_out is not None
                        and prev_out.command == BoardCommand.HOME), ctx
            if out.command == BoardCommand.JOG:
                assert sum(1 for v in out.speeds if v) <= 1 and all(abs(v) <= 1 for v in out.speeds), ctx
            if out.command == BoardCommand.GOTO and enabled:  # a disabled board ignores it
                for j, g in enumerate(goto_goal(out.positions, out.speeds)):
                    assert abs(g - arrival[j]) <= REACH[j] + ROUNDING_STEPS + 1e-9, (j, arrival, ctx)
                prev_goto_target = [float(p) for p in out.positions]
            sent = b.log[-1]
            assert all(abs(v) <= m for v, m in zip(sent.reply.speeds, BOARD_MAX)), ctx
            assert all(abs(v) <= m for v, m in zip(sent.start_speeds, BOARD_MAX)), (sent.start_speeds, ctx)
            assert all(v <= m for v, m in zip(sent.peak_speeds, BOARD_MAX)), (sent.peak_speeds, ctx)
            prev_out = out
            if out.command == BoardCommand.GOTO:
                peak = max(p / m for p, m in zip(sent.peak_speeds, VMAX))
                event(f"GO TO accepted, board at {min(int(peak * 10) * 10, 100)} % of its maximum or more")
            if res.violation:
                why = res.violation
                event(f"replaced: {why.split(' ')[1] if why.startswith('J') else why[:30]}")
