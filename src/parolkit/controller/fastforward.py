"""A controller driven in-process, tick by tick, on a simulated board in lockstep: the same
frames whether it runs paced at real time or fast-forwarded.

:class:`InProcessController` is the whole controller of ``parolkit serve`` (the core, its
driver, the UDP server's command handling, the acks) on a simulated board in lockstep with the
frames (``sim://?clock=virtual&step=<period>``: each frame written runs the board one period),
with plans made inline.  It has no threads: a client reaches it through
:class:`~parolkit.client.robot.DatagramChannel` (``Robot(channel=...)``), and it ticks only
while that client waits for a reply (:meth:`InProcessController.receive`).  A datagram the
client sends is served at once, between two ticks (:meth:`InProcessController.send`).

So every command enters the controller at a tick fixed by the program, not by the wall clock:
the RBTscript interpreter sends its next command after the tick whose output carried the
previous command's terminal ack.  What the board is sent depends on the program alone, and
pacing decides only how long it takes: ``paced=True`` sleeps to each tick's deadline
(``t0 + k x period``, real time), ``paced=False`` ticks as soon as the board has answered
(fast-forward).  The two write the same frames, byte for byte (``frame_log``).

Queries (GET_ANGLES, GET_TOOL, PING ...) are answered from the latest snapshot and change
nothing the core sees; they may come at any time.
"""

from __future__ import annotations

import socket
import threading
import time
from collections import deque
from typing import Any, TextIO

from parolkit.config import Config
from parolkit.controller.app import Controller
from parolkit.controller.driver import Driver
from parolkit.controller.snapshot import RobotState
from parolkit.protocol.frames import CommandFrame
from parolkit.transport.base import Transport
from parolkit.transport.url import parse_transport_url

__all__ = ["InProcessController", "FrameLogTransport", "FRAME_LOG_HEADER", "READY_TIMEOUT_S", "parse_frame_log"]

#: the first line of a frame log
FRAME_LOG_HEADER = "# parolkit frame log: one line per frame written to the board: TICK HEX-BYTES\n"
#: board seconds the simulated board may take to home and settle before the first command
READY_TIMEOUT_S = 300.0


def parse_frame_log(text: str) -> list[tuple[int, CommandFrame]]:
    """The frames of a frame log (:class:`FrameLogTransport`): ``(tick, frame)`` in order.
    ValueError naming the line for one that is not ``TICK HEX`` of a command frame, or a text
    without the header."""
    lines = text.splitlines()
    if not lines or lines[0] + "\n" != FRAME_LOG_HEADER:
        raise ValueError("not a parolkit frame log: its first line must be " + FRAME_LOG_HEADER.strip())
    out = []
    for n, line in enumerate(lines[1:], start=2):
        try:
            tick, data = line.split(" ")
            out.append((int(tick), CommandFrame.decode(bytes.fromhex(data))))
        except ValueError as exc:
            raise ValueError(f"frame log line {n}: {exc} ({line[:60]!r})") from None
    return out


class FrameLogTransport(Transport):
    """Wraps ``inner`` and writes every frame written through it to ``log`` as one line,
    ``TICK HEX``: the index of the tick that wrote it (:attr:`tick`, set by the owner) and its
    bytes.  No times: two runs that wrote the same frames at the same ticks give the same log."""

    def __init__(self, inner: Transport, log: TextIO) -> None:
        self.inner = inner
        self.log = log
        self.simulated = inner.simulated
        self.virtual_clock = inner.virtual_clock
        self.step_s = inner.step_s
        #: the index of the tick writing now
        self.tick = 0
        log.write(FRAME_LOG_HEADER)

    @property
    def description(self) -> str:
        return self.inner.description

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def open(self) -> None:
        self.inner.open()

    def close(self) -> None:
        self.inner.close()
        self.log.flush()

    def write(self, data: bytes) -> None:
        self.inner.write(data)
        self.log.write(f"{self.tick} {bytes(data).hex()}\n")

    def read(self) -> bytes:
        return self.inner.read()


class _ClientSocket(socket.socket):
    """The controller's command socket with one in-process client at :attr:`client`: what the
    controller sends there is kept in :attr:`outgoing`; what it sends elsewhere (the original
    protocol's fixed ack port of another host) is dropped.  Never bound: nothing arrives."""

    def __init__(self, family: int = socket.AF_INET, type: int = socket.SOCK_DGRAM, proto: int = 0,
                 fileno: int | None = None) -> None:
        super().__init__(family, type, proto, fileno)
        self.client: tuple[str, int] = ("127.0.0.1", 0)
        self.outgoing: deque[bytes] = deque()

    def sendto(self, data: Any, *args: Any) -> int:
        address = args[-1]
        if (str(address[0]), int(address[1])) == self.client:
            self.outgoing.append(bytes(data))
        return len(data)


class InProcessController:
    """The controller on a simulated board in lockstep, driven by its client's waits (see
    the module docstring).  ``paced``: real time (sleep to each tick's deadline) or
    fast-forward; ``frame_log``: a text stream that gets every frame written to the board
    (:class:`FrameLogTransport`).  :meth:`start` homes the board (when the config says so) and
    returns once it is ready; :meth:`close` stops the robot (the driver's final frames) and
    closes the board link.  It is a :class:`~parolkit.client.robot.DatagramChannel`."""

    def __init__(self, config: Config, *, paced: bool, frame_log: TextIO | None = None) -> None:
        self.config = config
        self.paced = paced
        cs = config.controller
        self.period = cs.period_s
        self.controller = Controller(config)
        url = parse_transport_url(f"sim://?clock=virtual&step={self.period!r}").with_options(
            defaults={"speedup": cs.sim_homing_speedup})
        from parolkit.transport import open_transport

        board = open_transport(url)
        self.frame_log = FrameLogTransport(board, frame_log) if frame_log is not None else None
        self.transport: Transport = self.frame_log if self.frame_log is not None else board
        self._sock = _ClientSocket()
        #: where the client's datagrams come from: the ack port, so its acks go there alone
        self.client: tuple[str, int] = ("127.0.0.1", cs.ack_port)
        self._sock.client = self.client
        self.controller.assemble_server(self._sock)
        self.driver: Driver = self.controller.assemble_driver(self.transport, plan_inline=True)
        # one thread: a snapshot is built when a query (or start's wait) reads it, between ticks
        self.driver.lazy_snapshots = True
        self._lock = threading.RLock()
        self._closed = False
        self._t0 = 0.0
        #: ticks run before the first command (the board homing and settling)
        self.ready_ticks = 0

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        """Home the simulated board (if the config says so) and tick until it is ready: all
        joints homed, not homing, the start-up probe done."""
        ctl = self.controller
        ctl.home_if_simulated(self.transport)
        self._t0 = time.monotonic()
        limit = int(READY_TIMEOUT_S / self.period)
        with self._lock:
            for _ in range(limit):
                self._wait_for_deadline()
                self._tick()
                s = ctl.snapshot
                if (all(s.homed) and s.state is not RobotState.HOMING and s.state is not RobotState.DISCONNECTED
                        and not ctl.core.probe.active and not ctl.busy()):
                    self.ready_ticks = self.ticks
                    return
        raise RuntimeError(f"the simulated board was not ready after {READY_TIMEOUT_S:g} s of board time "
                           f"(state {ctl.snapshot.state.value})")

    def close(self) -> None:
        """Stop: the driver's final frames (through the guard), then close the board link."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            if self.frame_log is not None:
                self.frame_log.tick = self.ticks
            self.driver.stop()
            self.controller.server.stop()
            self._sock.close()

    def __enter__(self) -> InProcessController:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ figures

    @property
    def ticks(self) -> int:
        """Ticks run so far."""
        return self.driver.tick_count

    @property
    def board_seconds(self) -> float:
        """The board's time: ticks x period, s."""
        return self.ticks * self.period

    # ------------------------------------------------------------------ DatagramChannel

    def send(self, data: bytes) -> None:
        """Serve one datagram from the client now, between two ticks (a command reaches the
        core at the next tick)."""
        with self._lock:
            if self._closed:
                return
            self.controller.server.serve_now(bytes(data), self.client)
            self.controller.outbox.send_waiting()

    def receive(self, timeout: float) -> bytes | None:
        """The next datagram for the client, ticking until one comes (at most ``timeout`` s
        of wall-clock time; None then, or once closed)."""
        end = time.monotonic() + timeout
        out = self._sock.outgoing
        while True:
            with self._lock:
                if out:
                    return out.popleft()
                if self._closed:
                    return None
                wait = self._until_deadline()
                if wait <= 0.0:
                    self._tick()
                    if out:
                        return out.popleft()
            now = time.monotonic()
            if now >= end:
                return None
            if wait > 0.0:
                time.sleep(min(wait, end - now))

    # ------------------------------------------------------------------ ticks

    def run_ticks(self, n: int) -> None:
        """Run ``n`` ticks now (fast-forward, whatever ``paced`` says): tools and tests that
        send datagrams at ticks of their choosing (:meth:`send`) and read what came back."""
        with self._lock:
            for _ in range(int(n)):
                if self._closed:
                    return
                self._tick()

    def take_datagrams(self) -> list[bytes]:
        """Every datagram the controller has sent the client since the last call (acks,
        replies), oldest first."""
        with self._lock:
            out = list(self._sock.outgoing)
            self._sock.outgoing.clear()
            return out

    def _until_deadline(self) -> float:
        """Seconds until the next tick's deadline (0 when fast-forwarding).  Paced: a run that
        fell more than a period behind (the client did not wait) starts again from now."""
        if not self.paced:
            return 0.0
        now = time.monotonic()
        deadline = self._t0 + self.ticks * self.period
        if now - deadline > self.period:
            self._t0 = now - self.ticks * self.period
            return 0.0
        return deadline - now

    def _wait_for_deadline(self) -> None:
        wait = self._until_deadline()
        if wait > 0.0:
            time.sleep(wait)

    def _tick(self) -> None:
        """(holding the lock) One tick: the core's update, the frame, the board's period, the
        snapshot and the acks."""
        if self.frame_log is not None:
            self.frame_log.tick = self.ticks
        self.driver.run_fast(1)
        self.controller.outbox.send_waiting()
