"""The controller's status stream as a test sees it: every tick's status, and which command ran
on which ticks.  Timing judged on these is judged in ticks (``seq``, the controller's tick
count), whatever the machine's load did to the wall clock; on a board in lockstep with the
frames (``start_controller(lockstep=True)``) the board's position at a tick is exact too.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from parolkit.client.core import RobotStatus
from parolkit.client.robot import Robot


class StatusLog:
    """Every status of the controller (one per tick, ``Robot.subscribe(1)``) since the last
    :meth:`clear`; :meth:`close` ends the subscription."""

    #: the subscription socket's receive buffer: ~2,000 statuses (20 s at 100 Hz), so a test
    #: process starved by a loaded machine loses none (the default holds about one second's)
    RCVBUF = 4 << 20

    def __init__(self, robot: Robot) -> None:
        self.items: list[RobotStatus] = []
        self._lock = threading.Lock()
        self.sub = robot.subscribe(1, callback=self._add)
        self.sub._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.RCVBUF)

    def _add(self, st: RobotStatus) -> None:
        with self._lock:
            self.items.append(st)

    def snapshot(self) -> list[RobotStatus]:
        with self._lock:
            return list(self.items)

    def clear(self) -> None:
        with self._lock:
            self.items.clear()

    def close(self) -> None:
        self.sub.close()


@contextmanager
def client_and_status_log(ctl: Any) -> Iterator[tuple[Any, StatusLog]]:
    """A raw UDP client of the controller ``ctl`` (``tests.integration.test_controller_sim``'s
    ``Client``) and the log of its every status, closed afterwards."""
    from tests.integration.test_controller_sim import Client

    client = Client(ctl)
    robot = Robot(ctl.host, ctl.port, ack_port=0, timeout=2.0)
    log = StatusLog(robot)
    try:
        yield client, log
    finally:
        log.close()
        robot.close()
        client.close()


@dataclass(frozen=True)
class CommandRun:
    """The ticks one command was the controller's active command: ``first`` and ``last`` seq
    it was seen with (a status lost on the way shortens the run by that tick at most)."""

    id: str
    name: str
    first: int
    last: int

    @property
    def ticks(self) -> int:
        return self.last - self.first + 1


def command_runs(statuses: list[RobotStatus]) -> list[CommandRun]:
    """Every command seen active in ``statuses``, in the order they started."""
    runs: dict[str, CommandRun] = {}
    for st in statuses:
        cmd = st.command
        if cmd is None or not cmd.id:
            continue
        run = runs.get(cmd.id)
        runs[cmd.id] = (CommandRun(cmd.id, cmd.name, st.seq, st.seq) if run is None
                        else CommandRun(run.id, run.name, run.first, max(run.last, st.seq)))
    return sorted(runs.values(), key=lambda r: r.first)
