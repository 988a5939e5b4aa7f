"""The commander's gamepad (no UI imports): what the sticks, triggers and buttons mean, the
deadman, and the servo stream that moves the arm while the deadman is held.

The page (``gui/static/gamepad.js``) polls the browser's Gamepad API and sends each new
state of the pad, and a heartbeat, to the server as the NiceGUI event ``pk_gamepad``
(:meth:`PadInput.from_event`); the server maps it to joint or Cartesian speeds here
(:func:`pad_speeds`) and streams servo targets to the controller through the link
(``SERVOJ`` / ``SERVOL``, :class:`GamepadDrive`).  Nothing moves unless the deadman
(:data:`DEADMAN`, the right shoulder button) is held, and a press counts only after the
deadman was seen released (:class:`PadControls`): a pad that connects, or comes back, with
it held does not move the arm.

Units: joint speeds in deg/s, Cartesian speeds in mm/s and deg/s, poses ``[x, y, z mm,
A, B, C deg]`` (``R = Rx(C) Ry(B) Rz(A)``, :mod:`parolkit.gui.jog`), times in s.

What stops the arm, each a STOP to the controller at once (it begins a controlled stop at
its next tick): the deadman released, the pad disconnected or gone from the browser's list,
its data frozen while the deadman is held (:data:`STALE_S`), the page hidden, no word from
the page for :data:`INPUT_TIMEOUT_S` (a stalled page; a closed one's socket closing stops it
at once), the link to the controller lost, the header's Stop or E-STOP, a jog button, and the
controller refusing or ending a target (its reason in the log).  Should the commander itself
stall, the controller's servo timeout (``servo.timeout_s``, 0.05 s) stops the arm once no
target comes.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum, IntEnum
from typing import TYPE_CHECKING

import numpy as np

from parolkit.client import robot_api as wire
from parolkit.client.core import AckStatus
from parolkit.client.errors import CommandNotCompleted, RobotError
from parolkit.errors import ParolkitValueError
from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.jog import matrix_to_rpy, rpy_to_matrix
from parolkit.gui.link import LINK_TIMEOUT_S
from parolkit.moves import Frame
from parolkit.robot import JOINT_NAMES, PAROL6, RobotModel

if TYPE_CHECKING:
    from parolkit.client.async_robot import AsyncCommandHandle
    from parolkit.client.core import RobotStatus
    from parolkit.gui.link import ControllerLink

__all__ = [
    "Axis", "Button", "DEADMAN", "MODE_BUTTON", "FRAME_BUTTON", "DEAD_ZONE", "PRESS_THRESHOLD",
    "POLL_S", "HEARTBEAT_S", "STALE_S", "INPUT_TIMEOUT_S", "SILENCE_STEP_S", "SERVO_PERIOD_S", "IDLE_HOLD_S", "LEAD_S",
    "GamepadInputError", "PadInput", "Mode", "PadControl", "JOINT_CONTROLS", "CART_CONTROLS", "PadControls",
    "apply_dead_zone", "joint_speeds", "cart_speeds", "pad_speeds", "step_joints", "step_pose",
    "page_settings", "GamepadView", "indicator", "GamepadDrive",
]


class Button(IntEnum):
    """Button indices of the W3C "standard" gamepad mapping (Xbox names; on a PlayStation
    pad A B X Y are cross, circle, square, triangle)."""

    A = 0
    B = 1
    X = 2
    Y = 3
    LB = 4
    RB = 5
    LT = 6
    RT = 7
    BACK = 8
    START = 9
    LEFT_STICK = 10
    RIGHT_STICK = 11
    UP = 12
    DOWN = 13
    LEFT = 14
    RIGHT = 15
    HOME = 16


class Axis(IntEnum):
    """Axis indices of the standard mapping: -1 is left / up, +1 right / down."""

    LX = 0
    LY = 1
    RX = 2
    RY = 3


#: held: the arm may move; released: it stops (the right shoulder button)
DEADMAN = Button.RB
#: toggles joint / Cartesian mode, only while the deadman is released
MODE_BUTTON = Button.Y
#: toggles the Cartesian frame WRF / TRF, only while the deadman is released
FRAME_BUTTON = Button.X
#: stick and trigger values within this of 0 count as 0; beyond it the value is rescaled so
#: the speed grows from 0 at the dead zone's edge to the full speed at full deflection
DEAD_ZONE = 0.15
#: a button counts as pressed from this value on (triggers and buttons report 0..1)
PRESS_THRESHOLD = 0.5
#: the page polls the Gamepad API this often, s
POLL_S = 0.01
#: the page sends its pad's state at least this often while a pad is connected, s
HEARTBEAT_S = 0.1
#: a pad whose data (its ``timestamp``) has not changed for this long while the deadman is
#: held counts as frozen: the arm stops (some pads report nothing while nothing changes:
#: release the deadman and press it again), s
STALE_S = 1.0
#: no word from the driving page for this long stops the arm (a stalled page; counted in the
#: server's own stream periods, each at most :data:`SILENCE_STEP_S`, so the server's own
#: stall, after which the page's waiting messages are read, is not taken for the page's; the
#: controller's status stream is judged the same way, silent for the link's
#: ``LINK_TIMEOUT_S``), s
INPUT_TIMEOUT_S = 1.5
#: the most one period of the stream counts toward the page's silence, s
SILENCE_STEP_S = 0.1
#: servo targets are sent this often (the controller's servo.timeout_s is 0.05 s), s
SERVO_PERIOD_S = 0.02
#: with every stick back in its dead zone the target is held this long, then no more targets
#: are sent (the stream ends at rest; the controller is free again), s
IDLE_HOLD_S = 0.5
#: a target runs at most this long (at the full speed) ahead of where the arm is: an arm held
#: back (a joint's speed limit in Cartesian mode, the guard) does not leave the target running
#: away, to be caught up with later, s
LEAD_S = 0.25
#: the longest time step integrated at once (a held-up server does not jump the target), s
MAX_STEP_S = 0.05
#: acks of targets are watched for this long; a stream's first target (EXECUTING until the
#: stream ends) until its end, s
ACK_KEEP_S = 2.0
MAX_AXES = 16
MAX_BUTTONS = 32
MAX_NAME = 200


class GamepadInputError(ParolkitValueError):
    """A ``pk_gamepad`` message the server cannot take (the field and its allowed range named)."""


def _flag(args: dict[str, object], key: str, default: bool | None = None) -> bool:
    value = args.get(key, default)
    if not isinstance(value, bool):
        raise GamepadInputError(f"gamepad message: {key} must be true or false, got {value!r}")
    return value


def _values(args: dict[str, object], key: str, lo: float, hi: float, most: int) -> tuple[float, ...]:
    value = args.get(key, [])
    if not isinstance(value, list) or len(value) > most:
        raise GamepadInputError(f"gamepad message: {key} must be a list of at most {most} numbers, got {value!r}")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
            raise GamepadInputError(f"gamepad message: {key}[{i}] must be a number in {lo:g}..{hi:g}, got {v!r}")
        out.append(float(v))
    return tuple(out)


@dataclass(frozen=True)
class PadInput:
    """One state of the page's gamepad: ``connected`` (a pad is in the browser's list),
    ``live`` (its data is not frozen, :data:`STALE_S`), ``visible`` (the page is shown),
    ``standard`` (it uses the standard mapping: the indices here mean what they say), its
    ``name``, ``axes`` (-1..1) and ``buttons`` (values 0..1)."""

    connected: bool = False
    live: bool = True
    visible: bool = True
    standard: bool = True
    name: str = ""
    axes: tuple[float, ...] = ()
    buttons: tuple[float, ...] = ()

    @classmethod
    def from_event(cls, args: object) -> PadInput:
        """The page's message ``{connected, live, visible, standard, name, axes, buttons}``;
        raises :class:`GamepadInputError` naming the field that is missing or out of range."""
        if not isinstance(args, dict):
            raise GamepadInputError(f"gamepad message must be an object, got {args!r}")
        visible = _flag(args, "visible", True)
        if not _flag(args, "connected"):
            return cls(connected=False, visible=visible)
        name = args.get("name", "")
        if not isinstance(name, str) or len(name) > MAX_NAME:
            raise GamepadInputError(f"gamepad message: name must be a text of at most {MAX_NAME} characters, "
                                    f"got {name!r}")
        return cls(connected=True, live=_flag(args, "live"), visible=visible, standard=_flag(args, "standard"),
                   name=name, axes=_values(args, "axes", -1.0, 1.0, MAX_AXES),
                   buttons=_values(args, "buttons", 0.0, 1.0, MAX_BUTTONS))

    def axis(self, axis: Axis) -> float:
        return self.axes[axis] if axis < len(self.axes) else 0.0

    def button(self, button: Button) -> float:
        return self.buttons[button] if button < len(self.buttons) else 0.0

    def pressed(self, button: Button) -> bool:
        return self.button(button) >= PRESS_THRESHOLD

    @property
    def deadman(self) -> bool:
        return self.pressed(DEADMAN)

    @property
    def problem(self) -> str | None:
        """Why this pad cannot move the arm now (the words of the log and the indicator), or
        None when it can."""
        if not self.connected:
            return "gamepad disconnected"
        if not self.visible:
            return "page hidden"
        if not self.standard:
            return "gamepad without the standard button layout: not used"
        if not self.live:
            return f"no new data from the gamepad for {STALE_S:g} s"
        return None


def apply_dead_zone(value: float, dead_zone: float = DEAD_ZONE) -> float:
    """0 within ``dead_zone`` of 0; beyond it rescaled to 0..1 (sign kept) at full deflection."""
    a = abs(value)
    if a <= dead_zone:
        return 0.0
    return math.copysign(min(1.0, (a - dead_zone) / (1.0 - dead_zone)), value)


@dataclass(frozen=True)
class PadControl:
    """Where one speed comes from: a stick ``axis`` (``sign`` -1 where the speed's + is the
    axis's -: stick up), or two buttons, ``plus`` minus ``minus`` (the triggers' analog
    values, the d-pad's 0 / 1).  ``label`` names it for people (the indicator, docs/gui.md)."""

    label: str
    axis: Axis | None = None
    sign: int = 1
    plus: Button | None = None
    minus: Button | None = None

    def value(self, pad: PadInput) -> float:
        """-1..1 after the dead zone."""
        if self.axis is not None:
            return self.sign * apply_dead_zone(pad.axis(self.axis))
        plus = apply_dead_zone(pad.button(self.plus)) if self.plus is not None else 0.0
        minus = apply_dead_zone(pad.button(self.minus)) if self.minus is not None else 0.0
        return plus - minus


class Mode(str, Enum):
    """What the sticks move: the joints or the TCP."""

    JOINT = "joint"
    CART = "cart"


_LEFT_X = PadControl("left stick right / left", axis=Axis.LX)
_LEFT_Y = PadControl("left stick up / down", axis=Axis.LY, sign=-1)
_RIGHT_X = PadControl("right stick right / left", axis=Axis.RX)
_RIGHT_Y = PadControl("right stick up / down", axis=Axis.RY, sign=-1)
_TRIGGERS = PadControl("right trigger / left trigger", plus=Button.RT, minus=Button.LT)
_DPAD = PadControl("d-pad right / left", plus=Button.RIGHT, minus=Button.LEFT)

#: J1..J6 in joint mode (+ / - of each joint)
JOINT_CONTROLS: tuple[PadControl, ...] = (_LEFT_X, _LEFT_Y, _RIGHT_Y, _RIGHT_X, _TRIGGERS, _DPAD)
#: X Y Z (mm/s) and RX RY RZ (deg/s, about the axes) in Cartesian mode, in WRF or TRF
CART_CONTROLS: tuple[PadControl, ...] = (_LEFT_X, _LEFT_Y, _TRIGGERS, _RIGHT_Y, _RIGHT_X, _DPAD)
CART_AXES = ("X", "Y", "Z", "RX", "RY", "RZ")


def _pct(speed_pct: float) -> float:
    v = float(speed_pct)
    if not math.isfinite(v) or not 0.0 < v <= 100.0:
        raise ParolkitValueError(f"speed_pct must be in (0, 100] %, got {speed_pct!r}")
    return v


def joint_speeds(pad: PadInput, speed_pct: float, model: RobotModel = PAROL6) -> tuple[float, ...]:
    """J1..J6 speeds, deg/s: each control's value x the joint's jog speed at ``speed_pct``
    (the Jog tab's speed slider; 100 %: the joint's maximum jog speed)."""
    pct = _pct(speed_pct)
    return tuple(c.value(pad) * float(v) * pct / 100.0 for c, v in zip(JOINT_CONTROLS, model.max_jog_speed_deg_s))


def cart_speeds(pad: PadInput, speed_pct: float, model: RobotModel = PAROL6) -> tuple[float, ...]:
    """X Y Z speeds (mm/s) and RX RY RZ (deg/s): each control's value x the Cartesian jog's
    linear / angular speed at ``speed_pct`` (as CARTJOG maps it)."""
    pct = _pct(speed_pct)
    lin = model.cart_linear_speed_from_percent(pct)
    ang = model.cart_angular_speed_from_percent(pct)
    return tuple(c.value(pad) * (lin if i < 3 else ang) for i, c in enumerate(CART_CONTROLS))


def pad_speeds(pad: PadInput, mode: Mode, speed_pct: float, model: RobotModel = PAROL6) -> tuple[float, ...]:
    """The speeds the pad asks for in ``mode``; all 0 unless it can drive and the deadman is held."""
    if pad.problem is not None or not pad.deadman:
        return (0.0,) * 6
    return joint_speeds(pad, speed_pct, model) if mode is Mode.JOINT else cart_speeds(pad, speed_pct, model)


class PadControls:
    """One page's buttons: the mode and frame toggles and the deadman's press.

    :meth:`feed` takes each state of the pad and returns True for a press of the deadman that
    may start motion: one that follows a state with the deadman released while the pad could
    drive.  A pad that cannot drive (disconnected, frozen, hidden page) forgets that, so a
    deadman held through a dropout (or held as the pad connects) never starts motion.  The
    mode and frame toggle on their buttons' press, only while the deadman is released."""

    def __init__(self) -> None:
        self.mode = Mode.JOINT
        self.frame = Frame.WRF
        self._armed = False
        self._prev: frozenset[Button] | None = None

    def feed(self, pad: PadInput) -> bool:
        if pad.problem is not None:
            self._armed = False
            self._prev = None
            return False
        pressed = frozenset(b for b in Button if pad.pressed(b))
        deadman = DEADMAN in pressed
        if not deadman and self._prev is not None:
            new = pressed - self._prev
            if MODE_BUTTON in new:
                self.mode = Mode.CART if self.mode is Mode.JOINT else Mode.JOINT
            if FRAME_BUTTON in new:
                self.frame = Frame.TRF if self.frame is Frame.WRF else Frame.WRF
        start = deadman and self._armed
        self._armed = not deadman
        self._prev = pressed
        return start


# ---- targets ----


def step_joints(target: Sequence[float], speeds_deg_s: Sequence[float], dt: float, actual: Sequence[float],
                model: RobotModel = PAROL6) -> tuple[tuple[float, ...], tuple[int, ...]]:
    """The next joint target: ``target`` + ``speeds_deg_s`` x ``dt``, each joint at most
    :data:`LEAD_S` of its maximum jog speed from where it is (``actual``) and inside its
    joint limits.  Returns (target, the joints a limit stopped)."""
    lead = model.max_jog_speed_deg_s * LEAD_S
    limits = model.safe_limits_deg
    out: list[float] = []
    stopped: list[int] = []
    for j in range(6):
        t = float(target[j]) + float(speeds_deg_s[j]) * dt
        t = min(max(t, float(actual[j]) - lead[j]), float(actual[j]) + lead[j])
        lo, hi = float(limits[j][0]), float(limits[j][1])
        if t < lo or t > hi:
            if speeds_deg_s[j] != 0.0:
                stopped.append(j)
            t = min(max(t, lo), hi)
        out.append(t)
    return tuple(out), tuple(stopped)


def _axis_angle(rotvec_rad: np.ndarray) -> np.ndarray:
    """The rotation matrix of a rotation vector (its direction the axis, its length the angle, rad)."""
    angle = float(np.linalg.norm(rotvec_rad))
    if angle < 1e-12:
        return np.eye(3)
    k = rotvec_rad / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    turn: np.ndarray = np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)
    return turn


def _rotation(pose: Sequence[float]) -> np.ndarray:
    return np.array(rpy_to_matrix(float(pose[3]), float(pose[4]), float(pose[5])))


def step_pose(target: Sequence[float], speeds: Sequence[float], dt: float, frame: Frame, actual: Sequence[float],
              model: RobotModel = PAROL6) -> tuple[float, ...]:
    """The next TCP target pose: ``target`` moved by ``speeds`` (X Y Z mm/s, RX RY RZ deg/s)
    for ``dt``.  WRF: along the world axes, turned about the world axes through the TCP; TRF:
    along and about the tool's own axes (the target's).  The target stays within
    :data:`LEAD_S` of the fastest Cartesian jog from ``actual`` (a rotation beyond it is not
    taken further)."""
    r = _rotation(target)
    p = np.array([float(v) for v in target[:3]])
    v = np.array([float(s) for s in speeds[:3]]) * dt
    w = np.radians([float(s) for s in speeds[3:6]]) * dt
    turn = _axis_angle(w)
    if frame is Frame.TRF:
        p = p + r @ v
        r_new = r @ turn
    else:
        p = p + v
        r_new = turn @ r
    here = np.array([float(x) for x in actual[:3]])
    lead_mm = model.cart_linear_speed_range_mm_s[1] * LEAD_S
    off = p - here
    dist = float(np.linalg.norm(off))
    if dist > lead_mm:
        p = here + off * (lead_mm / dist)
    lead_deg = model.cart_angular_speed_range_deg_s[1] * LEAD_S
    if np.any(w) and _angle_deg(r_new, _rotation(actual)) > lead_deg:
        r_new = r
    a, b, c = matrix_to_rpy(r_new.tolist())
    return (float(p[0]), float(p[1]), float(p[2]), a, b, c)


def _angle_deg(r1: np.ndarray, r2: np.ndarray) -> float:
    cos = (float(np.trace(r1.T @ r2)) - 1.0) / 2.0
    return math.degrees(math.acos(min(1.0, max(-1.0, cos))))


def page_settings() -> dict[str, float]:
    """What gamepad.js needs to know (its data island, ``#pk-gamepad``): one source of truth."""
    return {"poll_ms": POLL_S * 1000.0, "heartbeat_ms": HEARTBEAT_S * 1000.0, "stale_ms": STALE_S * 1000.0,
            "deadman": int(DEADMAN), "press": PRESS_THRESHOLD}


# ---- the indicator ----


@dataclass(frozen=True)
class GamepadView:
    """What a page's gamepad indicator shows: ``text`` and the state as data attributes."""

    text: str
    connected: bool
    deadman: bool
    mode: Mode
    frame: Frame
    driving: bool
    tone: str  # "idle", "ready", "driving", "problem"

    def attributes(self) -> dict[str, str]:
        return {"data-connected": str(int(self.connected)), "data-deadman": str(int(self.deadman)),
                "data-mode": self.mode.value, "data-frame": self.frame.value, "data-driving": str(int(self.driving)),
                "data-tone": self.tone}


def _mode_words(mode: Mode, frame: Frame) -> str:
    return "Joint" if mode is Mode.JOINT else f"Cartesian {frame.value}"


def indicator(pad: PadInput, controls: PadControls, *, driving: bool, elsewhere: bool, last_stop: str) -> GamepadView:
    """The indicator of a page whose pad is ``pad``: ``driving`` (its deadman drives the arm),
    ``elsewhere`` (another page's does), ``last_stop`` (why the arm last stopped, "" if
    nothing to say)."""
    mode, frame = controls.mode, controls.frame
    deadman = pad.connected and pad.deadman

    def view(text: str, tone: str) -> GamepadView:
        return GamepadView(text, pad.connected, deadman, mode, frame, driving, tone)

    if not pad.connected:
        return view("No gamepad", "idle")
    problem = pad.problem
    if problem is not None:
        return view(f"Gamepad: {problem}", "problem")
    words = _mode_words(mode, frame)
    if driving:
        return view(f"Gamepad · {words} · {DEADMAN.name} held: moving", "driving")
    if elsewhere:
        return view("Gamepad · another page drives the arm", "problem")
    if deadman:
        return view(f"Gamepad · {words} · release {DEADMAN.name}, then hold it to move"
                    + (f" ({last_stop})" if last_stop else ""), "problem")
    return view(f"Gamepad · {words} · hold {DEADMAN.name} to move ({MODE_BUTTON.name}: mode, "
                f"{FRAME_BUTTON.name}: frame)", "ready")


# ---- the stream ----


class GamepadDrive:
    """The one gamepad stream of the commander (one page drives at a time).

    :meth:`feed` takes each state of a page's pad: a deadman press (from :class:`PadControls`)
    starts driving, for that page only; while it drives, a servo target every
    :data:`SERVO_PERIOD_S` (``SERVOJ`` in joint mode, ``SERVOL`` in the world frame in
    Cartesian mode, TRF motion turned into world poses here), integrated from the speeds the
    pad asks for.  :meth:`halt` ends it: no more targets, and STOP when the controller may still
    stream (a controlled stop at its next tick); the log line names why, with the controller's
    tick when it answered a query sent right after the STOP."""

    def __init__(self, link: ControllerLink, log: EventLog, ensure_control: Callable[[], None], *,
                 may_start: Callable[[], bool] = lambda: True, model: RobotModel = PAROL6,
                 period_s: float = SERVO_PERIOD_S, input_timeout_s: float = INPUT_TIMEOUT_S,
                 idle_hold_s: float = IDLE_HOLD_S) -> None:
        self.link = link
        self.log = log
        self._ensure_control = ensure_control
        #: asked (in the page's event) before a press starts driving: False refuses it (a class:
        #: a page that watches; the refusal is the caller's to say)
        self._may_start = may_start
        self.model = model
        self.period_s = period_s
        self.input_timeout_s = input_timeout_s
        self.idle_hold_s = idle_hold_s
        #: the page that drives (its key), None while nobody does
        self.owner: str | None = None
        self.mode = Mode.JOINT
        self.frame = Frame.WRF
        self._pad = PadInput()
        self._speed_pct = 40.0
        #: how long the driving page, and the controller's status stream, have been silent
        #: (counted as :data:`INPUT_TIMEOUT_S` says), s
        self._silence = 0.0
        self._status_silence = 0.0
        self._status_count = 0
        self._task: asyncio.Task[None] | None = None
        #: targets are being sent (a servo stream runs at the controller)
        self.streaming = False
        self._joints: tuple[float, ...] | None = None
        self._pose: tuple[float, ...] | None = None
        self._still_since: float | None = None
        self._limited: tuple[int, ...] = ()
        self._acks: deque[tuple[AsyncCommandHandle, float]] = deque()
        #: why it stopped last (the indicator shows it while the deadman is still held)
        self.last_stop = ""
        #: changes with every state change (the indicators refresh on it)
        self.version = 0

    # ---- from the pages ----

    def feed(self, page: str, pad: PadInput, *, start: bool, mode: Mode, frame: Frame, speed_pct: float) -> None:
        """A new state of page ``page``'s pad; ``start``: a deadman press that may start
        motion (:meth:`PadControls.feed`); ``mode`` / ``frame``: the page's; ``speed_pct``:
        its jog speed slider."""
        if self.owner is not None and self.owner != page:
            return
        if self.owner == page:
            problem = pad.problem
            if problem is not None:
                self.halt(problem)
            elif not pad.deadman:
                self.halt("deadman released")
            else:
                self._pad, self._speed_pct, self._silence = pad, _pct(speed_pct), 0.0
            return
        if not start or pad.problem is not None or not pad.deadman or not self._may_start():
            return
        self.owner = page
        self._pad, self._speed_pct, self._silence = pad, _pct(speed_pct), 0.0
        self._status_silence, self._status_count = 0.0, self.link.status_count
        self.mode, self.frame = mode, frame
        self.streaming = False
        self._joints = self._pose = None
        self._still_since = None
        self._limited = ()
        self._acks.clear()
        self.last_stop = ""
        self.version += 1
        self._task = asyncio.ensure_future(self._run())

    def page_gone(self, page: str) -> None:
        """Page ``page``'s connection closed: if it drives, the arm stops."""
        if self.owner == page:
            self.halt("the driving page closed")

    def driving(self, page: str) -> bool:
        return self.owner == page

    # ---- stopping ----

    def halt(self, reason: str, *, send_stop: bool = True, level: Level = Level.INFO) -> None:
        """End the drive (if one runs): no more targets; with ``send_stop``, STOP when the
        controller may still stream our targets (the header's Stop and E-STOP send their own)."""
        if self.owner is None:
            return
        streamed = self.streaming or self._servo_running()
        self.owner = None
        self.streaming = False
        self._joints = self._pose = None
        self._acks.clear()
        task, self._task = self._task, None
        if task is not None and task is not _current_task():
            task.cancel()
        self.last_stop = reason
        self.version += 1
        if not (send_stop and streamed):
            self.log.add(f"gamepad: {reason}", level)
            return
        try:
            self.link.send("STOP", label="gamepad STOP", quiet=True)
        except RobotError as exc:
            self.log.error(f"gamepad: {reason}: STOP not sent: {exc}")
            return
        asyncio.ensure_future(self._log_stop(reason, level))

    async def _log_stop(self, reason: str, level: Level) -> None:
        """The stop's log line, with the controller's tick from a query sent right after the STOP."""
        try:  # the status's seq is the tick of the controller's newest snapshot
            status = await self.link.robot.status()
        except RobotError:
            self.log.add(f"gamepad: {reason}: STOP sent", level)
            return
        self.log.add(f"gamepad: {reason}: STOP sent (controller tick {status.seq})", level)

    def _servo_running(self) -> bool:
        st = self.link.status
        return st is not None and st.command is not None and st.command.name in ("SERVOJ", "SERVOL")

    # ---- the stream ----

    async def _run(self) -> None:
        last = time.monotonic()
        try:
            self._ensure_control()
            while self.owner is not None:
                now = time.monotonic()
                self._count_silence(min(now - last, SILENCE_STEP_S))
                why = self._why_stop()
                if why is not None:
                    self.halt(why)
                    return
                failure = await self._refusal(now)
                if failure is not None:
                    self.halt(f"the controller stopped it: {failure}", level=Level.ERROR)
                    return
                self._step(now, min(now - last, MAX_STEP_S))
                last = now
                await asyncio.sleep(self.period_s)
        except (RobotError, OSError) as exc:
            self.halt(f"targets not sent: {exc}", level=Level.ERROR)

    def _count_silence(self, step: float) -> None:
        self._silence += step
        if self.link.status_count != self._status_count:
            self._status_count, self._status_silence = self.link.status_count, 0.0
        else:
            self._status_silence += step

    def _why_stop(self) -> str | None:
        if self._status_silence > LINK_TIMEOUT_S:
            return f"no status from the controller for {LINK_TIMEOUT_S:g} s"
        if self._silence > self.input_timeout_s:
            return f"no word from the page for {self.input_timeout_s:g} s"
        return None

    async def _refusal(self, now: float) -> str | None:
        """The controller's words when it refused or ended one of our targets' streams
        (FAILED, INVALID, CANCELLED); None while all is well."""
        keep: deque[tuple[AsyncCommandHandle, float]] = deque()
        for handle, sent in self._acks:
            if handle.done():
                result = await handle.result(timeout=0.0, raise_on_error=False)
                if isinstance(result, CommandNotCompleted) and result.status in (
                        AckStatus.FAILED.value, AckStatus.INVALID.value, AckStatus.CANCELLED.value):
                    return result.reason or result.status
            elif handle.status() is AckStatus.EXECUTING or now - sent < ACK_KEEP_S:
                keep.append((handle, sent))
        self._acks = keep
        return None

    def _step(self, now: float, dt: float) -> None:
        st = self.link.status
        if st is None:
            return
        speeds = pad_speeds(self._pad, self.mode, self._speed_pct, self.model)
        if not any(speeds):
            if not self.streaming:
                return
            if self._still_since is None:
                self._still_since = now
            if now - self._still_since >= self.idle_hold_s:  # at rest: the stream ends at the controller
                self.streaming = False
                self._joints = self._pose = None
                self.version += 1
                return
        else:
            self._still_since = None
        if not self.streaming:
            self._joints, self._pose = tuple(st.angles), tuple(st.pose)
            self.streaming = True
            self.version += 1
        self._send(self._next_target(st, speeds, dt), now)

    def _next_target(self, st: RobotStatus, speeds: tuple[float, ...], dt: float) -> str:
        if self.mode is Mode.JOINT:
            assert self._joints is not None
            self._joints, limited = step_joints(self._joints, speeds, dt, st.angles, self.model)
            if limited and limited != self._limited:
                names = ", ".join(JOINT_NAMES[j] for j in limited)
                self.log.add(f"gamepad: {names} at its limit", Level.WARNING)
            self._limited = limited
            return wire.build_servo_j(list(self._joints))
        assert self._pose is not None
        self._pose = step_pose(self._pose, speeds, dt, self.frame, st.pose, self.model)
        return wire.build_servo_l(list(self._pose), "WRF")

    def _send(self, body: str, now: float) -> None:
        handle = self.link.robot.send_nowait(body)
        self._acks.append((handle, now))


def _current_task() -> asyncio.Task[object] | None:
    try:
        return asyncio.current_task()
    except RuntimeError:  # no running loop
        return None
