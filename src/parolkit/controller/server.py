"""UDP side of the controller: the command socket, the outbox and the status stream.

* :class:`UdpServer` has one thread that alternates two jobs.  It **drains** the socket
  (every datagram waiting, without blocking): a safety command (ESTOP, STOP, DISABLE) goes
  straight to the loop's safety lane, so the next frame written carries it however much other
  traffic is waiting (an ACK_HERE takes effect as it is read, so such a command's acks
  already reach the socket that asked); everything else waits in a bounded lane per source.  Then it **serves**
  a few datagrams, one from each source in turn (round-robin: a flooding client cannot starve
  the others): parse (:mod:`parolkit.protocol.commands`), answer queries from the latest
  snapshot, hand commands to the loop (:class:`~parolkit.controller.inbox.CommandInbox`), and
  drains again.  It never waits for a tick, and no datagram changes threads on its way (a
  hand-over costs a GIL switch, which is what delays replies under load).  A source over its
  share is refused with a "busy" ack (or ``ERROR|`` reply to a query), never silently: the
  counts are in GET_STATUS (``OVERLOAD=``) and GET_STATUS_JSON (``server``).  Nothing a
  datagram contains can raise out of :meth:`UdpServer.handle`.
  What may be a stop does not come to this socket at all where the kernel steers it to the
  port's safety socket (:mod:`parolkit.controller.steering`): the tick thread reads that one
  (:meth:`UdpServer.read_safety_socket`), the same checks, so a stop never waits behind the
  flood in the command socket's queue; what is not a stop there comes on to this thread.
* :class:`Outbox` sends acks and replies in order from one thread.
* :class:`StatusStream` sends ``STATUS_JSON|{...}`` to subscribers every N ticks.
"""

from __future__ import annotations

import itertools
import logging
import os
import select
import socket
import struct
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from queue import Empty, SimpleQueue
from typing import Protocol

from parolkit.controller.inbox import CommandInbox
from parolkit.controller.lease import ClientId, ControlLease, is_loopback
from parolkit.controller.messages import SET_PORT_SCHEMES, Ack, AckRoute, Address, Submission
from parolkit.controller.senders import CommandIds, KnownClients, ReturnCookies
from parolkit.controller.snapshot import Snapshot
from parolkit.controller.steering import SAFETY_MAX_BYTES, SO_RXQ_OVFL, SO_TIMESTAMPNS
from parolkit.protocol import commands as C
from parolkit.protocol.commands import (
    AckStatus,
    DatagramError,
    format_ack,
    format_error,
    is_command_id,
    parse_datagram,
)
from parolkit.robot import RobotModel
from parolkit.transport.factory import resolve_url
from parolkit.transport.options import TransportURLError

__all__ = [
    "Outbox", "StatusStream", "UdpServer", "QueryAnswerer", "SUBSCRIPTION_TTL_S", "MAX_SUBSCRIBERS",
    "MAX_DATAGRAMS_PER_SOURCE", "LOG_BUDGET_BYTES_PER_S",
]

log = logging.getLogger("parolkit.controller")

#: a subscription lapses this long after the last SUBSCRIBE, s
SUBSCRIPTION_TTL_S = 10.0
MAX_SUBSCRIBERS = 16
#: datagrams of one source waiting to be served; more are refused as busy
MAX_DATAGRAMS_PER_SOURCE = 256
#: datagrams served between two drains of the socket (bounds how long a safety command waits
#: in the kernel's queue: SERVE_BATCH times the slowest datagram, well under a millisecond)
SERVE_BATCH = 8
#: at most this many datagrams are read in one drain before serving again
DRAIN_MAX = 512
#: ancillary buffer for one SO_TIMESTAMPNS stamp (struct timespec) and one SO_RXQ_OVFL count
_ANC_SPACE = socket.CMSG_SPACE(16) + socket.CMSG_SPACE(4)
#: at most this many datagrams the tick thread reads from the safety socket per call
SAFETY_READS_PER_CALL = 32
#: bytes of log lines about invalid datagrams per second; the rest is counted, not logged
LOG_BUDGET_BYTES_PER_S = 4096


class QueryAnswerer(Protocol):
    """What the server needs from the rest of the controller: replies to queries (from the
    latest snapshot and the read-only views), a tool looked up by name (SET_TOOL's
    kinematics work happens here, never in the tick) and a plan started ahead for a motion
    command (the handle travels with it to the tick)."""

    def answer_query(self, name: str, viewer: str | None = None) -> str: ...

    def resolve_tool(self, name: str) -> object: ...

    def plan_ahead(self, command: C.Command) -> int | None:
        """Start planning ``command`` now if the robot is idle; the key of that plan (the
        submission carries it to the tick), or None."""

    def busy(self) -> bool:
        """True while the robot runs or queues a command (the control lease does not lapse)."""


class Outbox:
    """Sends datagrams (acks, replies) in FIFO order from its own thread, so neither the loop
    nor the server ever waits on a socket."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self._q: SimpleQueue[tuple[bytes, Address] | None] = SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="parolkit-outbox", daemon=True)
        self.sent = 0
        self.errors = 0

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._q.put(None)
        self._thread.join(2.0)

    def put(self, text: str, addr: Address | AckRoute) -> None:
        """Queue ``text`` for one address or for each address of an ack route."""
        data = text.encode("utf-8")
        if isinstance(addr[0], str):  # one (host, port)
            self._q.put((data, (addr[0], int(addr[1]))))
            return
        for a in addr:
            self._q.put((data, a))

    def send_acks(self, acks: Iterable[Ack]) -> None:
        for ack in acks:
            self.put(ack.text, ack.route)

    def send_waiting(self) -> None:
        """Send every queued datagram now, in the calling thread (an outbox whose thread was
        never started: a controller driven in-process)."""
        while True:
            try:
                item = self._q.get_nowait()
            except Empty:
                return
            if item is not None:
                self._send(*item)

    def flush(self, timeout: float = 1.0) -> None:
        end = time.monotonic() + timeout
        while not self._q.empty() and time.monotonic() < end:
            time.sleep(0.005)

    def _run(self) -> None:
        while True:
            item = self._q.get()
            if item is None:
                # drain what is left, then stop
                while True:
                    try:
                        rest = self._q.get_nowait()
                    except Empty:
                        return
                    if rest is not None:
                        self._send(*rest)
            self._send(*item)

    def _send(self, data: bytes, addr: tuple[str, int]) -> None:
        try:
            self.sock.sendto(data, addr)
            self.sent += 1
        except OSError as exc:
            self.errors += 1
            log.debug("sending to %s failed: %s", addr, exc)


@dataclass
class _Subscriber:
    addr: tuple[str, int]
    every: int
    expires: float


class StatusStream:
    """Status datagrams to subscribers: every tick's snapshot, in order.

    The loop hands each tick's snapshot over (:meth:`notify`, cheap when nobody subscribed);
    this thread sends each one to the subscribers it is due for.  When the thread falls behind
    (a loaded machine) the snapshots wait in a queue of :attr:`QUEUE_TICKS` and are all sent
    when it runs again, so a recorder sees every tick (the stream used to send only the newest
    snapshot when the thread woke: ticks went missing from recordings under load); should the
    queue ever fill, the oldest are dropped and counted in :attr:`overflowed`."""

    #: snapshots waiting for the stream thread at most (2.5 s at 100 Hz)
    QUEUE_TICKS = 256

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self._subs: dict[tuple[str, int], _Subscriber] = {}
        self._lock = threading.Lock()
        self._cv = threading.Condition()
        self._pending: deque[Snapshot] = deque(maxlen=self.QUEUE_TICKS)
        self._running = False
        self._thread = threading.Thread(target=self._run, name="parolkit-stream", daemon=True)
        self.sent = 0
        #: snapshots dropped because the queue was full (the thread stalled for 2.5 s)
        self.overflowed = 0

    def start(self) -> None:
        self._running = True
        self._thread.start()

    def stop(self) -> None:
        with self._cv:
            self._running = False
            self._cv.notify_all()
        self._thread.join(2.0)

    @property
    def count(self) -> int:
        return len(self._subs)

    def subscribe(self, addr: tuple[str, int], every: int) -> str | None:
        """Add or renew; returns an error text when full."""
        now = time.monotonic()
        with self._lock:
            for k in [k for k, s in self._subs.items() if s.expires < now]:
                del self._subs[k]
            if addr not in self._subs and len(self._subs) >= MAX_SUBSCRIBERS:
                return f"at most {MAX_SUBSCRIBERS} status subscribers"
            self._subs[addr] = _Subscriber(addr, every, now + SUBSCRIPTION_TTL_S)
        return None

    def unsubscribe(self, addr: tuple[str, int]) -> bool:
        with self._lock:
            return self._subs.pop(addr, None) is not None

    @property
    def subscribed(self) -> bool:
        """Anyone subscribed (read without the lock: a subscriber added meanwhile gets the next
        tick's)."""
        return bool(self._subs)

    def notify(self, snapshot: Snapshot) -> None:
        """Loop thread: this tick's snapshot (cheap when nobody subscribed)."""
        if not self._subs:
            return
        with self._cv:
            if len(self._pending) == self.QUEUE_TICKS:
                self.overflowed += 1
            self._pending.append(snapshot)
            self._cv.notify()

    def _run(self) -> None:
        while True:
            with self._cv:
                while self._running and not self._pending:
                    self._cv.wait(0.5)
                if not self._running:
                    return
                batch = list(self._pending)
                self._pending.clear()
            for snap in batch:
                self._send(snap)

    def _send(self, snap: Snapshot) -> None:
        now = time.monotonic()
        with self._lock:
            due = []
            for k in list(self._subs):
                s = self._subs[k]
                if s.expires < now:
                    del self._subs[k]
                elif snap.seq % s.every == 0:
                    due.append(s.addr)
        if not due:
            return
        try:
            data = snap.reply("GET_STATUS_JSON").encode()
        except Exception:
            log.exception("status stream: building the status failed")
            return
        for addr in due:
            try:
                self.sock.sendto(data, addr)
                self.sent += 1
            except OSError:
                pass


class UdpServer:
    """The command socket, its receiver and its worker thread (see the module docstring).

    Who sent what (issue 22, :mod:`parolkit.controller.senders`): every sender is its socket
    (address and port); :attr:`known` are the sockets that asked for their acks, :attr:`ids`
    whose each command ID is (a datagram with another sender's ID is refused to its sender,
    and nothing reaches the owner), :attr:`cookies` prove a subscriber receives where the
    stream would go."""

    def __init__(
        self,
        sock: socket.socket,
        *,
        model: RobotModel,
        inbox: CommandInbox,
        outbox: Outbox,
        stream: StatusStream,
        answerer: QueryAnswerer,
        ack_port: int,
        max_waiting_per_source: int = MAX_DATAGRAMS_PER_SOURCE,
        lease: ControlLease | None = None,
        safety_sock: socket.socket | None = None,
    ) -> None:
        self.sock = sock
        #: the port's safety socket (:mod:`parolkit.controller.steering`): read by the tick
        #: thread (:meth:`read_safety_socket`); None: everything comes to ``sock``
        self.safety_sock = safety_sock
        self.model = model
        self.inbox = inbox
        self.outbox = outbox
        self.stream = stream
        self.answerer = answerer
        self.ack_port = ack_port
        self.max_waiting = max_waiting_per_source
        #: who may command the robot (see parolkit.controller.lease)
        self.lease = lease if lease is not None else ControlLease()
        #: sockets that asked for their acks (ACK_HERE)
        self.known = KnownClients()
        #: the sender of every live (and recently ended) command ID
        self.ids = CommandIds()
        #: SUBSCRIBE's return-address proof
        self.cookies = ReturnCookies()
        # per-source lanes of (receive number, datagram), and the order sources are served in
        # (server thread only)
        self._lanes: dict[Address, deque[tuple[int, bytes]]] = {}
        self._turn: deque[Address] = deque()
        self._running = False
        self._thread = threading.Thread(target=self._serve, name="parolkit-udp", daemon=True)
        # the same socket, never waiting: Python polls a socket with a timeout before every
        # read even with MSG_DONTWAIT, so draining reads through a non-blocking twin
        self._nowait = sock.dup()
        self._nowait.setblocking(False)
        # receive order over both sockets (next() on a count is one step: any thread)
        self._seqs = itertools.count(1)
        # datagrams the tick thread read from the safety socket that are not stops (ACK_HERE,
        # lookalikes): the server thread serves them, woken through a socket pair
        self._passed: deque[tuple[int, bytes, Address]] = deque()
        self._wake_r: socket.socket | None = None
        self._wake_w: socket.socket | None = None
        self._safety_lock = threading.Lock()
        if safety_sock is not None:
            self._wake_r, self._wake_w = socket.socketpair()
            self._wake_r.setblocking(False)
            self._wake_w.setblocking(False)
        #: datagrams read from the command socket (server thread) / from the safety socket
        #: (tick thread, server thread; under the safety lock)
        self.read_main = 0
        self.steered = 0
        # the kernel's drop count of the command socket (False) and the safety socket (True)
        self._dropped: dict[bool, int] = {}
        #: datagrams not valid / refused because their source was over its share
        self.invalid = 0
        self.shed = 0
        #: commands refused with a busy ack (datagram lane or the loop's inbox full)
        self.busy_acks = 0
        self.safety_fast = 0
        #: ACK_HERE refused because the table of registered sockets was full
        self.clients_refused = 0
        self._log_window = 0.0
        self._log_bytes = 0
        self._suppressed = 0
        #: invalid datagrams not logged one by one (over the log budget), since start
        self.log_suppressed = 0

    def start(self) -> None:
        self._running = True
        self._thread.start()

    def stop(self) -> None:
        self._running = False
        if self._thread.ident is not None:  # (never started: served in-process, serve_now)
            self._thread.join(2.0)
        self._nowait.close()
        for s in (self._wake_r, self._wake_w):
            if s is not None:
                s.close()

    @property
    def received(self) -> int:
        """Datagrams read from the port (both sockets)."""
        return self.read_main + self.steered

    def overload_view(self) -> dict[str, int]:
        """Counters of refused traffic (GET_STATUS ``OVERLOAD=``, JSON ``server``)."""
        return {
            "received": self.received, "invalid": self.invalid, "shed": self.shed,
            "busy_acks": self.busy_acks, "inbox_refused": self.inbox.refused,
            "safety_fast": self.safety_fast, "steered": self.steered, "log_suppressed": self.log_suppressed,
            "foreign_ids": self.ids.refused, "clients_refused": self.clients_refused,
            "kernel_dropped": self.kernel_dropped,
        }

    def commands_ended(self, acks: Iterable[Ack]) -> None:
        """(loop thread) ``acks`` were sent: the IDs of the terminal ones are no longer live
        (they stay their senders' while recent)."""
        for ack in acks:
            if ack.status.terminal:
                self.ids.ended(ack.command_id)

    @property
    def overload(self) -> int:
        """Datagrams refused or lost for load so far (shed + commands refused by the inbox +
        dropped by the kernel before they were read)."""
        return self.shed + self.inbox.refused + self.kernel_dropped

    # ------------------------------------------------------------------ the server thread

    def _serve(self) -> None:
        self.sock.settimeout(0.2)
        while self._running:
            if not self._turn and not self._passed:
                if self._wake_r is not None:  # nothing to serve: sleep until a datagram comes
                    assert self.safety_sock is not None
                    ready = select.select([self._nowait, self.safety_sock, self._wake_r], [], [], 0.2)[0]
                    if self._wake_r in ready:
                        self._drain_wake()
                else:
                    try:
                        data, addr = self.sock.recvfrom(65535)
                    except TimeoutError:
                        continue
                    except OSError as exc:
                        if not self._running:
                            return
                        # e.g. ICMP port unreachable reported on Linux: ignore and go on
                        log.debug("recvfrom: %s", exc)
                        continue
                    self._take_in(data, addr)
            self._server_reads_safety()  # (first: what waits there arrived before the drain's)
            self._drain()
            # an ACK_HERE sent before what was just read is in effect before that is served
            self._server_reads_safety()
            while self._passed:
                self._queue(*self._passed.popleft())
            for _ in range(SERVE_BATCH):
                if not self._turn:
                    break
                self._serve_one()

    def _serve_one(self) -> None:
        """Serve the next datagram in turn (round-robin over the sources)."""
        src = self._turn.popleft()
        lane = self._lanes[src]
        seq, data = lane.popleft()
        if lane:
            self._turn.append(src)  # its next datagram after every other source's
        else:
            del self._lanes[src]
        try:
            self.handle(data, src, seq)
        except Exception:  # nothing a datagram contains may stop the server
            log.exception("handling a datagram from %s failed", src)

    def serve_now(self, data: bytes, addr: Address) -> None:
        """Take in ``data`` from ``addr`` and serve everything waiting, in the calling thread:
        for a controller driven in-process, without the server thread (:meth:`start` not
        called; :class:`~parolkit.controller.fastforward.InProcessController`)."""
        self._take_in(data, addr)
        while self._turn:
            self._serve_one()

    def _drain(self) -> None:
        """Read every datagram waiting in the socket (at most DRAIN_MAX), without blocking."""
        for data, addr, seq in self._waiting(self._nowait, DRAIN_MAX, "recvfrom"):
            self._take_in(data, addr, seq)

    def _waiting(self, sock: socket.socket, limit: int, what: str) -> Iterator[tuple[bytes, Address, int]]:
        """The datagrams waiting in the non-blocking ``sock`` (at most ``limit``), with their
        senders and receive numbers (:meth:`_recv`); ends when none is left or the socket
        fails (logged at debug level as ``what``)."""
        for _ in range(limit):
            try:
                got = self._recv(sock)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                log.debug("%s: %s", what, exc)
                return
            yield got

    def _recv(self, sock: socket.socket) -> tuple[bytes, Address, int]:
        """A datagram, its sender and its receive number.  With a safety socket, that is the
        kernel's arrival time (ns, ``SO_TIMESTAMPNS``) on both sockets: a stop the tick reads
        before the server thread reads a command sent before it still has the later number, so
        the core cancels that command when it comes (a STOP cancels what was sent before it).
        The kernel's count of datagrams it dropped at the socket comes along
        (``SO_RXQ_OVFL``): :attr:`kernel_dropped`."""
        data, anc, _flags, addr = sock.recvmsg(65535, _ANC_SPACE)
        stamp = None
        for level, kind, value in anc:
            if level != socket.SOL_SOCKET:
                continue
            if kind == SO_TIMESTAMPNS and len(value) >= 16:
                sec, nsec = struct.unpack("=qq", value[:16])
                stamp = sec * 1_000_000_000 + nsec
            elif kind == SO_RXQ_OVFL and len(value) >= 4:
                self._dropped[sock is self.safety_sock] = struct.unpack("=I", value[:4])[0]
        if self.safety_sock is None:
            return data, addr, next(self._seqs)
        return data, addr, stamp if stamp is not None else time.time_ns()

    @property
    def kernel_dropped(self) -> int:
        """Datagrams the kernel dropped at the port's sockets because their receive buffers
        were full (a client sending faster than this server reads): they never reached the
        controller, so nothing can answer them.  The kernel stamps its count on each datagram as it
        queues it, so drops show with the first datagram that arrives after them, once read."""
        return sum(self._dropped.values())

    def _drain_wake(self) -> None:
        assert self._wake_r is not None
        try:
            while self._wake_r.recv(4096):
                pass
        except (BlockingIOError, InterruptedError):
            pass

    def read_safety_socket(self) -> None:
        """(tick thread) Read what the kernel steered to the safety socket (at most
        :data:`SAFETY_READS_PER_CALL` datagrams, never waiting): a stop goes to the loop's
        safety lane now, anything else on to the server thread.  The tick calls it before it
        takes the safety lane and again before it writes the frame.  It never waits for the
        server thread: while that one reads the socket (it puts a stop in the safety lane the
        same way) the tick leaves it."""
        if self.safety_sock is None or not self._safety_lock.acquire(blocking=False):
            return
        try:
            self._read_safety(self._pass_on, SAFETY_READS_PER_CALL)
        finally:
            self._safety_lock.release()

    def _pass_on(self, seq: int, data: bytes, addr: Address) -> None:
        """(tick thread) A datagram from the safety socket that is not a stop: to the server
        thread, woken."""
        self._passed.append((seq, data, addr))
        try:
            assert self._wake_w is not None
            self._wake_w.send(b"w")
        except OSError:
            pass  # (full: the server thread is awake anyway)

    def _server_reads_safety(self) -> None:
        """(server thread, before it serves) Every ACK_HERE that arrived before what was just
        read is in effect: read the safety socket when it holds something, else wait out a
        read of the tick's that may be under way (the lock is held for microseconds)."""
        sock = self.safety_sock
        if sock is None:
            return
        ready = bool(select.select([sock], [], [], 0)[0])
        with self._safety_lock:
            if ready:
                self._read_safety(self._queue, DRAIN_MAX)

    def _read_safety(self, rest: Callable[[int, bytes, Address], None], limit: int) -> None:
        """(under the safety lock: one reader at a time, so an ACK_HERE is in effect before the
        stop read after it, whoever reads that) Read the safety socket (at most ``limit``
        datagrams); ``rest(seq, data, addr)`` takes what is not a stop."""
        assert self.safety_sock is not None
        for data, addr, seq in self._waiting(self.safety_sock, limit, "recvfrom (safety socket)"):
            self.steered += 1
            if not self._sorted_out(data, addr, seq):
                rest(seq, data, addr)

    def _take_in(self, data: bytes, addr: Address, seq: int | None = None) -> None:
        """A datagram just read (``seq``: its receive number, see :meth:`_recv`): the safety
        lane, its source's lane, or refused as busy."""
        self.read_main += 1
        if seq is None:
            seq = next(self._seqs)
        if not self._sorted_out(data, addr, seq):
            self._queue(seq, data, addr)

    def _sorted_out(self, data: bytes, addr: Address, seq: int) -> bool:
        """True when ``data`` was a safety command (now in the loop's safety lane); an
        ACK_HERE takes effect here, as it is read."""
        try:
            if len(data) <= SAFETY_MAX_BYTES:
                if self._safety(data, addr, seq):
                    return True
                self._ack_here_now(data, addr)
        except Exception:  # nothing a datagram contains may stop the server
            log.exception("safety check of a datagram from %s failed", addr)
        return False

    def _queue(self, seq: int, data: bytes, addr: Address) -> None:
        """(server thread) ``data`` waits in its source's lane, or is refused as busy."""
        lane = self._lanes.get(addr)
        if lane is None:
            lane = self._lanes[addr] = deque()
            self._turn.append(addr)
        if len(lane) >= self.max_waiting:
            self._shed(data, addr, len(lane))
        elif lane and lane[-1][0] > seq:
            # read from the safety socket after the datagrams that came after it (ACK_HERE):
            # its place is by receive order, so its reply comes before theirs
            at = next(i for i, (s, _) in enumerate(lane) if s > seq)
            lane.insert(at, (seq, data))
        else:
            lane.append((seq, data))

    def _safety(self, data: bytes, addr: Address, seq: int) -> bool:
        """ESTOP / STOP / DISABLE: to the loop's safety lane now (True); anything else False."""
        up = data.upper()
        if b"STOP" not in up and b"DISABLE" not in up:
            return False
        try:
            parsed = parse_datagram(data, self.model)
        except DatagramError:
            return False  # the worker answers it as invalid
        if not parsed.command.SAFETY:
            return False
        cid = parsed.command_id
        if cid is not None and not self._claim(cid, addr, f"{parsed.command.name} applied, but its ID",
                                               applied=True):
            cid = None  # a stop always works; the ID's owner hears nothing of it
        self.inbox.put_safety(Submission(parsed.command, cid, self._ack_addr(addr) if cid else None, addr, seq,
                                         client=str(self.client(addr))))
        self.safety_fast += 1
        return True

    def _ack_here_now(self, data: bytes, addr: Address) -> None:
        """ACK_HERE takes effect when it is read, like the safety commands: an ID'd STOP read
        in the same drain skips the queue, and its acks must already reach this socket (the
        datagram itself still waits its turn for its own ack)."""
        if b"ACK_HERE" not in data.upper():
            return
        try:
            parsed = parse_datagram(data, self.model)
        except DatagramError:
            return
        if isinstance(parsed.command, C.AckHere):
            self.ack_here(addr)  # a refusal is answered when the datagram is served

    def _shed(self, data: bytes, addr: Address, waiting: int) -> None:
        """Refuse a datagram of a source over its share, saying so where the protocol can."""
        self.shed += 1
        reason = (f"controller busy: {waiting} datagrams from {addr[0]}:{addr[1]} are waiting; "
                  "slow down and send again")
        head = data[:40].split(b"|", 1)[0].strip().decode("ascii", "replace")
        if is_command_id(head):
            if self._claim(head, addr, "the datagram"):
                self.busy_acks += 1
                self._ack(head, addr, AckStatus.FAILED, reason)
        elif _looks_like_query(data):
            self._reply(format_error(reason), addr)

    # ------------------------------------------------------------------ helpers

    def ack_here(self, addr: Address) -> str | None:
        """(ext ACK_HERE) acks of commands from ``addr`` also go to ``addr`` itself.  None when
        registered; else why not (the table is full: see
        :class:`~parolkit.controller.senders.KnownClients`)."""
        return self.known.admit(addr, time.monotonic(), self._pinned)

    def _pinned(self, addr: Address) -> bool:
        """A registered socket that must keep its place: the lease holder, or one whose
        commands are live."""
        holder = self.lease.holder
        return (holder is not None and holder.address == addr) or self.ids.has_live(addr)

    def client(self, addr: Address) -> ClientId:
        """Who sent a datagram from ``addr``: that socket (see
        :class:`~parolkit.controller.lease.ClientId`)."""
        return ClientId(addr[0], addr[1])

    def _ack_addr(self, addr: Address) -> AckRoute:
        """Where the acks of a command from ``addr`` go: the sender's host at the ack port (the
        original protocol), plus the sending socket itself if it asked with ACK_HERE."""
        primary = (addr[0], self.ack_port)
        if addr[1] != self.ack_port and addr in self.known:
            return (primary, (addr[0], addr[1]))
        return (primary,)

    def _claim(self, cid: str, addr: Address, what: str, *, applied: bool = False) -> bool:
        """``cid`` arrives from ``addr``: True when it is free or ``addr``'s own.  Another
        sender's ID (live or recent) is refused with an ``ERROR|`` reply to ``addr`` alone:
        no ack with that ID leaves, so nothing reaches its owner."""
        if self.ids.claim(cid, addr) is None:
            return True
        verb = "was not used" if applied else "refused"
        reason = (f"{what} {verb}: command ID {cid} belongs to another client's command; "
                  "every command needs a new random ID")
        self._reply(format_error(reason), addr)
        self._log_invalid(addr, reason)
        return False

    def _reply(self, text: str, addr: Address) -> None:
        try:
            self.sock.sendto(text.encode("utf-8"), addr)
        except OSError as exc:
            log.debug("reply to %s failed: %s", addr, exc)

    def _log_invalid(self, addr: Address, message: str) -> None:
        """Log an invalid datagram within LOG_BUDGET_BYTES_PER_S; what does not fit is counted
        and reported in one line when the next second's first invalid datagram comes."""
        now = time.monotonic()
        if now - self._log_window >= 1.0:
            if self._suppressed:
                log.warning("%d more invalid datagrams in the last second (not logged one by one: "
                            "the log takes at most %d bytes/s of them)", self._suppressed, LOG_BUDGET_BYTES_PER_S)
            self._log_window, self._log_bytes, self._suppressed = now, 0, 0
        line = f"invalid datagram from {addr[0]}:{addr[1]}: {message}"
        if self._log_bytes + len(line) <= LOG_BUDGET_BYTES_PER_S:
            self._log_bytes += len(line)
            log.warning("%s", line)
        else:
            self._suppressed += 1
            self.log_suppressed += 1

    def _ack(self, command_id: str | None, addr: Address, status: AckStatus, details: str = "") -> None:
        """An ack that reports nothing the status shows (queries, ACK_HERE, SUBSCRIBE, INVALID,
        busy): sent at once, from this thread."""
        if command_id is not None:
            text = format_ack(command_id, status, details)
            for a in self._ack_addr(addr):
                self._reply(text, a)
            self.ids.ended(command_id)

    # ------------------------------------------------------------------ dispatch

    def handle(self, data: bytes, addr: Address, seq: int = 0) -> None:
        """Handle one datagram from ``addr``, the ``seq``-th received (replies, acks,
        hand-off to the loop)."""
        try:
            parsed = parse_datagram(data, self.model)
        except DatagramError as exc:
            self.invalid += 1
            self._log_invalid(addr, str(exc))
            if exc.command_id is not None:
                if self._claim(exc.command_id, addr, "the datagram"):
                    self._ack(exc.command_id, addr, AckStatus.INVALID, str(exc))
            elif _looks_like_query(data):
                # (ext) an invalid query without an ID gets ERROR|details to the sender
                self._reply(format_error(str(exc)), addr)
            return
        cmd = parsed.command
        cid = parsed.command_id
        now = time.monotonic()
        self.known.heard(addr, now)
        if cid is not None and not self._claim(cid, addr, cmd.name):
            return
        if isinstance(cmd, C.AckHere):
            refusal = self.ack_here(addr)
            if refusal is not None:
                self.clients_refused += 1
                self._refuse(cid, addr, f"ACK_HERE refused: {refusal}")
                return
        who = self.client(addr)
        if cmd.KIND is C.CommandKind.QUERY:
            if cmd.name == "GET_CONTROL":
                reply = "CONTROL|" + C.dumps(self.lease.view(now, self.answerer.busy()))
            else:
                reply = self.answerer.answer_query(cmd.name, str(who))
            self._reply(reply, addr)
            self._ack(cid, addr, AckStatus.COMPLETED, f"{cmd.name} answered")
            return
        if isinstance(cmd, C.AckHere):
            self._ack(cid, addr, AckStatus.COMPLETED, "acks also go to this socket")
            return
        if isinstance(cmd, (C.Subscribe, C.Unsubscribe)):
            self._subscription(cmd, cid, addr, len(data), now)
            return
        if isinstance(cmd, C.Control):
            self._control(cmd, cid, addr, who, now)
            return
        if not cmd.OPEN:
            refusal = self.lease.check(who, now, self.answerer.busy(), registered=addr in self.known)
            if refusal is not None:
                self._refuse(cid, addr, f"{cmd.name} refused: {refusal}")
                return
        tool = None
        if isinstance(cmd, C.SetPort):
            if not is_loopback(addr[0]):
                self._refuse(cid, addr, f"SET_PORT is accepted only from this machine (loopback), "
                                        f"not from {addr[0]}: set serial.port in the config or --port")
                return
            try:
                resolve_url(cmd.port, allowed_schemes=SET_PORT_SCHEMES)
            except TransportURLError as exc:
                self._ack(cid, addr, AckStatus.INVALID, f"SET_PORT: {exc}")
                return
            if not os.path.exists(cmd.port):
                # (a fuzzed SET_PORT|None dropped a working link for a device that is not there)
                self._ack(cid, addr, AckStatus.FAILED,
                          f"SET_PORT: no device at {cmd.port!r}: the board link stays as it is")
                return
        if isinstance(cmd, C.SetTool):
            try:
                tool = self.answerer.resolve_tool(cmd.tool)
            except Exception as exc:
                self._ack(cid, addr, AckStatus.INVALID, f"SET_TOOL: {exc}")
                return
        route = self._ack_addr(addr) if cid is not None else None
        if cmd.SAFETY:
            self.inbox.put_safety(Submission(cmd, cid, route, addr, seq, client=str(who)))
        elif not self.inbox.put(Submission(cmd, cid, route, addr, seq, tool, self.answerer.plan_ahead(cmd),
                                           client=str(who))):
            self.busy_acks += 1 if cid is not None else 0
            self._ack(cid, addr, AckStatus.FAILED,
                      f"controller busy: {self.inbox.max_waiting} commands from {addr[0]}:{addr[1]} "
                      "wait for the control loop; slow down and send again")


    def _refuse(self, cid: str | None, addr: Address, reason: str) -> None:
        """A command this client may not send: FAILED ack with the reason (an ``ERROR|`` reply
        to the sender when it has no ID, so nothing is refused in silence)."""
        if cid is not None:
            self._ack(cid, addr, AckStatus.FAILED, reason)
        else:
            self._reply(format_error(reason), addr)
            self._log_invalid(addr, reason)

    def _subscription(self, cmd: C.Subscribe | C.Unsubscribe, cid: str | None, addr: Address,
                      size: int, now: float) -> None:
        """SUBSCRIBE / UNSUBSCRIBE: only for the socket that sends it, and SUBSCRIBE only once
        that socket echoed its cookie (the status stream is never sent to an address that did
        not ask: a forged source address cannot echo what is sent there).  Until it does, the
        answer is ``COOKIE|c`` alone, no longer than the datagram (``size`` bytes): a forged
        SUBSCRIBE makes the controller send no more than it received, and no ack."""
        if isinstance(cmd, C.Subscribe) and not self.cookies.valid(addr, cmd.cookie, now):
            challenge = C.format_cookie(self.cookies.issue(addr, now))
            if len(challenge) <= size:
                self._reply(challenge, addr)
            else:
                self._log_invalid(addr, f"SUBSCRIBE of {size} bytes not answered: its cookie answer "
                                        f"takes {len(challenge)}")
            if cid is not None:
                self.ids.ended(cid)
            return
        if cmd.port != addr[1]:
            self._refuse(cid, addr, f"{cmd.name} applies to the socket that sends it: send "
                                    f"{cmd.name}|{cmd.port} from port {cmd.port} (this came from port {addr[1]})")
            return
        if isinstance(cmd, C.Unsubscribe):
            self.stream.unsubscribe((addr[0], cmd.port))
            self._ack(cid, addr, AckStatus.COMPLETED, "unsubscribed")
            return
        err = self.stream.subscribe((addr[0], cmd.port), cmd.every_n_ticks)
        self._ack(cid, addr, *((AckStatus.FAILED, err) if err else (AckStatus.COMPLETED, "subscribed")))

    def _control(self, cmd: C.Control, cid: str | None, addr: Address, who: ClientId, now: float) -> None:
        """CONTROL|TAKE / CONTROL|RELEASE."""
        busy = self.answerer.busy()
        if cmd.action == "RELEASE":
            ok, text = self.lease.release(who, now, busy)
            self._ack(cid, addr, AckStatus.COMPLETED if ok else AckStatus.FAILED, text)
            return
        ok, text, prev = self.lease.take(who, now, force=cmd.force, secret=cmd.secret, busy=busy)
        if ok and prev is not None:
            # the previous holder's commands stop with the lease (the STOP lane: first frame)
            log.warning("%s", text)
            self.inbox.put_safety(Submission(C.Stop(reason=f"stopped: {text}"), None, None, addr,
                                             time.time_ns() if self.safety_sock is not None else self.received))
        self._ack(cid, addr, AckStatus.COMPLETED if ok else AckStatus.FAILED, text)
        if cid is None and not ok:
            self._reply(format_error(text), addr)


def _looks_like_query(data: bytes) -> bool:
    head = bytes(data[:16]).upper()
    return head.startswith(b"GET_") or head.startswith(b"PING")
