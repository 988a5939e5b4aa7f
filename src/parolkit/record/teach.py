"""``parolkit teach run.mcap -o prog.rbt``: fit a short RBTscript program to a demonstration.

The demonstration is cut at its pauses (no joint moved for ``min_rest_s``).  A motion whose
TCP went along a straight line while its joints did not (a Cartesian jog: a MoveJoint between
its ends would bow away from the line) becomes one ``MoveCart`` to the pose where it came to
rest, when that line's plan follows the recording within the tolerances.  Any other motion
becomes a MoveJoint to where it came to rest, timed like the recording (the duration whose
plan is closest to it, see :func:`parolkit.record.segments.fit_joint_move`); one whose planned
path strays from the recorded one by more than the tolerances (TCP mm, joint deg) is split at
its farthest sample into two MoveJoints, recursively.  Pauses become ``Delay`` lines, changes
of the digital outputs ``Output`` lines and changes of the electric gripper's commanded
position ``Gripper`` lines, placed between the moves where they happened.

The deviation printed is measured on the program's own dry run (the planner's paths from the
recording's start pose): for every recorded sample of a motion, the distance to the nearest
point of that motion's planned path (its lines' trajectories), in TCP mm and in joint deg
(largest joint), the largest over the recording.  Motion by motion, so a long demonstration
costs about its length, not its length squared.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from parolkit.record.reader import Recording, load_recording, warn_if_damaged
from parolkit.record.segments import MotionSpan, fit_joint_move, rest_segments, steps_to_deg

__all__ = ["TeachResult", "teach", "path_deviation", "planned_path_deg", "planned_moves_deg", "teach_command",
           "CART_MIN_MM"]


@dataclass(frozen=True)
class TeachResult:
    """The program text, its move / delay counts and the deviation its dry run achieves."""

    text: str
    moves: int
    delays: int
    deviation_mm: float
    deviation_deg: float
    #: of ``moves``, the MoveCart lines (straight TCP lines)
    cart_moves: int = 0


def _densify(q: NDArray[np.float64], factor: int = 4) -> NDArray[np.float64]:
    """Linear interpolation between consecutive samples (so the nearest point is found between)."""
    if len(q) < 2:
        return q
    s = np.linspace(0.0, 1.0, factor, endpoint=False)
    parts = q[:-1, None, :] + s[None, :, None] * (q[1:] - q[:-1])[:, None, :]
    return np.vstack([parts.reshape(-1, q.shape[1]), q[-1:]])


def path_deviation(recorded_deg: NDArray[np.float64], planned_deg: NDArray[np.float64]) -> tuple[float, float]:
    """(largest TCP distance in mm, largest joint deviation in deg) of the recorded samples from
    the nearest point of the planned path (both (N, 6) joint angles in deg)."""
    from parolkit.kinematics.fk import fk_batch

    if len(recorded_deg) == 0:
        return 0.0, 0.0
    plan = _densify(np.asarray(planned_deg, dtype=float))
    plan_xyz = fk_batch(plan)[:, :3]
    rec_xyz = fk_batch(np.asarray(recorded_deg, dtype=float))[:, :3]
    worst_mm = worst_deg = 0.0
    for i in range(0, len(recorded_deg), 128):
        r = recorded_deg[i:i + 128]
        dj = np.abs(r[:, None, :] - plan[None, :, :]).max(axis=2).min(axis=1)
        dx = np.linalg.norm(rec_xyz[i:i + 128, None, :] - plan_xyz[None, :, :], axis=2).min(axis=1)
        worst_deg = max(worst_deg, float(dj.max()))
        worst_mm = max(worst_mm, float(dx.max()))
    return worst_mm, worst_deg


def planned_moves_deg(program_text: str, start_deg: tuple[float, ...], rate_hz: float) -> list[NDArray[np.float64]]:
    """The planned joint samples (deg) of each motion line of the program's dry run from
    ``start_deg``, in order (ValueError when it does not parse or plan)."""
    from parolkit.script import parse
    from parolkit.script.dryrun import dry_run

    parsed = parse(program_text)
    if parsed.program is None:
        raise ValueError("the taught program does not parse: " + "; ".join(str(e) for e in parsed.errors))
    report = dry_run(parsed.program, start_deg, rate_hz=rate_hz)
    if not report.ok:
        raise ValueError("the taught program does not plan: " + "; ".join(str(e) for e in report.errors))
    return [np.asarray(traj.positions, dtype=float) / traj.model.steps_per_deg for _, traj in report.segments]


def planned_path_deg(program_text: str, start_deg: tuple[float, ...], rate_hz: float) -> NDArray[np.float64]:
    """Every planned joint sample (deg) of the program's dry run from ``start_deg``, in order."""
    return np.vstack([np.asarray(start_deg, dtype=float)[None, :],
                      *planned_moves_deg(program_text, start_deg, rate_hz)])


def _split(rec: Recording, seg: MotionSpan, tol_mm: float, tol_deg: float, depth: int = 0) -> list[Any]:
    """Fitted moves for ``seg``, split at the farthest sample while off by more than the tolerances."""
    fit = fit_joint_move(rec, seg)
    recorded = steps_to_deg(rec.steps[seg.start:seg.end + 1])
    planned = np.asarray(fit.planned, dtype=float) / rec_model_spd()
    mm, deg = path_deviation(recorded, np.vstack([recorded[:1], planned]))
    if (mm <= tol_mm * 0.8 and deg <= tol_deg * 0.8) or depth >= 6 or seg.end - seg.start < 4:
        return [fit]
    # split at the recorded sample farthest (in joint space) from the straight joint path
    off = _joint_chord_offset(recorded)
    k = int(np.argmax(off[1:-1])) + 1
    mid = seg.start + k
    left = MotionSpan(seg.start, mid, int(rec.ticks[seg.start]), int(rec.ticks[mid]))
    right = MotionSpan(mid, seg.end, int(rec.ticks[mid]), int(rec.ticks[seg.end]))
    return _split(rec, left, tol_mm, tol_deg, depth + 1) + _split(rec, right, tol_mm, tol_deg, depth + 1)


#: shortest TCP line taught as a MoveCart (mm): below it a MoveJoint cannot bow away by much
CART_MIN_MM = 5.0


def _joint_chord_offset(recorded: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per sample, how far (deg, largest joint) it lies from the straight joint-space path
    between the first and the last sample."""
    a, b = recorded[0], recorded[-1]
    d = b - a
    denom = float(d @ d) or 1.0
    s = np.clip(((recorded - a) @ d) / denom, 0.0, 1.0)
    return np.asarray(np.abs(recorded - (a + s[:, None] * d)).max(axis=1), dtype=float)


def _cart_line(rec: Recording, seg: MotionSpan, tol_mm: float, tol_deg: float) -> str | None:
    """The ``MoveCart`` line that reproduces ``seg`` when its TCP went along a straight line
    (within a quarter of ``tol_mm``, at least :data:`CART_MIN_MM` long) straighter than its
    joints went in joint space (relative to each path's length: a Cartesian jog's TCP is
    straight to a few hundredths of a mm while its joints bow; one joint turning alone bows the
    TCP slightly and is a straight joint path), and the line's plan from the motion's start
    follows the recording within 0.8 x the tolerances; else None.  The recording's time
    first, then up to twice as long if the planner needs more (the path counts, not the pace).
    Recordings made with another tool than the default are left to MoveJoint (the pose shown
    is that tool's)."""
    first = rec.statuses[seg.start]
    if first.get("tool", "default") != "default" or rec.statuses[seg.end].get("tool", "default") != "default":
        return None
    xyz = rec.pose[seg.start:seg.end + 1, :3]
    a, b = xyz[0], xyz[-1]
    length = float(np.linalg.norm(b - a))
    if length < CART_MIN_MM:
        return None
    u = (b - a) / length
    rel = xyz - a
    perp = np.linalg.norm(rel - (rel @ u)[:, None] * u, axis=1)
    if float(perp.max()) > 0.25 * tol_mm:
        return None
    recorded = steps_to_deg(rec.steps[seg.start:seg.end + 1])
    span = float(np.abs(recorded[-1] - recorded[0]).max())
    if span <= 0.0 or float(perp.max()) / length >= float(_joint_chord_offset(recorded).max()) / span:
        return None  # the joints went (relatively) as straight: a MoveJoint follows it as well
    start = tuple(float(v) for v in recorded[0])
    secs = max(float(rec.ticks[seg.end] - rec.ticks[seg.start]) / rec.rate_hz, 0.05)
    for factor in (1.0, 1.25, 1.5, 2.0):
        line = f"MoveCart({_fmt(rec.pose[seg.end])},t={secs * factor:.2f})"
        try:
            planned = planned_moves_deg(f"Begin()\n{line}\nEnd()\n", start, rec.rate_hz)
        except ValueError:
            continue  # too fast for the planner (or unreachable): slower, or a MoveJoint
        mm, deg = path_deviation(recorded, np.vstack([recorded[:1], *planned]))
        return line if mm <= 0.8 * tol_mm and deg <= 0.8 * tol_deg else None
    return None


def rec_model_spd() -> NDArray[np.float64]:
    from parolkit.robot import PAROL6

    return np.asarray(PAROL6.steps_per_deg, dtype=float)


def _fmt(q: tuple[float, ...] | NDArray[np.float64]) -> str:
    return ",".join(f"{float(v):.4f}" for v in q)


def _io_events(rec: Recording) -> list[tuple[int, str]]:
    """(row, program line) of each change of OUT1/OUT2 and of the gripper's commanded position."""
    events: list[tuple[int, str]] = []
    prev_out: dict[str, Any] = {}
    prev_grip: Any = None
    for i, s in enumerate(rec.statuses):
        io = s.get("io") or {}
        for n, key in ((1, "out1"), (2, "out2")):
            v = io.get(key)
            if key in prev_out and v != prev_out[key]:
                events.append((i, f"Output({n}, {'HIGH' if v else 'LOW'})"))
            prev_out[key] = v
        g = s.get("gripper") or {}
        pos = g.get("position") if g.get("activated") else None
        if pos is not None and prev_grip is not None and abs(int(pos) - int(prev_grip)) > 3:
            events.append((i, f"Gripper({int(pos)}, 150, 500)"))
        if pos is not None:
            prev_grip = pos
    return events


def teach(rec: Recording, *, tol_mm: float = 5.0, tol_deg: float = 2.0, min_rest_s: float = 0.3) -> TeachResult:
    """See the module docstring; ValueError when the robot never moves."""
    rate = rec.rate_hz
    segs = rest_segments(rec, max(1, int(round(min_rest_s * rate))))
    if not segs:
        raise ValueError(f"{rec.path}: the robot does not move in this recording: nothing to teach")
    start = tuple(float(v) for v in steps_to_deg(rec.steps[segs[0].start]))
    lines = ["Begin()", f"MoveJoint({_fmt(start)})  # the demonstration's start pose"]
    events = _io_events(rec)
    moves = delays = carts = 0
    prev_end: int | None = None
    per_seg: list[int] = []  # motion lines of each motion
    for seg in segs:
        after = -1 if prev_end is None else prev_end
        for _row, text in [e for e in events if after < e[0] <= seg.start]:
            lines.append(text)
        if prev_end is not None:
            pause = (rec.ticks[seg.start] - rec.ticks[prev_end]) / rate
            if pause >= 0.01:
                lines.append(f"Delay({pause:.2f})")
                delays += 1
        cart = _cart_line(rec, seg, tol_mm, tol_deg)
        if cart is not None:
            lines.append(cart)
            carts += 1
            per_seg.append(1)
        else:
            fits = _split(rec, seg, tol_mm, tol_deg)
            for fit in fits:
                timing = f",t={fit.duration_s:.2f}" if fit.duration_s is not None else ""
                lines.append(f"MoveJoint({_fmt(fit.target_deg)}{timing})")
            per_seg.append(len(fits))
        moves += per_seg[-1]
        prev_end = seg.end
    for _, text in [e for e in events if prev_end is not None and e[0] > prev_end]:
        lines.append(text)
    lines.append("End()")
    text = "\n".join(lines) + "\n"
    # the dry run of the whole program, judged motion by motion against its own lines' paths
    planned = planned_moves_deg(text, start, rate)
    mm = deg = 0.0
    k = 1  # trajectory 0 is the move to the start pose
    for seg, n in zip(segs, per_seg):
        path = np.vstack([planned[k - 1][-1:], *planned[k:k + n]])
        m, d = path_deviation(steps_to_deg(rec.steps[seg.start:seg.end + 1]), path)
        mm, deg = max(mm, m), max(deg, d)
        k += n
    return TeachResult(text, moves, delays, mm, deg, carts)


def teach_command(args: argparse.Namespace) -> int:
    from parolkit.errors import ParolkitValueError

    try:
        rec = load_recording(args.recording)
        warn_if_damaged(rec, "teach")
        result = teach(rec, tol_mm=args.tolerance_mm, tol_deg=args.tolerance_deg)
    except (ParolkitValueError, ValueError) as exc:
        print(f"parolkit teach: {exc}", file=sys.stderr)
        return 2
    Path(args.output).write_text(result.text, encoding="utf-8")
    ok = result.deviation_mm <= args.tolerance_mm and result.deviation_deg <= args.tolerance_deg
    print(f"wrote {args.output}: {result.moves} moves ({result.cart_moves} MoveCart), {result.delays} delays; "
          f"deviation along the path "
          f"(dry run vs recording): {result.deviation_mm:.2f} mm TCP, {result.deviation_deg:.3f} deg joint "
          f"({'within' if ok else 'OUTSIDE'} {args.tolerance_mm:g} mm / {args.tolerance_deg:g} deg)")
    return 0 if ok else 1
