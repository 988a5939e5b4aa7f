"""Live motion (issue 24) over a real pseudo-terminal: blending, PAUSE / RESUME on a MoveCart,
SPEED|50 halfway through a MoveJoint, a SERVOJ stream and a program's Output / Delay lines,
judged on the frames the board received and on the acks.

Real parts only: ``parolkit board-sim`` in its own process on a real pty with its exchange log on
(every command frame as it arrived, in order, all 56 bytes: ``docs/board-emulator.md``; the
frame log behind ``frames since=...`` keeps the command codes only, not the targets), the real
controller process on the pty (``tests.integration.test_controller_pty.Bench``), commands and
acks over real UDP.  Each test has its own board and controller.

What is judged, and on what:

* **the frames**: the GO TO (156) frames the board received, in the order it received them, one
  per controller tick (no other frame between them while a motion runs): their targets (steps,
  turned into degrees and through the forward kinematics into the TCP, mm) and their
  feed-forward speeds (steps/s).  Timing is judged in frames (the virtual clock: one frame, one
  period), never in seconds.  Where a blended move ends (its COMPLETED) is found in the frames
  by the planner's own rule: the frame nearest its target, walking on from the previous one;
* **the acks**: their statuses and details, and their order (one listener, one list in the
  order the datagrams came: the controller sends a hand-over's COMPLETED and the next move's
  EXECUTING in the same tick, in that order).

The wall clock is used only as generous timeouts of the waits; nothing is judged on it (the
SERVOJ datagrams go one per status the controller publishes, from a sender process of their own,
raised like the controller).  (The controller ticks on the wall clock and plays a planned move by it: a tick that
starts late moves the target further along the plan, the one right after it less far, and a
tick more than a period late skips the missed deadlines.  The servo stream's generator steps
one period per tick whatever the clock did.  The checks below hold either way.)

A blended chain sent to an IDLE controller blends its first move too (the server's plan ahead
for that move, made before the chain was queued, is dropped for the chain's plan: it once won
and the first move stopped at its target).
"""

from __future__ import annotations

import bisect
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from tests.conftest import wait_until
from tests.integration.boardsim import REPO_ROOT, BoardSim
from tests.integration.test_controller_pty import TERMINAL, AckListener, Bench

from parolkit.kinematics import fk, fk_batch
from parolkit.protocol.frames import BoardCommand, CommandFrame
from parolkit.robot import PAROL6

RATE = 100.0
PERIOD = 1.0 / RATE
ACCEL = np.asarray(PAROL6.accel_limit_steps_s2, dtype=float)
SPD = np.asarray(PAROL6.steps_per_deg, dtype=float)
#: the joints the tests start from (off the wrist singularity), as tests/unit/test_blending.py
START = (90.0, -90.0, 180.0, 0.0, 30.0, 180.0)
START_MOVE = "MOVEJOINT|" + "|".join(f"{v:g}" for v in START) + "|1|None"


# ------------------------------------------------------------------------------ the bench


class TimedAckListener(AckListener):
    """:class:`AckListener` that also keeps every ack in one list, in the order they came:
    ``(monotonic receive time, ID, status, details)``."""

    def __init__(self, port: int) -> None:
        self.log: list[tuple[float, str, str, str]] = []
        super().__init__(port)

    def _record(self, cid: str, status: str, details: str) -> None:
        super()._record(cid, status, details)
        self.log.append((time.monotonic(), cid, status, details))

    def index(self, cid: str, status: str) -> int:
        """Where the first ``status`` ack of ``cid`` is in :attr:`log`."""
        with self._cv:
            return next(i for i, (_, c, s, _) in enumerate(self.log) if c == cid and s == status)

    def entry(self, cid: str, status: str) -> tuple[float, str, str, str]:
        with self._cv:
            return self.log[self.index(cid, status)]


class ExchangeLog:
    """board-sim's exchange log, read as it grows: the command frames the board received
    (``ins``: ``(n, t, frame)``, ``n`` counting from 1 in the order they arrived, ``t`` the
    board's monotonic receive time) and where the board was when it took each in (``board``:
    ``n`` -> the positions of the status frame it answered frame ``n`` with, steps)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._offset = 0
        self._rest = b""
        self.ins: list[tuple[int, float, CommandFrame]] = []
        self.board: dict[int, tuple[int, ...]] = {}

    def update(self) -> ExchangeLog:
        with open(self.path, "rb") as f:
            f.seek(self._offset)
            data = f.read()
        self._offset += len(data)
        lines = (self._rest + data).split(b"\n")
        self._rest = lines.pop()  # a line being written
        for line in lines:
            if not line.strip():
                continue
            e = json.loads(line)
            if e["k"] == "in":
                self.ins.append((e["n"], e["t"], CommandFrame.decode(bytes.fromhex(e["raw"]))))
            elif e["k"] == "ex":
                self.board[e["n"]] = tuple(e["reply"]["p"])
        return self

    def idle_mark(self) -> int:
        """Once the newest frame the board received is not a GO TO (the controller idles: every
        frame of the motion before has arrived, however late the pty delivered it), its number:
        the frames after it are new."""
        def idle() -> int | None:
            self.update()
            return self.ins[-1][0] if self.ins and self.ins[-1][2].command != BoardCommand.GOTO else None

        return wait_until(idle, 10, what="an idle frame at the board")

    def gotos(self, after: int) -> list[tuple[int, CommandFrame]]:
        """The GO TO frames received after frame number ``after``, in order."""
        self.update()
        return [(n, f) for n, _, f in self.ins if n > after and f.command == BoardCommand.GOTO]


class MotionBench(Bench):
    """:class:`Bench` on a board-sim with its exchange log on, acks kept in order."""

    def __init__(self, tmp_path: Path, config_text: str = "") -> None:
        board = BoardSim(tmp_path, frame_log=None, exchange_log=True, speedup=100)
        try:
            super().__init__(tmp_path, link=board.link, config_text=config_text)
        except BaseException:
            board.close()
            raise
        self.board = board
        # nothing has been acked yet (the bench sent queries only): listen in order from here
        self.acks.close()
        self.acks: TimedAckListener = TimedAckListener(self.ctl.ack_port)
        self.exchange = ExchangeLog(board.record_path)


@pytest.fixture
def bench(tmp_path):
    b = MotionBench(tmp_path)
    yield b
    b.close()


# ------------------------------------------------------------------------------ helpers


def _deg(frame: CommandFrame) -> np.ndarray:
    return np.asarray(frame.positions, dtype=float) / SPD


def _tcp(frames: list[tuple[int, CommandFrame]]) -> np.ndarray:
    """The TCP (mm) where each frame's target puts the joints."""
    q = np.array([f.positions for _, f in frames], dtype=float) / SPD
    return np.asarray(fk_batch(q), dtype=float)[:, :3]


def _contiguous(frames: list[tuple[int, CommandFrame]], runs: int = 1) -> list[list[tuple[int, CommandFrame]]]:
    """Frames that follow each other on the wire (no other frame between: one per tick), in
    at most ``runs`` runs (motions one after another: several servo streams, :func:`_one_stream`);
    the runs."""
    ns = [n for n, _ in frames]
    cuts = [i + 1 for i, (a, b) in enumerate(zip(ns, ns[1:])) if b != a + 1]
    gaps = [(ns[i - 1], ns[i]) for i in cuts]
    assert len(cuts) < runs, f"other frames between the GO TO frames of one motion: {gaps[:5]}"
    return [frames[a:b] for a, b in zip([0, *cuts], [*cuts, len(frames)])]


def _assert_speed_steps_within_accel(frames: list[tuple[int, CommandFrame]], slack: float = 1.1) -> None:
    """From frame to frame, no joint's feed-forward speed changes by more than the acceleration
    limit allows in one period (as tests/unit/test_live_motion.py)."""
    for (n0, a), (n1, b) in zip(frames, frames[1:]):
        assert n1 == n0 + 1, "a GO TO frame every tick"
        for j in range(6):
            dv = abs(b.speeds[j] - a.speeds[j])
            assert dv <= ACCEL[j] * PERIOD * slack + 2, (n1, j, a.speeds[j], b.speeds[j])


def _path_speed(frames: list[tuple[int, CommandFrame]]) -> np.ndarray:
    """The TCP speed (mm/s) each frame's feed-forward asks for at its target."""
    q = np.array([f.positions for _, f in frames], dtype=float) / SPD
    v = np.array([f.speeds for _, f in frames], dtype=float) / SPD
    a = np.asarray(fk_batch(q), dtype=float)[:, :3]
    b = np.asarray(fk_batch(q + v * 1e-3), dtype=float)[:, :3]
    return np.linalg.norm(b - a, axis=1) / 1e-3


def _ok(bench: MotionBench, text: str, timeout: float = 30.0) -> None:
    status, details = bench.run(text, timeout)
    assert status == "COMPLETED", (text, status, details)


def _completes(bench: MotionBench, cid: str, timeout: float = 30.0) -> None:
    """The command ``cid`` (sent already) ends COMPLETED."""
    status, details = bench.acks.terminal(cid, timeout)
    assert status == "COMPLETED", (cid, status, details)


def _arrived(bench: MotionBench, after: int) -> list[tuple[int, CommandFrame]]:
    """The GO TO frames of the motion that ended (acked) after frame number ``after``, once all
    of them have reached the board: the ack comes from the controller's tick, while a board-sim
    held up on a busy machine may not have read that motion's last frames yet (a frame not yet
    read at the ack is not missing: it is on its way).  Waits for an idle frame after them."""
    end = bench.exchange.idle_mark()
    return [(n, f) for n, f in bench.exchange.gotos(after) if n < end]


def _motion(bench: MotionBench, after: int) -> list[tuple[int, CommandFrame]]:
    """The GO TO frames the board received after frame number ``after`` (all of them:
    :func:`_arrived`): one motion's, one a tick (no other frame between them)."""
    return _streamed(bench, after, 1)[0]


def _streamed(bench: MotionBench, after: int, streams: int) -> list[list[tuple[int, CommandFrame]]]:
    """:func:`_motion` of ``streams`` servo streams one after another (a sender held up past a
    stream's stop: :func:`_one_stream`): the GO TO frames of each, one a tick."""
    return _contiguous(_arrived(bench, after), streams)


def _pose_text(pose) -> str:
    return "|".join(f"{v:.4f}" for v in pose)


def _passes(tcp: np.ndarray, corners: list[np.ndarray], r: float, tol: float = 1.0) -> list[int]:
    """For each corner in order, the frame nearest it on the way: walking on from the previous
    corner's frame, the first local minimum of the distance within ``r`` + ``tol`` (the rule the
    planner marks each move's end by: parolkit.motion.blending._marks).  A corner the frames do
    not come within ``r`` + ``tol`` of fails."""
    out: list[int] = []
    i = 0
    for k, c in enumerate(corners):
        d = np.linalg.norm(tcp[i:] - c, axis=1)
        near = np.nonzero(d <= r + tol)[0]
        assert len(near), f"corner {k} {c.round(2)}: no frame within {r + tol} mm after frame {i} " \
                          f"(nearest {d.min():.2f} mm)"
        j = int(near[0])
        while j + 1 < len(d) and d[j + 1] <= d[j]:
            j += 1
        i += j
        out.append(i)
    return out


# ------------------------------------------------------------------------------ blending


def _zigzag(n: int = 20) -> list[list[float]]:
    """``n`` poses zigzagging +-15 mm in X around the start TCP, 4 mm on in Y each (same Z and
    orientation): tests/unit/test_blending.py's zigzag."""
    p0 = [float(v) for v in fk(START)]
    return [[p0[0] + (15.0 if i % 2 == 0 else -15.0), p0[1] + 4.0 * (i + 1), p0[2], *p0[3:]] for i in range(n)]


def _movecarts(poses: list[list[float]]) -> list[str]:
    """MOVECART datagrams at 60 %, ``r=10`` on all but the last."""
    last = len(poses) - 1
    return ["MOVECART|" + _pose_text(p) + "|None|60" + ("|r=10" if i < last else "") for i, p in enumerate(poses)]


def test_twenty_blended_movecarts_over_a_pty_hand_over_in_order_and_the_tcp_never_stops(bench):
    """20 MoveCarts zigzagging +-15 mm in X, 4 mm on in Y each, r=10 on all but the last
    (tests/unit/test_blending.py's zigzag), from the pose the MoveJoint before them reaches:
    all COMPLETED in order, each one's EXECUTING comes with the COMPLETED of the one before
    (handed over: "blended"); in the GO TO frames the board received, the TCP moves in every
    frame from the first corner to the second-to-last, and every corner is passed within 10 mm.

    The 20 datagrams go out while the MoveJoint runs, so the chain is queued whole before it
    starts (as a program's lines are).  Sent to an idle controller, the first one runs on its
    own: :func:`test_a_blended_chain_sent_to_an_idle_controller_blends_its_first_move_too`."""
    poses = _zigzag()
    n0 = bench.exchange.idle_mark()
    first = bench.send(START_MOVE)
    bench.acks.wait_status(first, "EXECUTING")
    ids = [bench.send(t) for t in _movecarts(poses)]
    assert bench.acks.terminal(first, 20)[0] == "COMPLETED"
    for cid in ids:
        status, details = bench.acks.terminal(cid, 60)
        assert status == "COMPLETED", (cid, status, details, bench.acks.statuses(cid))
    acks = bench.acks
    for k, cid in enumerate(ids):
        assert acks.statuses(cid) == ["QUEUED", "EXECUTING", "COMPLETED"], (k, acks.acks[cid])
    done = [acks.index(c, "COMPLETED") for c in ids]
    assert done == sorted(done), "COMPLETED in the order sent"
    for k in range(1, 20):
        before, now = acks.entry(ids[k - 1], "COMPLETED"), acks.entry(ids[k], "EXECUTING")
        assert acks.index(ids[k], "EXECUTING") > done[k - 1], f"move {k} EXECUTING before move {k - 1} COMPLETED"
        # handed over in one tick: nothing of these 20 acked between the two
        between = [e for e in acks.log[done[k - 1] + 1: acks.index(ids[k], "EXECUTING")] if e[1] in ids]
        assert not between, (k, between)
        assert "blended" in before[3] and "blended" in now[3], (k, before, now)
    # one plan for the 20: the first one's EXECUTING says so
    head = acks.entry(ids[0], "EXECUTING")[3]
    assert "blended chain of 20 moves" in head, head
    # the end: "finished successfully"; on a busy machine, replies late enough that the guard
    # held the frames back (a bounded commitment before speed) add the warning that says so,
    # and the TCP may then stand still for those frames (reported below, not judged)
    end = acks.entry(ids[-1], "COMPLETED")[3]
    held = end.startswith("MoveCart finished successfully; warning: ran stretched: for ") and \
        "the board could not be asked for more without risking its maximum speed (late replies" in end
    assert end == "MoveCart finished successfully" or held, end

    # the chain's frames: the GO TO frames after the last one at the MoveJoint's target (the
    # chain leaves it at once, on to Y + 80 mm, and never comes back)
    gotos = _arrived(bench, n0)
    at_start = [k for k, (_, f) in enumerate(gotos) if np.allclose(_deg(f), START, atol=0.01)]
    frames = gotos[at_start[-1] + 1:]
    _contiguous(frames)
    tcp = _tcp(frames)
    corners = [np.asarray(p[:3]) for p in poses]
    marks = _passes(tcp, corners[:-1], 10.0)
    dist = [float(np.linalg.norm(tcp[m] - c)) for m, c in zip(marks, corners)]
    assert max(dist) <= 10.0 + 0.05, [round(d, 3) for d in dist]
    # from the first corner to the second-to-last (the first and the 19th move's COMPLETED) the
    # TCP never stands still: every frame's feed-forward asks for motion (> 1 mm/s of path
    # speed), and from frame to frame the TCP moves more than 0.005 mm.  (The controller plays
    # a plan by the wall clock: a tick that runs right after a late one, less than a period
    # later, moves the target that much less.  So a single step is judged with the one after it
    # when it is shorter: two frames always span a period of the plan or more.)
    lo, hi = marks[0], marks[-1]
    speed = _path_speed(frames[lo: hi + 1])
    steps = np.linalg.norm(np.diff(tcp[lo: hi + 1], axis=0), axis=1)
    pairs = np.linalg.norm(tcp[lo + 2: hi + 1] - tcp[lo: hi - 1], axis=1)
    short = [lo + i for i in np.nonzero(steps <= 0.005)[0]]
    if not held:
        assert speed.min() > 1.0, f"frame {lo + int(speed.argmin())}: feed-forward {speed.min():.3f} mm/s"
        assert pairs.min() > 0.005, f"the TCP stood still at frame {lo + int(pairs.argmin())}"
        assert all(i + 2 <= hi and np.linalg.norm(tcp[i + 2] - tcp[i + 1]) > 0.005 for i in short), short
    # the chain ends on the last target, at rest
    assert np.linalg.norm(tcp[-1] - corners[-1]) < 0.05 and not any(frames[-1][1].speeds)
    # (report only) the frame the board received nearest the time each hand-over's ack came
    t_of = {n: t for n, t, _ in bench.exchange.ins}
    lag = [int(np.searchsorted([t_of[n] for n, _ in frames], acks.entry(c, "COMPLETED")[0])) - m
           for c, m in zip(ids, marks)]
    print(f"\nblending: {len(frames)} GO TO frames; corners passed at {[round(d, 2) for d in dist]} mm; "
          f"smallest step between corners {steps.min():.4f} mm ({len(short)} of {len(steps)} steps <= 0.005 mm), "
          f"lowest feed-forward path speed {speed.min():.1f} mm/s; ack vs mark (frames): {lag}; "
          f"controller overruns {bench.loop_stats()['overruns']}"
          + ("; HELD BACK for late replies: " + end if held else ""))


def test_a_blended_chain_sent_to_an_idle_controller_blends_its_first_move_too(bench):
    """Three blended MoveCarts sent in one burst to an idle controller (the datagrams reach it
    in one tick: all three QUEUED together): the first should hand over to the second as the
    others do."""
    _ok(bench, START_MOVE)
    ids = [bench.send(t) for t in _movecarts(_zigzag(3))]
    for cid in ids:
        assert bench.acks.terminal(cid, 30)[0] == "COMPLETED"
    head = bench.acks.entry(ids[0], "EXECUTING")[3]
    first_done = bench.acks.entry(ids[0], "COMPLETED")[3]
    assert "blended chain of 3 moves" in head and "blended" in first_done, (head, first_done)


# ------------------------------------------------------------------------------ PAUSE / RESUME


def _line_distance(tcp: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = (b - a) / np.linalg.norm(b - a)
    q = tcp - a
    return np.linalg.norm(q - np.outer(q @ d, d), axis=1)


def _hold_run(frames: list[tuple[int, CommandFrame]]) -> tuple[int, int]:
    """The longest run of frames with one target and no feed-forward: (first index, length)."""
    best, start = (0, 0), None
    for i, (_, f) in enumerate(frames):
        still = not any(f.speeds) and i > 0 and f.positions == frames[i - 1][1].positions \
            and not any(frames[i - 1][1].speeds)
        if still:
            start = i - 1 if start is None else start
            if i - start + 1 > best[1]:
                best = (start, i - start + 1)
        else:
            start = None
    return best


def test_pause_mid_movecart_over_a_pty_slows_on_the_line_holds_and_resume_ends_on_the_target(bench):
    """A 60 mm MoveCart (-Y, 3 s) paused after 100 frames: the frames slow down on the line
    (every target within 0.05 mm of it, the feed-forward's path speed falling to 0), then hold
    (one target, no feed-forward, 30 frames and more) while the move is not ended; after RESUME
    it COMPLETES and its last frame's target is the move's target (within 0.05 mm)."""
    _ok(bench, START_MOVE)
    p0 = np.asarray(fk(START), dtype=float)
    target = p0.copy()
    target[1] -= 60.0
    n0 = bench.exchange.idle_mark()
    cid = bench.send("MOVECART|" + _pose_text(target) + "|3|None")
    wait_until(lambda: len(bench.exchange.gotos(n0)) >= 100, 20, what="100 GO TO frames of the MoveCart")
    pause = bench.send("PAUSE")
    status, details = bench.acks.terminal(pause, 10)
    assert status == "COMPLETED" and details.startswith("paused"), (status, details)

    def held() -> bool:
        frames = bench.exchange.gotos(n0)
        tail = frames[-30:]
        return len(tail) == 30 and len({f.positions for _, f in tail}) == 1 and not any(
            any(f.speeds) for _, f in tail)

    wait_until(held, 20, what="30 frames holding one target without feed-forward")
    assert not any(s in TERMINAL for s in bench.acks.statuses(cid)), bench.acks.acks[cid]
    assert "PAUSED=1" in bench.query("GET_STATUS")
    resume = bench.send("RESUME")
    assert bench.acks.terminal(resume, 10) == ("COMPLETED", "resumed")
    _completes(bench, cid)

    frames = _motion(bench, n0)
    tcp = _tcp(frames)
    off = _line_distance(tcp, p0[:3], target[:3])
    assert off.max() <= 0.05, f"frame {int(off.argmax())}: the TCP {off.max():.3f} mm off the line"
    i, length = _hold_run(frames)
    assert length >= 30, (i, length)
    along = float(np.dot(tcp[i] - p0[:3], (target[:3] - p0[:3]) / 60.0))
    assert 1.0 < along < 59.0, f"held {along:.2f} mm along the line: not on the way"
    assert i >= 100, f"held from frame {i}, before the PAUSE was sent (after 100 frames)"
    # slowing: the feed-forward's path speed falls to 0 into the hold (never rises again there)
    speed = _path_speed(frames)
    top = int(np.argmax(speed[:i]))
    ramp = speed[top: i + 1]
    assert np.all(np.diff(ramp) <= 0.05), [round(float(s), 2) for s in ramp]
    assert ramp[-1] == 0.0
    # the move ends on its target: the last frame's target, at rest, and the board there within
    # a step (its own report)
    last = frames[-1][1]
    assert not any(last.speeds)
    assert np.linalg.norm(tcp[-1] - target[:3]) < 0.05, tcp[-1] - target[:3]
    board = np.asarray(bench.sim.status()["positions"], dtype=float)
    assert np.all(np.abs(board - np.asarray(last.positions)) <= 1.0), (board, last.positions)
    print(f"\npause: {len(frames)} GO TO frames; held {length} frames from frame {i}, {along:.2f} mm along; "
          f"slowed from {ramp[0]:.2f} mm/s in {len(ramp) - 1} frames; farthest off the line {off.max():.4f} mm")


# ------------------------------------------------------------------------------ SERVOJ


#: the SERVOJ client: its own process, raised like the controller (SCHED_FIFO where the OS
#: allows it, below the controller's 10; else nice -10) once it is up, sending one target per
#: status the controller publishes (one per tick: paced by the controller's ticks, as
#: test_live_motion_clients paces its streams, not by this process's clock; beside two CPU hogs
#: a sender at normal priority sent them in bunches: the follower then chased its targets, see
#: the test's docstring)
_SENDER = r"""
import socket, sys, threading
from parolkit.client.robot import Robot
from parolkit.controller.scheduling import raise_priority
host, port = sys.argv[1], int(sys.argv[2])
lines = sys.stdin.read().splitlines()
print(raise_priority(5), flush=True)
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
ticks = threading.Semaphore(0)
with Robot(host, port, ack_port=0, timeout=2.0) as watcher:
    sub = watcher.subscribe(1, callback=lambda _st: ticks.release())
    try:
        if not ticks.acquire(timeout=10):
            sys.exit("no status from the controller")
        while ticks.acquire(blocking=False):
            pass  # the statuses before the stream starts
        for line in lines:
            if not ticks.acquire(timeout=10):
                sys.exit("no status from the controller")
            sock.sendto(line.encode(), (host, port))
    finally:
        sub.close()
"""


def _stream(bench: MotionBench, targets: list[np.ndarray]) -> tuple[list[str], str]:
    """SERVOJ datagrams, one per controller tick (one per status it publishes); their IDs and
    the sender's scheduling."""
    ids = [bench.new_id() for _ in targets]
    lines = [f"{cid}|SERVOJ|" + "|".join(f"{v:.5f}" for v in q) for cid, q in zip(ids, targets)]
    out = subprocess.run([sys.executable, "-c", _SENDER, bench.ctl.host, str(bench.ctl.port)],
                         input="\n".join(lines), capture_output=True, text=True, timeout=60, cwd=REPO_ROOT)
    assert out.returncode == 0, out.stderr
    return ids, out.stdout.strip()


def _one_stream(bench: MotionBench, ids: list[str]) -> tuple[tuple[str, str], int]:
    """Every SERVOJ was taken: the first started the stream, the others updated it, or started
    a new one after the stream before had come to rest in a silence (the sender held up longer
    than the slow-down takes, beside CPU hogs: the stream ends then, as it must, and the next
    target starts another); none was refused.  Returns the last stream's terminal ack and
    the number of streams."""
    started = "servo stream started (a controlled stop after 0.05 s without a target)"
    for c in ids:
        bench.acks.terminal(c, 20)
    acks = bench.acks.acks
    assert acks[ids[0]][0] == ("EXECUTING", started)
    heads = [c for c in ids if acks[c][0] == ("EXECUTING", started)]
    bad = [(k, acks[c]) for k, c in enumerate(ids) if c not in heads and acks[c] != [("COMPLETED", "target taken")]]
    assert not bad, f"targets refused or not taken: {bad[:5]}"
    for c in heads[:-1]:  # an earlier stream ended only by a silence, at rest
        assert acks[c][-1] == ("COMPLETED", "servo stream ended: no target for 0.05 s, stopped under control"), acks[c]
    if len(heads) > 1:
        print(f"\nservo: the sender was held up past the stream's stop {len(heads) - 1} time(s): {len(heads)} streams")
    return bench.acks.terminal(heads[-1], 20), len(heads)


def _min_jerk(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)


def test_a_servoj_stream_over_a_pty_is_followed_to_its_last_target_and_ends_with_a_controlled_stop(bench):
    """SERVOJ targets, one a tick: J6 +10 deg on a minimum-jerk curve over 100 targets, the
    last one held for 20 more (a client that wants the arm to stop there holds it), then
    silence.  The frames: J6 alone moves, forward to the last target (the overshoot as the
    follower settles is bounded by the stream's top speed x the 0.05 s silence), the last frame's
    target is the last target and the feed-forward reaches 0 without a step larger than the
    acceleration limit allows in a period; the stream's ack: COMPLETED after the silence.
    Then a stream cut while J6 runs at 20 deg/s: the silence ends it with a slow-down to rest
    within the acceleration limit, past the last target by no more than the silent ticks' travel
    and a braking distance (it cannot end on its last target: it keeps the target's speed
    through the silent ticks, then brakes).

    The follower estimates a target's speed from the ticks the targets came in: a datagram a
    tick late halves the estimate, and the follower brakes, even steps back, before the
    silence; one that jumps from rest to speed makes it ring (feed-forward up to 2.2 times the
    stream's speed and briefly backwards, in lockstep too).  The streams here are paced by a
    raised sender and reach their speed smoothly; what the follower does with a late datagram
    is printed, not judged."""
    a0 = np.asarray(bench.status()["angles"], dtype=float)
    targets = [a0 + np.asarray([0, 0, 0, 0, 0, 10.0 * _min_jerk(k / 100)]) for k in range(121)]
    n0 = bench.exchange.idle_mark()
    ids, sched = _stream(bench, targets)
    ended, streams = _one_stream(bench, ids)
    assert ended == ("COMPLETED", "servo stream ended: no target for 0.05 s, stopped under control")

    runs = _streamed(bench, n0, streams)
    frames = [f for run in runs for f in run]
    pos = np.array([f.positions for _, f in frames], dtype=float)
    ff = np.array([f.speeds for _, f in frames], dtype=float)
    start_steps, last_steps = a0 * SPD, targets[-1] * SPD
    # only J6 moves, from the start to the last target and never farther past it than the
    # stream's top speed covers in the silence that ends a stream (the follower settles on a
    # decelerating stream with a small overshoot: 0.05 deg at an even pace; a datagram that
    # comes a tick late makes it brake early and step back a little: reported, not judged)
    assert np.all(np.abs(pos[:, :5] - start_steps[:5]) <= 1.0), "a joint other than J6 moved"
    assert pos[:, 5].min() >= start_steps[5] - 1.0, "J6 went back behind its start"
    reach = int(np.argmax(pos[:, 5] >= last_steps[5] - 1.0))
    assert pos[reach, 5] >= last_steps[5] - 1.0, f"J6 never reached the last target: {pos[-1, 5]}"
    overshoot = (pos[:, 5].max() - last_steps[5]) / SPD[5]
    top = max(b[5] - a[5] for a, b in zip(targets, targets[1:])) / PERIOD  # deg/s
    assert overshoot <= top * 0.05, f"J6 went {overshoot:.3f} deg past the last target"
    back = max(0.0, -float(np.diff(pos[: reach + 1, 5]).min()))  # (report only)
    # the last frame's target is the last target, at rest
    assert abs(pos[-1, 5] - last_steps[5]) <= 1.0, (pos[-1, 5], last_steps[5])
    assert not any(frames[-1][1].speeds)
    # the feed-forward: within the acceleration limit from frame to frame, down to 0
    for run in runs:
        _assert_speed_steps_within_accel(run)
    # the board followed: it reports the last target
    assert abs(bench.sim.status()["positions"][5] - pos[-1, 5]) <= 1.0
    print(f"\nservo: {len(ids)} targets, {len(frames)} GO TO frames; J6 {pos[0, 5]:.0f} -> {pos[-1, 5]:.0f} steps "
          f"(last target {last_steps[5]:.1f}, reached at frame {reach}, overshoot {overshoot:.3f} deg, "
          f"largest step back on the way {back:.0f} steps); "
          f"peak feed-forward {ff[:, 5].max():.0f} steps/s; sender {sched}")

    # a second stream, cut while J6 runs at 20 deg/s (reached smoothly: a minimum-jerk speed-up
    # over the first 30 targets, then 50 at that speed): the silence ends it with a controlled
    # stop from speed (the follower keeps the target's speed for the 5 silent ticks, then brakes)
    a1 = targets[-1]
    travel = np.cumsum([20.0 * _min_jerk(k / 30) * PERIOD for k in range(80)])
    ramp = [a1 - np.asarray([0, 0, 0, 0, 0, d]) for d in travel]
    n1 = bench.exchange.idle_mark()
    ended, streams = _one_stream(bench, _stream(bench, ramp)[0])
    assert ended == ("COMPLETED", "servo stream ended: no target for 0.05 s, stopped under control")
    runs = _streamed(bench, n1, streams)
    frames = [f for run in runs for f in run]
    for run in runs:
        _assert_speed_steps_within_accel(run)
    v6 = -np.array([f.speeds[5] for _, f in frames], dtype=float)  # J6 runs backwards
    assert not any(frames[-1][1].speeds), "the last frame holds"
    # it went on past the last target (it keeps the target's speed through the silent ticks,
    # then brakes), never over J6's position-tracking maximum.  How far past depends on when the last
    # datagrams came: on time, the silence's travel and a braking distance (the bound
    # tests/unit/test_live_motion.py judges on the lockstep board); a sender held up resumes the
    # slowing stream and the arm goes on a little (768 steps once on a busy machine): printed
    v = 20.0 * SPD[5]
    past = ramp[-1][5] * SPD[5] - frames[-1][1].positions[5]
    assert past >= 0, past
    assert np.abs(v6).max() <= PAROL6.max_tracked_speed_steps_s(RATE)[5], v6.max()
    # (report only) the slow-down at the end: from the last frame at the stream's speed
    k = max((i for i in range(len(v6)) if v6[i] >= 0.99 * v), default=int(np.argmax(v6)))
    print(f"servo, cut at speed: {len(frames)} GO TO frames; feed-forward {v6[k]:.0f} -> 0 steps/s in "
          f"{len(v6) - 1 - k} frames{', monotone' if np.all(np.diff(v6[k:]) <= 0) else ', NOT monotone'} "
          f"(the stream's lowest {v6.min():.0f}, highest {v6.max():.0f} steps/s); {past:.0f} steps past the last "
          f"target; controller overruns {bench.loop_stats()['overruns']}")


# ------------------------------------------------------------------------------ SPEED


def _progress(frames: list[tuple[int, CommandFrame]], start: np.ndarray, goal: np.ndarray, j: int) -> np.ndarray:
    """How far along a MoveJoint each frame's target is, 0..1, by joint ``j`` (the joints of
    a MoveJoint move in step: one is as good as another)."""
    p = np.array([f.positions[j] for _, f in frames], dtype=float)
    return (p - start[j]) / (goal[j] - start[j])


def test_speed_50_halfway_through_a_movejoint_over_a_pty_makes_the_rest_take_twice_as_long(bench):
    """A MoveJoint t=4 (J1 -30 deg, J5 -40 deg and the others 10 deg) at 100 %, back to the
    start, then again with ``SPEED|50`` sent once 200 of its frames have reached the board.
    The frames of the second run: as the first up to where the override takes hold (found in
    the frames: the first whose feed-forward falls below the first run's at the same point of
    the path); from there each point of the path is passed at half the first run's speed
    (after a ramp inside the acceleration limit), so the rest of the path takes twice as long,
    and twice the frames it took at 100 % (within the ramp and the settle at the end, which is
    not scaled; counted when no tick came more than a period late, which skips a deadline);
    no joint's feed-forward changes by more than the acceleration limit allows in a period;
    the last frame's target is the goal, at rest.  The override stays for what follows."""
    _ok(bench, START_MOVE)
    goal = np.asarray((60.0, -80.0, 170.0, 10.0, -10.0, 170.0))
    start_steps, goal_steps = np.asarray(START) * SPD, goal * SPD
    move = "MOVEJOINT|" + "|".join(f"{v:g}" for v in goal) + "|4|None"
    J = 4  # J5: the longest way in steps

    overruns = bench.loop_stats()["overruns"]
    n0 = bench.exchange.idle_mark()
    _ok(bench, move)
    ref = _motion(bench, n0)
    _ok(bench, START_MOVE)

    n1 = bench.exchange.idle_mark()
    cid = bench.send(move)
    wait_until(lambda: len(bench.exchange.gotos(n1)) >= 200, 20, what="200 GO TO frames of the MoveJoint")
    speed = bench.send("SPEED|50")
    assert bench.acks.terminal(speed, 10) == ("COMPLETED", "speed override 50 %")
    _completes(bench, cid)
    frames = _motion(bench, n1)
    _assert_speed_steps_within_accel(frames)

    # each frame's feed-forward against the first run's at the same point of the path
    s_all = _progress(ref, start_steps, goal_steps, J)
    v_all = np.array([f.speeds[J] for _, f in ref], dtype=float)
    keep = np.concatenate(([True], np.diff(s_all) > 1e-6))  # strictly along the path
    s_ref, v_ref = s_all[keep], v_all[keep]
    s = _progress(frames, start_steps, goal_steps, J)
    v = np.array([f.speeds[J] for _, f in frames], dtype=float)
    expected = np.interp(s, s_ref, v_ref)
    peak = float(np.abs(v_ref).max())
    drop = np.nonzero(np.abs(v) < np.abs(expected) - 0.03 * peak)[0]
    assert len(drop), "the feed-forward never fell below the first run's: the override did not take hold"
    k = int(drop[0])
    assert k >= 190, f"the override took hold at frame {k}, before SPEED was sent (after 200 frames)"
    # the rest of the path: the frames it took at 100 % from the same point, and now
    ref_rest = len(ref) - int(np.argmax(s_all >= s[k]))
    rest = len(frames) - k
    # (a tick more than a period late skips its deadline: the move catches up with the clock
    # and has a frame fewer; then the counts are printed, the speeds below say the same)
    late = bench.loop_stats()["overruns"] - overruns
    if not late:
        assert abs(rest - 2 * ref_rest) <= 30, (f"the rest took {rest} frames where it took {ref_rest} at 100 %",
                                                len(ref), len(frames), k)
    # after the ramp (the speed ratio falls from 1 to 0.5 inside the acceleration limit) and
    # before the end (the last 10 % of the path: the plan's own slow-down, then the settle),
    # each point of the path is passed at half the first run's speed
    ramp = k + int(np.ceil(peak / (ACCEL[J] * PERIOD))) + 2
    on = [i for i in range(ramp, len(frames)) if s[i] < 0.9]
    assert len(on) > 50, (ramp, len(frames))
    err = np.abs(v[on] - 0.5 * expected[on]) / peak
    assert err.max() <= 0.05, f"frame {on[int(err.argmax())]}: feed-forward {v[on][int(err.argmax())]:.0f} " \
                              f"where half the first run's is {0.5 * expected[on][int(err.argmax())]:.0f} steps/s"
    # it ends on the goal, at rest, and the override stays
    assert np.all(np.abs(np.asarray(frames[-1][1].positions) - goal_steps) <= 1.0), frames[-1][1].positions
    assert not any(frames[-1][1].speeds)
    assert bench.status()["speed_pct"] == 50.0
    print(f"\nspeed: {len(ref)} GO TO frames at 100 %; SPEED|50 took hold at frame {k} ({s[k]:.2f} of the way); "
          f"the rest {rest} frames (at 100 %: {ref_rest}); ratio {rest / ref_rest:.2f}; "
          f"largest deviation from half speed {err.max():.3f} of the peak; "
          f"{late} ticks more than a period late{' (frame counts not judged)' if late else ''}")


# ------------------------------------------------------------------------------ a program's lines


def test_a_programs_output_and_delay_lines_each_take_exactly_their_ticks_at_the_pty(bench):
    """An RBTscript program run by the interpreter (its lines over UDP to the controller, sent
    ahead of execution): at the board, counted in frames (one a tick), ``Output`` takes one,
    ``Delay(0.01)`` one and ``Delay(1.5)`` 150: the outputs change exactly at those frames (an
    Output whose reply comes late holds the queue until the board shows the level: at most the
    slowest reply's ticks more, on a busy machine)."""
    from parolkit.client.robot import Robot
    from parolkit.protocol.frames import IOBits
    from parolkit.script import Interpreter, parse

    program = ("Begin()\nOutput(1,HIGH)\nDelay(0.01)\nOutput(1,LOW)\nDelay(0.01)\nOutput(1,HIGH)\n"
               "Output(2,HIGH)\nDelay(1.5)\nOutput(1,LOW)\nEnd()\n")
    n0 = bench.exchange.idle_mark()
    with Robot(bench.ctl.host, bench.ctl.port, ack_port=0, timeout=5.0) as robot:
        result = Interpreter(parse(program).program, robot).run()
    assert result.ok, result.message
    def outs(frame: CommandFrame) -> tuple[bool, bool]:
        return bool(frame.io & IOBits.OUT1), bool(frame.io & IOBits.OUT2)

    # (the program's last frames may still be on their way to a board-sim held up: wait for the
    # outputs its last line leaves)
    wait_until(lambda: outs(bench.exchange.update().ins[-1][2]) == (False, True), 10,
               what="the board's outputs as the program leaves them")
    ins = bench.exchange.ins
    last = next(outs(f) for n, _, f in ins if n == n0)
    assert last == (False, False), last
    changes = []
    for n, _, frame in ins:
        if n <= n0:
            continue
        io = outs(frame)
        if io != last:
            changes.append((n, io))
            last = io
    expected = [(0, (True, False)), (2, (False, False)), (4, (True, False)), (5, (True, True)), (156, (False, True))]
    assert [io for _, io in changes] == [io for _, io in expected], changes
    # an Output ends when the board's status shows the level: its reply read the tick after its
    # frame, as a board answers (exact then); a board-sim held up on a busy machine answers
    # late, and the Output then holds the queue until it does (at most the slowest reply's
    # ticks more), while the Delays stay exact.  The slowest reply is the longest run of frames
    # left unanswered at a tick's start (rtt_max_ms times only the replies within the tick's
    # reply wait: a late one never shows there; a run at load 7 took 4 frames for 2 with
    # rtt_max 3.3 ms)
    slack = bench.loop_stats()["unanswered_max"]
    gaps = np.diff([n for n, _ in changes])
    want = np.diff([n for n, _ in expected])
    assert np.all(gaps >= want) and np.all(gaps <= want + slack), (gaps.tolist(), want.tolist(), slack)
    print(f"\noutputs at the board: frames between changes {gaps.tolist()} (exact: {want.tolist()}); "
          f"longest run of unanswered frames {slack}")


# ------------------------------------------------------------------------------ a streamed curve


#: the curve's client: its own process, raised like _SENDER, sampling the curve at the
#: controller's time: for each status (its ``seq``: the ticks the controller has run) it sends
#: the curve's target for that tick, skipping the ticks it was told to drop and any it was held
#: up past (it sends for the newest status it has).  After the curve it holds the last target
#: for ``hold`` more ticks, then goes silent.  Prints JSON: the first status's seq (k = 0), the
#: tick that took the first target in (the first status showing the stream's ID, minus one:
#: ``seq`` is the tick number plus one), the ks it sent and the ones it was held up past.
_CURVE = r"""
import json, math, queue, socket, sys
from parolkit.client.robot import Robot
from parolkit.controller.scheduling import raise_priority
host, port = sys.argv[1], int(sys.argv[2])
spec = json.loads(sys.stdin.read())
a0, amp, n, hold, drop = spec["a0"], spec["amp"], spec["n"], spec["hold"], set(spec["drop"])
raise_priority(5)
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
seqs = queue.Queue()
def target(k):
    k = min(k, n - 1)
    return [a + d * (1 - math.cos(2 * math.pi * k / 100.0)) for a, d in zip(a0, amp)]
sent, skipped, took, taken = [], [], None, []
def seen(st):
    if st.command is not None and st.command.target:
        taken.append((st.seq, int(st.command.target[2:])))  # the newest target taken at that tick
    seqs.put((st.seq, st.command.id if st.command else None))
with Robot(host, port, ack_port=0, timeout=2.0) as watcher:
    sub = watcher.subscribe(1, callback=seen)
    try:
        seqs.get(timeout=10)
        while not seqs.empty():
            seqs.get_nowait()  # the statuses before the stream
        seq0, last = None, -1
        while True:
            seq, cid = seqs.get(timeout=10)
            while not seqs.empty():  # held up: the newest status counts
                if took is None and cid == "sv000000":
                    took = seq - 1
                seq, cid = seqs.get_nowait()
            if took is None and cid == "sv000000":
                took = seq - 1
            if seq0 is None:
                seq0 = seq
            k = seq - seq0
            if k >= n + hold:
                break
            skipped += [j for j in range(last + 1, k) if j not in drop and j < n + hold]
            last = k
            if k in drop:
                continue
            sock.sendto((f"sv{k:06d}|SERVOJ|" + "|".join(f"{v:.5f}" for v in target(k))).encode(), (host, port))
            sent.append(k)
        while took is None:
            seq, cid = seqs.get(timeout=10)
            if cid == "sv000000":
                took = seq - 1
    finally:
        sub.close()
print(json.dumps({"seq0": seq0, "took": took, "sent": sent, "skipped": skipped, "taken": taken}))
"""


def _controller_late(taken: list, sent: list, seq0: int) -> set[int]:
    """The ticks (from ``seq0``) not to judge because the controller took its targets late:
    ``taken`` is (tick, newest target taken) from its status; target k is sent at tick k and
    taken at k + 1, a tick later at worst when judged.  A tick whose newest target is older than
    the newest one sent two ticks before starts a late stretch (the controller's server held up
    on a busy machine); the stretch and as long again plus 10 ticks after it are left out (what
    the curve moved meanwhile is caught up within the acceleration limits: that long)."""
    sent_sorted = sorted(sent)
    behind = []
    for tick, k in taken:
        r = tick - seq0
        i = bisect.bisect_right(sent_sorted, r - 2)
        if i and k < sent_sorted[i - 1]:
            behind.append(r)
    late: set[int] = set()
    runs: list[list[int]] = []  # the stretches of consecutive late ticks
    for r in sorted(set(behind)):
        if runs and r == runs[-1][1] + 1:
            runs[-1][1] = r
        else:
            runs.append([r, r])
    for start, end in runs:
        late.update(range(start, end + (end - start + 1) + 11))
    return late


def test_a_1_hz_curve_streamed_with_10_percent_dropped_is_followed_within_2_ticks_over_a_pty(bench):
    """SERVOJ at the controller's rate (one target a tick, sampled at the tick the controller
    has reached), a 1 Hz curve on every joint (peak acceleration 30 % of the joint's limit),
    10 % of the targets dropped (a fixed random set), then the last target held for 30 ticks,
    then silence.  Judged on the frames the board received, each at its tick (frames are one a
    tick: the first GO TO is the tick that took the first target in): the curve shifted by the
    lag that fits the frames' targets best (each where the board is a period later) is at most
    2 ticks late and off by less than 30 % of the amplitude (5.6 % on a quiet machine, at lag
    0); no joint's feed-forward is over its maximum speed or changes by more than its
    acceleration limit allows in a period (but into a frame the guard's box put on its nearest
    point in hundredths of a step: a box narrower than a step, late replies); the last
    target is held (the frames end on it, at rest); the silence ends the stream COMPLETED with
    a controlled stop.  A sender held up past a tick skips that tick's target (as a real-time
    client would): those count as dropped too, and the frames right after one are not judged;
    likewise the ticks where the controller's status shows it took its targets late (its
    server held up: :func:`_controller_late`)."""
    import random

    a0 = np.asarray(bench.status()["angles"], dtype=float)
    amp = 0.3 * ACCEL / (4 * np.pi ** 2) / np.abs(SPD)  # deg: peak acceleration 30 % of the limit
    n, hold = 300, 30
    rng = random.Random(7)
    drop = [k for k in range(1, n) if rng.random() < 0.1]
    n0 = bench.exchange.idle_mark()
    spec = json.dumps({"a0": a0.tolist(), "amp": amp.tolist(), "n": n, "hold": hold, "drop": drop})
    out = subprocess.run([sys.executable, "-c", _CURVE, bench.ctl.host, str(bench.ctl.port)],
                         input=spec, capture_output=True, text=True, timeout=60, cwd=REPO_ROOT)
    assert out.returncode == 0, out.stderr
    run = json.loads(out.stdout.strip().splitlines()[-1])
    seq0, took, skipped = run["seq0"], run["took"], set(run["skipped"])
    late = _controller_late(run["taken"], run["sent"], seq0)
    status, details = bench.acks.terminal("sv000000", 20)
    assert (status, details) == ("COMPLETED", "servo stream ended: no target for 0.05 s, stopped under control"), \
        (status, details, f"sender held up past {len(skipped)} ticks")

    def curve(k: float) -> np.ndarray:
        k = min(k, n - 1)
        return a0 + amp * (1 - np.cos(2 * np.pi * k / 100.0))

    frames = _arrived(bench, n0)
    # every frame is one tick (idle ones too): frame number m went out at tick took + m - first
    ticks = [took + m - frames[0][0] for m, _ in frames]
    runs = np.split(np.arange(len(frames)), np.nonzero(np.diff([m for m, _ in frames]) != 1)[0] + 1)
    pos = np.array([f.positions for _, f in frames], dtype=float)
    amp_steps = amp * np.abs(SPD)
    # judged: from 40 ticks in (the stream has its speed estimate) to the end of the curve,
    # not within 10 ticks after a tick the sender was held up past.  The board takes a
    # frame's period to reach its target (position tracking): a frame sent at tick t is where
    # the board is at t + 1, so the curve is compared there
    judged = [i for i, t in enumerate(ticks) if 40 <= t - seq0 < n and t - seq0 not in late
              and not any(t - seq0 - 10 <= j <= t - seq0 for j in skipped)]
    assert len(judged) > 150, (len(judged), len(skipped), len(late))
    err = {}
    for lag in range(-3, 8):
        err[lag] = max(float(np.max(np.abs(pos[i] - curve(ticks[i] + 1 - seq0 - lag) * SPD) / amp_steps))
                       for i in judged)
    best = min(err, key=err.__getitem__)
    # (the curve's own fit is 0.056 of the amplitude at lag 0; 0.08 a tick early before issue
    # 23's follower.  Datagrams that reach the controller a tick late on a busy machine moved
    # it to 0.18 once: the lockstep test with 40 % of the targets a tick late sees up to 0.32.
    # Beside two CPU hogs and other test runs the old follower was 0.6 to 1.1 off at lags 0 to
    # -3 after the controller took no target for 12 ticks while the sender skipped one (the
    # silence's slow-down, then a restart that overshot); the guard's box holding it back for
    # late replies did the same in the lockstep test.  It now runs back onto the curve within
    # the limits (tests/unit/test_live_motion.py), but targets that stop coming still cost
    # what the curve moved meanwhile, and this judge knows of the sender's own delays only)
    assert best <= 2 and err[best] < 0.3, ({k: round(v, 3) for k, v in err.items()}, seq0, took, frames[0][0],
                                           sorted(skipped), sorted(late), len(runs), len(frames))
    # within the acceleration limit from frame to frame, also where the guard's box holds the
    # frames back (late replies: the follower's speed changes within the limit while the goal
    # is put inside the box); except into a frame on the point of a box narrower than a step,
    # in hundredths of a step (|ff| <= 50): the bounded commitment comes first there (printed)
    holds = []
    for r in runs:  # (a sender held up past the silence ends the stream; the next target starts another)
        seq = [frames[i] for i in r]
        for (n_a, a), (n_b, b) in zip(seq, seq[1:]):
            if max(abs(v) for v in b.speeds) <= 50 and any(abs(x - y) > ACCEL[j] * PERIOD + 2
                                                          for j, (x, y) in enumerate(zip(a.speeds, b.speeds))):
                holds.append(n_b)
                continue
            _assert_speed_steps_within_accel([(n_a, a), (n_b, b)], slack=1.0)
    # (report only) where the board said it was when each frame came: a board-sim process
    # held up on a busy machine answers a backlog of frames from one place
    where = np.array([bench.exchange.board.get(m, f.positions) for m, f in frames], dtype=float)
    board_err = max(float(np.max(np.abs(where[i] - curve(ticks[i] - seq0 - best) * SPD) / amp_steps)) for i in judged)
    top = np.asarray(PAROL6.max_speed_steps_s, dtype=float)
    assert all(np.all(np.abs(np.asarray(f.speeds)) <= top) for _, f in frames)
    # the last target held: the frames end on it, at rest
    last = curve(n - 1) * SPD
    assert np.all(np.abs(pos[-1] - last) <= 1.0), pos[-1] - last
    assert not any(frames[-1][1].speeds)
    print(f"\nservo curve: {len(run['sent'])} targets sent, {len(drop)} dropped on purpose, sender held up past "
          f"{len(skipped)} ticks, the controller's targets late at {len(late)} ticks ({len(run['taken'])} statuses "
          f"seen); {len(frames)} GO TO frames from tick {took} (first status seq {seq0}); "
          f"lag {best} ticks, off by {err[best]:.3f} of the amplitude there; {len(runs)} stream(s); the board's "
          f"answers off by {board_err:.3f} of the amplitude at that lag; frames the guard held back at once: {holds}")
