"""The commander's UDP link to the controller (docs/protocol.md), on asyncio.

Three sockets: one for commands and queries (replies come back to it), one bound to the
controller's ack port (acks of ID'd commands), one for the status stream (SUBSCRIBE, renewed
every :data:`RENEW_S`).  Keeps the newest :class:`RobotStatus`, a short history for the
plots, the active plan (``GET_PLAN`` whenever ``plan_seq`` changes) and logs every terminal
ack to the :class:`EventLog`.
"""

from __future__ import annotations

import asyncio
import json
import logging
import socket
import time
import uuid
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable

from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.gui.eventlog import EventLog, Level, level_of_ack
from parolkit.gui.status import RobotStatus, parse_status_datagram

__all__ = ["Ack", "Plan", "Sample", "ControllerLink", "new_command_id", "LinkError"]

log = logging.getLogger(__name__)

#: the controller drops a subscription after 10 s; renew well before
RENEW_S = 3.0
#: no status for this long = link down, s
LINK_TIMEOUT_S = 1.0
TERMINAL = frozenset({"COMPLETED", "FAILED", "CANCELLED", "INVALID"})


class LinkError(ParolkitError):
    """The controller did not answer (timeout) or answered with ERROR."""


def new_command_id() -> str:
    """An 8-character command ID (first 8 chars of a uuid4, with at least one lower-case letter)."""
    while True:
        cid = uuid.uuid4().hex[:8]
        if any(c.isalpha() for c in cid):
            return cid


@dataclass(frozen=True)
class Ack:
    """One acknowledgement: command ID, status and details."""

    id: str
    status: str
    details: str = ""

    @property
    def terminal(self) -> bool:
        return self.status in TERMINAL

    @classmethod
    def parse(cls, text: str) -> "Ack":
        parts = text.split("|", 3)
        if len(parts) < 3 or parts[0].upper() != "ACK":
            raise ParolkitValueError(f"expected 'ACK|ID|STATUS|details', got {text[:60]!r}")
        return cls(parts[1], parts[2].upper(), parts[3] if len(parts) > 3 else "")


@dataclass(frozen=True)
class Plan:
    """The active motion's plan: target joints (deg) and TCP path (mm), either may be empty."""

    seq: int
    command: str | None
    target_angles: tuple[float, ...] | None
    tcp_path: tuple[tuple[float, float, float], ...]

    @classmethod
    def parse(cls, text: str) -> "Plan":
        head, _, payload = text.partition("|")
        if head.upper() != "PLAN":
            raise ParolkitValueError(f"expected 'PLAN|{{...}}', got {text[:60]!r}")
        obj = json.loads(payload)
        target = obj.get("target_angles")
        path = obj.get("tcp_path") or []
        return cls(
            seq=int(obj.get("seq") or 0),
            command=obj.get("command"),
            target_angles=tuple(float(v) for v in target) if target else None,
            tcp_path=tuple((float(p[0]), float(p[1]), float(p[2])) for p in path),
        )


@dataclass(frozen=True)
class Sample:
    """One plot sample: monotonic time (s), joint angles (deg), joint speeds (deg/s)."""

    t: float
    angles: tuple[float, ...]
    speeds: tuple[float, ...]


class _Receiver(asyncio.DatagramProtocol):
    def __init__(self, handler: Callable[[bytes, Any], None]) -> None:
        self.handler = handler

    def datagram_received(self, data: bytes, addr: Any) -> None:  # noqa: D401
        try:
            self.handler(data, addr)
        except Exception:  # one bad datagram must not kill the link
            log.exception("bad datagram from %s", addr)

    def error_received(self, exc: Exception) -> None:
        log.debug("UDP error: %s", exc)


class ControllerLink:
    """UDP link to one controller at ``host:port``.

    Acks come back to the link's own command socket: it registers that socket with the
    controller's (ext) ``ACK_HERE`` command (renewed with every status subscription, so a
    restarted controller learns it again).  ``ack_port`` is the controller's fixed ack port,
    kept for information; the link does not occupy it, so scripts and the program runner can.
    """

    def __init__(self, host: str, port: int, ack_port: int, *, every_n_ticks: int = 3,
                 event_log: EventLog | None = None, history_s: float = 30.0) -> None:
        self.host, self.port, self.ack_port = host, int(port), int(ack_port)
        self.every_n_ticks = every_n_ticks
        self.log = event_log or EventLog()
        self.status: RobotStatus | None = None
        self.status_monotonic = 0.0
        self.history: deque[Sample] = deque()
        self.history_s = history_s
        self.plan: Plan | None = None
        self.acks: dict[str, Ack] = {}
        self._labels: dict[str, str] = {}
        self._quiet: set[str] = set()
        self._waiters: dict[str, asyncio.Future] = {}
        self._query_lock = asyncio.Lock()
        self._reply: asyncio.Future | None = None
        self._cmd: asyncio.DatagramTransport | None = None
        self._status_tr: asyncio.DatagramTransport | None = None
        self._tasks: list[asyncio.Task] = []
        self._plan_seq_seen: int | None = None
        self._was_up = False
        self._last_error: str | None = None
        self._listeners: list[Callable[[RobotStatus], None]] = []
        self.status_count = 0

    # ---- lifecycle ----

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        local = "127.0.0.1" if self.host in ("127.0.0.1", "localhost") else "0.0.0.0"
        # commands go out through the plain socket (a UDP send on it never blocks for long and
        # an error is reported, not latched); the transport only reads replies from it
        self._cmd_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._cmd_sock.bind((local, 0))
        self._cmd_sock.setblocking(False)
        self._cmd, _ = await loop.create_datagram_endpoint(lambda: _Receiver(self._on_reply), sock=self._cmd_sock)
        self._status_tr, _ = await loop.create_datagram_endpoint(
            lambda: _Receiver(self._on_status), local_addr=(local, 0))
        self._raw_send("ACK_HERE")  # acks of our commands come back to the command socket
        self._tasks.append(asyncio.create_task(self._subscription_loop()))
        self.log.info(f"connecting to controller at {self.host}:{self.port}")

    async def close(self) -> None:
        for t in self._tasks:
            t.cancel()
        for t in self._tasks:
            try:
                await t
            except (asyncio.CancelledError, Exception):
                pass
        self._tasks.clear()
        if self._cmd is not None and self._status_tr is not None:
            port = self._status_tr.get_extra_info("sockname")[1]
            try:
                self._raw_send(f"UNSUBSCRIBE|{port}")
            except LinkError:
                pass
        for tr in (self._cmd, self._status_tr):
            if tr is not None:
                tr.close()

    async def _subscription_loop(self) -> None:
        assert self._status_tr is not None
        port = self._status_tr.get_extra_info("sockname")[1]
        while True:
            try:
                self._raw_send(f"SUBSCRIBE|{port}|{self.every_n_ticks}")
                self._raw_send("ACK_HERE")
            except LinkError as exc:
                log.warning("subscribe failed: %s", exc)
            # check quickly until the first status arrives, then renew every RENEW_S
            for _ in range(int(RENEW_S / 0.25)):
                await asyncio.sleep(0.25)
                self._check_link()
                if not self.link_up:
                    break

    def _check_link(self) -> None:
        up = self.link_up
        if up != self._was_up:
            self._was_up = up
            if up:
                self.log.add(f"controller link up ({self.host}:{self.port})", Level.SUCCESS)
            else:
                self.log.add("controller link lost: no status for 1 s", Level.ERROR)

    # ---- receiving ----

    def _on_reply(self, data: bytes, addr: Any) -> None:
        text = data.decode("utf-8", errors="replace")
        if text.upper().startswith("ACK|"):  # acks come here (ACK_HERE)
            self._on_ack(data, addr)
            return
        if text.upper().startswith("STATUS_JSON|") and (self._reply is None or self._reply.done()):
            self._on_status(data, addr)
            return
        if self._reply is not None and not self._reply.done():
            self._reply.set_result(text)
        elif text.upper().startswith("ERROR|"):
            self.log.error(f"controller: {text[6:]}")

    def _on_status(self, data: bytes, addr: Any) -> None:
        try:
            status = parse_status_datagram(data.decode("utf-8", errors="replace"))
        except ParolkitValueError as exc:
            if str(exc) != self._last_error:
                self._last_error = str(exc)
                self.log.error(f"bad status datagram: {exc}")
            return
        prev = self.status
        self.status = status
        self.status_monotonic = time.monotonic()
        self.status_count += 1
        self.history.append(Sample(self.status_monotonic, status.angles, status.speeds_deg_s))
        cutoff = self.status_monotonic - self.history_s
        while self.history and self.history[0].t < cutoff:
            self.history.popleft()
        self._log_transitions(prev, status)
        if status.plan_seq != self._plan_seq_seen:
            self._plan_seq_seen = status.plan_seq
            self._tasks.append(asyncio.ensure_future(self._fetch_plan()))
            self._tasks = [t for t in self._tasks if not t.done()]
        for listener in list(self._listeners):
            listener(status)

    def _log_transitions(self, prev: RobotStatus | None, new: RobotStatus) -> None:
        if prev is None:
            self.log.info(f"state {new.state.value}, {'simulated board' if new.board.simulated else new.board.port}")
            return
        if new.estop_latched and not prev.estop_latched:
            self.log.error("E-STOP latched: press Enable after releasing it")
        elif prev.estop_latched and not new.estop_latched:
            self.log.add("E-stop latch cleared", Level.SUCCESS)
        if new.errors.message and new.errors.message != prev.errors.message:
            self.log.error(f"robot error: {new.errors.message}")
        for name, bits, pbits in (("temperature", new.errors.temperature, prev.errors.temperature),
                                  ("position", new.errors.position, prev.errors.position)):
            for j, (b, pb) in enumerate(zip(bits, pbits)):
                if b and not pb:
                    self.log.error(f"J{j + 1} {name} error")
        # IDLE <-> MOVING is the normal rhythm of every move and jog: not worth a log line
        routine = {prev.state.value, new.state.value} <= {"IDLE", "MOVING"}
        if new.state != prev.state and not routine:
            self.log.info(f"state {prev.state.value} -> {new.state.value}")

    def _on_ack(self, data: bytes, addr: Any) -> None:
        try:
            ack = Ack.parse(data.decode("utf-8", errors="replace"))
        except ParolkitValueError:
            return
        if ack.id not in self._labels:
            return  # somebody else's command (another client on this machine)
        if not ack.terminal or ack.id not in self._quiet:
            self.acks[ack.id] = ack
        if ack.terminal:
            label = self._labels.pop(ack.id, ack.id)
            detail = f": {ack.details}" if ack.details else ""
            quiet = ack.id in self._quiet
            self._quiet.discard(ack.id)
            if not quiet or level_of_ack(ack.status) is Level.ERROR:
                self.log.add(f"{label} {ack.status.lower()}{detail}", level_of_ack(ack.status))
            fut = self._waiters.pop(ack.id, None)
            if fut is not None and not fut.done():
                fut.set_result(ack)

    async def _fetch_plan(self) -> None:
        try:
            reply = await self.query("GET_PLAN", timeout=1.0)
            self.plan = Plan.parse(reply)
        except (LinkError, ParolkitValueError, ValueError, KeyError, TypeError) as exc:
            self.plan = None
            log.debug("GET_PLAN failed: %s", exc)

    # ---- sending ----

    @property
    def link_up(self) -> bool:
        return self.status is not None and time.monotonic() - self.status_monotonic < LINK_TIMEOUT_S

    def add_listener(self, listener: Callable[[RobotStatus], None]) -> None:
        self._listeners.append(listener)

    def remove_listener(self, listener: Callable[[RobotStatus], None]) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def _raw_send(self, text: str) -> None:
        if self._cmd is None:
            raise LinkError("link not started")
        try:
            self._cmd_sock.sendto(text.encode("utf-8"), (self.host, self.port))
        except OSError as exc:  # e.g. a full socket buffer on a stalled machine
            raise LinkError(f"cannot send {text.split('|', 1)[0]} to {self.host}:{self.port}: {exc}") from exc

    def send(self, text: str, *, label: str | None = None, track: bool = True, quiet: bool = False) -> str | None:
        """Send one command. With ``track`` it gets an ID and its terminal ack is logged
        (labelled ``label``; with ``quiet`` only FAILED / INVALID acks are logged); returns
        the ID (None when untracked)."""
        if not track:
            self._raw_send(text)
            return None
        cid = new_command_id()
        self._labels[cid] = label or text.split("|", 1)[0]
        if quiet:
            self._quiet.add(cid)
        self._raw_send(f"{cid}|{text}")
        return cid

    async def send_wait(self, text: str, *, label: str | None = None, timeout: float = 60.0) -> Ack:
        """Send a tracked command and wait for its terminal ack."""
        loop = asyncio.get_running_loop()
        fut: asyncio.Future = loop.create_future()
        cid = self.send(text, label=label)
        if cid is None:
            raise LinkError("internal: a tracked command got no ID")
        self._waiters[cid] = fut
        try:
            return await asyncio.wait_for(fut, timeout)
        except asyncio.TimeoutError:
            self._waiters.pop(cid, None)
            raise LinkError(f"{label or text.split('|', 1)[0]}: no terminal ack within {timeout:g} s") from None

    async def query(self, text: str, timeout: float = 1.0) -> str:
        """Send a query and return the reply text; raises LinkError on timeout or ERROR."""
        async with self._query_lock:
            self._reply = asyncio.get_running_loop().create_future()
            self._raw_send(text)
            try:
                reply = await asyncio.wait_for(self._reply, timeout)
            except asyncio.TimeoutError:
                raise LinkError(f"{text.split('|', 1)[0]}: no reply within {timeout:g} s") from None
            finally:
                self._reply = None
        if reply.upper().startswith("ERROR|"):
            raise LinkError(f"controller: {reply[6:]}")
        return reply
