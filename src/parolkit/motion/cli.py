"""``parolkit plan``: plan one move, print a summary table, optionally plot it.

Examples::

    parolkit plan movejoint 0 -90 180 0 0 180 --t 4 --profile trap --plot out.png
    parolkit plan movejoint 0 -60 150 0 0 180 --v 50 --a 50 --from 90 -90 180 0 0 180
    parolkit plan movepose 7 250 200 -100 0 -90
    parolkit plan movecart 0 263.23 161.241 -90 0 -89.5 --t 3
    parolkit plan movecartreltrf 0 0 -50 0 0 0
    parolkit plan speedjoint 5 0 0 0 0 -10 --t 2
    parolkit plan jog 0 50 --t 1          (UDP JOG index rule: 0-5 positive, 6-11 negative)

Exit status 0 when the move is feasible, 1 when it is refused (the reason is printed).
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from parolkit.motion.trajectory import Trajectory
    from parolkit.moves import Move

__all__ = ["register", "run"]

_KINDS = ("movejoint", "movepose", "movecart", "movecartreltrf", "speedjoint", "jog")


def register(
    subparsers: argparse._SubParsersAction[argparse.ArgumentParser], name: str = "plan",
) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        name, help="plan one move and print or plot its trajectory",
        description="Plan one move from a start configuration and print its summary "
        "(duration, samples, notes, peak speeds). Units: deg, mm, %, s.",
    )
    p.add_argument("kind", choices=_KINDS, type=str.lower, help="the move")
    p.add_argument("values", nargs="+", type=float,
                   help="6 joint angles (deg) / pose (mm, deg) / deltas / speeds (deg/s); "
                        "jog: INDEX SPEED%%")
    p.add_argument("--t", "--duration", dest="duration", type=float, default=None, help="duration (s)")
    p.add_argument("--v", "--speed", dest="speed", type=float, default=None, help="speed %%")
    p.add_argument("--a", "--accel", dest="accel", type=float, default=None, help="acceleration %%")
    p.add_argument("--profile", choices=("poly", "trap", "ruckig", "toppra"), default=None)
    p.add_argument("--tracking", choices=("position", "speed"), default="position")
    p.add_argument("--distance", type=float, default=None, help="jog distance (deg)")
    p.add_argument("--from", dest="start", nargs=6, type=float, metavar="J", default=None,
                   help="start joint angles (deg); default: the standby pose 90 -90 180 0 0 180")
    p.add_argument("--rate", type=float, default=100.0, help="control rate (Hz), default 100")
    p.add_argument("--plot", default=None, metavar="PNG", help="write position/speed curves here")
    p.add_argument("--csv", default=None, metavar="CSV", help="write t, positions, speeds, command")
    p.set_defaults(func=run)
    return p


def _build_move(args: argparse.Namespace) -> Move:
    from parolkit import motion as m

    vals = args.values
    kind = args.kind
    if kind == "jog":
        if len(vals) != 2 or not float(vals[0]).is_integer():
            raise ValueError("jog needs INDEX (0-11) and SPEED% (e.g. 'jog 0 50 --t 1')")
        return m.JointJog.from_index(int(vals[0]), vals[1], args.duration, args.distance)
    if len(vals) != 6:
        raise ValueError(f"{kind} needs 6 values, got {len(vals)}")
    common = dict(duration_s=args.duration, speed_pct=args.speed, profile=args.profile,
                  tracking=args.tracking)
    if kind == "movejoint":
        return m.JointMove(vals, accel_pct=args.accel, **common)
    if kind == "movepose":
        return m.PoseMove(vals, accel_pct=args.accel, **common)
    if kind == "movecart":
        return m.CartMove(vals, **common)
    if kind == "movecartreltrf":
        return m.CartRelTRFMove(vals, **common)
    if args.duration is None:
        raise ValueError("speedjoint needs --t (s)")
    return m.SpeedJointMove(vals, args.duration)


def run(args: argparse.Namespace) -> int:
    from parolkit.errors import ParolkitError
    from parolkit.motion import plan, plot_trajectory
    from parolkit.robot import PAROL6

    start = np.asarray(args.start if args.start is not None else PAROL6.standby_deg, dtype=float)
    try:
        move = _build_move(args)
        traj = plan(move, start, rate_hz=args.rate)
    except (ParolkitError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    _print_table(traj)
    if args.plot:
        out = plot_trajectory(traj, args.plot)
        print(f"plot written to {out}")
    if args.csv:
        cols = ["t"] + [f"pos{j}" for j in range(1, 7)] + [f"speed{j}" for j in range(1, 7)] + ["command"]
        data = np.column_stack([traj.t, traj.positions, traj.speeds, traj.commands])
        np.savetxt(args.csv, data, delimiter=",", header=",".join(cols), comments="",
                   fmt=["%.4f"] + ["%d"] * 13)
        print(f"samples written to {args.csv}")
    return 0


def _print_table(traj: Trajectory) -> None:
    print(f"move       {traj.name}")
    print(f"duration   {traj.duration:.3f} s  ({len(traj)} samples at {traj.rate_hz:g} Hz, "
          f"board command {int(traj.commands[-1])})")
    for n in traj.notes:
        print(f"note       {n}")
    spd = traj.model.steps_per_deg
    peaks = traj.peak_speeds_steps_s()
    mx = np.asarray(traj.model.max_speed_steps_s, dtype=float)
    print(f"{'joint':<6}{'start deg':>11}{'end deg':>11}{'peak steps/s':>14}{'peak deg/s':>12}{'% of max':>10}")
    for j in range(6):
        print(f"J{j + 1:<5}{traj.start_deg[j]:>11.3f}{traj.final_deg[j]:>11.3f}{int(peaks[j]):>14d}"
              f"{peaks[j] / spd[j]:>12.2f}{100 * peaks[j] / mx[j]:>10.1f}")
