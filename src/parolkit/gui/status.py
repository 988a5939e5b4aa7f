"""Readout formatting of the controller's status for the commander (presentation only).

The status itself is the client's :class:`parolkit.client.core.RobotStatus` (parsed and
validated by the client, shared with every other client user); this module only turns it
into the strings and badge colours the page shows (units: deg, mm, deg/s, ms).
"""

from __future__ import annotations

from collections.abc import Sequence

from parolkit.client.core import GripperState, LoopStats, RobotState, RobotStatus

__all__ = [
    "POSE_LABELS",
    "POSE_READOUTS",
    "POSE_UNITS",
    "format_angles",
    "format_pose",
    "format_speeds",
    "format_bits",
    "format_loop",
    "format_gripper",
    "gripper_summary",
    "state_badge",
]

#: The TCP pose readouts: (name, index into the pose [x, y, z, A, B, C], the pose's own name
#: of the value).  The pose's orientation is R = Rx(C) · Ry(B) · Rz(A) (docs/kinematics.md),
#: so each angle is named after the axis it turns about, as the Cartesian jog names its axes:
#: RX is C (a WRF RX jog changes C alone), RY is B, RZ is A (a TRF RZ jog changes A alone).
#: The original GUI labelled A, B, C "Rx, Ry, Rz" in that order: jogging RX changed its "Rz".
POSE_READOUTS = (("X", 0, "x"), ("Y", 1, "y"), ("Z", 2, "z"), ("RX", 5, "C"), ("RY", 4, "B"), ("RZ", 3, "A"))
#: the readouts' names, as the Cartesian jog names its axes
POSE_LABELS = tuple(name for name, _, _ in POSE_READOUTS)
POSE_UNITS = ("mm", "mm", "mm", "°", "°", "°")


# ------------------------------------------------------------------------------------------
# readout formatting
# ------------------------------------------------------------------------------------------


def format_angles(angles: Sequence[float]) -> list[str]:
    """Joint angles as 'J1  90.000°' style strings (3 decimals, degrees)."""
    return [f"{a:+.3f}°" for a in angles]


def format_pose(pose: Sequence[float]) -> list[str]:
    """The readouts of the TCP pose [x, y, z, A, B, C] in :data:`POSE_READOUTS` order: X, Y, Z
    in mm (2 decimals), RX (= C), RY (= B), RZ (= A) in degrees (3 decimals)."""
    return [f"{pose[i]:+.2f} mm" if i < 3 else f"{pose[i]:+.3f}°" for _, i, _ in POSE_READOUTS]


def format_speeds(speeds_deg_s: Sequence[float]) -> list[str]:
    """Joint speeds in deg/s, one decimal."""
    return [f"{v:+.1f} °/s" for v in speeds_deg_s]


def format_bits(bits: Sequence[bool], on: str = "1", off: str = "0") -> str:
    """A bit vector as a compact string, e.g. '1 1 0 1 1 1'."""
    return " ".join(on if b else off for b in bits)


def format_loop(loop: LoopStats) -> str:
    """One line of loop statistics, e.g. '100 Hz · p50 10.00 ms · p99 10.40 ms · 0 overruns';
    fields the controller did not report (absent from ``loop.raw``) are left out."""
    have = loop.raw
    parts: list[str] = []
    if "rate_hz" in have:
        parts.append(f"{loop.rate_hz:.0f} Hz")
    if "period_p50_ms" in have:
        parts.append(f"p50 {loop.period_p50_ms:.2f} ms")
    if "period_p99_ms" in have:
        parts.append(f"p99 {loop.period_p99_ms:.2f} ms")
    if "period_max_ms" in have:
        parts.append(f"max {loop.period_max_ms:.2f} ms")
    if "overruns" in have:
        parts.append(f"{loop.overruns} overruns")
    return " · ".join(parts) if parts else "n/a"


#: The SSG-48's object code (status byte bits 5 and 4, :attr:`GripperState.object_code`) in words.
_GRIPPER_MOTION = {
    0: "moving",
    1: "holding an object (stopped on it while closing)",
    2: "holding an object (stopped on it while opening)",
    3: "at its position, no object",
}


def _gripper_errors(g: GripperState) -> list[str]:
    bits = []
    if g.error:
        bits.append("E-stop")
    if g.timeout_error:
        bits.append("timeout")
    if g.temperature_error:
        bits.append("over-temperature")
    return bits


def gripper_summary(g: GripperState) -> str:
    """The SSG-48 in a few words for the always-visible readout, e.g. 'Gripper 100 · at its
    position, no object', 'Gripper 87 · moving', 'Gripper · not calibrated', 'Gripper 12 ·
    error: timeout' (position 0..255)."""
    errors = _gripper_errors(g)
    if errors:
        return f"Gripper {g.position} · error: {', '.join(errors)}"
    if not g.calibrated:
        return "Gripper · not calibrated"
    motion = _GRIPPER_MOTION.get(g.object_code, f"object code {g.object_code}")
    return f"Gripper {g.position} · {motion.split(' (')[0]}"


def format_gripper(g: GripperState) -> str:
    """The SSG-48's full readout in words: position and speed (0..255), current (mA), whether
    it is calibrated, its errors and what its jaws are doing."""
    errors = _gripper_errors(g)
    state = "calibrated" if g.calibrated else "not calibrated"
    if errors:
        state += " · error: " + ", ".join(errors)
    text = f"position {g.position} · speed {g.speed} · current {g.current} mA · {state}"
    if g.calibrated:  # the jaws' state means nothing before calibration
        text += " · " + _GRIPPER_MOTION.get(g.object_code, f"object code {g.object_code}")
    return text


def state_badge(status: RobotStatus | None, link_up: bool, program: str | None = None) -> tuple[str, str]:
    """(text, colour) for the state badge; colour is a Quasar colour: 'positive', 'warning',
    'negative', 'info' or 'grey-8'.  ``program``: the program runner's state while a program
    runs ("running", "pausing", "paused"), else None: PROGRAM RUNNING / PROGRAM PAUSING (Pause
    pressed, the controller paused, the arm still slowing down on its path) / PROGRAM PAUSED
    then, through its moves, Delay and Output lines alike (only a fault or DISABLED says more).
    With no program of ours, PAUSED while the controller is paused (another client's PAUSE:
    nothing moves on until RESUME)."""
    if not link_up or status is None:
        return "NO LINK", "grey-8"
    if status.estop_latched or status.estop_pressed or status.state is RobotState.ESTOP:
        return "E-STOP", "negative"
    if status.state is RobotState.ERROR or status.errors.message:
        return "ERROR", "negative"
    if status.state is RobotState.DISCONNECTED:
        return "BOARD LOST", "negative"
    if not status.enabled or status.state is RobotState.DISABLED:
        return "DISABLED", "warning"
    if program == "paused":
        return "PROGRAM PAUSED", "warning"
    if program == "pausing" and status.paused:
        return "PROGRAM PAUSING", "warning"
    if program is not None:
        return "PROGRAM RUNNING", "info"
    if status.paused:
        return "PAUSED", "warning"
    if status.state is RobotState.HOMING:
        return "HOMING", "warning"
    if not status.all_homed:
        return "NOT HOMED", "warning"
    if status.state is RobotState.MOVING:
        return "MOVING", "info"
    return "READY", "positive"
