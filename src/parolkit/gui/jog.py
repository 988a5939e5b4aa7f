"""Jog logic: command building, limit blocking and the keyboard map (no UI imports).

Units: joint angles in deg, positions in mm, orientations in deg, speeds/accelerations in %.
A *continuous* jog is streamed (``STREAM|ON``, then a JOG/CARTJOG with a short duration
every :data:`JOG_REPEAT_S` while the button is held); a *step* jog is one MOVEJOINT /
MOVECART / MOVECARTRELTRF to a target a fixed increment away.

Jogs are the :mod:`parolkit.moves` value objects (:class:`~parolkit.moves.JointJog`,
:class:`~parolkit.moves.CartJog`, with :class:`~parolkit.moves.Frame` and
:class:`~parolkit.moves.CartAxis`); :func:`jog_command` writes one as its datagram.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from parolkit.errors import ParolkitValueError
from parolkit.moves import CartAxis, CartJog, Frame, JointJog
from parolkit.robot import JOINT_NAMES, PAROL6, RobotModel

__all__ = [
    "jog_command",
    "JOG_REPEAT_S",
    "JOG_DURATION_S",
    "LIMIT_MARGIN_DEG",
    "joint_jog_blocked",
    "joint_step_target",
    "cart_step_command",
    "cart_jog_blocked",
    "jog_target_pose",
    "rpy_to_matrix",
    "matrix_to_rpy",
    "KeyBinding",
    "KEYMAP",
    "key_action",
]

#: While a jog button is held, a new streamed jog is sent this often, s (one per control
#: tick: the controller's stream watchdog, ``controller.stream_watchdog_s``, is 20 ms).
JOG_REPEAT_S = 0.01
#: Duration of each streamed jog, s (longer than the repeat so motion is continuous; the
#: controller's watchdog stops motion when updates stop).
JOG_DURATION_S = 0.2
#: A joint this close to a limit (deg) counts as "at the limit": jogging further is blocked.
LIMIT_MARGIN_DEG = 0.05


def _percent(value: float, name: str) -> float:
    v = float(value)
    if not math.isfinite(v) or not 0.0 < v <= 100.0:
        raise ParolkitValueError(f"{name} must be in (0, 100] %, got {value!r}")
    return v


def _joint(joint: int) -> int:
    if isinstance(joint, bool) or not isinstance(joint, int) or not 0 <= joint < 6:
        raise ParolkitValueError(f"joint must be an index 0..5 (J1..J6), got {joint!r}")
    return joint


def jog_command(jog: JointJog | CartJog) -> str:
    """The datagram body (no ID) of a jog: ``JOG`` for one joint, ``MULTIJOG`` for several,
    ``CARTJOG`` for a Cartesian jog.  Numbers in their shortest form (``30``, ``0.2``)."""
    if isinstance(jog, CartJog):
        frame, axis = Frame.parse(jog.frame), CartAxis.parse(jog.axis)
        return f"CARTJOG|{frame.value}|{axis.value}|{jog.speed_pct:g}|{jog.duration_s:g}"
    if len(jog.joints) == 1:
        duration = "None" if jog.duration_s is None else f"{jog.duration_s:g}"
        distance = "None" if jog.distance_deg is None else f"{jog.distance_deg:g}"
        return f"JOG|{jog.wire_indices[0]}|{jog.speed_pct[0]:g}|{duration}|{distance}"
    # several joints: JointJog guarantees duration_s (a distance is for one joint only)
    indices = ",".join(str(i) for i in jog.wire_indices)
    speeds = ",".join(f"{p:g}" for p in jog.speed_pct)
    return f"MULTIJOG|{indices}|{speeds}|{jog.duration_s:g}"


def joint_jog_blocked(angles_deg: Sequence[float], joint: int, direction: int,
                      model: RobotModel = PAROL6, margin_deg: float = LIMIT_MARGIN_DEG) -> bool:
    """True when joint ``joint`` cannot move further in ``direction`` (+1/-1): it is within
    ``margin_deg`` of the corresponding (safe) limit."""
    _joint(joint)
    limits = model.safe_limits_deg[joint]
    lo, hi = float(limits[0]), float(limits[1])
    a = float(angles_deg[joint])
    return a >= hi - margin_deg if direction > 0 else a <= lo + margin_deg


def joint_step_target(angles_deg: Sequence[float], joint: int, step_deg: float,
                      model: RobotModel = PAROL6) -> list[float]:
    """The joint target of an incremental joint jog; raises if it leaves the joint range."""
    _joint(joint)
    if not math.isfinite(step_deg) or step_deg == 0:
        raise ParolkitValueError(f"step must be a non-zero number of degrees, got {step_deg!r}")
    target = [float(a) for a in angles_deg]
    target[joint] += step_deg
    lo, hi = model.safe_limits_deg[joint]
    if not lo <= target[joint] <= hi:
        raise ParolkitValueError(
            f"{JOINT_NAMES[joint]} step to {target[joint]:.3f}° leaves the range {lo:.3f} .. {hi:.3f}°")
    return target


# ---- pose maths (convention: R = Rx(C) @ Ry(B) @ Rz(A), angles in degrees) ----

Matrix = list[list[float]]


def _mul(a: Matrix, b: Matrix) -> Matrix:
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _rot(axis: int, deg: float) -> Matrix:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    if axis == 0:
        return [[1, 0, 0], [0, c, -s], [0, s, c]]
    if axis == 1:
        return [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def rpy_to_matrix(a_deg: float, b_deg: float, c_deg: float) -> Matrix:
    """Rotation matrix of pose angles A, B, C (deg): Rx(C) @ Ry(B) @ Rz(A)."""
    return _mul(_mul(_rot(0, c_deg), _rot(1, b_deg)), _rot(2, a_deg))


def matrix_to_rpy(r: Matrix) -> tuple[float, float, float]:
    """Inverse of :func:`rpy_to_matrix`: (A, B, C) in degrees, B in [-90, 90]."""
    # R = Rx(C) Ry(B) Rz(A): r[0][2] = sin B, r[0][0] = cos B cos A, r[0][1] = -cos B sin A,
    # r[1][2] = -sin C cos B, r[2][2] = cos C cos B
    sb = max(-1.0, min(1.0, r[0][2]))
    b = math.asin(sb)
    if abs(sb) < 1.0 - 1e-9:
        a = math.atan2(-r[0][1], r[0][0])
        c = math.atan2(-r[1][2], r[2][2])
    else:  # gimbal lock: put everything into A
        c = 0.0
        a = math.atan2(r[1][0], r[1][1])
    return math.degrees(a), math.degrees(b), math.degrees(c)


def jog_target_pose(pose: Sequence[float], frame: Frame, axis: CartAxis, step: float) -> tuple[float, ...]:
    """The pose (mm, deg) ``step`` mm / deg from ``pose`` along / about ``axis`` of ``frame``.

    WRF: translate along the world axis, or rotate about the world axis through the TCP
    (pre-multiplied).  TRF: translate along / rotate about the tool's own axis
    (post-multiplied)."""
    x, y, z, a, b, c = (float(v) for v in pose)
    r = rpy_to_matrix(a, b, c)
    sgn_step = axis.sign * step
    if axis.is_rotation:
        d = _rot(axis.axis_index, sgn_step)
        r = _mul(d, r) if frame is Frame.WRF else _mul(r, d)
        a, b, c = matrix_to_rpy(r)
    else:
        v = [0.0, 0.0, 0.0]
        v[axis.axis_index] = sgn_step
        if frame is Frame.TRF:
            v = [sum(r[i][k] * v[k] for k in range(3)) for i in range(3)]
        x, y, z = x + v[0], y + v[1], z + v[2]
    return (x, y, z, a, b, c)


#: how far ahead (mm / deg) :func:`cart_jog_blocked` probes
PROBE_MM = 3.0
PROBE_DEG = 2.0


def cart_jog_blocked(pose: Sequence[float], angles_deg: Sequence[float], frame: Frame, axis: CartAxis,
                     solve: Callable[[Sequence[float], Sequence[float]], object]) -> bool:
    """True when a Cartesian jog from ``pose`` along ``axis`` cannot go on: the pose a small
    step ahead has no IK solution inside the joint limits near the current joints.

    ``solve(pose, seed_deg) -> joints_deg`` raises (any :class:`ParolkitError` / ValueError)
    when the pose is unreachable (e.g. ``parolkit.kinematics.ik``)."""
    step = PROBE_DEG if axis.is_rotation else PROBE_MM
    target = jog_target_pose(pose, frame, axis, step)
    from parolkit.errors import ParolkitError

    try:
        solve(target, angles_deg)
    except (ParolkitError, ValueError, ArithmeticError):  # IKError is a ParolkitError
        return True
    return False


def cart_step_command(pose: Sequence[float], frame: Frame, axis: CartAxis, step: float,
                      speed_percent: float) -> str:
    """The datagram body of an incremental Cartesian jog.

    ``step`` is mm for translations and degrees for rotations (positive; the axis gives the
    sign).  WRF: a MOVECART to the pose moved along / rotated about the world axis (rotation
    about the TCP point, pre-multiplied).  TRF: a MOVECARTRELTRF (post-multiplied, in the
    tool frame).
    """
    if not math.isfinite(step) or step <= 0:
        raise ParolkitValueError(f"step must be a positive number (mm or deg), got {step!r}")
    _percent(speed_percent, "speed_percent")
    delta = [0.0] * 6
    delta[(3 if axis.is_rotation else 0) + axis.axis_index] = axis.sign * step
    if frame is Frame.TRF:
        return "MOVECARTRELTRF|" + "|".join(f"{v:g}" for v in delta) + f"|None|{speed_percent:g}"
    target = jog_target_pose(pose, frame, axis, step)
    return "MOVECART|" + "|".join(f"{v:.4f}" for v in target) + f"|None|{speed_percent:g}"


# ---- keyboard map ----


@dataclass(frozen=True)
class KeyBinding:
    """A keyboard shortcut: ``key`` (KeyboardEvent.key, lower-case for letters) -> action.

    ``action`` is ``"estop"``, ``"stop"``, ``"joint"`` (with ``joint``, ``direction``) or
    ``"cart"`` (with ``axis``; frame = the panel's current frame).
    """

    key: str
    action: str
    description: str
    joint: int | None = None
    direction: int = 0
    axis: CartAxis | None = None


def _joint_keys() -> list[KeyBinding]:
    out = []
    for j, (plus, minus) in enumerate(zip("qwerty", "asdfgh")):
        out.append(KeyBinding(plus, "joint", f"jog {JOINT_NAMES[j]} +", joint=j, direction=1))
        out.append(KeyBinding(minus, "joint", f"jog {JOINT_NAMES[j]} −", joint=j, direction=-1))
    return out


#: Every shortcut of the commander (shown in the help dialog).
KEYMAP: tuple[KeyBinding, ...] = (
    KeyBinding("escape", "estop", "E-STOP (software stop, latched until Enable)"),
    KeyBinding(" ", "stop", "stop motion (cancel the queue)"),
    *_joint_keys(),
    KeyBinding("arrowright", "cart", "Cartesian X +", axis=CartAxis.X_POS),
    KeyBinding("arrowleft", "cart", "Cartesian X −", axis=CartAxis.X_NEG),
    KeyBinding("arrowup", "cart", "Cartesian Y +", axis=CartAxis.Y_POS),
    KeyBinding("arrowdown", "cart", "Cartesian Y −", axis=CartAxis.Y_NEG),
    KeyBinding("pageup", "cart", "Cartesian Z +", axis=CartAxis.Z_POS),
    KeyBinding("pagedown", "cart", "Cartesian Z −", axis=CartAxis.Z_NEG),
    KeyBinding("i", "cart", "Cartesian RX +", axis=CartAxis.RX_POS),
    KeyBinding("k", "cart", "Cartesian RX −", axis=CartAxis.RX_NEG),
    KeyBinding("o", "cart", "Cartesian RY +", axis=CartAxis.RY_POS),
    KeyBinding("l", "cart", "Cartesian RY −", axis=CartAxis.RY_NEG),
    KeyBinding("p", "cart", "Cartesian RZ +", axis=CartAxis.RZ_POS),
    KeyBinding(";", "cart", "Cartesian RZ −", axis=CartAxis.RZ_NEG),
)

_BY_KEY = {b.key: b for b in KEYMAP}
assert len(_BY_KEY) == len(KEYMAP), "duplicate key in KEYMAP"


def key_action(key: str) -> KeyBinding | None:
    """The binding of a KeyboardEvent.key value (case-insensitive), or None."""
    if not isinstance(key, str) or not key:
        return None
    return _BY_KEY.get(key if key == " " else key.lower())


def key_label(key: str) -> str:
    """How a key is shown in the help dialog."""
    names = {"escape": "Esc", " ": "Space", "arrowright": "→", "arrowleft": "←", "arrowup": "↑",
             "arrowdown": "↓", "pageup": "PgUp", "pagedown": "PgDn"}
    return names.get(key, key.upper())
