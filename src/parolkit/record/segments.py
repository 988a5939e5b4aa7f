"""A recording cut into motions, each fitted with the planned joint move that reproduces it.

* :func:`command_segments`: the motions of the recorded commands (from the status's active
  command at each tick), with the ticks between them; used by ``replay``.
* :func:`rest_segments`: the motions between pauses (no joint moved for ``min_rest_ticks``);
  used by ``teach`` on any demonstration (jogs included).
* :func:`fit_joint_move`: the MoveJoint (target = where the motion came to rest; duration a
  whole number of ticks, or the default speed) whose plan is closest to the recorded positions
  tick by tick (the smallest largest deviation in steps over a lag of -3..``max_lag`` ticks:
  the board reports a position one frame or more after it was sent; a motion found from the
  positions alone starts where the first step shows, a tick or more into the plan).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from parolkit.moves import JointMove
from parolkit.record.reader import Recording
from parolkit.robot import PAROL6, RobotModel

__all__ = ["MotionSpan", "FittedMove", "command_segments", "rest_segments", "fit_joint_move", "steps_to_deg"]


def steps_to_deg(steps: NDArray[np.int64], model: RobotModel = PAROL6) -> NDArray[np.float64]:
    """Board steps -> deg, exact enough (1e-9 deg) that MoveJoint rounds back to the same steps."""
    return np.asarray(steps, dtype=float) / model.steps_per_deg


@dataclass(frozen=True)
class MotionSpan:
    """One motion: rows ``start``..``end`` of the recording (``start``: the last row before the
    joints move, ``end``: the first row at rest after), its ticks, and the command (if known)."""

    start: int
    end: int
    start_tick: int
    end_tick: int
    command: str | None = None
    #: tick at which the command became active (command segments), else start_tick
    command_tick: int | None = None
    #: first tick after the command (command segments), else end_tick
    command_end_tick: int | None = None
    #: the command's planned length in ticks, from its progress (command segments), else None
    planned_ticks: int | None = None


@dataclass(frozen=True)
class FittedMove:
    """The fitted MoveJoint: ``target_deg``, ``duration_s`` (None: the default speed and
    acceleration of MoveJoint, :data:`parolkit.motion.joint.MOVEJOINT_DEFAULT_PCT`),
    ``error_steps`` (largest |planned - recorded| over the motion, steps) and ``lag`` (ticks)."""

    target_deg: tuple[float, ...]
    duration_s: float | None
    error_steps: int
    lag: int
    planned: NDArray[np.int64]

    def move(self) -> JointMove:
        return _joint_move(self.target_deg, self.duration_s)


def _joint_move(target: tuple[float, ...], duration: float | None) -> JointMove:
    """The MoveJoint the controller plans for MOVEJOINT with this duration (None: the defaults)."""
    from parolkit.motion.joint import MOVEJOINT_DEFAULT_PCT

    if duration is not None:
        return JointMove(target, duration_s=duration)
    return JointMove(target, speed_pct=MOVEJOINT_DEFAULT_PCT[0], accel_pct=MOVEJOINT_DEFAULT_PCT[1])


def _rows_by_tick(rec: Recording, first_tick: int, count: int) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Recorded steps for ticks first_tick .. first_tick+count-1 (missing ticks masked out)."""
    out = np.zeros((count, 6), dtype=np.int64)
    have = np.zeros(count, dtype=bool)
    idx = rec.ticks - first_tick
    ok = (idx >= 0) & (idx < count)
    out[idx[ok]] = rec.steps[ok]
    have[idx[ok]] = True
    return out, have


def _error(planned: NDArray[np.int64], rec: Recording, first_tick: int, lag: int, tail: int) -> int:
    """Largest deviation when planned sample j is compared with tick first_tick + lag + j (and the
    last planned sample with the ``tail`` ticks after it)."""
    n = len(planned)
    ext = np.vstack([planned, np.repeat(planned[-1:], tail, axis=0)])
    got, have = _rows_by_tick(rec, first_tick + lag, n + tail)
    if not have.any():
        return 1 << 30
    return int(np.abs(ext[have] - got[have]).max())


def fit_joint_move(rec: Recording, seg: MotionSpan, *, max_lag: int = 4, model: RobotModel = PAROL6) -> FittedMove:
    """See the module docstring.  Raises PlanningError when no candidate can be planned."""
    from parolkit.motion import PlanningError, plan

    rate = rec.rate_hz
    start_deg = steps_to_deg(rec.steps[seg.start], model)
    target = tuple(round(float(v), 6) for v in steps_to_deg(rec.steps[seg.end], model))
    first = seg.start_tick + 1
    span = max(1, seg.end_tick - seg.start_tick)
    tail = 5
    best: FittedMove | None = None

    def consider(duration: float | None) -> int:
        nonlocal best
        try:
            traj = plan(_joint_move(target, duration), start_deg, model=model, rate_hz=rate)
        except PlanningError:
            return 1 << 30
        errs = [(_error(traj.positions, rec, first, lag, tail), lag) for lag in range(-3, max_lag + 1)]
        err, lag = min(errs)
        if best is None or err < best.error_steps:
            best = FittedMove(target, duration, err, lag, traj.positions)
        return err

    consider(None)
    if seg.planned_ticks is not None:  # the controller's own figure: the duration is known
        consider(seg.planned_ticks / rate)
        if best is not None:
            return best
    # coarse then fine over whole ticks: the motion lasts about as long as it was recorded
    lo, hi = max(1, span // 3), span + 10
    coarse = {k: consider(k / rate) for k in range(lo, hi + 1, 5)}
    k0 = min(coarse, key=lambda k: coarse[k])
    for k in range(max(1, k0 - 5), k0 + 6):
        if k not in coarse:
            consider(k / rate)
    if best is None:
        raise PlanningError("MoveJoint", f"no joint move reproduces ticks {seg.start_tick}..{seg.end_tick}")
    return best


def _moving(rec: Recording) -> NDArray[np.bool_]:
    """moving[i]: row i differs from row i-1 (row 0: False)."""
    mv = np.zeros(len(rec), dtype=bool)
    if len(rec) > 1:
        mv[1:] = np.any(rec.steps[1:] != rec.steps[:-1], axis=1)
    return mv


def rest_segments(rec: Recording, min_rest_ticks: int = 10) -> list[MotionSpan]:
    """Motions separated by pauses of at least ``min_rest_ticks`` ticks without a joint moving."""
    mv = _moving(rec)
    segs: list[MotionSpan] = []
    i, n = 1, len(rec)
    while i < n:
        if not mv[i]:
            i += 1
            continue
        start = i - 1
        j = i
        last_move = i
        while j < n:
            if mv[j]:
                last_move = j
            elif rec.ticks[j] - rec.ticks[last_move] >= min_rest_ticks:
                break
            j += 1
        end = last_move
        segs.append(MotionSpan(start, end, int(rec.ticks[start]), int(rec.ticks[end])))
        i = j
    return segs


def _planned_ticks(rec: Recording, a: int, b: int) -> tuple[int | None, int]:
    """(planned length in ticks, first tick) of the command shown in rows a..b-1.

    The length comes from the command's progress (``k/n`` after its k-th sample, rounded to 4
    decimals by the controller): from the steps between consecutive ticks.  The controller
    samples a trajectory by the wall clock, so a late tick advances it by two samples or more;
    such steps (more than 1.5x the smallest) are left out, and the rest averaged."""
    first = int(rec.ticks[a])
    pts = [(int(rec.ticks[i]), float((rec.statuses[i].get("command") or {}).get("progress") or 0.0))
           for i in range(a, b)]
    pts = [(t, p) for t, p in pts if 0.0 < p < 1.0]
    steps = [(p1 - p0) for (t0, p0), (t1, p1) in zip(pts, pts[1:]) if t1 - t0 == 1 and p1 > p0]
    if len(steps) < 2:
        return None, first
    smallest = min(steps)
    regular = [d for d in steps if d <= 1.5 * smallest]
    n = int(round(len(regular) / sum(regular)))
    return (n if n >= 1 else None), first


def command_runs(rec: Recording) -> list[tuple[int, int, str]]:
    """(first row, first row after, command name) of each recorded command, in order."""
    runs: list[tuple[int, int, str]] = []
    prev: tuple[object, object] | None = None
    for i, s in enumerate(rec.statuses):
        cmd = s.get("command") or {}
        key = (cmd.get("id"), cmd.get("name"))
        if key[1] is None:
            key = (None, None)
        if key != prev:
            if runs and runs[-1][1] < 0:
                runs[-1] = (runs[-1][0], i, runs[-1][2])
            if key[1] is not None:
                runs.append((i, -1, str(key[1])))
            prev = key
    if runs and runs[-1][1] < 0:
        runs[-1] = (runs[-1][0], len(rec), runs[-1][2])
    return runs


def command_segments(rec: Recording) -> list[MotionSpan]:
    """One segment per recorded command during which (or right after which) the joints moved."""
    mv = _moving(rec)
    runs = command_runs(rec)
    segs: list[MotionSpan] = []
    for a, b, name in runs:
        moved = np.nonzero(mv[a:b])[0]
        if len(moved) == 0:
            continue
        # settle: the joints come to rest at most a few ticks after the command ends
        end = a + int(moved[-1])
        k = end + 1
        while k < len(rec) and k < b + 5 and mv[k]:
            end = k
            k += 1
        start = max(0, a - 1)
        n, first_tick = _planned_ticks(rec, a, b)
        segs.append(MotionSpan(start, end, int(rec.ticks[start]), int(rec.ticks[end]), name,
                            first_tick, int(rec.ticks[b - 1]) + 1, n))
    return segs
