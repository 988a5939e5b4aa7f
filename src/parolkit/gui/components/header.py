"""The header (NiceGUI): always visible (a fixed Quasar header), it holds what must never
scroll away: link and robot state (PAUSED while the controller is paused), who controls the
robot, the compact gripper readout, REC while a recording runs, Home / Enable / Disable / Clear
error / Resume (while paused) / Stop, help and the E-STOP button
(in a layer of its own above every dialog, menu and tooltip, over its slot in the header row).

On a narrow screen (phones, <= 760 px) the stylesheet moves E-STOP onto the first row and
shows the buttons as icons; every button keeps its accessible name (``aria-label``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from nicegui import ui

from parolkit.client.core import RobotStatus
from parolkit.gui.commander import Commander
from parolkit.gui.control_badge import ControlBadge
from parolkit.gui.status import gripper_summary, state_badge

__all__ = ["Header"]


def _action(label: str, icon: str, testid: str, props: str, on_click: Callable[[], Any],
            tooltip: str) -> ui.button:
    """A header button: text and icon, its accessible name = its label."""
    b = ui.button(label, icon=icon, on_click=on_click) \
        .props(f'{props} no-caps aria-label="{label}" data-testid={testid}').classes("px-2")
    b.tooltip(tooltip)
    return b


class Header:
    """The page's header; :meth:`update` follows the link's status."""

    def __init__(self, commander: Commander, on_help: Callable[[], None]) -> None:
        c = self.c = commander
        self._shown: tuple[bool, str, str, bool] | None = None
        with ui.header(fixed=True).classes("pk-header p-0").props('role=banner'):
            with ui.element("div").classes("pk-header-row"):
                with ui.element("div").classes("pk-brand"):
                    ui.icon("precision_manufacturing", size="30px").classes("text-sky-400")
                    with ui.element("div"):
                        ui.label("parolkit commander").classes("pk-brand-title")
                        ui.label("PAROL6 · jog · IO · RBTscript").classes("pk-brand-sub")
                with ui.element("div").classes("pk-mid"):
                    with ui.element("div").classes("pk-status").props('role=status aria-label="robot status"') \
                            as self.status_box:
                        self.link_chip = ui.chip("NO LINK", icon="link_off", color="grey-8") \
                            .props("data-testid=link-chip")
                        self.mode_chip = ui.chip(c.mode_label, icon="memory", color="indigo") \
                            .props("data-testid=mode-chip")
                        self.state_chip = ui.chip("—", color="grey-8").classes("text-weight-bold") \
                            .props("data-testid=state-chip")
                        self.control_badge = ControlBadge(c.control)
                        self.grip_chip = ui.chip("Gripper —", icon="back_hand", color="blue-grey-8") \
                            .classes("pk-grip-chip").props("data-testid=grip-compact")
                        self.grip_chip.tooltip("SSG-48 gripper (details in the IO · Gripper tab)")
                        # while the status stream is recorded (the Record tab), whichever tab is open
                        self.rec_chip = ui.chip("REC", icon="fiber_manual_record", color="red-9") \
                            .classes("pk-rec-chip").props("data-testid=rec-chip")
                        self.rec_chip.tooltip("recording the robot (stop it in the Record tab)")
                        self.rec_chip.set_visibility(False)
                        self._rec_shown = ""
                    with ui.element("div").classes("pk-actions"):
                        self.controls = [_action("Home", "home", "btn-home", "unelevated dense color=primary",
                                lambda: c.command("HOME", "Home"), "home the robot"),
                        _action("Enable", "power_settings_new", "btn-enable", "unelevated dense color=positive",
                                lambda: c.command("ENABLE", "Enable"), "enable the motors (also ends an E-STOP latch)"),
                        _action("Disable", "power_off", "btn-disable", "unelevated dense color=warning",
                                lambda: c.command("DISABLE", "Disable"), "disable the motors"),
                        _action("Clear error", "healing", "btn-clear", "outline dense color=grey-4",
                                self.clear_error, "clear the board's error and the gripper's")]
                        # while the controller is paused (our program's Pause or another
                        # client's PAUSE): RESUME, which only the holder of the control lease may send
                        self.resume_btn = _action("Resume", "play_arrow", "btn-resume",
                                                  "unelevated dense color=positive", c.resume,
                                                  "the paused motion continues on its path (RESUME; "
                                                  "refused while another client controls the robot)")
                        self.resume_btn.set_visibility(False)
                        self._resume_shown = False
                        _action("Stop", "stop", "btn-stop", "outline dense color=orange",
                                c.stop, "stop motion and cancel the queue (Space)")
                        # icon buttons: a short label under the icon on a phone (.pk-short: no hover there)
                        with ui.button(icon="help_outline", on_click=on_help) \
                                .props('flat round color=grey-4 aria-label="Help: keyboard shortcuts" '
                                       'data-testid=help-button').tooltip("keyboard shortcuts"):
                            ui.label("Help").classes("pk-short")
                        if c.login:
                            with ui.button(icon="logout", on_click=lambda: ui.navigate.to("/logout")) \
                                    .props('flat round color=grey-4 aria-label="Log out" data-testid=btn-logout') \
                                    .tooltip("log out"):
                                ui.label("Log out").classes("pk-short")
                # E-STOP's place in the row; the button itself is in a layer of its own (below)
                ui.element("div").classes("pk-estop-slot").props("aria-hidden=true")
            # shown while there is no link to the controller: says so and offers a restart of
            # the controller this GUI started
            with ui.element("div").classes("pk-link-banner").props('role=alert data-testid=link-banner') \
                    as self.banner:
                ui.icon("link_off", size="22px")
                self.banner_text = ui.label("").props("data-testid=link-banner-text")
                self.restart_btn = ui.button("Restart controller", icon="restart_alt", on_click=c.restart_controller) \
                    .props('unelevated dense no-caps color=primary data-testid=link-restart')
                self.restart_btn.set_visibility(c.own_controller is not None)
            self.banner.set_visibility(False)
        # E-STOP sits in a layer of its own above every overlay (dialogs and their dimming
        # backdrop, menus, tooltips, notifications), over its slot in the header row: what the
        # user sees on top is what a click or a tap hits.  It acts on the press (commander.js
        # sends "pk_estop" on pointerdown, and on a click without a pointer: Enter, assistive
        # technology), before an open menu takes that press for closing itself.
        with ui.element("div").classes("pk-estop-layer"):
            self.estop_btn = ui.button("E-STOP", icon="dangerous") \
                .props('color=red-8 size=lg aria-label="E-STOP" data-testid=btn-estop') \
                .classes("pk-estop")
            self.estop_btn.tooltip("software emergency stop (Esc); latched until Enable")
        ui.on("pk_estop", lambda _: c.estop())
        self._banner_key: tuple[bool, str] | None = None

    def clear_error(self) -> None:
        """Clear error: the board's error (CLEAR_ERROR) and, when the gripper reports one, the
        gripper's (its error flag, set by an E-stop, stays until the gripper is told to clear it,
        as the IO · Gripper tab's Clear error does): once the cause is gone no error stays shown."""
        self.c.command("CLEAR_ERROR", "Clear error")
        st = self.c.link.status
        if st is not None and st.gripper.error:
            self.c.command("ELECTRICGRIPPER|clear_error", "Gripper clear error")

    def _update_banner(self, link_up: bool) -> None:
        own = self.c.own_controller
        if link_up:
            text = ""
        elif own is not None and own.restarting:
            text = "No link to the controller: restarting it ... controls are disabled."
        elif own is not None and not own.alive:
            text = (f"The controller has stopped (exit code {own.exit_code}): the robot is not controlled and "
                    "the controls are disabled. Restart it here.")
        elif own is not None:
            text = "No status from the controller for 1 s: the controls are disabled. Restart it if it hangs."
        else:
            text = ("No status from the controller for 1 s: the controls are disabled. Check the controller "
                    f"at {self.c.link.host}:{self.c.link.port} (restart it where it runs).")
        key = (link_up, text)
        if key == self._banner_key:
            return
        self._banner_key = key
        self.banner.set_visibility(not link_up)
        self.banner_text.set_text(text)
        for b in self.controls:
            b.set_enabled(link_up)
        if own is not None:
            self.restart_btn.set_enabled(not own.restarting)

    def _update_recording(self) -> None:
        rec = self.c.recording
        text = f"REC {int(rec.elapsed_s) // 60}:{int(rec.elapsed_s) % 60:02d}" if rec.active else ""
        if text != self._rec_shown:
            self.rec_chip.set_visibility(bool(text))
            self.rec_chip.set_text(text)
            self._rec_shown = text

    def update(self, st: RobotStatus | None, link_up: bool) -> None:
        """Show the link, the robot state (PROGRAM RUNNING / PAUSED from the program runner
        while a program runs), the E-STOP latch and the gripper (every 0.1 s; an element is
        sent to the page only when what it shows changed)."""
        self.control_badge.update()
        self._update_recording()
        self._update_banner(link_up)
        paused = link_up and st is not None and st.paused
        if paused != self._resume_shown:
            self._resume_shown = paused
            self.resume_btn.set_visibility(paused)
        runner = self.c.program
        program = runner.state if runner.active else ("running" if runner.finishing(st) else None)
        text, colour = state_badge(st, link_up, program)
        latched = st is not None and (st.estop_latched or st.estop_pressed)
        key = (link_up, text, colour, latched)
        if key != self._shown:
            self._shown = key
            self.link_chip.set_text("LINKED" if link_up else "NO LINK")
            self.link_chip.props(f"color={'positive' if link_up else 'grey-8'} "
                                 f"icon={'link' if link_up else 'link_off'}")
            self.state_chip.set_text(text)
            self.state_chip.props(f"color={colour}")
            if latched:
                self.estop_btn.classes(add="latched")
            else:
                self.estop_btn.classes(remove="latched")
            self.estop_btn.set_text("E-STOP LATCHED" if latched else "E-STOP")
            self.estop_btn.props(f'aria-label="{"E-STOP, latched" if latched else "E-STOP"}"')
        if st is None:
            return
        if st.board.simulated:
            self.mode_chip.set_text("SIMULATOR")
        elif st.board.port:
            self.mode_chip.set_text(f"REAL · {st.board.port}")
        self.grip_chip.set_text(gripper_summary(st.gripper))
