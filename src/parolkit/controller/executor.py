"""Command queue, planner worker and the active job; every ack after QUEUED comes from here.

Threads and ownership:

* the **loop thread** calls :meth:`tick` once per tick with the commands the server handed
  over (:class:`~parolkit.controller.inbox.Submission`, safety commands first): it applies
  them (immediate commands at once, the rest queued), activates the next job when its plan is
  ready and asks the active activity for this tick's frame.  Every ack is collected, never
  sent from here: the loop takes them with :meth:`take_acks` and sends them only after it
  published the snapshot that shows what they report;
* the **planner thread** plans queued motion jobs ahead of time, each from the final joints of
  the job before it (or from the measured joints when nothing is ahead), and CARTJOG streams;
* any thread may read the views (:meth:`queue_view`, :meth:`plan_view`).

Planning never happens in the tick.  A job whose plan assumed a start the robot is not at (a
jog or a speed-tracked move ended elsewhere) is sent back to the planner; the loop holds still
until the new plan is ready.
"""

from __future__ import annotations

import importlib
import logging
import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from queue import Empty, SimpleQueue
from types import ModuleType
from typing import Any

from parolkit.controller.inbox import Ack, Submission
from parolkit.controller.integrity import BoardProbe, StatusIntegrity
from parolkit.controller.jobs import (
    Activity,
    DelayActivity,
    GripperCalibrateActivity,
    HomeActivity,
    Job,
    OneShotActivity,
    OutputActivity,
    PlanAhead,
    SpeedActivity,
    Step,
    TickContext,
    TrajectoryActivity,
    WaitInputActivity,
    ticks_for,
)
from parolkit.protocol import commands as C
from parolkit.protocol.commands import AckStatus
from parolkit.protocol.frames import BoardCommand, GripperCommandBits, GripperMode, IOBits, StatusFrame
from parolkit.robot import JOINT_NAMES, RobotModel

__all__ = ["Executor", "START_TOLERANCE_DEG", "SAFETY_COMMANDS", "SET_PORT_SCHEMES"]

log = logging.getLogger("parolkit.controller")

#: commands that take the safety lane: applied before anything else, whatever the traffic
SAFETY_COMMANDS = (C.EStop, C.Stop, C.Disable)
#: the links SET_PORT may switch to: a serial device only (a datagram must not choose the
#: emulator, or a spy+ link that writes files)
SET_PORT_SCHEMES = frozenset({"serial"})

#: a planned move may start this far (deg, any joint) from the measured joints
START_TOLERANCE_DEG = 0.5
#: ELECTRICGRIPPER|calibrate FAILS if the gripper has not reported calibrated by then (the
#: emulated SSG-48 takes 1 s, the seed waits 2-3 s after Gripper_cal(), the original
#: controller's calibrate returned after about 3 s), s
GRIPPER_CALIBRATE_TIMEOUT_S = 5.0
#: a position-tracked move FAILS if the board has not reported its exact target (at rest) this
#: long after the last sample (a few ticks are normal: the GO TO loop closes the last steps at
#: 50 steps/s per step of error); a speed-tracked one ends then anyway, s
SETTLE_TIMEOUT_S = 1.0
#: PNEUMATICGRIPPER FAILS if the board has not reported the new output level by then, s
OUTPUT_REPORT_TIMEOUT_S = 0.5
#: how many queued jobs the planner plans ahead
PLAN_AHEAD = 4
#: a HOME whose board shows no homing within this time FAILS (a disabled board ignores it), s
HOME_START_TIMEOUT_S = 0.5
#: default travel of one jog press (JOG / MULTIJOG, or one held streamed jog) before homing, deg
UNHOMED_JOG_TRAVEL_DEG = 20.0

_TRAJECTORY_COMMANDS = (
    C.MoveJoint, C.MoveJointPath, C.MovePose, C.MoveCart, C.MoveCartRelTRF, C.CartJogCommand, C.SmoothCircle,
    C.SmoothArcCenter, C.SmoothArcParam, C.SmoothSpline, C.SmoothHelix, C.SmoothBlend,
)
_SPEED_COMMANDS = (C.Jog, C.MultiJog, C.SpeedJoint)
_STREAMABLE = (C.Jog, C.MultiJog, C.CartJogCommand)


def needs_plan(cmd: C.Command) -> bool:
    return isinstance(cmd, _TRAJECTORY_COMMANDS)


@dataclass
class GripperSetpoint:
    """Persistent SSG-48 setpoints sent in every frame."""

    position: int = 0
    speed: int = 0
    current: int = 0
    command: int = 0


class Executor:
    """The queue and the active job.  See the module docstring for the threading rules."""

    def __init__(
        self,
        *,
        model: RobotModel,
        rate_hz: float,
        queue_size: int,
        watchdog_s: float,
        tool_provider: Callable[[], object] | None = None,
        homing_timeout_s: float = 180.0,
        homing_speedup: float = 1.0,
        unhomed_jog_travel_deg: float = UNHOMED_JOG_TRAVEL_DEG,
    ) -> None:
        if not unhomed_jog_travel_deg > 0.0:
            raise ValueError(f"unhomed_jog_travel_deg must be > 0 deg, got {unhomed_jog_travel_deg!r}")
        self.model = model
        self.rate_hz = rate_hz
        self.queue_size = queue_size
        self.watchdog_s = watchdog_s
        self.tool_provider = tool_provider or (lambda: None)
        self.homing_timeout_s = homing_timeout_s
        #: how much faster than real time the board homes (a simulated board; 1 on a serial link)
        self.homing_speedup = homing_speedup
        self.unhomed_jog_travel_deg = float(unhomed_jog_travel_deg)
        self._lock = threading.RLock()
        self._plan_cv = threading.Condition(self._lock)
        self.queue: deque[Job] = deque()
        self.active: Job | None = None
        self.activity: Activity | None = None
        #: acks produced since the loop last took them (any thread appends, under the lock)
        self._acks: list[Ack] = []
        #: the plan started ahead by the server (see PlanAhead) until it is done; one at a time
        self._ahead: PlanAhead | None = None
        self._ahead_todo = False
        #: streamed CARTJOG jobs the planner finished, for the loop to switch to
        self._planned_streams: SimpleQueue[Job] = SimpleQueue()
        #: the tool in use (name, and its kinematics object once resolved)
        self.tool_name = "default"
        self.tool_obj: object | None = None
        #: SET_PORT accepted: the port the loop should switch to (the loop clears it)
        self.requested_port: str | None = None
        #: receive number of the newest safety command applied (see :meth:`apply`)
        self._safety_seq = 0
        self._safety_name = ""
        self._seq = 0
        self.plan_seq = 0
        self.stream_mode = False
        self.enabled = True
        #: a DISABLE (E-stop, DISABLE, uncommanded motion) not yet written: it goes out before
        #: anything else, even when an ENABLE arrives in the same tick (the ENABLE follows it;
        #: a client that re-enabled at once otherwise kept the board from ever getting it)
        self._disable_owed = False
        self._disable_paid = -1
        #: this tick's goals the guard allows for a GO TO frame, and where a new motion starts
        #: from (see TickContext.box and .origin), given by the loop with each tick
        self._box: Sequence[tuple[float, float]] | None = None
        self._origin: Sequence[float] | None = None
        #: the board runs exactly one period per frame (a simulated board in lockstep with the
        #: frames, set by the control loop): trajectories are scheduled on tick / rate, that
        #: board's own time, rather than on the wall clock (a late tick would otherwise jump
        #: ahead in the plan while the board advanced one period)
        self.tick_clock = False
        #: the time this tick's trajectory schedule runs on (see TickContext.clock_s)
        self._sched = 0.0
        self.estop_latched = False
        self.estop_pressed = False
        self.error: str | None = None
        self.outputs = [False, False]
        self.gripper = GripperSetpoint()
        self._pending_code: int | None = None
        self._stream_cart: Job | None = None
        self._measured: tuple[float, ...] | None = None
        self._now = 0.0
        self._link_up = True
        #: frames in a row the board left unanswered while the loop counts replies as missing
        #: (0: they come); commands are refused meanwhile
        self._replies_missing = 0
        self._estop_raw_prev = False
        self._last_status: StatusFrame | None = None
        self._homed = False
        self._spd = tuple(float(v) for v in model.steps_per_deg)
        self._limits = tuple((int(lo), int(hi)) for lo, hi in model.limits_steps)
        #: the joint ranges planned moves keep to, deg (SPEEDJOINT is refused beyond them)
        self._safe_deg = tuple((float(lo), float(hi)) for lo, hi in model.safe_limits_deg)
        self._running = False
        self._planner: threading.Thread | None = None
        self._motion: ModuleType | None = None  # parolkit.motion, imported by the planner thread
        self.planned_count = 0
        self.plan_time_s = 0.0
        #: the board's state is not in its status frame: the probe asks whether it is enabled
        #: at the start of every link session (see BoardProbe)
        self.probe = BoardProbe()
        self.probe.start()
        #: which status frames are the truth, and motion nobody commanded (the loop feeds it)
        self.integrity = StatusIntegrity(model, rate_hz, homing_speedup=homing_speedup,
                                         on_fault=self.integrity_fault, probe=self.probe)
        #: why the robot is disabled when it was not the user's DISABLE (None otherwise)
        self._disabled_reason: str | None = None
        #: the stop supervisor is lost (what happened to it) and no new one is ready yet:
        #: motion is refused (None otherwise; see :meth:`supervisor_lost`)
        self.supervisor_missing: str | None = None
        #: travel of the current unhomed jog press so far, deg per joint, and its latest
        #: segment: (speeds steps/s, start, planned end; monotonic s)
        self._press_used = [0.0] * 6
        self._press_speeds: tuple[tuple[int, ...], float, float] | None = None

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        self._running = True
        self._planner = threading.Thread(target=self._planner_main, name="parolkit-planner", daemon=True)
        self._planner.start()

    def stop(self) -> None:
        with self._plan_cv:
            self._running = False
            self._plan_cv.notify_all()
        if self._planner is not None:
            self._planner.join(2.0)

    # ------------------------------------------------------------------ acks

    def _ack(self, job: Job, status: AckStatus, details: str = "") -> None:
        if job.terminal is not None:
            return
        details = job.ack_details(status, details)
        if status.terminal:
            job.terminal = status
            log.debug("job %d %s (%s): %s %s", job.seq, job.name, job.command_id, status.value, details)
        if job.command_id is None or job.ack_addr is None:
            if status is AckStatus.FAILED:
                log.warning("%s failed: %s", job.name, details)
            return
        with self._lock:
            self._acks.append(Ack(job.command_id, job.ack_addr, status, details))

    def take_acks(self) -> list[Ack]:
        """Every ack produced since the last call, in order (the loop sends them after it
        published the snapshot of the same tick)."""
        with self._lock:
            acks, self._acks = self._acks, []
        return acks

    # ------------------------------------------------------------------ server-thread API

    def new_job(self, command: C.Command, command_id: str | None,
                ack_addr: tuple[tuple[str, int], ...] | None) -> Job:
        with self._lock:
            self._seq += 1
            return Job(self._seq, command, command_id, ack_addr, time.monotonic())

    def plan_ahead(self, cmd: C.Command) -> PlanAhead | None:
        """(server thread) Start planning ``cmd`` now if the robot is idle (see
        :class:`PlanAhead`); the :class:`Submission` carries the handle to the tick."""
        if not needs_plan(cmd) or self.stream_mode:
            return None
        with self._lock:
            meas = self._measured
            if (self.active is not None or self.queue or self._stream_cart is not None or not self._homed
                    or meas is None or not self.enabled or self.estop_latched
                    or (self._ahead is not None and not self._ahead.done)):
                return None
            pa = self._ahead = PlanAhead(cmd, meas, self.tool_name)
            self._ahead_todo = True
            self._plan_cv.notify_all()
        return pa

    def _attach_ahead(self, job: Job) -> None:
        """(under the lock) Give ``job`` its plan made ahead, if there is a usable one."""
        pa = job.ahead
        if pa is None or not pa.done or job.planned or job not in self.queue:
            return
        job.ahead = None
        if pa.tool_name != self.tool_name or self.queue[0] is not job or self.active is not None:
            return  # the plan assumed another start or tool: planned as usual
        if pa.error is not None:
            job.start_deg, job.final_deg, job.planned, job.plan_error = pa.start, pa.start, True, pa.error
        else:
            self._set_plan(job, pa.start, pa.trajectory)

    def submit(self, job: Job) -> None:
        """Queue ``job`` (QUEUED ack) or refuse it (FAILED ack).  Streaming jogs replace."""
        cmd = job.command
        with self._lock:
            if self.estop_latched:
                self._ack(job, AckStatus.FAILED, "E-stop latched: release it and send ENABLE")
                return
            if not self.enabled:
                self._ack(job, AckStatus.FAILED, self._disabled_reason or "robot is disabled: send ENABLE first")
                return
            if not self._link_up:
                self._ack(job, AckStatus.FAILED, f"board link is down ({self.error or 'reconnecting'})")
                return
            if self._replies_missing:
                self._ack(job, AckStatus.FAILED, f"the board's replies are missing ({self._replies_missing} frames "
                                                 "unanswered): nothing is accepted until they return")
                return
            if self.supervisor_missing is not None and (cmd.is_motion or isinstance(cmd, C.Home)):
                self._ack(job, AckStatus.FAILED, f"motion refused: {self.supervisor_missing}; a new one "
                                                 f"is starting")
                return
            if self.stream_mode and isinstance(cmd, _STREAMABLE) and not self.queue and (
                self.active is None or self.active.streamed
            ):
                job.streamed = True
                if self.active is not None and self.active.streamed and self.activity is not None:
                    # an update arrived: the client still holds the jog (the watchdog counts
                    # from here, not from when a CARTJOG's plan is ready)
                    self.activity.touch(self._now)
                if isinstance(cmd, C.CartJogCommand):
                    if not self._homed or self._measured is None:
                        self._ack(job, AckStatus.FAILED, "robot is not homed: send HOME first")
                        return
                    old = self._stream_cart
                    if old is not None and old.command == cmd:
                        # the same jog already waits for its plan: superseding it would restart
                        # planning with every update and, with updates faster than planning,
                        # no plan would ever take over
                        self._ack(job, AckStatus.COMPLETED, "merged into the same jog waiting for its plan")
                        return
                    self._stream_cart = job
                    if old is not None:
                        self._ack(old, AckStatus.COMPLETED, "superseded by a newer jog before it started")
                    self._plan_cv.notify_all()
                else:
                    self._stream_replace(job)
                return
            if len(self.queue) >= self.queue_size:
                self._ack(job, AckStatus.FAILED,
                          f"queue full ({self.queue_size} commands): wait for acks or send STOP")
                return
            self.queue.append(job)
            ahead = len(self.queue) + (1 if self.active is not None else 0)
            self._ack(job, AckStatus.QUEUED, f"Position {ahead} in queue")
            self._attach_ahead(job)
            self._plan_cv.notify_all()

    def apply(self, sub: Submission) -> None:
        """(loop thread) Apply one command from the server: an immediate command at once (its
        ack COMPLETED, FAILED or INVALID), any other queued (or refused) as :meth:`submit`."""
        cmd = sub.command
        job = self.new_job(cmd, sub.command_id, sub.route)
        job.client = sub.client
        pa = sub.ahead
        if pa is not None and pa.command is cmd:
            with self._lock:
                job.ahead, pa.job = pa, job
        if isinstance(cmd, SAFETY_COMMANDS):
            if sub.seq > self._safety_seq:
                self._safety_seq, self._safety_name = sub.seq, cmd.name
        elif sub.seq and sub.seq < self._safety_seq and (
            cmd.KIND is not C.CommandKind.IMMEDIATE or isinstance(cmd, (C.Enable, C.ClearError))
        ):
            # received before a STOP / ESTOP / DISABLE that overtook it in the safety lane:
            # that command cancels it, as if it had been applied in arrival order
            self._ack(job, AckStatus.CANCELLED, f"{self._safety_name} received after it")
            return
        if cmd.KIND is not C.CommandKind.IMMEDIATE:
            self.submit(job)
            return
        status, details = self._immediate(cmd, sub)
        self._ack(job, status, details)

    def _immediate(self, cmd: C.Command, sub: Submission) -> tuple[AckStatus, str]:
        if isinstance(cmd, C.Stop):
            self.do_stop(cmd.reason)
            return AckStatus.COMPLETED, "stopped"
        if isinstance(cmd, C.EStop):
            self.do_estop("software E-stop (ESTOP command)")
            return AckStatus.COMPLETED, "E-stop latched: send ENABLE to release"
        if isinstance(cmd, C.Disable):
            self.do_disable()
            return AckStatus.COMPLETED, "disabled"
        if isinstance(cmd, C.Enable):
            if self.estop_pressed:
                return AckStatus.FAILED, "hardware E-stop is still pressed: release it first"
            self.do_enable()
            return AckStatus.COMPLETED, "enabled"
        if isinstance(cmd, C.ClearError):
            self.do_clear_error()
            return AckStatus.COMPLETED, "error cleared"
        if isinstance(cmd, C.StreamMode):
            self.set_stream_mode(cmd.on)
            return AckStatus.COMPLETED, f"stream mode {'on' if cmd.on else 'off'}"
        if isinstance(cmd, C.SetPort):
            if self.active is not None or self.queue:
                return AckStatus.FAILED, "robot is busy: STOP before switching the port"
            if not os.path.exists(cmd.port):
                # (a fuzzed SET_PORT|None dropped a working link for a device that is not there)
                return AckStatus.FAILED, f"SET_PORT: no device at {cmd.port!r}: the board link stays as it is"
            self.requested_port = cmd.port
            return AckStatus.COMPLETED, f"switching to {cmd.port}"
        if isinstance(cmd, C.SetTool):
            if sub.tool is None:
                return AckStatus.INVALID, f"SET_TOOL: tool {cmd.tool!r} was not resolved"
            if self.active is not None or self.queue:
                return AckStatus.FAILED, "robot is busy: the tool can change only when idle"
            self.tool_name, self.tool_obj = cmd.tool, sub.tool
            return AckStatus.COMPLETED, f"tool {cmd.tool}"
        return AckStatus.INVALID, f"{cmd.name} is not a command the loop applies"

    # immediate actions (loop thread)

    def cancel_all(self, reason: str) -> int:
        """Cancel the active job and every queued one (CANCELLED acks). Returns how many."""
        with self._lock:
            n = 0
            if (isinstance(self.activity, HomeActivity) and self.activity.sent and self.enabled
                    and not self.estop_latched):
                # the firmware runs a homing to its end whatever else it gets, except 101 / 102
                # / 103: a STOP sends ENABLE (the board stays enabled, every motor stops where
                # it is, unhomed) -- with IDLE frames it homed on, and the ENABLE that followed
                # made the rest of its homing "uncommanded motion"
                self._pending_code = BoardCommand.ENABLE
            if self.active is not None:
                self._ack(self.active, AckStatus.CANCELLED, reason)
                self.active = None
                self.activity = None
                n += 1
            while self.queue:
                self._ack(self.queue.popleft(), AckStatus.CANCELLED, reason)
                n += 1
            if self._stream_cart is not None:
                self._ack(self._stream_cart, AckStatus.CANCELLED, reason)
                self._stream_cart = None
                n += 1
            return n

    def do_stop(self, reason: str | None = None) -> None:
        self.cancel_all(reason or "stopped by STOP")

    def do_estop(self, reason: str) -> None:
        if not self.estop_latched:
            log.warning("E-stop: %s", reason)
        self.estop_latched = True
        self._disable_owed = True
        self.probe.cancel()  # DISABLE every tick from now on, ENABLE needed: the answer is moot
        self._drop_pending_enable()
        self.cancel_all(f"E-stop: {reason}")

    def do_enable(self) -> None:
        self.estop_latched = False
        self.enabled = True
        self.error = None
        self._disabled_reason = None
        self.probe.cancel()  # the board gets 101: it will be enabled
        self._pending_code = BoardCommand.ENABLE

    def do_disable(self) -> None:
        self.enabled = False
        self._disable_owed = True
        self.probe.cancel()
        self._drop_pending_enable()
        self.cancel_all("robot disabled by DISABLE")

    def _drop_pending_enable(self) -> None:
        """An ENABLE still waiting for the running command to end is void once the robot is
        disabled or E-stopped again (it went out after the DISABLE otherwise)."""
        if self._pending_code == BoardCommand.ENABLE:
            self._pending_code = None

    def integrity_fault(self, message: str) -> None:
        """(loop thread) The board moved (or homed) in a way nobody commanded: disable the
        robot (DISABLE frames from the next tick on, ENABLE required), cancel everything,
        report ``message`` (it names the joints) as the error."""
        self.enabled = False
        self._disable_owed = True
        self.error = f"uncommanded motion: {message}"
        self._disabled_reason = f"robot disabled after {self.error}: send ENABLE"
        self.probe.cancel()
        self._drop_pending_enable()
        self.cancel_all(self.error)

    def _board_found(self, enabled: bool, reason: str) -> None:
        """(loop thread) The start-up probe answered: the board is (not) enabled."""
        if enabled:
            return
        log.warning("%s", reason)
        self.enabled = False
        self.error = reason
        self._disabled_reason = reason
        with self._lock:
            for job in list(self.queue):
                self._ack(job, AckStatus.FAILED, reason)
            self.queue.clear()
            if self._stream_cart is not None:
                self._ack(self._stream_cart, AckStatus.FAILED, reason)
                self._stream_cart = None
            self._plan_cv.notify_all()

    def do_clear_error(self) -> None:
        self.error = None
        self._pending_code = BoardCommand.CLEAR_ERROR

    def set_stream_mode(self, on: bool) -> None:
        self.stream_mode = on
        if not on:
            with self._lock:
                if self.active is not None and self.active.streamed:
                    self._ack(self.active, AckStatus.COMPLETED, "stream mode switched off")
                    self.active = None
                    self.activity = None

    def link_lost(self, reason: str) -> None:
        """Called by the loop: motion is cancelled and never resumed; the error is latched.
        The board's state is asked again when the link is back (it may have been power
        cycled, or another controller may have used it)."""
        self.error = reason
        self.cancel_all(f"board link lost: {reason}")
        if self.enabled and not self.estop_latched:
            self.probe.start()

    def supervisor_lost(self, what: str) -> None:
        """(loop thread) The stop supervisor is gone (``what`` says how): a controller crash
        now would leave the board running its last command.  Motion is stopped as STOP stops
        it (everything cancelled: the board gets a zero-speed frame after a speed stream),
        the error is latched, and motion is refused until a new supervisor is ready
        (:meth:`supervisor_ready`); what was cancelled never resumes by itself."""
        self.supervisor_missing = what
        self.error = f"{what}: motion stopped, refused until a new stop supervisor is ready"
        self.do_stop(f"stopped: {what}")

    def supervisor_ready(self) -> None:
        """(loop thread) A stop supervisor is ready: motion is accepted again (the error of
        a loss stays latched, saying that a new supervisor took over, until cleared)."""
        what, self.supervisor_missing = self.supervisor_missing, None
        if what is not None and self.error is not None and self.error.startswith(what):
            self.error = f"{what}: motion was stopped; a new stop supervisor is ready"

    # ------------------------------------------------------------------ views

    def queue_length(self) -> int:
        return len(self.queue)

    def queue_view(self, viewer: str | None = None) -> dict[str, Any]:
        """The active and queued commands; a command's ID only to the client that sent it
        (``viewer``: see Submission.client), ``null`` to everyone else (an ID lets its holder
        follow the command's acks; nobody else needs it)."""
        def cid(job: Job) -> str | None:
            return job.command_id if viewer is not None and job.client == viewer else None

        with self._lock:
            a = self.active
            act = None
            if a is not None:
                act = {"id": cid(a), "name": a.name, "mine": a.client == viewer,
                       "progress": round(self.activity.progress, 4) if self.activity else 0.0}
            return {"active": act,
                    "queued": [{"id": cid(j), "name": j.name, "mine": j.client == viewer} for j in self.queue]}

    def plan_view(self, tool: object = None) -> dict[str, Any]:
        with self._lock:
            a = self.active
            traj = a.trajectory if a is not None else None
            seq = self.plan_seq
        if a is None or traj is None:
            return {"seq": seq, "command": a.name if a else None, "target_angles": None, "tcp_path": None}
        try:
            path = traj.tcp_path_mm(tool, max_points=400)  # type: ignore[attr-defined]
            tcp = [[round(float(v), 3) for v in p[:3]] for p in path]
        except Exception as exc:  # kinematics trouble must not kill the server thread
            log.warning("GET_PLAN: could not compute the TCP path: %s", exc)
            tcp = None
        final = a.final_deg
        return {"seq": seq, "command": a.name, "id": a.command_id,
                "target_angles": [round(v, 4) for v in final] if final else None, "tcp_path": tcp}

    # ------------------------------------------------------------------ planner thread

    def _chain_start(self) -> tuple[float, ...] | None:
        if self.active is not None:
            return self.active.final_deg
        return self._measured if self._homed else None

    def _next_to_plan(self) -> tuple[Job, tuple[float, ...], bool] | None:
        """(job, start, is_stream) of the first job that needs a plan now, under the lock."""
        if self._stream_cart is not None and self._measured is not None and self._homed:
            return self._stream_cart, self._stream_start(self._stream_cart), True
        prev = self._chain_start()
        for job in list(self.queue)[:PLAN_AHEAD]:
            cmd = job.command
            if isinstance(cmd, C.Home):
                job.planned = True
                prev = tuple(float(v) for v in self.model.standby_deg)
                job.final_deg = prev
                continue
            if isinstance(cmd, _SPEED_COMMANDS):
                job.planned = True
                job.final_deg = None
                prev = None
                continue
            if not needs_plan(cmd):
                job.planned = True
                job.final_deg = prev
                continue
            if job.ahead is not None and not job.ahead.done:
                return None  # its plan is being made ahead: wait for it
            if job.planned and job.start_deg == prev:
                prev = job.final_deg if job.plan_error is None else prev
                continue
            if prev is None:
                return None
            return job, prev, False
        return None

    def _stream_start(self, job: Job) -> tuple[float, ...]:
        """Where a streamed Cartesian jog starts (deg), under the lock: where the running
        streamed jog last commanded the board, so a held jog continues smoothly; the measured
        joints only when none runs.  (The measured position lags the commanded one by the
        board's position loop: planning every update from it stepped back each time, and a
        held jog covered a fraction of its distance.)"""
        act = self.activity
        job.jog_start = None
        if self.active is not None and self.active.streamed and isinstance(act, TrajectoryActivity):
            steps = act.commanded()
            if steps is not None:
                job.stream_anchor = (act, act.i)
                # the running jog's path orientation and speeds at the commanded sample: the
                # update continues its wrist turn near J5 = 0 instead of restarting it
                jog_start = getattr(self.active.trajectory, "jog_start", None)
                if callable(jog_start):
                    job.jog_start = jog_start(act.i - 1)
                return tuple(p / s for p, s in zip(steps, self._spd))
        job.stream_anchor = None
        return self._measured  # type: ignore[return-value]

    def _planner_main(self) -> None:
        try:
            self._motion_module()  # the import, off the start-up path
        except Exception as exc:  # pragma: no cover - a broken install
            log.error("motion planner unavailable: %s", exc)
        while self._running:
            try:
                self._planner_step()
            except Exception:  # the planner thread must survive anything
                log.exception("planner step failed")
                time.sleep(0.05)

    def _planner_step(self) -> None:
        """Plan one job (or wait briefly when none needs a plan)."""
        with self._plan_cv:
            if not self._running:
                return
            pa = self._ahead if self._ahead_todo and self._stream_cart is None else None
            self._ahead_todo = False
            item = None if pa is not None else self._next_to_plan()
            if pa is None and item is None:
                self._plan_cv.wait(0.05)
                return
        if pa is not None:
            t0 = time.perf_counter()
            traj, err = self._plan(pa.command, pa.start)
            dt = time.perf_counter() - t0
            with self._lock:
                self.planned_count += 1
                self.plan_time_s += dt
                pa.trajectory, pa.error, pa.done = traj, err, True
                if pa.job is not None:
                    self._attach_ahead(pa.job)
            return
        assert item is not None
        job, start, streamed = item
        t0 = time.perf_counter()
        traj, err = self._plan(job.command, start, job.jog_start if streamed else None)
        dt = time.perf_counter() - t0
        with self._lock:
            self.planned_count += 1
            self.plan_time_s += dt
            if streamed:
                if self._stream_cart is not job:
                    return  # superseded while planning
                self._stream_cart = None
                if err is not None:
                    self._ack(job, AckStatus.FAILED, err)
                    return
                self._set_plan(job, start, traj)
                self._planned_streams.put(job)
                return
            if job not in self.queue:
                return  # cancelled while planning
            if err is not None:
                job.start_deg, job.final_deg, job.planned, job.plan_error = start, start, True, err
            else:
                self._set_plan(job, start, traj)

    def _set_plan(self, job: Job, start: tuple[float, ...], traj: object) -> None:
        job.trajectory = traj
        job.samples = (traj.positions.tolist(), traj.speeds.tolist(), traj.commands.tolist())  # type: ignore[attr-defined]
        job.start_deg = start
        job.final_deg = tuple(float(v) for v in traj.final_deg)  # type: ignore[attr-defined]
        job.notes = tuple(getattr(traj, "notes", ()))
        job.plan_error = None
        job.planned = True

    def to_move(self, cmd: C.Command) -> object:
        """The :mod:`parolkit.moves` value object a planned motion command carries."""
        if not needs_plan(cmd):
            raise TypeError(f"{cmd.name} is not a planned motion command")
        return cmd.move  # type: ignore[attr-defined]

    def _motion_module(self) -> ModuleType:
        """:mod:`parolkit.motion`, imported on first use (numpy, planners: not at start-up)."""
        m = self._motion
        if m is None:
            m = self._motion = importlib.import_module("parolkit.motion")
        return m

    def _plan(self, cmd: C.Command, start: Sequence[float], jog_start: object = None,
              ) -> tuple[object | None, str | None]:
        try:
            move = self.to_move(cmd)
            traj = self._motion_module().plan(move, start, model=self.model, tool=self.tool_provider(),
                                              rate_hz=self.rate_hz, jog_start=jog_start)
            if len(traj) == 0:
                return None, "the move plans to zero samples"
            return traj, None
        except Exception as exc:  # PlanningError, IKError, value errors: all become FAILED
            msg = str(exc) or type(exc).__name__
            log.info("planning %s failed: %s", cmd.name, msg)
            return None, msg

    # ------------------------------------------------------------------ loop thread

    def _stream_replace(self, job: Job) -> None:
        """(loop thread) make a streamed jog the active job, superseding the previous one."""
        now = self._now
        with self._lock:
            if job.terminal is not None:
                return
            if self.estop_latched or not self.enabled:
                self._ack(job, AckStatus.FAILED, "robot is disabled or E-stopped")
                return
            if self.queue or (self.active is not None and not self.active.streamed):
                # something non-streamed is running: queue it like any other command
                job.streamed = False
                self.queue.append(job)
                self._ack(job, AckStatus.QUEUED, f"Position {len(self.queue) + 1} in queue")
                self._plan_cv.notify_all()
                return
            cmd = job.command
            if isinstance(cmd, C.CartJogCommand) and not self._homed:
                self._ack(job, AckStatus.FAILED, "robot is not homed: send HOME first")
                return
            old, old_act = self.active, self.activity
            if (
                old is not None and isinstance(old_act, SpeedActivity) and not isinstance(cmd, C.CartJogCommand)
            ):
                speeds, secs, err = self._speed_plan(cmd)
                note = ""
                if err is None:
                    secs, note, err = self._cap_unhomed_travel(speeds, secs, now, continuing=True)
                if err is not None:
                    self._ack(job, AckStatus.FAILED, err)
                    return
                old_act.replace(speeds, secs, now, self._sched)
                self._ack(old, AckStatus.COMPLETED, "superseded by a newer jog")
                self.active = job
                self._ack(job, AckStatus.EXECUTING, note)
                return
            if old is not None:
                self._ack(old, AckStatus.COMPLETED, "superseded by a newer jog")
                self.active = None
                self.activity = None
            self._activate(job, now)
            anchor = job.stream_anchor
            if anchor is not None and anchor[0] is old_act and isinstance(self.activity, TrajectoryActivity):
                # planned from old_act's sample anchor[1] - 1; old_act would send old_act.i next
                self.activity.skip(old_act.i - anchor[1])  # type: ignore[union-attr]

    def _speed_plan(self, cmd: C.Command) -> tuple[tuple[int, ...], float, str | None]:
        """Steps/s per joint and duration (s, exact: a JOG's distance is speed x duration)
        of JOG / MULTIJOG / SPEEDJOINT."""
        m = self.model
        speeds = [0] * 6
        if isinstance(cmd, C.Jog):
            jog = cmd.move
            joint, direction = jog.joints[0], jog.directions[0]
            v = float(m.jog_speed_from_percent(jog.speed_pct[0])[joint])
            speeds[joint] = int(round(v)) * direction
            secs = []
            if jog.duration_s is not None:
                secs.append(jog.duration_s)
            if jog.distance_deg is not None:
                secs.append(jog.distance_deg * self._spd[joint] / max(v, 1e-9))
            return tuple(speeds), min(secs), None
        if isinstance(cmd, C.MultiJog):
            jog = cmd.move
            table = m.jog_speed_from_percent(100.0)
            for j, d, pct in zip(jog.joints, jog.directions, jog.speed_pct):
                speeds[j] = int(round(float(table[j]) * pct / 100.0)) * d
            if jog.duration_s is None:
                return (), 0, "MULTIJOG needs a duration"
            return tuple(speeds), jog.duration_s, None
        if isinstance(cmd, C.SpeedJoint):
            for j, v in enumerate(cmd.move.speeds_deg_s):
                speeds[j] = int(round(v * self._spd[j]))
                if abs(speeds[j]) > m.max_speed_steps_s[j]:
                    return (), 0, f"J{j + 1} speed {v:g} deg/s exceeds the maximum"
            err = self._speed_joint_range(cmd.move.speeds_deg_s, cmd.move.duration_s)
            return tuple(speeds), cmd.move.duration_s, err
        return (), 0, f"{cmd.name} is not a speed command"

    def _speed_joint_range(self, speeds_deg_s: Sequence[float], secs: float) -> str | None:
        """SPEEDJOINT from the measured joints: the refusal when a joint would leave its range
        within ``secs`` (s) at ``speeds_deg_s`` (deg/s), in the words of the planner's (the
        script's) refusal of the same SpeedJoint; None when it stays inside.  Plain Python on
        6 values (the loop thread)."""
        start = self._measured
        if start is None:
            return None  # no status yet: the activity's own limit stop applies
        worst: tuple[float, int, float, str, float] | None = None
        for j, (q0, v, (lo, hi)) in enumerate(zip(start, speeds_deg_s, self._safe_deg)):
            end = q0 + v * secs
            if lo <= end <= hi:
                continue
            bound, side = (hi, "upper") if v > 0 else (lo, "lower")
            t_hit = max(0.0, (bound - q0) / v) if v != 0 else 0.0
            if worst is None or t_hit < worst[0]:
                worst = (t_hit, j, end, side, bound)
        if worst is None:
            return None
        th, j, end, _side, _bound = worst
        lo, hi = self._safe_deg[j]
        longest = math.floor(th * self.rate_hz) / self.rate_hz
        return (f"SpeedJoint refused at t={th:.3f} s: {JOINT_NAMES[j]} would reach {end:.3f} deg, beyond its "
                f"range {lo:.3f} .. {hi:.3f} deg (it gets there after {th:.3f} s; the longest allowed "
                f"duration is {longest:.2f} s).")

    def _cap_unhomed_travel(self, speeds: Sequence[int], secs: float, now: float, *,
                            continuing: bool) -> tuple[float, str, str | None]:
        """Before homing the joint limits are unknown: one jog press (a JOG / MULTIJOG, or a
        held streamed jog and its updates) may move each joint at most
        :attr:`unhomed_jog_travel_deg`.  Returns (duration s, note for the ack, error): the
        duration cut so the press stops at the limit (the note says so; the stream covers
        speed x duration exactly), or an error when less than a tick of travel is left.  A
        homed robot is not limited (the joint limits are)."""
        if self._homed:
            self._press_speeds = None
            return secs, "", None
        prev = self._press_speeds
        if not continuing or prev is None:
            self._press_used = [0.0] * 6
        elif prev is not None:  # the same press goes on: count what it moved so far
            v0, t0, t1 = prev
            for j in range(6):
                self._press_used[j] += abs(v0[j]) / self._spd[j] * max(0.0, min(now, t1) - t0)
        used = self._press_used
        cap = self.unhomed_jog_travel_deg
        room = {j: max(0.0, cap - used[j]) * self._spd[j] / abs(v) for j, v in enumerate(speeds) if v != 0}
        allowed = min([secs, *room.values()])
        stops = [JOINT_NAMES[j] for j, t in room.items() if t == allowed]
        if allowed < 1.0 / self.rate_hz:
            self._press_speeds = ((0,) * 6, now, now)  # still held: the next update is refused too
            return 0, "", (f"robot not homed: this jog press has used its {cap:g} deg of travel "
                           f"({', '.join(stops)}): release and press again, or send HOME to lift the limit")
        self._press_speeds = (tuple(int(v) for v in speeds), now, now + allowed)
        if allowed < secs:
            return allowed, (f"robot not homed: jog travel limited to {cap:g} deg per press "
                             f"({', '.join(stops)} stops there); send HOME to lift the limit"), None
        return secs, "", None

    def _activate(self, job: Job, now: float) -> None:
        cmd = job.command
        settle = max(3, int(SETTLE_TIMEOUT_S * self.rate_hz))
        act: Activity
        if isinstance(cmd, C.Home):
            integrity = self.integrity
            act = HomeActivity(self.model.standby_steps, ticks_for(self.homing_timeout_s, self.rate_hz),
                               start_timeout_ticks=ticks_for(HOME_START_TIMEOUT_S, self.rate_hz),
                               seen=lambda: integrity.homing_seen)
        elif isinstance(cmd, _SPEED_COMMANDS):
            speeds, secs, err = self._speed_plan(cmd)
            if err is None:
                # a held streamed jog that ran into the limit and sends its next update is
                # still the same press; anything else starts a new one
                held = (job.streamed and self._press_speeds is not None
                        and now <= self._press_speeds[2] + self.watchdog_s + 2.0 / self.rate_hz)
                secs, note, err = self._cap_unhomed_travel(speeds, secs, now, continuing=held)
                if note:
                    job.notes = (*job.notes, note)
            if err is not None:
                self._ack(job, AckStatus.FAILED, err)
                return
            act = SpeedActivity(speeds, secs, rate_hz=self.rate_hz, settle_ticks=settle, streamed=job.streamed,
                                started=now, schedule_start=self._sched)
        elif needs_plan(cmd):
            for note in job.warnings:
                log.warning("%s (%s): %s", job.name, job.command_id or "no id", note)
            act = TrajectoryActivity(job.samples, settle_ticks=settle, streamed=job.streamed, started=now,  # type: ignore[arg-type]
                                     schedule_start=self._sched)
            self.plan_seq += 1
        elif isinstance(cmd, C.Delay):
            act = DelayActivity(int(round(cmd.seconds * self.rate_hz)))
        elif isinstance(cmd, C.PneumaticGripper):
            on = cmd.action == "open"  # as the original: open = output on
            self.outputs[cmd.port - 1] = on
            act = OutputActivity(cmd.port, on, ticks_for(OUTPUT_REPORT_TIMEOUT_S, self.rate_hz))
        elif isinstance(cmd, C.ElectricGripper):
            g = self.gripper
            if cmd.action == "move":
                g.position, g.speed, g.current = cmd.position, cmd.speed, cmd.current_ma
                g.command = GripperCommandBits.ACTIVATE | GripperCommandBits.MOVE | GripperCommandBits.RELEASE_DIR
                act = OneShotActivity()
            elif cmd.action == "calibrate":
                # the whole queue waits for the calibration, as in the original controller:
                # the gripper ignores moves meanwhile, and COMPLETED means calibrated
                g.command = GripperCommandBits.ACTIVATE | GripperCommandBits.RELEASE_DIR
                act = GripperCalibrateActivity(ticks_for(GRIPPER_CALIBRATE_TIMEOUT_S, self.rate_hz))
            else:
                act = OneShotActivity(GripperMode.CLEAR_ERROR)
        elif isinstance(cmd, C.WaitInput):
            to = ticks_for(cmd.timeout_s, self.rate_hz) if cmd.timeout_s is not None else None
            act = WaitInputActivity(cmd.input_no, cmd.state, to)
        else:
            self._ack(job, AckStatus.FAILED, f"{cmd.name} cannot be executed")
            return
        self.active = job
        self.activity = act
        details = "; ".join(job.notes) if job.notes else ""
        self._ack(job, AckStatus.EXECUTING, details)

    def _try_activate(self, now: float, status: StatusFrame | None) -> None:
        with self._lock:
            while self.queue:
                job = self.queue[0]
                cmd = job.command
                if cmd.is_motion and not isinstance(cmd, (C.Jog, C.MultiJog)) and not self._homed:
                    self.queue.popleft()
                    self._ack(job, AckStatus.FAILED, "robot is not homed: send HOME first")
                    continue
                if not job.planned:
                    self._plan_cv.notify_all()
                    return
                if job.plan_error is not None:
                    self.queue.popleft()
                    self._ack(job, AckStatus.FAILED, job.plan_error)
                    self._plan_cv.notify_all()
                    continue
                if needs_plan(cmd):
                    meas = self._measured
                    if meas is None or job.start_deg is None or any(
                        abs(a - b) > START_TOLERANCE_DEG for a, b in zip(meas, job.start_deg)
                    ):
                        job.planned = False  # plan again from where the robot is
                        self._plan_cv.notify_all()
                        return
                self.queue.popleft()
                self._activate(job, now)
                if self.active is not None:
                    self._plan_cv.notify_all()
                    return

    def tick(
        self,
        *,
        tick: int,
        now: float,
        status: StatusFrame | None,
        link_up: bool,
        commands: Iterable[Submission] = (),
        box: Sequence[tuple[float, float]] | None = None,
        origin: Sequence[float] | None = None,
        replies_missing: int = 0,
    ) -> Step:
        """This tick's frame content, after taking in ``status`` and applying ``commands``
        (the server's hand-off, safety commands first).  ``box``: the goals the guard allows
        for a GO TO frame this tick; ``origin``: where a new motion starts from (see
        :class:`TickContext`); ``replies_missing``: frames in a row left unanswered, when the loop
        counts the replies as missing (new commands are refused).  Loop thread only.  The acks this produced wait in
        :meth:`take_acks`."""
        self._now = now
        self._link_up = link_up
        self._box = box
        self._origin = origin
        self._replies_missing = replies_missing
        if status is not None:
            self._homed = status.all_homed
            self._measured = tuple(p / s for p, s in zip(status.positions, self._spd))
            if status is not self._last_status:  # a new frame
                self._hardware_estop(status)
        probe = self.probe
        if probe.result is not None:
            result, probe.result = probe.result, None
            self._board_found(result, probe.reason)
        for sub in commands:
            try:
                self.apply(sub)
            except Exception as exc:  # a command must never kill the loop
                log.exception("applying %s failed", sub.command.name)
                if sub.command_id is not None and sub.route is not None:
                    with self._lock:
                        self._acks.append(Ack(sub.command_id, sub.route, AckStatus.FAILED, f"internal error: {exc}"))
        while True:
            try:
                job = self._planned_streams.get_nowait()
            except Empty:
                break
            self._stream_replace(job)
        return self._step(tick, now, status, link_up)

    def _hardware_estop(self, status: StatusFrame) -> None:
        """The E-stop input of a new status frame (IO bit 0x08, 0 = pressed).

        The link has no checksum, so a frame showing "pressed" may be a corrupted IO byte.
        Pressed counts at once (the next frame written is DISABLE) when the IO byte equals
        the previous frame's with only the E-stop bit cleared and the outputs echo what was
        commanded: a press changes exactly that bit, while a corrupted byte is a random other
        value (1 in 255 corrupted IO bytes looks like a press and latches: the safe side).
        Any other "pressed" byte needs a second frame in a row.  Release always needs two
        frames in a row (a corrupted byte must not let an ENABLE through)."""
        prev = self._last_status
        raw = status.estop_pressed
        if raw:
            out = (IOBits.OUT1 if self.outputs[0] else 0) | (IOBits.OUT2 if self.outputs[1] else 0)
            quick = (prev is not None and not prev.estop_pressed and status.io == (prev.io & ~IOBits.ESTOP)
                     and (status.io & (IOBits.OUT1 | IOBits.OUT2)) == out)
            pressed = self.estop_pressed or quick or self._estop_raw_prev
        else:
            pressed = self.estop_pressed and self._estop_raw_prev
        self._estop_raw_prev = raw
        self._last_status = status
        if pressed and not self.estop_pressed:
            self.do_estop("hardware E-stop pressed")
        self.estop_pressed = pressed

    def preempt(self, commands: Iterable[Submission], *, tick: int, now: float) -> Step:
        """(loop thread) Safety commands that arrived after :meth:`tick` composed this tick's
        frame: apply them and give the frame to send instead (held still, or DISABLE)."""
        for sub in commands:
            self.apply(sub)
        return self._step(tick, now, self._last_status, self._link_up)

    def _step(self, tick: int, now: float, status: StatusFrame | None, link_up: bool) -> Step:
        if self.estop_latched or self._disable_owed or self._disable_paid == tick:
            if self._disable_owed:
                # paid by this tick's frame (a preempting STOP recomposes the same tick's
                # frame: it must stay DISABLE, not become the ENABLE queued behind it)
                self._disable_owed, self._disable_paid = False, tick
            return Step(BoardCommand.DISABLE)
        if self._pending_code is not None and self.activity is None:
            # ENABLE (101) / CLEAR_ERROR (103) wait for the running command to end: the board
            # zeroes every speed when it gets one, so sent mid-move it dropped a joint from
            # full speed to 0 and back in one tick (and 103 aborts a homing)
            code, self._pending_code = self._pending_code, None
            return Step(code)
        if not self.enabled:
            return Step(BoardCommand.DISABLE)
        if not link_up:
            return Step(BoardCommand.IDLE)
        if self.probe.active:
            # is the board enabled?  Nothing else runs until it answers (a few ticks)
            code, speeds = self.probe.frame(status, self._limits)
            return Step(code, speeds=speeds)
        self._sched = tick / self.rate_hz if self.tick_clock else now
        if self.active is None and self.queue:
            self._try_activate(now, status)
        act = self.activity
        if act is None:
            return Step(BoardCommand.IDLE)
        ctx = TickContext(tick, now, self.rate_hz, status, self._homed, self.stream_mode, self.watchdog_s,
                          self._limits, self._box, self._origin, self._sched if self.tick_clock else None)
        step = self._run_activity(act, ctx)
        if step.done is not None and act.frameless_end and self.queue:
            # its end needs no frame of its own (it only saw the board's report): the next
            # queued command takes this tick (an Output() lasts one tick, as in the original)
            self._try_activate(now, status)
            nxt = self.activity
            if nxt is not None:
                step = self._run_activity(nxt, ctx)
        return step

    def _run_activity(self, act: Activity, ctx: TickContext) -> Step:
        """(loop thread) This tick's step of the active job's activity; ends the job (its
        terminal ack, with the plan's warnings) when the step says so."""
        try:
            step = act.step(ctx)
        except Exception as exc:
            log.exception("activity of %s failed", self.active.name if self.active else "?")
            step = Step(BoardCommand.IDLE, done=AckStatus.FAILED, details=f"internal error: {exc}")
        if step.done is not None:
            with self._lock:
                job = self.active
                self.active = None
                self.activity = None
                if job is not None:
                    if act.warnings:
                        job.notes = (*job.notes, *act.warnings)
                    self._ack(job, step.done, step.details)
                self._plan_cv.notify_all()
        return step

    def fail_active(self, reason: str) -> None:
        """The guard refused this job's frame: FAILED, nothing else of it is sent."""
        with self._lock:
            job = self.active
            if job is None:
                return
            self.active = None
            self.activity = None
            self._ack(job, AckStatus.FAILED, f"safety guard: {reason}")
            self._plan_cv.notify_all()

    @property
    def steps_per_deg(self) -> tuple[float, ...]:
        return self._spd

    @property
    def homed(self) -> bool:
        return self._homed

    @property
    def measured_deg(self) -> tuple[float, ...] | None:
        return self._measured
