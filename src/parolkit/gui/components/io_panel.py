"""The IO · Gripper tab (NiceGUI): OUT1 / OUT2 and the SSG-48 electric gripper (calibrate,
clear error, move to a position with a speed and a current) with its full readout in words.

Units: gripper position and speed 0..255, current in mA (0..1300).  The compact gripper
readout that stays visible while a program runs is in the header
(:mod:`parolkit.gui.components.header`).

Each output's HIGH / LOW pair shows the output's state from the status: the button of the
state it is in is filled (``aria-pressed=true``), the other outlined, and the line beside says
"is HIGH" / "is LOW" (before the first status both are outlined and it says "—").  Each gripper
slider has its name and value above it, in one group with it.
"""

from __future__ import annotations

from nicegui import ui

from parolkit.client.core import RobotStatus
from parolkit.gui.commander import Commander
from parolkit.gui.status import format_gripper

__all__ = ["IoGripperPanel", "output_look"]

#: how an output's button looks: (Quasar props, ``aria-pressed``) for the state it shows
_FILLED = {"HIGH": "unelevated color=positive", "LOW": "unelevated color=grey-7"}
_OUTLINED = "outline color=grey-4"


def output_look(level: str, high: bool | None) -> tuple[str, str]:
    """The props and ``aria-pressed`` of output button ``level`` ("HIGH" / "LOW") while the
    output is ``high`` (None: not known yet): filled when it is the output's state."""
    if level not in _FILLED:
        raise ValueError(f"level must be HIGH or LOW, got {level!r}")
    pressed = high is not None and high == (level == "HIGH")
    return (_FILLED[level] if pressed else _OUTLINED), ("true" if pressed else "false")


class IoGripperPanel:
    """Outputs and gripper controls; :meth:`update` shows the outputs' and the gripper's status."""

    def __init__(self, commander: Commander) -> None:
        c = self.c = commander
        self._online: bool | None = None
        #: per output (1, 2): its HIGH and LOW buttons, its state line, the state shown
        self._out_buttons: dict[int, dict[str, ui.button]] = {}
        self._out_state: dict[int, ui.label] = {}
        self._out_shown: dict[int, bool | None] = {1: None, 2: None}
        with ui.element("div").classes("pk-wrap") as root:
            with ui.column().classes("gap-2"):
                ui.label("Outputs").classes("pk-title")
                for n in (1, 2):
                    self._output_row(n)
                ui.label("Pneumatic gripper on OUT1/OUT2: HIGH = open (output on), LOW = close, as the original. "
                         "The filled button is the output's state.").classes("text-xs pk-muted w-56")
            with ui.column().classes("gap-2 pk-grow"):
                ui.label("SSG-48 electric gripper").classes("pk-title")
                with ui.row().classes("gap-2"):
                    ui.button("Calibrate", icon="tune",
                              on_click=lambda: c.command("ELECTRICGRIPPER|calibrate", "Gripper calibrate")) \
                        .props("unelevated color=primary data-testid=grip-cal")
                    ui.button("Clear error", icon="healing",
                              on_click=lambda: c.command("ELECTRICGRIPPER|clear_error", "Gripper clear error")) \
                        .props('outline color=grey-4 aria-label="Clear error of the gripper" data-testid=grip-clear')
                self.grip_pos = self._slider("position", "", 0, 255, 1, 100,
                                             'aria-label="gripper position, 0 to 255" data-testid=grip-pos')
                self.grip_speed = self._slider("speed", "", 0, 255, 1, 60,
                                               'aria-label="gripper speed, 0 to 255" data-testid=grip-speed')
                self.grip_current = self._slider("current", " mA", 0, 1300, 10, 600,
                                                 'aria-label="gripper current, mA" data-testid=grip-current')
                ui.button("Move", icon="play_arrow", on_click=self.gripper_move) \
                    .props('unelevated color=primary aria-label="Move gripper" data-testid=grip-move')
                self.grip_readout = ui.label("—").classes("pk-val text-sm").style("white-space: normal") \
                    .props("data-testid=grip-readout")
        self.controls = [e for e in root.descendants() if isinstance(e, (ui.button, ui.slider))]

    def _output_row(self, n: int) -> None:
        """OUT``n``: its name, HIGH and LOW, and the state it is in."""
        with ui.row().classes("items-center gap-2"):
            ui.label(f"OUT{n}").classes("w-12 text-slate-300")
            buttons: dict[str, ui.button] = {}
            for level, action in (("HIGH", "open"), ("LOW", "close")):
                props, pressed = output_look(level, None)
                buttons[level] = ui.button(
                    level, on_click=lambda n=n, level=level, action=action:
                    self.c.command(f"PNEUMATICGRIPPER|{action}|{n}", f"OUT{n} {level}")) \
                    .props(f'{props} dense aria-pressed={pressed} aria-label="OUT{n} {level.lower()}" '
                           f'data-testid=out{n}-{level.lower()}')
            self._out_buttons[n] = buttons
            self._out_state[n] = ui.label("—").classes("pk-val text-sm").props(f"data-testid=out{n}-state")

    @staticmethod
    def _slider(name: str, unit: str, lo: int, hi: int, step: int, value: int, props: str) -> ui.slider:
        """A gripper slider with its name and value above it (one group)."""
        with ui.column().classes("gap-0 w-full pk-slider-group"):
            caption = ui.label().classes("text-xs pk-muted").props(f"data-testid=grip-{name}-label")
            slider = ui.slider(min=lo, max=hi, step=step, value=value).props(f"label {props}")
            caption.bind_text_from(slider, "value", lambda v: f"{name} {v}{unit}")
        return slider

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

    def _show_output(self, n: int, high: bool | None) -> None:
        if self._out_shown[n] == high:
            return
        self._out_shown[n] = high
        for level, button in self._out_buttons[n].items():
            props, pressed = output_look(level, high)
            button.props(remove="outline unelevated color").props(f"{props} aria-pressed={pressed}")
        self._out_state[n].set_text("—" if high is None else f"is {'HIGH' if high else 'LOW'}")

    def update(self, st: RobotStatus) -> None:
        self._show_output(1, bool(st.io.out1))
        self._show_output(2, bool(st.io.out2))
        self.grip_readout.set_text(format_gripper(st.gripper))
