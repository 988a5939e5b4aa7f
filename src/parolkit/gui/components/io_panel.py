"""The IO · Gripper tab (NiceGUI): OUT1 / OUT2 and the SSG-48 electric gripper (calibrate,
clear error, move to a position with a speed and a current) with its full readout in words.

Units: gripper position and speed 0..255, current in mA (0..1300).  The compact gripper
readout that stays visible while a program runs is in the header
(:mod:`parolkit.gui.components.header`).
"""

from __future__ import annotations

from nicegui import ui

from parolkit.client.core import RobotStatus
from parolkit.gui.commander import Commander
from parolkit.gui.status import format_gripper

__all__ = ["IoGripperPanel"]


class IoGripperPanel:
    """Outputs and gripper controls; :meth:`update` shows the gripper's status."""

    def __init__(self, commander: Commander) -> None:
        c = self.c = commander
        self._online: bool | None = None
        with ui.element("div").classes("pk-wrap") as root:
            with ui.column().classes("gap-2"):
                ui.label("Outputs").classes("pk-title")
                for n in (1, 2):
                    with ui.row().classes("items-center gap-2"):
                        ui.label(f"OUT{n}").classes("w-12 text-slate-300")
                        ui.button("HIGH",
                                  on_click=lambda n=n: c.command(f"PNEUMATICGRIPPER|open|{n}", f"OUT{n} HIGH")) \
                            .props(f'unelevated color=positive dense aria-label="OUT{n} high" data-testid=out{n}-high')
                        ui.button("LOW",
                                  on_click=lambda n=n: c.command(f"PNEUMATICGRIPPER|close|{n}", f"OUT{n} LOW")) \
                            .props(f'outline color=grey-4 dense aria-label="OUT{n} low" data-testid=out{n}-low')
                ui.label("Pneumatic gripper on OUT1/OUT2: HIGH = open (output on), LOW = close, as the original.") \
                    .classes("text-xs pk-muted w-56")
            with ui.column().classes("gap-2 pk-grow"):
                ui.label("SSG-48 electric gripper").classes("pk-title")
                with ui.row().classes("gap-2"):
                    ui.button("Calibrate", icon="tune",
                              on_click=lambda: c.command("ELECTRICGRIPPER|calibrate", "Gripper calibrate")) \
                        .props("unelevated color=primary data-testid=grip-cal")
                    ui.button("Clear error", icon="healing",
                              on_click=lambda: c.command("ELECTRICGRIPPER|clear_error", "Gripper clear error")) \
                        .props('outline color=grey-4 aria-label="Clear error of the gripper" data-testid=grip-clear')
                self.grip_pos = ui.slider(min=0, max=255, value=100) \
                    .props('label aria-label="gripper position, 0 to 255" data-testid=grip-pos')
                ui.label().bind_text_from(self.grip_pos, "value", lambda v: f"position {v}").classes("text-xs pk-muted")
                self.grip_speed = ui.slider(min=0, max=255, value=60) \
                    .props('label aria-label="gripper speed, 0 to 255" data-testid=grip-speed')
                ui.label().bind_text_from(self.grip_speed, "value", lambda v: f"speed {v}").classes("text-xs pk-muted")
                self.grip_current = ui.slider(min=0, max=1300, step=10, value=600) \
                    .props('label aria-label="gripper current, mA" data-testid=grip-current')
                ui.label().bind_text_from(self.grip_current, "value", lambda v: f"current {v} mA") \
                    .classes("text-xs pk-muted")
                ui.button("Move", icon="play_arrow", on_click=self.gripper_move) \
                    .props('unelevated color=primary aria-label="Move gripper" data-testid=grip-move')
                self.grip_readout = ui.label("—").classes("pk-val text-sm").style("white-space: normal") \
                    .props("data-testid=grip-readout")
        self.controls = [e for e in root.descendants() if isinstance(e, (ui.button, ui.slider))]

    def set_online(self, online: bool) -> None:
        """Grey the outputs and gripper controls while there is no link to the controller."""
        if online == self._online:
            return
        self._online = online
        for e in self.controls:
            e.set_enabled(online)

    def gripper_move(self) -> None:
        p, s, cur = int(self.grip_pos.value), int(self.grip_speed.value), int(self.grip_current.value)
        self.c.command(f"ELECTRICGRIPPER|move|{p}|{s}|{cur}", f"Gripper move {p}/{s}/{cur} mA")

    def update(self, st: RobotStatus) -> None:
        self.grip_readout.set_text(format_gripper(st.gripper))
