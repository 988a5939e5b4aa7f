"""The commander page (NiceGUI).  Imported only by ``parolkit gui``.

One :class:`~parolkit.gui.commander.Commander` per process holds the controller link, the
event log, the jog hold and the program runner; every browser tab gets its own
:class:`CommanderPage`, which puts the components of :mod:`parolkit.gui.components` on the
page, routes the keyboard and runs the timers.  The stylesheet and the keyboard script are
static files of the package (``gui/static``), served under :data:`STATIC_URL`.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from nicegui import app, ui

from parolkit.gui.commander import Commander
from parolkit.gui.completion import completion_table
from parolkit.gui.components.class_panel import ClassPanel, install_gate
from parolkit.gui.components.header import Header
from parolkit.gui.components.help_dialog import HelpDialog
from parolkit.gui.components.io_panel import IoGripperPanel
from parolkit.gui.components.jog_panel import JogPanel
from parolkit.gui.components.program_panel import ProgramPanel
from parolkit.gui.components.recordings_panel import RecordingsPanel
from parolkit.gui.components.speed_override import SpeedOverride
from parolkit.gui.components.tabs import icon_tab
from parolkit.gui.components.telemetry import LiveCharts, Readouts
from parolkit.gui.components.view3d import ArmView
from parolkit.gui.downloads import install_downloads
from parolkit.gui.jog import KEYMAP, key_action
from parolkit.gui.security import SESSION_COOKIE, session_key

__all__ = ["Commander", "CommanderPage", "build_app", "STATIC_DIR", "STATIC_URL", "static_url"]

#: the package's static files (stylesheet, keyboard script) and the URL they are served at
STATIC_DIR = Path(__file__).resolve().parent / "static"
STATIC_URL = "/parolkit-static"
READOUT_PERIOD_S = 0.1
PLOT_PERIOD_S = 0.5


def static_url(name: str) -> str:
    """URL of the static file ``name`` with a content hash (a new version is never served
    from a browser's cache)."""
    digest = hashlib.sha256((STATIC_DIR / name).read_bytes()).hexdigest()[:12]
    return f"{STATIC_URL}/{name}?v={digest}"


class CommanderPage:
    """One browser tab: the components, the keyboard routing and the timers."""

    def __init__(self, commander: Commander) -> None:
        self.c = commander
        self.link = commander.link
        ui.add_head_html(f'<link rel="stylesheet" href="{static_url("commander.css")}">')
        # the key list as a JSON data island, read by commander.js
        keys = json.dumps([b.key for b in KEYMAP]).replace("<", "\\u003c")
        ui.add_body_html(f'<script type="application/json" id="pk-keymap">{keys}</script>')
        # the editor's completion items (parolkit.gui.completion), read by commander.js
        items = json.dumps(completion_table()).replace("<", "\\u003c")
        ui.add_body_html(f'<script type="application/json" id="pk-completions">{items}</script>')
        ui.add_body_html(f'<script src="{static_url("commander.js")}"></script>')
        ui.add_body_html(f'<script src="{static_url("gamepad.js")}"></script>')  # the gamepad (gui/gamepad.py)
        ui.dark_mode(True)
        # brand colours dark enough for white text at >= 4.5:1 (Quasar's own are 2.9..4.4:1)
        ui.colors(primary="#1d4ed8", positive="#15803d", warning="#a16207", negative="#b91c1c", info="#0369a1")
        ui.on("pk_key", self.on_key)
        self._was_up = True  # the first update greys the jog buttons if there is no link
        # "something moves" for commander.js: Space is STOP in a text field then (data-moving)
        self._moving = commander.moving
        self.motion = ui.element("div").classes("pk-motion") \
            .props(f"data-moving={int(self._moving)} aria-hidden=true")
        self.motion.set_visibility(False)
        self.help = HelpDialog()
        self.header = Header(commander, on_help=self.help.open)
        with ui.element("main").classes("pk-main"):
            with ui.element("div").classes("pk-col"):
                self.view = ArmView(self.link, commander.collision, fps=commander.view_fps)
                self.readouts = Readouts(commander.log, self.link)  # (the link: the age of stale values)
            with ui.element("div").classes("pk-col"):
                # a class: the queue, at the top of the column (gui/components/class_panel.py)
                class_box = ui.element("div").classes("w-full") if commander.classroom is not None else None
                # above the tabs: beside the jog speed and the program's Run / Pause, whichever
                # tab is open
                self.override = SpeedOverride(commander)
                self._build_tabs()
                self.charts = LiveCharts(self.link)
        self.program.on_preview = self.view.show_preview
        self.view.sim_source = self.program.sim_frame  # Simulate's ghost arm
        ui.timer(1.0 / commander.view_fps, self.view.update)
        ui.timer(READOUT_PERIOD_S, self.update_readouts)
        self.member_key: str | None = None
        self.class_panel: ClassPanel | None = None
        if class_box is not None:
            self._join_class(class_box)
        ui.timer(PLOT_PERIOD_S, self.charts.update)

    def _join_class(self, card_box: ui.element) -> None:
        """A class: this page's member (from its session cookie), the Class card and the header's
        part, the greyed controls of a page that watches, and the server's gate on its events."""
        service = self.c.classroom
        assert service is not None
        client = ui.context.client
        token = client.request.cookies.get(SESSION_COOKIE)
        self.member_key = key = session_key(token) if token else ""
        header = self.header
        lockable = [*header.controls, header.resume_btn, header.control_badge.take_button, header.restart_btn,
                    self.override.slider, self.panels]
        self.class_panel = ClassPanel(service, key, header_box=header.status_box, card_box=card_box,
                                      lockable=lockable)
        install_gate(client, service, key, self.class_panel.open_ids, self.class_panel.refused)

    def may_drive(self) -> bool:
        """This page may move the robot (always without a class)."""
        service = self.c.classroom
        return service is None or service.may_drive(self.member_key)

    def _build_tabs(self) -> None:
        with ui.card().classes("pk-card w-full p-0 gap-0"):
            with ui.tabs().classes("w-full").props("align=left dense no-caps outside-arrows mobile-arrows") as tabs:
                t_jog = icon_tab("Jog", "open_with", "tab-jog")
                t_grip = icon_tab("IO · Gripper", "back_hand", "tab-gripper")
                t_prog = icon_tab("Program", "code", "tab-program")
                t_rec = icon_tab("Record", "fiber_manual_record", "tab-record")
            # not animated: a panel sliding out stayed in the page for 1-3 s on a loaded machine
            # (axe-core found the leaving editor's scroller without its focusable content)
            with ui.tab_panels(tabs, value=t_jog, animated=False).classes("w-full bg-transparent") as self.panels:
                with ui.tab_panel(t_jog):
                    self.jog = JogPanel(self.c)
                with ui.tab_panel(t_grip):
                    self.io = IoGripperPanel(self.c)
                with ui.tab_panel(t_prog):
                    self.program: ProgramPanel = ProgramPanel(self.c)
                with ui.tab_panel(t_rec):
                    self.recordings = RecordingsPanel(self.c, on_program_opened=lambda: self._show_program(tabs, t_prog))
            # opening the Program tab creates its editor: scroll the executing line into view then
            t_prog.on("click", self.program.shown)

    def _show_program(self, tabs: ui.tabs, t_prog: ui.tab) -> None:
        """A program was opened from elsewhere (taught from a recording): show it in the editor."""
        tabs.set_value(t_prog)
        self.program.shown()

    def update_readouts(self) -> None:
        st = self.link.status
        up = self.link.link_up
        self.header.update(st, up)
        self.override.update(st, up)
        self.readouts.update(st, up)
        self.io.set_online(up)
        self.program.set_online(up)
        self.recordings.set_online(up)
        if st is not None and up:
            self.jog.update(st)
            self.io.update(st)
        elif self._was_up:
            self.jog.offline()
        self._was_up = up
        self.program.update()
        self.recordings.update()
        if self.class_panel is not None:
            self.class_panel.update()
        moving = self.c.moving
        if moving != self._moving:
            self._moving = moving
            self.motion.props(f"data-moving={int(moving)}")

    def on_key(self, e: Any) -> None:
        """A key from commander.js: ``{key, down, typed}``; 'blur' and 'release' end a held
        jog.  ``typed``: a Space the page typed into a text field (it saw nothing moving); it
        is STOP all the same if something moves by now (it may have started just before)."""
        args = e.args if isinstance(e.args, dict) else {}
        key, down = args.get("key", ""), bool(args.get("down"))
        driver = self.may_drive()  # a class: a watching page's keys are Stop and E-STOP only
        if key == "blur" or not down:
            if driver:  # (a watching page's blur must not end the driver's jog)
                self.jog.release()
            return
        b = key_action(key)
        if b is None:
            return
        if not driver and b.action not in ("estop", "stop"):
            if self.class_panel is not None:
                self.class_panel.refused(f"key {key}")
            return
        if b.action == "estop":
            self.c.estop()
        elif b.action == "stop":
            if not args.get("typed") or self.c.moving:
                self.c.stop()
        elif b.action == "joint" and b.joint is not None:
            self.jog.joint_press(b.joint, b.direction)
        elif b.action == "cart" and b.axis is not None:
            self.jog.cart_press(b.axis)


def build_app(commander: Commander) -> Callable[[], None]:
    """The root page function for ``ui.run``; serves the static files and the recordings'
    downloads and starts/stops the link with the app."""
    app.add_static_files(STATIC_URL, STATIC_DIR)
    install_downloads(commander)  # the recordings' and the programs' file downloads

    async def startup() -> None:
        await commander.link.start()
        commander.control.start()
        if commander.classroom is not None:
            commander.classroom.start()

    async def shutdown() -> None:
        commander.jog_release()
        commander.program.stop("stopped: commander shutting down")
        await asyncio.to_thread(commander.recording.close)  # the file gets its summary
        await asyncio.to_thread(commander.teach_process.close)
        await commander.control.stop()
        if commander.classroom is not None:
            await commander.classroom.stop()
        await commander.collision.close()
        await commander.link.close()  # gives the control lease back (CONTROL|RELEASE)

    app.on_startup(startup)
    app.on_shutdown(shutdown)

    def root() -> None:
        page = CommanderPage(commander)
        # once per socket connection (a reconnecting page connects again)
        ui.context.client.on_connect(lambda: commander.page_opened(page.member_key))
        ui.context.client.on_disconnect(lambda: commander.page_closed(page.member_key, page.may_drive()))
        ui.page_title("parolkit commander")

    return root
