"""Run an RBTscript program on the controller through the client API.

::

    from parolkit import Robot
    from parolkit.script import load, Interpreter

    with Robot("127.0.0.1", 5001) as robot:
        it = Interpreter(load("pick.rbt"), robot, on_line=lambda p: print(p.line, p.command))
        result = it.run()            # blocking; or it.start() for a background thread
        print(result.state, result.elapsed_s)

Before the first command the program is checked (a dry run planned from the robot's current
joints with the controller's tool), every move also for collisions in the controller's own
collision world (``GET_ZONES``: its keep-out zones and the tool's shape; an older controller
that does not answer it: the default table only, with a warning).  With any error nothing is
sent to the controller and the run ends FAILED with every error in ``result.errors``.

Programs run on ticks: while a line runs, the next ones (up to :data:`LINES_AHEAD`) are
already queued at the controller, so each starts in the tick the one before it ends: an
``Output`` takes one tick at the board, ``Delay(x)`` exactly x, and no line waits for a round
trip (nor for this process, on a busy machine: a line of one tick has the ticks of the lines
queued before it to be sent in; the first lines of a burst go out while the controller holds
its queue).  ``current_line`` is the line the robot is executing (announced when it starts); a
line that fails ends the run FAILED, and the lines queued behind it are cancelled (STOP).
``Speed()`` acts at once, so it waits for the running line to end; ``Input()`` waits for it too,
and the lines after an ``Input()`` wait for its outcome (a timeout ends the run FAILED with
nothing after it started).  ``Gripper()`` and
``Gripper_cal()`` do not wait for the jaws (as in the original: follow them with a Delay).
Control from any thread:

* :meth:`pause` / :meth:`resume`: pause BETWEEN lines: the running line ends, the ones queued
  behind it are held at the controller (``PAUSE|QUEUE``) and nothing more is sent until
  :meth:`resume` (which releases them);
* :meth:`step`: run exactly one more line, then pause (``step=True`` starts paused): the
  controller lets one held line start (``RESUME|ONE``), or the next line is sent; while
  stepping nothing more is queued ahead;
* :meth:`stop`: sends STOP (cancels the active move and the queue) and ends the run.

``on_line(progress)`` is called before each command and ``on_state(state)`` on every state
change, from the interpreter's thread; keep them short (the GUI posts them to its loop).
"""

from __future__ import annotations

import enum
import functools
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, TypeVar

from parolkit.moves import MAX_BLEND_CHAIN
from parolkit.script.program import (
    Begin,
    Command,
    Delay,
    End,
    Gripper,
    GripperCalibrate,
    Home,
    Input,
    Loop,
    MoveCart,
    MoveCartRelTRF,
    MoveJoint,
    MovePose,
    Output,
    Program,
    ScriptError,
    Severity,
    Speed,
    SpeedJoint,
)

if TYPE_CHECKING:
    from parolkit.client.core import ZonesInfo
    from parolkit.client.robot import Robot
    from parolkit.collision import HeldObject, ToolShape, Zone
    from parolkit.kinematics.tools import Tool
    from parolkit.robot import RobotModel
    from parolkit.script.dryrun import DryRunReport

__all__ = ["InterpreterState", "Progress", "RunResult", "Interpreter", "CollisionSetup", "collision_setup"]

_log = logging.getLogger(__name__)

_T = TypeVar("_T")


def _blends(cmd: Command) -> bool:
    """A move with a blend radius (``r=``): the line after it is sent at once, so that the
    controller has it queued to blend into."""
    return isinstance(cmd, (MoveJoint, MovePose, MoveCart)) and bool(cmd.move.blend)


def _word(value: enum.Enum | str | None) -> str | None:
    """The wire word the client sends for a profile / tracking (None: not given)."""
    return value.value if isinstance(value, enum.Enum) else value


class InterpreterState(enum.Enum):
    """Life cycle: IDLE -> CHECKING -> RUNNING <-> PAUSED -> FINISHED | STOPPED | FAILED."""

    IDLE = "idle"
    CHECKING = "checking"
    RUNNING = "running"
    PAUSED = "paused"
    STOPPING = "stopping"
    FINISHED = "finished"
    STOPPED = "stopped"
    FAILED = "failed"

    @property
    def done(self) -> bool:
        return self in (InterpreterState.FINISHED, InterpreterState.STOPPED, InterpreterState.FAILED)


@dataclass(frozen=True)
class Progress:
    """Where the run is: the command about to run (``line``, ``index`` into the program,
    ``command`` text), the loop ``iteration`` (1-based), ``elapsed_s`` since the start, and
    the planned total ``planned_total_s`` (None for endless loops; then ``planned_pass_s`` is
    one pass through the program)."""

    line: int
    index: int
    iteration: int
    command: str
    elapsed_s: float
    planned_total_s: float | None
    planned_pass_s: float
    commands_done: int


@dataclass(frozen=True)
class RunResult:
    """How a run ended.  ``errors``: the check's errors (nothing ran) or the failing line's
    error; ``final_deg``: the robot's joints after the run (None when unknown);
    ``elapsed_s``: from the first command to the end (the check before it not included)."""

    state: InterpreterState
    commands_executed: int
    iterations: int
    elapsed_s: float
    errors: tuple[ScriptError, ...] = ()
    warnings: tuple[ScriptError, ...] = ()
    final_deg: tuple[float, ...] | None = None
    report: object = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        return self.state is InterpreterState.FINISHED

    @property
    def message(self) -> str:
        """One line for people."""
        head = f"{self.state.value} after {self.commands_executed} commands, {self.elapsed_s:.2f} s"
        if self.iterations > 1:
            head += f", {self.iterations} loop iterations"
        if self.errors:
            head += f": {self.errors[0].headline()}"
        return head


@dataclass(frozen=True)
class CollisionSetup:
    """The collision world a program is checked in, as the collision check takes it: the
    keep-out ``zones`` (base frame), the ``tool_shape`` (None: the tool has no body) and the
    ``held`` objects (flange frame).  ``source``: "controller" (its ``GET_ZONES``) or
    "default" (the default table: the controller did not say)."""

    zones: tuple[Zone, ...]
    tool_shape: ToolShape | None
    held: tuple[HeldObject, ...] = ()
    source: str = "controller"


def collision_setup(info: ZonesInfo) -> CollisionSetup:
    """The collision check's objects for the world a controller reports (the client's
    :class:`~parolkit.client.ZonesInfo`, ``Robot.zones()``): each zone validated as the config
    validates ``[[zones]]``, the tool's capsule named after the tool, the held objects placed
    by :func:`parolkit.collision.held_object`.  Raises ParolkitValueError for a zone or shape
    out of range (naming it)."""
    from parolkit.collision import ToolShape, held_object
    from parolkit.collision.shapes import zone_from_mapping

    zones = []
    for z in info.zones:
        spec: dict[str, object] = {"name": z.name, "kind": z.kind, "margin": z.margin}
        for key in ("center", "size", "rpy", "point", "normal", "axis", "radius", "height"):
            value = getattr(z, key)
            if value is not None:
                spec[key] = value
        zones.append(zone_from_mapping(spec, f"GET_ZONES zone {z.name!r}"))
    shape = info.tool_shape
    tool = None if shape is None else ToolShape(info.tool or "tool", shape.radius, shape.start, shape.end)
    held = tuple(held_object(h.name, h.start, h.end, h.radius, h.kind) for h in info.held)
    return CollisionSetup(tuple(zones), tool, held)


class _Stopped(Exception):
    """Internal: the run was stopped."""


class _LineFailed(Exception):
    """Internal: a line the controller ran (or refused) did not complete."""

    def __init__(self, cmd: Command, exc: Exception) -> None:
        super().__init__(str(exc))
        self.cmd = cmd
        self.exc = exc


#: how many lines may be queued at the controller behind the running one: each line takes at
#: least a tick, so the next line to send has that many ticks to reach the controller before
#: the queue runs dry (a round trip, this process held up on a busy machine); well inside the
#: controller's per-client inbox (32) and queue (256).  A pause holds them at the controller
#: (they do not run); a STOP or a failed line cancels them.
LINES_AHEAD = 16

def _started(handle: Any) -> bool:
    """Whether the controller said the line ``handle`` stands for has started (an ack past
    QUEUED: EXECUTING, or its end).  A line without a handle (it acted at once) has."""
    if handle is None:
        return True
    status = getattr(handle, "status", None)
    latest = status() if callable(status) else None
    return latest is not None and str(getattr(latest, "value", latest)) != "QUEUED"


#: a command sent with ``wait=False``: ``result(timeout)`` waits for its end (raising when it
#: did not complete)
_Handle = Any


class Interpreter:
    """Executes a :class:`Program` on a robot (``parolkit.Robot`` or anything with its methods).

    ``loops``: how many passes a Loop() program makes (None = until stopped); ``step``: start
    paused and run one command per :meth:`step`; ``check``: dry-run the program first and refuse
    to run on any error (default True); ``model``/``rate_hz``: for the check.
    """

    def __init__(
        self,
        program: Program,
        robot: Robot,
        *,
        on_line: Callable[[Progress], object] | None = None,
        on_state: Callable[[InterpreterState], object] | None = None,
        loops: int | None = None,
        step: bool = False,
        check: bool = True,
        model: RobotModel | None = None,
        rate_hz: float = 100.0,
    ) -> None:
        if loops is not None and (isinstance(loops, bool) or not isinstance(loops, int) or loops < 1):
            raise ValueError(f"loops must be a whole number >= 1 or None, got {loops!r}")
        self.program = program
        self.robot = robot
        self.on_line = on_line
        self.on_state = on_state
        self.loops = loops
        self.check_first = check
        self.model = model
        self.rate_hz = rate_hz
        self._cond = threading.Condition()
        self._state = InterpreterState.IDLE
        self._paused = bool(step)
        self._step_tokens = 0
        #: the controller holds the lines queued behind the running one (PAUSE|QUEUE, sent by
        #: :meth:`pause`); ``_hold_sent`` is set once it acked that
        self._held = False
        self._hold_sent = threading.Event()
        self._hold_sent.set()
        #: the lines sent and not seen to end, the running one first: (command, handle, index,
        #: loop pass); changed by the run loop under ``_cond``
        self._pend: deque[tuple[Command, _Handle, int, int]] = deque()
        #: a line has passed its gate and waits for the running one to end (not yet announced)
        self._line_waiting = False
        self._stop_requested = False
        self._current_line: int | None = None
        self._current_index: int | None = None
        #: the loop pass being sent to the controller, and the pass of the line running now
        #: (lines may be queued ahead of the one that runs: the next pass's first ones)
        self._iteration = 0
        self._running_iteration = 0
        self._started = 0
        self._thread: threading.Thread | None = None
        self._result: RunResult | None = None
        self._t0 = 0.0
        self.report: DryRunReport | None = None
        #: the collision world the last check used (None: the default table, the controller
        #: did not say)
        self.collision: CollisionSetup | None = None

    # ---- observation --------------------------------------------------------------------

    @property
    def state(self) -> InterpreterState:
        return self._state

    @property
    def current_line(self) -> int | None:
        """Source line of the command running now (or about to run); None before/after."""
        return self._current_line

    @property
    def current_index(self) -> int | None:
        return self._current_index

    @property
    def commands_started(self) -> int:
        """How many commands have started so far (grows by one per step in single-step mode)."""
        return self._started

    @property
    def iteration(self) -> int:
        """Current loop pass, 1-based (0 before the start)."""
        return self._running_iteration

    @property
    def result(self) -> RunResult | None:
        """The outcome once the run is over (else None)."""
        return self._result

    def _set_state(self, state: InterpreterState) -> None:
        with self._cond:
            if self._state is state:
                return
            self._state = state
            self._cond.notify_all()
        self._notify(self.on_state, state)

    @staticmethod
    def _notify(callback: Callable[[_T], object] | None, value: _T) -> None:
        """Call a user callback; an exception in it is logged and never ends the run."""
        if callback is None:
            return
        try:
            callback(value)
        except Exception:
            _log.exception("RBTscript callback %r failed", callback)

    # ---- control (any thread) -----------------------------------------------------------

    def pause(self) -> None:
        """Pause after the line that runs now: the lines queued behind it at the controller
        are held there (``PAUSE|QUEUE``) until :meth:`resume` or :meth:`step`."""
        with self._cond:
            self._paused = True
            hold = self._begin_hold()
            self._cond.notify_all()
        if hold:
            self._hold_queue()

    @property
    def _queued_ahead(self) -> bool:
        """(under ``_cond``) Lines wait at the controller behind the running one."""
        return len(self._pend) > 1

    def _begin_hold(self) -> bool:
        """(under ``_cond``) Whether the caller must send PAUSE|QUEUE now: lines are queued
        ahead and not held yet."""
        hold = self._queued_ahead and not self._held
        if hold:
            self._held = True
            self._hold_sent.clear()
        return hold

    def resume(self) -> None:
        """Continue after :meth:`pause` or single-stepping."""
        with self._cond:
            self._paused = False
            self._step_tokens = 0
            release, self._held = self._held, False
            self._cond.notify_all()
        if release:
            self._release_queue()

    def step(self) -> bool:
        """Run exactly one more line, then pause (also from a running program: the first line
        queued behind the running one is that one more line, the others stay held).  True when
        lines were held at the controller and it was told to let one start (``RESUME|ONE``,
        which also lets a move paused on its path go on: the caller must not send RESUME, which
        would release them all)."""
        with self._cond:
            self._paused = True
            hold = self._begin_hold()
            one = self._held
            if not one and not self._line_waiting:
                self._step_tokens += 1  # the run loop sends one more line (else: the one past its gate)
            self._cond.notify_all()
        if hold:
            self._hold_queue()
        if one:
            # the controller lets one more line start (RESUME|ONE): the first held one, or,
            # when none is held, the next the run loop sends (a step token)
            self._hold_sent.wait()  # (the hold's ack: which lines started is known)
            with self._cond:
                if all(_started(h) for _, h, _, _ in self._pend):
                    self._step_tokens += 1
                self._cond.notify_all()
            try:
                self.robot.resume(one=True)
            except Exception:
                _log.exception("letting one held line start failed")
        return one

    def _hold_queue(self) -> None:
        try:
            self.robot.pause(queue_only=True)
        except Exception:  # the run loop reports what happened to the line
            _log.exception("holding the queue for a pause failed")
        finally:
            self._hold_sent.set()

    def _release_queue(self) -> None:
        try:
            self.robot.resume()
        except Exception:
            _log.exception("releasing the held queue failed")

    def stop(self) -> None:
        """Stop the program: send STOP to the controller (cancels the move in progress and the
        queue) and end the run as STOPPED."""
        with self._cond:
            if self._state.done:
                return
            self._stop_requested = True
            self._held = False  # STOP ends the controller's hold too
            running = self._state in (InterpreterState.RUNNING, InterpreterState.PAUSED)
            self._cond.notify_all()
        if running:
            self._set_state(InterpreterState.STOPPING)
            try:
                self.robot.stop()
            except Exception:  # the run loop reports what happened
                pass

    def start(self) -> threading.Thread:
        """Run in a background thread (daemon); returns it.  See :meth:`wait`."""
        if self._thread is not None:
            raise RuntimeError("this Interpreter has already been started")
        self._thread = threading.Thread(target=self.run, name="rbtscript", daemon=True)
        self._thread.start()
        return self._thread

    def wait(self, timeout: float | None = None) -> RunResult | None:
        """Wait for a :meth:`start`-ed run to end; its result (None on timeout)."""
        if self._thread is not None:
            self._thread.join(timeout)
        return self._result

    # ---- checking -----------------------------------------------------------------------

    def _robot_tool(self) -> Tool | None:
        try:
            info = self.robot.tool()
        except Exception:
            return None
        if info is None or getattr(info, "name", "default") == "default":
            return None
        from parolkit.kinematics.tools import Tool

        return Tool.from_pose(info.name, info.pose)

    def _collision_world(self) -> tuple[CollisionSetup | None, str | None]:
        """The controller's collision world (``GET_ZONES``) for the check, or (None, why) when
        it does not answer it (an older controller) or answers something the check cannot
        take: the check then uses the default table."""
        try:
            info = self.robot.zones()
        except Exception as exc:  # a RobotError (no answer, an unknown command) or no zones() at all
            return None, f"the controller did not answer GET_ZONES ({exc})"
        try:
            return collision_setup(info), None
        except Exception as exc:
            return None, f"the controller's collision world could not be read ({exc})"

    def check(self) -> DryRunReport:
        """Dry-run the program from the robot's current joints (and tool), every move checked
        for collisions with the controller's zones and tool shape (``robot.zones()``); the
        report.  A controller that does not answer ``GET_ZONES`` (an older one): the default
        table only, and the report carries a warning saying so.  (Held objects are checked by
        the controller when it admits each move; the dry run knows only zones and the tool.)"""
        from parolkit.script.dryrun import dry_run

        start = tuple(float(v) for v in self.robot.angles())
        setup, why = self._collision_world()
        self.collision = setup
        report = dry_run(
            self.program, start, loops=self.loops if self.loops is not None else None,
            model=self.model, tool=self._robot_tool(), rate_hz=self.rate_hz,
            zones=None if setup is None else setup.zones, tool_shape=None if setup is None else setup.tool_shape,
        )
        if why is not None:
            text = (f"{why}: the program was checked for collisions against the default table only, not the "
                    "controller's zones and tool shape (the controller still checks every move it admits)")
            _log.warning("%s", text)
            first = self.program.commands[0] if self.program.commands else None
            warning = ScriptError(first.line if first else 1, first.col if first else 1, text,
                                  first.text if first else "", Severity.WARNING, self.program.source_name)
            report = replace(report, warnings=(*report.warnings, warning))
        return report

    # ---- running ------------------------------------------------------------------------

    def _error(self, cmd: Command, message: str) -> ScriptError:
        return ScriptError(cmd.line, cmd.col, message, cmd.text, Severity.ERROR, self.program.source_name)

    def _gate(self, cmd: Command | None, index: int, drain: Callable[[int], int], settle: Callable[[], int],
              held_next: Callable[[], tuple[int, int] | None]) -> int:
        """Block while paused (unless a step token is available); raise when stopped.  Before
        it says PAUSED the lines still running at the controller end: all of them (``drain``)
        unless the controller holds the ones queued (:meth:`pause`); then the ones that have
        started (``settle``: before the hold, or let start by a step's ``RESUME|ONE``), and
        PAUSED with the first held line next (``held_next``: its source line and index, None
        when none is held), watching for a step to start it.  A step token sends the next line
        when none is held.  ``cmd`` None: the run waits for the lines it sent (held ones among
        them), not before a line to send.  Returns how many lines were seen to end."""
        drained = 0
        drained_all = False
        while True:
            with self._cond:
                if self._stop_requested:
                    raise _Stopped
                if not self._paused:
                    break
                held = self._held
            if held:
                self._hold_sent.wait()  # its ack: every line that started before it is known
                drained += settle()
            elif not drained_all:  # the lines at the controller end first (may block)
                drained += drain(0)
                drained_all = True
                continue
            with self._cond:
                if self._stop_requested:
                    raise _Stopped
                if not self._paused:
                    break
                if held != self._held:
                    continue  # released (resume) or held (a step) meanwhile
                nxt = held_next() if held else None
                if nxt is None:
                    if cmd is None:
                        break  # nothing of ours is held: the run goes on waiting for its lines
                    if self._step_tokens > 0 and (held or drained_all):
                        self._step_tokens -= 1
                        break  # the next line is sent (held: a step's RESUME|ONE lets it start)
                    line, at = cmd.line, index
                else:
                    line, at = nxt
                changed = (self._current_line, self._current_index) != (line, at)
                self._current_line, self._current_index = line, at
                if self._state is InterpreterState.PAUSED and not changed:
                    # held lines: watch for one a step lets start (its ack), else wait
                    self._cond.wait(0.02 if nxt is not None else 0.5)
                    continue
            self._set_state(InterpreterState.PAUSED)
        if cmd is not None:
            with self._cond:
                self._started += 1
                self._line_waiting = True
        self._set_state(InterpreterState.RUNNING)
        return drained

    def _ahead(self, cmd: Command) -> bool:
        """``cmd`` may be queued behind the line that runs: not when single-stepping (each
        step is one line, run to its end), not ``Speed()`` (it acts at once, on what runs), not
        ``Input()``: its timeout is an outcome, not an error, and it ends the run: the lines
        after it wait for it (queued behind it, the controller started the next move when the
        input timed out, and the STOP that cancels it came a round trip later: 2.6 deg of a
        MoveJoint on a busy machine)."""
        with self._cond:
            stepping = self._paused
        return not stepping and not isinstance(cmd, (Speed, Input))

    def _announce(self, cmd: Command, index: int, executed: int, planned_total: float | None,
                  planned_pass: float, iteration: int | None = None) -> None:
        """``cmd`` (of loop pass ``iteration``, default the one being sent) runs now: the
        current line, and ``on_line``."""
        with self._cond:
            self._current_line, self._current_index = cmd.line, index
            self._running_iteration = self._iteration if iteration is None else iteration
            self._line_waiting = False
        if self.on_line is not None:
            self._notify(self.on_line, Progress(
                cmd.line, index, self._running_iteration, cmd.to_source(),
                time.monotonic() - self._t0, planned_total, planned_pass, executed))

    def _run_line(self, cmd: Command, *, wait: bool) -> _Handle | None:
        """:meth:`_execute`, its failure as :class:`_LineFailed` (or :class:`_Stopped`).  A line
        sent ahead (``wait=False``) goes out without waiting for the controller's first ack
        where the robot can (``Robot.pipelined``): that ack comes with the controller's next
        tick, and lines of one tick each must be sent faster than one a tick."""
        pipelined = getattr(self.robot, "pipelined", None)
        try:
            if not wait and pipelined is not None:
                with pipelined():
                    return self._execute(cmd, wait=wait)
            return self._execute(cmd, wait=wait)
        except Exception as exc:
            if self._stop_requested:
                raise _Stopped from None
            raise _LineFailed(cmd, exc) from None

    def _await(self, pending: tuple[Command, _Handle] | None) -> int:
        """Wait for the line sent ahead to end: 1 when it completed, 0 for none; raises
        :class:`_LineFailed` when it did not complete."""
        if pending is None:
            return 0
        cmd, handle = pending
        if handle is None:
            return 1
        try:
            handle.result(timeout=None)
        except Exception as exc:
            if self._stop_requested:
                raise _Stopped from None
            raise _LineFailed(cmd, exc) from None
        return 1

    def _cancel_queued(self) -> None:
        """A line failed with the next one already queued at the controller: STOP cancels it."""
        try:
            self.robot.stop()
        except Exception:  # the failure is what the run reports
            _log.exception("STOP after a failed line failed")

    def _execute(self, cmd: Command, wait: bool = True) -> _Handle | None:
        """Send ``cmd``: ``wait=True`` returns once the controller reported it COMPLETED
        (raises when it did not); ``wait=False`` returns its handle once the controller took
        it (queued behind what runs).  ``Speed()`` acts at once either way (None)."""
        from parolkit.script.dryrun import effective_timing

        r = self.robot
        if isinstance(cmd, Speed):
            r.set_speed(cmd.percent, timeout=None)
            return None
        if isinstance(cmd, Delay):
            return r.delay(cmd.seconds, wait=wait, timeout=None)
        if isinstance(cmd, (MoveJoint, MovePose)):
            tm = effective_timing(cmd)
            fn = r.move_joints if isinstance(cmd, MoveJoint) else r.move_pose
            values = cmd.move.target_deg if isinstance(cmd, MoveJoint) else cmd.move.pose
            return fn(
                list(values), duration=tm.duration_s, speed=tm.speed_pct, accel=tm.accel_pct,
                profile=_word(cmd.move.profile), tracking=_word(cmd.move.tracking),
                wait=wait, timeout=None, blend=cmd.move.blend,
            )
        if isinstance(cmd, (MoveCart, MoveCartRelTRF)):
            tm = effective_timing(cmd)
            line_fn = (functools.partial(r.move_cart, blend=cmd.move.blend) if isinstance(cmd, MoveCart)
                       else r.move_cart_rel_trf)  # (a relative move does not blend)
            values = cmd.move.pose if isinstance(cmd, MoveCart) else cmd.move.delta
            return line_fn(
                list(values), duration=tm.duration_s, speed=tm.speed_pct,
                profile=_word(cmd.move.profile), tracking=_word(cmd.move.tracking),
                wait=wait, timeout=None,
            )
        if isinstance(cmd, SpeedJoint):
            return r.speed_joint(list(cmd.move.speeds_deg_s), cmd.move.duration_s, wait=wait, timeout=None)
        if isinstance(cmd, Home):
            return r.home(wait=wait, timeout=None)
        if isinstance(cmd, Output):
            return r.set_output(cmd.port, cmd.state, wait=wait, timeout=None)
        if isinstance(cmd, Input):
            return r.wait_input(cmd.port, cmd.state, input_timeout=cmd.timeout_s, wait=wait, timeout=None)
        if isinstance(cmd, Gripper):
            # as in the original, the program does not wait for the jaws (the controller's
            # command ends once the setpoints are sent): queued, never waited for here
            return r.gripper_move(cmd.position, cmd.speed, cmd.current_ma, wait=False)
        if isinstance(cmd, GripperCalibrate):
            return r.gripper_calibrate(wait=False)
        raise TypeError(f"no executor for {type(cmd).__name__}")  # pragma: no cover

    def _final_deg(self) -> tuple[float, ...] | None:
        try:
            return tuple(float(v) for v in self.robot.angles())
        except Exception:
            return None

    def run(self) -> RunResult:
        """Check, then run the program to its end (blocking).  Never raises for robot or
        program problems: they are in the returned :class:`RunResult`."""
        with self._cond:
            if self._state is not InterpreterState.IDLE:
                raise RuntimeError("this Interpreter has already run")
        self._t0 = time.monotonic()
        warnings: tuple[ScriptError, ...] = tuple(self.program.warnings)
        executed = 0
        commands = self.program.commands
        planned_pass = 0.0
        planned_total: float | None = None
        try:
            if self.check_first:
                self._set_state(InterpreterState.CHECKING)
                try:
                    report = self.check()
                except Exception as exc:
                    err = ScriptError(1, 1, f"cannot check the program against the robot: {exc}", "",
                                      Severity.ERROR, self.program.source_name)
                    return self._finish(InterpreterState.FAILED, 0, (err,), warnings)
                self.report = report
                warnings = report.warnings
                if not report.ok:
                    return self._finish(InterpreterState.FAILED, 0, report.errors, warnings, report)
                if report.iterations:
                    planned_pass = report.total_s / report.counted_iterations
                if not self.program.loops:
                    planned_total = report.total_s
                elif self.loops is not None:
                    planned_total = planned_pass * self.loops
            if self._stop_requested:
                raise _Stopped
            self._t0 = time.monotonic()  # times are measured from the first command on
            self._set_state(InterpreterState.PAUSED if self._paused else InterpreterState.RUNNING)
            self._iteration = 1
            # programs on ticks: the line after the running one is already queued at the
            # controller (sent when the running one started), so it starts the tick that one
            # ends; the gate before each line is passed before it is sent.  After a move with a
            # blend radius the next line is sent at once too (and so on while they blend): the
            # controller plans a blended chain from the moves it has queued
            pend = self._pend

            def pop_first() -> None:
                nonlocal executed
                c0, h0, _, _ = pend[0]
                try:
                    ended = self._await((c0, h0))
                except _LineFailed:
                    if len(pend) > 1:
                        self._cancel_queued()  # the lines sent behind the failed one
                    raise
                executed += ended
                with self._cond:
                    pend.popleft()
                if pend:
                    self._announce(pend[0][0], pend[0][2], executed, planned_total, planned_pass, pend[0][3])

            primed = False

            def prime(nxt: Command | None) -> None:
                """Lines about to be sent ahead to a controller where none of ours runs: hold its
                queue while they go out (released before anything waits for them), so they run
                back to back even when this process is held up between two sends; the start
                waits for the sends instead (a round trip).  Not for one line alone."""
                nonlocal primed
                if primed or nxt is None or isinstance(nxt, (Begin, End, Loop)) or not self._ahead(nxt):
                    return
                try:
                    self.robot.pause(queue_only=True)
                    primed = True
                except Exception:  # the lines then start as they come
                    _log.exception("holding the queue while the first lines are sent failed")

            def unprime() -> None:
                nonlocal primed
                if not primed:
                    return
                primed = False
                with self._cond:  # (a pause() meanwhile keeps the hold: it is the user's now)
                    if not self._held:
                        self._release_queue()

            def drain(keep: int = 0) -> int:
                """Wait for the lines sent to end, in order, until ``keep`` are left, each next one
                announced as it starts (while paused with them held: :meth:`_gate`); counted in
                ``executed`` as each ends (a failure reports the lines before it and cancels the
                ones queued behind it).  Returns how many ended."""
                if len(pend) > keep:
                    unprime()
                before = executed
                while len(pend) > keep:
                    with self._cond:
                        held = self._paused and self._held
                    if held and not _started(pend[0][1]):
                        # paused with our lines held at the controller: PAUSED here (steps,
                        # resume), not a wait for a line that does not start
                        self._gate(None, -1, drain, settle, held_next)
                        continue
                    pop_first()
                return executed - before

            def settle() -> int:
                """Wait for the lines sent that have started (acked EXECUTING, or ended) to end,
                in order: the lines a held queue let start before the hold."""
                before = executed
                while pend and _started(pend[0][1]):
                    pop_first()
                return executed - before

            def held_next() -> tuple[int, int] | None:
                return (pend[0][0].line, pend[0][2]) if pend else None

            try:
                while True:
                    for index, cmd in enumerate(commands):
                        if isinstance(cmd, Loop):
                            if self.loops is not None and self._iteration >= self.loops:
                                drain()
                                return self._finish(InterpreterState.FINISHED, executed, (), warnings)
                            break

                        # (the lines it drains are counted as they end)
                        self._gate(cmd, index, drain, settle, held_next)
                        if isinstance(cmd, (Begin, End)) or not self._ahead(cmd):
                            drain()
                            self._announce(cmd, index, executed, planned_total, planned_pass)
                            if isinstance(cmd, End):
                                executed += 1
                                return self._finish(InterpreterState.FINISHED, executed, (), warnings)
                            if not isinstance(cmd, Begin):
                                self._run_line(cmd, wait=True)
                            executed += 1
                            if self._stop_requested:
                                raise _Stopped
                            continue
                        if not pend:  # nothing runs: it starts at once (the current line now)
                            prime(commands[index + 1] if index + 1 < len(commands) else None)
                            self._announce(cmd, index, executed, planned_total, planned_pass)
                        handle = self._run_line(cmd, wait=False)
                        with self._cond:
                            pend.append((cmd, handle, index, self._iteration))
                            # a pause that came after the gate: this line must wait too
                            hold = self._paused and self._begin_hold()
                        if hold:
                            self._hold_queue()
                        elif _blends(cmd) and len(pend) < MAX_BLEND_CHAIN:
                            continue  # the next line goes out now too: this move blends into it
                        # the lines before this one end, in order, while LINES_AHEAD wait behind
                        # the one that runs
                        drain(keep=LINES_AHEAD + 1)
                        if self._stop_requested:
                            raise _Stopped
                    else:
                        # no Loop(): the program ends after its last line
                        drain()
                        return self._finish(InterpreterState.FINISHED, executed, (), warnings)
                    self._iteration += 1
            except _LineFailed as failed:
                if self._stop_requested:
                    raise _Stopped from None
                cause = failed.exc
                reason = getattr(cause, "reason", None) or str(cause)
                status = getattr(cause, "status", None)
                kw = failed.cmd.keyword
                what = f"{kw} {status.lower()}" if isinstance(status, str) else f"{kw} failed"
                err = self._error(failed.cmd, f"{what}: {reason}")
                return self._finish(InterpreterState.FAILED, executed, (err,), warnings)
        except _Stopped:
            return self._finish(InterpreterState.STOPPED, executed, (), warnings)

    def _finish(self, state: InterpreterState, executed: int, errors: Iterable[ScriptError],
                warnings: Iterable[ScriptError], report: DryRunReport | None = None) -> RunResult:
        result = RunResult(
            state=state,
            commands_executed=executed,
            iterations=max(self._running_iteration, 1 if executed else 0),
            elapsed_s=time.monotonic() - self._t0,
            errors=tuple(errors),
            warnings=tuple(warnings),
            final_deg=self._final_deg(),
            report=report if report is not None else self.report,
        )
        self._result = result
        with self._cond:
            self._current_line = None
            self._current_index = None
        self._set_state(state)
        return result
