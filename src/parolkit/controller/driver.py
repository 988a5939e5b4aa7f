"""The driver: the thin part of the controller that owns the world around the core.

It owns the clock (a fixed-rate, deadline-based tick), the board link (the transport, the
status-frame parser, the short wait for the reply to each frame written, reconnecting), the
planner (plans the core asks for, run in a worker thread, or inline), the stop supervisor
process, and the hand-off from the UDP server (:class:`~parolkit.controller.inbox.CommandInbox`).
Each tick it gathers what happened into a :class:`~parolkit.controller.core.TickInput`, calls
:meth:`ControllerCore.update <parolkit.controller.core.ControllerCore.update>` and carries out
the output: writes the frame (to the board and the stop supervisor), starts the plans, switches
the port, and hands the output to ``publish`` (the snapshot first, then the acks).

Timing: deadlines are ``t0 + k * period`` (no drift).  A tick that starts more than one period
late counts as an overrun and the missed deadlines are skipped (never a burst of catch-up
frames).  Every tick sleeps, at least :data:`MIN_SLEEP_S` when it is already late, so a tick
thread with a real-time policy can never take a core for itself.  The tick thread asks for
SCHED_FIFO (``realtime_priority``), else nice -10, else runs at normal priority; which one it
got is logged once and reported (GET_STATUS ``SCHED=``).  When it got one, the process's other
threads are raised to nice -10 as well: the tick needs the interpreter lock, and a thread
holding it while the OS runs a CPU hog instead would hold the tick up (priority inversion).

Fast-forward: with a simulated board in lockstep with the frames (``sim://?clock=virtual&
step=...``) the board's time is the frames' (one period each), so :meth:`Driver.run_fast`
ticks as soon as the board has answered, with plans made inline: the same frames as a
real-time run, as fast as the machine computes them.

The link is judged by the core (frames left unanswered); the driver reports what only it can
see: the link came up (a reconnect succeeded), or a read or write failed.  A lost link is
reconnected once a second in a helper thread (the tick never blocks on ``open()``).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import replace
from typing import Any

from parolkit.controller.core import ControllerCore, ReplyBatch, TickInput, TickOutput, TickResult, Written
from parolkit.controller.inbox import CommandInbox
from parolkit.controller.messages import (
    SET_PORT_SCHEMES,
    LinkEvent,
    LinkEventKind,
    SupervisorEvent,
    SupervisorEventKind,
)
from parolkit.controller.planning import PlanRequest, PlanResult, plan
from parolkit.controller.scheduling import raise_priority
from parolkit.controller.snapshot import Snapshot
from parolkit.controller.stats import LoopMetrics, LoopStatsView
from parolkit.controller.supervisor import STOPPED_PERIODS, StopSupervisor
from parolkit.controller.world import SceneRequest, SceneResult, build_scene
from parolkit.protocol.frames import CommandFrame
from parolkit.protocol.stream import StatusParser
from parolkit.transport.base import LinkLostError, Transport, TransportError

__all__ = ["Driver", "MIN_SLEEP_S"]

log = logging.getLogger("parolkit.controller")

#: a tick that starts late still sleeps this long (s) before it runs: a SCHED_FIFO thread that
#: never slept would starve everything else on its core
MIN_SLEEP_S = 0.0003
#: the niceness the process's other threads get when the tick thread got a raised priority
HELPER_NICE = -10
#: a tick that starts this late (s) is logged (at most one warning per 10 s)
LATE_WARNING_S = 0.05


class Driver:
    """Owns the transport, the supervisor, the planner and the tick thread around ``core``.

    ``publish(out)`` is called after every tick (tick thread); it must store ``out.snapshot``
    before it sends ``out.acks``.  ``plan_inline``: plans are made in the tick that asks for
    them (deterministic; fast-forward) instead of in a worker thread.  ``server_view``: the UDP
    server's counters, for the status."""

    def __init__(
        self,
        core: ControllerCore,
        transport: Transport,
        *,
        realtime_priority: int = 10,
        raise_process: bool = True,
        inbox: CommandInbox | None = None,
        publish: Callable[[TickOutput], None] | None = None,
        reply_wait_fraction: float = 0.4,
        supervisor: StopSupervisor | None = None,
        plan_inline: bool = False,
        server_view: Callable[[], dict[str, Any]] | None = None,
        safety_intake: Callable[[], None] | None = None,
    ) -> None:
        self.core = core
        self.transport = transport
        self.rate_hz = core.rate_hz
        self.period = core.period
        step_s = getattr(transport, "step_s", None)
        if step_s is not None and abs(step_s * self.rate_hz - 1.0) > 1e-6:
            raise ValueError(f"the simulated board's step ({step_s:g} s per frame) must be the control "
                             f"period (1/{self.rate_hz:g} Hz = {self.period:g} s)")
        #: a simulated board in lockstep with the frames: the link record's clock is its own
        #: time, the tick count x period (a tick that ran early or late gave it one period)
        self.lockstep = step_s is not None
        core.lockstep = self.lockstep
        self.realtime_priority = realtime_priority
        self.raise_process = raise_process
        self._helper_nice = 0
        self.inbox = inbox if inbox is not None else CommandInbox()
        self.publish = publish
        self.server_view = server_view
        #: reads the port's safety socket into the inbox's safety lane (the UDP server's
        #: ``read_safety_socket``): called before the lane is taken and before the frame is written
        self.safety_intake = safety_intake
        self.reply_wait = min(self.period * reply_wait_fraction, 0.003)
        self.stats = LoopMetrics(self.rate_hz)
        self._stats_view: LoopStatsView | None = None
        #: the last :meth:`loop_view` and what it was made from
        self._view_parts: tuple[object, ...] = ()
        self._view: Mapping[str, Any] = {}
        self.parser = StatusParser()
        self.tick_count = 0
        self.start_time = time.monotonic()
        self.scheduling = "not started"
        self.supervisor = supervisor
        self.plan_inline = plan_inline
        self._pool: ThreadPoolExecutor | None = None
        self._plans_done: list[PlanResult] = []
        self._scenes_done: list[SceneResult] = []
        self._plans_lock = threading.Lock()
        #: what the next tick input carries: the frame written, replies read since, link events
        self._written: Written | None = None
        self._batches: list[ReplyBatch] = []
        self._events: list[LinkEvent] = []
        self._events_lock = threading.Lock()
        self.link_up = False
        self._virtual = bool(getattr(transport, "virtual_clock", False))
        #: the port SET_PORT asked for, once the transport is the one opened for it (its link
        #: events say so: the core completes the SET_PORT on that link, not on the old one)
        self._switched_port: str | None = None
        if transport.is_open:
            self._link_up(transport)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._reconnecting = False
        self._next_reconnect = 0.0
        self._final_frame_sent = False
        self.port_request: str | None = None
        self._supervise_lock = threading.Lock()
        self._supervisor_starting = False
        self._next_supervisor_start = 0.0
        self.last_output: TickOutput | None = None
        #: ticks without a snapshot in their output, built when asked (:meth:`snapshot_now`);
        #: only for a driver whose ticks and readers share one thread (fast-forward)
        self.lazy_snapshots = False
        self._snapshot_due: tuple[TickInput, CommandFrame | None] | Snapshot | None = None

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        self.supervise()
        self._thread = threading.Thread(target=self._run, name="parolkit-loop", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Stop ticking; then write the core's final frames (the last motion ended, DISABLE;
        through the guard) and close the port."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
        try:
            if self.transport.is_open and self.link_up:
                t = self._clock(time.monotonic())
                written, self._written = self._written, None
                for frame in self.core.final_frames(t, written):
                    self._write(frame, t)
                self._final_frame_sent = True
        except Exception as exc:
            log.warning("could not send the final DISABLE frame: %s", exc)
        if self.supervisor is not None:
            self.supervisor.close()
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
        try:
            self.transport.close()
        except Exception as exc:
            log.warning("closing the board link: %s", exc)

    def take_acks(self) -> list[Any]:
        """The acks the shutdown produced (the commands it cancelled, a SET_PORT under way)."""
        self.core.cancel_port_switch("controller shutting down")
        return self.core.jobs.take_acks()

    # ------------------------------------------------------------------ the link

    def _link_up(self, transport: Transport) -> None:
        self._virtual = bool(getattr(transport, "virtual_clock", False))
        self.parser.reset()
        self._batches = []
        self._written = None
        self.link_up = True
        self._event(LinkEvent(LinkEventKind.UP, description=transport.description, virtual_clock=self._virtual,
                              simulated=bool(getattr(transport, "simulated", False)), port=self._switched_port))

    def _event(self, ev: LinkEvent) -> None:
        with self._events_lock:
            self._events.append(ev)

    def _link_failed(self, reason: str) -> None:
        """A read or write failed: the link is gone (the next tick tells the core)."""
        if not self.link_up:
            return
        self.link_up = False
        self._event(LinkEvent(LinkEventKind.LOST, reason=reason))
        self._link_down()

    def _link_down(self) -> None:
        if self.supervisor is not None:
            self.supervisor.port_closed()
        self._next_reconnect = time.monotonic() + 1.0

    def supervise(self) -> None:
        """Hand the open link's file descriptor to the stop supervisor (started on the first
        link that has one: a serial port; the in-process emulator dies with this process;
        started again when the last one was lost).  :meth:`start` does it."""
        with self._supervise_lock:
            self._supervise()

    def _supervise(self) -> None:
        sup = self.supervisor
        if sup is None:
            return
        fd = self.transport.fileno() if self.transport.is_open else None
        if fd is None:
            sup.port_closed()
            return
        if sup.state in ("off", "dead") and not sup.start():
            return
        sup.port_opened(fd)

    def _supervisor_events(self, now: float) -> tuple[SupervisorEvent, ...]:
        sup = self.supervisor
        if sup is None:
            return ()
        events = tuple(sup.poll())
        if any(ev.kind is SupervisorEventKind.LOST for ev in events):
            self._next_supervisor_start = now
        if (sup.state == "dead" and self.link_up and not self._supervisor_starting
                and now >= self._next_supervisor_start):
            self._supervisor_starting = True
            threading.Thread(target=self._restart_supervisor, name="parolkit-supervisor-start",
                             daemon=True).start()
        return events

    def _restart_supervisor(self) -> None:
        """(helper thread) Start a new stop supervisor and hand it the port; tried again a
        second later when it fails.  With the link down, the reconnect does it."""
        self._helper_priority()
        try:
            with self._supervise_lock:
                if self.link_up:
                    self._supervise()
        except Exception as exc:  # never let a restart attempt kill anything
            log.error("starting a new stop supervisor failed: %s", exc)
        finally:
            self._next_supervisor_start = time.monotonic() + 1.0
            self._supervisor_starting = False

    def _reconnect_worker(self) -> None:
        self._helper_priority()  # started by the tick thread: do not run with its priority
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
                self._switched_port = port
            else:
                self.transport.reconnect()
            with self._supervise_lock:
                self._supervise()
                self._link_up(self.transport)
            log.warning("board link up again: %s", self.transport.description)
        except (TransportError, OSError) as exc:
            log.info("reconnect failed: %s", exc)
        except Exception as exc:  # never let a reconnect attempt kill anything
            log.warning("reconnect failed: %s", exc)
        finally:
            self._next_reconnect = time.monotonic() + 1.0
            self._reconnecting = False

    # ------------------------------------------------------------------ plans

    def _plan(self, requests: tuple[PlanRequest, ...]) -> None:
        for req in requests:
            if self.plan_inline:
                self._plans_done.append(self._run_plan(req))
                continue
            if self._pool is None:
                self._pool = ThreadPoolExecutor(1, thread_name_prefix="parolkit-planner",
                                                initializer=self._helper_priority)
            self._pool.submit(self._run_plan, req).add_done_callback(self._plan_done)

    @staticmethod
    def _run_plan(req: PlanRequest) -> PlanResult:
        t0 = time.perf_counter()
        r = plan(req)
        return replace(r, seconds=time.perf_counter() - t0)

    def _plan_done(self, fut: Future[PlanResult]) -> None:
        try:
            r = fut.result()
        except Exception:  # (plan() catches every planning error itself)
            log.exception("a planner task failed")
            return
        with self._plans_lock:
            self._plans_done.append(r)

    def _build_scenes(self, requests: tuple[SceneRequest, ...]) -> None:
        """Collision scenes the core asked for (:func:`parolkit.controller.world.build_scene`,
        cached by world): in the planner's worker, or inline; the answers reach the next tick."""
        for req in requests:
            if self.plan_inline:
                self._scenes_done.append(self._run_scene(req))
                continue
            if self._pool is None:
                self._pool = ThreadPoolExecutor(1, thread_name_prefix="parolkit-planner",
                                                initializer=self._helper_priority)
            self._pool.submit(self._run_scene, req).add_done_callback(self._scene_done)

    @staticmethod
    def _run_scene(req: SceneRequest) -> SceneResult:
        t0 = time.perf_counter()
        r = build_scene(req)
        return replace(r, seconds=time.perf_counter() - t0)

    def _scene_done(self, fut: Future[SceneResult]) -> None:
        try:
            r = fut.result()
        except Exception:  # (build_scene catches every error itself)
            log.exception("a scene task failed")
            return
        with self._plans_lock:
            self._scenes_done.append(r)

    def _take_scenes(self) -> tuple[SceneResult, ...]:
        with self._plans_lock:
            done, self._scenes_done = self._scenes_done, []
        return tuple(done)

    def plan_ahead(self, req: PlanRequest) -> None:
        """(any thread) Start planning ``req`` now: the UDP server's plan ahead of the tick for
        a motion command that reached an idle robot (its result reaches the core by its key)."""
        self._plan((req,))

    def _take_plans(self) -> tuple[PlanResult, ...]:
        with self._plans_lock:
            done, self._plans_done = self._plans_done, []
        return tuple(done)

    # ------------------------------------------------------------------ the tick

    def _clock(self, now: float) -> float:
        """The link record's clock at ``now``: ``now`` (monotonic s), or with a board in lockstep
        with the frames, that board's own time, the tick count x period."""
        return self.tick_count * self.period if self.lockstep else now

    def _read(self, t: float, *, after_write: bool) -> int:
        """Read what the board sent; returns how many status frames (kept for the next tick)."""
        try:
            data = self.transport.read()
        except (LinkLostError, TransportError) as exc:
            self._link_failed(str(exc) or "link lost")
            return 0
        if not data:
            return 0
        frames = self.parser.feed(data)
        if frames:
            wall = time.monotonic()
            self._batches.append(ReplyBatch(tuple(frames), t if self._virtual else wall, wall, after_write,
                                            self.parser.stats.bytes_dropped))
        return len(frames)

    def _write(self, frame: CommandFrame, t: float) -> float | None:
        """Write ``frame`` (to the stop supervisor too); the next tick tells the core.  Returns
        the write time (``perf_counter``), None when the write failed."""
        data = frame.encode()
        # the clock before the write: the board cannot take the frame in earlier, and a tick
        # thread held up inside or after the write must not make the frame look written late
        # (the integrity check would read a stall of the board's timer into that time)
        wall = time.monotonic()
        t_write = time.perf_counter()
        try:
            self.transport.write(data)
        except (LinkLostError, TransportError) as exc:
            self._link_failed(str(exc) or "write failed")
            return None
        self._written = Written(frame, t, wall)
        self.stats.frames_sent += 1
        if self.supervisor is not None:
            self.supervisor.sent(data)
        return t_write

    def _input(self, now: float, t: float) -> TickInput:
        with self._events_lock:
            events, self._events = tuple(self._events), []
        written, self._written = self._written, None
        batches, self._batches = tuple(self._batches), []
        if self.safety_intake is not None:
            self.safety_intake()
        subs = self.inbox.take_safety()
        subs += self.inbox.take()
        return TickInput(self.tick_count, t, time.monotonic(), written=written, replies=batches,
                         submissions=tuple(subs), plans=self._take_plans(), scenes=self._take_scenes(), links=events,
                         supervisor=self._supervisor_events(now), loop_stats=self.loop_view(),
                         server_stats=self.server_view() if self.server_view is not None else {},
                         snapshot=not self.lazy_snapshots)

    def snapshot_now(self) -> Snapshot | None:
        """The latest tick's snapshot when it was made without one (:attr:`lazy_snapshots`):
        built now, once; None if that tick had one (or there was no tick)."""
        due = self._snapshot_due
        if due is None:
            return None
        if isinstance(due, tuple):
            due = self._snapshot_due = self.core.snapshot_now(*due)
        return due

    def tick(self, now: float) -> TickOutput:
        """One tick at time ``now`` (monotonic s): gather, update the core, write, wait briefly
        for the reply.  Returns what to publish; the caller advances :attr:`tick_count`."""
        t = self._clock(now)
        if self.link_up:
            self._read(t, after_write=False)
        elif not self._reconnecting and now >= self._next_reconnect:
            self._reconnecting = True
            threading.Thread(target=self._reconnect_worker, name="parolkit-reconnect", daemon=True).start()
        inp = self._input(now, t)
        self._snapshot_due = None
        out = self.core.update(inp)
        if out.frame is not None and out.result is TickResult.FRAME:
            if self.safety_intake is not None:
                self.safety_intake()
            if self.inbox.safety_waiting:
                # ESTOP / STOP / DISABLE arrived while this frame was being made: it goes instead
                inp = TickInput(self.tick_count, t, time.monotonic(), submissions=tuple(self.inbox.take_safety()),
                                recompose=True, loop_stats=inp.loop_stats, server_stats=inp.server_stats,
                                snapshot=inp.snapshot)
                again = self.core.update(inp)
                out = replace(again, acks=out.acks + again.acks,
                              plan_requests=out.plan_requests + again.plan_requests,
                              scene_requests=out.scene_requests + again.scene_requests)
        self._plan(out.plan_requests)
        self._build_scenes(out.scene_requests)
        if out.port_request is not None:
            self.port_request = out.port_request
            self._next_reconnect = 0.0
        if out.frame is not None and self.link_up:
            t_write = self._write(out.frame, t)
            if t_write is not None and out.result is TickResult.FRAME:
                self._reply_wait(t, t_write)
        if out.result is TickResult.LINK_LOST and self.link_up:
            self.link_up = False
            self._link_down()
            if out.port_request is not None:
                self._next_reconnect = 0.0
        if out.snapshot is None:
            self._snapshot_due = (inp, out.frame)
        self.last_output = out
        return out

    def _reply_wait(self, t: float, t_write: float) -> None:
        """Wait briefly for the reply to the frame just written (the round trip), so that it
        reaches the next tick's input as the answer to this frame."""
        deadline = t_write + self.reply_wait
        while True:
            got = self._read(t, after_write=True)
            if not self.link_up or got:
                if self.link_up:
                    self.stats.rtt.add(time.perf_counter() - t_write)
                return
            if time.perf_counter() >= deadline:
                return
            time.sleep(0.0002)

    def run_fast(self, ticks: int, *, until: Callable[[TickOutput], bool] | None = None) -> TickOutput | None:
        """Fast-forward (a board in lockstep with the frames, plans inline): ``ticks`` ticks, or
        until ``until(output)``, as fast as the board answers; no sleeping, no wall-clock
        deadlines.  Returns the last output."""
        if not (self.lockstep and self.plan_inline):
            raise ValueError("fast-forward needs a simulated board in lockstep with the frames "
                             "(sim://?clock=virtual&step=...) and plan_inline=True")
        out = None
        for _ in range(ticks):
            out = self.tick(time.monotonic())
            self.tick_count += 1
            self.stats.ticks = self.tick_count
            if self.publish is not None:
                self.publish(out)
            if until is not None and until(out):
                break
        return out

    def loop_view(self) -> Mapping[str, Any]:
        """The loop statistics with the stop supervisor's state, process id (None: none
        started), restarts, scheduling and limits: a stopped controller is stopped after
        ``supervisor_stopped_ms`` without a frame, a running one after ``supervisor_stall_ms``
        (0: never).  The same mapping while none of that changed: read it, do not change it."""
        stats = self.stats.view(max_age_s=0.25)
        sup = self.supervisor
        parts = ((sup.state, sup.pid, sup.restarts, sup.scheduling, round(STOPPED_PERIODS * sup.period_s * 1e3, 3),
                  round(sup.stall_s * 1e3, 3)) if sup is not None else ("off", None, 0, "off", 0.0, 0.0))
        if stats is self._stats_view and parts == self._view_parts:
            return self._view  # (a view is reused for 0.25 s: so is the dict made from it)
        view = stats.as_dict()
        view.update(zip(("supervisor", "supervisor_pid", "supervisor_restarts", "supervisor_scheduling",
                         "supervisor_stopped_ms", "supervisor_stall_ms"), parts))
        self._stats_view, self._view_parts, self._view = stats, parts, view
        return view

    #: SCHED_FIFO at a priority, else nice -10, for the calling thread (:mod:`.scheduling`)
    raise_priority = staticmethod(raise_priority)

    @staticmethod
    def raise_other_threads(nice: int = HELPER_NICE) -> int:
        """Every other thread of this process to ``nice`` where the OS allows it (Linux: per
        thread); returns how many.  The tick thread needs the interpreter lock that any of them
        may hold: one that holds it while the OS runs a CPU hog instead holds the tick up (a
        real-time tick thread waited 100-300 ms that way under two hogs)."""
        me = threading.get_native_id()
        try:
            tids = [int(t) for t in os.listdir("/proc/self/task")]
        except OSError:
            return 0
        done = 0
        for tid in tids:
            if tid == me:
                continue
            try:
                os.setpriority(os.PRIO_PROCESS, tid, nice)
                done += 1
            except (AttributeError, OSError):
                pass
        return done

    def _helper_priority(self) -> None:
        """A thread the tick thread started (threads inherit their creator's policy): back to
        SCHED_OTHER, at the other threads' nice."""
        tid = threading.get_native_id()
        try:
            if os.sched_getscheduler(tid) != os.SCHED_OTHER:
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
            os.setpriority(os.PRIO_PROCESS, tid, self._helper_nice)
        except (AttributeError, OSError):
            pass

    def _run(self) -> None:
        self.scheduling = self.stats.scheduling = self.raise_priority(self.realtime_priority)
        others = self.raise_other_threads() if self.raise_process and self.scheduling != "normal" else 0
        if others:
            self._helper_nice = HELPER_NICE
        if self.scheduling == "normal":
            log.warning("tick thread runs at normal priority: the OS granted neither SCHED_FIFO nor "
                        "nice -10 (late ticks under load are caught up, not prevented)")
        else:
            log.info("tick thread scheduling: %s; %d other threads at nice %d", self.scheduling, others,
                     self._helper_nice)
        period = self.period
        t0 = time.monotonic()
        self.start_time = t0
        k = 0
        last_start: float | None = None
        next_late_warning = 0.0
        while not self._stop.is_set():
            deadline = t0 + k * period
            now = time.monotonic()
            # always sleep: to the deadline, or a little when already late (a real-time thread
            # that never slept would take its core from everything else)
            time.sleep(max(deadline - now, MIN_SLEEP_S))
            now = time.monotonic()
            late = now - deadline
            self.stats.lateness.add(max(0.0, late))
            if late > period:
                skipped = int(late // period)
                self.stats.overruns += 1
                k += skipped
                if late > LATE_WARNING_S and now >= next_late_warning:
                    next_late_warning = now + 10.0
                    log.warning("tick %d started %.1f ms late (%s; the missed deadlines are skipped, "
                                "the motion catches up)", self.tick_count, late * 1e3, self.scheduling)
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
