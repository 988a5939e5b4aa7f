"""Property test of the safety guard (issue 12, item 4): random command sequences through the
guard into the real board emulator (virtual clock, its replies fed back to the guard as the
control loop does), every frame that goes out checked.

What may be random: the board command (GO TO near the board, a stream continuing at a random
fraction of the maximum speed, GO TO anywhere, JOG, IDLE, HOME, ENABLE, DISABLE, CLEAR_ERROR,
codes the controller never sends), targets, feed-forward and JOG speeds (up to 1.3x the
maximum), the E-stop, whether the board starts homed, lost replies, and the time between
frames (one to three periods: the loop writes at most one frame per period; a frame written
early after a late one is judged as one period after it, see the guard's docstring).
``homed`` is what the controller passes: the newest status says every joint is homed.

Checked for every frame written:

* E-stop -> DISABLE; HOME never twice in a row;
* every speed field within the maximum (JOG while not homed: the maximum jog speed);
* a GO TO target moves from the previous GO TO target by at most the maximum speed x the
  time between them (+1 step of rounding); the first GO TO after another frame lies at most
  one period of maximum-speed travel (+1) from where the board really is;
* the board's speeds: what each status frame reports, what each stepper starts the period at,
  and every stepper's speed at every firmware pass until the next frame, within the maximum
  + one step's worth (``ROUNDING_STEPS`` x 50 steps/s: a GO TO target is a whole step, so its
  start speed has that resolution; the guard allows it, the planners stay 3 % below).
"""

from __future__ import annotations

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from tests.unit.guard_bench import PERIOD, VMAX, GuardedBoard

from parolkit.controller.guard import ROUNDING_STEPS
from parolkit.protocol.frames import BoardCommand, CommandFrame
from parolkit.robot import GOTO_GAIN_PER_S, PAROL6

VJOG = tuple(float(v) for v in PAROL6.max_jog_speed_steps_s)
LO = [lo for lo, _ in PAROL6.limits_steps]
HI = [hi for _, hi in PAROL6.limits_steps]
TICK = [v * PERIOD for v in VMAX]
#: what the board may start a GO TO frame at: the maximum + one step of rounding
BOARD_MAX = [v + GOTO_GAIN_PER_S * ROUNDING_STEPS for v in VMAX]

_ff = st.floats(-1.0, 1.0) | st.floats(-1.3, 1.3) | st.just(0.0)
_ff6 = st.lists(_ff, min_size=6, max_size=6)
_lead6 = st.lists(st.just(0.0) | st.floats(-2.5, 2.5), min_size=6, max_size=6)
_action = st.one_of(
    st.tuples(st.just("near"), _lead6, _ff6),  # lead (ticks of max travel), feed-forward (x max)
    # a staircase on one joint at a fraction of its maximum speed (the planners' streams:
    # 0.76 at 100 %; beyond that the board would run faster than its maximum)
    st.tuples(st.just("stream"), st.floats(-1.2, 1.2) | st.floats(0.6, 1.05) | st.floats(-1.05, -0.6),
              st.integers(0, 5), st.integers(1, 40)),
    st.tuples(st.just("far"), st.lists(st.floats(0, 1), min_size=6, max_size=6), _ff6),
    st.tuples(st.just("jog"), st.lists(st.just(0.0) | st.floats(-1.2, 1.2), min_size=6, max_size=6)),
    st.tuples(st.sampled_from(["idle", "home", "enable", "disable", "clear", "unknown"])),
)
_step = st.tuples(
    _action,
    st.sampled_from([1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 3.0]),  # periods since the previous frame
    st.integers(0, 19).map(lambda n: n == 0),  # E-stop pressed (1 frame in 20)
    st.integers(0, 9),  # 0: this frame's reply is lost
)


def _frame(board: GuardedBoard, action: tuple, prev_target: list[float] | None) -> list[CommandFrame]:
    kind = action[0]
    pos = board.positions
    if kind == "near":
        _, lead, ff = action
        tgt = [p + f * t for p, f, t in zip(pos, lead, TICK)]
        return [CommandFrame(positions=tuple(int(round(x)) for x in tgt),
                             speeds=tuple(int(round(f * v)) for f, v in zip(ff, VMAX)), command=BoardCommand.GOTO)]
    if kind == "stream":  # a staircase on one joint at a fraction of its maximum speed
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
        return [CommandFrame(positions=pos, speeds=tuple(int(round(f * v)) for f, v in zip(action[1], VMAX)),
                             command=BoardCommand.JOG)]
    code = {"idle": BoardCommand.IDLE, "home": BoardCommand.HOME, "enable": BoardCommand.ENABLE,
            "disable": BoardCommand.DISABLE, "clear": BoardCommand.CLEAR_ERROR, "unknown": 7}[kind]
    return [CommandFrame(positions=pos, command=code)]


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(start_homed=st.integers(0, 4).map(bool), steps=st.lists(_step, min_size=1, max_size=40))
def test_every_frame_the_guard_lets_out_keeps_the_board_within_its_limits(start_homed, steps):
    b = GuardedBoard(homed=start_homed)
    prev_out: CommandFrame | None = None
    prev_goto_target: list[float] | None = None
    for action, periods, estop, reply_no in steps:
        for frame in _frame(b, action, prev_goto_target):
            b.estop = estop
            b.homed = b.status.all_homed
            arrival = b.positions  # where the board really is as the frame arrives
            wait = periods * PERIOD
            res = b.send(frame, wait, reply=reply_no != 0)
            out = res.frame
            ctx = (action[0], len(b.log), out, res.violation)
            # E-stop -> DISABLE; HOME once
            if estop:
                assert out.command == BoardCommand.DISABLE, ctx
            assert not (out.command == BoardCommand.HOME and prev_out is not None
                        and prev_out.command == BoardCommand.HOME), ctx
            # speed fields
            vlim = VJOG if out.command == BoardCommand.JOG and not b.homed else VMAX
            assert all(abs(v) <= m for v, m in zip(out.speeds, vlim)), ctx
            # GO TO steps
            if out.command == BoardCommand.GOTO:
                dt_prev = b.log[-2].wait if len(b.log) > 1 else PERIOD
                if prev_out is not None and prev_out.command == BoardCommand.GOTO:
                    for j in range(6):
                        step = abs(out.positions[j] - prev_out.positions[j])
                        assert step <= VMAX[j] * max(dt_prev, PERIOD) + 1, ctx
                else:
                    for j in range(6):
                        assert abs(out.positions[j] - arrival[j]) <= TICK[j] + 1 + 1e-9, (j, arrival, ctx)
                prev_goto_target = [float(p) for p in out.positions]
            # the board: status report, start of the period, every pass until the next frame
            sent = b.log[-1]
            assert all(abs(v) <= m for v, m in zip(sent.reply.speeds, VMAX)), ctx
            assert all(abs(v) <= m for v, m in zip(sent.start_speeds, BOARD_MAX)), (sent.start_speeds, ctx)
            assert all(v <= m for v, m in zip(sent.peak_speeds, BOARD_MAX)), (sent.peak_speeds, ctx)
            prev_out = out
            if out.command == BoardCommand.GOTO:
                peak = max(p / m for p, m in zip(sent.peak_speeds, VMAX))
                event(f"GO TO accepted, board at {min(int(peak * 10) * 10, 100)} % of its maximum or more")
            if res.violation:
                why = res.violation
                event(f"replaced: {why.split(' ')[1] if why.startswith('J') else why[:30]}")
