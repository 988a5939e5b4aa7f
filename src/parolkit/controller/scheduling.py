"""The operating system's scheduling a controller thread or process asks for (Linux).

One rule for the tick thread and the stop supervisor process: SCHED_FIFO at a given priority
where the OS grants it, else nice -10, else normal priority; the caller reports which it got.
Light to import (the supervisor process starts with it).
"""

from __future__ import annotations

import os
import threading

__all__ = ["raise_priority"]


def raise_priority(fifo_priority: int, tid: int | None = None) -> str:
    """Ask the OS to prefer the calling thread (or thread ``tid``, of any process the caller
    may change): SCHED_FIFO at ``fifo_priority`` (0: do not ask), else nice -10, else nothing.
    Returns what it got: ``"fifo:N"``, ``"nice:-10"`` or ``"normal"``."""
    if tid is None:
        tid = threading.get_native_id()
    if fifo_priority > 0:
        try:
            os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(fifo_priority))
            return f"fifo:{fifo_priority}"
        except (AttributeError, OSError, ValueError):
            pass
    try:
        os.setpriority(os.PRIO_PROCESS, tid, -10)
        return "nice:-10"
    except (AttributeError, OSError):
        return "normal"
