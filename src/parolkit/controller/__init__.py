"""The headless controller: fixed-rate loop, command queue, safety guard, UDP server.

Rooms (one job each):

* :mod:`~parolkit.controller.core`     the tick as a function: ``ControllerCore.update(TickInput) -> TickOutput``
* :mod:`~parolkit.controller.safety`   the safety state (E-stop, enable, faults) as pure transitions
* :mod:`~parolkit.controller.jobs`     accepted commands, their queue and acks
* :mod:`~parolkit.controller.activities` what a running command does tick by tick
* :mod:`~parolkit.controller.setpoints` outputs and gripper setpoints every frame carries
* :mod:`~parolkit.controller.planning` a plan as a pure function of its request
* :mod:`~parolkit.controller.link`     the one record of the board link; where the board can be
* :mod:`~parolkit.controller.guard`    THE safety guard every outgoing frame passes
* :mod:`~parolkit.controller.integrity` which status frames are the truth; motion nobody commanded
* :mod:`~parolkit.controller.snapshot` the status snapshot (plain data) and every reply format
* :mod:`~parolkit.controller.messages` the values that cross between the parts
* :mod:`~parolkit.controller.driver`   the thin driver: clock, transport, reply wait, reconnects,
  planner, stop supervisor; the deadline-based tick thread and fast-forward
* :mod:`~parolkit.controller.stats`    loop timing statistics (histograms, no per-query sort)
* :mod:`~parolkit.controller.supervisor` the stop supervisor process: DISABLE when the controller dies
* :mod:`~parolkit.controller.scheduling` SCHED_FIFO / nice for the tick thread and the supervisor
* :mod:`~parolkit.controller.inbox`    the server -> tick hand-off (safety lane, fair lanes)
* :mod:`~parolkit.controller.server`   UDP socket thread: parse, enqueue, answer queries, stream
* :mod:`~parolkit.controller.lease` / :mod:`~parolkit.controller.senders` who may command; IDs, cookies
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
