"""Run an RBTscript program on the controller through the client API.

::

    from parolkit import Robot
    from parolkit.script import load, Interpreter

    with Robot("127.0.0.1", 5001) as robot:
        it = Interpreter(load("pick.rbt"), robot, on_line=lambda p: print(p.line, p.command))
        result = it.run()            # blocking; or it.start() for a background thread
        print(result.state, result.elapsed_s)

Before the first command the program is checked (a dry run planned from the robot's current
joints with the controller's tool).  With any error nothing is sent to the controller and the
run ends FAILED with every error in ``result.errors``.

Programs run on ticks: while a line runs, the next one is already queued at the controller
(sent when the running one started), so it starts in the tick the running one ends: an
``Output`` takes one tick at the board, ``Delay(x)`` exactly x, and no line waits for a round
trip.  ``current_line`` is the line the robot is executing (announced when it starts); a line
that fails ends the run FAILED, and the line queued behind it is cancelled (STOP).
``Speed()`` acts at once, so it waits for the running line to end.  ``Gripper()`` and
``Gripper_cal()`` do not wait for the jaws (as in the original: follow them with a Delay).
Control from any thread:

* :meth:`pause` / :meth:`resume`: pause BETWEEN lines: the running line ends, the one queued
  behind it is held at the controller (``PAUSE|QUEUE``) and nothing more is sent until
  :meth:`resume` (which releases it);
* :meth:`step`: run exactly one more line, then pause (``step=True`` starts paused); while
  stepping nothing is queued ahead;
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
from dataclasses import dataclass, field
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
    from parolkit.client.robot import Robot
    from parolkit.kinematics.tools import Tool
    from parolkit.robot import RobotModel
    from parolkit.script.dryrun import DryRunReport

__all__ = ["InterpreterState", "Progress", "RunResult", "Interpreter"]

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


class _Stopped(Exception):
    """Internal: the run was stopped."""


class _LineFailed(Exception):
    """Internal: a line the controller ran (or refused) did not complete."""

    def __init__(self, cmd: Command, exc: Exception) -> None:
        super().__init__(str(exc))
        self.cmd = cmd
        self.exc = exc


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
        #: a line waits at the controller behind the running one; the controller holds it
        #: (PAUSE|QUEUE, sent by :meth:`pause`)
        self._queued_ahead = False
        self._held = False
        #: a line has passed its gate and waits for the running one to end (not yet announced)
        self._line_waiting = False
        self._stop_requested = False
        self._current_line: int | None = None
        self._current_index: int | None = None
        #: the loop pass being sent to the controller, and the pass of the line running now
        #: (one line may be queued ahead of the one that runs: the next pass's first)
        self._iteration = 0
        self._running_iteration = 0
        self._started = 0
        self._thread: threading.Thread | None = None
        self._result: RunResult | None = None
        self._t0 = 0.0
        self.report: DryRunReport | None = None

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
        """Pause after the line that runs now: the line queued behind it at the controller is
        held there (``PAUSE|QUEUE``) until :meth:`resume` or :meth:`step`."""
        with self._cond:
            self._paused = True
            hold = self._queued_ahead and not self._held
            self._held = self._held or hold
            self._cond.notify_all()
        if hold:
            self._hold_queue()

    def resume(self) -> None:
        """Continue after :meth:`pause` or single-stepping."""
        with self._cond:
            self._paused = False
            self._step_tokens = 0
            release, self._held = self._held, False
            self._cond.notify_all()
        if release:
            self._release_queue()

    def step(self) -> None:
        """Run exactly one more line, then pause (also from a running program: the line queued
        behind the running one is that one more line)."""
        with self._cond:
            self._paused = True
            release = self._held
            if release:  # the line held at the controller is the step
                self._held = False
            elif not (self._queued_ahead or self._line_waiting):
                # (a line already past its gate, queued or waiting to be sent, is the step)
                self._step_tokens += 1
            self._cond.notify_all()
        if release:
            self._release_queue()

    def _hold_queue(self) -> None:
        try:
            self.robot.pause(queue_only=True)
        except Exception:  # the run loop reports what happened to the line
            _log.exception("holding the queue for a pause failed")

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

    def check(self) -> DryRunReport:
        """Dry-run the program from the robot's current joints (and tool); the report."""
        from parolkit.script.dryrun import dry_run

        start = tuple(float(v) for v in self.robot.angles())
        return dry_run(
            self.program, start, loops=self.loops if self.loops is not None else None,
            model=self.model, tool=self._robot_tool(), rate_hz=self.rate_hz,
        )

    # ---- running ------------------------------------------------------------------------

    def _error(self, cmd: Command, message: str) -> ScriptError:
        return ScriptError(cmd.line, cmd.col, message, cmd.text, Severity.ERROR, self.program.source_name)

    def _gate(self, cmd: Command, index: int, drain: Callable[[], int]) -> int:
        """Block while paused (unless a step token is available); raise when stopped.  Before
        it says PAUSED the lines still at the controller end (``drain``: how many lines ended;
        more than one after blended moves), unless the controller holds them (:meth:`pause`):
        then PAUSED at once, the held line next; returns how many lines ``drain`` saw end."""
        drained: int | None = None
        announced: bool | None = None  # PAUSED said, while held (True) / after the drain (False)
        while True:
            with self._cond:
                if self._stop_requested:
                    raise _Stopped
                if not self._paused:
                    break
                held = self._held
            if not held and drained is None:  # the line at the controller ends first (may block)
                drained = drain()
                continue
            with self._cond:
                if self._stop_requested:
                    raise _Stopped
                if not self._paused:
                    break
                if drained is not None and self._step_tokens > 0:
                    self._step_tokens -= 1
                    break
                held = self._held
                if announced is held:
                    self._cond.wait(0.5)
                    continue
                if not held:  # (held: the held line, announced already, is the next to run)
                    self._current_line, self._current_index = cmd.line, index
            self._set_state(InterpreterState.PAUSED)
            announced = held
        with self._cond:
            self._started += 1
            self._line_waiting = True
        self._set_state(InterpreterState.RUNNING)
        return drained or 0

    def _ahead(self, cmd: Command) -> bool:
        """``cmd`` may be queued behind the line that runs: not when single-stepping (each
        step is one line, run to its end), not ``Speed()`` (it acts at once, on what runs)."""
        with self._cond:
            stepping = self._paused
        return not stepping and not isinstance(cmd, Speed)

    def _announce(self, cmd: Command, index: int, executed: int, planned_total: float | None,
                  planned_pass: float) -> None:
        """``cmd`` runs now: the current line, and ``on_line``."""
        with self._cond:
            self._current_line, self._current_index = cmd.line, index
            self._running_iteration = self._iteration
            self._line_waiting = False
        if self.on_line is not None:
            self._notify(self.on_line, Progress(
                cmd.line, index, self._running_iteration, cmd.to_source(),
                time.monotonic() - self._t0, planned_total, planned_pass, executed))

    def _run_line(self, cmd: Command, *, wait: bool) -> _Handle | None:
        """:meth:`_execute`, its failure as :class:`_LineFailed` (or :class:`_Stopped`)."""
        try:
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
            pend: deque[tuple[Command, _Handle, int]] = deque()

            def drain(keep: int = 0) -> int:
                """Wait for the lines sent to end, in order, until ``keep`` are left, each next one
                announced as it starts; counted in ``executed`` as each ends (a failure reports
                the lines before it).  Returns how many ended."""
                nonlocal executed
                done = 0
                while len(pend) > keep:
                    c0, h0, _ = pend[0]
                    ended = self._await((c0, h0))
                    executed += ended
                    done += ended
                    pend.popleft()
                    if pend:
                        self._announce(pend[0][0], pend[0][2], executed, planned_total, planned_pass)
                return done

            try:
                while True:
                    for index, cmd in enumerate(commands):
                        if isinstance(cmd, Loop):
                            if self.loops is not None and self._iteration >= self.loops:
                                drain()
                                return self._finish(InterpreterState.FINISHED, executed, (), warnings)
                            break

                        self._gate(cmd, index, drain)  # (the lines it drains are counted as they end)
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
                            self._announce(cmd, index, executed, planned_total, planned_pass)
                        handle = self._run_line(cmd, wait=False)
                        with self._cond:
                            self._queued_ahead = bool(pend)
                            # a pause that came after the gate: this line must wait too
                            hold = self._queued_ahead and self._paused and not self._held
                            self._held = self._held or hold
                        pend.append((cmd, handle, index))
                        if hold:
                            self._hold_queue()
                        elif _blends(cmd) and len(pend) < MAX_BLEND_CHAIN:
                            continue  # the next line goes out now too: this move blends into it
                        try:
                            drain(keep=1)  # the lines before this one end, in order
                        except _LineFailed:
                            self._cancel_queued()  # the lines sent behind the failed one
                            raise
                        finally:
                            with self._cond:
                                self._queued_ahead = False
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
