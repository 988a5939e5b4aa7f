"""``parolkit.Robot``: the synchronous object API.

::

    from parolkit import Robot

    with Robot() as robot:                      # 127.0.0.1:5001
        robot.move_joints([90, -90, 160, 12, 12, 180], duration=2)   # waits for COMPLETED
        print(robot.angles(), robot.pose())
        for status in robot.subscribe(every_n=10):                   # 10 Hz status stream
            print(status.state, status.angles)
            break

One UDP socket carries commands, queries, their replies and the acknowledgements; a
background thread receives and sorts them.  ``ack_port=0`` (default) binds an ephemeral
port: query replies always come back to it, and so do acks, because the Robot registers
its socket with the controller's (ext) ``ACK_HERE`` command.  Give
``ack_port=<the controller's --ack-port>`` (5002 by default) to listen where the original
protocol sends acks (one program per machine can hold that port).

``channel=``: instead of a UDP socket, a :class:`DatagramChannel`, an in-process path to a
controller (``parolkit run --sim`` drives its simulated controller so, tick by tick:
:class:`parolkit.controller.fastforward.InProcessController`).  The Robot then has no reader
thread: a call that waits for an ack or a reply receives from the channel itself, and the
controller behind it may advance while (and only while) someone waits.

Every method is documented in :class:`parolkit.client.core.RobotCommands`; errors are the
classes of :mod:`parolkit.client.errors`.  Here a command returns its :class:`CommandResult`
(``wait=True``) or a :class:`CommandHandle` (``wait=False``), a query its typed value.
"""

from __future__ import annotations

import contextlib
import queue
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Literal, Protocol, TypeVar, overload

from parolkit.client import robot_api as wire
from parolkit.client.core import (
    DEFAULT_TIMEOUT_S,
    SUBSCRIBE_RENEW_S,
    AckBook,
    AckRecord,
    AckStatus,
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

__all__ = ["Robot", "CommandHandle", "StatusSubscription", "DatagramChannel"]

_T = TypeVar("_T")


class DatagramChannel(Protocol):
    """An in-process datagram path to a controller, in place of the Robot's UDP socket.

    :meth:`send` hands one datagram to the controller (it is taken in before ``send``
    returns); :meth:`receive` returns the next datagram the controller sent this client,
    waiting up to ``timeout`` seconds (None when nothing came).  A channel whose controller
    runs only while a client waits (a simulated one, fast-forwarded) advances it inside
    :meth:`receive`.  Both may be called from several threads."""

    def send(self, data: bytes) -> None: ...

    def receive(self, timeout: float) -> bytes | None: ...


class CommandHandle:
    """A command sent with ``wait=False``: ``id``, ``command``, ``status()``, ``result()``."""

    def __init__(self, robot: Robot, record: AckRecord) -> None:
        self._robot = robot
        self._record = record

    @property
    def id(self) -> str:
        return self._record.id

    @property
    def command(self) -> str:
        return self._record.command

    def status(self) -> AckStatus | None:
        """Latest acknowledgement status (None before the first ack)."""
        with self._robot._cond:
            latest = self._record.latest
        return None if latest is None else latest[0]

    def done(self) -> bool:
        with self._robot._cond:
            return self._record.terminal is not None

    @overload
    def result(self, timeout: float | None = None, *,
               raise_on_error: Literal[True] = True) -> CommandResult: ...
    @overload
    def result(self, timeout: float | None = None, *,
               raise_on_error: bool) -> CommandResult | CommandNotCompleted: ...

    def result(self, timeout: float | None = None, *,
               raise_on_error: bool = True) -> CommandResult | CommandNotCompleted:
        """Wait for the terminal ack (see ``wait=True``) and return the COMPLETED
        :class:`CommandResult`; a failure raises like a waiting call
        (:class:`~parolkit.client.errors.CommandNotCompleted`: CommandFailed, CommandInvalid,
        CommandCancelled, CommandTimeout).  ``raise_on_error=False`` returns that error
        instead of raising it."""
        try:
            return self._robot._wait_terminal(self._record, timeout)
        except CommandNotCompleted as exc:
            if raise_on_error:
                raise
            return exc

    def __repr__(self) -> str:
        return f"<CommandHandle {self.command} id={self.id} status={self.status()}>"


class StatusSubscription:
    """Iterator over :class:`RobotStatus` from the SUBSCRIBE stream (renewed every 3 s).

    The controller starts the stream once this socket echoed its cookie: the ``COOKIE|``
    answer is read like a status and answered at once with SUBSCRIBE and the cookie (also
    when the controller issues a new one, every 30 s or so).

    Use as a context manager or call :meth:`close`; iteration raises
    :class:`ControllerUnreachable` if no status arrives for ``timeout`` seconds.
    """

    def __init__(self, robot: Robot, every_n: int, timeout: float,
                 callback: Callable[[RobotStatus], object] | None = None) -> None:
        self._robot = robot
        self._every_n = every_n
        self._timeout = timeout
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.bind((bind_address(robot.host), 0))
        # connected: the kernel delivers only the controller's datagrams (no forged statuses)
        self._sock.connect(robot._addr)
        self.port: int = self._sock.getsockname()[1]
        self._closed = threading.Event()
        self._last_renew = 0.0
        self._cookie: str | None = None
        self.received = 0
        self._renew()
        self._renewer = threading.Thread(target=self._renew_loop, daemon=True,
                                         name=f"parolkit-subscribe-{self.port}")
        self._renewer.start()
        self._callback_thread: threading.Thread | None = None
        if callback is not None:
            self._callback_thread = threading.Thread(target=self._pump, args=(callback,),
                                                     daemon=True, name="parolkit-status-callback")
            self._callback_thread.start()

    def _renew(self) -> None:
        # from this socket: the controller streams only to the socket that asks
        self._sock.send(wire.build_subscribe(self.port, self._every_n, self._cookie).encode("utf-8"))
        self._last_renew = time.monotonic()

    def _renew_loop(self) -> None:
        while not self._closed.wait(SUBSCRIBE_RENEW_S):
            try:
                self._renew()
            except (OSError, RobotError):
                pass  # the next renewal retries; iteration reports a silent controller

    def _pump(self, callback: Callable[[RobotStatus], object]) -> None:
        try:
            for status in self:
                callback(status)
        except (RobotError, OSError):
            if not self._closed.is_set():
                raise

    def next(self, timeout: float | None = None) -> RobotStatus:
        """The next status (waits up to ``timeout`` s, default the subscription's)."""
        wait = self._timeout if timeout is None else timeout
        deadline = time.monotonic() + wait
        while True:
            if self._closed.is_set():
                raise StopIteration
            left = deadline - time.monotonic()
            if left <= 0:
                raise ControllerUnreachable(
                    f"no status from {self._robot.host}:{self._robot.port} within {wait:g} s "
                    "(is the controller running?)")
            self._sock.settimeout(min(left, 0.5))
            try:
                data, _ = self._sock.recvfrom(65535)
            except TimeoutError:
                continue
            except OSError:
                if self._closed.is_set():
                    raise StopIteration from None
                raise
            text = data.decode("utf-8", "replace")
            if text.startswith("STATUS_JSON|"):
                self.received += 1
                return parse_query_reply(Queries.status, text)
            cookie = wire.parse_cookie(text)
            if cookie is not None:
                self._cookie = cookie
                self._renew()

    def __iter__(self) -> Iterator[RobotStatus]:
        while True:
            try:
                yield self.next()
            except StopIteration:
                return

    def close(self) -> None:
        """Unsubscribe and close the socket (idempotent)."""
        if self._closed.is_set():
            return
        self._closed.set()
        try:
            self._sock.send(wire.build_unsubscribe(self.port).encode("utf-8"))
        except OSError:
            pass
        self._sock.close()

    def __enter__(self) -> StatusSubscription:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Robot(RobotCommands[CommandResult, CommandHandle]):
    """Synchronous client of a parolkit (or original PAROL6) controller.

    ``host``/``port``: the controller's UDP address; ``ack_port``: local port for replies
    and acks (0 = ephemeral); ``timeout``: seconds to wait for a query reply or for the
    first acknowledgement of a command.  Thread-safe: several threads may share one Robot.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 5001, ack_port: int = 0,
                 timeout: float = DEFAULT_TIMEOUT_S, *, channel: DatagramChannel | None = None) -> None:
        if not isinstance(host, str) or not host:
            raise ParolkitValueError(f"host must be a host name or address, got {host!r}")
        self.host = host
        self.port = check_port(port, "port", 1)
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or timeout <= 0:
            raise ParolkitValueError(f"timeout must be a number of seconds > 0, got {timeout!r}")
        self.timeout = float(timeout)
        self._addr = (host, self.port)
        self._cond = threading.Condition()
        #: per thread: :meth:`pipelined`
        self._local = threading.local()
        self._acks = AckBook()
        self._replies: queue.Queue[str] = queue.Queue()
        self._query_lock = threading.Lock()
        self._last_heard = 0.0
        self._closed = False
        self._channel = channel
        #: one thread at a time receives from the channel; the others wait for what it sorts
        self._pump_lock = threading.Lock()
        if channel is not None:
            self.ack_port: int = 0
            self._send("ACK_HERE")
            return
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.bind((bind_address(host), check_port(ack_port, "ack_port", 0)))
        except OSError as exc:
            self._sock.close()
            raise RobotError(
                f"cannot bind UDP port {ack_port} for acknowledgements: {exc.strerror}; another "
                "program holds it (use ack_port=0 for an ephemeral port)") from None
        try:
            # connected: the kernel delivers only datagrams from the controller's address, so no
            # other process can forge an ack or a reply (the controller answers from this port)
            self._sock.connect(self._addr)
        except OSError as exc:
            self._sock.close()
            raise ControllerUnreachable(f"cannot reach {host}:{self.port}: {exc.strerror or exc}") from None
        self.ack_port = self._sock.getsockname()[1]
        self._sock.settimeout(0.25)  # lets the reader thread notice close()
        self._reader = threading.Thread(target=self._read_loop, daemon=True,
                                        name=f"parolkit-robot-{self.ack_port}")
        self._reader.start()
        # (ext) ask the controller to send this socket the acks of what it sends (it also
        # sends them to its fixed ack port, where robot_api scripts listen)
        self._send("ACK_HERE")

    # ---- plumbing ----
    def _send(self, text: str) -> None:
        if self._closed:
            raise RobotError("this Robot is closed")
        if self._channel is not None:
            self._channel.send(text.encode("utf-8"))
            return
        try:
            self._sock.send(text.encode("utf-8"))
        except OSError as exc:  # unresolvable host, no route, ...
            raise ControllerUnreachable(
                f"cannot send to {self.host}:{self.port}: {exc.strerror or exc}") from None

    def _read_loop(self) -> None:
        sock = self._sock
        while not self._closed:
            try:
                data, _ = sock.recvfrom(65535)
            except TimeoutError:
                continue
            except OSError:
                if self._closed:
                    return
                continue  # e.g. ICMP port unreachable reported on Linux: keep listening
            if data:  # (empty: close() shut the socket down, or an empty datagram)
                self._sort(data)

    def _sort(self, data: bytes) -> None:
        """One datagram from the controller: an ack to its record, anything else to the
        replies; wakes the waiters."""
        text = data.decode("utf-8", "replace")
        with self._cond:
            self._last_heard = time.monotonic()
            if text.startswith("ACK|"):
                self._acks.on_datagram(text)
            else:
                self._replies.put(text)
            self._cond.notify_all()

    def _pump(self, deadline: float) -> None:
        """(channel only; not holding ``_cond``) Receive one datagram until ``deadline``
        (monotonic s) and sort it; when another thread is receiving, wait for what it sorts."""
        assert self._channel is not None
        left = max(0.0, deadline - time.monotonic())
        if self._pump_lock.acquire(blocking=False):
            try:
                data = self._channel.receive(left)
            finally:
                self._pump_lock.release()
            if data:
                self._sort(data)
            return
        with self._cond:
            self._cond.wait(min(left, 0.05))

    def _request(self, request: str, tag: str, timeout: float) -> str:
        """Send a query and return the raw reply carrying ``tag`` (or an ERROR reply)."""
        with self._query_lock:
            while True:  # drop late replies of earlier, timed-out queries
                try:
                    self._replies.get_nowait()
                except queue.Empty:
                    break
            self._send(request)
            deadline = time.monotonic() + timeout
            while True:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise ControllerUnreachable(
                        f"no {tag} reply from {self.host}:{self.port} within {timeout:g} s "
                        "(is the controller running?)")
                try:
                    text = self._replies.get_nowait() if self._channel else self._replies.get(timeout=left)
                except queue.Empty:
                    if self._channel:
                        self._pump(deadline)
                    continue
                head = text.partition("|")[0]
                if head in (tag, "ERROR"):
                    return text

    def _query(self, query: QuerySpec[_T]) -> _T:
        return parse_query_reply(query, self._request(query.request, query.tag, self.timeout))

    def _accepted(self, body: str, timeout: float | None) -> AckRecord:
        """Send ``body`` with a fresh ID and wait for its first ack (``CommandTimeout`` without
        one within the Robot's timeout)."""
        record = self._sent(body)
        limit = self.timeout if timeout is None else min(timeout, self.timeout)
        deadline = time.monotonic() + limit
        with self._cond:
            while record.first_at is None:
                if time.monotonic() >= deadline:
                    raise self._no_ack(record, limit)
                self._wait(deadline)
        return record

    def _sent(self, body: str) -> AckRecord:
        """Send ``body`` with a fresh ID; its record."""
        with self._cond:
            record, text = self._acks.new(body)
        self._send(text)
        return record

    def _no_ack(self, record: AckRecord, limit: float) -> CommandTimeout:
        return CommandTimeout(
            record.id, record.command, "TIMEOUT",
            f"no acknowledgement within {limit:g} s: is the controller running at "
            f"{self.host}:{self.port}, and does it send acks to this client's port "
            f"{self.ack_port}? (a controller that acks only its --ack-port needs "
            "Robot(ack_port=<that port>))")

    @contextlib.contextmanager
    def pipelined(self) -> Iterator[None]:
        """Within it, a command this thread sends with ``wait=False`` returns its handle as
        soon as it is sent, without waiting for the controller's first ack (which comes with
        the controller's next tick): for a sender that queues short commands back to back,
        such as the RBTscript interpreter's lines ahead.  A refusal or a lost datagram shows
        at the handle's ``result()`` (``CommandTimeout`` when no ack came within the Robot's
        timeout), not at the send."""
        before = getattr(self._local, "pipelined", False)
        self._local.pipelined = True
        try:
            yield
        finally:
            self._local.pipelined = before

    def _wait(self, deadline: float) -> None:
        """(holding ``_cond``) Wait for the next datagram until ``deadline`` (monotonic s)."""
        if self._channel is None:
            self._cond.wait(max(0.0, deadline - time.monotonic()))
            return
        self._cond.release()
        try:
            self._pump(deadline)
        finally:
            self._cond.acquire()

    def _run(self, body: str, timeout: float | None) -> CommandResult:
        return self._wait_terminal(self._accepted(body, timeout), timeout)

    def _start(self, body: str, timeout: float | None) -> CommandHandle:
        if getattr(self._local, "pipelined", False):
            return CommandHandle(self, self._sent(body))
        record = self._accepted(body, timeout)
        with self._cond:
            if record.terminal is not None:
                record.result()  # refused (INVALID) or failed at once: raise now
        return CommandHandle(self, record)

    def _wait_terminal(self, record: AckRecord, timeout: float | None) -> CommandResult:
        start = time.monotonic()
        deadline = None if timeout is None else start + timeout
        probe_at = start + max(self.timeout, 1.0)
        with self._cond:
            while record.terminal is None:
                now = time.monotonic()
                if record.first_at is None and now >= record.sent_at + self.timeout:
                    raise self._no_ack(record, self.timeout)  # (sent pipelined: never acked)
                if record.first_at is None:
                    probe_at = min(probe_at, record.sent_at + self.timeout)
                if deadline is not None and now >= deadline:
                    latest = record.latest[0].value if record.latest else "none"
                    raise CommandTimeout(record.id, record.command, "TIMEOUT",
                                         f"not finished within {timeout:g} s (last status: "
                                         f"{latest}); it may still run: stop() cancels it")
                if now >= probe_at:
                    # liveness: a long move is fine while the controller still answers
                    if now - self._last_heard > self.timeout:
                        self._cond.release()
                        try:
                            self._query(Queries.ping)
                        except ControllerUnreachable as exc:
                            raise CommandTimeout(record.id, record.command, "TIMEOUT",
                                                 f"controller stopped answering: {exc}") from None
                        finally:
                            self._cond.acquire()
                    probe_at = time.monotonic() + max(self.timeout, 1.0)
                    continue
                self._wait(probe_at if deadline is None else min(probe_at, deadline))
            return record.result()

    def wait_checkpoint(self, label: str, timeout: float | None = None) -> CommandResult:
        """Wait until the newest checkpoint ``label`` this robot queued (:meth:`checkpoint`,
        ``wait=False``) is reached: its result; ``CommandCancelled`` / ``CommandFailed`` when the
        queue ended before it (STOP, an E-stop), ``CommandTimeout`` after ``timeout`` s.
        ``ParolkitValueError`` for a label this robot never queued."""
        body = _check(wire.build_checkpoint, label)
        with self._cond:
            record = self._acks.newest(body)
        if record is None:
            raise ParolkitValueError(f"no checkpoint {label!r} was queued by this robot "
                                     f"(robot.checkpoint({label!r}, wait=False) first)")
        return self._wait_terminal(record, _opt_timeout(timeout))

    # ---- status stream ----
    def subscribe(self, every_n: int = 1, callback: Callable[[RobotStatus], object] | None = None,
                  timeout: float | None = None) -> StatusSubscription:
        """Status stream: every ``every_n``-th control tick a :class:`RobotStatus`.

        Without ``callback``: iterate the returned subscription.  With ``callback``: it is
        called from a background thread for every status.  Close the subscription (or use
        ``with``) to unsubscribe.  ``timeout``: seconds without a status before iteration
        raises ``ControllerUnreachable`` (default: the Robot's timeout, at least 2 s).
        """
        if isinstance(every_n, bool) or not isinstance(every_n, int) or every_n < 1:
            raise ParolkitValueError(f"every_n must be an integer >= 1 (ticks), got {every_n!r}")
        if self._channel is not None:
            raise RobotError("the status stream needs a UDP controller; this Robot talks to an "
                             "in-process one (channel=): poll status() instead")
        n = every_n
        wait = max(self.timeout, 2.0) if timeout is None else float(timeout)
        return StatusSubscription(self, n, wait, callback)

    # ---- helpers ----
    def wait_until_idle(self, timeout: float = 30.0, poll_s: float = 0.05) -> RobotStatus:
        """Poll the status until no command is active or queued; returns that status."""
        deadline = time.monotonic() + timeout
        while True:
            st = self.status()
            if st.command is None and st.queue == 0 and st.state not in ("MOVING", "HOMING"):
                return st
            if time.monotonic() >= deadline:
                raise RobotError(f"robot still busy after {timeout:g} s (state {st.state}, "
                                 f"queue {st.queue})")
            time.sleep(poll_s)

    def close(self) -> None:
        """Give the control lease back (if this client holds it) and close the socket
        (idempotent)."""
        if self._closed:
            return
        try:
            self._send("CONTROL|RELEASE")
        except RobotError:
            pass
        self._closed = True
        if self._channel is not None:
            return
        try:  # wake the reader thread at once instead of waiting for its poll timeout
            self._sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._reader.join(1.0)
        self._sock.close()

    def __enter__(self) -> Robot:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<Robot {self.host}:{self.port} ack_port={self.ack_port}>"
