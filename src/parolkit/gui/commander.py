"""Process-wide commander state (no page widgets): the controller link, the event log, the
jog hold, the RBTscript program runner, the recording of the status stream and the
controller's collision world with the bodies within a margin.

One :class:`Commander` per ``parolkit gui`` process; every browser tab's page
(:mod:`parolkit.gui.app`) reads from it.  All robot access goes through
:class:`~parolkit.gui.link.ControllerLink`.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from parolkit.client.core import CommandResult, RobotState
from parolkit.client.errors import RobotError
from parolkit.config import DEFAULT_VIEW_FPS
from parolkit.errors import ParolkitError
from parolkit.gui.collision import CollisionWatch
from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.gamepad import GamepadDrive
from parolkit.gui.jog import JOG_REPEAT_S
from parolkit.gui.lease_watch import ControlWatch, local_host_for
from parolkit.gui.link import ControllerLink
from parolkit.gui.program_doc import ProgramDoc
from parolkit.gui.programs import ProgramsFolder, default_programs_dir
from parolkit.gui.recordings import RecordingSession, RecordingsFolder, TeachProcess, default_recordings_dir
from parolkit.gui.templates import SEED_EXAMPLES

if TYPE_CHECKING:
    from parolkit.client.core import RobotStatus
    from parolkit.gui.class_service import ClassService
    from parolkit.gui.own_controller import OwnController
    from parolkit.gui.simulate import RunSpeedRobot
    from parolkit.script.interpreter import Interpreter, InterpreterState, RunResult
    from parolkit.script.program import Program

__all__ = ["ACTIVE_STATES", "Commander", "ProgramRunner"]

#: the runner's states while a program runs: "pausing" is Pause pressed (PAUSE sent) while the
#: arm still slows down on its path; "paused" the arm holding on its path (the controller
#: paused) or the program waiting between lines (after a Step)
ACTIVE_STATES = ("running", "pausing", "paused")
#: the arm counts as at rest (a pause has taken hold) below this joint speed, deg/s
AT_REST_DEG_S = 0.2
#: how many of a run's latest command IDs the runner keeps for :meth:`ProgramRunner.finishing`
#: (a status after the run shows one of its last lines: the interpreter queues a few ahead)
RUN_IDS_KEPT = 64
#: after the controller acknowledged our RESUME, a status still saying "paused" is taken for
#: one sent before it for this long, s
RESUME_GRACE_S = 0.5


class Commander:
    """Process-wide state: the link, the log, the current jog hold and the program run."""

    def __init__(self, link: ControllerLink, *, mode_label: str, programs: ProgramsFolder | None = None,
                 recordings: RecordingsFolder | None = None,
                 jog_repeat_s: float = JOG_REPEAT_S, cart_jog_repeat_s: float | None = None,
                 secret: str | None = None, login: bool = False,
                 own_controller: OwnController | None = None, view_fps: float = DEFAULT_VIEW_FPS) -> None:
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
        # the controller's pause (ours or another client's) becomes the program's state
        link.add_listener(self.program.follow)
        #: the controller's collision world (GET_ZONES) and the live arm's bodies within a margin
        self.collision = CollisionWatch(link)
        #: the gamepad's servo stream (one page drives at a time; gui/gamepad.py)
        self.gamepad = GamepadDrive(link, self.log, self.control.ensure,
                                    may_start=lambda: not self._refused("gamepad"))
        #: connected pages (browser tabs); when the last one goes the lease is given back
        self.pages = 0
        #: a class (gui.teacher_password): who may move the robot; None: no roles
        self.classroom: ClassService | None = None
        #: every page's 3D view: its updates and its drawing while something changes, Hz (gui.view_fps)
        self.view_fps = view_fps

    def page_opened(self, member_key: str | None) -> None:
        """A page (browser tab) connected (again, after a reconnect); ``member_key``: its
        member of a class (None: no class)."""
        self.pages += 1
        if self.classroom is not None and member_key:
            self.classroom.room.page_opened(member_key, time.monotonic())

    def page_closed(self, member_key: str | None, drove: bool) -> None:
        """A page's connection went away: end its jog when it was one that may move the robot
        (``drove``; in a class only the driver's page holds one); when no page is connected any
        more the commander gives the control lease back (unless a program runs: the runner
        holds the lease then and gives it back itself when the program ends)."""
        if self.classroom is not None and member_key:
            self.classroom.room.page_closed(member_key, time.monotonic())
        if drove:
            self.jog_release()
        self.pages = max(0, self.pages - 1)
        if self.pages == 0 and not self.program.running:
            try:
                self.control.release()
            except RobotError as exc:
                self.log.error(f"release control: {exc}")

    def _refused(self, what: str) -> bool:
        """In a class: the page this runs for may not move or change the robot now (logged)."""
        return self.classroom is not None and self.classroom.refuse(what)

    # ---- jogging ----

    def jog_press(self, make_command: Callable[[], str], period_s: float | None = None) -> None:
        """Start streaming a jog (``make_command`` builds each datagram, sent every
        ``period_s``, default :attr:`jog_repeat_s`) until :meth:`jog_release`."""
        if self._refused("jog"):
            return
        self.gamepad.halt("a jog button took over")
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

    def hold_move(self, command: str, label: str) -> None:
        """Hold-to-move ("go to start pose"): send the planned move ``command`` once and hold it
        like a jog until :meth:`jog_release` (the button let go, a release anywhere on the page,
        the window's blur, the page closed), which sends STOP: the arm stops on its path."""
        if self._refused(label):
            return
        self.gamepad.halt("go to start pose took over")
        self.jog_release(send_stop=False)
        self._hold = asyncio.ensure_future(self._hold_move(command, label))

    async def _hold_move(self, command: str, label: str) -> None:
        if not self.link.link_up:
            self.log.error(f"{label} not sent: no link to the controller")
            return
        try:
            self.control.ensure()
            self.link.send(command, label=label)
            self.log.info(f"sent {label} (hold to move: letting go stops it)")
            await asyncio.Event().wait()  # held until jog_release cancels it
        except (RobotError, OSError) as exc:
            self.log.error(f"{label}: {exc}")

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
        if self.jogging or self.gamepad.streaming or self.program.active or self.program.starting:
            return True
        st = self.link.status
        if st is None or not self.link.link_up:
            return False
        return st.command is not None or st.queue > 0 or st.state in (RobotState.MOVING, RobotState.HOMING)

    # ---- robot controls ----

    def stop(self) -> None:
        """The header's Stop and Space: end the program run as "stopped", end a held jog and
        send STOP (cancels the move in progress and the queue)."""
        self.gamepad.halt("Stop pressed", send_stop=False)
        self.jog_release(send_stop=False)
        self.program.stop()
        self.command("STOP", "Stop")

    async def set_speed(self, percent: float) -> bool:
        """The speed override slider: ``SPEED|pct`` (1..100 %), which only the holder of the
        control lease may send: through the program runner's client while a program runs (it
        holds the lease then), else through the link (taking the lease as every motion command
        does).  Waits for the controller's answer; True when it took the new override.  A
        refusal (another client controls the robot) is logged with the controller's reason."""
        pct = float(percent)
        if self._refused("speed override"):
            return False
        if not 1.0 <= pct <= 100.0:
            self.log.error(f"speed override {pct:g} % not sent: it must be 1..100 %")
            return False
        if not self.link.link_up:
            self.log.error("speed override not sent: no link to the controller")
            return False
        runner = self.program.robot
        if runner is not None and self.program.running:
            try:  # as given: the program's run speed scales only its own Speed() lines
                result = await asyncio.to_thread(runner.set_override, pct, 2.0)
            except ParolkitError as exc:
                self.log.error(f"speed override {pct:g} % (through the program's client): {exc}")
                return False
            self.log.info(f"SPEED completed (through the program's client): {result.details}")
            return True
        try:
            self.control.ensure()
            handle = self.link.submit(f"SPEED|{pct:g}", label="SPEED")
        except (RobotError, OSError) as exc:
            self.log.error(f"speed override {pct:g} %: {exc}")
            return False
        answer = await handle.result(timeout=2.0, raise_on_error=False)  # the link logs the ack
        return isinstance(answer, CommandResult) and answer.ok

    async def resume(self) -> None:
        """The header's Resume (shown while the controller is paused): the program's Run when
        a program of ours runs, else ``RESUME`` through the link (only the lease holder may
        send it: another client's control is refused with the controller's reason)."""
        if self._refused("Resume"):
            return
        if self.program.active:
            await self.program.resume()
        else:
            self.command("RESUME", "RESUME")

    def command(self, text: str, label: str | None = None) -> None:
        """Send ``text``; logs "sent" only when there is a link to the controller (STOP and
        E-STOP are sent anyway: a controller that only lost its status stream still acts)."""
        if text not in ("STOP", "ESTOP") and self._refused(label or text):
            return
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
        if self._refused("restart controller"):
            return
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
        self.gamepad.halt("E-STOP pressed", send_stop=False)
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
        self.robot: RunSpeedRobot | None = None
        #: the run speed of the program running (or run last), % of its planned speed, and the
        #: controller's speed override before Run (given back when the program ends)
        self.run_speed = 100.0
        self._override_before: float | None = None
        #: errors of the last run (check or the failing line), shown inline by the page
        self.errors: list[Any] = []
        self.thread: threading.Thread | None = None
        self.current_line: int | None = None
        #: idle (never run), running, pausing (Pause pressed: the arm slows down on its path),
        #: paused (it holds on its path, or the program waits between lines after a Step),
        #: finished, stopped, error
        self.state = "idle"
        #: guards the state between the page (pause, stop), the link's status listener and the
        #: interpreter's thread
        self._lock = threading.Lock()
        #: the interpreter is paused by us (Pause, Step or a Step-mode start): no new line starts
        #: until Run
        self._user_paused = False
        #: the IDs of the latest controller commands the statuses showed while the program ran
        #: (RUN_IDS_KEPT of them: an endless Loop() must not grow it): a status that still shows
        #: one after the run ended (it left the controller before the last line's ack) is the
        #: program's, not another move (:meth:`finishing`)
        self._run_ids: deque[str] = deque(maxlen=RUN_IDS_KEPT)
        #: PAUSE sent since the last RESUME (Run and Step send RESUME then)
        self._pause_sent = False
        #: our RESUME is on its way (True), or was acknowledged at this monotonic time: a
        #: status saying "paused" until then is an old one
        self._resuming: bool | float = False
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
        #: the line our E-STOP interrupted the program at (None: it was not interrupted so)
        self.estop_line: int | None = None
        #: set before :meth:`start`: the run resumes at this line (:mod:`parolkit.gui.resume`)
        self.resume_line: int | None = None
        #: a resumed Loop() program: the whole program, run (looping) after the rest of its pass
        self._then_loop: Program | None = None

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
        """Interpreter callback (its thread): "paused" once the interpreter has paused between
        lines (after a Step), "running" when it runs the next line, unless Pause or Step was
        pressed meanwhile (:meth:`pause`, :meth:`step` set the state themselves)."""
        word = {"paused": "paused", "running": "running"}.get(state.value)
        with self._lock:
            if word is None or self._stopping or self.state not in ACTIVE_STATES:
                return
            if word == "paused":  # between lines: the line it waits before (on_line says nothing)
                line = self.interpreter.current_line if self.interpreter is not None else None
                if line is not None and line != self.current_line:
                    self.current_line = line
                    self.version += 1
            if self.state == word or (word == "running" and self._user_paused):
                return  # (paused by Pause or Step: the interpreter still passes the gate it was at)
            self.state = word
            self.version += 1

    def _controller_paused(self) -> bool:
        st = self.commander.link.status
        return st is not None and st.paused

    @property
    def paused_by_us(self) -> bool:
        """The program was paused with our Pause (or Step), not by another client's PAUSE."""
        return self._user_paused

    def follow(self, st: RobotStatus) -> None:
        """Status listener (the event loop): the controller's pause is the program's.  Paused
        (ours or another client's ``PAUSE``) while the program runs: "pausing" while the arm
        still slows down on its path, "paused" once it is at rest; "running" again when the
        controller runs on and the interpreter is not paused by us (another client's pause
        ended)."""
        if not self.active:
            return
        if st.command is not None and st.command.id is not None and st.command.id not in self._run_ids:
            self._run_ids.append(st.command.id)
        at_rest = max((abs(v) for v in st.speeds_deg_s), default=0.0) < AT_REST_DEG_S
        with self._lock:
            if self._stopping or self.state not in ACTIVE_STATES:
                return
            new = self.state
            if st.paused:
                resuming = self._resuming
                if resuming is True or (resuming is not False and time.monotonic() - resuming < RESUME_GRACE_S):
                    return  # a status from before our RESUME took effect
                self._resuming = False
                if new == "running":
                    new = "pausing"  # another client's PAUSE, or ours before Pause was seen here
                if new == "pausing" and at_rest:
                    new = "paused"
            else:
                self._resuming = False
                if new != "running" and not self._user_paused:
                    new = "running"
            if new != self.state:
                self.state = new
                self.version += 1

    def finishing(self, st: RobotStatus | None) -> bool:
        """The program has ended here but ``st`` (the newest status) still shows one of its
        commands running: a status that left the controller before the last line's ack (the
        header says PROGRAM RUNNING for it, not MOVING: a run beside two CPU hogs showed
        PROGRAM RUNNING, MOVING, READY)."""
        return (not self.active and st is not None and st.command is not None
                and st.command.id is not None and st.command.id in self._run_ids)

    async def start(self, text: str, *, step: bool = False, name: str = "", run_speed: float = 100.0) -> list[Any]:
        """Parse ``text`` (the program ``name``) and run it at ``run_speed`` % of its planned
        speed (:mod:`parolkit.gui.simulate`: the speed override set at the start, Speed() lines
        scaled by it, the override before given back at the end); returns the parse errors
        (nothing runs when there are any, nor when :meth:`stop` cancelled the start)."""
        try:
            if self.commander._refused("Step" if step else "Run"):
                return []
            return await self._start(text, step=step, name=name, run_speed=run_speed)
        finally:
            self.starting = False
            self._start_cancelled = False

    async def _start(self, text: str, *, step: bool, name: str, run_speed: float) -> list[Any]:
        from parolkit.gui.simulate import RunSpeedRobot, run_speed_errors, run_speed_pct
        from parolkit.script import parse

        if self.active:
            if step:
                await self.step()
            elif self.state in ("pausing", "paused") or self._controller_paused():
                await self.resume()
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
        program = self._resume_point(program)
        try:
            run_pct = run_speed_pct(run_speed)
        except ParolkitError as exc:
            self.state, self.message = "error", f"program not started: {exc}"
            self.commander.log.error(self.message)
            self.version += 1
            return []
        speed_errors = run_speed_errors(program, run_pct)
        if speed_errors:
            self.state = "error"
            self.message = f"{len(speed_errors)} error(s) at the {run_pct:g} % run speed: nothing was run"
            self.version += 1
            return speed_errors
        try:
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
            robot = RunSpeedRobot(link.host, link.port, run_pct=run_pct, ack_port=0)
        except (OSError, ParolkitError) as exc:
            self.state = "error"
            self.message = f"cannot start the program client: {exc}"
            self.commander.log.error(self.message)
            self.version += 1
            return []
        self.robot = robot
        self.run_speed, self._override_before = run_pct, None
        self.interpreter = Interpreter(program, robot, on_line=self._on_line, on_state=self._on_state, step=step)
        self.errors = []
        self.state = "running"
        self._run_ids.clear()
        self._user_paused, self._pause_sent, self._resuming = step, False, False
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
            self._set_run_speed()
            interpreter.start()
            result = self._wait_run(interpreter)
            if self._stopping:
                self.state = "stopped"  # stop() said so (its STOP may have failed the move)
            elif result is not None and not result.ok and result.state.value != "stopped":
                self.state = "error"
                self.message = result.message
                self.errors = list(result.errors)
                self.commander.log.error(self._failure_words(result))
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
                self._give_back_override(robot)
                robot.close()
            self.version += 1

    def _set_run_speed(self) -> None:
        """(the runner's thread, holding the lease) The program's run speed as the controller's
        speed override before its first line.  A refusal is logged; the program runs at the
        override the controller has."""
        robot, st = self.robot, self.commander.link.status
        if robot is None:
            return
        try:
            robot.set_override(self.run_speed, 2.0)
        except ParolkitError as exc:
            self.commander.log.error(f"run speed {self.run_speed:g} % not set: {exc}")
            return
        self._override_before = st.speed_pct if st is not None else None
        self.commander.log.info(f"the program runs at {self.run_speed:g} % of its planned speed "
                                "(the speed override, given back when it ends)")

    def _give_back_override(self, robot: RunSpeedRobot) -> None:
        """(the runner's thread) The program ended: the speed override it found at Run again
        (the run speed and the program's Speed() lines were for this run)."""
        before, self._override_before = self._override_before, None
        if before is None:
            return
        try:
            robot.set_override(before, 2.0)
        except ParolkitError as exc:
            self.commander.log.error(f"the speed override was not set back to {before:g} %: {exc}")

    def _failure_words(self, result: RunResult) -> str:
        """The page log's line for a failed run: the student's sentence of its first error
        (:mod:`parolkit.gui.student_errors`); the technical message goes to the server's log
        (``parolkit gui``'s output), for the teacher."""
        from parolkit.gui.student_errors import explain

        if not result.errors:
            return f"program {result.message}"
        first = result.errors[0]
        logging.getLogger(__name__).warning("program %s failed at line %d: %s", self.name, first.line, first.message)
        return f"program failed: {explain(first, self.name).text()}"

    def _resume_point(self, program: Program) -> Program:
        """A new run: the program from :attr:`resume_line` when it is set (Resume after an
        E-stop: that line's move is planned again from where the arm is; a Loop() program runs
        the rest of its pass, then loops from its first line), else the whole program."""
        from parolkit.gui.resume import resume_plan

        line, self.resume_line = self.resume_line, None
        self.estop_line, self._then_loop = None, None
        if line is None:
            return program
        plan = resume_plan(program, line)
        if isinstance(plan, str):
            self.commander.log.error(f"resume: {plan}: the program runs from its first line")
            return program
        self._then_loop = program if plan.then_loop else None
        self.commander.log.info(f"resume from line {line}: its move is planned again from where the arm is")
        return plan.program

    def _wait_run(self, interpreter: Interpreter) -> RunResult | None:
        """(the runner's thread) Wait for the run; a resumed Loop() program then runs whole,
        looping, unless it was stopped or failed."""
        from parolkit.script import Interpreter

        result = interpreter.wait()
        program, self._then_loop = self._then_loop, None
        robot = self.robot
        if program is None or robot is None or result is None or not result.ok:
            return result
        after = Interpreter(program, robot, on_line=self._on_line, on_state=self._on_state)
        with self._lock:
            if self._stopping:
                return result
            self.interpreter = after  # (stop() stops this one from now on)
        after.start()
        return after.wait()

    @property
    def running(self) -> bool:
        return self.thread is not None and self.thread.is_alive()

    @property
    def active(self) -> bool:
        """A program runs or is paused (the editor shows it, read-only).  Not once it ended
        (finished, stopped, error) while its thread still closes its client: the page says
        "finished" then, and the editor takes typing again."""
        return self.running and self.state in ACTIVE_STATES

    async def pause(self) -> None:
        """The Program tab's Pause: ``PAUSE`` to the controller (open to every client), so the
        running move slows down on its own path within the acceleration limits and holds there
        (a running Delay, Output or wait runs to its end; nothing queued starts), and the
        interpreter is paused, so no new line starts.  "pausing" while the arm still slows
        down, "paused" once the controller reports it paused and the arm at rest
        (:meth:`follow`).  Run resumes (:meth:`resume`), Step runs on (:meth:`step`), Stop
        ends it all (STOP ends the controller's pause too)."""
        interpreter = self.interpreter
        if not self.active or interpreter is None:
            self.commander.log.info("pause: no program is running")
            return
        if self._user_paused and self.state in ("pausing", "paused"):
            self.commander.log.info(f"pause: the program is already {self.state}")
            return
        try:
            self.commander.link.send("PAUSE", label="PAUSE")
        except (RobotError, OSError) as exc:
            self.commander.log.error(f"pause: PAUSE not sent: {exc}")
        with self._lock:
            self._user_paused = self._pause_sent = True
            self._resuming = False
            if self.state == "running":
                self.state = "pausing"
            self.version += 1
        line = self.current_line
        self.commander.log.info(f"pause: the arm slows down on its path and holds at line {line}"
                                if line is not None else "pause: the program pauses before its first line")
        await asyncio.to_thread(interpreter.pause)  # it may ask the controller (PAUSE|QUEUE)

    async def resume(self) -> None:
        """Run while paused: the interpreter runs on and ``RESUME`` (through the runner's
        client, which holds the control lease) lets the arm continue on the same path to the
        same target."""
        interpreter = self.interpreter
        if not self.active or interpreter is None:
            self.commander.log.info("resume: no program is running")
            return
        with self._lock:
            self._user_paused = False
            self._resuming = True
            self.state = "running"
            self.version += 1
        await asyncio.to_thread(interpreter.resume)
        if await self._resume_controller("resume"):
            self.commander.log.info("resume: the program runs on (the arm continues on its path)")

    async def step(self) -> None:
        """Step while a program runs: run one more line, then pause between lines (the
        interpreter's :meth:`~parolkit.script.Interpreter.step`).  Paused on the path, the
        controller is resumed too: the arm finishes the line it paused in, the next line
        runs, and the program pauses before the one after it (the first line queued behind the
        paused one is that one more line; with lines held at the controller the interpreter's
        ``RESUME|ONE`` resumes the arm too, and a RESUME would release them all)."""
        interpreter = self.interpreter
        if not self.active or interpreter is None:
            return
        with self._lock:
            self._user_paused = True
            release = self._pause_sent or self._controller_paused()
            if release:
                self._resuming = True
            self.state = "running"
            self.version += 1
        resumed = await asyncio.to_thread(interpreter.step)
        if not release:
            self.commander.log.info("step: one more line runs, then the program pauses")
        elif await self._resume_controller("step", send=not resumed):
            self.commander.log.info("step: the arm finishes the line it paused in, one more line runs, "
                                    "then the program pauses")

    async def _resume_controller(self, what: str, send: bool = True) -> bool:
        """``RESUME`` through the runner's client when we paused the controller or it is paused
        (another client's PAUSE); a refusal (another client took control) is logged and the
        state follows the controller again.  ``send`` False: the interpreter resumed it
        (``RESUME|ONE``); only the bookkeeping."""
        robot = self.robot
        if robot is None or not (self._pause_sent or self._controller_paused()):
            with self._lock:
                self._resuming = False
            return True
        try:
            if send:
                await asyncio.to_thread(robot.resume, 2.0)
        except ParolkitError as exc:
            with self._lock:
                self._resuming = False
                self.version += 1
            self.commander.log.error(f"{what}: RESUME failed: {exc}")
            return False
        with self._lock:
            self._pause_sent = False
            if self._resuming is True:
                self._resuming = time.monotonic()
        return True

    def stop(self, reason: str = "stopped") -> None:
        if self.starting and not self.active and not self._start_cancelled:
            self._start_cancelled = True  # start() runs nothing
            self.state = "stopped"
            self.message = reason
            self.commander.log.add(f"program {reason} before it started", Level.WARNING)
            self.version += 1
        if self.active and self.interpreter is not None:
            self.estop_line = self.current_line if reason == "E-STOP" else None
            with self._lock:
                self._stopping = True
                self.state = "stopped"
                self._user_paused = self._pause_sent = self._resuming = False
            self.interpreter.stop()  # its state callbacks take the lock: not held here
            self.message = reason
            self.commander.log.add(f"program {reason}", Level.WARNING)
            self.version += 1
