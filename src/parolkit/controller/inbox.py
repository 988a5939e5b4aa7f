"""What crosses from the UDP server to the tick, and what comes back: plain values.

* :class:`Submission`: one parsed command on its way to the loop (with its ack route).
* :class:`Ack`: one acknowledgement the tick produced, sent only after the tick published the
  snapshot that shows what it reports.
* :class:`CommandInbox`: the server -> loop hand-off.  Safety commands (ESTOP, STOP,
  DISABLE) have a lane of their own that the loop empties first and checks again just before
  it writes the frame, so no other traffic can delay them.  Every other command waits in a
  per-source lane; the loop takes them round-robin, a bounded number per tick, and a source
  with too many commands waiting is refused ("busy"), never silently dropped.

The server thread only ever calls :meth:`CommandInbox.put` / :meth:`put_safety`; the loop
thread only :meth:`take_safety` / :meth:`take`.  Neither waits for the other.
"""

from __future__ import annotations

import threading
from collections import deque

from parolkit.controller.messages import Ack, AckRoute, Address, Submission

__all__ = [
    "Address",
    "AckRoute",
    "Submission",
    "Ack",
    "CommandInbox",
    "MAX_WAITING_PER_SOURCE",
    "MAX_TAKEN_PER_TICK",
]

#: a source may have this many commands waiting for the loop; more are refused as busy
MAX_WAITING_PER_SOURCE = 32
#: the loop takes at most this many (non-safety) commands per tick
MAX_TAKEN_PER_TICK = 64


class CommandInbox:
    """Server -> loop hand-off with a safety lane and fair per-source lanes (see module doc)."""

    def __init__(self, *, max_waiting_per_source: int = MAX_WAITING_PER_SOURCE,
                 max_taken_per_tick: int = MAX_TAKEN_PER_TICK) -> None:
        self.max_waiting = max_waiting_per_source
        self.max_taken = max_taken_per_tick
        self._lock = threading.Lock()
        self._safety: deque[Submission] = deque()
        self._lanes: dict[Address, deque[Submission]] = {}
        self._turn: deque[Address] = deque()  # sources with something waiting, next first
        #: commands refused because their source had too many waiting
        self.refused = 0

    # server thread -------------------------------------------------------------------------

    def put_safety(self, sub: Submission) -> None:
        """ESTOP / STOP / DISABLE: never refused, taken before anything else."""
        with self._lock:
            self._safety.append(sub)

    def put(self, sub: Submission) -> bool:
        """Queue ``sub`` in its source's lane; False (and counted) when that lane is full."""
        with self._lock:
            lane = self._lanes.get(sub.source)
            if lane is None:
                lane = self._lanes[sub.source] = deque()
                self._turn.append(sub.source)
            elif len(lane) >= self.max_waiting:
                self.refused += 1
                return False
            lane.append(sub)
            return True

    # loop thread ---------------------------------------------------------------------------

    @property
    def safety_waiting(self) -> bool:
        """True when a safety command arrived since the last :meth:`take_safety` (lock-free)."""
        return bool(self._safety)

    def take_safety(self) -> list[Submission]:
        with self._lock:
            out = list(self._safety)
            self._safety.clear()
        return out

    def take(self) -> list[Submission]:
        """Up to ``max_taken_per_tick`` commands, one per source in turn (round-robin)."""
        out: list[Submission] = []
        with self._lock:
            turn, lanes = self._turn, self._lanes
            while turn and len(out) < self.max_taken:
                src = turn.popleft()
                lane = lanes[src]
                out.append(lane.popleft())
                if lane:
                    turn.append(src)
                else:
                    del lanes[src]
        return out

    def __len__(self) -> int:
        with self._lock:
            return len(self._safety) + sum(len(q) for q in self._lanes.values())
