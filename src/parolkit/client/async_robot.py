"""``parolkit.AsyncRobot``: the asyncio twin of :class:`parolkit.Robot`.

Same method names and arguments (see :class:`parolkit.client.core.RobotCommands`); every
command and query returns a coroutine (:data:`~parolkit.client.core.AsyncResult`) of what
:class:`parolkit.Robot` returns (an :class:`AsyncCommandHandle` for ``wait=False``)::

    import asyncio
    from parolkit import AsyncRobot

    async def main():
        async with AsyncRobot() as robot:
            await robot.move_joints([90, -90, 160, 12, 12, 180], duration=2)
            print(await robot.angles())
            async with robot.subscribe(every_n=10) as stream:
                async for status in stream:
                    print(status.state, status.angles)
                    break

    asyncio.run(main())

Arguments are checked when the method is called (a bad value raises
``ParolkitValueError`` before anything is awaited or sent).  One datagram endpoint carries
commands, queries, replies and acks (``ack_port=0``: ephemeral).

For applications that drive the robot from an event loop (the browser commander does):

* :meth:`AsyncRobot.send_nowait` sends an already built command body with a fresh ID and
  returns its :class:`AsyncCommandHandle` at once, without waiting for any ack;
* :meth:`AsyncRobot.add_ack_listener` calls a function with the :class:`AckRecord` of every
  ack of our commands as it arrives;
* :meth:`AsyncRobot.register_for_acks` (re)sends the (ext) ``ACK_HERE`` registration; a
  status subscription repeats it with every renewal, so a restarted controller sends our
  acks to this socket again.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import time
from collections.abc import AsyncIterator, Callable
from typing import Literal, TypeVar, overload

from parolkit.client import robot_api as wire
from parolkit.client.core import (
    DEFAULT_TIMEOUT_S,
    SUBSCRIBE_RENEW_S,
    AckBook,
    AckRecord,
    AckStatus,
    AsyncResult,
    CommandResult,
    Queries,
    QuerySpec,
    RobotCommands,
    RobotStatus,
    _check,
    _opt_timeout,
    bind_address,
    check_port,
    parse_query_reply,
)
from parolkit.client.errors import CommandNotCompleted, CommandTimeout, ControllerUnreachable, RobotError
from parolkit.errors import ParolkitValueError

__all__ = ["AsyncRobot", "AsyncCommandHandle", "AsyncStatusSubscription"]

log = logging.getLogger(__name__)

_T = TypeVar("_T")


class _Protocol(asyncio.DatagramProtocol):
    def __init__(self, owner: AsyncRobot) -> None:
        self.owner = owner

    def datagram_received(self, data: bytes, addr: object) -> None:
        try:
            self.owner._on_datagram(data.decode("utf-8", "replace"))
        except Exception:  # one bad datagram (or listener) must never stop the endpoint
            log.exception("datagram from %s could not be handled", addr)

    def error_received(self, exc: Exception) -> None:  # ICMP unreachable etc.: keep going
        pass


class AsyncCommandHandle:
    """A command sent with ``wait=False``: ``id``, ``command``, ``status()``, ``await result()``."""

    def __init__(self, robot: AsyncRobot, record: AckRecord) -> None:
        self._robot = robot
        self._record = record

    @property
    def id(self) -> str:
        return self._record.id

    @property
    def command(self) -> str:
        return self._record.command

    def status(self) -> AckStatus | None:
        latest = self._record.latest
        return None if latest is None else latest[0]

    def done(self) -> bool:
        return self._record.terminal is not None

    @overload
    async def result(self, timeout: float | None = None, *,
                     raise_on_error: Literal[True] = True) -> CommandResult: ...
    @overload
    async def result(self, timeout: float | None = None, *,
                     raise_on_error: bool) -> CommandResult | CommandNotCompleted: ...

    async def result(self, timeout: float | None = None, *,
                     raise_on_error: bool = True) -> CommandResult | CommandNotCompleted:
        """Wait for the terminal ack and return the COMPLETED :class:`CommandResult`; a failure
        raises like a waiting call (:class:`~parolkit.client.errors.CommandNotCompleted`), or
        is returned with ``raise_on_error=False``."""
        try:
            return await self._robot._wait_terminal(self._record, timeout)
        except CommandNotCompleted as exc:
            if raise_on_error:
                raise
            return exc

    def __repr__(self) -> str:
        return f"<AsyncCommandHandle {self.command} id={self.id} status={self.status()}>"


class _StreamProtocol(asyncio.DatagramProtocol):
    def __init__(self, queue: asyncio.Queue[str | None], on_cookie: Callable[[str], None]) -> None:
        self.queue = queue
        self.on_cookie = on_cookie

    def datagram_received(self, data: bytes, addr: object) -> None:
        text = data.decode("utf-8", "replace")
        if text.startswith("STATUS_JSON|"):
            if self.queue.full():  # a slow consumer sees the newest statuses, never a backlog
                self.queue.get_nowait()
            self.queue.put_nowait(text)
            return
        cookie = wire.parse_cookie(text)
        if cookie is not None:
            self.on_cookie(cookie)

    def error_received(self, exc: Exception) -> None:
        pass


class AsyncStatusSubscription:
    """Async iterator of :class:`RobotStatus` from the SUBSCRIBE stream (renewed every 3 s).

    ``async with robot.subscribe(...) as stream: async for status in stream: ...``
    Iteration raises :class:`ControllerUnreachable` after ``timeout`` s without a status
    and :class:`~parolkit.client.errors.ReplyError` for a malformed status datagram; both
    leave the subscription usable (call ``next()`` again).  At most ``buffer`` statuses are
    buffered; older ones are dropped for a slow consumer.  Every renewal also repeats the
    robot's ``ACK_HERE`` registration (:meth:`AsyncRobot.register_for_acks`).  The controller
    starts the stream once this socket echoed its cookie: a ``COOKIE|`` answer is answered at
    once with SUBSCRIBE and the cookie.
    """

    def __init__(self, robot: AsyncRobot, every_n: int, timeout: float, buffer: int = 64) -> None:
        self._robot = robot
        self._every_n = every_n
        self._timeout = timeout
        self._queue: asyncio.Queue[str | None] = asyncio.Queue(maxsize=buffer)
        self._transport: asyncio.DatagramTransport | None = None
        self._renewer: asyncio.Task[None] | None = None
        self.port: int | None = None
        self._cookie: str | None = None
        self.received = 0
        self._closed = False

    async def start(self) -> AsyncStatusSubscription:
        await self._robot._ensure_open()
        loop = asyncio.get_running_loop()
        self._transport, _ = await loop.create_datagram_endpoint(
            lambda: _StreamProtocol(self._queue, self._on_cookie),
            local_addr=(bind_address(self._robot.host), 0),
            remote_addr=(self._robot.host, self._robot.port), family=socket.AF_INET)
        self.port = self._transport.get_extra_info("sockname")[1]
        self.renew()
        self._renewer = asyncio.ensure_future(self._renew_loop())
        return self

    def renew(self) -> None:
        """Send ``SUBSCRIBE`` (and ``ACK_HERE``) now; done every :data:`SUBSCRIBE_RENEW_S` s
        anyway.  Call it to pick up a restarted controller sooner.  Send errors are ignored
        (the next renewal retries)."""
        if self._closed or self.port is None:
            return
        try:
            # from this socket: the controller streams only to the socket that asks
            if self._transport is not None:
                self._transport.sendto(
                    wire.build_subscribe(self.port, self._every_n, self._cookie).encode("utf-8"))
            self._robot.register_for_acks()
        except (OSError, RobotError):
            pass

    def _on_cookie(self, cookie: str) -> None:
        self._cookie = cookie
        self.renew()

    async def _renew_loop(self) -> None:
        while not self._closed:
            await asyncio.sleep(SUBSCRIBE_RENEW_S)
            self.renew()

    async def next(self, timeout: float | None = None) -> RobotStatus:
        """The next status (waits up to ``timeout`` s, default the subscription's); raises
        ``StopAsyncIteration`` once the subscription is closed."""
        if self._closed:
            raise StopAsyncIteration
        if self._transport is None:
            await self.start()
        wait = self._timeout if timeout is None else timeout
        try:
            text = await asyncio.wait_for(self._queue.get(), wait)
        except TimeoutError:
            raise ControllerUnreachable(
                f"no status from {self._robot.host}:{self._robot.port} within {wait:g} s "
                "(is the controller running?)") from None
        if text is None:  # close() was called while we waited
            raise StopAsyncIteration
        self.received += 1
        return parse_query_reply(Queries.status, text)

    def __aiter__(self) -> AsyncIterator[RobotStatus]:
        return self

    async def __anext__(self) -> RobotStatus:
        if self._closed:
            raise StopAsyncIteration
        return await self.next()

    async def close(self) -> None:
        """Unsubscribe and close (idempotent)."""
        if self._closed:
            return
        self._closed = True
        if self._renewer is not None:
            self._renewer.cancel()
        if self.port is not None:
            try:
                if self._transport is not None:
                    self._transport.sendto(wire.build_unsubscribe(self.port).encode("utf-8"))
            except OSError:
                pass
        if self._transport is not None:
            self._transport.close()
        if self._queue.full():
            self._queue.get_nowait()
        self._queue.put_nowait(None)  # wakes a consumer waiting in next()

    async def __aenter__(self) -> AsyncStatusSubscription:
        if self._transport is None:
            await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()


class AsyncRobot(RobotCommands[AsyncResult[CommandResult], AsyncResult[AsyncCommandHandle]]):
    """asyncio client of the parolkit controller (same API as :class:`parolkit.Robot`).

    The endpoint opens on first use (or ``await robot.open()`` / ``async with``) in the
    running event loop; use one AsyncRobot per event loop.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 5001, ack_port: int = 0,
                 timeout: float = DEFAULT_TIMEOUT_S) -> None:
        if not isinstance(host, str) or not host:
            raise ParolkitValueError(f"host must be a host name or address, got {host!r}")
        check_port(port, "port", 1)
        check_port(ack_port, "ack_port", 0)
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or timeout <= 0:
            raise ParolkitValueError(f"timeout must be a number of seconds > 0, got {timeout!r}")
        self.host = host
        self.port = port
        self.timeout = float(timeout)
        self._requested_ack_port = ack_port
        self.ack_port: int | None = None
        self._transport: asyncio.DatagramTransport | None = None
        self._acks = AckBook()
        self._first: dict[str, asyncio.Future[None]] = {}
        self._final: dict[str, asyncio.Future[None]] = {}
        self._pending_reply: tuple[str, asyncio.Future[str]] | None = None  # (tag, future)
        self._query_lock: asyncio.Lock | None = None
        self._open_lock: asyncio.Lock | None = None
        self._last_heard = 0.0
        self._closed = False
        self._ack_listeners: list[Callable[[AckRecord], None]] = []

    # ---- plumbing ----
    async def open(self) -> AsyncRobot:
        """Open the datagram endpoint (idempotent)."""
        await self._ensure_open()
        return self

    async def _ensure_open(self) -> None:
        if self._transport is not None:
            return
        if self._closed:
            raise RobotError("this AsyncRobot is closed")
        if self._open_lock is None:
            self._open_lock = asyncio.Lock()
            self._query_lock = asyncio.Lock()
        async with self._open_lock:
            if self._transport is not None:
                return
            loop = asyncio.get_running_loop()
            try:
                transport, _ = await loop.create_datagram_endpoint(
                    lambda: _Protocol(self),
                    local_addr=(bind_address(self.host), self._requested_ack_port),
                    # connected: only the controller's datagrams arrive (no forged acks)
                    remote_addr=(self.host, self.port), family=socket.AF_INET)
            except OSError as exc:
                raise RobotError(
                    f"cannot bind UDP port {self._requested_ack_port} for acknowledgements: "
                    f"{exc.strerror}; use ack_port=0 for an ephemeral port") from None
            self._transport = transport
            self.ack_port = transport.get_extra_info("sockname")[1]
            self.register_for_acks()

    @property
    def is_open(self) -> bool:
        """True between :meth:`open` and :meth:`close`."""
        return self._transport is not None and not self._closed

    def register_for_acks(self) -> None:
        """(ext) Send ``ACK_HERE``: the controller then sends the acks of the commands we send
        to this client's socket (besides its fixed ack port).  Sent on open and with every
        status-subscription renewal; call it again after a controller restart otherwise."""
        self._send("ACK_HERE")

    def add_ack_listener(self, listener: Callable[[AckRecord], None]) -> None:
        """Call ``listener(record)`` for every new ack of a command we sent (``record.latest``
        is the (AckStatus, details) just received; ``record.terminal`` is set by the last).
        It runs in the event loop; an exception it raises is logged, not propagated."""
        self._ack_listeners.append(listener)

    def remove_ack_listener(self, listener: Callable[[AckRecord], None]) -> None:
        """Stop calling ``listener`` (no error if it was not registered)."""
        if listener in self._ack_listeners:
            self._ack_listeners.remove(listener)

    def send_nowait(self, body: str) -> AsyncCommandHandle:
        """Send an already built command body (``JOG|...``, ``robot_api.build_*`` output) with
        a fresh command ID and return its handle at once, without waiting for any ack.

        For streams of commands (jogging) and user interfaces; acks arrive at the handle and
        at the ack listeners.  The robot must be open (``await robot.open()``); raises
        :class:`RobotError` otherwise."""
        if not isinstance(body, str) or not body.strip() or "\n" in body:
            raise ParolkitValueError(f"body must be one non-empty command line, got {body!r}")
        record, text = self._acks.new(body)
        self._send(text)
        return AsyncCommandHandle(self, record)

    def _send(self, text: str) -> None:
        if self._transport is None or self._closed:
            raise RobotError("this AsyncRobot is not open (closed, or not used inside its event loop)")
        try:
            self._transport.sendto(text.encode("utf-8"))
        except OSError as exc:
            raise ControllerUnreachable(
                f"cannot send to {self.host}:{self.port}: {exc.strerror or exc}") from None

    def _on_datagram(self, text: str) -> None:
        self._last_heard = time.monotonic()
        if text.startswith("ACK|"):
            rec = self._acks.on_datagram(text)
            if rec is None:
                return
            for listener in list(self._ack_listeners):
                try:
                    listener(rec)
                except Exception:
                    log.exception("ack listener %r failed", listener)
            fut = self._first.pop(rec.id, None)
            if fut is not None and not fut.done():
                fut.set_result(None)
            if rec.terminal is not None:
                fut = self._final.pop(rec.id, None)
                if fut is not None and not fut.done():
                    fut.set_result(None)
            return
        pending = self._pending_reply
        if pending is not None:
            tag, reply = pending
            if text.partition("|")[0] in (tag, "ERROR") and not reply.done():
                reply.set_result(text)

    async def _request(self, request: str, tag: str, timeout: float) -> str:
        await self._ensure_open()
        assert self._query_lock is not None
        async with self._query_lock:
            fut: asyncio.Future[str] = asyncio.get_running_loop().create_future()
            self._pending_reply = (tag, fut)
            try:
                self._send(request)
                return await asyncio.wait_for(fut, timeout)
            except TimeoutError:
                raise ControllerUnreachable(
                    f"no {tag} reply from {self.host}:{self.port} within {timeout:g} s "
                    "(is the controller running?)") from None
            finally:
                self._pending_reply = None

    async def _query(self, query: QuerySpec[_T]) -> _T:
        return parse_query_reply(query, await self._request(query.request, query.tag, self.timeout))

    # the datagram body is already built (and validated) by the caller: only I/O is async
    async def _run(self, body: str, timeout: float | None) -> CommandResult:
        record = await self._accepted(body, timeout)
        if record.terminal is not None:
            self._final.pop(record.id, None)
            return record.result()
        return await self._wait_terminal(record, timeout)

    async def _start(self, body: str, timeout: float | None) -> AsyncCommandHandle:
        record = await self._accepted(body, timeout)
        if record.terminal is not None:
            record.result()  # refused or failed at once: raise now
        return AsyncCommandHandle(self, record)

    async def _accepted(self, body: str, timeout: float | None) -> AckRecord:
        """Send ``body`` with a fresh ID and wait for its first ack (``CommandTimeout`` without
        one within the robot's timeout)."""
        await self._ensure_open()
        loop = asyncio.get_running_loop()
        record, text = self._acks.new(body)
        first = self._first[record.id] = loop.create_future()
        self._final[record.id] = loop.create_future()
        self._send(text)
        limit = self.timeout if timeout is None else min(timeout, self.timeout)
        try:
            await asyncio.wait_for(asyncio.shield(first), limit)
        except TimeoutError:
            self._first.pop(record.id, None)
            self._final.pop(record.id, None)
            raise CommandTimeout(
                record.id, record.command, "TIMEOUT",
                f"no acknowledgement within {limit:g} s: is the controller running at "
                f"{self.host}:{self.port}, and does it send acks to this client's port "
                f"{self.ack_port}? (a controller that acks only its --ack-port needs "
                "AsyncRobot(ack_port=<that port>))") from None
        return record

    async def _wait_terminal(self, record: AckRecord, timeout: float | None) -> CommandResult:
        if record.terminal is not None:
            return record.result()
        fut = self._final.get(record.id)
        if fut is None:
            fut = self._final[record.id] = asyncio.get_running_loop().create_future()
        start = time.monotonic()
        probe = max(self.timeout, 1.0)
        while record.terminal is None:
            wait = probe
            if timeout is not None:
                left = start + timeout - time.monotonic()
                if left <= 0:
                    latest = record.latest[0].value if record.latest else "none"
                    raise CommandTimeout(record.id, record.command, "TIMEOUT",
                                         f"not finished within {timeout:g} s (last status: "
                                         f"{latest}); it may still run: stop() cancels it")
                wait = min(wait, left)
            try:
                await asyncio.wait_for(asyncio.shield(fut), wait)
            except TimeoutError:
                if time.monotonic() - self._last_heard > self.timeout:
                    try:
                        await self._query(Queries.ping)
                    except ControllerUnreachable as exc:
                        raise CommandTimeout(record.id, record.command, "TIMEOUT",
                                             f"controller stopped answering: {exc}") from None
        self._final.pop(record.id, None)
        return record.result()

    async def wait_checkpoint(self, label: str, timeout: float | None = None) -> CommandResult:
        """Wait until the newest checkpoint ``label`` this robot queued (:meth:`checkpoint`,
        ``wait=False``) is reached: its result; ``CommandCancelled`` / ``CommandFailed`` when the
        queue ended before it (STOP, an E-stop), ``CommandTimeout`` after ``timeout`` s.
        ``ParolkitValueError`` for a label this robot never queued."""
        body = _check(wire.build_checkpoint, label)
        record = self._acks.newest(body)
        if record is None:
            raise ParolkitValueError(f"no checkpoint {label!r} was queued by this robot "
                                     f"(await robot.checkpoint({label!r}, wait=False) first)")
        return await self._wait_terminal(record, _opt_timeout(timeout))

    # ---- status stream ----
    def subscribe(self, every_n: int = 1, timeout: float | None = None,
                  buffer: int = 64) -> AsyncStatusSubscription:
        """Status stream every ``every_n``-th tick; use with ``async with`` / ``async for``."""
        if isinstance(every_n, bool) or not isinstance(every_n, int) or every_n < 1:
            raise ParolkitValueError(f"every_n must be an integer >= 1 (ticks), got {every_n!r}")
        if isinstance(buffer, bool) or not isinstance(buffer, int) or buffer < 1:
            raise ParolkitValueError(f"buffer must be an integer >= 1, got {buffer!r}")
        wait = max(self.timeout, 2.0) if timeout is None else float(timeout)
        return AsyncStatusSubscription(self, every_n, wait, buffer)

    async def wait_until_idle(self, timeout: float = 30.0, poll_s: float = 0.05) -> RobotStatus:
        """Poll the status until no command is active or queued; returns that status."""
        deadline = time.monotonic() + timeout
        while True:
            st = await self.status()
            if st.command is None and st.queue == 0 and st.state not in ("MOVING", "HOMING"):
                return st
            if time.monotonic() >= deadline:
                raise RobotError(f"robot still busy after {timeout:g} s (state {st.state}, "
                                 f"queue {st.queue})")
            await asyncio.sleep(poll_s)

    async def close(self) -> None:
        """Give the control lease back (if this client holds it) and close the endpoint
        (idempotent)."""
        if self._transport is not None and not self._closed:
            try:
                self._transport.sendto(b"CONTROL|RELEASE")
            except OSError:
                pass
        self._closed = True
        if self._transport is not None:
            self._transport.close()
            self._transport = None

    async def __aenter__(self) -> AsyncRobot:
        await self._ensure_open()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    def __repr__(self) -> str:
        return f"<AsyncRobot {self.host}:{self.port} ack_port={self.ack_port}>"
