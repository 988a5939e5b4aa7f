"""The gamepad's indicator and the page's end of it (NiceGUI): what the page's pad is
(connected, deadman, joint / Cartesian mode and frame, driving) and the ``pk_gamepad``
events of ``gui/static/gamepad.js``, handed to the commander's one
:class:`~parolkit.gui.gamepad.GamepadDrive` with this page's mode, frame and jog speed.

The mapping, the deadman's rules and the stream are :mod:`parolkit.gui.gamepad`'s; this
module only routes.  A page's socket closing stops the arm it drives.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from nicegui import ui

from parolkit.gui.commander import Commander
from parolkit.gui.gamepad import GamepadInputError, PadControls, PadInput, indicator, page_settings

__all__ = ["GamepadIndicator", "INDICATOR_PERIOD_S"]

#: the indicator follows the drive this often, s
INDICATOR_PERIOD_S = 0.1

_TONES = {"idle": "pk-muted", "ready": "text-sky-300", "driving": "text-green-300", "problem": "text-amber-300"}


class GamepadIndicator:
    """One page's gamepad: the indicator (``data-testid=gamepad``) and its events."""

    def __init__(self, commander: Commander, speed_pct: Callable[[], float]) -> None:
        self.c = commander
        self.drive = commander.gamepad
        self.speed_pct = speed_pct
        client = ui.context.client
        self.key = str(client.id)
        self.controls = PadControls()
        self.pad = PadInput()
        self._bad_message = ""
        self._shown: tuple[object, ...] | None = None
        settings = json.dumps(page_settings()).replace("<", "\\u003c")
        ui.add_body_html(f'<script type="application/json" id="pk-gamepad">{settings}</script>')
        with ui.element("div").classes("flex items-center gap-2 text-xs") \
                .props('data-testid=gamepad role=status aria-live=polite') as self.element:
            ui.icon("sports_esports").props("aria-hidden=true")
            self.label = ui.label("No gamepad").props("data-testid=gamepad-text")
        ui.on("pk_gamepad", self.on_event)
        client.on_disconnect(lambda: self.drive.page_gone(self.key))
        ui.timer(INDICATOR_PERIOD_S, self.update)

    def on_event(self, e: Any) -> None:
        """A state of the page's pad from gamepad.js.  A message the server cannot take counts
        as no pad (the arm this page drives stops) and is logged once, with the field named."""
        try:
            pad = PadInput.from_event(e.args)
        except GamepadInputError as exc:
            if str(exc) != self._bad_message:
                self._bad_message = str(exc)
                self.c.log.error(str(exc))
            pad = PadInput()
        start = self.controls.feed(pad)
        self.pad = pad
        self.drive.feed(self.key, pad, start=start, mode=self.controls.mode, frame=self.controls.frame,
                        speed_pct=float(self.speed_pct()))
        self.update()

    def update(self) -> None:
        view = indicator(self.pad, self.controls, driving=self.drive.driving(self.key),
                         elsewhere=self.drive.owner not in (None, self.key), last_stop=self.drive.last_stop)
        shown = (view.text, view.tone, tuple(view.attributes().items()))
        if shown == self._shown:
            return
        self._shown = shown
        self.label.set_text(view.text)
        self.element.classes(remove=" ".join(_TONES.values()), add=_TONES[view.tone])
        self.element.props(" ".join(f"{k}={v}" for k, v in view.attributes().items()))
