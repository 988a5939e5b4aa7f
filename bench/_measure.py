"""What the collision benchmarks share: a per-call CPU time and the machine line they print first.

Not a benchmark itself (the leading underscore keeps it out of ``make bench``)."""

from __future__ import annotations

import os
import time
from collections.abc import Callable


def per_call_s(fn: Callable[[], object], min_s: float = 0.002) -> float:
    """CPU time of one call of ``fn`` (s, this process's ``process_time``: time the machine
    gave other work is not counted), averaged over as many calls as fill ``min_s``."""
    clock = time.process_time
    n = 0
    t0 = clock()
    while True:
        fn()
        n += 1
        t = clock() - t0
        if t >= min_s:
            return t / n


def machine_line() -> str:
    """``machine: N CPUs, load average a / b / c``: what the figures after it were taken on."""
    load = os.getloadavg()
    return f"machine: {os.cpu_count()} CPUs, load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}"
