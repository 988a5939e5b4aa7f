"""Plain values that cross between the controller's parts: what the UDP server hands the tick
(:class:`Submission`), what the tick gives back to be sent (:class:`Ack`), and what the driver
learns about the board link and the stop supervisor (:class:`LinkEvent`,
:class:`SupervisorEvent`).  Nothing here does anything: no threads, no I/O."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from parolkit.protocol.commands import AckStatus, Command, format_ack

__all__ = ["Address", "AckRoute", "Submission", "Ack", "LinkEvent", "LinkEventKind", "SupervisorEvent",
           "SupervisorEventKind", "SET_PORT_SCHEMES"]

#: the links SET_PORT may switch to: a serial device only (a datagram must not choose the
#: emulator, or a spy+ link that writes files)
SET_PORT_SCHEMES = frozenset({"serial"})

#: a UDP (host, port) pair
Address = tuple[str, int]
#: where a command's acks go: one or more addresses
AckRoute = tuple[Address, ...]


@dataclass(frozen=True, slots=True)
class Submission:
    """A parsed command from ``source`` whose acks go to ``route`` (None: no command ID).

    ``seq`` numbers datagrams in the order the server received them: a safety command applied
    first cancels every command received before it that the loop had not applied yet.
    ``tool`` and ``ahead`` carry what the server prepared off the tick: the resolved tool
    object of a SET_TOOL (kinematics work never runs in the tick), and the key of the plan it
    asked for ahead of the tick for a motion command that reached an idle robot
    (:class:`~parolkit.controller.planning.PlanRequest`)."""

    command: Command
    command_id: str | None
    route: AckRoute | None
    source: Address
    seq: int = 0
    tool: object | None = None
    #: the key of the plan requested ahead for it, if any
    ahead: int | None = None
    #: who sent it (``str`` of a :class:`~parolkit.controller.lease.ClientId`): GET_QUEUE shows
    #: a command's ID to its own client only
    client: str = ""


@dataclass(frozen=True, slots=True)
class Ack:
    """``ACK|ID|STATUS|details`` to every address of ``route``."""

    command_id: str
    route: AckRoute
    status: AckStatus
    details: str = ""

    @property
    def text(self) -> str:
        return format_ack(self.command_id, self.status, self.details)


class LinkEventKind(Enum):
    """What happened to the board link."""

    #: a link session starts (the port opened, or opened again): nothing is known of the board
    UP = "up"
    #: the link is gone (the port vanished, a write failed)
    LOST = "lost"


@dataclass(frozen=True, slots=True)
class LinkEvent:
    """The board link came up (``description`` of the board; ``virtual_clock``: a simulated
    board whose time stands still between ticks; ``simulated``; ``port``: the port SET_PORT
    asked for, when this is the link the driver opened for it) or was lost (``reason``)."""

    kind: LinkEventKind
    reason: str = ""
    description: str = ""
    virtual_clock: bool = False
    simulated: bool = False
    port: str | None = None


class SupervisorEventKind(Enum):
    """What the controller learnt from (or about) its stop supervisor."""

    #: it is up, watching the port (``text``: its scheduling, "fifo:11", "nice:-10", "normal")
    READY = "ready"
    #: it stopped the board on its own: the controller wrote no frame for the stall limit
    #: (``text``: its account)
    STOPPED = "stopped"
    #: it is gone: it exited, its socket broke, it answers no frames or it could not be
    #: started (``text``: which); nothing would stop the board if the controller died now
    LOST = "lost"


@dataclass(frozen=True, slots=True)
class SupervisorEvent:
    """One event of :meth:`~parolkit.controller.supervisor.StopSupervisor.poll`."""

    kind: SupervisorEventKind
    text: str
