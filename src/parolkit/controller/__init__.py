"""The headless controller: fixed-rate loop, command queue, safety guard, UDP server.

Rooms (one job each):

* :mod:`~parolkit.controller.stats`    loop timing statistics (histograms, no per-query sort)
* :mod:`~parolkit.controller.state`    status snapshot value object + reply formats
* :mod:`~parolkit.controller.guard`    THE safety guard every outgoing frame passes
* :mod:`~parolkit.controller.jobs`     accepted commands and what they do tick by tick
* :mod:`~parolkit.controller.executor` queue, planner worker, active job, acks
* :mod:`~parolkit.controller.loop`     the deadline-based tick: read, decide, guard, write, sleep
* :mod:`~parolkit.controller.supervisor` the stop supervisor process: DISABLE when the controller dies
* :mod:`~parolkit.controller.scheduling` SCHED_FIFO / nice for the tick thread and the supervisor
* :mod:`~parolkit.controller.server`   UDP socket thread: parse, enqueue, answer queries, stream
* :mod:`~parolkit.controller.app`      wiring, start/stop, signals
* :mod:`~parolkit.controller.cli`      ``parolkit serve`` / ``headless-commander``

Importing this package is light; :class:`Controller` is loaded on first use.
"""

from __future__ import annotations

__all__ = ["Controller"]


def __getattr__(name: str) -> type:
    if name == "Controller":
        from parolkit.controller.app import Controller

        return Controller
    raise AttributeError(f"module 'parolkit.controller' has no attribute {name!r}")
