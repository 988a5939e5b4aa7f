"""A model of the SSG-48 electric gripper as seen through the PAROL6 board.

Jaw position is in gripper units 0 (fully open) .. 255 (fully closed).  The jaws open
``STROKE_MM`` = 48 mm at position 0, linearly: ``opening_mm = 48 * (255 - position) / 255``.

Speed byte -> jaw rate (documented mapping, units per second)::

    rate = 20 + 480 * speed / 255      # 0 -> 20 units/s (full stroke 12.75 s),
                                       # 255 -> 500 units/s (full stroke 0.51 s)

Behaviour per accepted frame (the board forwards one CAN message per frame):

* mode 1 (CALIBRATE): the gripper calibrates for ``calibration_s`` (default 1.0 s) and ends
  fully open, calibrated and activated.
* mode 2 (CLEAR_ERROR): clears the E-stop/error flag.
* mode 0, setpoints unchanged since the last frame: only a keep-alive (no effect).
* mode 0, something changed: the command byte's ACTIVATE bit (0x80) keeps the gripper active (0 deactivates it:
  the jaws stop); with ACTIVATE and MOVE (0x40) the position/speed/current setpoints are
  taken; the ESTOP bit (0x20) stops the jaws and raises the error flag (0x02) until a
  clear-error.  Moves need a calibrated gripper (as the real SSG-48).

Status byte: 0x80 activated, 0x40 action (a move request is active), object code in
0x20/0x10 (0 moving, 1 object found while closing, 2 object found while opening, 3 at
position), 0x02 error/E-stop, 0x01 calibrated.  Temperature/timeout bits stay 0.

Setpoints reach the gripper as the board packs them: position and speed as bytes (low 8
bits), current as u16; the SSG-48 drives at most 1300 mA.

Current: the current setpoint (mA) while the jaws move or grip an object; ``REST_CURRENT_MA``
(20 mA) at rest.  An object of width ``w`` mm placed between the jaws (:meth:`place_object`)
stops a closing move at the position where the opening equals ``w`` (object code 1).
Opening moves never meet an object (internal grips are not modelled: code 2 is never reported).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from parolkit.errors import ParolkitValueError
from parolkit.protocol.frames import GripperCommandBits, GripperMode, GripperStatus

__all__ = ["SSG48Gripper", "GripperState", "STROKE_MM", "REST_CURRENT_MA", "jaw_rate_units_s"]

STROKE_MM = 48.0
REST_CURRENT_MA = 20
#: The SSG-48's current ceiling, mA.
MAX_CURRENT_MA = 1300
MIN_RATE_UNITS_S = 20.0
MAX_RATE_UNITS_S = 500.0


def jaw_rate_units_s(speed: int) -> float:
    """Jaw rate in position units per second for a speed byte 0..255."""
    if isinstance(speed, bool) or not isinstance(speed, int) or not 0 <= speed <= 255:
        raise ParolkitValueError(f"speed must be an integer byte 0..255, got {speed!r}")
    return MIN_RATE_UNITS_S + (MAX_RATE_UNITS_S - MIN_RATE_UNITS_S) * speed / 255.0


def position_for_opening(width_mm: float) -> float:
    """Jaw position (units) at which the opening equals ``width_mm``."""
    return 255.0 * (1.0 - width_mm / STROKE_MM)


@dataclass(frozen=True)
class GripperState:
    """A snapshot of the gripper (what the status frame carries, decoded)."""

    position: int
    current_ma: int
    status: GripperStatus
    setpoint: int
    object_width_mm: float | None


class SSG48Gripper:
    """The SSG-48 model.  Not thread-safe on its own: the emulator holds its lock."""

    def __init__(self, *, calibration_s: float = 1.0) -> None:
        if not isinstance(calibration_s, (int, float)) or isinstance(calibration_s, bool) \
                or not 0.0 <= float(calibration_s) <= 60.0:
            raise ParolkitValueError(f"calibration_s must be 0..60 s, got {calibration_s!r}")
        self.calibration_s = float(calibration_s)
        self.position = 0.0
        self.setpoint = 0.0
        self.speed = 0
        self.current_setpoint = 0
        self.calibrated = False
        self.activated = False
        self.action = False
        self.error = False
        self.object_width_mm: float | None = None
        self._calibrating_left = 0.0
        self._gripping = False
        self._last_msg: tuple[int, int, int, int] | None = (0, 0, 0, 0)

    # ---- PC side (once per accepted frame) ------------------------------------------------
    def on_frame(self, position: int, speed: int, current: int, command: int, mode: int) -> None:
        """Apply the gripper part of one accepted command frame."""
        if mode == GripperMode.CALIBRATE:
            self._calibrating_left = self.calibration_s
            self.calibrated = False
            self.action = False
            self._gripping = False
            if self.calibration_s == 0.0:
                self._finish_calibration()
            return
        if mode == GripperMode.CLEAR_ERROR:
            self.error = False
            return
        if mode != GripperMode.OPERATE:
            return  # other modes: the gripper ignores the message
        msg = (position, speed, current, command)
        if msg == self._last_msg:
            return  # unchanged setpoints: the board sends only a keep-alive
        self._last_msg = msg
        if command & GripperCommandBits.ESTOP:
            self.error = True
            self.action = False
            self._gripping = False
            self.setpoint = self.position
            return
        if self._calibrating_left > 0.0:
            return
        if not command & GripperCommandBits.ACTIVATE:
            self.activated = False
            self.action = False
            self.setpoint = self.position
            return
        if self.calibrated:
            self.activated = True
        if self.calibrated and not self.error and command & GripperCommandBits.MOVE:
            # the board packs the CAN message as [position u8, speed u8, current u16]: C casts
            # keep the low bits (the PC's 16-bit fields are 0..255 in practice)
            new_sp = float(position & 0xFF)
            if new_sp != self.setpoint or not self.action:
                self._gripping = False
            self.setpoint = new_sp
            self.speed = speed & 0xFF
            # the SSG-48 drives at most MAX_CURRENT_MA whatever it is asked for
            self.current_setpoint = min(current & 0xFFFF, MAX_CURRENT_MA)
            self.action = True

    def _finish_calibration(self) -> None:
        self._calibrating_left = 0.0
        self.calibrated = True
        self.activated = True
        self.error = False
        self.position = 0.0
        self.setpoint = 0.0

    # ---- physics (every emulator pass) -----------------------------------------------------
    def advance(self, dt: float) -> None:
        """Move the jaws for ``dt`` seconds."""
        if self._calibrating_left > 0.0:
            self._calibrating_left -= dt
            if self._calibrating_left <= 0.0:
                self._finish_calibration()
            return
        if not self.activated or self.error or self._gripping:
            return
        diff = self.setpoint - self.position
        if diff == 0.0:
            return
        step = jaw_rate_units_s(self.speed) * dt
        new = self.setpoint if abs(diff) <= step else self.position + math.copysign(step, diff)
        if diff > 0 and self.object_width_mm is not None:
            block = position_for_opening(self.object_width_mm)
            if self.position <= block <= new:
                new = block
                self._gripping = True
        self.position = new

    @property
    def busy(self) -> bool:
        """True when :meth:`advance` has something to do."""
        return self._calibrating_left > 0.0 or (
            self.activated and not self.error and not self._gripping
            and self.position != self.setpoint
        )

    # ---- objects ----------------------------------------------------------------------------
    def place_object(self, width_mm: float | None) -> None:
        """Put an object of ``width_mm`` (0 < w < 48 mm) between the jaws; None removes it."""
        if width_mm is None:
            self.object_width_mm = None
            self._gripping = False
            return
        if isinstance(width_mm, bool) or not isinstance(width_mm, (int, float)):
            raise ParolkitValueError(f"object width must be a number of mm, got {width_mm!r}")
        w = float(width_mm)
        if not 0.0 < w < STROKE_MM or math.isnan(w):
            raise ParolkitValueError(
                f"object width = {width_mm!r} mm is out of range: must be > 0 and < {STROKE_MM:g} mm"
            )
        if self.position > position_for_opening(w) + 1e-9:
            raise ParolkitValueError(
                f"object width = {w:g} mm does not fit: the jaws are open only "
                f"{STROKE_MM * (255 - self.position) / 255:.1f} mm (open the gripper first)"
            )
        self.object_width_mm = w

    # ---- telemetry ----------------------------------------------------------------------------
    @property
    def object_code(self) -> int:
        if self._gripping:
            return 1
        if not self.calibrated:
            return 0
        if self.position == self.setpoint and self._calibrating_left <= 0.0:
            return 3
        return 0

    @property
    def current_ma(self) -> int:
        moving = self._calibrating_left > 0.0 or (
            self.activated and not self.error and self.position != self.setpoint)
        if moving or self._gripping:
            return int(self.current_setpoint) if self.current_setpoint else REST_CURRENT_MA
        return REST_CURRENT_MA if self.calibrated else 0

    def status(self) -> GripperStatus:
        return _status(self.activated, self.action, self.object_code, self.error, self.calibrated)[0]

    def status_byte(self) -> int:
        """:meth:`status` as the status frame's byte."""
        return _status(self.activated, self.action, self.object_code, self.error, self.calibrated)[1]

    def state(self) -> GripperState:
        return GripperState(
            position=int(round(self.position)),
            current_ma=self.current_ma,
            status=self.status(),
            setpoint=int(round(self.setpoint)),
            object_width_mm=self.object_width_mm,
        )


@functools.cache
def _status(activated: bool, action: bool, object_code: int, error: bool,
            calibrated: bool) -> tuple[GripperStatus, int]:
    """The status and its byte (a few dozen combinations: each made once, the reply of every
    frame reads it)."""
    st = GripperStatus(activated=activated, action=action, object_code=object_code, temperature_error=False,
                       timeout_error=False, estop_error=error, calibrated=calibrated)
    return st, st.to_byte()
