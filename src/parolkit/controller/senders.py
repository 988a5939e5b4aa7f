"""What the UDP server knows about the senders of datagrams (issue 22).

A sender is its address and port, nothing else: two sockets are two clients, whatever they
send.  Bounded records, read and written by the server thread:

* :class:`KnownClients`: the sockets that asked for their acks (``ACK_HERE``).  At most
  :data:`MAX_KNOWN_CLIENTS`; when full, a newcomer takes the place of one silent for
  :data:`KNOWN_CLIENT_IDLE_S`, else it is refused ("busy").  The lease holder is never pushed
  out.
"""

from __future__ import annotations

from collections.abc import Callable

from parolkit.controller.inbox import Address

__all__ = ["KnownClients", "MAX_KNOWN_CLIENTS", "KNOWN_CLIENT_IDLE_S"]

#: sockets that sent ACK_HERE, remembered at most
MAX_KNOWN_CLIENTS = 256
#: a known socket silent this long may give its place to a newcomer when the table is full, s
KNOWN_CLIENT_IDLE_S = 60.0


class KnownClients:
    """Sockets that asked for their acks (``ACK_HERE``), least recently heard first."""

    def __init__(self, capacity: int = MAX_KNOWN_CLIENTS, idle_s: float = KNOWN_CLIENT_IDLE_S) -> None:
        self.capacity = capacity
        self.idle_s = idle_s
        self._heard: dict[Address, float] = {}

    def __contains__(self, addr: object) -> bool:
        return addr in self._heard

    def __len__(self) -> int:
        return len(self._heard)

    def heard(self, addr: Address, now: float) -> None:
        """A datagram from ``addr``: a known socket moves to the back (the last to give way)."""
        if addr in self._heard:
            del self._heard[addr]
            self._heard[addr] = now

    def admit(self, addr: Address, now: float, pinned: Callable[[Address], bool]) -> str | None:
        """Remember ``addr`` (ACK_HERE).  None when it is in; else why not.  When the table is
        full, the socket silent longest gives way if it has been silent for ``idle_s`` and
        ``pinned`` (true for the lease holder) is false for it."""
        if addr in self._heard:
            self.heard(addr, now)
            return None
        if len(self._heard) >= self.capacity:
            victim = None
            for old, last in self._heard.items():  # least recently heard first
                if pinned(old):
                    continue
                if now - last >= self.idle_s:
                    victim = old
                break
            if victim is None:
                return (f"controller busy: {self.capacity} client sockets are registered for acks and "
                        f"none has been silent for {self.idle_s:g} s; acks of this socket's commands go "
                        "to the ack port only")
            del self._heard[victim]
        self._heard[addr] = now
        return None

