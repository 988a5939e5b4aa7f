"""The header's control badge and "Take control" button (NiceGUI); the logic is
:mod:`parolkit.gui.lease_watch`."""

from __future__ import annotations

from nicegui import ui

from parolkit.client.errors import RobotError
from parolkit.gui.lease_watch import ControlWatch

__all__ = ["ControlBadge"]


class ControlBadge:
    """Shows who controls the robot; offers a confirmed take-over when another client does."""

    def __init__(self, watch: ControlWatch) -> None:
        self.watch = watch
        self._version = -1
        self.chip = ui.chip("Control: …", icon="lock", color="grey-8").props("data-testid=control-chip")
        self.take_button = ui.button("Take control", icon="pan_tool", on_click=self.confirm_take) \
            .props("unelevated dense color=deep-orange-10 data-testid=btn-take-control").classes("px-2")
        self.take_button.tooltip("take control from the other client (its commands are cancelled)")
        self.take_button.set_visibility(False)
        self.update()

    def update(self) -> None:
        """Follow :attr:`ControlWatch.view` (cheap when nothing changed)."""
        if self.watch.version == self._version:
            return
        self._version = self.watch.version
        view = self.watch.view
        self.chip.set_text(view.text)
        self.chip.props(f"color={view.colour}")
        self.take_button.set_visibility(view.can_take)

    async def confirm_take(self) -> None:
        holder = self.watch.view.address or "another client"
        with ui.dialog().props('aria-label="Take control of the robot"') as dlg, ui.card().classes("pk-card"):
            ui.label("Take control of the robot?").classes("font-bold")
            ui.label(f"{holder} controls it now. Taking control cancels its running and queued "
                     "commands; it can take control back the same way.").classes("text-sm w-96")
            with ui.row():
                ui.button("Take control", on_click=lambda: dlg.submit(True)) \
                    .props("unelevated color=deep-orange-10 data-testid=confirm-take-control")
                ui.button("Cancel", on_click=lambda: dlg.submit(False)).props("flat")
        if await dlg:
            try:
                self.watch.take_over()
            except RobotError as exc:
                ui.notify(f"cannot take control: {exc}", type="negative")
