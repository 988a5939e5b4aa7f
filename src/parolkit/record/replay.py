"""``parolkit replay run.mcap``: play a recording's joint motion into a controller.

The recording is cut into the motions of its commands (:func:`command_segments`); each is
sent as the MoveJoint that reproduces it (its rest-to-rest target and, from the command's
progress, its planned length in ticks; see :mod:`parolkit.record.segments`), with DELAYs
reproducing the ticks between them.  Everything goes through the normal command path: the
planner times every move and every frame passes the controller's guard.  First the robot is
brought to the recording's start pose with a normal planned move at ``--speed`` %.

The controller is a simulated one started for the replay unless ``--connect`` is given; a
controller whose board is not simulated is moved only with ``--real-robot``.  The simulated
one runs at the recording's rate with its board in lockstep with the frames
(``sim://?clock=virtual&step=1/rate``: every frame runs it exactly one period, and the
controller schedules trajectories on ticks), so the replay is the same tick for tick however
late the PC's ticks run; a recording made the same way replays within a step at every tick.
"""

from __future__ import annotations

import argparse
import socket
import sys
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from parolkit.client.launch import SimController
from parolkit.record.reader import Recording, load_recording, warn_if_damaged
from parolkit.record.segments import FittedMove, command_segments, fit_joint_move, steps_to_deg

__all__ = ["ReplayStep", "build_replay", "replay_command", "lockstep_board", "DELAY_OVERHEAD_TICKS"]

#: ticks between the end of a command and the start of the next one queued behind it (the
#: status shows no command for one tick): the ticks between two recorded commands beyond
#: this are replayed as a DELAY (measured with queued commands: move, DELAY 0.5 s, move =
#: 1 + 50 ticks between the moves)
DELAY_OVERHEAD_TICKS = 1


@dataclass(frozen=True)
class ReplayStep:
    """One command of the replay: a fitted move, or a delay of ``delay_s`` s."""

    move: FittedMove | None = None
    delay_s: float | None = None
    source: str = ""

    def text(self) -> str:
        if self.move is not None:
            m = self.move
            timing = f"t={m.duration_s:g} s" if m.duration_s is not None else "default speed"
            return (f"MoveJoint({', '.join(f'{v:.3f}' for v in m.target_deg)}, {timing})  "
                    f"[{self.source}; plan vs recording {m.error_steps} steps]")
        return f"Delay({self.delay_s:g})"


def lockstep_board(rate_hz: float) -> str:
    """The transport URL of a simulated board in lockstep with a controller at ``rate_hz``."""
    return f"sim://?clock=virtual&step={1.0 / rate_hz!r}"


def build_replay(rec: Recording) -> tuple[tuple[float, ...], list[ReplayStep]]:
    """(start pose in deg, the commands) that replay ``rec``."""
    segs = command_segments(rec)
    if not segs:
        raise ValueError(f"{rec.path}: the robot does not move in this recording")
    start = tuple(float(v) for v in steps_to_deg(rec.steps[segs[0].start]))
    steps: list[ReplayStep] = []
    rate = rec.rate_hz
    for i, seg in enumerate(segs):
        if i > 0:
            prev = segs[i - 1]
            gap = int((seg.command_tick or seg.start_tick) - (prev.command_end_tick or prev.end_tick))
            if gap > DELAY_OVERHEAD_TICKS:
                steps.append(ReplayStep(delay_s=round((gap - DELAY_OVERHEAD_TICKS) / rate, 6),
                                        source=f"{gap} ticks between commands"))
        fit = fit_joint_move(rec, seg)
        steps.append(ReplayStep(move=fit, source=f"{seg.command or 'motion'} ticks {seg.start_tick}..{seg.end_tick}"))
    return start, steps


def run_replay(host: str, port: int, start: tuple[float, ...], steps: list[ReplayStep], *,
               speed_pct: float, record_to: str | None = None, window: int = 16) -> dict[str, object]:
    """Move to ``start`` at ``speed_pct`` %, then send ``steps`` (at most ``window`` waiting)."""
    from parolkit.client.robot import Robot
    from parolkit.record.recorder import Recorder

    result: dict[str, object] = {}
    with Robot(host, port) as robot:
        now = np.asarray(robot.angles(), dtype=float)
        if np.abs(now - np.asarray(start)).max() > 1e-3:
            robot.move_joints(list(start), speed=speed_pct, timeout=120)
            result["moved_to_start"] = True
        recorder: Recorder | None = None
        rec_thread: threading.Thread | None = None
        if record_to is not None:
            recorder = Recorder(host, port, record_to)
            rec_thread = threading.Thread(target=recorder.run, name="parolkit-replay-recorder", daemon=True)
            rec_thread.start()
            deadline = time.monotonic() + 10
            while recorder.stats.statuses < 20 and time.monotonic() < deadline:
                time.sleep(0.02)
        handles: list[Any] = []
        try:
            for step in steps:
                while sum(1 for h in handles if not h.done()) >= window:
                    time.sleep(0.005)
                if step.move is not None:
                    m = step.move
                    if m.duration_s is not None:
                        h = robot.move_joints(list(m.target_deg), duration=m.duration_s, wait=False)
                    else:  # the defaults of MoveJoint without t (RBTscript's, the planner's)
                        jm = m.move()
                        h = robot.move_joints(list(m.target_deg), speed=jm.speed_pct, accel=jm.accel_pct,
                                              wait=False)
                else:
                    h = robot.delay(float(step.delay_s or 0.0), wait=False)
                handles.append(h)
            for h in handles:
                h.result(timeout=3600)  # raises CommandFailed etc. with the controller's reason
            result["commands"] = len(handles)
            result["final_deg"] = tuple(robot.angles())
        finally:
            if recorder is not None and rec_thread is not None:
                time.sleep(0.3)
                recorder.stop()
                rec_thread.join(10)
                result["recording"] = recorder.stats.text()
    return result


def replay_command(args: argparse.Namespace) -> int:
    """The ``parolkit replay`` sub-command (see the module docstring)."""
    from parolkit.client.errors import RobotError
    from parolkit.errors import ParolkitValueError

    try:
        rec = load_recording(args.recording)
        warn_if_damaged(rec, "replay")
        start, steps = build_replay(rec)
    except (ParolkitValueError, ValueError) as exc:
        print(f"parolkit replay: {exc}", file=sys.stderr)
        return 2
    print(f"{rec.path}: {len(rec)} ticks at {rec.rate_hz:g} Hz; start pose "
          f"[{', '.join(f'{v:.3f}' for v in start)}] deg; {len(steps)} commands:")
    for s in steps:
        print(f"  {s.text()}")
    sim: SimController | None = None
    try:
        if args.connect is not None:
            host, port = args.connect
            simulated = _is_simulated(host, port)
            if simulated is None:
                print(f"parolkit replay: no status from the controller at {host}:{port}: is it running?",
                      file=sys.stderr)
                return 1
            if not args.real_robot and not simulated:
                print(f"parolkit replay: the controller at {host}:{port} drives a real robot (its board is not "
                      f"simulated): add --real-robot to replay onto it", file=sys.stderr)
                return 2
        else:
            print("starting a controller with the simulated board ...", flush=True)
            sim = SimController(["--rate", f"{rec.rate_hz:g}"], board=lockstep_board(rec.rate_hz))
            sim.wait_ready()
            host, port = "127.0.0.1", sim.port
        out = run_replay(host, port, start, steps, speed_pct=args.speed, record_to=args.record)
    except (RobotError, RuntimeError, OSError) as exc:
        print(f"parolkit replay: {exc}", file=sys.stderr)
        return 1
    finally:
        if sim is not None:
            sim.close()
    print(f"replayed {out.get('commands')} commands; final joints "
          f"[{', '.join(f'{v:.3f}' for v in out.get('final_deg', ()))}] deg")  # type: ignore[attr-defined]
    if "recording" in out:
        print(out["recording"])
    return 0


def _is_simulated(host: str, port: int) -> bool | None:
    """Whether the controller at host:port reports a simulated board (None: no answer)."""
    import json

    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.settimeout(2.0)
        try:
            sock.sendto(b"GET_STATUS_JSON", (host, port))
            reply = sock.recv(65535).decode(errors="replace")
        except OSError:
            return None
    if not reply.startswith("STATUS_JSON|"):
        return None
    return bool(json.loads(reply.partition("|")[2]).get("board", {}).get("simulated"))


