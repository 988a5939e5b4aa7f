"""The keyboard-shortcuts dialog (NiceGUI), from :data:`parolkit.gui.jog.KEYMAP`."""

from __future__ import annotations

from nicegui import ui

from parolkit.gui.jog import KEYMAP, key_label

__all__ = ["HelpDialog"]


class HelpDialog:
    """The ``?`` dialog; Esc closes it (and does not latch E-STOP while it is open)."""

    def __init__(self) -> None:
        with ui.dialog().props('aria-label="Keyboard shortcuts"') as self.dialog, ui.card().classes("pk-card"):
            ui.label("Keyboard shortcuts").classes("text-lg font-bold")
            with ui.grid(columns=2).classes("gap-x-6 gap-y-1"):
                for b in KEYMAP:
                    ui.label(key_label(b.key)).classes("pk-mono text-amber-300")
                    ui.label(b.description).classes("text-slate-300")
            ui.label("Space stops and Esc latches E-STOP whatever has the focus; only while nothing moves "
                     "does Space type a space in a text field, and Esc only closes an open dialog or menu. "
                     "Jog keys are ignored while typing. Cartesian keys use the frame selected in the Jog "
                     "panel.") \
                .classes("text-xs text-slate-300").style("max-width: 24rem")
            ui.button("Close", on_click=self.dialog.close).props("flat no-caps data-testid=help-close")

    def open(self) -> None:
        self.dialog.open()
