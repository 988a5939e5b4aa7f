"""The Jog tab (NiceGUI): continuous (press and hold) or step jogging of the joints and of
the TCP in WRF / TRF, with speed, acceleration and step sizes.

Units: joint steps in deg, Cartesian steps in mm / deg, speed and acceleration in %.  A jog
button starts on ``pointerdown`` (mouse, pen and touch alike: one start per press; a touch
does not also start it again through the browser's emulated mouse events) and ends on
``pointerup`` / ``pointerleave`` / ``pointercancel``, a release anywhere on the page, a key
release or the window losing focus.  Every button is named for assistive technology
(``aria-label`` "J1 minus" ... "RZ plus").
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

from nicegui import ui

from parolkit.client.core import RobotStatus
from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.gui.commander import Commander
from parolkit.gui.components.gamepad_indicator import GamepadIndicator
from parolkit.gui.eventlog import Level
from parolkit.gui.jog import (
    JOG_DURATION_S,
    cart_jog_blocked,
    cart_step_command,
    jog_command,
    joint_jog_blocked,
    joint_step_target,
)
from parolkit.moves import CartAxis, CartJog, Frame, JointJog
from parolkit.robot import JOINT_NAMES

__all__ = ["JogPanel"]

_SIGN_WORD = {"-": "minus", "+": "plus"}


class JogPanel:
    """Jog settings and buttons; :meth:`joint_press` / :meth:`cart_press` also serve the keys."""

    def __init__(self, commander: Commander) -> None:
        self.c = commander
        self.link = commander.link
        self.frame = Frame.WRF
        self.step_mode = False
        self.speed = 40.0
        self.accel = 50.0
        self.step_deg = 5.0
        self.step_mm = 10.0
        self._cart_key: tuple[tuple[float, ...], Frame, bool, str] | None = None
        self._held_button: ui.button | None = None
        self.joint_buttons: dict[tuple[int, int], ui.button] = {}
        self.cart_buttons: dict[CartAxis, ui.button] = {}
        self._build()

    def _build(self) -> None:
        with ui.element("div").classes("pk-wrap items-center"):
            ui.toggle({False: "Continuous", True: "Step"}, value=False,
                      on_change=lambda e: setattr(self, "step_mode", e.value)) \
                .props('no-caps data-testid=jog-mode aria-label="jog mode"')
            with ui.column().classes("gap-0 pk-grow"):
                ui.label().bind_text_from(self, "speed", lambda v: f"Speed {v:.0f} %").classes("text-xs pk-muted")
                ui.slider(min=1, max=100, step=1).bind_value(self, "speed") \
                    .props('data-testid=speed-slider aria-label="jog speed, percent"')
            with ui.column().classes("gap-0 pk-grow"):
                ui.label().bind_text_from(self, "accel", lambda v: f"Acceleration {v:.0f} %") \
                    .classes("text-xs pk-muted")
                ui.slider(min=1, max=100, step=1).bind_value(self, "accel") \
                    .props('data-testid=accel-slider aria-label="jog acceleration, percent"')
        with ui.row().classes("items-center gap-3"):
            ui.number("step °", value=self.step_deg, min=0.1, max=45, step=0.5, format="%.1f") \
                .bind_value(self, "step_deg").classes("w-24").props("data-testid=step-deg")
            ui.number("step mm", value=self.step_mm, min=0.1, max=100, step=1, format="%.1f") \
                .bind_value(self, "step_mm").classes("w-24").props("data-testid=step-mm")
        with ui.element("div").classes("pk-wrap pk-jog"):
            with ui.column().classes("gap-1"):
                ui.label("Joint jog").classes("pk-title")
                with ui.element("div").classes("pk-jog-grid"):
                    for j in range(6):
                        ui.label(JOINT_NAMES[j]).classes("text-slate-300")
                        for d, sign in ((-1, "-"), (1, "+")):
                            name = f"{JOINT_NAMES[j]} {_SIGN_WORD[sign]}"
                            b = ui.button(icon="remove" if d < 0 else "add") \
                                .props(f'unelevated color=blue-grey-8 aria-label="{name}" '
                                       f'data-testid=jog-j{j + 1}{sign}')
                            b.tooltip(f"jog {name}")
                            self._hold_button(b, partial(self.joint_press, j, d))
                            self.joint_buttons[(j, d)] = b
            with ui.column().classes("gap-1"):
                with ui.row().classes("items-center gap-2"):
                    ui.label("Cartesian jog").classes("pk-title")
                    ui.toggle({Frame.WRF: "WRF", Frame.TRF: "TRF"}, value=Frame.WRF,
                              on_change=lambda e: setattr(self, "frame", e.value)) \
                        .props('dense data-testid=frame-toggle aria-label="Cartesian frame"')
                with ui.element("div").classes("pk-jog-grid"):
                    for axis_name in ("X", "Y", "Z", "RX", "RY", "RZ"):
                        ui.label(axis_name).classes("text-slate-300")
                        for sign in ("-", "+"):
                            axis = CartAxis(axis_name + sign)
                            name = f"{axis_name} {_SIGN_WORD[sign]}"
                            b = ui.button(icon="remove" if sign == "-" else "add") \
                                .props(f'unelevated color=indigo-8 aria-label="{name}" '
                                       f'data-testid=jog-{axis_name.lower()}{sign}')
                            b.tooltip(f"jog {name}")
                            self._hold_button(b, partial(self.cart_press, axis))
                            self.cart_buttons[axis] = b
        ui.label("Hold a button (or its key, see ?) to jog; release stops. Step mode moves one increment per click.") \
            .classes("text-xs pk-muted")
        # the gamepad's indicator; its jog speed is this panel's slider
        self.gamepad = GamepadIndicator(self.c, lambda: float(self.speed))

    def _hold_button(self, button: ui.button, press: Callable[[], None]) -> None:
        def down(e: Any) -> None:
            args = e.args if isinstance(e.args, dict) else {}
            if args.get("button", 0) != 0:  # a right or middle mouse button does not jog
                return
            self._held_button = button
            press()
            if self.c.jogging:
                button.classes(add="pk-held")

        # pointer events: one start per press whatever the pointer (a touch used to start a
        # jog twice: touchstart, then the browser's emulated mousedown)
        button.on("pointerdown", down, ["button", "pointerType"])
        for ev in ("pointerup", "pointerleave", "pointercancel"):
            button.on(ev, lambda _: self.release(), [])

    def release(self) -> None:
        """End a held jog (button, key, blur) and drop the held-button highlight."""
        self.c.jog_release()
        if self._held_button is not None:
            self._held_button.classes(remove="pk-held")
            self._held_button = None

    # ---- presses ----

    def joint_press(self, joint: int, direction: int) -> None:
        st = self.link.status
        if st is None:
            self.c.log.error("no robot status yet: cannot jog")
            return
        if joint_jog_blocked(st.angles, joint, direction):
            self.c.log.add(f"{JOINT_NAMES[joint]} is at its {'upper' if direction > 0 else 'lower'} limit",
                           Level.WARNING)
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

    # ---- enables ----

    def offline(self) -> None:
        """No link to the controller: every jog button greyed (until the next status)."""
        self.release()
        self._cart_key = None
        for b in (*self.joint_buttons.values(), *self.cart_buttons.values()):
            b.set_enabled(False)

    def update(self, st: RobotStatus) -> None:
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
