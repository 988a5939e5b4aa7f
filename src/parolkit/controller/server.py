"""UDP side of the controller: the command socket thread, the outbox and the status stream.

* :class:`UdpServer` receives datagrams, parses them (:mod:`parolkit.protocol.commands`),
  answers queries at once from the latest snapshot, applies immediate commands and queues the
  rest.  Nothing a datagram contains can raise out of :meth:`UdpServer.handle`.
* :class:`Outbox` sends acks in order from one thread (the loop never blocks on a socket).
* :class:`StatusStream` sends ``STATUS_JSON|{...}`` to subscribers every N ticks.
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from dataclasses import dataclass
from queue import Empty, SimpleQueue
from typing import TYPE_CHECKING

from parolkit.protocol import commands as C
from parolkit.protocol.commands import AckStatus, DatagramError, format_ack, format_error, parse_datagram

if TYPE_CHECKING:  # pragma: no cover
    from parolkit.controller.app import Controller

__all__ = ["Outbox", "StatusStream", "UdpServer", "SUBSCRIPTION_TTL_S", "MAX_SUBSCRIBERS"]

log = logging.getLogger("parolkit.controller")

#: a subscription lapses this long after the last SUBSCRIBE, s
SUBSCRIPTION_TTL_S = 10.0
MAX_SUBSCRIBERS = 16


#: a UDP (host, port) pair
Address = tuple[str, int]


class Outbox:
    """Sends datagrams (acks) in FIFO order from its own thread.

    :meth:`hold` / :meth:`release` (nestable, from any thread) keep what is put in between
    back until the last release, in order: the controller holds its acks until the status
    snapshot shows what they report, so a query sent after an ack never reads an older state.
    """

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self._q: SimpleQueue[tuple[bytes, tuple[str, int]] | None] = SimpleQueue()
        self._hold_lock = threading.Lock()
        self._holds = 0
        self._held: list[tuple[bytes, tuple[str, int]]] = []
        self._thread = threading.Thread(target=self._run, name="parolkit-outbox", daemon=True)
        self.sent = 0
        self.errors = 0

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._q.put(None)
        self._thread.join(2.0)

    def put(self, text: str, addr: "Address | tuple[Address, ...]") -> None:
        """Queue ``text`` for one address or for each of a tuple of addresses (an ack route)."""
        data = text.encode("utf-8")
        items = [(data, a) for a in addr] if addr and isinstance(addr[0], tuple) else [(data, addr)]
        with self._hold_lock:
            if self._holds:
                self._held.extend(items)  # type: ignore[arg-type]
                return
            for item in items:
                self._q.put(item)  # type: ignore[arg-type]

    def hold(self) -> None:
        """Keep datagrams back until the matching :meth:`release`."""
        with self._hold_lock:
            self._holds += 1

    def release(self) -> None:
        """End one :meth:`hold`; the last one sends everything held, in order."""
        with self._hold_lock:
            if self._holds == 0:
                return
            self._holds -= 1
            if self._holds == 0:
                for item in self._held:
                    self._q.put(item)
                self._held.clear()

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
    """Status datagrams to subscribers, woken by the loop every tick."""

    def __init__(self, sock: socket.socket, controller: "Controller") -> None:
        self.sock = sock
        self.controller = controller
        self._subs: dict[tuple[str, int], _Subscriber] = {}
        self._lock = threading.Lock()
        self._cv = threading.Condition()
        self._tick = 0
        self._running = False
        self._thread = threading.Thread(target=self._run, name="parolkit-stream", daemon=True)
        self.sent = 0

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

    def notify(self, tick: int) -> None:
        """Loop thread: a new snapshot exists (cheap when nobody subscribed)."""
        if not self._subs:
            return
        with self._cv:
            self._tick = tick
            self._cv.notify()

    def _run(self) -> None:
        last = -1
        while True:
            with self._cv:
                while self._running and self._tick == last:
                    self._cv.wait(0.5)
                if not self._running:
                    return
                tick = self._tick
            last = tick
            now = time.monotonic()
            with self._lock:
                due = []
                for k in list(self._subs):
                    s = self._subs[k]
                    if s.expires < now:
                        del self._subs[k]
                    elif tick % s.every == 0:
                        due.append(s.addr)
            if not due:
                continue
            try:
                data = self.controller.snapshot.reply_status_json().encode()
            except Exception:
                log.exception("status stream: building the status failed")
                continue
            for addr in due:
                try:
                    self.sock.sendto(data, addr)
                    self.sent += 1
                except OSError:
                    pass


class UdpServer:
    """The command socket and its thread."""

    #: at most this many ACK_HERE sockets are remembered
    MAX_ACK_HERE = 256

    def __init__(self, controller: "Controller", sock: socket.socket, ack_port: int) -> None:
        self.c = controller
        self.sock = sock
        self.ack_port = ack_port
        #: sockets that asked for their acks (ACK_HERE), oldest first
        self._ack_here: dict[Address, None] = {}
        self._ack_here_lock = threading.Lock()
        self._running = False
        self._thread = threading.Thread(target=self._run, name="parolkit-udp", daemon=True)
        self.received = 0
        self.invalid = 0
        self._log_window = 0.0
        self._log_count = 0
        self._suppressed = 0

    def start(self) -> None:
        self._running = True
        self._thread.start()

    def stop(self) -> None:
        self._running = False
        self._thread.join(2.0)

    def _run(self) -> None:
        self.sock.settimeout(0.2)
        while self._running:
            try:
                data, addr = self.sock.recvfrom(65535)
            except socket.timeout:
                continue
            except OSError as exc:
                if not self._running:
                    return
                # e.g. ICMP port unreachable reported on Linux: ignore and go on
                log.debug("recvfrom: %s", exc)
                continue
            self.received += 1
            try:
                self.handle(data, addr)
            except Exception:  # nothing a datagram contains may stop the server
                log.exception("handling a datagram from %s failed", addr)

    # ------------------------------------------------------------------ helpers

    def ack_here(self, addr: Address) -> None:
        """(ext ACK_HERE) acks of commands from ``addr`` also go to ``addr`` itself."""
        with self._ack_here_lock:
            self._ack_here.pop(addr, None)
            self._ack_here[addr] = None
            while len(self._ack_here) > self.MAX_ACK_HERE:  # bounded: oldest forgotten first
                self._ack_here.pop(next(iter(self._ack_here)))

    def _ack_addr(self, addr: Address) -> tuple[Address, ...]:
        """Where the acks of a command from ``addr`` go: the sender's host at the ack port (the
        original protocol), plus the sending socket itself if it asked with ACK_HERE."""
        primary = (addr[0], self.ack_port)
        if addr[1] != self.ack_port and addr in self._ack_here:
            return (primary, (addr[0], addr[1]))
        return (primary,)

    def _reply(self, text: str, addr: tuple[str, int]) -> None:
        try:
            self.sock.sendto(text.encode("utf-8"), addr)
        except OSError as exc:
            log.debug("reply to %s failed: %s", addr, exc)

    def _log_invalid(self, addr: tuple[str, int], message: str) -> None:
        now = time.monotonic()
        if now - self._log_window >= 1.0:
            if self._suppressed:
                log.warning("%d more invalid datagrams in the last second (not logged one by one)",
                            self._suppressed)
            self._log_window, self._log_count, self._suppressed = now, 0, 0
        if self._log_count < 20:
            self._log_count += 1
            log.warning("invalid datagram from %s:%s: %s", addr[0], addr[1], message)
        else:
            self._suppressed += 1

    def _immediate_ack(self, command_id: str | None, addr: tuple[str, int], status: AckStatus,
                       details: str = "") -> None:
        if command_id is not None:
            self.c.outbox.put(format_ack(command_id, status, details), self._ack_addr(addr))

    # ------------------------------------------------------------------ dispatch

    def handle(self, data: bytes, addr: tuple[str, int]) -> None:
        """Handle one datagram from ``addr`` (replies, acks, queueing)."""
        c = self.c
        try:
            parsed = parse_datagram(data, c.config.robot)
        except DatagramError as exc:
            self.invalid += 1
            self._log_invalid(addr, str(exc))
            if exc.command_id is not None:
                self.c.outbox.put(format_ack(exc.command_id, AckStatus.INVALID, str(exc)), self._ack_addr(addr))
            elif _looks_like_query(data):
                # (ext) an invalid query without an ID gets ERROR|details to the sender
                self._reply(format_error(str(exc)), addr)
            return
        cmd = parsed.command
        cid = parsed.command_id
        if cmd.KIND is C.CommandKind.QUERY:
            self._reply(c.answer_query(cmd.name), addr)  # type: ignore[arg-type]
            self._immediate_ack(cid, addr, AckStatus.COMPLETED)
            return
        if isinstance(cmd, C.AckHere):
            self.ack_here(addr)
            self._immediate_ack(cid, addr, AckStatus.COMPLETED, "acks also go to this socket")
            return
        # the acks wait for a snapshot that shows the change they report (Outbox.hold)
        c.outbox.hold()
        try:
            if cmd.KIND is C.CommandKind.IMMEDIATE:
                status, details = c.immediate(cmd, addr)
                self._immediate_ack(cid, addr, status, details)
            else:
                job = c.executor.new_job(cmd, cid, self._ack_addr(addr) if cid is not None else None)
                c.executor.submit(job)
            c.publish()
        finally:
            c.outbox.release()


def _looks_like_query(data: bytes) -> bool:
    head = bytes(data[:16]).upper()
    return head.startswith(b"GET_") or head.startswith(b"PING")
