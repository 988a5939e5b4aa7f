"""Live motion on the virtual clock (issue 24): the speed override (SPEED), pause on the path
(PAUSE / RESUME) and checkpoints (CHECKPOINT), judged on the frames the controller writes to
a simulated board in lockstep (one period per frame), with datagrams sent at ticks the test
chooses (:class:`~parolkit.controller.fastforward.InProcessController`).

The frames are GO TO (156) frames: a target (steps) and a feed-forward speed (steps/s); the
path speed is read from the feed-forward and from the targets' steps per tick."""

from __future__ import annotations

import io
import math
from collections.abc import Callable

import numpy as np
import pytest

from parolkit.config import load_config
from parolkit.controller.fastforward import InProcessController, parse_frame_log
from parolkit.kinematics.fk import fk
from parolkit.protocol.frames import BoardCommand, CommandFrame, IOBits
from parolkit.robot import PAROL6

RATE = 100.0
PERIOD = 1.0 / RATE
ACCEL = PAROL6.accel_limit_steps_s2
SPD = np.asarray(PAROL6.steps_per_deg, dtype=float)


class Bench:
    """An in-process controller, ready (homed), its frame log and the acks by command ID."""

    def __init__(self, rate_hz: float = RATE) -> None:
        self.log = io.StringIO()
        config = load_config(None, {"controller": {"rate_hz": rate_hz}}, search_default_paths=False)
        self.sim = InProcessController(config, paced=False, frame_log=self.log)
        self.sim.start()
        self.acks: dict[str, list[tuple[str, str]]] = {}
        self._n = 0

    def close(self) -> None:
        self.sim.close()

    def send(self, text: str) -> str:
        """Send ``ID|text`` now (it reaches the core at the next tick); returns the ID."""
        self._n += 1
        cid = f"lm{self._n:06d}"
        self.sim.send(f"{cid}|{text}".encode())
        self._collect()
        return cid

    def _collect(self) -> None:
        for d in self.sim.take_datagrams():
            parts = d.decode().split("|", 3)
            if parts[0] == "ACK":
                self._ack(parts[1], parts[2], parts[3] if len(parts) > 3 else "")

    def _ack(self, cid: str, status: str, details: str) -> None:
        self.acks.setdefault(cid, []).append((status, details))

    def run(self, ticks: int) -> None:
        self.sim.run_ticks(ticks)
        self._collect()

    def terminal(self, cid: str) -> tuple[str, str] | None:
        for status, details in self.acks.get(cid, []):
            if status in ("COMPLETED", "FAILED", "CANCELLED", "INVALID"):
                return status, details
        return None

    def run_until_done(self, cid: str, limit: int = 3000) -> tuple[int, tuple[str, str]]:
        """Tick until ``cid`` has its terminal ack: (ticks run, the ack)."""
        for k in range(limit):
            done = self.terminal(cid)
            if done is not None:
                return k, done
            self.run(1)
        raise AssertionError(f"{cid} did not end within {limit} ticks: {self.acks.get(cid)}")

    def frames(self) -> list[tuple[int, CommandFrame]]:
        return parse_frame_log(self.log.getvalue())

    @property
    def tick(self) -> int:
        return self.sim.ticks


@pytest.fixture()
def bench():
    b = Bench()
    yield b
    b.close()


def _gotos(frames: list[tuple[int, CommandFrame]], since: int) -> list[tuple[int, CommandFrame]]:
    return [(t, f) for t, f in frames if t >= since and f.command == BoardCommand.GOTO]


def _assert_speed_steps_within_accel(gotos: list[tuple[int, CommandFrame]], slack: float = 1.1) -> None:
    """From frame to frame, no joint's feed-forward speed changes by more than the acceleration
    limit allows in one period (``slack``: the rounding of speeds and the samples' own steps)."""
    for (t0, a), (t1, b) in zip(gotos, gotos[1:]):
        assert t1 == t0 + 1, "a GO TO frame every tick"
        for j in range(6):
            dv = abs(b.speeds[j] - a.speeds[j])
            assert dv <= ACCEL[j] * PERIOD * slack + 2, (t1, j, a.speeds[j], b.speeds[j])


def test_speed_50_halfway_through_a_movejoint_makes_the_rest_take_twice_as_long(bench):
    ref = Bench()
    try:
        cid = ref.send("MOVEJOINT|60|-80|170|10|-10|170|4|None")
        full_ticks, done = ref.run_until_done(cid)
        assert done[0] == "COMPLETED", done
    finally:
        ref.close()
    cid = bench.send("MOVEJOINT|60|-80|170|10|-10|170|4|None")
    start = bench.tick
    bench.run(200)  # halfway: 2 s of the 4
    speed = bench.send("SPEED|50")
    bench.run(1)
    assert bench.terminal(speed) == ("COMPLETED", "speed override 50 %")
    rest, done = bench.run_until_done(cid)
    assert done[0] == "COMPLETED", done
    first_half, second_half = 201, rest + 1
    # the rest (full_ticks - 201 at 100 %) takes twice as long, give or take the ramp (a few
    # ticks) and the settle at the end, which is not scaled
    assert abs(second_half - 2 * (full_ticks - first_half)) <= 30, (full_ticks, second_half)
    gotos = _gotos(bench.frames(), start)
    _assert_speed_steps_within_accel(gotos)
    # it ends on the target, exactly (the board's report, not the plan's)
    angles = bench.sim.controller.snapshot.angles_deg
    assert np.allclose(angles, (60, -80, 170, 10, -10, 170), atol=1.5 / SPD.min())
    # the override stays for the next move
    assert bench.sim.controller.snapshot.speed_pct == 50.0


def test_speed_is_refused_outside_1_to_100_naming_the_field(bench):
    for bad in ("0", "100.5", "-3", "fast", ""):
        cid = bench.send(f"SPEED|{bad}")
        bench.run(1)
        status, details = bench.terminal(cid) or ("", "")
        assert status == "INVALID" and "speed override (%)" in details or "SPEED takes 1" in details, (bad, details)
    assert bench.sim.controller.snapshot.speed_pct == 100.0


def _tcp(frame: CommandFrame) -> np.ndarray:
    """The TCP (mm) where a GO TO frame's target puts the joints."""
    deg = np.asarray(frame.positions, dtype=float) / SPD
    return np.asarray(fk(deg)[:3], dtype=float)


def _farthest_off_line(gotos: list[tuple[int, CommandFrame]], a, b) -> float:
    """How far (mm) the farthest of the frames' TCP targets lies from the line through ``a``
    and ``b`` (mm)."""
    p0, p1 = np.asarray(a[:3], dtype=float), np.asarray(b[:3], dtype=float)
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    worst = 0.0
    for _, f in gotos:
        q = _tcp(f) - p0
        worst = max(worst, float(np.linalg.norm(q - np.dot(q, d) * d)))
    return worst


def _completes(bench: Bench, text: str) -> None:
    """Send ``text`` and tick until it ends: it must be COMPLETED."""
    _, done = bench.run_until_done(bench.send(text))
    assert done[0] == "COMPLETED", (text, done)


def test_pause_mid_movecart_stops_on_the_line_holds_and_resume_ends_at_the_target(bench):
    start_pose = bench.sim.controller.snapshot.pose
    x, y, z, a, b, c = start_pose
    target = (x, y + 60.0, z - 40.0, a, b, c)
    cid = bench.send("MOVECART|" + "|".join(f"{v:.4f}" for v in target) + "|3|None")
    t_start = bench.tick
    bench.run(120)
    pause = bench.send("PAUSE")
    bench.run(1)
    status, details = bench.terminal(pause) or ("", "")
    assert status == "COMPLETED" and details.startswith("paused"), details
    bench.run(150)  # it slows down and holds
    assert bench.terminal(cid) is None  # still running: paused, not ended
    snap = bench.sim.controller.snapshot
    assert snap.paused and "PAUSED=1" in snap.reply_status()
    held = _gotos(bench.frames(), bench.tick - 50)
    assert len({f.positions for _, f in held}) == 1 and not any(any(f.speeds) for _, f in held), \
        "paused: the same target, no feed-forward, for the last 50 ticks"
    resume = bench.send("RESUME")
    rest, done = bench.run_until_done(cid)
    assert bench.terminal(resume) == ("COMPLETED", "resumed")
    assert done[0] == "COMPLETED", done
    gotos = _gotos(bench.frames(), t_start)
    _assert_speed_steps_within_accel(gotos)
    # every target on the way (the slow-down, the hold and the restart among them) is on the line
    worst = _farthest_off_line(gotos, start_pose, target)
    assert worst <= 0.05, f"a target {worst:.3f} mm off the line"
    p1 = np.asarray(target[:3])
    final = np.asarray(bench.sim.controller.snapshot.pose[:3])
    assert np.linalg.norm(final - p1) < 0.1


def test_a_pause_holds_the_queue_until_resume(bench):
    first = bench.send("DELAY|0.05")
    bench.run(2)  # the delay runs (a queued command starts at the tick after it came)
    paused = bench.send("PAUSE")
    move = bench.send("MOVEJOINT|0|-90|180|0|0|180|4|None")
    bench.run(60)
    # what runs and moves nothing (a delay, an output, a wait) runs to its end
    assert bench.terminal(first)[0] == "COMPLETED"
    assert bench.terminal(paused)[0] == "COMPLETED"
    assert [s for s, _ in bench.acks[move]] == ["QUEUED"], "nothing queued starts while paused"
    bench.send("RESUME")
    _, done = bench.run_until_done(move)
    assert done[0] == "COMPLETED", done


def test_stop_while_paused_cancels_the_move_and_ends_the_pause(bench):
    move = bench.send("MOVEJOINT|60|-80|170|10|-10|170|4|None")
    bench.run(100)
    bench.send("PAUSE")
    bench.run(60)
    bench.send("STOP")
    bench.run(2)
    assert bench.terminal(move)[0] == "CANCELLED"
    assert not bench.sim.controller.snapshot.paused
    _completes(bench, "MOVEJOINT|0|-90|180|0|0|180|4|None")


def test_a_checkpoint_is_acked_when_the_queue_reaches_it_and_takes_no_tick(bench):
    move = bench.send("MOVEJOINT|0|-90|180|0|0|180|4|None")
    mark = bench.send("CHECKPOINT|after-move.1")
    out = bench.send("PNEUMATICGRIPPER|open|1")
    bench.run(1)
    assert [s for s, _ in bench.acks[mark]] == ["QUEUED"]
    _, done = bench.run_until_done(move)
    assert done[0] == "COMPLETED", done
    move_end = bench.tick
    _, mark_done = bench.run_until_done(mark)
    assert mark_done == ("COMPLETED", "checkpoint after-move.1")
    _, out_done = bench.run_until_done(out)
    assert out_done[0] == "COMPLETED"
    # the output's frame follows the move's last frame at once: the checkpoint took no tick
    frames = bench.frames()
    first_out = next(t for t, f in frames if t >= move_end - 1 and f.io & IOBits.OUT1)
    assert first_out <= move_end, (first_out, move_end)


@pytest.mark.parametrize("bad, why", [
    ("CHECKPOINT", "CHECKPOINT takes 1 arguments, got 0"),
    ("CHECKPOINT|", "CHECKPOINT takes 1 arguments, got 0"),
    ("CHECKPOINT|a b", "label must be 1..64 characters"),
    ("CHECKPOINT|" + "x" * 65, "label must be 1..64 characters"),
])
def test_a_bad_checkpoint_label_is_refused_naming_the_rule(bench, bad, why):
    cid = bench.send(bad)
    bench.run(1)
    status, details = bench.terminal(cid) or ("", "")
    assert status == "INVALID" and why in details, details


# ---------------------------------------------------------------- RBTscript Speed(pct)


def test_rbtscript_speed_parses_formats_and_refuses_outside_1_to_100():
    from parolkit.script import Speed, parse

    res = parse("Begin()\nSpeed(50)\nMoveJoint(60,-80,170,10,-10,170,t=4, speed)\nEnd()\n")
    assert res.ok, res.errors
    speed = res.program.commands[1]
    assert isinstance(speed, Speed) and speed.percent == 50.0 and speed.to_source() == "Speed(50)"
    for bad, why in (("Speed(0)", "Speed = 0 % is out of range (allowed 1 .. 100 %)"),
                     ("Speed(120)", "Speed = 120 % is out of range (allowed 1 .. 100 %)"),
                     ("Speed()", "Speed takes 1 value (the speed override, %)"),
                     ("Speed(t=5)", "Speed takes one number, the override in % (1 .. 100)")):
        res = parse(f"Begin()\n{bad}\nEnd()\n")
        assert not res.ok and any(why in e.message for e in res.errors), (bad, [e.message for e in res.errors])


def test_the_dry_run_counts_the_moves_after_speed_at_their_stretched_time():
    from parolkit.script import dry_run, parse

    text = "Begin()\nMoveJoint(60,-80,170,10,-10,170,t=4)\nSpeed(25)\nMoveJoint(90,-90,180,0,0,180,t=4)\nEnd()\n"
    report = dry_run(parse(text).program, start_deg=(90, -90, 180, 0, 0, 180))
    assert not report.errors, report.errors
    rows = {r.line: r for r in report.rows}
    assert rows[2].duration_s == pytest.approx(4.0, abs=0.02)
    assert rows[3].duration_s == 0.0 and "speed override 25 %" in rows[3].note
    assert rows[4].duration_s == pytest.approx(16.0, abs=0.1) and "planned 4.00 s" in rows[4].note


def test_a_program_with_speed_runs_its_next_move_slower_at_the_board():
    from parolkit.client.robot import Robot
    from parolkit.script import Interpreter, parse

    def run(text: str) -> int:
        b = Bench()
        try:
            robot = Robot(channel=b.sim)
            start = b.tick
            result = Interpreter(parse(text).program, robot).run()
            assert result.ok, result.message
            robot.close()
            return b.tick - start
        finally:
            b.close()

    move = "MoveJoint(60,-80,170,10,-10,170,t=2)\n"
    full = run("Begin()\n" + move + "End()\n")
    half = run("Begin()\nSpeed(50)\n" + move + "End()\n")
    # 200 ticks of motion at 100 % take 400 at 50 % (the settle at the end is not scaled)
    assert abs((half - full) - 200) <= 5, (full, half)


def test_stop_mid_movecart_slows_down_on_the_line_and_clears_the_queue_at_once(bench):
    start_pose = bench.sim.controller.snapshot.pose
    x, y, z, a, b, c = start_pose
    target = (x, y + 60.0, z - 40.0, a, b, c)
    cid = bench.send("MOVECART|" + "|".join(f"{v:.4f}" for v in target) + "|2|None")
    queued = bench.send("MOVEJOINT|90|-90|180|0|0|180|4|None")
    t_start = bench.tick
    bench.run(100)  # mid-move, at speed
    stop = bench.send("STOP")
    bench.run(1)
    assert bench.terminal(stop) == ("COMPLETED", "stopping: the running move slows down on its path; "
                                                 "the queue is cleared")
    assert bench.terminal(queued) == ("CANCELLED", "stopped by STOP"), "the queue is cleared at once"
    assert bench.terminal(cid) is None, "the move runs on while it slows down"
    ticks, done = bench.run_until_done(cid, limit=100)
    assert done == ("CANCELLED", "stopped by STOP"), done
    assert 3 <= ticks <= 40, f"a controlled stop takes well under 0.4 s here, took {ticks} ticks"
    gotos = _gotos(bench.frames(), t_start)
    _assert_speed_steps_within_accel(gotos)
    assert _farthest_off_line(gotos, start_pose, target) <= 0.05
    last = gotos[-1][1]
    assert not any(last.speeds), "the last frame holds (no feed-forward)"
    bench.run(20)
    held = _gotos(bench.frames(), bench.tick - 10)
    assert all(f.positions == last.positions for _, f in held) or not held
    _completes(bench, "MOVEJOINT|90|-90|180|0|0|180|4|None")  # the robot takes the next command at once


def test_stop_during_a_jog_stops_within_a_frame_as_before(bench):
    jog = bench.send("JOG|0|50|2|None")
    bench.run(50)
    bench.send("STOP")
    bench.run(1)
    assert bench.terminal(jog)[0] == "CANCELLED"


# ---------------------------------------------------------------- servo streams (SERVOJ)


def _servo(bench: Bench, deg) -> str:
    return bench.send("SERVOJ|" + "|".join(f"{v:.5f}" for v in deg))


def _one_hz_curve(a0: np.ndarray) -> tuple[np.ndarray, Callable[[int], np.ndarray]]:
    """The 1 Hz curve the servo tests stream from ``a0`` (deg), one target a period, 300 of
    them (held at the last): each joint's amplitude (deg: the curve's peak acceleration 30 % of
    the joint's limit) and the target for period ``k``."""
    amp = 0.3 * ACCEL / (4 * math.pi**2) / np.abs(SPD)

    def curve(k: int) -> np.ndarray:
        return a0 + amp * (1 - math.cos(2 * math.pi * min(k, 299) * PERIOD))

    return amp, curve


def test_a_1_hz_curve_streamed_at_100_hz_with_10_percent_dropped_is_followed_within_2_ticks(bench):
    import random

    amp, curve = _one_hz_curve(np.asarray(bench.sim.controller.snapshot.angles_deg))
    rng = random.Random(7)
    start = bench.tick
    first = _servo(bench, curve(0))
    board = []
    dropped = 0
    for k in range(1, 300):
        if rng.random() < 0.1:
            dropped += 1
        else:
            _servo(bench, curve(k))
        bench.run(1)
        board.append((k, np.asarray(bench.sim.controller.snapshot.status.positions, dtype=float)))
    assert 15 <= dropped <= 45
    assert bench.acks[first][0][0] == "EXECUTING"
    # the lag: the shift of the curve that the board's reported positions fit best
    amp_steps = amp * np.abs(SPD)
    err = {}
    for lag in range(-3, 8):
        err[lag] = max(float(np.max(np.abs(p - curve(k - lag) * SPD) / amp_steps))
                       for k, p in board if k >= 40 and k - lag < 300)
    best = min(err, key=err.__getitem__)
    assert best <= 2 and err[best] < 0.15, err
    gotos = _gotos(bench.frames(), start)
    _assert_speed_steps_within_accel(gotos, slack=1.0)
    top = np.asarray(PAROL6.max_speed_steps_s, dtype=float)
    assert all(np.all(np.abs(np.asarray(f.speeds)) <= top) for _, f in gotos)
    # the last target held: the same target for 30 ticks, the arm on it and at rest
    last = curve(299)
    for _ in range(30):
        _servo(bench, last)
        bench.run(1)
    st = bench.sim.controller.snapshot.status
    assert np.allclose(st.positions, last * SPD, atol=1.0) and not any(st.speeds)
    assert bench.terminal(first) is None, "the stream runs while targets come"


@pytest.mark.parametrize("seed", range(5))
def test_a_curve_whose_targets_come_a_tick_late_at_random_is_followed_without_ringing(seed):
    """The 1 Hz curve with 10 % dropped, and 40 % of the targets a tick late (two in the next
    tick, the later wins): the way a client's datagrams come over a busy machine.  The speed
    estimate is a least-squares fit over the window, not the slope to one old target: the
    frames stay within half the amplitude of the curve (a two-point estimate rang up to four
    times the amplitude, and a generator step ruckig refused froze the stream on its last
    frame), within the speed and acceleration limits."""
    import random

    bench = Bench()
    try:
        amp, curve = _one_hz_curve(np.asarray(bench.sim.controller.snapshot.angles_deg))
        drops = random.Random(7)
        late = random.Random(seed)
        due: dict[int, list[int]] = {}
        for k in range(300):
            if k and drops.random() < 0.1:
                continue
            due.setdefault(k + (1 if late.random() < 0.4 else 0), []).append(k)
        start = bench.tick
        for t in range(330):
            for k in due.get(t, []):
                _servo(bench, curve(k))
            bench.run(1)
        gotos = _gotos(bench.frames(), start)
        t0 = gotos[0][0]
        amp_steps = amp * np.abs(SPD)
        err = {lag: max(float(np.max(np.abs(np.asarray(f.positions) - curve(t - t0 + 1 - lag) * SPD) / amp_steps))
                        for t, f in gotos if 40 <= t - t0 < 300) for lag in range(-3, 4)}
        best = min(err, key=err.__getitem__)
        assert err[best] < 0.5, {k: round(v, 3) for k, v in err.items()}
        _assert_speed_steps_within_accel(gotos, slack=1.0)
        top = np.asarray(PAROL6.max_speed_steps_s, dtype=float)
        assert all(np.all(np.abs(np.asarray(f.speeds)) <= top) for _, f in gotos)
    finally:
        bench.close()


@pytest.mark.parametrize("seed", range(5))
def test_a_curve_the_guards_box_holds_back_for_late_replies_is_rejoined_within_the_limits(seed):
    """Issue 23: the 1 Hz curve with 10 % dropped, while the board's replies come late (0.15 to
    0.25 s, for 1 to 4 ticks at a time, at random moments: a board-sim process or a tty held
    up on a busy machine), on the virtual clock.  Where the board may be is then uncertain:
    the guard's box holds the frames back (here for 1 to 16 ticks at a time, the motion
    held, as it must be).  Judged on the frames written, as the pty test judges them: the
    frames the box held back, and for as many ticks again after each hold plus 10, are not
    judged (the curve went on meanwhile, and running back onto it within the acceleration
    limit takes about as long again); the rest fit the curve best at most 2 ticks late, within
    0.15 of its amplitude.  No frame's feed-forward above the joint's maximum speed, nor the
    board's speed (read every millisecond); none changes by more than the acceleration limit
    allows in a period but into a frame the box held back.

    The follower used to restart from rest at the box's point after every hold and run back
    onto the curve with a proportional term that overshot: off by 0.27 to 0.37 of the
    amplitude after the holds, best 1 to 3 ticks late (beside two CPU hogs the pty test saw 0.6
    to 1.1 where the controller had taken no target for 12 ticks: the same restart from rest)."""
    import random

    from tests.unit.test_controller_core import Rig

    from parolkit.controller.activities import ServoActivity

    rig = Rig(link_timeout_ticks=50, link_hold_frames=2)
    try:
        amp, curve = _one_hz_curve(np.asarray(rig.angles))
        drops, late = random.Random(7), random.Random(seed)
        top = np.asarray(PAROL6.max_speed_steps_s, dtype=float)
        n0 = len(rig.frames)
        held: list[bool] = []
        peak = np.zeros(6)
        left, delay, last = 0, 0.0, -99
        for k in range(300):
            if k == 0 or drops.random() >= 0.1:
                rig.send(f"sv{k:06d}|SERVOJ|" + "|".join(f"{v:.5f}" for v in curve(k)))
            if not left and 30 <= k < 260 and k - last >= 30 and late.random() < 0.08:
                left, delay, last = late.randint(1, 4), late.choice([0.15, 0.2, 0.25]), k
            rig.emu.set_faults(delay_s=delay if left else 0.0, direction="from_board")
            left = max(0, left - 1)
            act = rig.core.jobs.activity
            before = act.held_ticks if isinstance(act, ServoActivity) else 0
            rig.step()
            held.append(isinstance(act, ServoActivity) and act.held_ticks > before)
            for _ in range(10):  # the board runs the period, its speed read every millisecond
                rig.emu.advance(PERIOD / 10)
                peak = np.maximum(peak, np.abs(rig.emu.speeds))
            rig.now += PERIOD
        rig.emu.clear_faults()
        frames = rig.frames[n0:]
        assert rig.terminal("sv000000") is None, rig.acks[-3:]
        t0 = next(i for i, f in enumerate(frames) if f.command == BoardCommand.GOTO)
        assert all(f.command == BoardCommand.GOTO for f in frames[t0:]), "a GO TO frame every tick"
        # the holds (held ticks less than 4 apart are one), and the frames judged
        holds: list[list[int]] = []
        for i in (i for i, h in enumerate(held) if h):
            if holds and i - holds[-1][1] < 4:
                holds[-1][1] = i
            else:
                holds.append([i, i])
        assert sum(held) >= 5, "the late replies held the stream back"
        skip = {i for a, b in holds for i in range(a, 2 * b - a + 12)}
        judged = [i for i in range(t0 + 40, len(frames)) if i not in skip]
        assert len(judged) > 120, (len(judged), holds)
        amp_steps = amp * np.abs(SPD)
        err = {lag: max(float(np.max(np.abs(np.asarray(frames[i].positions) - curve(i - t0 + 1 - lag) * SPD)
                                     / amp_steps)) for i in judged) for lag in range(-3, 8)}
        best = min(err, key=err.__getitem__)
        assert best <= 2 and err[best] < 0.15, (f"best {best} ticks late, off by {err[best]:.3f} of the amplitude",
                                                {k: round(v, 3) for k, v in err.items()},
                                                f"holds (tick, ticks): {[(a - t0, b - a + 1) for a, b in holds]}")
        assert all(np.all(np.abs(np.asarray(f.speeds)) <= top) for f in frames[t0:])
        assert np.all(peak <= top + 0.5), (peak, top)
        for i in range(t0 + 1, len(frames)):
            if not held[i]:
                _assert_speed_steps_within_accel([(i - 1, frames[i - 1]), (i, frames[i])], slack=1.0)
    finally:
        rig.close()


def test_250_targets_a_second_at_250_hz_are_each_taken_into_the_next_frame():
    """A controller at 250 Hz and a SERVOJ target every tick for 2 s (J6 on a minimum-jerk
    ramp of 30 deg, then held): every target taken (none refused or dropped; the status names
    it at the tick that took it), a GO TO frame every tick, and each frame goes toward the
    target of its own tick: the frames fit the targets' ramp best at most one tick late, within
    the speed and acceleration limits; the last target is reached, at rest."""
    b = Bench(rate_hz=250.0)
    try:
        period = 1.0 / 250.0
        a0 = np.asarray(b.sim.controller.snapshot.angles_deg)

        def target(k: int) -> np.ndarray:
            x = min(k / 400.0, 1.0)
            return a0 + np.asarray([0, 0, 0, 0, 0, 30.0 * x ** 3 * (10 - 15 * x + 6 * x * x)])

        start = b.tick
        ids, shown = [], []
        for k in range(500):
            ids.append(_servo(b, target(k)))
            b.run(1)
            shown.append(b.sim.controller.snapshot.command.target_id)  # the status: the target taken
        assert shown == ids, "each tick's status names the target that tick took"
        assert b.acks[ids[0]][0][0] == "EXECUTING"
        assert all(b.acks[c] == [("COMPLETED", "target taken")] for c in ids[1:]), \
            [(k, b.acks[c]) for k, c in enumerate(ids) if b.acks.get(c) != [("COMPLETED", "target taken")]][:3]
        gotos = _gotos(b.frames(), start)
        t0 = gotos[0][0]
        assert [t - t0 for t, _ in gotos[:500]] == list(range(500)), "a GO TO frame every tick"
        j6 = np.array([f.positions[5] for _, f in gotos[:500]], dtype=float) / SPD[5]
        err = {lag: float(np.max(np.abs(j6[20:400] - np.array([target(k - lag)[5] for k in range(20, 400)]))))
               for lag in range(-2, 5)}
        best = min(err, key=err.__getitem__)
        assert best <= 1 and err[best] < 0.05, {k: round(v, 4) for k, v in err.items()}
        for (_, a), (_, c) in zip(gotos, gotos[1:]):
            assert abs(c.speeds[5] - a.speeds[5]) <= ACCEL[5] * period * 1.0 + 2
        assert np.max(np.abs([f.speeds[5] for _, f in gotos])) <= PAROL6.max_speed_steps_s[5]
        assert abs(gotos[499][1].positions[5] - target(499)[5] * SPD[5]) <= 1.0 and not any(gotos[499][1].speeds)
    finally:
        b.close()


def test_silence_ends_a_servo_stream_with_a_controlled_stop(bench):
    a0 = np.asarray(bench.sim.controller.snapshot.angles_deg)
    speed = np.asarray([0, 0, 0, 0, 0, 20.0])  # deg/s on J6, a ramp
    start = bench.tick
    first = _servo(bench, a0)
    for k in range(1, 60):
        _servo(bench, a0 + speed * k * PERIOD)
        bench.run(1)
    last_target = (a0 + speed * 59 * PERIOD) * SPD
    moving = _gotos(bench.frames(), start)[-1][1].speeds[5]
    assert moving > 0.8 * 20 * SPD[5], "at the ramp's speed when the targets stop"
    ticks, done = bench.run_until_done(first, limit=100)
    assert done == ("COMPLETED", "servo stream ended: no target for 0.05 s, stopped under control"), done
    gotos = _gotos(bench.frames(), start)
    _assert_speed_steps_within_accel(gotos, slack=1.0)
    end = np.asarray(gotos[-1][1].positions, dtype=float)
    assert not any(gotos[-1][1].speeds)
    # it went on past the last target by no more than the timeout's travel and a braking distance
    v = 20 * SPD[5]
    assert 0 <= end[5] - last_target[5] <= v * 0.05 + v * v / (2 * ACCEL[5]) + 0.05 * v, (end[5], last_target[5])


def test_a_target_during_the_silences_slow_down_resumes_the_stream(bench):
    """A client whose datagrams were held up longer than servo.timeout_s (a busy machine): the
    stream has begun its controlled stop when the next target comes.  That target is taken by
    the same stream (not refused as "busy"), which goes on to it; only a silence that lasts
    until the arm is at rest ends the stream."""
    a0 = np.asarray(bench.sim.controller.snapshot.angles_deg)
    speed = np.asarray([0, 0, 0, 0, 0, 20.0])
    first = _servo(bench, a0)
    for k in range(1, 40):
        _servo(bench, a0 + speed * k * PERIOD)
        bench.run(1)
    bench.run(8)  # silent for 0.08 s: the slow-down has begun
    assert bench.terminal(first) is None
    goal = a0 + np.asarray([0, 0, 0, 0, 0, 2.0])
    late = _servo(bench, goal)
    for _ in range(60):
        _servo(bench, goal)
        bench.run(1)
    assert bench.terminal(late) == ("COMPLETED", "target taken"), bench.acks[late]
    assert bench.terminal(first) is None, "the same stream goes on"
    assert np.allclose(bench.sim.controller.snapshot.angles_deg, goal, atol=0.01)
    ticks, done = bench.run_until_done(first, limit=100)
    assert done[0] == "COMPLETED" and "no target for 0.05 s" in done[1]


def test_a_queued_move_ends_a_servo_stream_smoothly_then_runs(bench):
    a0 = np.asarray(bench.sim.controller.snapshot.angles_deg)
    first = _servo(bench, a0)
    for k in range(1, 40):
        _servo(bench, a0 + np.asarray([0, 0, 0, 0, 0, 20.0]) * k * PERIOD)
        bench.run(1)
    move = bench.send("MOVEJOINT|90|-90|180|0|0|180|3|None")
    bench.run(1)
    assert bench.terminal(first) is None, "the stream stops under control first"
    _, done = bench.run_until_done(first, limit=60)
    assert done == ("COMPLETED", "servo stream ended by MOVEJOINT, stopped under control")
    _, moved = bench.run_until_done(move)
    assert moved[0] == "COMPLETED", moved


def test_servo_is_refused_while_a_move_runs_and_out_of_range_targets_are_invalid(bench):
    move = bench.send("MOVEJOINT|60|-80|170|10|-10|170|4|None")
    bench.run(5)
    busy = bench.send("SERVOJ|60|-80|170|10|-10|170")
    bench.run(1)
    assert bench.terminal(busy) == ("FAILED", "robot is busy (MOVEJOINT): a servo stream starts when nothing else "
                                              "runs; wait for it or send STOP")
    bad = bench.send("SERVOJ|400|-80|170|10|-10|170")
    bench.run(1)
    status, details = bench.terminal(bad)
    assert status == "INVALID" and "J1 angle = 400 deg is out of range" in details
    bench.run_until_done(move)


def test_servol_follows_a_pose_target_in_the_world_and_in_the_tool_frame(bench):
    pose = np.asarray(bench.sim.controller.snapshot.pose)
    first = bench.send("SERVOL|" + "|".join(f"{v:.4f}" for v in pose + [0, 0, -5, 0, 0, 0]))
    for _ in range(80):
        bench.send("SERVOL|" + "|".join(f"{v:.4f}" for v in pose + [0, 0, -5, 0, 0, 0]))
        bench.run(1)
    now = np.asarray(bench.sim.controller.snapshot.pose)
    assert np.allclose(now[:3], pose[:3] + [0, 0, -5], atol=0.05), now
    assert bench.acks[first][0][0] == "EXECUTING"
    bench.run_until_done(first)
    # TRF: offsets from the TCP pose where the stream started, in its tool frame
    start = np.asarray(bench.sim.controller.snapshot.pose)
    trf = bench.send("SERVOL|0|0|10|0|0|0|TRF")
    for _ in range(80):
        bench.send("SERVOL|0|0|10|0|0|0|TRF")
        bench.run(1)
    from parolkit.kinematics.pose import pose_to_matrix

    m = pose_to_matrix(start)
    expected = start[:3] + 10.0 * m[:3, 2]  # 10 mm along the start pose's tool z
    now = np.asarray(bench.sim.controller.snapshot.pose)
    assert np.allclose(now[:3], expected, atol=0.05), (now, expected)
    bench.run_until_done(trf)


def test_a_jog_above_the_tracking_maximum_says_it_runs_stretched_naming_the_joint(bench):
    jog = bench.send("JOG|5|100|0.5|None")  # J6 at 100 %: its maximum speed
    _, done = bench.run_until_done(jog)
    executing = [d for s, d in bench.acks[jog] if s == "EXECUTING"][0]
    assert "warning: J6 at " in executing and "above its position-tracking maximum 16714 steps/s" in executing
    assert done[0] == "COMPLETED" and "the same distance runs stretched" in done[1], done


# ---------------------------------------------------------------- programs on ticks


def test_a_programs_output_and_delay_lines_each_take_exactly_their_ticks_at_the_board(bench):
    from parolkit.client.robot import Robot
    from parolkit.script import Interpreter, parse

    program = ("Begin()\nOutput(1,HIGH)\nDelay(0.01)\nOutput(1,LOW)\nDelay(0.01)\nOutput(1,HIGH)\n"
               "Output(2,HIGH)\nDelay(1.5)\nOutput(1,LOW)\nEnd()\n")
    robot = Robot(channel=bench.sim)
    start = bench.tick
    result = Interpreter(parse(program).program, robot).run()
    robot.close()
    assert result.ok, result.message
    changes, last = [], (False, False)
    for tick, frame in bench.frames():
        if tick < start:
            continue
        io = (bool(frame.io & IOBits.OUT1), bool(frame.io & IOBits.OUT2))
        if io != last:
            changes.append((tick, io))
            last = io
    t0 = changes[0][0]
    # Output one tick, Delay(0.01) one tick, ..., Delay(1.5) exactly 150 ticks (the lines queue
    # ahead of execution: none waits for a round trip)
    assert [(t - t0, io) for t, io in changes] == [
        (0, (True, False)), (2, (False, False)), (4, (True, False)), (5, (True, True)), (156, (False, True))]


def test_pause_queue_lets_the_running_command_end_and_holds_the_next(bench):
    move = bench.send("MOVEJOINT|60|-80|170|10|-10|170|2|None")
    nxt = bench.send("MOVEJOINT|90|-90|180|0|0|180|2|None")
    bench.run(50)
    held = bench.send("PAUSE|QUEUE")
    bench.run(1)
    assert bench.terminal(held) == ("COMPLETED", "queue held: the running command goes on to its end; "
                                                 "nothing queued starts until RESUME")
    _, done = bench.run_until_done(move)
    assert done[0] == "COMPLETED", "the running move was not slowed: it ends as planned"
    bench.run(50)
    assert [s for s, _ in bench.acks[nxt]] == ["QUEUED"]
    assert bench.sim.controller.snapshot.as_dict()["queue_held"] is True
    bench.send("RESUME")
    _, done = bench.run_until_done(nxt)
    assert done[0] == "COMPLETED"
    bad = bench.send("PAUSE|NOW")
    bench.run(1)
    assert bench.terminal(bad)[0] == "INVALID" and "PAUSE takes nothing or QUEUE" in bench.terminal(bad)[1]


def test_resume_one_lets_one_held_command_start_and_the_queue_stays_held(bench):
    """RESUME|ONE (a program stepped one line with the lines after it queued ahead): each lets
    exactly one more queued command start, in order, and the queue stays held; a credit given
    with nothing queued is used by the next command to come; RESUME releases the rest and
    forgets unused credits; RESUME|anything-else is INVALID naming the rule.  (From a PAUSE on
    the path: test_resume_one_from_a_pause_on_the_path_ends_the_move_then_runs_one_more.)"""
    held = bench.send("PAUSE|QUEUE")
    outs = [bench.send(f"PNEUMATICGRIPPER|{'open' if k % 2 == 0 else 'close'}|1") for k in range(3)]
    bench.run(20)
    assert all([s for s, _ in bench.acks[c]] == ["QUEUED"] for c in outs), [bench.acks[c] for c in outs]
    assert bench.terminal(held)[0] == "COMPLETED"
    one = bench.send("RESUME|ONE")
    bench.run(20)
    assert bench.terminal(one) == ("COMPLETED", "one more command starts; the queue stays held")
    assert bench.terminal(outs[0])[0] == "COMPLETED"
    assert [s for s, _ in bench.acks[outs[1]]] == ["QUEUED"] and [s for s, _ in bench.acks[outs[2]]] == ["QUEUED"]
    assert bench.sim.controller.snapshot.as_dict()["queue_held"] is True
    bench.send("RESUME|ONE")
    bench.run(20)
    assert bench.terminal(outs[1])[0] == "COMPLETED" and bench.terminal(outs[2]) is None
    bench.send("RESUME")
    bench.run(5)
    assert bench.terminal(outs[2])[0] == "COMPLETED"
    # a credit with nothing queued: the next command to come starts, the one after it waits
    bench.send("PAUSE|QUEUE")
    bench.send("RESUME|ONE")
    bench.run(5)
    first, second = bench.send("DELAY|0.05"), bench.send("DELAY|0.05")
    bench.run(30)
    assert bench.terminal(first)[0] == "COMPLETED" and bench.terminal(second) is None
    # RESUME forgets unused credits: after it and a new hold, nothing starts
    bench.send("RESUME|ONE")
    bench.send("RESUME")
    bench.run(30)
    assert bench.terminal(second)[0] == "COMPLETED"
    bench.send("PAUSE|QUEUE")
    bench.run(1)
    third = bench.send("DELAY|0.05")
    bench.run(30)
    assert [s for s, _ in bench.acks[third]] == ["QUEUED"]
    bad = bench.send("RESUME|TWO")
    bench.run(1)
    assert bench.terminal(bad)[0] == "INVALID" and "RESUME takes nothing or ONE" in bench.terminal(bad)[1]


def test_resume_one_from_a_pause_on_the_path_ends_the_move_then_runs_one_more(bench):
    """A program paused on the path and stepped: the paused move goes on to its target, the
    next queued command runs, the one after it is held."""
    move = bench.send("MOVEJOINT|60|-80|170|10|-10|170|1|None")
    out, delay = bench.send("PNEUMATICGRIPPER|open|1"), bench.send("DELAY|0.05")
    bench.run(40)
    bench.send("PAUSE")
    bench.run(150)
    assert bench.terminal(move) is None and bench.sim.controller.snapshot.paused
    one = bench.send("RESUME|ONE")
    bench.run(1)
    assert bench.terminal(one) == ("COMPLETED", "the paused move goes on; one more command starts; the queue "
                                                "stays held")
    _, done = bench.run_until_done(move)
    assert done[0] == "COMPLETED"
    bench.run(30)
    assert bench.terminal(out)[0] == "COMPLETED" and [s for s, _ in bench.acks[delay]] == ["QUEUED"]
    bench.send("RESUME")
    _, done = bench.run_until_done(delay)
    assert done[0] == "COMPLETED"


def test_servol_from_the_standby_pose_passes_the_wrist_singularity_with_the_tcp_on_its_targets(bench):
    """Issue 24, item 1: at the standby pose J5 = 0, where the exact solution's J4 is undefined
    and jumps by 90 deg between nearby poses.  SERVOL follows the Cartesian jog's singular-area
    policy: J4 (and J6 the other way) turn within their limits while the TCP stays on the
    targets; once J4 has turned the orientation is exact.  (Before: J4 chased the jump, the TCP
    ran 40 mm off and the guard ended the stream at J4's limit.)"""
    from parolkit.kinematics.pose import pose_to_matrix

    snap = bench.sim.controller.snapshot
    assert abs(snap.angles_deg[4]) < 1e-6  # on the singularity
    pose = np.asarray(snap.pose)
    first = None
    worst = 0.0
    for k in range(1, 301):
        tgt = pose + np.array([20.0 * min(k, 100) / 100, 0, 0, 0, 0, 0])  # 20 mm along X in 1 s, then held
        cid = bench.send("SERVOL|" + "|".join(f"{v:.4f}" for v in tgt))
        first = first or cid
        bench.run(1)
        if k > 5:  # the TCP a tick behind its target: within the 0.2 mm the target moves per tick and then some
            now = np.asarray(bench.sim.controller.snapshot.pose)
            worst = max(worst, float(np.linalg.norm(now[:3] - tgt[:3])))
    assert worst < 2.0, worst
    assert bench.acks[first][0][0] == "EXECUTING" and bench.terminal(first) is None  # still streaming
    end = np.asarray(bench.sim.controller.snapshot.pose)
    assert np.allclose(end[:3], tgt[:3], atol=0.05), end
    rot_end, rot_tgt = pose_to_matrix(list(end))[:3, :3], pose_to_matrix(list(tgt))[:3, :3]
    angle = np.degrees(np.arccos(np.clip((np.trace(rot_end.T @ rot_tgt) - 1) / 2, -1, 1)))
    assert angle < 0.05, angle  # J4 has turned: the orientation is exact again
    bench.run(20)
    assert bench.terminal(first)[0] == "COMPLETED"


@pytest.mark.parametrize("late_ticks", [3, 6, 10])
def test_the_last_servo_target_taken_in_late_never_turns_the_arm_back(late_ticks):
    """J1 streamed at 400 steps/s, one SERVOJ target a tick, then the stream ends; its last
    target reaches the core ``late_ticks`` late (the controller's server held up on a busy
    machine: test_gamepad's stalled commander, the speed 402 ... 162, 4, then 153 ... 394 back).
    The frames' speed on J1 must never change sign: the arm slows down and comes to rest, it
    does not run back.  (It did: the follower's speed estimate takes the late target's tick
    as its time (a quarter of the stream's speed at 3 ticks), so the target it extrapolates lies
    behind the arm, which turns back at up to 965 steps/s; after the servo timeout (5 ticks) the
    late target restarts the stream toward a point behind the arm.)"""
    from tests.unit.test_controller_core import Rig

    rig = Rig(link_timeout_ticks=50, link_hold_frames=2)
    try:
        a0 = np.asarray(rig.angles, dtype=float)
        speed = 400 / SPD[0]  # deg/s
        n0 = len(rig.frames)
        last = 49

        def target(k: int) -> str:
            q = a0.copy()
            q[0] += speed * k * PERIOD
            return f"sv{k:06d}|SERVOJ|" + "|".join(f"{v:.5f}" for v in q)

        for k in range(last + 80):
            if k < last:
                rig.send(target(k))
            if k == last + late_ticks:
                rig.send(target(last))
            rig.step()
            for _ in range(10):
                rig.emu.advance(PERIOD / 10)
            rig.now += PERIOD
        speeds = [f.speeds[0] for f in rig.frames[n0:] if f.command == BoardCommand.GOTO]
        assert len(speeds) > last and max(speeds) > 300
        assert min(speeds) >= 0, speeds[last - 5:last + 40]
    finally:
        rig.close()
