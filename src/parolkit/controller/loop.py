"""The control loop: a fixed-rate, deadline-based tick.  Small and boring:

1. read every byte the board sent, keep the newest status frame;
2. take the server's commands (safety lane first) and ask the executor for this tick's frame
   content (no planning here);
3. pass the frame through the safety guard; if a safety command arrived meanwhile, apply it
   and guard its frame instead (the first frame written after ESTOP / STOP / DISABLE arrives
   carries it);
4. write it, wait briefly for the reply (round-trip time);
5. hand the :class:`TickOutput` (frame, acks, snapshot) to ``publish``, which stores the
   snapshot before it sends the acks: an ack never reports what the status does not show yet.
   Sleep until the next deadline.

:meth:`ControlLoop.tick` is steps 1-4 as a function of the time, returning the value of step
5; tests drive it directly.

Deadlines are ``t0 + k * period`` (no drift).  A tick that starts more than one period late
counts as an overrun and the missed deadlines are skipped (never a burst of catch-up frames).

Link supervision: no status frame for ``link_timeout_ticks`` ticks, or a
:class:`LinkLostError`, means the link is lost: motion is cancelled (never resumed), the error
is latched, and a reconnect is tried once a second in a helper thread (the tick never blocks
on ``open()``).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from parolkit.controller.executor import SET_PORT_SCHEMES, Executor
from parolkit.controller.guard import SafetyGuard
from parolkit.controller.inbox import Ack, CommandInbox
from parolkit.controller.jobs import Step
from parolkit.controller.state import BoardInfo, PoseProvider, Snapshot, build_snapshot
from parolkit.controller.stats import LoopMetrics
from parolkit.controller.supervisor import StopSupervisor
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.protocol.stream import StatusParser
from parolkit.transport.base import LinkLostError, Transport, TransportError

__all__ = ["ControlLoop", "TickOutput"]

log = logging.getLogger("parolkit.controller")


@dataclass(frozen=True, slots=True)
class TickOutput:
    """What one tick produced: the frame written (None when the link is down), the acks of
    everything that happened in it, in order, and the snapshot that shows all of it."""

    frame: CommandFrame | None
    acks: tuple[Ack, ...]
    snapshot: Snapshot


class ControlLoop:
    """Owns the transport, the guard and the tick thread.

    ``publish(out)`` is called after every tick (loop thread); it must store
    ``out.snapshot`` before it sends ``out.acks``."""

    def __init__(
        self,
        *,
        transport: Transport,
        executor: Executor,
        guard: SafetyGuard,
        rate_hz: float,
        link_timeout_ticks: int,
        inbox: CommandInbox | None = None,
        publish: Callable[[TickOutput], None] | None = None,
        pose_provider: PoseProvider | None = None,
        reply_wait_fraction: float = 0.4,
        supervisor: StopSupervisor | None = None,
    ) -> None:
        self.transport = transport
        self.executor = executor
        self.guard = guard
        self.rate_hz = rate_hz
        self.period = 1.0 / rate_hz
        self.link_timeout_ticks = link_timeout_ticks
        self.inbox = inbox if inbox is not None else CommandInbox()
        self.publish = publish
        self.pose_provider = pose_provider
        #: counters of the UDP server for the snapshot (set by whoever runs one)
        self.server_view: Callable[[], dict[str, Any]] | None = None
        self.reply_wait = min(self.period * reply_wait_fraction, 0.003)
        self.stats = LoopMetrics(rate_hz)
        self.parser = StatusParser()
        #: newest status frame of the current link session (None right after (re)connecting)
        self.status: StatusFrame | None = None
        #: newest status frame ever received (what the robot last reported; for display)
        self.last_status: StatusFrame | None = None
        self.link_up = transport.is_open
        self.tick_count = 0
        self.start_time = time.monotonic()
        self._last_status_tick = 0
        self._alive_tick = 0
        #: which status frames are the truth (parolkit.controller.integrity)
        self.filter = executor.integrity
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._reconnecting = False
        self._reconnect_lock = threading.Lock()
        self._next_reconnect = 0.0
        self._final_frame_sent = False
        self.port_request: str | None = None
        self.last_frame: CommandFrame | None = None
        #: the stop supervisor (stops the board if this process dies), or None
        self.supervisor = supervisor

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        self._supervise()
        self._thread = threading.Thread(target=self._run, name="parolkit-loop", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Stop ticking; then send one DISABLE frame (robot stopped, idle) and close the port."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
        self.executor.cancel_all("controller shutting down")
        try:
            if self.transport.is_open:
                pos = self.status.positions if self.status else (0,) * 6
                last = self.last_frame
                if last is not None and last.command == BoardCommand.JOG and any(last.speeds):
                    self.transport.write(replace(last, speeds=(0,) * 6).encode())
                self.transport.write(CommandFrame(positions=pos, command=BoardCommand.DISABLE).encode())
                self._final_frame_sent = True
        except Exception as exc:
            log.warning("could not send the final DISABLE frame: %s", exc)
        if self.supervisor is not None:
            self.supervisor.close()
        try:
            self.transport.close()
        except Exception as exc:
            log.warning("closing the board link: %s", exc)

    # ------------------------------------------------------------------ link

    def _supervise(self) -> None:
        """Hand the open link's file descriptor to the stop supervisor (started on the first
        link that has one: a serial port; the in-process emulator dies with this process)."""
        sup = self.supervisor
        if sup is None:
            return
        fd = self.transport.fileno() if self.transport.is_open else None
        if fd is None:
            sup.port_closed()
            return
        if sup.state == "off":
            try:
                sup.start()
            except OSError as exc:
                log.error("could not start the stop supervisor: %s", exc)
                return
        sup.port_opened(fd)

    def _lose_link(self, reason: str) -> None:
        if not self.link_up:
            return
        self.link_up = False
        if self.supervisor is not None:
            self.supervisor.port_closed()
        self.stats.link_losses += 1
        log.error("board link lost: %s", reason)
        self.executor.link_lost(reason)
        self._next_reconnect = time.monotonic() + 1.0

    def _reconnect_worker(self) -> None:
        try:
            port = self.port_request
            if port is not None:
                from parolkit.transport import open_transport

                # SET_PORT: keep trying this port until it opens (the server refused any other
                # link already; checked again here)
                new = open_transport(port, allowed_schemes=SET_PORT_SCHEMES)
                if self.port_request == port:
                    self.port_request = None
                try:
                    self.transport.close()
                except Exception:
                    pass
                self.transport = new
            else:
                self.transport.reconnect()
            self.parser.reset()
            self.filter.reset()
            self.status = None
            self._last_status_tick = self.tick_count
            self._alive_tick = self.tick_count
            self._supervise()
            self.link_up = True
            log.warning("board link up again: %s", self.transport.description)
        except (TransportError, OSError) as exc:
            log.info("reconnect failed: %s", exc)
        except Exception as exc:  # never let a reconnect attempt kill anything
            log.warning("reconnect failed: %s", exc)
        finally:
            self._next_reconnect = time.monotonic() + 1.0
            self._reconnecting = False

    def request_port(self, port: str) -> None:
        """SET_PORT: switch the serial port (done by the reconnect helper)."""
        self.port_request = port
        self._lose_link(f"switching to port {port}")
        self._next_reconnect = 0.0

    # ------------------------------------------------------------------ the tick

    def _read(self) -> None:
        try:
            data = self.transport.read()
        except LinkLostError as exc:
            self._lose_link(str(exc) or "link lost")
            return
        except TransportError as exc:
            self._lose_link(str(exc))
            return
        if data:
            for f in self.parser.iter_feed(data):
                self.stats.frames_received += 1
                self._alive_tick = self.tick_count  # any frame proves the link is alive
                if self.filter.accept(f, time.monotonic(), self.parser.stats.bytes_dropped):
                    self.status = f
                    self.last_status = f
                    self._last_status_tick = self.tick_count
                else:
                    self.stats.implausible_frames += 1
            self.stats.bytes_dropped = self.parser.stats.bytes_dropped

    def _compose(self, step: Step) -> CommandFrame:
        ex = self.executor
        st = self.status
        pos = step.positions if step.positions is not None else (
            st.positions if st is not None else (0,) * 6)
        g = ex.gripper
        io = (0x20 if ex.outputs[0] else 0) | (0x10 if ex.outputs[1] else 0)
        return CommandFrame(
            positions=pos, speeds=step.speeds, command=step.command, io=io,
            gripper_position=g.position, gripper_speed=g.speed, gripper_current=g.current,
            gripper_command=g.command, gripper_mode=step.gripper_mode,
        )

    def tick(self, now: float) -> TickOutput:
        """One tick at time ``now`` (monotonic s): read, decide, guard, write.  Returns what
        to publish; the caller advances :attr:`tick_count`."""
        ex = self.executor
        inbox = self.inbox
        if self.supervisor is not None:
            stopped = self.supervisor.poll()
            if stopped is not None:
                log.error("%s", stopped)
                ex.do_disable()
                ex.error = stopped
        if self.link_up:
            self._read()
            if self.link_up and self.tick_count - self._alive_tick >= self.link_timeout_ticks:
                self._lose_link(f"no status frame for {self.tick_count - self._alive_tick} ticks")
        elif not self._reconnecting and now >= self._next_reconnect:
            self._reconnecting = True
            threading.Thread(target=self._reconnect_worker, name="parolkit-reconnect", daemon=True).start()
        commands = inbox.take_safety()
        commands += inbox.take()
        step = ex.tick(tick=self.tick_count, now=now, status=self.status if self.link_up else None,
                       link_up=self.link_up, commands=commands)
        if ex.requested_port is not None:
            port, ex.requested_port = ex.requested_port, None
            self.request_port(port)
        frame = self._write(step, now) if self.link_up else None
        return TickOutput(frame, tuple(ex.take_acks()), self.snapshot())

    def _guarded(self, step: Step, now: float) -> CommandFrame:
        """``step`` as a frame, through the guard.  ``now`` (the tick's time, s) tells the
        guard how long the previous frame ran: a GO TO target may step further after a late
        tick, as far as the board can follow within its maximum speed (guard rules 6, 7)."""
        ex = self.executor
        frame = self._compose(step)
        res = self.guard.check(frame, self.status, estop=ex.estop_latched or ex.estop_pressed,
                               homed=ex.homed, now=now)
        if res.violation is not None:
            log.error("safety guard replaced a %s frame: %s", frame.command, res.violation)
            ex.fail_active(res.violation)
        return res.frame

    def _write(self, step: Step, now: float) -> CommandFrame | None:
        frame = self._guarded(step, now)
        if self.inbox.safety_waiting:
            # ESTOP / STOP / DISABLE arrived while this frame was being made: it goes instead
            frame = self._guarded(self.executor.preempt(self.inbox.take_safety(), tick=self.tick_count, now=now),
                                  now)
        try:
            data = frame.encode()
            t_write = time.perf_counter()
            self.transport.write(data)
            self.filter.sent(frame, time.monotonic())
            self.last_frame = frame
            self.stats.frames_sent += 1
            if self.supervisor is not None:
                self.supervisor.sent(data)
        except (LinkLostError, TransportError) as exc:
            self._lose_link(str(exc) or "write failed")
            return None
        # wait briefly for the reply to measure the round trip and consume it this tick
        deadline = t_write + self.reply_wait
        got = self.stats.frames_received
        while True:
            self._read()
            if not self.link_up or self.stats.frames_received != got:
                if self.link_up:
                    self.stats.rtt.add(time.perf_counter() - t_write)
                break
            if time.perf_counter() >= deadline:
                break
            time.sleep(0.0002)
        return frame

    def snapshot(self) -> Snapshot:
        """The status snapshot as of now (built from this loop's and the executor's state)."""
        transport = self.transport
        board = BoardInfo(self.link_up and self.status is not None,
                          bool(getattr(transport, "simulated", False)), transport.description)
        return build_snapshot(
            self.executor, seq=self.tick_count + 1, time=time.monotonic() - self.start_time,
            link_up=self.link_up, status=self.status, last_status=self.last_status, board=board,
            pose_provider=self.pose_provider, loop_view=self._loop_view, server_view=self.server_view)

    def _loop_view(self) -> dict[str, Any]:
        view = self.stats.view(max_age_s=0.25).as_dict()
        view["supervisor"] = self.supervisor.state if self.supervisor is not None else "off"
        return view

    @staticmethod
    def _raise_priority() -> bool:
        """Ask the OS to prefer the tick thread (nice -10); needs the privilege, else no-op."""
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), -10)
            return True
        except (AttributeError, OSError):
            return False

    def _run(self) -> None:
        if self._raise_priority():
            log.debug("tick thread runs at nice -10")
        period = self.period
        t0 = time.monotonic()
        self.start_time = t0
        k = 0
        last_start: float | None = None
        while not self._stop.is_set():
            deadline = t0 + k * period
            now = time.monotonic()
            if now < deadline:
                time.sleep(deadline - now)
                now = time.monotonic()
            late = now - deadline
            if late > period:
                skipped = int(late // period)
                self.stats.overruns += 1
                k += skipped
            if last_start is not None:
                self.stats.period.add(now - last_start)
            last_start = now
            out: TickOutput | None = None
            try:
                out = self.tick(now)
            except Exception:  # the loop must survive anything
                log.exception("tick %d failed", self.tick_count)
            self.tick_count += 1
            self.stats.ticks = self.tick_count
            if out is not None and self.publish is not None:
                try:
                    self.publish(out)
                except Exception:
                    log.exception("status publication failed")
            self.stats.work.add(time.monotonic() - now)
            k += 1
