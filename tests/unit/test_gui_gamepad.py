"""The commander's gamepad, the server's part (parolkit.gui.gamepad): the page's messages
checked field by field, the dead zone, sticks / triggers / d-pad to joint and Cartesian
speeds, the deadman's rules, the mode and frame buttons, the targets (integrated, kept near
the arm and inside the joint limits), the indicator's words; and the drive against a real
controller process: the deadman held moves J1 the right way, its release sends STOP and the
arm comes to rest, a refused target ends the drive with the controller's reason."""

from __future__ import annotations

import asyncio
import math
import re
import time

import numpy as np
import pytest

from parolkit.gui.gamepad import (
    CART_CONTROLS,
    DEAD_ZONE,
    DEADMAN,
    FRAME_BUTTON,
    IDLE_HOLD_S,
    INPUT_TIMEOUT_S,
    JOINT_CONTROLS,
    LEAD_S,
    MODE_BUTTON,
    STALE_S,
    Axis,
    Button,
    GamepadDrive,
    GamepadInputError,
    Mode,
    PadControls,
    PadInput,
    apply_dead_zone,
    cart_speeds,
    indicator,
    joint_speeds,
    pad_speeds,
    page_settings,
    step_joints,
    step_pose,
)
from parolkit.gui.jog import rpy_to_matrix
from parolkit.moves import Frame
from parolkit.robot import PAROL6

STANDBY = PAROL6.standby_deg


def pad(axes: dict[Axis, float] | None = None, buttons: dict[Button, float] | None = None, **kw: object) -> PadInput:
    """A connected standard pad with these axes and buttons (the rest 0)."""
    a = [0.0] * 4
    for k, v in (axes or {}).items():
        a[k] = v
    b = [0.0] * 17
    for k, v in (buttons or {}).items():
        b[k] = v
    fields: dict[str, object] = {"connected": True, "live": True, "visible": True, "standard": True,
                                 "name": "test pad", "axes": a, "buttons": b}
    fields.update(kw)
    return PadInput.from_event(fields)


HELD = {DEADMAN: 1.0}


# ---- the page's messages ----


def test_a_message_is_taken_field_by_field_and_a_bad_field_is_named_with_its_range():
    p = pad({Axis.LX: 0.5}, {Button.RT: 0.25})
    assert p.connected and p.axis(Axis.LX) == 0.5 and p.button(Button.RT) == 0.25 and p.problem is None
    assert PadInput.from_event({"connected": False}) == PadInput(connected=False)
    ok = {"connected": True, "live": True, "standard": True}
    bad = [
        ("not a dict", "must be an object"),
        ({}, "connected must be true or false"),
        ({"connected": 1}, "connected must be true or false"),
        ({**ok, "axes": [0, 1.5]}, r"axes\[1\] must be a number in -1..1"),
        ({**ok, "buttons": [-0.1]}, r"buttons\[0\] must be a number in 0..1"),
        ({**ok, "axes": [math.nan]}, r"axes\[0\]"),
        ({**ok, "axes": [True]}, r"axes\[0\]"),
        ({**ok, "axes": [0.0] * 17}, "axes must be a list of at most 16"),
        ({**ok, "name": "x" * 201}, "name must be a text of at most 200"),
        ({"connected": True, "standard": True}, "live must be true or false"),
        ({**ok, "visible": "yes"}, "visible must be true or false"),
    ]
    for message, words in bad:
        with pytest.raises(GamepadInputError, match=words):
            PadInput.from_event(message)


def test_a_pad_that_cannot_drive_says_why():
    assert PadInput().problem == "gamepad disconnected"
    assert pad(visible=False).problem == "page hidden"
    assert "standard button layout" in (pad(standard=False).problem or "")
    assert pad(live=False).problem == f"no new data from the gamepad for {STALE_S:g} s"


# ---- the mapping ----


def test_the_dead_zone_is_zero_inside_and_rescaled_to_full_outside():
    assert apply_dead_zone(0.0) == 0.0 and apply_dead_zone(DEAD_ZONE) == 0.0 and apply_dead_zone(-0.1) == 0.0
    assert apply_dead_zone(1.0) == 1.0 and apply_dead_zone(-1.0) == -1.0
    assert apply_dead_zone(0.575) == pytest.approx(0.5) and apply_dead_zone(-0.575) == pytest.approx(-0.5)
    values = [apply_dead_zone(x / 100) for x in range(101)]
    assert values == sorted(values)  # grows with the deflection


def test_sticks_triggers_and_the_dpad_drive_one_joint_each_the_right_way():
    jog = PAROL6.max_jog_speed_deg_s
    cases = [  # (axes, buttons, joint, sign)
        ({Axis.LX: 1.0}, {}, 0, 1), ({Axis.LX: -1.0}, {}, 0, -1),
        ({Axis.LY: -1.0}, {}, 1, 1),  # stick up is -1 on the standard mapping: J2 +
        ({Axis.RY: -1.0}, {}, 2, 1), ({Axis.RX: 1.0}, {}, 3, 1),
        ({}, {Button.RT: 1.0}, 4, 1), ({}, {Button.LT: 1.0}, 4, -1),
        ({}, {Button.RIGHT: 1.0}, 5, 1), ({}, {Button.LEFT: 1.0}, 5, -1),
    ]
    for axes, buttons, joint, sign in cases:
        speeds = joint_speeds(pad(axes, buttons), 100.0)
        expected = [0.0] * 6
        expected[joint] = sign * float(jog[joint])
        assert speeds == pytest.approx(expected), (axes, buttons)
    # the jog speed slider scales it; the dead zone holds it at 0
    assert joint_speeds(pad({Axis.LX: 1.0}), 40.0)[0] == pytest.approx(0.4 * float(jog[0]))
    assert joint_speeds(pad({Axis.LX: 0.1, Axis.RY: -0.12}), 100.0) == (0.0,) * 6
    with pytest.raises(ValueError, match=r"speed_pct must be in \(0, 100\] %"):
        joint_speeds(pad(), 0.0)


def test_cartesian_mode_maps_the_same_controls_to_x_y_z_and_the_rotations():
    lin, ang = PAROL6.cart_linear_speed_from_percent(100.0), PAROL6.cart_angular_speed_from_percent(100.0)
    assert cart_speeds(pad({Axis.LX: 1.0}), 100.0) == pytest.approx([lin, 0, 0, 0, 0, 0])
    assert cart_speeds(pad({Axis.LY: -1.0}), 100.0) == pytest.approx([0, lin, 0, 0, 0, 0])
    assert cart_speeds(pad({}, {Button.RT: 1.0}), 100.0) == pytest.approx([0, 0, lin, 0, 0, 0])
    assert cart_speeds(pad({Axis.RY: -1.0}), 100.0) == pytest.approx([0, 0, 0, ang, 0, 0])
    assert cart_speeds(pad({Axis.RX: 1.0}), 100.0) == pytest.approx([0, 0, 0, 0, ang, 0])
    assert cart_speeds(pad({}, {Button.LEFT: 1.0}), 100.0) == pytest.approx([0, 0, 0, 0, 0, -ang])
    assert len(JOINT_CONTROLS) == len(CART_CONTROLS) == 6


def test_nothing_moves_without_the_deadman_or_from_a_pad_that_cannot_drive():
    stick = {Axis.LX: 1.0}
    assert pad_speeds(pad(stick), Mode.JOINT, 100.0) == (0.0,) * 6
    assert pad_speeds(pad(stick, {DEADMAN: 0.4}), Mode.JOINT, 100.0) == (0.0,) * 6  # not pressed yet
    assert pad_speeds(pad(stick, HELD), Mode.JOINT, 100.0)[0] > 0
    for frozen in (pad(stick, HELD, live=False), pad(stick, HELD, visible=False), pad(stick, HELD, standard=False)):
        assert pad_speeds(frozen, Mode.JOINT, 100.0) == (0.0,) * 6
        assert pad_speeds(frozen, Mode.CART, 100.0) == (0.0,) * 6


# ---- the deadman and the toggles ----


def test_the_deadman_starts_motion_only_when_pressed_after_it_was_seen_released():
    c = PadControls()
    assert not c.feed(pad({}, HELD)), "held as the pad connected: no motion"
    assert not c.feed(pad({}, HELD))
    assert not c.feed(pad())
    assert c.feed(pad({}, HELD)), "pressed after a release: motion may start"
    assert not c.feed(pad({}, HELD)), "only the press starts it"
    # a dropout while held, back with it held: no start until released and pressed again
    assert not c.feed(pad({}, HELD, live=False))
    assert not c.feed(pad({}, HELD))
    assert not c.feed(PadInput())
    assert not c.feed(pad({}, HELD))
    assert not c.feed(pad())
    assert c.feed(pad({}, HELD))


def test_the_mode_and_frame_buttons_toggle_on_their_press_only_while_the_deadman_is_released():
    c = PadControls()
    assert (c.mode, c.frame) == (Mode.JOINT, Frame.WRF)
    c.feed(pad())
    c.feed(pad({}, {MODE_BUTTON: 1.0}))
    assert c.mode is Mode.CART
    c.feed(pad({}, {MODE_BUTTON: 1.0}))  # still held: no second toggle
    assert c.mode is Mode.CART
    c.feed(pad({}, {FRAME_BUTTON: 1.0}))
    assert (c.mode, c.frame) == (Mode.CART, Frame.TRF)
    c.feed(pad())
    c.feed(pad({}, {**HELD}))
    c.feed(pad({}, {**HELD, MODE_BUTTON: 1.0, FRAME_BUTTON: 1.0}))  # while driving: ignored
    assert (c.mode, c.frame) == (Mode.CART, Frame.TRF)
    c.feed(PadInput())
    c.feed(pad({}, {MODE_BUTTON: 1.0}))  # held through a reconnection: not a press
    assert c.mode is Mode.CART


# ---- targets ----


def test_joint_targets_follow_the_speeds_stay_near_the_arm_and_inside_the_limits():
    speeds = (10.0, 0.0, -5.0, 0.0, 0.0, 0.0)
    target, stopped = step_joints(STANDBY, speeds, 0.02, STANDBY)
    assert target == pytest.approx([STANDBY[0] + 0.2, STANDBY[1], STANDBY[2] - 0.1, *STANDBY[3:]])
    assert stopped == ()
    # the arm held back: the target goes no further than LEAD_S of the joint's jog speed ahead
    lead = float(PAROL6.max_jog_speed_deg_s[0]) * LEAD_S
    far = list(STANDBY)
    far[0] += lead - 0.05
    target, _ = step_joints(far, speeds, 0.02, STANDBY)
    assert target[0] == pytest.approx(STANDBY[0] + lead)
    # at a limit: held there, and the joint named
    hi = float(PAROL6.safe_limits_deg[0][1])
    at = list(STANDBY)
    at[0] = hi - 0.1
    target, stopped = step_joints(at, speeds, 0.05, at)
    assert target[0] == pytest.approx(hi) and stopped == (0,)


def test_cartesian_targets_move_along_and_about_the_world_or_the_tool_axes():
    start = (0.0, 262.57, 288.75, -90.0, 0.0, -90.0)  # the standby pose (tool horizontal, z along world +Y)
    # WRF X: along the world X, the orientation kept
    p = step_pose(start, (20.0, 0, 0, 0, 0, 0), 0.05, Frame.WRF, start)
    assert p[:3] == pytest.approx((1.0, 262.57, 288.75)) and p[3:] == pytest.approx(start[3:])
    # TRF Z: along the tool's own z, which is the world +Y here
    p = step_pose(start, (0, 0, 20.0, 0, 0, 0), 0.05, Frame.TRF, start)
    assert p[:3] == pytest.approx((0.0, 263.57, 288.75), abs=1e-9)
    # WRF RZ: about the world z through the TCP: the position kept, R' = Rz(1 deg) R
    p = step_pose(start, (0, 0, 0, 0, 0, 20.0), 0.05, Frame.WRF, start)
    r0, r1 = np.array(rpy_to_matrix(*start[3:])), np.array(rpy_to_matrix(*p[3:]))
    c, s = math.cos(math.radians(1.0)), math.sin(math.radians(1.0))
    assert p[:3] == pytest.approx(start[:3]) and r1 == pytest.approx(np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ r0)
    # TRF RZ: about the tool's own z: R' = R Rz(1 deg)
    p = step_pose(start, (0, 0, 0, 0, 0, 20.0), 0.05, Frame.TRF, start)
    assert np.array(rpy_to_matrix(*p[3:])) == pytest.approx(r0 @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]))


def test_a_cartesian_target_stays_near_the_arm():
    start = (0.0, 262.57, 288.75, -90.0, 0.0, -90.0)
    lead_mm = PAROL6.cart_linear_speed_range_mm_s[1] * LEAD_S
    ahead = (lead_mm - 0.5, 262.57, 288.75, -90.0, 0.0, -90.0)
    p = step_pose(ahead, (60.0, 0, 0, 0, 0, 0), 0.05, Frame.WRF, start)
    assert p[0] == pytest.approx(lead_mm)
    lead_deg = PAROL6.cart_angular_speed_range_deg_s[1] * LEAD_S
    turned = step_pose(start, (0, 0, 0, 0, 0, 25.0), lead_deg / 25.0 - 0.01, Frame.WRF, start)
    again = step_pose(turned, (0, 0, 0, 0, 0, 25.0), 0.05, Frame.WRF, start)
    assert again == pytest.approx(turned), "a rotation beyond the lead is not taken further"


# ---- the indicator ----


def test_the_indicator_says_what_the_pad_is_and_what_to_do():
    c = PadControls()
    none = indicator(PadInput(), c, driving=False, elsewhere=False, last_stop="")
    assert none.text == "No gamepad" and none.attributes()["data-connected"] == "0"
    ready = indicator(pad(), c, driving=False, elsewhere=False, last_stop="")
    assert ready.text.startswith("Gamepad · Joint · hold RB to move") and ready.tone == "ready"
    c.feed(pad())
    c.feed(pad({}, {MODE_BUTTON: 1.0}))
    moving = indicator(pad({}, HELD), c, driving=True, elsewhere=False, last_stop="")
    assert moving.text == "Gamepad · Cartesian WRF · RB held: moving"
    assert moving.attributes() == {"data-connected": "1", "data-deadman": "1", "data-mode": "cart",
                                   "data-frame": "WRF", "data-driving": "1", "data-tone": "driving"}
    held = indicator(pad({}, HELD), c, driving=False, elsewhere=False, last_stop="deadman released")
    assert "release RB, then hold it to move (deadman released)" in held.text
    other = indicator(pad({}, HELD), c, driving=False, elsewhere=True, last_stop="")
    assert other.text == "Gamepad · another page drives the arm"
    hidden = indicator(pad(visible=False), c, driving=False, elsewhere=False, last_stop="")
    assert hidden.text == "Gamepad: page hidden" and hidden.tone == "problem"


def test_the_page_settings_come_from_the_constants():
    s = page_settings()
    assert s["deadman"] == int(DEADMAN) == 5 and s["stale_ms"] == STALE_S * 1000
    assert 0 < s["poll_ms"] < s["heartbeat_ms"] < 1000 * 0.5


def test_a_page_that_may_not_move_the_robot_does_not_start_the_drive():
    """A class: a watching page's press is refused by the commander's check (may_start)."""
    from parolkit.gui.eventlog import EventLog
    from parolkit.gui.link import ControllerLink

    link = ControllerLink("127.0.0.1", 9, 9)  # never started: nothing may be sent
    asked: list[bool] = []
    drive = GamepadDrive(link, EventLog(), lambda: None, may_start=lambda: asked.append(True) or False)
    controls = PadControls()
    for p in (pad(), pad({Axis.LX: 1.0}, HELD)):
        drive.feed("p", p, start=controls.feed(p), mode=Mode.JOINT, frame=Frame.WRF, speed_pct=50.0)
    assert asked == [True] and drive.owner is None and not drive.streaming


# ---- the drive, against a real controller process ----


def _ticks_in(line: str) -> int:
    m = re.search(r"controller tick (\d+)", line)
    assert m, line
    return int(m.group(1))


def test_the_drive_moves_j1_while_the_deadman_is_held_and_stops_it_on_release(controller):
    from parolkit.gui.eventlog import EventLog
    from parolkit.gui.link import ControllerLink

    async def main() -> None:
        log = EventLog()
        link = ControllerLink(controller.host, controller.port, controller.ack_port, event_log=log, every_n_ticks=1)
        await link.start()
        drive = GamepadDrive(link, log, lambda: None)
        try:
            await until(lambda: link.link_up, 10)
            before = link.status.angles
            j1 = before[0]
            controls = PadControls()
            page = "page-1"

            def feed(p: PadInput) -> None:
                drive.feed(page, p, start=controls.feed(p), mode=controls.mode, frame=controls.frame, speed_pct=100.0)

            feed(pad({Axis.LX: 1.0}))  # no deadman: nothing
            await asyncio.sleep(0.2)
            assert drive.owner is None and abs(link.status.angles[0] - j1) < 1e-6
            held = pad({Axis.LX: 1.0}, HELD)
            feed(held)
            assert drive.owner == page
            # the page's heartbeat keeps it going; J1 moves up (its + way)
            deadline = time.monotonic() + 20
            while link.status.angles[0] < j1 + 1.0:
                assert time.monotonic() < deadline, "J1 did not move 1 deg"
                assert drive.owner == page, [e.text for e in log]
                feed(held)
                await asyncio.sleep(0.05)
            assert drive.streaming
            assert link.status.angles[1:] == pytest.approx(before[1:], abs=1e-6), "only J1 moves"
            feed(pad({Axis.LX: 1.0}))  # released
            assert drive.owner is None and not drive.streaming
            line = await until(lambda: next((e.text for e in log if "STOP sent" in e.text), None), 10)
            assert line.startswith("gamepad: deadman released: STOP sent (controller tick ")
            _ticks_in(line)
            st = await until(lambda: link.status if link.status.command is None
                             and max(map(abs, link.status.speeds_deg_s)) == 0 else None, 20)
            rest = st.angles[0]
            await asyncio.sleep(0.3)
            assert link.status.angles[0] == pytest.approx(rest), "the arm moved after its stop"
        finally:
            drive.halt("test over")
            await link.close()

    asyncio.run(main())


def test_a_refused_target_ends_the_drive_with_the_controllers_reason(controller):
    from parolkit.gui.eventlog import EventLog
    from parolkit.gui.link import ControllerLink

    async def main() -> None:
        log = EventLog()
        link = ControllerLink(controller.host, controller.port, controller.ack_port, event_log=log)
        await link.start()
        drive = GamepadDrive(link, log, lambda: None)
        try:
            await until(lambda: link.link_up, 10)
            link.send("DISABLE")
            await until(lambda: not link.status.enabled, 10)
            controls = PadControls()
            for p in (pad(), pad({Axis.LX: 1.0}, HELD)):
                drive.feed("p", p, start=controls.feed(p), mode=Mode.JOINT, frame=Frame.WRF, speed_pct=50.0)
            line = await until(lambda: next((e.text for e in log if e.text.startswith("gamepad:")), None), 10)
            assert line.startswith("gamepad: the controller stopped it: "), line
            assert "disabled" in line.lower(), line
            assert drive.owner is None
        finally:
            drive.halt("test over")
            await link.close()

    asyncio.run(main())


def test_the_drive_stops_when_the_page_falls_silent_and_holds_still_sticks_only_briefly(controller):
    from parolkit.gui.eventlog import EventLog
    from parolkit.gui.link import ControllerLink

    async def main() -> None:
        log = EventLog()
        link = ControllerLink(controller.host, controller.port, controller.ack_port, event_log=log)
        await link.start()
        drive = GamepadDrive(link, log, lambda: None)
        try:
            await until(lambda: link.link_up, 10)
            controls = PadControls()
            for p in (pad(), pad({}, HELD)):
                drive.feed("p", p, start=controls.feed(p), mode=Mode.JOINT, frame=Frame.WRF, speed_pct=50.0)
            # deadman held, sticks still: nothing is streamed (the controller stays free)
            for _ in range(int(IDLE_HOLD_S / 0.05) + 2):
                drive.feed("p", pad({}, HELD), start=False, mode=Mode.JOINT, frame=Frame.WRF, speed_pct=50.0)
                await asyncio.sleep(0.05)
            assert drive.owner == "p" and not drive.streaming and link.status.command is None
            # another page's pad is not heard while this one drives
            drive.feed("q", pad(), start=False, mode=Mode.JOINT, frame=Frame.WRF, speed_pct=50.0)
            assert drive.owner == "p"
            # silence from the page: stopped
            line = await until(lambda: next((e.text for e in log if e.text.startswith("gamepad:")), None), 10)
            assert line == f"gamepad: no word from the page for {INPUT_TIMEOUT_S:g} s"
            assert drive.owner is None
        finally:
            drive.halt("test over")
            await link.close()

    asyncio.run(main())


async def until(predicate, timeout: float):  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"not reached within {timeout} s (last {value!r})")
        await asyncio.sleep(0.02)
