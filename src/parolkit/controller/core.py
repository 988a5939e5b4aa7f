"""The controller core: one tick as a function of its inputs.

``ControllerCore.update(TickInput) -> TickOutput``, in the shape of ruckig's ``otg.update(input,
output)``: everything the tick needs comes in as a value, everything it decides goes out as a
value, and nothing inside does I/O, starts threads, reads a clock or calls back.  The same
inputs give the same outputs, so the core is tested by lists of inputs, and on a virtual clock
the driver (:mod:`parolkit.controller.driver`) can tick as fast as the emulated board answers.

In: the tick (its number, its time on the link record's clock, the monotonic time for ages),
the frame the driver wrote last tick, the status frames it read since, the commands the UDP
server handed over (safety commands first), the plans the planner finished, what happened to
the board link and to the stop supervisor, and the driver's and server's counters (shown in
the status as they are).

Out: the frame to write (or none), the acks of everything that happened, the snapshot that
shows all of it (plain frozen data: every query and the status stream are answered from it),
the plans to start, a port to switch to, and a result code.

Inside, each part has one owner and one job: the safety state (:mod:`~parolkit.controller.safety`,
pure transitions), the job queue (:mod:`~parolkit.controller.jobs`), the running activity
(:mod:`~parolkit.controller.activities`), the output and gripper setpoints
(:mod:`~parolkit.controller.setpoints`), and the one record of the link
(:mod:`~parolkit.controller.link`) that the integrity check (:mod:`~parolkit.controller.integrity`)
and the safety guard (:mod:`~parolkit.controller.guard`) judge by, in this same update.

Link supervision is judged by the frames the board left unanswered, never by the controller's
own late ticks (a stalled controller writes nothing).  After ``link_hold_frames`` unanswered
frames in a row during motion the replies count as missing (counted and logged; every frame
being a bounded commitment, the motion holds by itself: new commands queue behind it); after
``link_timeout_ticks`` the link is lost: everything is cancelled, the error latched, the last
frame's motion ended with one more frame, and no frame is written until the driver reports the
link up again.
"""

from __future__ import annotations

import logging
import math
from collections import OrderedDict, deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Any

from parolkit._frozen import quick_init
from parolkit.controller.activities import (
    Activity,
    CheckpointActivity,
    DelayActivity,
    DoneActivity,
    FrameRequest,
    GripperCalibrateActivity,
    GuardStopActivity,
    HomeActivity,
    OneShotActivity,
    OutputActivity,
    ServoActivity,
    SpeedActivity,
    TickContext,
    TrajectoryActivity,
    WaitInputActivity,
    ticks_for,
)
from parolkit.controller.guard import SafetyGuard
from parolkit.controller.integrity import BoardProbe, StatusIntegrity
from parolkit.controller.jobs import Job, JobQueue
from parolkit.controller.link import LinkHistory
from parolkit.controller.messages import (
    Ack,
    LinkEvent,
    LinkEventKind,
    Submission,
    SupervisorEvent,
    SupervisorEventKind,
)
from parolkit.controller.planning import PlanRequest, PlanResult, needs_plan
from parolkit.controller.safety import SafetyState
from parolkit.controller.setpoints import Setpoints
from parolkit.controller.snapshot import BoardInfo, CommandInfo, PlanView, PoseProvider, RobotState, Snapshot
from parolkit.controller.world import (
    MAX_HELD,
    CollisionView,
    CollisionWorld,
    SceneRequest,
    SceneResult,
    StopPlan,
    held_item,
    joint_stop,
    path_stop,
    stop_check,
)
from parolkit.errors import ParolkitError
from parolkit.moves import MAX_BLEND_CHAIN, Frame, blend_kind
from parolkit.protocol import commands as C
from parolkit.protocol.commands import AckStatus, CollisionCheck, Execution
from parolkit.protocol.frames import BoardCommand, CommandFrame, GripperCommandBits, GripperMode, StatusFrame
from parolkit.robot import JOINT_NAMES, RobotModel, goto_goal

__all__ = [
    "ControllerCore", "TickInput", "TickOutput", "TickResult", "ReplyBatch", "Written",
    "START_TOLERANCE_DEG", "PLAN_AHEAD", "UNHOMED_JOG_TRAVEL_DEG",
]

log = logging.getLogger("parolkit.controller")

#: a planned move may start this far (deg, any joint) from the measured joints
START_TOLERANCE_DEG = 0.5
#: a move FAILS if the board has not reported its exact target (at rest) this long after its
#: last sample (a few ticks are normal: the GO TO law closes the last steps at 50 steps/s per
#: step of error), s
SETTLE_TIMEOUT_S = 1.0
#: PNEUMATICGRIPPER FAILS if the board has not reported the new output level by then, s
OUTPUT_REPORT_TIMEOUT_S = 0.5
#: ELECTRICGRIPPER|calibrate FAILS if the gripper has not reported calibrated by then, s
GRIPPER_CALIBRATE_TIMEOUT_S = 5.0
#: how many queued jobs are planned ahead
PLAN_AHEAD = 4
#: |J5| (deg) below which a SERVOL target follows the wrist's singular-area policy
#: (:data:`parolkit.motion.singular.WRIST_AREA_DEG`, imported with the kinematics when needed)
_WRIST_AREA_DEG = 15.0
#: keys of the plans asked for blended chains (and for a job after a chain it headed grew)
#: count from here: above every job number, so an earlier request's answer is dropped
_CHAIN_KEY_BASE = 1 << 40
#: a HOME whose board shows no homing within this time FAILS (a disabled board ignores it), s
HOME_START_TIMEOUT_S = 0.5
#: a servo stream's generator reaches its full acceleration in this long (its jerk limit is the
#: acceleration limit / this), s
SERVO_JERK_TIME_S = 0.05
#: default travel of one jog press (JOG / MULTIJOG, or one held streamed jog) before homing, deg
UNHOMED_JOG_TRAVEL_DEG = 20.0
#: plans asked for ahead by the server whose command has not arrived yet, kept at most
_EARLY_PLANS = 16


@quick_init
@dataclass(frozen=True)
class ReplyBatch:
    """Status frames the driver read in one go: at ``t`` on the link record's clock (``wall``:
    monotonic s), ``after_write``: while waiting for the reply to the frame just written, else
    at the start of a tick (either way they answer the oldest frames still unanswered, in order:
    :meth:`LinkHistory.answered_range`); ``dropped``: the stream parser's count of bytes dropped
    so far, after the last of them."""

    frames: tuple[StatusFrame, ...]
    t: float
    wall: float
    after_write: bool
    dropped: int = 0


@quick_init
@dataclass(frozen=True)
class Written:
    """The frame the driver wrote (the previous output's, or the one recomposed), at ``t`` on the
    link record's clock (``wall``: monotonic s)."""

    frame: CommandFrame
    t: float
    wall: float


@quick_init
@dataclass(frozen=True)
class TickInput:
    """Everything one tick needs (see the module docstring)."""

    tick: int
    #: the tick's time on the link record's clock: monotonic s on a real link, the board's own
    #: time (tick x period) on a simulated board in lockstep with the frames
    time: float
    #: monotonic s (ages, the status's uptime)
    wall: float
    written: Written | None = None
    replies: tuple[ReplyBatch, ...] = ()
    submissions: tuple[Submission, ...] = ()
    plans: tuple[PlanResult, ...] = ()
    links: tuple[LinkEvent, ...] = ()
    supervisor: tuple[SupervisorEvent, ...] = ()
    #: the driver's and the UDP server's counters, shown in the status as they are
    loop_stats: Mapping[str, Any] = field(default_factory=dict)
    server_stats: Mapping[str, Any] = field(default_factory=dict)
    #: the collision scenes the driver built since (answers to :attr:`TickOutput.scene_requests`)
    scenes: tuple[SceneResult, ...] = ()
    #: safety commands that arrived while this tick's frame was being made: apply them and
    #: give the frame to write instead (same tick, nothing read again)
    recompose: bool = False
    #: build the snapshot in the output; False: the output's is None, and a caller that needs
    #: it asks :meth:`ControllerCore.snapshot_now` before the next update (one thread only:
    #: fast-forward, where a query comes between two ticks and most ticks are never looked at)
    snapshot: bool = True


class TickResult(Enum):
    """What the driver does with this tick's output."""

    #: write :attr:`TickOutput.frame`
    FRAME = "frame"
    #: the link is down: nothing to write (the driver reconnects)
    NO_LINK = "no_link"
    #: the link was lost in this tick: write :attr:`TickOutput.frame` if there is one (it ends
    #: the last frame's motion), then close and reconnect
    LINK_LOST = "link_lost"


@quick_init
@dataclass(frozen=True)
class TickOutput:
    """What one tick decided (see the module docstring)."""

    frame: CommandFrame | None
    acks: tuple[Ack, ...]
    #: None when the input asked for none (:attr:`TickInput.snapshot`)
    snapshot: Snapshot | None
    plan_requests: tuple[PlanRequest, ...] = ()
    port_request: str | None = None
    result: TickResult = TickResult.FRAME
    #: collision scenes to build (off the tick: :func:`parolkit.controller.world.build_scene`)
    scene_requests: tuple[SceneRequest, ...] = ()


@dataclass
class LinkCounters:
    """The core's part of the loop statistics."""

    frames_received: int = 0
    #: the integrity check's count (``integrity.implausible`` of the status): one number
    implausible_frames: int = 0
    bytes_dropped: int = 0
    link_losses: int = 0
    link_holds: int = 0
    unanswered_max: int = 0
    planned: int = 0
    plan_time_s: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"frames_received": self.frames_received, "implausible_frames": self.implausible_frames,
                "bytes_dropped": self.bytes_dropped, "link_losses": self.link_losses,
                "link_holds": self.link_holds, "unanswered_max": self.unanswered_max, "planned": self.planned,
                "plan_time_total_s": round(self.plan_time_s, 4)}


class ControllerCore:
    """The tick as a function (see the module docstring).  One owner: the driver's thread."""

    def __init__(
        self,
        *,
        model: RobotModel,
        rate_hz: float,
        queue_size: int = 256,
        watchdog_s: float = 0.02,
        link_timeout_ticks: int = 50,
        link_hold_frames: int = 2,
        homing_timeout_s: float = 180.0,
        homing_speedup: float = 1.0,
        unhomed_jog_travel_deg: float = UNHOMED_JOG_TRAVEL_DEG,
        lockstep: bool = False,
        pose_provider: PoseProvider | None = None,
        board: BoardInfo | None = None,
        tool_name: str = "default",
        config: object | None = None,
        servo_timeout_s: float = 0.05,
        zones: Sequence[object] | None = None,
    ) -> None:
        if not unhomed_jog_travel_deg > 0.0:
            raise ValueError(f"unhomed_jog_travel_deg must be > 0 deg, got {unhomed_jog_travel_deg!r}")
        if not 1 <= link_hold_frames <= link_timeout_ticks:
            raise ValueError(f"link_hold_frames must be 1..link_timeout_ticks ({link_timeout_ticks}), "
                             f"got {link_hold_frames}")
        self.model = model
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.watchdog_s = watchdog_s
        self.link_timeout_ticks = link_timeout_ticks
        self.link_hold_frames = link_hold_frames
        self.homing_timeout_s = homing_timeout_s
        self.homing_speedup = homing_speedup
        self.unhomed_jog_travel_deg = float(unhomed_jog_travel_deg)
        #: the board runs exactly one period per frame (a simulated board in lockstep with the
        #: frames): times are its own, tick x period
        self.lockstep = lockstep
        self.pose_provider = pose_provider
        self.board = board if board is not None else BoardInfo(False, True, "emulated board")
        self._spd = tuple(float(v) for v in model.steps_per_deg)
        self._limits = tuple((int(lo), int(hi)) for lo, hi in model.limits_steps)
        #: the joint ranges planned moves keep to, deg (SPEEDJOINT is refused beyond them)
        self._safe_deg = tuple((float(lo), float(hi)) for lo, hi in model.safe_limits_deg)
        self.safety = SafetyState()
        self.jobs = JobQueue(queue_size)
        self.setpoints = Setpoints()
        self.link = LinkHistory()
        self.guard = SafetyGuard(model, rate_hz)
        #: the board's state is not in its status frame: the probe asks whether it is enabled
        #: at the start of every link session
        self.probe = BoardProbe()
        #: which status frames are the truth, and motion nobody commanded
        self.integrity = StatusIntegrity(model, rate_hz, homing_speedup=homing_speedup, probe=self.probe)
        self.counters = LinkCounters()
        self.tool_name = tool_name
        #: the tool object of a SET_TOOL (None: the tool is resolved by name when planning, from
        #: ``config``'s [tools.NAME] or the built-in ones)
        self.tool_obj: object | None = None
        self.config = config
        self.stream_mode = False
        #: the SPEED override (1..100 % of every planned speed) and PAUSE (the running move
        #: holds on its path, nothing queued starts until RESUME)
        self.speed_pct = 100.0
        self.paused = False
        #: PAUSE|QUEUE: the running command goes on, nothing queued starts until RESUME;
        #: ``queue_steps``: how many more may start meanwhile (one per RESUME|ONE)
        self.queue_held = False
        self.queue_steps = 0
        self._accel = tuple(float(a) for a in model.accel_limit_steps_s2)
        #: servo streams: silence that ends one (s), the speeds they keep to (the position-
        #: tracking maxima: every frame a bounded commitment), the joint ranges (steps)
        self.servo_timeout_s = float(servo_timeout_s)
        self._servo_vmax = tuple(float(v) for v in model.max_tracked_speed_steps_s(self.rate_hz))
        self._safe_steps = tuple((min(lo * s, hi * s), max(lo * s, hi * s))
                                 for (lo, hi), s in zip(self._safe_deg, self._spd))
        self.plan_seq = 0
        #: the link: up (a session), and whether the replies count as missing now
        self.link_up = False
        self.holding = False
        self._virtual = False
        #: newest true status frame of this link session; newest ever (shown while down)
        self.status: StatusFrame | None = None
        self.last_status: StatusFrame | None = None
        self.homed = False
        self.measured_deg: tuple[float, ...] | None = None
        self.last_frame: CommandFrame | None = None
        #: SET_PORT: the port the driver is to open, output by this tick's update
        self.port_request: str | None = None
        #: a SET_PORT under way: the port and its job (EXECUTING until the board there answers
        #: and its state is known, then COMPLETED: a move sent after that ack runs there); and
        #: whether this link session is the one the driver opened on that port
        self._switch: tuple[str, Job] | None = None
        self._switch_on = False
        self._plan_requests: list[PlanRequest] = []
        #: the blended chain that runs (issue 24): its activity, the number of the job that
        #: headed it, the sample marks of the jobs not yet handed over; the count of chain keys
        self._chain_act: Activity | None = None
        self._chain_head: int | None = None
        self._marks: deque[int] = deque()
        self._chain_keys = 0
        #: plans asked for ahead that arrived before their command (key -> result)
        self._early: OrderedDict[int, PlanResult] = OrderedDict()
        #: receive number of the newest safety command applied (see :meth:`_apply`)
        self._safety_seq = 0
        self._safety_name = ""
        #: travel of the current unhomed jog press so far, deg per joint, and its latest
        #: segment: (speeds steps/s, start, planned end)
        self._press_used = [0.0] * 6
        self._press_speeds: tuple[tuple[int, ...], float, float] | None = None
        self._now = 0.0
        self._tick = 0
        self._start_wall: float | None = None
        # ---- the collision world (docs/collision.md): the zones (``zones``, else the config's,
        # else the table), the tool's shape, the held objects; its compiled scene comes from
        # the driver (never built here)
        if zones is None:
            zones = getattr(config, "zones", None)
        if zones is None:
            from parolkit.config import default_zones

            zones = default_zones()
        self.world = CollisionWorld(tuple(zones), self._tool_shape(tool_name))  # type: ignore[arg-type]
        #: changes whenever the world does (the status's collision.seq: GET_ZONES again)
        self.world_seq = 0
        #: the scene of :attr:`world` once the driver built it (None: not yet)
        self.scene: Any = None
        #: scenes and errors the driver answered, by world (a few kept: ATTACH / DETACH back and forth)
        self._scenes: OrderedDict[CollisionWorld, SceneResult] = OrderedDict()
        self._scenes_asked: set[CollisionWorld] = set()
        self._scene_requests: list[SceneRequest] = []
        #: the controlled stop checked with the last guarded frame (it begins at the next
        #: tick), and the one of the frame before this tick's (what a refused frame plays)
        self._stop_plan: StopPlan | None = None
        self._prev_stop: StopPlan | None = None
        #: pairs found within their margin where a guarded motion started: the clearance
        #: they had then (mm), which the motion may not go below
        self._floors: dict[int, float] = {}
        self._rad_per_step = tuple(math.pi / 180.0 / s for s in self._spd)
        #: ticks spent in the per-tick stop check, and how long (s): the loop statistics' figures
        self.guard_checks = 0

    # ================================================================== the update

    def update(self, inp: TickInput) -> TickOutput:
        """One tick (see the module docstring)."""
        self._now = inp.time
        self._tick = inp.tick
        if self._start_wall is None:
            self._start_wall = inp.wall
        if inp.recompose:
            return self._recompose(inp)
        if inp.written is not None and self.link_up:
            self._written(inp.written)
        for ev in inp.links:
            self._link_event(ev)
        for sev in inp.supervisor:
            self._supervisor_event(sev)
        self._take_plans(inp.plans)
        self._take_scenes(inp.scenes)
        self._take_probe_answer()
        # the commands first: their senders saw the status of the previous tick; what the
        # replies read now show is newer (a fault they reveal is shown even when an ENABLE
        # came in the same tick: it voids that ENABLE)
        for sub in inp.submissions:
            self._apply_safe(sub)
        result = TickResult.FRAME
        lost_frame: CommandFrame | None = None
        if self.link_up:
            for batch in inp.replies:
                self._read(batch)
            lost = self._judge_link()
            if lost is not None:
                lost_frame = self._lose_link(lost, inp, may_write=True)
                result = TickResult.LINK_LOST
        # the stop checked with the last frame written begins at this tick (if this tick's
        # frame is refused, it is played); this tick's frame checks a new one
        self._prev_stop, self._stop_plan = self._stop_plan, None
        if result is TickResult.LINK_LOST:
            frame = lost_frame
        elif self.link_up:
            frame = self._frame(inp)
        else:
            frame, result = None, TickResult.NO_LINK
        self._request_plans()
        self._ask_scene()
        port, self.port_request = self.port_request, None
        sw = self._switch
        if sw is not None and port is None and self.link_up and not self._switch_on:
            # the link came up again on the old port (its reconnect was under way when
            # SET_PORT came): it ends too
            port = sw[0]
        if port is not None and self.link_up and result is TickResult.FRAME:
            self._leave_link(port)
            result = TickResult.LINK_LOST
        elif sw is not None and self._switch_on and self._state_known():
            self._switch = None
            why = self.safety.refusal(motion=True)
            self.jobs.ack(sw[1], AckStatus.COMPLETED,
                          f"switched to {sw[0]}: the board answers" + (f"; {why}" if why else ""))
        requests, self._plan_requests = tuple(self._plan_requests), []
        scenes, self._scene_requests = tuple(self._scene_requests), []
        return TickOutput(frame, tuple(self.jobs.take_acks()), self._snapshot(inp, frame) if inp.snapshot else None,
                          requests, port, result, scenes)

    def _recompose(self, inp: TickInput) -> TickOutput:
        """Safety commands that came while this tick's frame was made: applied, and this tick's
        frame made again (the first was never written)."""
        for sub in inp.submissions:
            self._apply_safe(sub)
        self._stop_plan = None  # (the first frame's, never written)
        frame = self._frame(inp) if self.link_up else None
        result = TickResult.FRAME if frame is not None else TickResult.NO_LINK
        requests, self._plan_requests = tuple(self._plan_requests), []
        self._ask_scene()
        scenes, self._scene_requests = tuple(self._scene_requests), []
        return TickOutput(frame, tuple(self.jobs.take_acks()), self._snapshot(inp, frame) if inp.snapshot else None,
                          requests, None, result, scenes)

    # ================================================================== the link

    def _link_event(self, ev: LinkEvent) -> None:
        if ev.kind is LinkEventKind.UP:
            self._switch_on = self._switch is not None and ev.port == self._switch[0]
            # a new session: nothing is known of the board (it may have been power cycled,
            # or another controller may have used it)
            self.link.reset()
            self.integrity.reset()
            self.status = None
            self.holding = False
            self._virtual = ev.virtual_clock
            self.board = BoardInfo(False, ev.simulated, ev.description)
            self.link_up = True
            s = self.safety
            if s.enabled and not s.estop_latched:
                self.probe.start()
        elif self.link_up:
            self._lose(ev.reason or "link lost")

    def _written(self, w: Written) -> None:
        """The driver wrote ``w.frame``: the link record, the integrity check and the probe
        count it."""
        n = self.link.sent(w.frame, w.t)
        self.integrity.sent(w.frame, self._board_time(w.t, w.wall), n)
        self.last_frame = w.frame

    def _board_time(self, t: float, wall: float) -> float:
        """The time the integrity check judges the board's motion by: the PC's clock (``wall``,
        monotonic s) on a real link; on a board in lockstep with the frames its own time, the
        link record's ``t`` (each frame one period): a PC stalled longer than the board timer's
        wrap must not read as board time that passed.  On a simulated board with a virtual
        clock (``sim://?clock=virtual``) that clock, ``t``, for the same reason: the board's
        time is the one its owner advances, not the time the PC took."""
        return t if self.lockstep or self._virtual else wall

    def _read(self, batch: ReplyBatch) -> None:
        """Judge every status frame of ``batch`` (see :meth:`LinkHistory.answered_range`)."""
        count = len(batch.frames)
        for i, f in enumerate(batch.frames):
            self.counters.frames_received += 1
            answers, newest = self.link.answered_range(count, i, after_write=batch.after_write)
            earliest = self.link.earliest(f)
            self.holding = False
            if self.integrity.accept(f, self._board_time(batch.t, batch.wall), batch.dropped, answers,
                                     newest=newest):
                self.status = f
                self.last_status = f
                self.link.trust(earliest, f, batch.t)
                self._took_status(f)
            self.counters.implausible_frames = self.integrity.implausible
            self.link.homing = self.integrity.homing
            fault = self.integrity.take_fault()
            if fault is not None:
                self._fault(fault)
            self._take_probe_answer()
        self.counters.bytes_dropped = batch.dropped

    def _took_status(self, status: StatusFrame) -> None:
        """A new true status frame: homed, the measured joints, the hardware E-stop."""
        self.homed = status.all_homed
        self.measured_deg = tuple(p / s for p, s in zip(status.positions, self._spd))
        s, pressed = self.safety.hardware_estop(status, self.setpoints.io & 0x30)
        self.safety = s
        if pressed:
            self._estop("hardware E-stop pressed")

    def _judge_link(self) -> str | None:
        """By the frames the board left unanswered: the reason the link is lost, or None."""
        u = self.link.unanswered
        if u > self.counters.unanswered_max:
            self.counters.unanswered_max = u
        if u >= self.link_timeout_ticks:
            return f"the board left {u} frames in a row unanswered"
        if u >= self.link_hold_frames and not self.holding:
            act = self.jobs.activity
            if act is not None and act.moves:
                self.holding = True
                self.counters.link_holds += 1
                log.warning("the board left %d frames in a row unanswered: motion holds at its last goal "
                            "(the link counts as lost after %d)", u, self.link_timeout_ticks)
        return None

    def _lose_link(self, reason: str, inp: TickInput, *, may_write: bool) -> CommandFrame | None:
        """The link is lost: the frame that ends the last frame's motion (guarded), if it needs
        one; then everything is cancelled and the error latched."""
        frame = None
        stop = self.stop_request(self.last_frame) if may_write else None
        if stop is not None:
            frame = self._guarded(stop, inp.time)
        self._lose(reason)
        return frame

    def _leave_link(self, port: str) -> None:
        """SET_PORT: this link session ends here, on purpose (no error latched, no link loss
        counted).  Nothing runs: SET_PORT is refused while anything does, and so is every
        command after it until it is COMPLETED (the cancel is for completeness)."""
        self.link_up = False
        self.holding = False
        log.warning("board link to %s closed: switching to port %s", self.board.port, port)
        self._cancel_all(f"the board link is switching to port {port}")

    def _state_known(self) -> bool:
        """The link is up, a true status frame was read and the start-up probe's answer (if
        it asked) has been taken in: what the snapshot shows is this board's."""
        return (self.link_up and self.status is not None and not self.probe.active
                and self.probe.result is None)

    def _set_port(self, job: Job, cmd: C.SetPort) -> None:
        """SET_PORT: EXECUTING at once; the link is left at the end of this update (the driver
        opens the new port), COMPLETED once the board there answers and its state is known
        (see :attr:`_switch`).  A newer SET_PORT supersedes one under way (CANCELLED)."""
        jobs = self.jobs
        if jobs.busy:
            jobs.ack(job, AckStatus.FAILED, "robot is busy: STOP before switching the port")
            return
        old = self._switch
        if old is not None:
            jobs.ack(old[1], AckStatus.CANCELLED, f"superseded by SET_PORT to {cmd.port}")
        self._switch, self._switch_on = (cmd.port, job), False
        self.port_request = cmd.port
        jobs.ack(job, AckStatus.EXECUTING, f"switching to {cmd.port}: COMPLETED once the board there answers")

    def cancel_port_switch(self, reason: str) -> None:
        """A SET_PORT under way ends CANCELLED with ``reason`` (the controller shuts down)."""
        sw, self._switch = self._switch, None
        if sw is not None:
            self.jobs.ack(sw[1], AckStatus.CANCELLED, reason)

    def _lose(self, reason: str) -> None:
        self.link_up = False
        self.holding = False
        self.counters.link_losses += 1
        log.error("board link lost: %s", reason)
        self.safety = self.safety.link_lost(reason)
        self._cancel_all(f"board link lost: {reason}")

    @staticmethod
    def stop_request(last: CommandFrame | None) -> FrameRequest | None:
        """The frame that ends what ``last`` commanded, or None when nothing needs ending: 123
        with a speed (the start-up probe's) -> the same with zero speeds; 156 with a
        feed-forward -> its goal rounded to whole steps, with none.  (A GO TO stops at its goal
        by itself, a bounded commitment; but a goal between two steps keeps the joint stepping
        to and fro across it, one step each way, until the next frame.)"""
        if last is None or not any(last.speeds):
            return None
        if last.command == BoardCommand.JOG:
            return FrameRequest(BoardCommand.JOG, last.positions, (0,) * 6)
        if last.command == BoardCommand.GOTO:
            return FrameRequest(BoardCommand.GOTO, tuple(int(round(g)) for g in goto_goal(last.positions, last.speeds)),
                                (0,) * 6)
        return None

    # ================================================================== the stop supervisor

    def _supervisor_event(self, ev: SupervisorEvent) -> None:
        if ev.kind is SupervisorEventKind.STOPPED:
            log.error("%s", ev.text)
            self.safety = self.safety.supervisor_stopped(ev.text)
            self.probe.cancel()
            self._cancel_all("robot disabled by DISABLE")
            # the board ran on while this process stood still, then the supervisor stopped
            # it: what the next replies show was done behind the integrity check's back, not
            # against the frames it saw written; the truth starts afresh, as after a new link
            self.integrity.reset()
            self.link.anchor = None
        elif ev.kind is SupervisorEventKind.LOST:
            self.safety = self.safety.supervisor_lost(ev.text)
            self._cancel_all(f"stopped: {ev.text}")
        elif ev.kind is SupervisorEventKind.READY:
            if self.safety.supervisor_missing is not None:
                log.warning("a new stop supervisor is ready (%s): motion is accepted again", ev.text)
            self.safety = self.safety.supervisor_ready()

    # ================================================================== safety events

    def _cancel_all(self, reason: str) -> int:
        self.paused = self.queue_held = False  # nothing is left to resume
        self.queue_steps = 0
        act = self.jobs.activity
        if (isinstance(act, HomeActivity) and act.sent and self.safety.enabled
                and not self.safety.estop_latched):
            # the firmware runs a homing to its end whatever else it gets, except 101 / 102 /
            # 103: a STOP sends ENABLE (the board stays enabled, every motor stops where it
            # is, unhomed) -- with IDLE frames it homed on, and the ENABLE that followed made
            # the rest of its homing "uncommanded motion"
            self.safety = replace(self.safety, pending_code=int(BoardCommand.ENABLE))
        return self.jobs.cancel_all(reason)

    def _estop(self, reason: str) -> None:
        if not self.safety.estop_latched:
            log.warning("E-stop: %s", reason)
        self.safety = self.safety.estop()
        self.probe.cancel()  # DISABLE every tick from now on, ENABLE needed: the answer is moot
        self._cancel_all(f"E-stop: {reason}")

    def _disable(self) -> None:
        self.safety = self.safety.disable()
        self.probe.cancel()
        self._cancel_all("robot disabled by DISABLE")

    def _enable(self) -> None:
        self.safety = self.safety.enable()
        self.probe.cancel()  # the board gets 101: it will be enabled

    def _fault(self, message: str) -> None:
        """The board moved (or homed) in a way nobody commanded: disabled, everything cancelled,
        ``message`` (it names the joints) reported."""
        error = f"uncommanded motion: {message}"
        self.safety = self.safety.fault(error, f"robot disabled after {error}: send ENABLE")
        self.probe.cancel()
        self._cancel_all(error)

    def _take_probe_answer(self) -> None:
        probe = self.probe
        if probe.result is None:
            return
        enabled, probe.result = probe.result, None
        if enabled:
            return
        reason = probe.reason
        log.warning("%s", reason)
        self.safety = self.safety.board_found_disabled(reason)
        self.jobs.fail_waiting(reason)

    # ================================================================== commands

    def _apply_safe(self, sub: Submission) -> None:
        try:
            self._apply(sub)
        except Exception as exc:  # a command must never stop the tick
            log.exception("applying %s failed", sub.command.name)
            if sub.command_id is not None and sub.route is not None:
                self.jobs._acks.append(Ack(sub.command_id, sub.route, AckStatus.FAILED, f"internal error: {exc}"))

    def _apply(self, sub: Submission) -> None:
        """Apply one command from the server: an immediate command at once (its ack COMPLETED,
        FAILED or INVALID), any other queued (or refused) as :meth:`_submit`."""
        cmd = sub.command
        job = self.jobs.new_job(cmd, sub.command_id, sub.route, sub.client)
        job.ahead = sub.ahead
        if cmd.SAFETY:
            if sub.seq > self._safety_seq:
                self._safety_seq, self._safety_name = sub.seq, cmd.name
        elif sub.seq and sub.seq < self._safety_seq and (
            cmd.KIND is not C.CommandKind.IMMEDIATE or isinstance(cmd, (C.Enable, C.ClearError, C.ServoJ, C.ServoL))
        ):
            # received before a STOP / ESTOP / DISABLE that overtook it in the safety lane:
            # that command cancels it, as if it had been applied in arrival order (a servo
            # target too: taken after the stop, it would start a new stream that moves the arm
            # again: a gamepad's deadman release did that at load 30-40)
            self.jobs.ack(job, AckStatus.CANCELLED, f"{self._safety_name} received after it")
            return
        if isinstance(cmd, (C.ServoJ, C.ServoL)):
            self._servo(job, cmd)
            return
        if isinstance(cmd, C.SetPort):
            self._set_port(job, cmd)
            return
        if cmd.KIND is not C.CommandKind.IMMEDIATE:
            self._submit(job)
            return
        status, details = self._immediate(cmd, sub)
        self.jobs.ack(job, status, details)

    def _immediate(self, cmd: C.Command, sub: Submission) -> tuple[AckStatus, str]:
        if isinstance(cmd, C.Stop):
            if cmd.reason is None and self._stop_on_path("stopped by STOP"):
                return AckStatus.COMPLETED, "stopping: the running move slows down on its path; the queue is cleared"
            self._cancel_all(cmd.reason or "stopped by STOP")
            return AckStatus.COMPLETED, "stopped"
        if isinstance(cmd, C.EStop):
            self._estop("software E-stop (ESTOP command)")
            return AckStatus.COMPLETED, "E-stop latched: send ENABLE to release"
        if isinstance(cmd, C.Disable):
            self._disable()
            return AckStatus.COMPLETED, "disabled"
        if isinstance(cmd, C.Enable):
            if self.safety.estop_pressed:
                return AckStatus.FAILED, "hardware E-stop is still pressed: release it first"
            self._enable()
            return AckStatus.COMPLETED, "enabled"
        if isinstance(cmd, C.ClearError):
            self.safety = self.safety.clear_error()
            return AckStatus.COMPLETED, "error cleared"
        if isinstance(cmd, C.StreamMode):
            self._set_stream_mode(cmd.on)
            return AckStatus.COMPLETED, f"stream mode {'on' if cmd.on else 'off'}"
        if isinstance(cmd, C.SpeedCommand):
            self.speed_pct = float(cmd.percent)
            return AckStatus.COMPLETED, f"speed override {cmd.percent:g} %"
        if isinstance(cmd, C.Pause) and cmd.queue_only:
            self.queue_held = True
            return AckStatus.COMPLETED, "queue held: the running command goes on to its end; nothing queued " \
                                        "starts until RESUME"
        if isinstance(cmd, C.Pause):
            if self.paused:
                return AckStatus.COMPLETED, "already paused"
            self.paused = True
            what = ("the running move slows down on its path and holds" if self.jobs.active is not None
                    else "nothing runs")
            return AckStatus.COMPLETED, f"paused: {what}; nothing queued starts until RESUME"
        if isinstance(cmd, C.Resume) and cmd.one:
            moving = self.paused
            self.paused = False
            self.queue_held = True
            self.queue_steps += 1
            return AckStatus.COMPLETED, ("the paused move goes on; " if moving else "") + \
                "one more command starts; the queue stays held"
        if isinstance(cmd, C.Resume):
            if not (self.paused or self.queue_held):
                return AckStatus.COMPLETED, "not paused: nothing to resume"
            self.paused = self.queue_held = False
            self.queue_steps = 0
            return AckStatus.COMPLETED, "resumed"
        if isinstance(cmd, C.SetTool):
            if sub.tool is None:
                return AckStatus.INVALID, f"SET_TOOL: tool {cmd.tool!r} was not resolved"
            if self.jobs.active is not None or self.jobs.waiting:
                return AckStatus.FAILED, "robot is busy: the tool can change only when idle"
            self.tool_name, self.tool_obj = cmd.tool, sub.tool
            self._set_world(self.world.with_tool(self._tool_shape(cmd.tool)))
            return AckStatus.COMPLETED, f"tool {cmd.tool}"
        return AckStatus.INVALID, f"{cmd.name} is not a command the loop applies"

    # ================================================================== servo streams

    def _servo(self, job: Job, cmd: C.ServoJ | C.ServoL) -> None:
        """A servo target: it updates the running stream (COMPLETED ``target taken``), or
        starts one when nothing else runs (EXECUTING; the job ends when the stream does), or is
        refused (FAILED with the reason: not homed, busy, out of reach)."""
        jobs = self.jobs
        why = self._refusal(cmd)
        if why is None and (not self.homed or self.measured_deg is None):
            why = "robot is not homed: send HOME first"
        if why is not None:
            jobs.ack(job, AckStatus.FAILED, why)
            return
        act = jobs.activity
        if isinstance(act, GuardStopActivity):
            jobs.ack(job, AckStatus.FAILED, f"{cmd.name} refused: the arm is stopping short of a collision "
                                            f"({act.outcome[1]})")
            return
        if isinstance(act, ServoActivity) and act.ending is not None:
            act.resume()  # a target during the silence's slow-down: the stream goes on
        stream = act if isinstance(act, ServoActivity) and act.ending is None else None
        if stream is None and (jobs.active is not None or jobs.waiting or jobs.stream_cart is not None):
            busy = jobs.active.name if jobs.active is not None else "a queued command"
            jobs.ack(job, AckStatus.FAILED, f"robot is busy ({busy}): a servo stream starts when nothing else "
                                            "runs; wait for it or send STOP")
            return
        try:
            target, anchor = self._servo_target(cmd, stream)
        except ParolkitError as exc:
            jobs.ack(job, AckStatus.FAILED, f"{cmd.name}: {exc}")
            return
        if stream is not None:
            if stream.anchor is None:  # the stream's first TRF target: its offsets are from here
                stream.anchor = anchor
            stream.set_target(target, self._tick)
            stream.target_id = job.command_id
            jobs.ack(job, AckStatus.COMPLETED, "target taken")
            return
        servo = ServoActivity(target, self._tick, rate_hz=self.rate_hz, max_speed_steps_s=self._servo_vmax,
                              max_accel_steps_s2=self._accel, jerk_time_s=SERVO_JERK_TIME_S,
                              timeout_ticks=ticks_for(self.servo_timeout_s, self.rate_hz),
                              limits_steps=self._safe_steps)
        servo.anchor = anchor
        servo.target_id = job.command_id
        jobs.start(job, servo, f"servo stream started (a controlled stop after "
                               f"{self.servo_timeout_s:g} s without a target)")

    def _servo_target(self, cmd: C.ServoJ | C.ServoL,
                      stream: ServoActivity | None) -> tuple[list[float], object | None]:
        """The target of ``cmd`` in steps (SERVOL: the joints nearest the stream's target, or
        the measured ones, that put the TCP at the pose), and the TCP pose a TRF target is
        relative to (the stream's, else the pose now; None for the other forms)."""
        if isinstance(cmd, C.ServoJ):
            return [d * s for d, s in zip(cmd.target_deg, self._spd)], None
        from parolkit.kinematics.fk import fk_matrix
        from parolkit.kinematics.ik import ik
        from parolkit.kinematics.pose import pose_to_matrix

        assert self.measured_deg is not None
        seed = ([t / s for t, s in zip(stream.target, self._spd)] if stream is not None else list(self.measured_deg))
        tool = self.tool_obj if self.tool_obj is not None else self.tool_name
        pose: object = list(cmd.pose)
        anchor = None
        if cmd.frame is Frame.TRF:
            anchor = stream.anchor if stream is not None else None
            if anchor is None:  # the stream starts here: offsets from the TCP pose now
                anchor = fk_matrix(self.measured_deg, tool)  # type: ignore[arg-type]
            pose = anchor @ pose_to_matrix(cmd.pose)  # type: ignore[operator]
        exact = ik(pose, seed, tool)  # type: ignore[arg-type]
        deg = self._servo_wrist(pose, [float(v) for v in exact], seed, stream, tool)
        return [d * s for d, s in zip(deg, self._spd)], anchor

    def _servo_wrist(self, pose: object, exact: list[float], seed: Sequence[float], stream: ServoActivity | None,
                     tool: object) -> list[float]:
        """A SERVOL target in the wrist's singular area (|J5| of the exact solution below
        :data:`parolkit.motion.singular.WRIST_AREA_DEG`; the standby pose has J5 = 0): the
        Cartesian jog's policy, target by target.  There the exact solution's J4 is undefined
        or jumps by up to 90 deg between two nearby poses: J4 turns toward it (or its twin
        J4 +- 180, the same wrist) within J4's and J6's speed and acceleration limits (J6
        turns the other way), braking to arrive at rest, from target to target (it holds while
        |J5| < LOCK_DEG: the tilt's direction is noise), and the other joints put the TCP
        exactly at the target position, its orientation as close as that J4 allows (the
        deviation is at most the exact |J5|; it vanishes once J4 has turned)."""
        if abs(exact[4]) >= _WRIST_AREA_DEG:
            if stream is not None:
                stream.wrist_t, stream.wrist_v = self._now, 0.0
            return exact
        import numpy as np

        from parolkit.kinematics.pose import pose_to_matrix
        from parolkit.kinematics.wrist import solve_with_j4
        from parolkit.motion import singular

        j4 = float(seed[3])
        lo, hi = (float(v) for v in self.model.safe_limits_deg[3])
        want = exact[3] if abs(exact[4]) >= singular.LOCK_DEG else j4
        want = min((a for a in (want, want - 180.0, want + 180.0) if lo <= a <= hi), key=lambda a: abs(a - j4),
                   default=want)
        since = self._now - stream.wrist_t if stream is not None and stream.wrist_t is not None else self.period
        dt = min(max(since, 0.0), 0.1)
        v0 = stream.wrist_v if stream is not None else 0.0
        # J4's turn (J6 the other way): within the slower of the two, deg/s and deg/s^2
        vmax = min(self._servo_vmax[3] / self._spd[3], self._servo_vmax[5] / self._spd[5]) * singular.SPEED_SHARE
        amax = min(self._accel[3] / self._spd[3], self._accel[5] / self._spd[5]) * singular.ACCEL_SHARE
        d = want - j4
        v_want = math.copysign(min(vmax, math.sqrt(2.0 * amax * abs(d))), d)  # brakes to arrive at rest
        v = v0 + min(max(v_want - v0, -amax * dt), amax * dt)
        q4 = j4 + v * dt
        if (want - q4) * d <= 0.0:  # arrived (or would pass it)
            q4, v = want, 0.0
        if stream is not None:
            stream.wrist_t, stream.wrist_v = self._now, v
        if abs(q4 - exact[3]) < 1e-9:
            return exact
        m = np.asarray(pose if not isinstance(pose, list) else pose_to_matrix(pose), dtype=float)
        sol = solve_with_j4(m[None, :3, 3] * 1e3, m[None, :3, :3], np.array([q4]), np.array([exact]),
                            tool)  # type: ignore[arg-type]
        return [float(v) for v in sol.q_deg[0]]

    def _stop_on_path(self, reason: str) -> bool:
        """A client's STOP while a planned move (not a jog) is on its way: the queue is
        cancelled now, the move slows down along its own path within the acceleration limits
        and ends CANCELLED where it stands (:meth:`TrajectoryActivity.stop_on_path`).  False
        when there is no such move: the caller cancels everything at once (a jog stops within
        a frame, as the original's; a move settling on its target holds there)."""
        a, act = self.jobs.active, self.jobs.activity
        if isinstance(act, ServoActivity):
            act.finish(AckStatus.CANCELLED, reason)  # a controlled stop, then the stream ends
            self.paused = False
            self.jobs.cancel_waiting(reason)
            return True
        if (a is None or not isinstance(act, TrajectoryActivity) or isinstance(act, SpeedActivity)
                or a.streamed or a.command.STREAMABLE or a.command.EXECUTION is not Execution.PLANNED):
            return False
        if not act.stop_on_path(reason):
            return False
        self.paused = False
        self.jobs.cancel_waiting(reason)
        return True

    def _set_stream_mode(self, on: bool) -> None:
        self.stream_mode = on
        a = self.jobs.active
        if not on and a is not None and a.streamed:
            self.jobs.end_active(AckStatus.COMPLETED, "stream mode switched off")

    def _refusal(self, cmd: C.Command) -> str | None:
        """Why ``cmd`` cannot be accepted now, or None."""
        s = self.safety
        why = s.refusal(motion=False)
        if why is not None:
            return why
        if self._switch is not None:
            # (until then the link is down, or up on a board whose state is not known yet)
            return f"the board link is switching to {self._switch[0]}: send it once SET_PORT is COMPLETED"
        if not self.link_up:
            return f"board link is down ({s.error or 'reconnecting'})"
        if cmd.is_motion or cmd.EXECUTION is Execution.HOME:
            return s.refusal(motion=True)
        return None

    def _submit(self, job: Job) -> None:
        """Queue ``job`` (QUEUED ack) or refuse it (FAILED ack).  Streaming jogs replace."""
        cmd = job.command
        jobs = self.jobs
        why = self._refusal(cmd)
        if why is not None:
            jobs.ack(job, AckStatus.FAILED, why)
            return
        if isinstance(jobs.activity, ServoActivity):
            # a queued command ends a servo stream: a controlled stop, then it runs
            jobs.activity.finish(AckStatus.COMPLETED, f"servo stream ended by {cmd.name}, stopped under control")
        if self.stream_mode and cmd.STREAMABLE and not jobs.waiting and (jobs.active is None or jobs.active.streamed):
            job.streamed = True
            if jobs.active is not None and jobs.active.streamed and jobs.activity is not None:
                # an update arrived: the client still holds the jog (the watchdog counts from
                # here, not from when a CARTJOG's plan is ready)
                jobs.activity.touch(self._now)
            if cmd.EXECUTION is Execution.PLANNED:
                if not self.homed or self.measured_deg is None:
                    jobs.ack(job, AckStatus.FAILED, "robot is not homed: send HOME first")
                    return
                old = jobs.stream_cart
                if old is not None and old.command == cmd:
                    # the same jog already waits for its plan: superseding it would restart
                    # planning with every update and, with updates faster than planning, no
                    # plan would ever take over
                    jobs.ack(job, AckStatus.COMPLETED, "merged into the same jog waiting for its plan")
                    return
                jobs.stream_cart = job
                if old is not None:
                    jobs.ack(old, AckStatus.COMPLETED, "superseded by a newer jog before it started")
            else:
                self._stream_replace(job)
            return
        if not jobs.admit(job):
            return
        if job.ahead is not None:
            early = self._early.pop(job.ahead, None)
            if early is not None:
                self._take_plan(early)
        # what needs no plan (a delay, an output, ...) may start in this very tick, and a move's
        # plan is asked for now: a command queued behind a running one starts the tick that one
        # ends (a program's lines run back to back: issue 24, "programs on ticks")
        self._request_plans()

    # ================================================================== planning

    def _chain_start(self) -> tuple[float, ...] | None:
        a = self.jobs.active
        if a is not None:
            return a.final_deg
        return self.measured_deg if self.homed else None

    def _request(self, job: Job, start: tuple[float, ...], jog_start: object = None,
                 chain: Sequence[Job] = (), world: CollisionWorld | None = None) -> None:
        ids = tuple(f.seq for f in chain)
        if job.planning is not None and job.chain_asked == ids:
            return
        if ids or job.chain_asked:
            # a blended chain (or one that grew): a key of its own, so that the answer to an
            # earlier request (the move alone, a shorter chain) is dropped when it comes
            self._chain_keys += 1
            key = _CHAIN_KEY_BASE + self._chain_keys
            job.planned = False
        else:
            key = job.seq
        job.planning, job.chain_asked = key, ids
        self._plan_requests.append(PlanRequest(key, job.command, start, self.tool_name, self.tool_obj,
                                               self.rate_hz, self.model, jog_start, self.config,
                                               tuple(f.command for f in chain),
                                               self.world if world is None else world, self.speed_pct))

    def _blend_followers(self, waiting: Sequence[Job], idx: int) -> list[Job]:
        """The waiting jobs after ``waiting[idx]`` that its plan blends into (issue 24): the
        consecutive moves of its kind (MoveCart; MoveJoint / MovePose) and tracking, as long as
        the one before each has a blend radius; at most :data:`MAX_BLEND_CHAIN` in all."""
        head = waiting[idx]
        move = getattr(head.command, "move", None)
        kind = blend_kind(move)
        out: list[Job] = []
        if kind is None:
            return out
        cur = move
        for job in list(waiting)[idx + 1: idx + MAX_BLEND_CHAIN]:
            nxt = getattr(job.command, "move", None)
            if (not getattr(cur, "blend", None) or blend_kind(nxt) != kind
                    or getattr(nxt, "tracking", None) != getattr(move, "tracking", None)):
                break
            out.append(job)
            cur = nxt
        return out

    def _riding(self, job: Job) -> bool:
        """``job`` is played by the running activity: a follower of the blended chain that
        runs."""
        return (job.rider_of is not None and self._chain_act is not None
                and self.jobs.activity is self._chain_act and job.rider_of == self._chain_head)

    def _request_plans(self) -> None:
        """Ask for the plans the next jobs need: a streamed Cartesian jog first, then the first
        :data:`PLAN_AHEAD` queued ones in order, each from the final joints of the one before
        (or the measured joints when nothing runs)."""
        jobs = self.jobs
        sc = jobs.stream_cart
        if sc is not None:
            if sc.planning is None and self.measured_deg is not None and self.homed:
                start, jog_start = self._stream_start(sc)
                self._request(sc, start, jog_start)
            return
        prev = self._chain_start()
        # the collision world each job will run in: the one in force, as changed by the
        # ATTACH / DETACH queued before it
        world = self.world
        waiting = list(jobs.waiting)
        skip = 0
        count = 0
        for idx, job in enumerate(waiting):
            if skip:
                skip -= 1
                continue
            if self._riding(job):
                continue  # played by the blended chain that runs (prev: where it ends)
            if count >= PLAN_AHEAD:
                return
            count += 1
            if job.rider_of is not None:
                # its chain no longer runs (it failed or was replaced): planned on its own
                job.rider_of, job.planned = None, False
            ex = job.command.EXECUTION
            if ex is Execution.HELD:
                world = self._held_world(world, job.command)[0] or world
            if ex is Execution.HOME:
                job.planned = True
                prev = tuple(float(v) for v in self.model.standby_deg)
                job.final_deg = prev
                continue
            if ex is Execution.SPEED:
                job.planned, job.final_deg = True, None
                prev = None
                continue
            if ex is not Execution.PLANNED:
                job.planned, job.final_deg = True, prev
                continue
            followers = self._blend_followers(waiting, idx)
            ids = tuple(f.seq for f in followers)
            if job.planning is not None and job.chain_asked == ids:
                return  # its plan is on its way
            if job.ahead is not None and not ids:
                return  # the plan the server asked for ahead is on its way
            if (job.planned and job.planning is None and job.start_deg == prev and job.chain == ids
                    and job.world == world):
                prev = job.final_deg if job.plan_error is None else prev
                if job.plan_error is None:
                    for f in followers:
                        f.ride(job)
                    skip = len(followers)
                continue
            if prev is None:
                return
            self._request(job, prev, chain=followers, world=world)
            return

    def _stream_start(self, job: Job) -> tuple[tuple[float, ...], object]:
        """Where a streamed Cartesian jog starts (deg), and the running jog's ``JogStart``:
        where the running streamed jog last commanded the board, so a held jog continues
        smoothly; the measured joints only when none runs.  (The measured position lags the
        commanded one: planning every update from it stepped back each time, and a held jog
        covered a fraction of its distance.)"""
        act = self.jobs.activity
        a = self.jobs.active
        if a is not None and a.streamed and isinstance(act, TrajectoryActivity):
            steps = act.commanded()
            if steps is not None:
                job.stream_anchor = (act, act.i)
                jog_start = getattr(a.trajectory, "jog_start", None)
                js = jog_start(act.i - 1) if callable(jog_start) else None
                return tuple(p / s for p, s in zip(steps, self._spd)), js
        job.stream_anchor = None
        assert self.measured_deg is not None
        return self.measured_deg, None

    def _take_plans(self, results: Sequence[PlanResult]) -> None:
        for r in results:
            self.counters.planned += 1
            self.counters.plan_time_s += r.seconds
            if not self._take_plan(r) and r.key < 0:
                # a plan the server asked for ahead (its keys are negative), before its command
                # arrived; a job's own plan (its number) whose job has gone is dropped
                self._early[r.key] = r
                while len(self._early) > _EARLY_PLANS:
                    self._early.popitem(last=False)

    def _take_plan(self, r: PlanResult) -> bool:
        """Attach ``r`` to the job that asked for it (False: no such job, yet)."""
        jobs = self.jobs
        sc = jobs.stream_cart
        if sc is not None and sc.planning == r.key:
            sc.planning = None
            jobs.stream_cart = None
            if r.error is not None:
                jobs.ack(sc, AckStatus.FAILED, r.error)
                return True
            assert r.samples is not None and r.final_deg is not None
            sc.set_plan(r.start_deg, r.trajectory, r.samples, r.final_deg, r.notes)
            self._stream_replace(sc)
            return True
        for i, job in enumerate(jobs.waiting):
            if job.planning == r.key:
                job.planning = None
                job.chain = job.chain_asked
                job.marks = r.marks
            elif job.ahead == r.key:
                job.ahead = None
                if (r.tool_name != self.tool_name or i != 0 or jobs.active is not None or r.command is not job.command
                        or job.chain_asked or r.world != self.world):
                    # the plan assumed another start or tool, or the move blends into the ones
                    # queued after it (the plan of the chain is on its way): planned as usual
                    return True
                job.chain, job.marks = (), ()
            else:
                continue
            job.world = r.world
            if r.error is not None:
                job.set_plan_error(r.start_deg, r.error)
            else:
                assert r.samples is not None and r.final_deg is not None
                job.set_plan(r.start_deg, r.trajectory, r.samples, r.final_deg, r.notes)
                if job.chain:
                    # the jobs it blends into are played by this plan from now on
                    for f in jobs.waiting:
                        if f.seq in job.chain:
                            f.ride(job)
            return True
        return False

    # ================================================================== the collision world

    def _tool_shape(self, name: str) -> Any:
        """The body of the tool ``name`` (``[tools.NAME] shape`` of the config), None when it
        has none (the built-in tools)."""
        for t in getattr(self.config, "tools", None) or ():
            if getattr(t, "name", None) == name:
                return getattr(t, "shape", None)
        return None

    def _set_world(self, world: CollisionWorld) -> None:
        """The world changes (SET_TOOL, ATTACH, DETACH): its scene is asked for (or taken from
        the ones kept); a guarded motion's floors start again."""
        if world == self.world:
            return
        self.world = world
        self.world_seq += 1
        self._floors.clear()
        kept = self._scenes.get(world)
        self.scene = kept.scene if kept is not None else None

    def _held_world(self, world: CollisionWorld, cmd: C.Command) -> tuple[CollisionWorld | None, str]:
        """The world after ATTACH / DETACH ``cmd`` and its ack's words; (None, why) when it
        cannot be done."""
        names = ", ".join(repr(h.name) for h in world.held)
        if isinstance(cmd, C.Attach):
            item = held_item(cmd)
            again = any(h.name == item.name for h in world.held)
            if not again and len(world.held) >= MAX_HELD:
                return None, (f"ATTACH: at most {MAX_HELD} objects may be held ({names}): DETACH one first")
            what = "in place of the one of that name: " if again else ""
            return world.with_held(item), f"attached {item.name!r}: {what}{item.describe()} in the flange frame"
        if isinstance(cmd, C.Detach):
            name = cmd.object_name
            if name is None:
                gone = [h.name for h in world.held]
                if not gone:
                    return world, "nothing was held"
                if len(gone) == 1:
                    return world.without(None), f"detached {gone[0]!r}"
                return world.without(None), f"detached {len(gone)} objects: {names}"
            if not any(h.name == name for h in world.held):
                held = f"held: {names}" if names else "nothing is held"
                return None, f"DETACH: no held object named {name!r} ({held})"
            return world.without(name), f"detached {name!r}"
        return world, ""

    def _take_scenes(self, results: Sequence[SceneResult]) -> None:
        """Scenes the driver built: kept (a few), and the current world's swapped in."""
        if not results:
            return
        for r in results:
            self._scenes_asked.discard(r.world)
            self._scenes[r.world] = r
            self._scenes.move_to_end(r.world)
            while len(self._scenes) > 8:
                self._scenes.popitem(last=False)
            if r.error is not None:
                log.error("%s", r.error)
        kept = self._scenes.get(self.world)
        if kept is not None:
            self.scene = kept.scene

    def _ask_scene(self) -> None:
        """Ask the driver for the current world's scene when it is neither here nor asked for."""
        w = self.world
        if self.scene is None and w not in self._scenes and w not in self._scenes_asked:
            self._scenes_asked.add(w)
            self._scene_requests.append(SceneRequest(w))

    def _scene_ready(self) -> bool:
        return self.scene is not None

    def _scene_error(self) -> str | None:
        kept = self._scenes.get(self.world)
        return kept.error if kept is not None else None

    def _checked_every_tick(self) -> bool:
        """The running job's motion is checked every tick (jogs, servo streams) and its
        activity is its own (not the stop the check chose).  Not before homing: the joints'
        positions are not known then (a jog press is limited to ``unhomed_jog_travel_deg``)."""
        a, act = self.jobs.active, self.jobs.activity
        return (a is not None and self.homed and a.command.COLLISION is CollisionCheck.TICK
                and not isinstance(act, GuardStopActivity))

    def _hold_request(self) -> FrameRequest:
        """A frame that holds the arm where the last frame took it (nothing new commanded)."""
        return self.stop_request(self.last_frame) or FrameRequest(BoardCommand.IDLE)

    def _guard_words(self) -> str:
        a = self.jobs.active
        if a is None:
            return "motion"
        if isinstance(a.command, (C.ServoJ, C.ServoL)):
            return "servo stream"
        return "jog" if a.command.STREAMABLE else a.label

    def _stop_after(self, act: Activity) -> StopPlan | None:
        """The controlled stop of ``act`` beginning at the next tick (its last frame just
        made): along its path for a path-following jog, joint by joint for a servo stream."""
        if isinstance(act, TrajectoryActivity):
            s = act.sample_position
            if s is None or not act.n:
                return None
            return path_stop(act.positions, act.speeds, s, act.k, self._accel, self.rate_hz,
                             straight=isinstance(act, SpeedActivity))
        if isinstance(act, ServoActivity):
            st = act.motion_state
            return None if st is None else joint_stop(st[0], st[1], self._accel, self.rate_hz)
        return None

    def _guard_frame(self, act: Activity, req: FrameRequest, ctx: TickContext) -> FrameRequest:
        """The per-tick collision check of a jog or servo stream's frame ``req`` (docs/collision.md,
        "Jogs and servo streams"): if the controlled stop beginning at the next tick, from this
        frame's goal, would bring a pair within its margin, the frame does not go: the stop
        checked with the last frame (it begins now) is played instead and the job ends FAILED
        naming the pair; with no such stop (the motion starts here) the job is refused and the
        arm holds."""
        if req.command != BoardCommand.GOTO or req.positions is None or ctx.origin is None:
            return req
        stop = self._stop_after(act)
        if stop is None:
            return req
        goal = goto_goal(req.positions, req.speeds)
        self.guard_checks += 1
        verdict = stop_check(self.scene, ctx.origin, goal, stop, self._rad_per_step, self._floors)
        if verdict is None:
            self._stop_plan = stop
            return req
        what = self._guard_words()
        prev = self._prev_stop
        if prev is None:
            why = f"{what} refused: {verdict.words()}: moving on would bring it within the margin"
            log.warning("%s", why)
            return replace(self._hold_request(), done=AckStatus.FAILED, details=why)
        why = f"{what} stopped: {verdict.words()}: a controlled stop from here would end within the margin"
        log.warning("%s", why)
        stop_act = GuardStopActivity(prev.samples(), settle_ticks=max(3, int(SETTLE_TIMEOUT_S * self.rate_hz)),
                                     started=self._now, status=AckStatus.FAILED, details=why)
        self.jobs.activity = stop_act
        if act is self._chain_act:
            self._chain_act = None
        return stop_act.step(ctx)

    def _collision_view(self) -> CollisionView:
        waiting = None
        if self._checked_every_tick() and not self._scene_ready():
            a = self.jobs.active
            err = self._scene_error()
            waiting = err or (f"{a.name if a else 'motion'} waits for the collision check of the current world "
                              "(being built)")
        return CollisionView(self.world, self.world_seq, self._scene_ready(), waiting)

    # ================================================================== running jobs

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

    def _speed_stretch(self, speeds: Sequence[int], secs: float) -> str | None:
        """The warning of a speed move (JOG, MULTIJOG, SPEEDJOINT) above a joint's position-
        tracking maximum (within its maximum: the seed's speed rule runs it, stretched), naming
        the joint that limits it most; None when it is within every one."""
        ratios = [abs(v) / m for v, m in zip(speeds, self._servo_vmax)]
        j = max(range(6), key=ratios.__getitem__)
        if ratios[j] <= 1.0:
            return None
        return (f"warning: {JOINT_NAMES[j]} at {abs(speeds[j])} steps/s is above its position-tracking maximum "
                f"{self._servo_vmax[j]:.0f} steps/s (the bounded GO TO frames cannot follow faster): the same "
                f"distance runs stretched, about {secs:.2f} s -> {secs * ratios[j]:.2f} s")

    def _speed_joint_range(self, speeds_deg_s: Sequence[float], secs: float) -> str | None:
        """SPEEDJOINT from the measured joints: the refusal when a joint would leave its range
        within ``secs`` (s) at ``speeds_deg_s`` (deg/s), in the words of the planner's (the
        script's) refusal of the same SpeedJoint; None when it stays inside."""
        start = self.measured_deg
        if start is None:
            return None  # no status yet: the activity's own limit stop applies
        worst: tuple[float, int, float] | None = None
        for j, (q0, v, (lo, hi)) in enumerate(zip(start, speeds_deg_s, self._safe_deg)):
            end = q0 + v * secs
            if lo <= end <= hi:
                continue
            bound = hi if v > 0 else lo
            t_hit = max(0.0, (bound - q0) / v) if v != 0 else 0.0
            if worst is None or t_hit < worst[0]:
                worst = (t_hit, j, end)
        if worst is None:
            return None
        th, j, end = worst
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
        duration cut so the press stops at the limit (the note says so), or an error when less
        than a tick of travel is left.  A homed robot is not limited (the joint limits are)."""
        if self.homed:
            self._press_speeds = None
            return secs, "", None
        prev = self._press_speeds
        if not continuing or prev is None:
            self._press_used = [0.0] * 6
        else:  # the same press goes on: count what it moved so far
            v0, t0, t1 = prev
            for j in range(6):
                self._press_used[j] += abs(v0[j]) / self._spd[j] * max(0.0, min(now, t1) - t0)
        used = self._press_used
        cap = self.unhomed_jog_travel_deg
        room = {j: max(0.0, cap - used[j]) * self._spd[j] / abs(v) for j, v in enumerate(speeds) if v != 0}
        allowed = min([secs, *room.values()])
        stops = [JOINT_NAMES[j] for j, t in room.items() if t == allowed]
        if allowed < self.period:
            self._press_speeds = ((0,) * 6, now, now)  # still held: the next update is refused too
            return 0, "", (f"robot not homed: this jog press has used its {cap:g} deg of travel "
                           f"({', '.join(stops)}): release and press again, or send HOME to lift the limit")
        self._press_speeds = (tuple(int(v) for v in speeds), now, now + allowed)
        if allowed < secs:
            return allowed, (f"robot not homed: jog travel limited to {cap:g} deg per press "
                             f"({', '.join(stops)} stops there); send HOME to lift the limit"), None
        return secs, "", None

    def _stream_replace(self, job: Job) -> None:
        """Make a streamed jog the running job, superseding the previous one."""
        now = self._now
        jobs = self.jobs
        if job.terminal is not None:
            return
        s = self.safety
        if s.estop_latched or not s.enabled:
            jobs.ack(job, AckStatus.FAILED, "robot is disabled or E-stopped")
            return
        if jobs.waiting or (jobs.active is not None and not jobs.active.streamed):
            # something non-streamed is running: queue it like any other command
            job.streamed = False
            jobs.waiting.append(job)
            jobs.ack(job, AckStatus.QUEUED, f"Position {len(jobs.waiting) + 1} in queue")
            return
        cmd = job.command
        if cmd.EXECUTION is Execution.PLANNED and not self.homed:
            jobs.ack(job, AckStatus.FAILED, "robot is not homed: send HOME first")
            return
        old, old_act = jobs.active, jobs.activity
        if isinstance(old_act, GuardStopActivity):
            # the running jog is stopping short of a collision: that stop is not cut short
            jobs.ack(job, AckStatus.FAILED, f"jog refused: the arm is stopping short of a collision "
                                            f"({old_act.outcome[1]})")
            return
        if old is not None and isinstance(old_act, SpeedActivity) and cmd.EXECUTION is Execution.SPEED:
            speeds, secs, err = self._speed_plan(cmd)
            note = ""
            if err is None:
                secs, note, err = self._cap_unhomed_travel(speeds, secs, now, continuing=True)
            if err is not None:
                jobs.ack(job, AckStatus.FAILED, err)
                return
            old_act.replace(speeds, secs, now, now)
            jobs.ack(old, AckStatus.COMPLETED, "superseded by a newer jog")
            jobs.active = job
            jobs.ack(job, AckStatus.EXECUTING, note)
            return
        if old is not None:
            jobs.ack(old, AckStatus.COMPLETED, "superseded by a newer jog")
            jobs.active = jobs.activity = None
        self._activate(job)
        anchor = job.stream_anchor
        act = jobs.activity
        if anchor is not None and anchor[0] is old_act and isinstance(act, TrajectoryActivity) \
                and isinstance(old_act, TrajectoryActivity):
            # planned from old_act's sample anchor[1] - 1; old_act would send old_act.i next
            act.skip(old_act.i - anchor[1])

    def _activate(self, job: Job) -> None:
        """``job`` runs from this tick: its activity (or FAILED when it cannot run)."""
        cmd = job.command
        now = self._now
        settle = max(3, int(SETTLE_TIMEOUT_S * self.rate_hz))
        ex = cmd.EXECUTION
        act: Activity
        if ex is Execution.HOME:
            act = HomeActivity(self.model.standby_steps, ticks_for(self.homing_timeout_s, self.rate_hz),
                               start_timeout_ticks=ticks_for(HOME_START_TIMEOUT_S, self.rate_hz))
        elif ex is Execution.SPEED:
            speeds, secs, err = self._speed_plan(cmd)
            if err is None:
                # a held streamed jog that ran into the limit and sends its next update is
                # still the same press; anything else starts a new one
                held = (job.streamed and self._press_speeds is not None
                        and now <= self._press_speeds[2] + self.watchdog_s + 2.0 * self.period)
                secs, note, err = self._cap_unhomed_travel(speeds, secs, now, continuing=held)
                if note:
                    job.notes = (*job.notes, note)
            if err is not None:
                self.jobs.ack(job, AckStatus.FAILED, err)
                return
            stretch = self._speed_stretch(speeds, secs)
            if stretch is not None:
                job.notes = (*job.notes, stretch)
            act = SpeedActivity(speeds, secs, rate_hz=self.rate_hz, settle_ticks=settle, streamed=job.streamed,
                                started=now, schedule_start=now)
        elif ex is Execution.PLANNED:
            for note in job.warnings:
                log.warning("%s (%s): %s", job.name, job.command_id or "no id", note)
            assert job.samples is not None
            act = TrajectoryActivity(job.samples, settle_ticks=settle, streamed=job.streamed, started=now,
                                     schedule_start=now)
            self.plan_seq += 1
            if job.chain:
                # a blended chain: the jobs planned with it follow as the arm passes their marks
                self._chain_act, self._chain_head = act, job.seq
                self._marks = deque(job.marks)
        elif ex is Execution.HELD:
            world, why = self._held_world(self.world, cmd)
            if world is None:
                self.jobs.ack(job, AckStatus.FAILED, why)
                return
            self._set_world(world)
            act = DoneActivity(why)
        elif isinstance(cmd, C.Delay):
            act = DelayActivity(int(round(cmd.seconds * self.rate_hz)))
        elif isinstance(cmd, C.Checkpoint):
            act = CheckpointActivity(cmd.label)
        elif isinstance(cmd, C.PneumaticGripper):
            on = cmd.action == "open"  # as the original: open = output on
            self.setpoints = self.setpoints.with_output(cmd.port, on)
            act = OutputActivity(cmd.port, on, ticks_for(OUTPUT_REPORT_TIMEOUT_S, self.rate_hz))
        elif isinstance(cmd, C.ElectricGripper):
            act = self._gripper(cmd)
        elif isinstance(cmd, C.WaitInput):
            to = ticks_for(cmd.timeout_s, self.rate_hz) if cmd.timeout_s is not None else None
            act = WaitInputActivity(cmd.input_no, cmd.state, to)
        else:
            self.jobs.ack(job, AckStatus.FAILED, f"{cmd.name} cannot be executed")
            return
        self.jobs.start(job, act, "; ".join(job.notes) if job.notes else "")

    def _gripper(self, cmd: C.ElectricGripper) -> Activity:
        sp = self.setpoints
        if cmd.action == "move":
            self.setpoints = sp.with_gripper(
                position=cmd.position, speed=cmd.speed, current=cmd.current_ma,
                command=GripperCommandBits.ACTIVATE | GripperCommandBits.MOVE | GripperCommandBits.RELEASE_DIR)
            return OneShotActivity()
        if cmd.action == "calibrate":
            # the whole queue waits for the calibration, as in the original controller: the
            # gripper ignores moves meanwhile, and COMPLETED means calibrated
            self.setpoints = sp.with_gripper(command=GripperCommandBits.ACTIVATE | GripperCommandBits.RELEASE_DIR)
            return GripperCalibrateActivity(ticks_for(GRIPPER_CALIBRATE_TIMEOUT_S, self.rate_hz))
        return OneShotActivity(GripperMode.CLEAR_ERROR)

    def _try_activate(self) -> None:
        """Start the next waiting job if it can run (planned, from where the robot is)."""
        jobs = self.jobs
        while jobs.waiting and not (self.paused or (self.queue_held and not self.queue_steps)):
            job = jobs.waiting[0]
            cmd = job.command
            if job.rider_of is not None:
                # the chain that was to play it ended early: planned again, on its own
                job.rider_of, job.planned = None, False
                return
            if cmd.is_motion and not self.homed and not (cmd.EXECUTION is Execution.SPEED and cmd.STREAMABLE):
                # before homing only jogs (JOG, MULTIJOG) move the robot
                jobs.waiting.popleft()
                jobs.ack(job, AckStatus.FAILED, "robot is not homed: send HOME first")
                continue
            if not job.planned:
                return
            if job.plan_error is not None:
                jobs.waiting.popleft()
                jobs.ack(job, AckStatus.FAILED, job.plan_error)
                continue
            if needs_plan(cmd):
                meas = self.measured_deg
                if meas is None or job.start_deg is None or any(
                    abs(a - b) > START_TOLERANCE_DEG for a, b in zip(meas, job.start_deg)
                ) or job.world != self.world:
                    job.planned = False  # plan (and check) again from where the robot is, in this world
                    return
            jobs.waiting.popleft()
            if self.queue_held:
                self.queue_steps -= 1  # (RESUME|ONE)
            self._activate(job)
            if jobs.active is not None:
                return

    # ================================================================== this tick's frame

    def _frame(self, inp: TickInput) -> CommandFrame:
        """This tick's frame: what the safety state asks, or the probe's, or the running
        activity's, through the guard."""
        return self._guarded(self._request_frame(inp), inp.time)

    def _request_frame(self, inp: TickInput) -> FrameRequest:
        jobs = self.jobs
        tick = inp.tick
        s, code = self.safety.frame_code(tick, idle=jobs.activity is None)
        self.safety = s
        if code is not None:
            return FrameRequest(code)
        if self.probe.active:
            # is the board enabled?  Nothing else runs until it answers (a few ticks)
            code, speeds = self.probe.frame(self.status, self._limits)
            return FrameRequest(code, speeds=speeds)
        if jobs.active is None and jobs.waiting:
            self._try_activate()
        act = jobs.activity
        if act is None:
            return FrameRequest(BoardCommand.IDLE)
        ctx = self._context(inp)
        req = self._run_activity(act, ctx)
        if req.done is not None and act.frameless_end and jobs.waiting:
            # its end needs no frame of its own (it only saw the board's report): the next
            # queued command takes this tick (an Output() lasts one tick, as in the original)
            self._try_activate()
            nxt = jobs.activity
            if nxt is not None:
                req = self._run_activity(nxt, self._context(inp))
        return req

    def _context(self, inp: TickInput) -> TickContext:
        box = self.guard.goal_box(self.link, inp.time)
        last = self.link.last
        if last is not None and last.command == BoardCommand.GOTO:
            origin: list[float] | None = goto_goal(last.positions, last.speeds)
        else:
            st = self.status
            origin = [float(p) for p in st.positions] if st is not None else None
        return TickContext(inp.tick, inp.time, self.rate_hz, self.status, self.homed, self.stream_mode,
                           self.watchdog_s, self._limits, box, origin, self.integrity.homing_seen,
                           speed_scale=0.0 if self.paused else self.speed_pct / 100.0, accel_steps_s2=self._accel)

    def _run_activity(self, act: Activity, ctx: TickContext) -> FrameRequest:
        """This tick's request of the running job's activity; ends the job (its terminal ack)
        when the request says so.  A jog's or servo stream's frame passes the collision check
        first (:meth:`_guard_frame`); until the check of the current world is ready it waits,
        holding the arm."""
        guarded = self._checked_every_tick()
        if guarded and not self._scene_ready():
            err = self._scene_error()
            req = self._hold_request()
            if isinstance(act, TrajectoryActivity):
                act.wait_start(ctx)
            if err is not None:
                req = replace(req, done=AckStatus.FAILED, details=err)
                self.jobs.end_active(req.done, req.details)  # type: ignore[arg-type]
            return req
        try:
            req = act.step(ctx)
            if guarded and req.done is None:
                req = self._guard_frame(act, req, ctx)
        except Exception as exc:
            log.exception("activity of %s failed", self.jobs.active.name if self.jobs.active else "?")
            req = FrameRequest(BoardCommand.IDLE, done=AckStatus.FAILED, details=f"internal error: {exc}")
        if act is self._chain_act:
            self._hand_over(act, req)
        if req.done is not None:
            self.jobs.end_active(req.done, req.details)
        return req

    def _hand_over(self, act: Activity, req: FrameRequest) -> None:
        """A blended chain plays on: each job of it is done once the sample nearest its target
        is played (COMPLETED, and the next one EXECUTING); all of them when the chain completes.
        A chain that ends otherwise (stopped, failed) leaves the rest waiting: STOP cancels
        them, else each is planned again on its own."""
        jobs = self.jobs
        marks = self._marks
        done = req.done is AckStatus.COMPLETED
        while marks and (done or (isinstance(act, TrajectoryActivity) and act.i > marks[0])):
            nxt = jobs.waiting[0] if jobs.waiting else None
            if nxt is None or nxt.rider_of != self._chain_head:
                marks.clear()
                break
            marks.popleft()
            jobs.hand_over(nxt, "passed its target, blended into the next move")
        if req.done is not None:
            self._chain_act, self._chain_head = None, None
            marks.clear()

    def _compose(self, req: FrameRequest) -> CommandFrame:
        st = self.status
        pos = req.positions if req.positions is not None else (st.positions if st is not None else (0,) * 6)
        return self.setpoints.frame(pos, req.speeds, req.command, req.gripper_mode)

    def _guarded(self, req: FrameRequest, t_write: float) -> CommandFrame:
        """``req`` as a frame, through the guard (a refused frame FAILs the running job)."""
        frame = self._compose(req)
        s = self.safety
        res = self.guard.check(frame, self.link, self.status, estop=s.blocked, homed=self.homed, t_write=t_write)
        if res.violation is not None:
            log.error("safety guard replaced a %s frame: %s", frame.command, res.violation)
            if self.jobs.active is not None:
                self.jobs.end_active(AckStatus.FAILED, f"safety guard: {res.violation}")
        return res.frame

    def final_frames(self, t_write: float, written: Written | None = None) -> list[CommandFrame]:
        """The frames a clean shutdown writes, through the guard (``written``: the last frame
        written, if no tick has taken it in yet): the end of the last frame's motion if it needs
        one, then DISABLE (outputs and gripper setpoints kept: a part held is not dropped, as
        the stop supervisor leaves them)."""
        if written is not None and self.link_up:
            self._written(written)
        self._cancel_all("controller shutting down")
        out = []
        stop = self.stop_request(self.last_frame)
        if stop is not None:
            out.append(self._guarded(stop, t_write))
        out.append(self._guarded(FrameRequest(BoardCommand.DISABLE), t_write))
        return out

    # ================================================================== the snapshot

    def state(self) -> RobotState:
        if not (self.link_up and self.status is not None):
            return RobotState.DISCONNECTED
        s = self.safety
        if s.estop_latched or s.estop_pressed:
            return RobotState.ESTOP
        if not s.enabled:
            return RobotState.DISABLED
        a = self.jobs.active
        if a is not None:
            if a.command.EXECUTION is Execution.HOME:
                return RobotState.HOMING
            if a.command.is_motion:
                return RobotState.MOVING
        if s.error:
            return RobotState.ERROR
        return RobotState.IDLE

    def _plan_view(self) -> PlanView:
        a = self.jobs.active
        if a is None or a.trajectory is None:
            return PlanView(self.plan_seq, a.name if a else None)
        return PlanView(self.plan_seq, a.name, a.command_id, a.final_deg, a.trajectory)

    def snapshot_now(self, inp: TickInput, frame: CommandFrame | None) -> Snapshot:
        """The snapshot the update of ``inp`` (which wrote ``frame``) would have given: asked
        after an update made without one (:attr:`TickInput.snapshot` False), before the next."""
        return self._snapshot(inp, frame)

    def _snapshot(self, inp: TickInput, frame: CommandFrame | None) -> Snapshot:
        jobs = self.jobs
        a, act = jobs.active, jobs.activity
        info = (CommandInfo(a.command_id, a.name, act.progress if act else 0.0,
                            act.target_id if isinstance(act, ServoActivity) else None)
                if a is not None else None)
        s = self.safety
        loop = dict(inp.loop_stats)
        loop.update(self.counters.as_dict())
        loop["guard_replaced_frames"] = self.guard.replaced_frames
        loop["guard_violations"] = self.guard.violations
        board = BoardInfo(self.link_up and self.status is not None, self.board.simulated, self.board.port)
        return Snapshot(
            seq=inp.tick + 1, time=inp.wall - (self._start_wall or inp.wall), state=self.state(),
            enabled=s.enabled, estop_pressed=s.estop_pressed, estop_latched=s.estop_latched,
            status=self.status or self.last_status, board=board, error=s.error, command=info,
            queue=len(jobs.waiting), stream_mode=self.stream_mode, tool=self.tool_name, plan_seq=self.plan_seq,
            outputs=self.setpoints.outputs, steps_per_deg=self._spd, pose_provider=self.pose_provider,
            loop=loop, server=dict(inp.server_stats),
            integrity=self.integrity.view(self._board_time(inp.time, inp.wall)),
            # known once the core has taken the probe's answer in (it does so in the tick after
            # the reply that answered it: until then the snapshot would show the old state)
            state_known=not self.probe.active and self.probe.result is None,
            sent=frame if self.link_up else None, queue_view=jobs.view(), plan=self._plan_view(),
            speed_pct=self.speed_pct, paused=self.paused, queue_held=self.queue_held,
            collision=self._collision_view(),
        )

    # ================================================================== views for tests and tools

    def apply(self, sub: Submission) -> list[Ack]:
        """Apply one command between ticks, as an update would (tools and tests); returns the
        acks it produced."""
        self._apply_safe(sub)
        return self.jobs.take_acks()

    @property
    def busy(self) -> bool:
        return self.jobs.busy

    @property
    def steps_per_deg(self) -> tuple[float, ...]:
        return self._spd

    @property
    def active(self) -> Job | None:
        return self.jobs.active

    @property
    def activity(self) -> Activity | None:
        return self.jobs.activity

    @property
    def queue(self) -> Sequence[Job]:
        return self.jobs.waiting

    @property
    def estop_latched(self) -> bool:
        return self.safety.estop_latched

    @property
    def estop_pressed(self) -> bool:
        return self.safety.estop_pressed

    @property
    def enabled(self) -> bool:
        return self.safety.enabled

    @property
    def error(self) -> str | None:
        return self.safety.error


#: ``(request) -> result``: how the driver runs a plan (inline, or in a worker)
Planner = Callable[[PlanRequest], PlanResult]
