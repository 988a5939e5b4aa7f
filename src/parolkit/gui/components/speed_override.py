"""The speed override (NiceGUI): one slider, 1..100 %, above the Jog / Program / ... tabs, so it
is beside the jog speed and the program's Run / Pause whichever tab is open.

It sets the controller's ``SPEED`` override: the running move slows down or speeds up on its
own path within the acceleration limits, and every later move runs at that share of its
planned speed until changed.  It is sent once, when the slider is let go (a drag's release, a
click on the track, a key's release), never while it is dragged.  Between changes the slider
shows the controller's override from the status stream, so a change made by another client
(a script's ``set_speed``, a program's ``Speed()``) shows here; it never moves under a pointer
that drags it, nor while a change of ours waits for the controller's answer.

``SPEED`` needs the control lease, like every motion command: the commander sends it through
its link (taking a free lease) or, while one of its programs runs, through the program
runner's client (:meth:`parolkit.gui.commander.Commander.set_speed`).  While another client
controls the robot a change is refused with the controller's reason in the log, the slider
goes back to the controller's value and the line under it says so.
"""

from __future__ import annotations

import time
from typing import Any

from nicegui import ui

from parolkit.client.core import RobotStatus
from parolkit.gui.commander import Commander
from parolkit.gui.lease_watch import Holder

__all__ = ["SpeedOverride", "RESYNC_S"]

#: after the user's last touch of the slider, a value the controller does not have is replaced
#: by the controller's after this long, s (a release whose event never arrived)
RESYNC_S = 1.0

_NOTE = "The running move and every later one at this share of their planned speed (SPEED)."


class SpeedOverride:
    """The slider, its value and a note; :meth:`update` every 0.1 s with the newest status."""

    def __init__(self, commander: Commander) -> None:
        self.c = commander
        #: the controller's override last put on the slider (None: none yet)
        self._shown_ctrl: float | None = None
        self._dragging = False
        #: a change of ours waits for the controller's answer
        self._pending = False
        self._touched = 0.0
        self._setting = False
        self._online: bool | None = None
        self._note_shown = ""
        with ui.element("div").classes("pk-card pk-override-card w-full") \
                .props('role=region aria-label="Speed override" data-testid=override'):
            with ui.element("div").classes("pk-override"):
                ui.label("Speed override").classes("pk-title")
                self.slider = ui.slider(min=1, max=100, step=1, value=100, on_change=self._on_value) \
                    .props('data-testid=override-slider aria-label="speed override, percent"')
                self.value_label = ui.label().classes("pk-val pk-num text-sm") \
                    .bind_text_from(self.slider, "value", lambda v: f"{v:.0f} %" if v is not None else "—") \
                    .props("data-testid=override-value")
            self.note = ui.label(_NOTE).classes("text-xs pk-muted").props("data-testid=override-note")
        self.slider.on("pan", self._on_pan)
        self.slider.on("change", self._on_release)

    # ---- the user's hand ----

    def _on_value(self, _: Any) -> None:
        if not self._setting:  # moved in the page (not set from the controller's status)
            self._touched = time.monotonic()

    def _on_pan(self, e: Any) -> None:
        self._dragging = e.args == "start"
        self._touched = time.monotonic()

    async def _on_release(self, e: Any) -> None:
        """Let go (Quasar's ``change``: after a drag, a click on the track or a key): send
        the new override once and wait for the controller's answer; refused, the slider goes
        back to the controller's value."""
        self._dragging = False
        self._touched = time.monotonic()
        value = e.args if isinstance(e.args, (int, float)) and not isinstance(e.args, bool) else self.slider.value
        if value is None:
            return
        pct = float(min(100, max(1, round(float(value)))))
        st = self.c.link.status
        if st is not None and st.speed_pct == pct:
            return  # the controller has it already
        self._pending = True
        try:
            ok = await self.c.set_speed(pct)
        finally:
            self._pending = False
            self._touched = time.monotonic()
        if not ok:
            self._show_controller(force=True)

    # ---- following the controller ----

    def _set(self, value: float) -> None:
        self._setting = True
        try:
            self.slider.value = value
        finally:
            self._setting = False

    def _show_controller(self, *, force: bool = False) -> None:
        """Put the controller's override on the slider when it changed (another client, a
        program's Speed()), or when the slider shows a value the controller does not have
        and nobody has touched it for :data:`RESYNC_S` (``force``: at once)."""
        st = self.c.link.status
        if st is None or self._dragging or (self._pending and not force):
            return
        ctrl = float(st.speed_pct)
        changed = ctrl != self._shown_ctrl
        stale = self.slider.value != ctrl and (force or time.monotonic() - self._touched > RESYNC_S)
        if changed or stale:
            self._shown_ctrl = ctrl
            if self.slider.value != ctrl:
                self._set(ctrl)

    def _note_text(self) -> str:
        view = self.c.control.view
        if view.holder is Holder.OTHER:
            return (f"Controlled by {view.address}: a change is refused until you take control "
                    "(header).")
        return _NOTE

    def update(self, st: RobotStatus | None, link_up: bool) -> None:
        """Follow the link (the slider greyed without one), the controller's override and who
        controls the robot."""
        if link_up != self._online:
            self._online = link_up
            self.slider.set_enabled(link_up)
        if st is not None and link_up:
            self._show_controller()
        note = self._note_text()
        if note != self._note_shown:
            self._note_shown = note
            self.note.set_text(note)
