"""Process-wide commander state (no page widgets): the controller link, the event log, the
jog hold, the RBTscript program runner and the recording of the status stream.

One :class:`Commander` per ``parolkit gui`` process; every browser tab's page
(:mod:`parolkit.gui.app`) reads from it.  All robot access goes through
:class:`~parolkit.gui.link.ControllerLink`.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from parolkit.client.core import RobotState
from parolkit.client.errors import RobotError
from parolkit.errors import ParolkitError
from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.jog import JOG_REPEAT_S
from parolkit.gui.lease_watch import ControlWatch, local_host_for
from parolkit.gui.link import ControllerLink
from parolkit.gui.program_doc import ProgramDoc
from parolkit.gui.programs import ProgramsFolder, default_programs_dir
from parolkit.gui.recordings import RecordingSession, RecordingsFolder, TeachProcess, default_recordings_dir
from parolkit.gui.templates import SEED_EXAMPLES

if TYPE_CHECKING:
    from parolkit.client.robot import Robot
    from parolkit.gui.own_controller import OwnController
    from parolkit.script.interpreter import Interpreter, InterpreterState

__all__ = ["ACTIVE_STATES", "Commander", "ProgramRunner"]

#: the runner's states while a program runs: "pausing" is Pause pressed while a line (a move,
#: a Delay) still runs: the program pauses after it
ACTIVE_STATES = ("running", "pausing", "paused")


class Commander:
    """Process-wide state: the link, the log, the current jog hold and the program run."""

    def __init__(self, link: ControllerLink, *, mode_label: str, programs: ProgramsFolder | None = None,
                 recordings: RecordingsFolder | None = None,
                 jog_repeat_s: float = JOG_REPEAT_S, cart_jog_repeat_s: float | None = None,
                 secret: str | None = None, login: bool = False,
                 own_controller: OwnController | None = None) -> None:
        """``jog_repeat_s`` / ``cart_jog_repeat_s``: period of the streamed joint / Cartesian
        jog updates, s; both must stay below the controller's stream watchdog (20 ms by
        default, 150 ms for a controller the GUI starts).  Every CARTJOG update is planned
        anew by the controller, so fewer, longer updates move more smoothly.  ``programs``:
        the only folder Open / Save use (default :func:`default_programs_dir`); ``recordings``:
        the only folder Record writes and the recordings list reads (default
        :func:`default_recordings_dir`); ``secret``:
        the controller's shared secret (``controller.secret``) if it has one; ``login``: the
        pages sit behind a login (a Log out button is shown); ``own_controller``: the
        controller process this GUI started (the page offers to restart it)."""
        self.link = link
        self.jog_repeat_s = jog_repeat_s
        self.cart_jog_repeat_s = jog_repeat_s if cart_jog_repeat_s is None else cart_jog_repeat_s
        self.log: EventLog = link.log
        self.mode_label = mode_label
        self.programs = programs or ProgramsFolder(default_programs_dir())
        self.recordings = recordings or RecordingsFolder(default_recordings_dir())
        #: the one recording of the controller's status stream (an observer, like `parolkit record`)
        self.recording = RecordingSession(self.recordings, link.host, link.port, self.log)
        #: where the Record tab's teach fits run (a process of their own)
        self.teach_process = TeachProcess()
        self.login = login
        self.own_controller = own_controller
        #: the one program document every tab edits (kept until saved)
        self.doc = ProgramDoc(self.programs, self.log, SEED_EXAMPLES["Output click"])
        self._hold: asyncio.Task[None] | None = None
        self.program = ProgramRunner(self)
        self.control = ControlWatch(link.robot, link.send, local_host=local_host_for(link.host),
                                    runner_port=self.program.port, secret=secret)
        #: connected pages (browser tabs); when the last one goes the lease is given back
        self.pages = 0

    # ---- jogging ----

    def jog_press(self, make_command: Callable[[], str], period_s: float | None = None) -> None:
        """Start streaming a jog (``make_command`` builds each datagram, sent every
        ``period_s``, default :attr:`jog_repeat_s`) until :meth:`jog_release`."""
        self.jog_release(send_stop=False)
        self._hold = asyncio.ensure_future(self._hold_loop(make_command, period_s or self.jog_repeat_s))

    async def _hold_loop(self, make_command: Callable[[], str], period_s: float) -> None:
        if not self.link.link_up:
            self.log.error("jog not sent: no link to the controller")
            return
        try:
            self.control.ensure()
            self.link.send("STREAM|ON", label="STREAM ON", quiet=True)
            while True:
                self.link.send(make_command(), label="jog", quiet=True)  # only refusals are logged
                await asyncio.sleep(period_s)
        except RobotError as exc:
            self.log.error(f"jog stopped: {exc}")

    def jog_release(self, *, send_stop: bool = True) -> None:
        """Stop a held jog: stop sending, then STOP and STREAM|OFF for certainty."""
        if self._hold is None:
            return
        self._hold.cancel()
        self._hold = None
        if send_stop:
            try:
                self.link.send("STOP", quiet=True)
                self.link.send("STREAM|OFF", quiet=True)
            except RobotError as exc:
                self.log.error(f"jog release: {exc}")

    @property
    def jogging(self) -> bool:
        return self._hold is not None

    @property
    def moving(self) -> bool:
        """Something moves or is about to: a held jog, a program starting, running or paused, or the
        controller busy (a command running or queued, state MOVING or HOMING; the same test
        as the client's wait for idle).  Space is STOP in a text field then (commander.js)."""
        if self.jogging or self.program.active or self.program.starting:
            return True
        st = self.link.status
        if st is None or not self.link.link_up:
            return False
        return st.command is not None or st.queue > 0 or st.state in (RobotState.MOVING, RobotState.HOMING)

    # ---- robot controls ----

    def stop(self) -> None:
        """The header's Stop and Space: end the program run as "stopped", end a held jog and
        send STOP (cancels the move in progress and the queue)."""
        self.jog_release(send_stop=False)
        self.program.stop()
        self.command("STOP", "Stop")

    def command(self, text: str, label: str | None = None) -> None:
        """Send ``text``; logs "sent" only when there is a link to the controller (STOP and
        E-STOP are sent anyway: a controller that only lost its status stream still acts)."""
        if not self.link.link_up and text not in ("STOP", "ESTOP"):
            self.log.error(f"{label or text} not sent: no link to the controller")
            return
        try:
            if text not in ("STOP", "ESTOP", "DISABLE"):  # open to every client
                self.control.ensure()
            self.link.send(text, label=label)
            self.log.info(f"sent {label or text}")
        except (RobotError, OSError) as exc:
            self.log.error(f"{label or text}: {exc}")

    async def restart_controller(self) -> None:
        """Restart the controller process this GUI started (the page's banner offers it)."""
        own = self.own_controller
        if own is None:
            self.log.error("this commander did not start the controller: restart it where it runs")
            return
        if own.restarting:
            return
        self.log.info("restarting the controller ...")
        try:
            await asyncio.to_thread(own.restart)
        except (RuntimeError, OSError) as exc:
            self.log.error(f"controller restart failed: {exc}")
            return
        self.log.add("controller restarted", Level.SUCCESS)

    def estop(self) -> None:
        self.jog_release(send_stop=False)
        self.program.stop(reason="E-STOP")
        try:
            self.link.send("ESTOP", label="E-STOP")
            self.log.error("software E-STOP sent")
        except RobotError as exc:
            self.log.error(f"E-STOP could not be sent: {exc}")


class ProgramRunner:
    """Runs one RBTscript program at a time with :class:`parolkit.script.Interpreter`."""

    def __init__(self, commander: Commander) -> None:
        self.commander = commander
        self.interpreter: Interpreter | None = None
        self.robot: Robot | None = None
        #: errors of the last run (check or the failing line), shown inline by the page
        self.errors: list[Any] = []
        self.thread: threading.Thread | None = None
        self.current_line: int | None = None
        #: idle (never run), running, pausing (Pause pressed: the line running finishes
        #: first), paused, finished, stopped, error
        self.state = "idle"
        #: guards the state between the page (pause, stop) and the interpreter's thread
        self._lock = threading.Lock()
        self.message = ""
        #: the text and program name of the program running (or run last): the page shows it
        self.text = ""
        self.name = ""
        self._stopping = False
        #: Run was pressed and the program is not running yet (the page's text is being asked
        #: for, the lease handed over): Space is STOP then, and stop() cancels the start
        self.starting = False
        self._start_cancelled = False
        self.version = 0

    def port(self) -> int | None:
        """Local UDP port of the runner's client while a program runs (the controller names
        the lease holder by it), else None."""
        robot = self.robot
        return None if robot is None else robot.ack_port

    def announce_start(self) -> None:
        """Run or Step was pressed: from now until :meth:`start` returns, the program counts
        as starting (:attr:`starting`) and :meth:`stop` cancels it."""
        self.starting = True
        self._start_cancelled = False

    def _on_line(self, progress: Any) -> None:
        """Interpreter callback: ``progress.line`` is the line about to run (1-based)."""
        self.current_line = int(getattr(progress, "line", progress))
        self.version += 1

    def _on_state(self, state: InterpreterState) -> None:
        """Interpreter callback (its thread): "paused" only once the interpreter has paused
        (between lines), "running" again when it runs the next line (Run, Step)."""
        word = {"paused": "paused", "running": "running"}.get(state.value)
        with self._lock:
            if word is None or self._stopping or self.state not in ACTIVE_STATES or self.state == word:
                return
            self.state = word
            self.version += 1

    async def start(self, text: str, *, step: bool = False, name: str = "") -> list[Any]:
        """Parse ``text`` (the program ``name``) and run it; returns the parse errors (nothing
        runs when there are any, nor when :meth:`stop` cancelled the start)."""
        try:
            return await self._start(text, step=step, name=name)
        finally:
            self.starting = False
            self._start_cancelled = False

    async def _start(self, text: str, *, step: bool, name: str) -> list[Any]:
        from parolkit.script import parse

        if self.active:
            if step and self.interpreter is not None:
                self.interpreter.step()
            elif self.interpreter is not None and self.state in ("pausing", "paused"):
                with self._lock:
                    self.interpreter.resume()
                    self.state = "running"  # a pause still pending is called off
                    self.version += 1
            return []
        thread = self.thread
        if thread is not None and thread.is_alive():  # the last run ended and closes its client
            await asyncio.to_thread(thread.join, 5.0)
            if thread.is_alive():
                self.commander.log.error("program not started: the last run has not finished closing")
                return []
        if self._start_cancelled:
            return []  # stopped before it started (stop() said so)
        result = parse(text, "editor")
        if not result.ok:
            self.state = "error"
            self.message = f"{len(result.errors)} error(s): nothing was run"
            self.version += 1
            return list(result.errors)
        program = result.program
        if program is None:
            raise RuntimeError("the parser found no error but returned no program")
        try:
            from parolkit.client import Robot
            from parolkit.script import Interpreter
        except ImportError as exc:
            self.state = "error"
            self.message = f"the program runner is not available in this build: {exc}"
            self.commander.log.error(self.message)
            self.version += 1
            return []
        link = self.commander.link
        # the runner is another client of the controller: the link gives the lease back
        # first, then the runner takes it (_run) and gives it back when the program ends
        await self.commander.control.hand_over()
        if self._start_cancelled:
            return []
        try:
            # its own ephemeral socket: the controller acks it there (ACK_HERE)
            robot = Robot(host=link.host, port=link.port, ack_port=0)
        except (OSError, ParolkitError) as exc:
            self.state = "error"
            self.message = f"cannot start the program client: {exc}"
            self.commander.log.error(self.message)
            self.version += 1
            return []
        self.robot = robot
        self.interpreter = Interpreter(program, robot, on_line=self._on_line, on_state=self._on_state, step=step)
        self.errors = []
        self.state = "running"
        self.message = ""
        self.text, self.name = text, name
        self._stopping = False
        self.current_line = None
        self.version += 1
        self.thread = threading.Thread(target=self._run, args=(step,), name="rbtscript", daemon=True)
        self.thread.start()
        self.commander.log.info("program started")
        return []

    def _run(self, step: bool) -> None:
        interpreter = self.interpreter
        if interpreter is None:
            raise RuntimeError("ProgramRunner._run needs the interpreter that start() creates")
        try:
            try:
                if self.robot is None:
                    raise RuntimeError("ProgramRunner._run needs the client that start() creates")
                self.robot.take_control(secret=self.commander.control.secret)
            except RobotError as exc:
                self.state = "error"
                self.message = f"cannot take control of the robot: {exc}"
                self.commander.log.error(f"program not started: {self.message}")
                return
            finally:
                self.commander.control.refresh_soon()
            interpreter.start()
            result = interpreter.wait()
            if self._stopping:
                self.state = "stopped"  # stop() said so (its STOP may have failed the move)
            elif result is not None and not result.ok and result.state.value != "stopped":
                self.state = "error"
                self.message = result.message
                self.errors = list(result.errors)
                self.commander.log.error(f"program {result.message}")
            elif result is not None and result.state.value == "stopped":
                self.state = "stopped"
                self.message = self.message or "stopped"
            elif self.state != "error":
                self.commander.log.add(f"program {result.message if result else 'finished'}", Level.SUCCESS)
                self.state = "finished"
                self.message = "finished"
            self.current_line = None
        except ParolkitError as exc:
            self.state = "error"
            self.message = str(exc)
            self.commander.log.error(f"program stopped: {exc}")
        except Exception as exc:
            self.state = "error"
            self.message = f"{type(exc).__name__}: {exc}"
            self.commander.log.error(f"program crashed: {self.message}")
        finally:
            robot, self.robot = self.robot, None
            if robot is not None:
                robot.close()
            self.version += 1

    @property
    def running(self) -> bool:
        return self.thread is not None and self.thread.is_alive()

    @property
    def active(self) -> bool:
        """A program runs or is paused (the editor shows it, read-only).  Not once it ended
        (finished, stopped, error) while its thread still closes its client: the page says
        "finished" then, and the editor takes typing again."""
        return self.running and self.state in ACTIVE_STATES

    def pause(self) -> None:
        """Pause after the line that runs now (the interpreter pauses between lines: a move
        in progress finishes): "pausing" until the interpreter has paused (:meth:`_on_state`)."""
        if self.active and self.interpreter is not None and self.state == "running":
            with self._lock:
                self.interpreter.pause()
                self.state = "pausing"
                self.version += 1
            line = self.current_line
            self.commander.log.info(f"pause: the program pauses after line {line}" if line is not None
                                    else "pause: the program pauses before its next line")
        elif self.state in ("pausing", "paused"):
            self.commander.log.info(f"pause: the program is already {self.state}")
        else:
            self.commander.log.info("pause: no program is running")

    def stop(self, reason: str = "stopped") -> None:
        if self.starting and not self.active and not self._start_cancelled:
            self._start_cancelled = True  # start() runs nothing
            self.state = "stopped"
            self.message = reason
            self.commander.log.add(f"program {reason} before it started", Level.WARNING)
            self.version += 1
        if self.active and self.interpreter is not None:
            with self._lock:
                self._stopping = True
                self.state = "stopped"
            self.interpreter.stop()  # its state callbacks take the lock: not held here
            self.message = reason
            self.commander.log.add(f"program {reason}", Level.WARNING)
            self.version += 1
