"""The Jog tab (NiceGUI): continuous (press and hold) or step jogging of the joints and of
the TCP in WRF / TRF, with speed, acceleration and step sizes; each joint's angle and each
TCP coordinate beside its buttons.

Units: joint steps in deg, Cartesian steps in mm / deg, speed and acceleration in %.  A jog
button is pressed on ``pointerdown`` (mouse, pen and touch alike: one press; a touch does not
also press it again through the browser's emulated mouse events).  In step mode the press moves
one step.  In continuous mode the page times the press (commander.js): released within
:data:`TAP_MAX_S` it is a tap and moves one step (event ``pk_jog`` "tap"); held longer it jogs
(``pk_jog`` "hold") until ``pointerup`` / ``pointerleave`` / ``pointercancel``, a release
anywhere on the page, a key release or the window losing focus.  Enter on a focused jog button
moves one step.  Every button is named for assistive technology (``aria-label`` "J1 minus" ...
"RZ plus").
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

from nicegui import ui

from parolkit.client.core import RobotStatus
from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.gui.commander import Commander
from parolkit.gui.components.gamepad_indicator import GamepadIndicator
from parolkit.gui.components.telemetry import HOMING_TEXT
from parolkit.gui.eventlog import Level
from parolkit.gui.jog import (
    JOG_DURATION_S,
    cart_jog_blocked,
    cart_step_command,
    jog_command,
    jog_target_pose,
    joint_jog_blocked,
    joint_step_target,
)
from parolkit.gui.link import joints_known
from parolkit.gui.status import format_angles, format_pose
from parolkit.moves import CartAxis, CartJog, Frame, JointJog
from parolkit.robot import JOINT_NAMES

__all__ = ["JogPanel", "TAP_MAX_S"]

_SIGN_WORD = {"-": "minus", "+": "plus"}
#: a press of a jog button in continuous mode released sooner than this (s) is a tap: one step;
#: held longer it jogs until released (the page times it: ``data-tap-ms`` of ``.pk-jog``)
TAP_MAX_S = 0.25
#: a late tap (see :meth:`JogPanel.on_page_press`) waits this long (s) for the arm to stop
LATE_TAP_WAIT_S = 3.0


@dataclass(frozen=True)
class _Press:
    """A continuous-mode press of a jog button: its test id, the jog it starts when held, the
    step a tap moves (from a status; None: the newest) and the status when it was pressed."""

    testid: str
    jog: Callable[[], None]
    step: Callable[[RobotStatus | None], None]
    status: RobotStatus | None


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
        #: a continuous-mode press the page is timing, and the one it said is held (a jog)
        self._pending: _Press | None = None
        self._holding: _Press | None = None
        self._tasks: set[asyncio.Future[None]] = set()
        self.joint_buttons: dict[tuple[int, int], ui.button] = {}
        self.cart_buttons: dict[CartAxis, ui.button] = {}
        self._build()
        ui.on("pk_jog", self.on_page_press)  # the page's word on a press: held, or a tap

    def _build(self) -> None:
        # two compact rows (a 1024x768 projector shows the view and the buttons together):
        # mode and step sizes, then speed and acceleration
        with ui.element("div").classes("pk-jog-settings"):
            ui.toggle({False: "Continuous", True: "Step"}, value=False,
                      on_change=lambda e: setattr(self, "step_mode", e.value)) \
                .props('no-caps data-testid=jog-mode aria-label="jog mode"')
            ui.number("step °", value=self.step_deg, min=0.1, max=45, step=0.5, format="%.1f") \
                .bind_value(self, "step_deg").props("dense data-testid=step-deg")
            ui.number("step mm", value=self.step_mm, min=0.1, max=100, step=1, format="%.1f") \
                .bind_value(self, "step_mm").props("dense data-testid=step-mm")
        with ui.element("div").classes("pk-jog-settings"):
            with ui.column().classes("gap-0 pk-grow"):
                ui.label().bind_text_from(self, "speed", lambda v: f"Speed {v:.0f} %").classes("text-xs pk-muted")
                ui.slider(min=1, max=100, step=1).bind_value(self, "speed") \
                    .props('data-testid=speed-slider aria-label="jog speed, percent"')
            with ui.column().classes("gap-0 pk-grow"):
                ui.label().bind_text_from(self, "accel", lambda v: f"Acceleration {v:.0f} %") \
                    .classes("text-xs pk-muted")
                ui.slider(min=1, max=100, step=1).bind_value(self, "accel") \
                    .props('data-testid=accel-slider aria-label="jog acceleration, percent"')
        self.joint_values: list[ui.label] = []
        self.cart_values: list[ui.label] = []
        with ui.element("div").classes("pk-wrap pk-jog").props(f"data-tap-ms={round(TAP_MAX_S * 1000)}"):
            with ui.column().classes("gap-1"):
                ui.label("Joint jog").classes("pk-title pk-jog-head")
                with ui.element("div").classes("pk-jog-grid"):
                    for j in range(6):
                        ui.label(JOINT_NAMES[j]).classes("text-slate-300")
                        # the joint's angle beside its buttons (a phone shows no other readout there)
                        self.joint_values.append(ui.label("—").classes("pk-val pk-num pk-jog-val")
                                                 .props(f"data-testid=jog-angle-{j + 1}"))
                        for d, sign in ((-1, "-"), (1, "+")):
                            name = f"{JOINT_NAMES[j]} {_SIGN_WORD[sign]}"
                            b = ui.button(icon="remove" if d < 0 else "add") \
                                .props(f'unelevated color=blue-grey-8 aria-label="{name}" '
                                       f'data-testid=jog-j{j + 1}{sign}')
                            b.tooltip(f"jog {name}")
                            self._hold_button(b, partial(self.joint_press, j, d), partial(self.joint_step, j, d))
                            self.joint_buttons[(j, d)] = b
            with ui.column().classes("gap-1"):
                with ui.row().classes("items-center gap-2 pk-jog-head"):
                    ui.label("Cartesian jog").classes("pk-title")
                    ui.toggle({Frame.WRF: "WRF", Frame.TRF: "TRF"}, value=Frame.WRF,
                              on_change=lambda e: setattr(self, "frame", e.value)) \
                        .props('dense data-testid=frame-toggle aria-label="Cartesian frame"')
                with ui.element("div").classes("pk-jog-grid"):
                    for axis_name in ("X", "Y", "Z", "RX", "RY", "RZ"):
                        ui.label(axis_name).classes("text-slate-300")
                        # the TCP's coordinate beside its buttons (the readouts' X Y Z RX RY RZ)
                        self.cart_values.append(ui.label("—").classes("pk-val pk-num pk-jog-val")
                                                .props(f"data-testid=jog-pose-{axis_name.lower()}"))
                        for sign in ("-", "+"):
                            axis = CartAxis(axis_name + sign)
                            name = f"{axis_name} {_SIGN_WORD[sign]}"
                            b = ui.button(icon="remove" if sign == "-" else "add") \
                                .props(f'unelevated color=indigo-8 aria-label="{name}" '
                                       f'data-testid=jog-{axis_name.lower()}{sign}')
                            b.tooltip(f"jog {name}")
                            self._hold_button(b, partial(self.cart_press, axis), partial(self.cart_step, axis))
                            self.cart_buttons[axis] = b
        ui.label("Hold a button (or its key, see ?) to jog; release stops. A tap, or Enter on a button, moves "
                 "one step; in Step mode every press does.").classes("text-xs pk-muted")
        # the gamepad's indicator; its jog speed is this panel's slider
        self.gamepad = GamepadIndicator(self.c, lambda: float(self.speed))

    def _hold_button(self, button: ui.button, jog: Callable[[], None],
                     step: Callable[[RobotStatus | None], None]) -> None:
        """Wire a jog button: ``jog`` jogs (continuous mode: once the page says it is held),
        ``step(status)`` moves one step (step mode, a tap, Enter; from ``status``, None: the
        newest)."""
        testid = str(button.props.get("data-testid", ""))

        def down(e: Any) -> None:
            args = e.args if isinstance(e.args, dict) else {}
            if args.get("button", 0) != 0:  # a right or middle mouse button does not jog
                return
            self._held_button = button
            if self.step_mode:
                step(None)
                return
            # the page says whether this press is a tap or held (pk_jog); nothing moves before
            self._pending = _Press(testid, jog, step, self.link.status)
            self._holding = None
            button.classes(add="pk-held")

        def keyboard_click(e: Any) -> None:
            args = e.args if isinstance(e.args, dict) else {}
            if args.get("detail", 1) == 0:  # Enter on the focused button (a pointer's click has detail >= 1)
                step(None)

        # pointer events: one press whatever the pointer (a touch used to start a jog twice:
        # touchstart, then the browser's emulated mousedown)
        button.on("pointerdown", down, ["button", "pointerType"])
        button.on("click", keyboard_click, ["detail"])
        for ev in ("pointerup", "pointerleave", "pointercancel"):
            button.on(ev, lambda _: self.release(), [])

    def on_page_press(self, e: Any) -> None:
        """``pk_jog`` from the page about the press it times: ``{action: "hold" | "tap", id}``
        (the button's test id).  Held: the jog starts.  A tap: one step; a tap after "hold"
        (the page judges by the input's own times, and a busy page ran its hold timer before it
        saw the release) stops that jog and, once the arm is at rest, moves one step from where
        the press began.  Only the press this panel is waiting on counts (a message after a
        release moves nothing)."""
        args = e.args if isinstance(e.args, dict) else {}
        action, testid = args.get("action"), args.get("id")
        pending, holding = self._pending, self._holding
        if action == "hold" and pending is not None and pending.testid == testid:
            self._pending, self._holding = None, pending
            pending.jog()
        elif action == "tap" and pending is not None and pending.testid == testid:
            self._pending = None
            pending.step(None)
        elif action == "tap" and holding is not None and holding.testid == testid:
            self._holding = None
            self.c.jog_release()
            self._tasks.add(asyncio.ensure_future(self._step_at_rest(holding)))

    async def _step_at_rest(self, press: _Press) -> None:
        """A late tap's step: once the jog it started has stopped, one step from where the
        press began (nothing if the arm does not come to rest within :data:`LATE_TAP_WAIT_S`)."""
        deadline = time.monotonic() + LATE_TAP_WAIT_S
        try:
            while time.monotonic() < deadline:
                if self.link.link_up and not self.c.moving:
                    press.step(press.status)
                    return
                await asyncio.sleep(0.02)
            self.c.log.error(f"tap on {press.testid}: the arm did not come to rest; no step sent")
        finally:
            self._tasks = {t for t in self._tasks if not t.done()}

    def release(self) -> None:
        """End a held jog (button, key, blur) and drop the held-button highlight."""
        self._pending = self._holding = None
        self.c.jog_release()
        if self._held_button is not None:
            self._held_button.classes(remove="pk-held")
            self._held_button = None

    # ---- presses ----

    def _status(self, st: RobotStatus | None) -> RobotStatus | None:
        st = st if st is not None else self.link.status
        if st is None:
            self.c.log.error("no robot status yet: cannot jog")
        return st

    def joint_press(self, joint: int, direction: int, *, step: bool | None = None) -> None:
        """Jog joint ``joint`` (0..5) in ``direction`` (+1 / -1): one step with ``step`` (None:
        the panel's mode), else a continuous jog until released."""
        if self.step_mode if step is None else step:
            self.joint_step(joint, direction)
            return
        st = self._status(None)
        if st is None:
            return
        if joint_jog_blocked(st.angles, joint, direction):
            self.c.log.add(f"{JOINT_NAMES[joint]} is at its {'upper' if direction > 0 else 'lower'} limit",
                           Level.WARNING)
            return
        jog = JointJog.single(joint, direction, float(self.speed), duration_s=JOG_DURATION_S)
        self.c.log.info(f"jog {JOINT_NAMES[joint]}{'+' if direction > 0 else '−'} at {self.speed:g} %")
        self.c.jog_press(lambda: jog_command(jog))

    def joint_step(self, joint: int, direction: int, from_status: RobotStatus | None = None) -> None:
        """One step of joint ``joint`` in ``direction`` from ``from_status``'s angles (None:
        the newest status)."""
        st = self._status(from_status)
        if st is None:
            return
        if joint_jog_blocked(st.angles, joint, direction):
            self.c.log.add(f"{JOINT_NAMES[joint]} is at its {'upper' if direction > 0 else 'lower'} limit",
                           Level.WARNING)
            return
        try:
            target = joint_step_target(st.angles, joint, direction * float(self.step_deg))
        except ParolkitValueError as exc:
            self.c.log.error(str(exc))
            return
        self.c.command("MOVEJOINT|" + "|".join(f"{v:.4f}" for v in target) + f"|None|{self.speed:g}|{self.accel:g}",
                       f"step {JOINT_NAMES[joint]} {direction * float(self.step_deg):+g}°")

    def cart_press(self, axis: CartAxis, *, step: bool | None = None) -> None:
        """Jog the TCP along / about ``axis`` in the panel's frame: one step with ``step``
        (None: the panel's mode), else a continuous jog until released."""
        if self.step_mode if step is None else step:
            self.cart_step(axis)
            return
        if self._status(None) is None:
            return
        period = self.c.cart_jog_repeat_s
        cart_jog = CartJog(self.frame, axis, float(self.speed), max(JOG_DURATION_S, 3 * period))
        self.c.log.info(f"jog {self.frame.value} {axis.value} at {self.speed:g} %")
        self.c.jog_press(lambda: jog_command(cart_jog), period)

    def cart_step(self, axis: CartAxis, from_status: RobotStatus | None = None) -> None:
        """One step of the TCP along / about ``axis`` in the panel's frame.  From the newest
        status: ``cart_step_command`` (TRF as a relative move); from an earlier ``from_status``
        (a late tap): a MOVECART to the pose one step from that status's pose, in either frame."""
        st = self._status(from_status)
        if st is None:
            return
        size = float(self.step_deg if axis.is_rotation else self.step_mm)
        label = f"step {self.frame.value} {axis.value} {size:g}{'°' if axis.is_rotation else ' mm'}"
        if from_status is None:
            self.c.command(cart_step_command(st.pose, self.frame, axis, size, float(self.speed)), label)
            return
        target = jog_target_pose(st.pose, self.frame, axis, size)
        self.c.command("MOVECART|" + "|".join(f"{v:.4f}" for v in target) + f"|None|{self.speed:g}", label)

    # ---- enables ----

    def offline(self) -> None:
        """No link to the controller: every jog button greyed (until the next status)."""
        self.release()
        self._cart_key = None
        for b in (*self.joint_buttons.values(), *self.cart_buttons.values()):
            b.set_enabled(False)

    def update(self, st: RobotStatus) -> None:
        """Grey jog buttons that cannot move: robot not movable, joint at its limit in that
        direction, or (Cartesian) no IK solution a small step ahead in that direction.  The
        angles and the TCP beside the buttons follow the status (none while the board homes:
        its counters count from the limit switches then, :func:`~parolkit.gui.link.joints_known`)."""
        known = joints_known(st)
        for lbl, text in zip(self.joint_values, format_angles(st.angles) if known else [HOMING_TEXT] * 6):
            lbl.set_text(text)
        for lbl, text in zip(self.cart_values, format_pose(st.pose) if known else ["—"] * 6):
            lbl.set_text(text)
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
