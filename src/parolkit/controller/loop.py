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

Timing: deadlines are ``t0 + k * period`` (no drift).  A tick that starts more than one period
late counts as an overrun and the missed deadlines are skipped (never a burst of catch-up
frames); the activities catch up instead: they play the sample due at the time the tick
actually runs (:mod:`parolkit.controller.pacing`), so a late tick does not stretch a move.
Every tick sleeps, at least :data:`MIN_SLEEP_S` when it is already late, so a tick thread
with a real-time policy can never take a core for itself.  The tick thread asks for
SCHED_FIFO (``realtime_priority``), else nice -10, else runs at normal priority; which one
it got is logged once and reported (GET_STATUS ``SCHED=``, ``scheduling`` in the status
object and the loop statistics).  When it got one, the process's other threads are raised to
nice -10 as well: the tick needs the interpreter lock, and a thread holding it while the OS
runs a CPU hog instead would hold the tick up (priority inversion; under two hogs a
SCHED_FIFO tick waited 100-300 ms that way).

Link supervision is judged by frames the board left unanswered, never by the controller's
own late ticks.  The board answers every frame it accepts with exactly one status frame, so
the loop counts the frames written since the last structurally valid status frame arrived
(one the plausibility filter rejects still proves that the board answered; a reply read at
the start of the next tick, after the short reply wait, still answers).  A stalled
controller writes nothing, so it never counts against the board.  When replies go missing:

* after ``link_hold_frames`` (default 2) unanswered frames in a row, running motion is
  paused: the board is told to stop (the firmware runs its last command forever, so it must
  be told, not left alone): a zero-speed 123 after a speed stream, the last 156 target with
  zero feed-forward after a position stream, every tick, while the activity is not stepped
  and new commands are refused.  The controller cannot see the board meanwhile (not even an
  E-stop press), so nothing moves.  When replies come back the motion goes on: the activity
  knows the board stopped (:meth:`~parolkit.controller.jobs.Activity.held`) and catches up as
  after a late tick (a JOG still covers its distance, a timed move keeps its time where the
  board's speed allows);
* after ``link_timeout_ticks`` (default 50) unanswered frames in a row the link is lost:
  motion is cancelled (never resumed), the error is latched, and if the last frame written
  still commanded motion (the pause switched off by ``link_hold_frames`` =
  ``link_timeout_ticks``) its stop frame is written first (best effort), so the board is
  never left running a speed; then no frame is written until a reconnect, tried once a second
  in a helper thread (the tick never blocks on ``open()``).  A transport error (the port
  vanished) loses the link at once.

The pause is what makes the robot safe, within 2 ticks; the loss only decides when to give
up, and waits for longer than the operating system takes, under load, to deliver replies
that were sent in time (a loaded Linux PC's tty layer held them back 20-300 ms; a raw pty
echo between two SCHED_FIFO processes under two CPU hogs showed the same).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from parolkit.controller.executor import SET_PORT_SCHEMES, Executor
from parolkit.controller.guard import SafetyGuard
from parolkit.controller.inbox import Ack, CommandInbox
from parolkit.controller.jobs import Step
from parolkit.controller.link import LinkHistory
from parolkit.controller.scheduling import raise_priority
from parolkit.controller.state import BoardInfo, PoseProvider, Snapshot, build_snapshot
from parolkit.controller.stats import LoopMetrics
from parolkit.controller.supervisor import STOPPED_PERIODS, StopSupervisor, SupervisorEventKind
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.protocol.stream import StatusParser
from parolkit.robot import goto_goal
from parolkit.transport.base import LinkLostError, Transport, TransportError

__all__ = ["ControlLoop", "TickOutput", "MIN_SLEEP_S"]

log = logging.getLogger("parolkit.controller")

#: a tick that starts late still sleeps this long (s) before it runs: a SCHED_FIFO thread that
#: never slept would starve everything else on its core
MIN_SLEEP_S = 0.0003
#: the niceness the process's other threads get when the tick thread got a raised priority
HELPER_NICE = -10
#: a tick that starts this late (s) is logged (at most one warning per 10 s)
LATE_WARNING_S = 0.05


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
        link_hold_frames: int = 2,
        realtime_priority: int = 10,
        raise_process: bool = True,
        inbox: CommandInbox | None = None,
        publish: Callable[[TickOutput], None] | None = None,
        pose_provider: PoseProvider | None = None,
        reply_wait_fraction: float = 0.4,
        supervisor: StopSupervisor | None = None,
    ) -> None:
        self.transport = transport
        self.executor = executor
        self.guard = guard
        # a simulated board in lockstep with the frames (sim://?clock=virtual&step=...) runs
        # one period per frame: trajectories follow its time, the tick count
        step_s = getattr(transport, "step_s", None)
        if step_s is not None and abs(step_s * rate_hz - 1.0) > 1e-6:
            raise ValueError(f"the simulated board's step ({step_s:g} s per frame) must be the control "
                             f"period (1/{rate_hz:g} Hz = {1.0 / rate_hz:g} s)")
        executor.tick_clock = step_s is not None
        #: the board's time stands still between ticks (a simulated board on a virtual clock):
        #: a reply read in a tick was produced at that tick's time
        self._virtual = bool(getattr(transport, "virtual_clock", False))
        #: the one record of the link: frames written, which reply answered which, the newest
        #: trusted reply (parolkit.controller.link)
        self.link = LinkHistory()
        #: this tick's time on the link record's clock (see _guard_time)
        self._tick_t = 0.0
        self.rate_hz = rate_hz
        self.period = 1.0 / rate_hz
        if not 1 <= link_hold_frames <= link_timeout_ticks:
            raise ValueError(f"link_hold_frames must be 1..link_timeout_ticks ({link_timeout_ticks}), "
                             f"got {link_hold_frames}")
        #: unanswered frames in a row that lose the link / stop a speed stream first
        self.link_timeout_ticks = link_timeout_ticks
        self.link_hold_frames = link_hold_frames
        self.realtime_priority = realtime_priority
        #: also raise the process's other threads (:meth:`raise_other_threads`) when it starts
        self.raise_process = raise_process
        self._helper_nice = 0
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
        #: replies went missing during motion (at least link_hold_frames in a row): counted and
        #: logged; every frame being a bounded commitment, the motion holds by itself (its
        #: goals cannot advance past what the last trusted reply allows)
        self.holding = False
        self._holds_unlogged = 0
        self._next_hold_log = 0.0
        #: the tick thread's scheduling ("fifo:10", "nice:-10", "normal"), set when it starts
        self.scheduling = "not started"
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
        self._supervise_lock = threading.Lock()
        self._supervisor_starting = False
        self._next_supervisor_start = 0.0

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        self.supervise()
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
                # through the guard like every frame; the outputs and gripper setpoints stay
                # (a part held is not dropped), as the stop supervisor leaves them
                t = self._tick_t if self._virtual else self._guard_time(time.monotonic())
                stop = self.stop_step(self.last_frame)
                if stop is not None:
                    self._send(self._guarded(stop, t), t)
                self._send(self._guarded(Step(BoardCommand.DISABLE), t), t)
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

    def supervise(self) -> None:
        """Hand the open link's file descriptor to the stop supervisor (started on the first
        link that has one: a serial port; the in-process emulator dies with this process;
        started again when the last one was lost).  :meth:`start` does it."""
        with self._supervise_lock:
            self._supervise()

    def _supervise(self) -> None:
        """:meth:`supervise` with :attr:`_supervise_lock` held (the reconnect helper and the
        supervisor's restart helper may run at once)."""
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

    def _watch_supervisor(self, sup: StopSupervisor, now: float) -> None:
        """(tick) Take in what the stop supervisor reported; start a new one when it is lost."""
        ex = self.executor
        for ev in sup.poll():
            if ev.kind is SupervisorEventKind.STOPPED:
                log.error("%s", ev.text)
                ex.do_disable()
                ex.error = ev.text
                # the board ran on while this process stood still, then the supervisor stopped
                # it: what the next replies show was done behind the integrity check's back, not
                # against the frames it saw written (judged so, a jog that ran on for the stall
                # read as "uncommanded motion" and hid the supervisor's report); the truth
                # starts afresh from two agreeing frames, as after a new link
                self.filter.reset()
            elif ev.kind is SupervisorEventKind.LOST:
                ex.supervisor_lost(ev.text)
                self._next_supervisor_start = now
            elif ev.kind is SupervisorEventKind.READY:
                if ex.supervisor_missing is not None:
                    log.warning("a new stop supervisor is ready (pid %s, %s): motion is accepted again",
                                sup.pid, ev.text)
                ex.supervisor_ready()
        if (sup.state == "dead" and self.link_up and not self._supervisor_starting
                and now >= self._next_supervisor_start):
            self._supervisor_starting = True
            threading.Thread(target=self._restart_supervisor, name="parolkit-supervisor-start",
                             daemon=True).start()

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

    def _lose_link(self, reason: str, *, may_write: bool = True) -> None:
        """The link is lost: cancel motion, latch the error and, if the last frame written still
        commands motion and ``may_write``, write its stop frame first (best effort)."""
        if not self.link_up:
            return
        if may_write:
            self._write_stop()
        self.link_up = False
        self.holding = False
        if self.supervisor is not None:
            self.supervisor.port_closed()
        self.stats.link_losses += 1
        log.error("board link lost: %s", reason)
        self.executor.link_lost(reason)
        self._next_reconnect = time.monotonic() + 1.0

    @staticmethod
    def stop_step(last: CommandFrame | None) -> Step | None:
        """The frame that ends what ``last`` commanded, or None when nothing needs ending: 123
        with a speed (the start-up probe's) -> the same with zero speeds; 156 with a
        feed-forward -> its goal rounded to whole steps, with none.  (A GO TO stops at its goal
        by itself, a bounded commitment; but a goal between two steps keeps the joint stepping
        to and fro across it, one step each way, until the next frame.)"""
        if last is None or not any(last.speeds):
            return None
        if last.command == BoardCommand.JOG:
            return Step(BoardCommand.JOG, last.positions, (0,) * 6)
        if last.command == BoardCommand.GOTO:
            return Step(BoardCommand.GOTO, tuple(int(round(g)) for g in goto_goal(last.positions, last.speeds)),
                        (0,) * 6)
        return None

    def _write_stop(self) -> None:
        """Write the stop frame of the last frame (guarded like any frame), if it needs one."""
        step = self.stop_step(self.last_frame)
        if step is None or not self.transport.is_open:
            return
        t = self._tick_t if self._virtual else self._guard_time(time.monotonic())
        try:
            self._send(self._guarded(step, t), t)
        except Exception as exc:  # the link is going away anyway
            log.warning("could not write the stop frame before declaring the link lost: %s", exc)

    @property
    def unanswered(self) -> int:
        """Frames written since the last structurally valid status frame arrived."""
        return self.link.unanswered

    def _hold(self, now: float) -> None:
        """Replies went missing during motion: counted and logged (the motion holds by itself)."""
        self.holding = True
        self.stats.link_holds += 1
        self._holds_unlogged += 1
        if now >= self._next_hold_log:
            self._next_hold_log = now + 10.0
            log.warning("the board left %d frames in a row unanswered: motion holds at its last goal "
                        "(%d such pause(s) since the last report; the link counts as lost after %d)",
                        self.unanswered, self._holds_unlogged, self.link_timeout_ticks)
            self._holds_unlogged = 0

    def _judge_link(self, now: float) -> None:
        """Judge the link by the frames the board left unanswered (see the module docstring)."""
        u = self.unanswered
        if u > self.stats.unanswered_max:
            self.stats.unanswered_max = u
        if u >= self.link_timeout_ticks:
            self._lose_link(f"the board left {u} frames in a row unanswered")
        elif u >= self.link_hold_frames and not self.holding:
            act = self.executor.activity
            if act is not None and act.moves:
                self._hold(now)

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
            else:
                self.transport.reconnect()
            self.parser.reset()
            self.filter.reset()
            self.link.reset()
            self._virtual = bool(getattr(self.transport, "virtual_clock", False))
            self.status = None
            self._last_status_tick = self.tick_count
            self.holding = False
            with self._supervise_lock:
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

    def _read(self, *, after_write: bool = False) -> None:
        """Read and judge every status frame the board sent.  ``after_write``: in the reply wait
        of the frame just written (the last reply there answers that frame, the ones before it
        the frames before; anything older still missing was lost).  A reply read at the start
        of a tick came late and answers the oldest frame still unanswered (the board answers
        in order; replies the OS held back arrive several at once): the integrity check is
        told which one."""
        try:
            data = self.transport.read()
        except LinkLostError as exc:
            self._lose_link(str(exc) or "link lost", may_write=False)
            return
        except TransportError as exc:
            self._lose_link(str(exc), may_write=False)
            return
        if data:
            frames = self.parser.feed(data)
            # when it was read, on the link record's clock: a board on a virtual clock
            # produced it in this tick's time; a real one before this moment
            t_read = self._tick_t if self._virtual else time.monotonic()
            for i, f in enumerate(frames):
                self.stats.frames_received += 1
                answers = self.link.answered(len(frames), i, after_write=after_write)
                self.holding = False
                if self.filter.accept(f, time.monotonic(), self.parser.stats.bytes_dropped, answers):
                    self.status = f
                    self.last_status = f
                    self._last_status_tick = self.tick_count
                    self.link.trust(answers, f, t_read)
                else:
                    self.stats.implausible_frames += 1
                self.link.homing = self.filter.homing
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

    def _motion_bounds(self) -> tuple[list[tuple[float, float]] | None, list[float] | None]:
        """This tick's goals the guard allows for a GO TO frame, and where a new motion starts:
        the goal of the last frame if it was a GO TO (the board is on its way there), else
        the trusted position."""
        box = self.guard.goal_box(self.link, self._tick_t)
        last = self.link.last
        if last is not None and last.command == BoardCommand.GOTO:
            return box, goto_goal(last.positions, last.speeds)
        st = self.status
        return box, [float(p) for p in st.positions] if st is not None else None

    def tick(self, now: float) -> TickOutput:
        """One tick at time ``now`` (monotonic s): read, decide, guard, write.  Returns what
        to publish; the caller advances :attr:`tick_count`."""
        ex = self.executor
        inbox = self.inbox
        self._tick_t = self._guard_time(now)
        if self.supervisor is not None:
            self._watch_supervisor(self.supervisor, now)
        if self.link_up:
            self._read()
            if self.link_up:
                self._judge_link(now)
        elif not self._reconnecting and now >= self._next_reconnect:
            self._reconnecting = True
            threading.Thread(target=self._reconnect_worker, name="parolkit-reconnect", daemon=True).start()
        commands = inbox.take_safety()
        commands += inbox.take()
        up = self.link_up
        box, origin = self._motion_bounds() if up else (None, None)
        step = ex.tick(tick=self.tick_count, now=now, status=self.status if up else None,
                       link_up=up, commands=commands, box=box, origin=origin,
                       replies_missing=self.unanswered if self.holding else 0)
        if ex.requested_port is not None:
            port, ex.requested_port = ex.requested_port, None
            self.request_port(port)
        frame = self._write(step, now) if self.link_up else None
        return TickOutput(frame, tuple(ex.take_acks()), self.snapshot())

    def _guard_time(self, now: float) -> float:
        """The time the guard judges frame intervals on: ``now``, or with a board in lockstep
        with the frames (executor.tick_clock) that board's own time, the tick count x period
        (a tick that ran early or late gave it no more and no less than one period)."""
        return self.tick_count * self.period if self.executor.tick_clock else now

    def _guarded(self, step: Step, t_write: float) -> CommandFrame:
        """``step`` as a frame, through the guard; ``t_write``: when it is written, on the link
        record's clock."""
        ex = self.executor
        frame = self._compose(step)
        res = self.guard.check(frame, self.link, self.status, estop=ex.estop_latched or ex.estop_pressed,
                               homed=ex.homed, t_write=t_write)
        if res.violation is not None:
            log.error("safety guard replaced a %s frame: %s", frame.command, res.violation)
            ex.fail_active(res.violation)
        return res.frame

    def _send(self, frame: CommandFrame, t_link: float) -> float:
        """Write ``frame`` and tell whoever keeps count (the link record, the integrity check,
        the stop supervisor); ``t_link``: the write time on the link record's clock.  Returns
        the write time (``perf_counter``)."""
        data = frame.encode()
        t_write = time.perf_counter()
        self.transport.write(data)
        n = self.link.sent(frame, t_link)
        self.filter.sent(frame, time.monotonic(), n)
        self.last_frame = frame
        self.stats.frames_sent += 1
        if self.supervisor is not None:
            self.supervisor.sent(data)
        return t_write

    def _write(self, step: Step, now: float) -> CommandFrame | None:
        g = self._guard_time(now)
        frame = self._guarded(step, g)
        if self.inbox.safety_waiting:
            # ESTOP / STOP / DISABLE arrived while this frame was being made: it goes instead
            frame = self._guarded(self.executor.preempt(self.inbox.take_safety(), tick=self.tick_count, now=now),
                                  g)
        try:
            t_write = self._send(frame, g)
        except (LinkLostError, TransportError) as exc:
            self._lose_link(str(exc) or "write failed", may_write=False)
            return None
        # wait briefly for the reply to measure the round trip and consume it this tick
        deadline = t_write + self.reply_wait
        got = self.stats.frames_received
        while True:
            self._read(after_write=True)
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
            pose_provider=self.pose_provider, loop_view=self.loop_view, server_view=self.server_view,
            sent=self.last_frame if self.link_up else None)

    def loop_view(self) -> dict[str, Any]:
        """The loop statistics with the stop supervisor's state, process id (None: none
        started), restarts, scheduling and limits: a stopped controller is stopped after
        ``supervisor_stopped_ms`` without a frame, a running one after ``supervisor_stall_ms``
        (0: never)."""
        view = self.stats.view(max_age_s=0.25).as_dict()
        sup = self.supervisor
        view["supervisor"] = sup.state if sup is not None else "off"
        view["supervisor_pid"] = sup.pid if sup is not None else None
        view["supervisor_restarts"] = sup.restarts if sup is not None else 0
        view["supervisor_scheduling"] = sup.scheduling if sup is not None else "off"
        view["supervisor_stopped_ms"] = round(STOPPED_PERIODS * sup.period_s * 1e3, 3) if sup is not None else 0.0
        view["supervisor_stall_ms"] = round(sup.stall_s * 1e3, 3) if sup is not None else 0.0
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
