"""``parolkit board-sim`` in its own process on a real pty, for the integration tests and the
controller bench (one wrapper: the load rig, the link-fault, integrity, guard-on-the-wire and
flood tests all start it here).

The emulated board runs as SCHED_FIFO (else at nice -10) where the OS allows it: the real
board is a microcontroller of its own that answers every frame within a millisecond, whatever
the PC does; an emulator at normal priority on a busy machine left frames unanswered for
30-100 ms (its threads wait for the interpreter lock held by one the OS has preempted), which
a real board never does, so a fault it causes is not the controller's.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

from parolkit.board.control_channel import send_control
from parolkit.client.launch import die_with_parent, stop_process
from parolkit.controller.scheduling import raise_priority
from parolkit.robot import PAROL6

__all__ = ["BoardSim", "BOARD_FIFO_PRIORITY", "REPO_ROOT"]

REPO_ROOT = Path(__file__).resolve().parents[2]
SPD = tuple(float(v) for v in PAROL6.steps_per_deg)

#: the SCHED_FIFO priority board-sim asks for (see :class:`BoardSim`); above the controller's
BOARD_FIFO_PRIORITY = 20


def _raise(pid: int) -> str:
    """Every thread of process ``pid`` to SCHED_FIFO at :data:`BOARD_FIFO_PRIORITY`, else nice
    -10 (the controller's own rule, :func:`parolkit.controller.scheduling.raise_priority`);
    returns what the first got (``fifo:20``, ``nice:-10``, ``normal``).  Done once the board is
    up, not before its ``exec``: a process raised from the start runs its interpreter's
    start-up (a second or more of imports on a busy machine) at real-time priority, and on 2
    cores that starved everything else there, the kernel's tty flush included: frames another
    test's controller wrote reached its board 70 ms late, and its link was judged lost.
    Threads started later inherit it."""
    try:
        tids = [int(t) for t in os.listdir(f"/proc/{pid}/task")]
    except OSError:
        tids = [pid]
    return [raise_priority(BOARD_FIFO_PRIORITY, tid) for tid in tids][0]


class BoardSim:
    """``parolkit board-sim --link tmp/NAME`` in its own process.

    ``start_homed`` (``--start-homed``), ``frame_log`` (``--frame-log N``: the receive time and
    command code of every frame, see :meth:`frames`; None: off), ``exchange_log``
    (``--exchange-log tmp/NAME-exchange.jsonl``: every frame as sent and as executed and every
    true status frame, :attr:`record_path`), ``speedup`` (``--speedup``: homing time scale).
    ``raised`` runs it as SCHED_FIFO (else at nice -10) where the OS allows it (module
    docstring); :attr:`scheduling` says what it got.  (It does little work per frame and
    sleeps between frames; the kernel still keeps 5 % of the CPU for everything else.)
    """

    def __init__(self, tmp: Path, *, name: str = "p6", start_homed: bool = True,
                 frame_log: int | None = 100_000, exchange_log: bool = False, speedup: float | None = None,
                 env: dict[str, str] | None = None, raised: bool = True) -> None:
        self.link = tmp / name
        self.log_path = tmp / f"{name}-board-sim.log"
        self.record_path = tmp / f"{name}-exchange.jsonl"
        args = [sys.executable, "-m", "parolkit", "board-sim", "--link", str(self.link)]
        if start_homed:
            args.append("--start-homed")
        if frame_log is not None:
            args += ["--frame-log", str(frame_log)]
        if exchange_log:
            args += ["--exchange-log", str(self.record_path)]
        if speedup is not None:
            args += ["--speedup", str(speedup)]
        self._log = open(self.log_path, "wb")
        self.proc = subprocess.Popen(args, stdout=self._log, stderr=subprocess.STDOUT, env=env, cwd=REPO_ROOT,
                                     preexec_fn=die_with_parent)
        end = time.monotonic() + 20
        while not (self.link.exists() and Path(f"{self.link}.ctl").exists()):
            if self.proc.poll() is not None or time.monotonic() > end:
                raise RuntimeError(f"board-sim did not start: {self.log_path.read_text(errors='replace')}")
            time.sleep(0.02)
        self.scheduling = _raise(self.proc.pid) if raised else "normal"
        self.control_path = f"{self.link}.ctl"

    def ctl(self, text: str, timeout_s: float = 5.0) -> str:
        """A control command's reply as it is (``ok ...`` or ``error: ...``)."""
        return send_control(self.control_path, text, timeout_s=timeout_s)

    def control(self, text: str, timeout_s: float = 5.0) -> str:
        """A control command's answer (without ``ok ``); RuntimeError on an error reply."""
        reply = self.ctl(text, timeout_s)
        if not reply.startswith("ok"):
            raise RuntimeError(f"board-sim {text!r}: {reply}")
        return reply[3:]

    def status(self) -> dict:
        return json.loads(self.control("status"))

    def positions_deg(self) -> tuple[float, ...]:
        return tuple(p / s for p, s in zip(self.status()["positions"], SPD))

    def frames(self, since: float) -> list[list]:
        """Every frame the board received after ``since`` (monotonic s): ``[seq, t, command]``."""
        out: list[list] = []
        query = f"frames since={since:.6f}"
        while True:
            got = json.loads(self.control(query))
            out += got["frames"]
            if not got["more"] or not got["frames"]:
                return out
            query = f"frames since={since:.6f} after={got['frames'][-1][0]}"

    def close(self) -> None:
        stop_process(self.proc)
        self._log.close()


