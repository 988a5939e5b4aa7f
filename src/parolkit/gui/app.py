"""The commander page (NiceGUI).  Imported only by ``parolkit gui``.

One :class:`Commander` per process holds the controller link, the event log, the jog hold
and the program runner; every browser tab gets its own :class:`CommanderPage` (3D view,
panels, timers) that reads from it.  All robot access goes through :class:`ControllerLink`.
"""

from __future__ import annotations

import asyncio
import json
import threading
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any

from nicegui import app, ui

from parolkit.client.core import RobotState, RobotStatus
from parolkit.client.errors import RobotError
from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.gui import geometry
from parolkit.gui.control import ControlWatch, local_host_for
from parolkit.gui.control_badge import ControlBadge
from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.highlight import line_decorations, mark_decorations
from parolkit.gui.jog import (
    JOG_DURATION_S,
    JOG_REPEAT_S,
    KEYMAP,
    cart_jog_blocked,
    cart_step_command,
    jog_command,
    joint_jog_blocked,
    joint_step_target,
    key_action,
    key_label,
)
from parolkit.gui.link import ControllerLink
from parolkit.gui.programs import ProgramsFolder, default_programs_dir
from parolkit.gui.programs_panel import ProgramsPanel
from parolkit.gui.status import (
    POSE_LABELS,
    format_angles,
    format_loop,
    format_pose,
    format_speeds,
    state_badge,
)
from parolkit.gui.templates import SEED_EXAMPLES, TEMPLATES, render_template
from parolkit.moves import CartAxis, CartJog, Frame, JointJog
from parolkit.robot import JOINT_NAMES, PAROL6

if TYPE_CHECKING:
    from nicegui.elements.scene.scene_object3d import Object3D

    from parolkit.client.robot import Robot
    from parolkit.script.interpreter import Interpreter

__all__ = ["Commander", "CommanderPage", "build_app"]

SCENE_FPS = 30.0
READOUT_PERIOD_S = 0.1
PLOT_PERIOD_S = 0.5
PLOT_WINDOW_S = 20.0
JOINT_COLOURS = ("#60a5fa", "#f472b6", "#34d399", "#fbbf24", "#a78bfa", "#f87171")

CSS = """
<style>
body { background: #0b1220; }
.pk-card { background: #111a2e !important; border: 1px solid #1e2a44; border-radius: 12px; }
.pk-title { font-size: 11px; letter-spacing: .08em; text-transform: uppercase; color: #8ea0c4; }
.pk-mono { font-family: ui-monospace, SFMono-Regular, Menlo, monospace; font-variant-numeric: tabular-nums; }
.pk-val { font-family: ui-monospace, SFMono-Regular, Menlo, monospace; font-variant-numeric: tabular-nums;
          color: #e6edf7; }
.pk-led { width: 11px; height: 11px; border-radius: 50%; display: inline-block; background: #334155; }
.pk-led.on { background: #22c55e; box-shadow: 0 0 6px #22c55e; }
.pk-led.bad { background: #ef4444; box-shadow: 0 0 6px #ef4444; }
.pk-estop { background: radial-gradient(circle at 35% 30%, #ff6b6b, #c81e1e 70%) !important;
            color: white !important; font-weight: 800; letter-spacing: .06em; border: 3px solid #fde047;
            min-width: 128px; min-height: 52px; border-radius: 12px; }
.pk-estop.latched { animation: pk-blink 1s steps(2, start) infinite; }
@keyframes pk-blink { to { border-color: #111827; } }
.pk-log { height: 180px; overflow-y: auto; font-family: ui-monospace, monospace; font-size: 12px; }
.pk-log .error { color: #fca5a5; background: rgba(239, 68, 68, .14); }
.pk-log .warning { color: #fcd34d; }
.pk-log .success { color: #86efac; }
.pk-log .info { color: #cbd5e1; }
.pk-jog .q-btn { min-width: 46px; }
.pk-jog .q-btn.pk-held { outline: 2px solid #fde047; box-shadow: 0 0 12px #fde047; }
.rbt-command { color: #2563eb; font-weight: 600; }
.rbt-number { color: #b45309; }
.rbt-keyword { color: #7c3aed; font-weight: 600; }
.rbt-param { color: #0f766e; }
.rbt-comment { color: #6b7280; font-style: italic; }
.rbt-unknown { color: #111827; }
.cm-line.rbt-current { background: rgba(250, 204, 21, .35) !important; }
.cm-line.rbt-error { background: rgba(239, 68, 68, .18) !important; text-decoration: underline wavy #dc2626; }
.pk-editor { border-radius: 8px; overflow: hidden; border: 1px solid #1e2a44; }
</style>
"""

KEY_JS = """
<script>
(() => {
  const keys = new Set(%s);
  const editing = () => {
    const t = document.activeElement;
    return t && (t.isContentEditable || ['INPUT', 'TEXTAREA', 'SELECT'].includes(t.tagName));
  };
  document.addEventListener('keydown', (e) => {
    const k = e.key === ' ' ? ' ' : e.key.toLowerCase();
    if (k === 'escape') { e.preventDefault(); emitEvent('pk_key', {key: k, down: true}); return; }
    if (editing() || e.ctrlKey || e.metaKey || e.altKey || !keys.has(k)) return;
    e.preventDefault();
    if (e.repeat) return;
    emitEvent('pk_key', {key: k, down: true});
  });
  document.addEventListener('keyup', (e) => {
    const k = e.key === ' ' ? ' ' : e.key.toLowerCase();
    if (keys.has(k) && k !== 'escape') emitEvent('pk_key', {key: k, down: false});
  });
  window.addEventListener('blur', () => emitEvent('pk_key', {key: 'blur', down: false}));
  // a held jog button may be greyed out under the pointer (limit reached): a disabled button
  // emits no mouseup, so any mouseup / touchend on the page also ends a held jog
  document.addEventListener('mouseup', () => emitEvent('pk_key', {key: 'release', down: false}), true);
  document.addEventListener('touchend', () => emitEvent('pk_key', {key: 'release', down: false}), true);
})();
</script>
"""


class Commander:
    """Process-wide state: the link, the log, the current jog hold and the program run."""

    def __init__(self, link: ControllerLink, *, mode_label: str, programs: ProgramsFolder | None = None,
                 jog_repeat_s: float = JOG_REPEAT_S, cart_jog_repeat_s: float | None = None,
                 secret: str | None = None, login: bool = False) -> None:
        """``jog_repeat_s`` / ``cart_jog_repeat_s``: period of the streamed joint / Cartesian
        jog updates, s; both must stay below the controller's stream watchdog (20 ms by
        default, 150 ms for a controller the GUI starts).  Every CARTJOG update is planned
        anew by the controller, so fewer, longer updates move more smoothly.  ``programs``:
        the only folder Open / Save use (default :func:`default_programs_dir`); ``secret``:
        the controller's shared secret (``controller.secret``) if it has one; ``login``: the
        pages sit behind a login (a Log out button is shown)."""
        self.link = link
        self.jog_repeat_s = jog_repeat_s
        self.cart_jog_repeat_s = jog_repeat_s if cart_jog_repeat_s is None else cart_jog_repeat_s
        self.log: EventLog = link.log
        self.mode_label = mode_label
        self.programs = programs or ProgramsFolder(default_programs_dir())
        self.login = login
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

    # ---- robot controls ----

    def command(self, text: str, label: str | None = None) -> None:
        try:
            if text not in ("STOP", "ESTOP", "DISABLE"):  # open to every client
                self.control.ensure()
            self.link.send(text, label=label)
            self.log.info(f"sent {label or text}")
        except (RobotError, OSError) as exc:
            self.log.error(f"{label or text}: {exc}")

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
        self.state = "idle"  # idle, running, paused, error
        self.message = ""
        self.version = 0

    def port(self) -> int | None:
        """Local UDP port of the runner's client while a program runs (the controller names
        the lease holder by it), else None."""
        robot = self.robot
        return None if robot is None else robot.ack_port

    def _on_line(self, progress: Any) -> None:
        """Interpreter callback: ``progress.line`` is the line about to run (1-based)."""
        self.current_line = int(getattr(progress, "line", progress))
        self.version += 1

    async def start(self, text: str, *, step: bool = False) -> list[Any]:
        """Parse ``text`` and run it; returns the parse errors (nothing runs when there are any)."""
        from parolkit.script import parse

        if self.running:
            if step and self.interpreter is not None:
                self.interpreter.step()
            elif self.interpreter is not None and self.state == "paused":
                self.interpreter.resume()
                self.state = "running"
            return []
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
        self.interpreter = Interpreter(program, robot, on_line=self._on_line, step=step)
        self.errors = []
        self.state = "running"
        self.message = ""
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
            if result is not None and not result.ok and result.state.value != "stopped":
                self.state = "error"
                self.message = result.message
                self.errors = list(result.errors)
                self.commander.log.error(f"program {result.message}")
            elif self.state != "error":
                self.commander.log.add(f"program {result.message if result else 'finished'}", Level.SUCCESS)
                self.state = "idle"
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

    def pause(self) -> None:
        if self.running and self.interpreter is not None:
            self.interpreter.pause()
            self.state = "paused"
            self.version += 1

    def stop(self, reason: str = "stopped") -> None:
        if self.running and self.interpreter is not None:
            self.interpreter.stop()
            self.state = "idle"
            self.message = reason
            self.commander.log.add(f"program {reason}", Level.WARNING)
            self.version += 1


# ------------------------------------------------------------------------------------------


def arm_frames(angles_deg: Any, tool: str = "default") -> Any:
    """The 8 drawing frames (base, 1..5, flange, TCP) from ``parolkit.kinematics.fk_frames``
    with the controller's current tool (the default TCP if the name is unknown here)."""
    from parolkit.kinematics import fk_frames

    try:
        return fk_frames(angles_deg, None if tool == "default" else tool)
    except (ParolkitError, KeyError, ValueError):
        return fk_frames(angles_deg, None)


def _fmt_ms(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.2f} ms"


class CommanderPage:
    """The widgets of one browser tab."""

    def __init__(self, commander: Commander) -> None:
        self.c = commander
        self.link = commander.link
        self.frame = Frame.WRF
        self.step_mode = False
        self.speed = 40.0
        self.accel = 50.0
        self.step_deg = 5.0
        self.step_mm = 10.0
        self._last_seq = -1
        self._last_plan_seq: tuple[int | None, bool] | None = None  # (plan seq, shown)
        self._log_version = -1
        self._prog_version = -1
        self._errors: dict[int, str] = {}
        self._cart_key: tuple[tuple[float, ...], Frame, bool, str] | None = None
        self._held_button: ui.button | None = None
        self.joint_buttons: dict[tuple[int, int], ui.button] = {}
        self.cart_buttons: dict[CartAxis, ui.button] = {}
        self.build()

    # ---------------------------------------------------------------- layout

    def build(self) -> None:
        ui.add_head_html(CSS)
        ui.add_body_html(KEY_JS % json.dumps([b.key for b in KEYMAP]))
        ui.dark_mode(True)
        ui.query(".nicegui-content").classes("p-3 gap-3")
        ui.on("pk_key", self.on_key)
        self.build_header()
        with ui.row().classes("w-full gap-3 no-wrap items-start"):
            with ui.column().classes("gap-3").style("width: 700px; flex: none"):
                self.build_scene()
                self.build_readouts()
            with ui.column().classes("gap-3 grow").style("min-width: 520px"):
                self.build_tabs()
                self.build_plots()
        self.build_help()
        ui.timer(1.0 / SCENE_FPS, self.update_scene)
        ui.timer(READOUT_PERIOD_S, self.update_readouts)
        ui.timer(PLOT_PERIOD_S, self.update_plots)

    def build_header(self) -> None:
        with ui.row().classes("w-full items-center gap-2 pk-card px-4 py-2 no-wrap"):
            ui.icon("precision_manufacturing", size="32px").classes("text-sky-400")
            with ui.column().classes("gap-0"):
                ui.label("parolkit commander").classes("text-lg font-bold text-slate-100")
                ui.label("PAROL6 · jog · IO · RBTscript").classes("text-xs text-slate-400")
            self.link_chip = ui.chip("NO LINK", icon="link_off", color="grey").props("outline").props("data-testid=link-chip")
            self.mode_chip = ui.chip(self.c.mode_label, icon="memory", color="indigo").props("data-testid=mode-chip")
            self.state_chip = ui.chip("—", color="grey").classes("text-weight-bold").props("data-testid=state-chip")
            self.control_badge = ControlBadge(self.c.control)
            ui.space()
            ui.button("Home", icon="home", on_click=lambda: self.c.command("HOME", "Home")).props("unelevated dense color=primary").classes("px-2").props("data-testid=btn-home")
            ui.button("Enable", icon="power_settings_new", on_click=lambda: self.c.command("ENABLE", "Enable")).props("unelevated dense color=positive").classes("px-2").props("data-testid=btn-enable")
            ui.button("Disable", icon="power_off", on_click=lambda: self.c.command("DISABLE", "Disable")).props("unelevated dense color=warning").classes("px-2").props("data-testid=btn-disable")
            ui.button("Clear error", icon="healing", on_click=lambda: self.c.command("CLEAR_ERROR", "Clear error")).props("outline dense color=grey-4").classes("px-2").props("data-testid=btn-clear")
            ui.button("Stop", icon="stop", on_click=lambda: self.c.command("STOP", "Stop")).props("outline dense color=orange").classes("px-2").props("data-testid=btn-stop")
            ui.button(icon="help_outline", on_click=lambda: self.help.open()).props("flat round color=grey-4 data-testid=help-button").tooltip("keyboard shortcuts")
            self.estop_btn = ui.button("E-STOP", icon="dangerous", on_click=self.c.estop).props("color=red-8 size=lg").classes("pk-estop").props("data-testid=btn-estop")
            self.estop_btn.tooltip("software emergency stop (Esc); latched until Enable")
            if self.c.login:
                ui.button(icon="logout", on_click=lambda: ui.navigate.to("/logout")) \
                    .props("flat round color=grey-4 data-testid=btn-logout").tooltip("log out")

    def build_scene(self) -> None:
        with ui.card().classes("pk-card w-full p-2 gap-1"):
            with ui.row().classes("w-full items-center"):
                ui.label("3D view").classes("pk-title")
                ui.space()
                self.fps_label = ui.label("").classes("text-xs text-slate-400 pk-mono")
            self.scene = ui.scene(width=684, height=430, grid=(20, 20), background_color="#0d1526", fps=30).props("data-testid=scene")
            with self.scene:
                self.scene.axes_helper(length=1.2)  # world frame
                self.groups = self._arm(opacity=1.0)
                self.ghost = self._arm(opacity=0.22, ghost=True)
                for g in self.ghost:
                    g.visible(False)
                self.path = self.scene.point_cloud([], point_size=0.14).material("#22d3ee")
            self.scene.move_camera(x=4.6, y=-4.2, z=3.9, look_at_x=0, look_at_y=0.8, look_at_z=1.7, duration=0)
            for g, t in zip(self.groups, geometry.dh_frames(PAROL6.standby_deg)):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot)
            self._frames_t = time.monotonic()
            self._frames_n = 0

    def _arm(self, *, opacity: float, ghost: bool = False) -> list[Any]:
        colours = {"base": "#475569", "joint": "#f97316", "link": "#cbd5e1", "tool": "#38bdf8"}
        if ghost:
            colours = {k: "#a5f3fc" for k in colours}
        groups = [self.scene.group() for _ in range(geometry.N_FRAMES)]
        s = geometry.SCENE_SCALE
        for solid in geometry.arm_solids(PAROL6):
            with groups[solid.frame]:
                obj: Object3D
                if solid.shape == "cylinder":
                    obj = self.scene.cylinder(solid.radius * s, solid.radius * s, solid.length * s, 28)
                    obj.move(*(v * s for v in solid.center)).rotate_R(solid.rotation_y_to_axis())
                elif solid.shape == "sphere":
                    obj = self.scene.sphere(solid.radius * s).move(*(v * s for v in solid.start))
                else:
                    width, height, depth = (v * s for v in solid.size)
                    obj = self.scene.box(width, height, depth).move(*(v * s for v in solid.start))
                obj.material(colours[solid.role], opacity=opacity)
        if not ghost:
            with groups[7]:
                self.scene.axes_helper(length=0.6)  # tool frame
        return groups

    def build_readouts(self) -> None:
        with ui.card().classes("pk-card w-full p-3 gap-2"):
            with ui.row().classes("w-full gap-6 no-wrap"):
                with ui.column().classes("gap-1"):
                    ui.label("Joints").classes("pk-title")
                    self.joint_labels, self.speed_labels, self.homed_leds = [], [], []
                    with ui.grid(columns=4).classes("gap-x-4 gap-y-0 items-center"):
                        for name in ("", "angle", "speed", "homed"):
                            ui.label(name).classes("text-xs text-slate-500")
                        for j in range(6):
                            ui.label(JOINT_NAMES[j]).classes("text-slate-400 text-sm")
                            self.joint_labels.append(ui.label("—").classes("pk-val text-sm").props(f"data-testid=angle-{j + 1}"))
                            self.speed_labels.append(ui.label("—").classes("pk-val text-xs text-slate-300").props(f"data-testid=speed-{j + 1}"))
                            self.homed_leds.append(ui.html("<span class='pk-led'></span>").props(f"data-testid=homed-{j + 1}"))
                with ui.column().classes("gap-1"):
                    ui.label("TCP pose").classes("pk-title")
                    self.pose_labels = []
                    with ui.grid(columns=2).classes("gap-x-3 gap-y-0"):
                        for name in POSE_LABELS:
                            ui.label(name).classes("text-slate-400 text-sm")
                            self.pose_labels.append(ui.label("—").classes("pk-val text-sm whitespace-nowrap").props(f"data-testid=pose-{name.lower()}"))
                with ui.column().classes("gap-1 grow"):
                    ui.label("IO · safety").classes("pk-title")
                    self.io_leds = {}
                    with ui.grid(columns=2).classes("gap-x-3 gap-y-1 items-center"):
                        for key, label in (("in1", "IN1"), ("in2", "IN2"), ("out1", "OUT1"), ("out2", "OUT2"),
                                           ("estop", "E-stop")):
                            ui.label(label).classes("text-slate-400 text-sm")
                            self.io_leds[key] = ui.html("<span class='pk-led'></span> <span class='pk-mono'>—</span>").props(f"data-testid=io-{key}")
                    self.error_label = ui.label("no errors").classes("text-xs text-slate-400").props("data-testid=error-bits")
            with ui.row().classes("w-full gap-6 text-xs text-slate-400 pk-mono"):
                self.timing_label = ui.label("board —").props("data-testid=board-timing")
                self.loop_label = ui.label("loop —").props("data-testid=loop-stats")
                self.queue_label = ui.label("queue —").props("data-testid=queue")
            ui.label("Log").classes("pk-title")
            self.log_box = ui.html("").classes("pk-log w-full").props("data-testid=log")

    def build_tabs(self) -> None:
        with ui.card().classes("pk-card w-full p-0 gap-0"):
            with ui.tabs().classes("w-full text-slate-200").props("align=left dense") as tabs:
                t_jog = ui.tab("Jog", icon="open_with").props("data-testid=tab-jog")
                t_grip = ui.tab("IO · Gripper", icon="back_hand").props("data-testid=tab-gripper")
                t_prog = ui.tab("Program", icon="code").props("data-testid=tab-program")
            with ui.tab_panels(tabs, value=t_jog).classes("w-full bg-transparent"):
                with ui.tab_panel(t_jog):
                    self.build_jog()
                with ui.tab_panel(t_grip):
                    self.build_gripper()
                with ui.tab_panel(t_prog):
                    self.build_program()

    def build_jog(self) -> None:
        with ui.row().classes("w-full items-center gap-4"):
            ui.toggle({False: "Continuous", True: "Step"}, value=False,
                      on_change=lambda e: setattr(self, "step_mode", e.value)).props("data-testid=jog-mode")
            with ui.column().classes("gap-0 grow"):
                ui.label().bind_text_from(self, "speed", lambda v: f"Speed {v:.0f} %").classes("text-xs text-slate-400")
                ui.slider(min=1, max=100, step=1).bind_value(self, "speed").props("data-testid=speed-slider")
            with ui.column().classes("gap-0 grow"):
                ui.label().bind_text_from(self, "accel", lambda v: f"Acceleration {v:.0f} %").classes("text-xs text-slate-400")
                ui.slider(min=1, max=100, step=1).bind_value(self, "accel").props("data-testid=accel-slider")
        with ui.row().classes("items-center gap-3"):
            ui.number("step °", value=self.step_deg, min=0.1, max=45, step=0.5, format="%.1f").bind_value(self, "step_deg").classes("w-24")
            ui.number("step mm", value=self.step_mm, min=0.1, max=100, step=1, format="%.1f").bind_value(self, "step_mm").classes("w-24")
        with ui.row().classes("w-full gap-6 no-wrap items-start pk-jog"):
            with ui.column().classes("gap-1"):
                ui.label("Joint jog").classes("pk-title")
                for j in range(6):
                    with ui.row().classes("items-center gap-2 no-wrap"):
                        ui.label(JOINT_NAMES[j]).classes("w-6 text-slate-300")
                        for d, icon in ((-1, "remove"), (1, "add")):
                            b = ui.button(icon=icon).props("unelevated color=blue-grey-8").props(f"data-testid=jog-j{j + 1}{'+' if d > 0 else '-'}")
                            self._hold_button(b, partial(self.joint_press, j, d))
                            self.joint_buttons[(j, d)] = b
            with ui.column().classes("gap-1"):
                with ui.row().classes("items-center gap-2"):
                    ui.label("Cartesian jog").classes("pk-title")
                    ui.toggle({Frame.WRF: "WRF", Frame.TRF: "TRF"}, value=Frame.WRF,
                              on_change=lambda e: setattr(self, "frame", e.value)).props("dense").props("data-testid=frame-toggle")
                with ui.grid(columns=3).classes("gap-2"):
                    for axis_name in ("X", "Y", "Z", "RX", "RY", "RZ"):
                        ui.label(axis_name).classes("text-slate-300 self-center")
                        for sign in ("-", "+"):
                            axis = CartAxis(axis_name + sign)
                            b = ui.button(icon="remove" if sign == "-" else "add").props("unelevated color=indigo-8").props(f"data-testid=jog-{axis_name.lower()}{sign}")
                            self._hold_button(b, partial(self.cart_press, axis))
                            self.cart_buttons[axis] = b
        ui.label("Hold a button (or its key, see ?) to jog; release stops. Step mode moves one increment per click.") \
            .classes("text-xs text-slate-500")

    def _hold_button(self, button: ui.button, press: Callable[[], None]) -> None:
        def down(_: Any) -> None:
            self._held_button = button
            press()
            if self.c.jogging:
                button.classes(add="pk-held")

        button.on("mousedown", down)
        button.on("touchstart", down)
        for ev in ("mouseup", "mouseleave", "touchend", "touchcancel"):
            button.on(ev, lambda _: self.release())

    def release(self) -> None:
        """End a held jog (button, key, blur) and drop the held-button highlight."""
        self.c.jog_release()
        if self._held_button is not None:
            self._held_button.classes(remove="pk-held")
            self._held_button = None

    def build_gripper(self) -> None:
        with ui.row().classes("w-full gap-6 items-start no-wrap"):
            with ui.column().classes("gap-2"):
                ui.label("Outputs").classes("pk-title")
                for n in (1, 2):
                    with ui.row().classes("items-center gap-2"):
                        ui.label(f"OUT{n}").classes("w-12 text-slate-300")
                        ui.button("HIGH", on_click=lambda n=n: self.c.command(f"PNEUMATICGRIPPER|open|{n}", f"OUT{n} HIGH")).props("unelevated color=positive dense").props(f"data-testid=out{n}-high")
                        ui.button("LOW", on_click=lambda n=n: self.c.command(f"PNEUMATICGRIPPER|close|{n}", f"OUT{n} LOW")).props("outline color=grey-4 dense").props(f"data-testid=out{n}-low")
                ui.label("Pneumatic gripper on OUT1/OUT2: HIGH = open (output on), LOW = close, as the original.").classes("text-xs text-slate-500 w-56")
            with ui.column().classes("gap-2 grow"):
                ui.label("SSG-48 electric gripper").classes("pk-title")
                with ui.row().classes("gap-2"):
                    ui.button("Calibrate", icon="tune", on_click=lambda: self.c.command("ELECTRICGRIPPER|calibrate", "Gripper calibrate")).props("unelevated color=primary").props("data-testid=grip-cal")
                    ui.button("Clear error", icon="healing", on_click=lambda: self.c.command("ELECTRICGRIPPER|clear_error", "Gripper clear error")).props("outline color=grey-4").props("data-testid=grip-clear")
                self.grip_pos = ui.slider(min=0, max=255, value=100).props("label").props("data-testid=grip-pos")
                ui.label().bind_text_from(self.grip_pos, "value", lambda v: f"position {v}").classes("text-xs text-slate-400")
                self.grip_speed = ui.slider(min=0, max=255, value=60).props("label").props("data-testid=grip-speed")
                ui.label().bind_text_from(self.grip_speed, "value", lambda v: f"speed {v}").classes("text-xs text-slate-400")
                self.grip_current = ui.slider(min=0, max=1300, step=10, value=600).props("label").props("data-testid=grip-current")
                ui.label().bind_text_from(self.grip_current, "value", lambda v: f"current {v} mA").classes("text-xs text-slate-400")
                ui.button("Move", icon="play_arrow", on_click=self.gripper_move).props("unelevated color=primary").props("data-testid=grip-move")
                self.grip_readout = ui.label("—").classes("pk-val text-sm").props("data-testid=grip-readout")

    def gripper_move(self) -> None:
        p, s, c = int(self.grip_pos.value), int(self.grip_speed.value), int(self.grip_current.value)
        self.c.command(f"ELECTRICGRIPPER|move|{p}|{s}|{c}", f"Gripper move {p}/{s}/{c} mA")

    def build_program(self) -> None:
        with ui.row().classes("w-full items-center gap-2"):
            ui.button(icon="play_arrow", on_click=lambda: self.run_program(step=False)).props("unelevated color=positive").props("data-testid=prog-run").tooltip("Run / resume")
            ui.button(icon="pause", on_click=self.c.program.pause).props("unelevated color=warning").props("data-testid=prog-pause").tooltip("Pause")
            ui.button(icon="skip_next", on_click=lambda: self.run_program(step=True)).props("unelevated color=info").props("data-testid=prog-step").tooltip("Step one line")
            ui.button(icon="stop", on_click=self.stop_program).props("unelevated color=negative").props("data-testid=prog-stop").tooltip("Stop")
            ui.button("Check", icon="rule", on_click=self.check_program).props("outline color=grey-4").props("data-testid=prog-check")
            ui.space()
            with ui.button("Insert", icon="add").props("outline color=grey-4"):
                with ui.menu():
                    for t in TEMPLATES:
                        ui.menu_item(f"{t.name} — {t.description}", on_click=lambda t=t: self.insert_template(t.name))
            with ui.button("Examples", icon="library_books").props("outline color=grey-4"):
                with ui.menu():
                    for name, text in SEED_EXAMPLES.items():
                        ui.menu_item(name, on_click=lambda text=text: self.set_program(text))
        self.files = ProgramsPanel(self.c.programs, self.c.log, lambda: self.editor.value or "", self.set_program)
        self.editor = ui.codemirror(SEED_EXAMPLES["Output click"], on_change=self.on_edit, theme="githubLight") \
            .classes("w-full pk-editor").style("height: 300px").props("data-testid=editor")
        self.prog_status = ui.label("").classes("text-sm pk-mono").props("data-testid=prog-status")
        self.diag_box = ui.column().classes("gap-0 w-full").props("data-testid=diagnostics")
        with ui.row().classes("w-full no-wrap gap-2"):
            self.plan_chart = ui.echart(self._plan_options("deg", "planned positions")).classes("w-1/2").style("height: 200px").props("data-testid=plan-chart")
            self.plan_speed_chart = ui.echart(self._plan_options("deg/s", "planned speeds")).classes("w-1/2").style("height: 200px").props("data-testid=plan-speed-chart")
        self.on_edit()

    def build_plots(self) -> None:
        with ui.card().classes("pk-card w-full p-3 gap-1"):
            ui.label(f"Live joint positions and speeds (last {PLOT_WINDOW_S:.0f} s)").classes("pk-title")
            with ui.row().classes("w-full no-wrap gap-2"):
                self.pos_chart = ui.echart(self._live_options("deg")).classes("w-1/2").style("height: 230px").props("data-testid=pos-chart")
                self.speed_chart = ui.echart(self._live_options("deg/s")).classes("w-1/2").style("height: 230px").props("data-testid=speed-chart")

    def build_help(self) -> None:
        with ui.dialog() as self.help, ui.card().classes("pk-card"):
            ui.label("Keyboard shortcuts").classes("text-lg font-bold")
            with ui.grid(columns=2).classes("gap-x-6 gap-y-1"):
                for b in KEYMAP:
                    ui.label(key_label(b.key)).classes("pk-mono text-amber-300")
                    ui.label(b.description).classes("text-slate-300")
            ui.label("Cartesian keys use the frame selected in the Jog panel. Keys are ignored while typing in the editor, except Esc.").classes("text-xs text-slate-400 w-96")
            ui.button("Close", on_click=self.help.close).props("flat")

    # ---------------------------------------------------------------- actions

    def joint_press(self, joint: int, direction: int) -> None:
        st = self.link.status
        if st is None:
            self.c.log.error("no robot status yet: cannot jog")
            return
        if joint_jog_blocked(st.angles, joint, direction):
            self.c.log.add(f"{JOINT_NAMES[joint]} is at its {'upper' if direction > 0 else 'lower'} limit", Level.WARNING)
            return
        if self.step_mode:
            try:
                target = joint_step_target(st.angles, joint, direction * float(self.step_deg))
            except ParolkitValueError as exc:
                self.c.log.error(str(exc))
                return
            self.c.command("MOVEJOINT|" + "|".join(f"{v:.4f}" for v in target) + f"|None|{self.speed:g}|{self.accel:g}",
                           f"step {JOINT_NAMES[joint]} {direction * float(self.step_deg):+g}°")
            return
        jog = JointJog.single(joint, direction, float(self.speed), duration_s=JOG_DURATION_S)
        self.c.log.info(f"jog {JOINT_NAMES[joint]}{'+' if direction > 0 else '−'} at {self.speed:g} %")
        self.c.jog_press(lambda: jog_command(jog))

    def cart_press(self, axis: CartAxis) -> None:
        st = self.link.status
        if st is None:
            self.c.log.error("no robot status yet: cannot jog")
            return
        if self.step_mode:
            step = float(self.step_deg if axis.is_rotation else self.step_mm)
            self.c.command(cart_step_command(st.pose, self.frame, axis, step, float(self.speed)),
                           f"step {self.frame.value} {axis.value} {step:g}{'°' if axis.is_rotation else ' mm'}")
            return
        period = self.c.cart_jog_repeat_s
        cart_jog = CartJog(self.frame, axis, float(self.speed), max(JOG_DURATION_S, 3 * period))
        self.c.log.info(f"jog {self.frame.value} {axis.value} at {self.speed:g} %")
        self.c.jog_press(lambda: jog_command(cart_jog), period)

    def on_key(self, e: Any) -> None:
        args = e.args if isinstance(e.args, dict) else {}
        key, down = args.get("key", ""), bool(args.get("down"))
        if key == "blur" or not down:
            self.release()
            return
        b = key_action(key)
        if b is None:
            return
        if b.action == "estop":
            self.c.estop()
        elif b.action == "stop":
            self.c.command("STOP", "Stop")
        elif b.action == "joint" and b.joint is not None:
            self.joint_press(b.joint, b.direction)
        elif b.action == "cart" and b.axis is not None:
            self.cart_press(b.axis)

    # ---- program ----

    def set_program(self, text: str) -> None:
        self.editor.value = text
        self.on_edit()

    def insert_template(self, name: str) -> None:
        st = self.link.status
        joints = st.angles if st else PAROL6.standby_deg
        pose = st.pose if st else (0.0,) * 6
        line = render_template(name, joints, pose)
        text = self.editor.value or ""
        if text and not text.endswith("\n"):
            text += "\n"
        self.set_program(text + line + "\n")

    def on_edit(self, *_: Any) -> None:
        """Re-colour the text; old error marks go (their lines may have moved): Check again."""
        self._errors = {}
        self._refresh_decorations()

    def _refresh_decorations(self) -> None:
        text = self.editor.value or ""
        runner = self.c.program
        cur = runner.current_line if runner.running or runner.state == "paused" else None
        decos = mark_decorations(text) + line_decorations(text, current_line=cur, error_lines=self._errors)
        self.editor.decorations = decos
        self.editor.line_tooltips = dict(self._errors)

    def _show_errors(self, errors: list[Any]) -> None:
        self._errors = {}
        self.diag_box.clear()
        with self.diag_box:
            for err in errors:
                self._errors.setdefault(int(err.line), f"{err.line}:{err.col} {err.message}")
                ui.label(f"line {err.line}, col {err.col}: {err.message}").classes("text-sm text-red-400 pk-mono").props("data-testid=diagnostic")
        self._refresh_decorations()

    def check_program(self) -> bool:
        from parolkit.script import parse

        result = parse(self.editor.value or "", "editor")
        errors = list(result.errors)
        if not errors:
            errors = self._dry_run(result.program)
        self._show_errors(errors)
        ok = not errors
        self.prog_status.set_text("✓ program OK" if ok else f"✗ {len(errors)} error(s)")
        self.prog_status.classes(replace="text-sm pk-mono " + ("text-green-400" if ok else "text-red-400"))
        return ok

    def _dry_run(self, program: Any) -> list[Any]:
        """Plan the program without the robot (from the current joints); returns its errors
        and fills the planned position/speed charts."""
        from parolkit.script import dry_run

        st = self.link.status
        try:
            report = dry_run(program, st.angles if st else None)
        except (ParolkitError, ValueError) as exc:
            self.c.log.error(f"dry run: {exc}")
            return []
        if report.segments:
            self._plot_plan(*report.series())
        return list(report.errors)

    def _plot_plan(self, t: Any, q: Any, v: Any) -> None:
        step = max(1, len(t) // 400)
        idx = range(0, len(t), step)
        for chart, data in ((self.plan_chart, q), (self.plan_speed_chart, v)):
            opts = chart.options
            for j in range(6):
                opts["series"][j]["data"] = [[round(float(t[i]), 3), round(float(data[i][j]), 3)] for i in idx]
            chart.update()

    async def run_program(self, step: bool) -> None:
        errors = await self.c.program.start(self.editor.value or "", step=step)
        self._show_errors(errors)
        if errors:
            self.prog_status.set_text(f"✗ {len(errors)} error(s): nothing was run")

    def stop_program(self) -> None:
        """Stop the program run and send STOP (cancels the move in progress and the queue)."""
        self.c.program.stop()
        self.c.command("STOP", "Stop")

    # ---------------------------------------------------------------- periodic updates

    def update_scene(self) -> None:
        st = self.link.status
        if st is None or st.seq == self._last_seq:
            return
        self._last_seq = st.seq
        frames = arm_frames(st.angles, st.tool)
        with self.scene._batch_calls():  # one websocket message per update
            for g, t in zip(self.groups, frames):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot)
            self._update_plan(st)
        self._frames_n += 1
        now = time.monotonic()
        if now - self._frames_t >= 1.0:
            self.fps_label.set_text(f"{self._frames_n / (now - self._frames_t):.0f} fps · seq {st.seq}")
            self._frames_t, self._frames_n = now, 0

    def _update_plan(self, st: RobotStatus) -> None:
        plan = self.link.plan
        # the ghost and path show while the robot is in motion (state MOVING or HOMING)
        moving = st.state in (RobotState.MOVING, RobotState.HOMING)
        shown = plan if plan is not None and moving and plan.seq == st.plan_seq else None
        show = shown is not None
        key = (plan.seq if plan else None, show)
        if key == self._last_plan_seq:
            return
        self._last_plan_seq = key
        s = geometry.SCENE_SCALE / 1000.0
        if shown is not None and shown.target_angles:
            for g, t in zip(self.ghost, arm_frames(shown.target_angles, st.tool)):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot).visible(True)
        else:
            for g in self.ghost:
                g.visible(False)
        pts = [[p[0] * s, p[1] * s, p[2] * s] for p in shown.tcp_path] if shown is not None else []
        self.path.set_points(pts)

    def update_readouts(self) -> None:
        self.control_badge.update()
        link_up = self.link.link_up
        st = self.link.status
        self.link_chip.set_text("LINKED" if link_up else "NO LINK")
        self.link_chip.props(f"color={'positive' if link_up else 'grey'} icon={'link' if link_up else 'link_off'}")
        text, colour = state_badge(st, link_up)
        self.state_chip.set_text(text)
        self.state_chip.props(f"color={colour}")
        if st is not None:
            if st.board.simulated:
                self.mode_chip.set_text("SIMULATOR")
            elif st.board.port:
                self.mode_chip.set_text(f"REAL · {st.board.port}")
            latched = st.estop_latched or st.estop_pressed
            self.estop_btn.classes(add="latched") if latched else self.estop_btn.classes(remove="latched")
            self.estop_btn.set_text("E-STOP LATCHED" if latched else "E-STOP")
            for lbl, v in zip(self.joint_labels, format_angles(st.angles)):
                lbl.set_text(v)
            for lbl, v in zip(self.speed_labels, format_speeds(st.speeds_deg_s)):
                lbl.set_text(v)
            for led, h in zip(self.homed_leds, st.homed):
                led.set_content(f"<span class='pk-led{' on' if h else ''}'></span>")
            for lbl, v in zip(self.pose_labels, format_pose(st.pose)):
                lbl.set_text(v)
            io = st.io
            for key in ("in1", "in2", "out1", "out2"):
                v = getattr(io, key)
                self.io_leds[key].set_content(f"<span class='pk-led{' on' if v else ''}'></span> "
                                              f"<span class='pk-mono'>{'HIGH' if v else 'LOW'}</span>")
            pressed = io.estop_pressed
            self.io_leds["estop"].set_content(
                f"<span class='pk-led{' bad' if pressed or st.estop_latched else ' on'}'></span> <span class='pk-mono'>"
                f"{'PRESSED' if pressed else 'released'}{' · latched' if st.estop_latched else ''}</span>")
            err = st.errors
            bits = [f"J{j + 1} temp" for j, b in enumerate(err.temperature) if b]
            bits += [f"J{j + 1} pos" for j, b in enumerate(err.position) if b]
            if err.message:
                bits.append(err.message)
            self.error_label.set_text("errors: " + ", ".join(bits) if bits else "no temperature / position errors")
            self.error_label.classes(replace="text-xs " + ("text-red-400" if bits else "text-slate-400"))
            self.timing_label.set_text(f"board {_fmt_ms(st.board.timing_ms)}")
            self.loop_label.set_text(f"loop {format_loop(st.loop)}")
            cmd = st.command
            cmd_text = "idle" if cmd is None else cmd.name + (f" {cmd.progress * 100:.0f}%" if cmd.progress is not None else "")
            self.queue_label.set_text(f"queue {st.queue} · {cmd_text}")
            self._update_enables(st)
            g = st.gripper
            self.grip_readout.set_text(
                f"pos {g.position} · speed {g.speed} · current {g.current} mA · {g.status_text}"
                f" · object {'yes' if g.object_detected else 'no'} (code {g.object_detection})")
        if self.c.log.version != self._log_version:
            self._log_version = self.c.log.version
            rows = "".join(f"<div class='{e.level.value}'>{_html_escape(e.format())}</div>" for e in reversed(self.c.log.tail(80)))
            self.log_box.set_content(rows)
        runner = self.c.program
        if runner.version != self._prog_version:
            self._prog_version = runner.version
            if runner.state in ("running", "paused"):
                self.prog_status.set_text(f"▶ {runner.state} · line {runner.current_line or '—'}")
                self.prog_status.classes(replace="text-sm pk-mono text-amber-300")
            elif runner.state == "error":
                if runner.errors:
                    self._show_errors(runner.errors)
                self.prog_status.set_text(f"✗ {runner.message}")
                self.prog_status.classes(replace="text-sm pk-mono text-red-400")
            elif runner.message:
                self.prog_status.set_text(f"■ {runner.message}")
            self._refresh_decorations()

    def _update_enables(self, st: RobotStatus) -> None:
        """Grey jog buttons that cannot move: robot not movable, joint at its limit in that
        direction, or (Cartesian) no IK solution a small step ahead in that direction."""
        movable = st.can_move
        for (j, d), b in self.joint_buttons.items():
            b.set_enabled(movable and not joint_jog_blocked(st.angles, j, d))
        key = (tuple(round(v, 2) for v in st.pose), self.frame, movable, st.tool)
        if key == self._cart_key:
            return
        self._cart_key = key
        blocked: dict[CartAxis, bool] = {}
        if movable:
            from parolkit.kinematics import get_tool, ik

            try:
                tool = None if st.tool == "default" else get_tool(st.tool)
            except (ParolkitError, KeyError, ValueError):
                tool = None  # a tool only the controller knows: do not guess
            if tool is not None or st.tool == "default":
                solve = lambda pose, seed: ik(pose, seed, tool=tool)  # noqa: E731
                blocked = {a: cart_jog_blocked(st.pose, st.angles, self.frame, a, solve) for a in CartAxis}
        for axis, b in self.cart_buttons.items():
            b.set_enabled(movable and not blocked.get(axis, False))

    def update_plots(self) -> None:
        if not hasattr(self, "pos_chart"):
            return
        hist = list(self.link.history)
        if not hist:
            return
        t_end = hist[-1].t
        step = max(1, len(hist) // 300)
        sel = hist[::step]
        for chart, attr in ((self.pos_chart, "angles"), (self.speed_chart, "speeds")):
            opts = chart.options
            for j in range(6):
                opts["series"][j]["data"] = [[round(s.t - t_end, 2), round(getattr(s, attr)[j], 2)] for s in sel]
            chart.update()

    # ---------------------------------------------------------------- chart options

    @staticmethod
    def _live_options(unit: str) -> dict[str, Any]:
        return {
            "animation": False,
            "backgroundColor": "transparent",
            "grid": {"left": 52, "right": 14, "top": 30, "bottom": 34},
            "legend": {"textStyle": {"color": "#cbd5e1"}, "top": 0, "left": 44, "itemWidth": 14, "itemGap": 8},
            "tooltip": {"trigger": "axis"},
            "xAxis": {"type": "value", "min": -PLOT_WINDOW_S, "max": 0, "name": "s",
                      "axisLabel": {"color": "#94a3b8"}, "splitLine": {"show": False}},
            "yAxis": {"type": "value", "name": unit, "nameLocation": "middle", "nameGap": 36, "scale": True,
                      "nameTextStyle": {"color": "#94a3b8"}, "axisLabel": {"color": "#94a3b8"},
                      "splitLine": {"lineStyle": {"color": "#1e293b"}}},
            "series": [{"name": JOINT_NAMES[j], "type": "line", "showSymbol": False, "data": [],
                        "lineStyle": {"width": 1.6}, "color": JOINT_COLOURS[j]} for j in range(6)],
        }

    @staticmethod
    def _plan_options(unit: str, title: str) -> dict[str, Any]:
        opts = CommanderPage._live_options(unit)
        opts["xAxis"] = {"type": "value", "name": "s", "axisLabel": {"color": "#94a3b8"}, "splitLine": {"show": False}}
        opts["title"] = {"text": title + " (Check)", "textStyle": {"color": "#94a3b8", "fontSize": 11},
                         "left": "center", "bottom": 0}
        return opts


def _html_escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def build_app(commander: Commander) -> Callable[[], None]:
    """The root page function for ``ui.run``; starts/stops the link with the app."""

    async def startup() -> None:
        await commander.link.start()
        commander.control.start()

    async def shutdown() -> None:
        commander.jog_release()
        commander.program.stop("stopped: commander shutting down")
        await commander.control.stop()
        await commander.link.close()  # gives the control lease back (CONTROL|RELEASE)

    app.on_startup(startup)
    app.on_shutdown(shutdown)

    def opened() -> None:
        commander.pages += 1

    def closed() -> None:
        """A page's connection went away: end its jog; when no page is connected any more the
        commander gives the control lease back (unless a program runs: the runner holds the
        lease then and gives it back itself when the program ends)."""
        commander.jog_release()
        commander.pages = max(0, commander.pages - 1)
        if commander.pages == 0 and not commander.program.running:
            try:
                commander.control.release()
            except RobotError as exc:
                commander.log.error(f"release control: {exc}")

    def root() -> None:
        page = CommanderPage(commander)
        # once per socket connection (a reconnecting page connects again)
        ui.context.client.on_connect(opened)
        ui.context.client.on_disconnect(closed)
        ui.page_title("parolkit commander")
        del page  # the page's timers and handlers keep it alive with the client

    return root
