"""What the UDP server knows about the senders of datagrams (issue 22).

A sender is its address and port, nothing else: two sockets are two clients, whatever they
send.  Three small records, each bounded, read and written by the server thread and by the
tick thread when it reads the safety socket (a stop's ID, ACK_HERE: see
:mod:`parolkit.controller.steering`), so the two that change hold a lock for each short step;
the loop thread reports finished command IDs through a lock-free deque:

* :class:`KnownClients`: the sockets that asked for their acks (``ACK_HERE``).  At most
  :data:`MAX_KNOWN_CLIENTS`; when full, a newcomer takes the place of one silent for
  :data:`KNOWN_CLIENT_IDLE_S`, else it is refused ("busy").  The lease holder and a socket with
  commands still running or queued are never pushed out.
* :class:`CommandIds`: which sender each command ID belongs to, while the command is live
  (queued, running, waiting for the loop) and for the :data:`MAX_RECENT_IDS` IDs that ended
  last.  A datagram that reuses another sender's ID is refused, so no client can make the
  controller send an ack with someone else's ID (a forged COMPLETED of a running move).  Live
  IDs are never forgotten, however many new IDs a flood brings.
* :class:`ReturnCookies`: stateless proof that a sender receives datagrams at its address (a
  forged source address cannot echo what is sent there): an HMAC of the address and a time
  period under a key drawn at start.  SUBSCRIBE starts a status stream only for an address that
  echoed its cookie.
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import secrets
import threading
from collections import deque
from collections.abc import Callable

from parolkit.controller.inbox import Address

__all__ = [
    "KnownClients", "CommandIds", "ReturnCookies", "MAX_KNOWN_CLIENTS", "KNOWN_CLIENT_IDLE_S",
    "MAX_RECENT_IDS", "COOKIE_PERIOD_S", "COOKIE_CHARS",
]

#: sockets that sent ACK_HERE, remembered at most
MAX_KNOWN_CLIENTS = 256
#: a known socket silent this long may give its place to a newcomer when the table is full, s
KNOWN_CLIENT_IDLE_S = 60.0
#: IDs of ended commands still owned by their sender (beyond the live ones, which all are)
MAX_RECENT_IDS = 4096
#: a SUBSCRIBE cookie is valid in the period it was issued and the next one (30..60 s), s
COOKIE_PERIOD_S = 30.0
#: characters of a cookie (48 bits, URL-safe base64)
COOKIE_CHARS = 8


class KnownClients:
    """Sockets that asked for their acks (``ACK_HERE``), least recently heard first."""

    def __init__(self, capacity: int = MAX_KNOWN_CLIENTS, idle_s: float = KNOWN_CLIENT_IDLE_S) -> None:
        self.capacity = capacity
        self.idle_s = idle_s
        self._heard: dict[Address, float] = {}
        self._lock = threading.Lock()

    def __contains__(self, addr: object) -> bool:
        return addr in self._heard

    def __len__(self) -> int:
        return len(self._heard)

    def heard(self, addr: Address, now: float) -> None:
        """A datagram from ``addr``: a known socket moves to the back (the last to give way)."""
        with self._lock:
            self._heard_locked(addr, now)

    def _heard_locked(self, addr: Address, now: float) -> None:
        if addr in self._heard:
            del self._heard[addr]
            self._heard[addr] = now

    def admit(self, addr: Address, now: float, pinned: Callable[[Address], bool]) -> str | None:
        """Remember ``addr`` (ACK_HERE).  None when it is in; else why not.  When the table is
        full, the socket silent longest gives way if it has been silent for ``idle_s`` and
        ``pinned`` (the lease holder, a socket with live commands) is false for it."""
        with self._lock:
            return self._admit_locked(addr, now, pinned)

    def _admit_locked(self, addr: Address, now: float, pinned: Callable[[Address], bool]) -> str | None:
        if addr in self._heard:
            self._heard_locked(addr, now)
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


class CommandIds:
    """Which sender each command ID belongs to (see the module docstring).

    :meth:`claim` is called by the server thread for every datagram that carries an ID;
    :meth:`ended` by whichever thread sends an ID's terminal ack."""

    def __init__(self, recent: int = MAX_RECENT_IDS) -> None:
        self.recent_max = recent
        self._live: dict[str, Address] = {}
        self._recent: dict[str, Address] = {}  # oldest first
        self._live_per_sender: dict[Address, int] = {}
        self._ended: deque[str] = deque()  # appended by any thread, taken under the lock
        self._lock = threading.Lock()
        #: datagrams refused because their ID belonged to another sender
        self.refused = 0

    def claim(self, cid: str, addr: Address) -> Address | None:
        """``cid`` arrives from ``addr``: None when it is free or already ``addr``'s (it is then
        live for ``addr``), else the sender it belongs to (refuse the datagram)."""
        with self._lock:
            return self._claim_locked(cid, addr)

    def _claim_locked(self, cid: str, addr: Address) -> Address | None:
        self._absorb()
        owner = self._live.get(cid)
        if owner is None:
            owner = self._recent.get(cid)
        if owner is not None and owner != addr:
            self.refused += 1
            return owner
        if cid not in self._live:
            self._recent.pop(cid, None)
            self._live[cid] = addr
            self._live_per_sender[addr] = self._live_per_sender.get(addr, 0) + 1
        return None

    def ended(self, cid: str) -> None:
        """The terminal ack of ``cid`` was sent (any thread): it stays its sender's while it is
        among the :attr:`recent_max` IDs that ended last."""
        self._ended.append(cid)

    def has_live(self, addr: Address) -> bool:
        """True while a command ``addr`` sent is live (queued, running, waiting for the loop)."""
        with self._lock:
            self._absorb()
            return addr in self._live_per_sender

    @property
    def live(self) -> int:
        with self._lock:
            self._absorb()
            return len(self._live)

    def _absorb(self) -> None:
        """(under the lock) The IDs that ended since: recent, no longer live."""
        ended, live, recent = self._ended, self._live, self._recent
        while ended:
            cid = ended.popleft()
            owner = live.pop(cid, None)
            if owner is None:
                continue  # a second terminal ack, or an ID claimed twice by its sender
            left = self._live_per_sender[owner] - 1
            if left:
                self._live_per_sender[owner] = left
            else:
                del self._live_per_sender[owner]
            recent[cid] = owner
            if len(recent) > self.recent_max:
                del recent[next(iter(recent))]


class ReturnCookies:
    """Cookies that prove a sender receives at its address (``COOKIE|c`` to it, ``c`` echoed)."""

    def __init__(self, period_s: float = COOKIE_PERIOD_S, key: bytes | None = None) -> None:
        self.period_s = period_s
        self._key = key if key is not None else secrets.token_bytes(32)

    def _cookie(self, addr: Address, period: int) -> str:
        mac = hmac.new(self._key, f"{addr[0]}|{addr[1]}|{period}".encode(), hashlib.sha256).digest()
        return base64.urlsafe_b64encode(mac[: COOKIE_CHARS * 3 // 4]).decode("ascii")

    def issue(self, addr: Address, now: float) -> str:
        """The cookie for ``addr`` at time ``now`` (s, monotonic)."""
        return self._cookie(addr, int(now // self.period_s))

    def valid(self, addr: Address, cookie: str | None, now: float) -> bool:
        """True when ``cookie`` is ``addr``'s of this period or the one before."""
        if cookie is None or len(cookie) != COOKIE_CHARS:
            return False
        period = int(now // self.period_s)
        return any(hmac.compare_digest(cookie, self._cookie(addr, p)) for p in (period, period - 1))
