"""The PAROL6 URDF, generated from :data:`parolkit.robot.PAROL6` (the one source of constants).

Kinematics: one URDF joint per DH row.  With the standard DH convention
``T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``, link ``Li`` (child of joint ``Li``) is DH frame
``i-1`` turned by ``Rz(q_i)``; joint ``L(i+1)``'s origin is the rest of row ``i``,
``Tz(d_i) Tx(a_i) Rx(alpha_i)``.  Joint ``L1``'s origin is the base frame.  Joint values are
therefore exactly parolkit's joint angles (radians here, degrees in the rest of parolkit):
``/joint_states`` published by :mod:`parolkit.ros2.bridge` drives this model with no offsets.

Row 6 carries the original commander's tool point: link ``flange`` is DH frame 6 with row 6's
``d`` and ``a`` left out (as :func:`parolkit.kinematics.fk_frames`); link ``tcp`` is the
flange with the tool applied (:data:`parolkit.kinematics.TOOLS` ``['default']`` unless another
tool is given).

Limits: ``lower``/``upper`` are :attr:`RobotModel.safe_limits_deg` in radians (the range the
planner and the wire guard both accept), ``velocity`` is what the controller accepts for a
trajectory (:func:`trajectory_velocity_limits_rad_s`: the position-tracking maximum of
:meth:`RobotModel.max_tracked_speed_steps_s` at the control rate, 76 % of the maximum speed at
100 Hz), in rad/s, so a plan within the URDF's limits runs on time.  ``effort`` is not known
for the PAROL6 steppers; the URDF format requires it, and it is written as 0 with a comment
saying so.

Joint convention (:mod:`parolkit.ros2.convention`): with ``community`` each joint's zero and
direction are those of the community PAROL6 URDF: joint ``Li``'s origin gets the fixed turn
``Rz(-sign * offset)`` appended and its axis is ``0 0 sign``, so the links (and every shape on
them) are where they are in parolkit's convention and only the joint values differ
(``q_comm = sign * q + offset``); the limits are mapped the same way.

Visual geometry is simple (cylinders along each link's DH offsets) and has no mass data: the
model is for display (RViz) and planning (MoveIt), not for dynamics simulation.

Collision geometry is parolkit's own collision model (:class:`parolkit.collision.CollisionModel`,
docs/collision.md), so ROS tools check the same shapes as the controller: the base box as a
``<box>`` on ``base_link``; each link capsule (and the tool's, ``[tools.NAME] shape``) as a
``<cylinder>`` along its axis plus a ``<sphere>`` at each end (URDF has no capsule; the three
together are exactly the capsule).  A body of DH frame ``i`` (1..5) sits on link ``Li`` through
the fixed rest of DH row ``i``, ``Tz(d_i) Tx(a_i) Rx(alpha_i)`` (link ``Li`` is DH frame ``i-1``
turned by ``Rz(q_i)``); the flange's bodies (the J6 link, the tool) sit on link ``flange``,
which is DH frame 6 itself.  Held objects are not in the URDF (they come and go at run time).
"""

from __future__ import annotations

import math
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import NDArray

from parolkit.collision.model import Body, CollisionModel, tool_body
from parolkit.config import Config, ControllerSettings, ToolSettings
from parolkit.kinematics.tools import Tool, get_tool
from parolkit.robot import NUM_JOINTS, PAROL6, DHRow, RobotModel
from parolkit.ros2.convention import PAROLKIT, JointConvention, get_convention

__all__ = ["ROS_JOINT_NAMES", "BASE_LINK", "FLANGE_LINK", "TCP_LINK", "make_urdf", "rot_to_rpy",
           "collision_link", "dh_frame_in_link", "trajectory_velocity_limits_rad_s", "urdf_rate_hz",
           "urdf_convention", "tool_settings"]

#: Joint names as the community PAROL6 MoveIt configuration spells them.
ROS_JOINT_NAMES = tuple(f"L{i + 1}" for i in range(NUM_JOINTS))
BASE_LINK = "base_link"
FLANGE_LINK = "flange"
TCP_LINK = "tcp"
#: Radius of the display cylinders, metres.
_RADIUS_M = 0.02


def trajectory_velocity_limits_rad_s(model: RobotModel, rate_hz: float) -> NDArray[np.float64]:
    """The joint speeds (rad/s, J1..J6) a trajectory may ask for at control rate ``rate_hz``:
    the position-tracking maximum the controller's planner checks every sample of a joint path
    against (:meth:`RobotModel.max_tracked_speed_steps_s`), the URDF's ``velocity`` limits."""
    out: NDArray[np.float64] = model.max_tracked_speed_steps_s(rate_hz) / model.steps_per_rad
    return out


def urdf_rate_hz(config: Config | None, rate_hz: float | None = None) -> float:
    """The control rate (Hz) the velocity limits are for: ``rate_hz``, else the config's
    ``[controller] rate_hz``, else the default controller's."""
    if rate_hz is not None:
        return float(rate_hz)
    return float((config.controller if config is not None else ControllerSettings()).rate_hz)


def urdf_convention(config: Config | None, convention: str | JointConvention | None = None) -> JointConvention:
    """The joint convention: ``convention``, else the config's ``[ros2] joint_convention``,
    else parolkit's own."""
    if convention is not None:
        return get_convention(convention)
    return get_convention(config.ros2.joint_convention) if config is not None else PAROLKIT


def _joint_rpy(alpha: float, turn: float) -> tuple[float, float, float]:
    """rpy of ``Rx(alpha) Rz(turn)`` (a joint origin's DH twist, then a convention's fixed turn)."""
    if turn == 0.0:
        return (alpha, 0.0, 0.0)
    ca, sa, ct, st = math.cos(alpha), math.sin(alpha), math.cos(turn), math.sin(turn)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    rz = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    roll, pitch, yaw = (v if abs(v) > 1e-15 else 0.0 for v in rot_to_rpy(rx @ rz))  # sin(pi) dust as 0
    return (roll, pitch, yaw)


def rot_to_rpy(r: NDArray[np.float64]) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (rad) of a 3x3 rotation: ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    pitch = math.atan2(-float(r[2, 0]), math.hypot(float(r[0, 0]), float(r[1, 0])))
    if math.cos(pitch) > 1e-9:
        roll = math.atan2(float(r[2, 1]), float(r[2, 2]))
        yaw = math.atan2(float(r[1, 0]), float(r[0, 0]))
    else:  # gimbal lock: put everything in yaw
        roll = 0.0
        yaw = math.atan2(-float(r[0, 1]), float(r[1, 1]))
    return roll, pitch, yaw


def _num(v: float) -> str:
    """A float for XML: 17 significant digits round-trip exactly; -0 written as 0."""
    return repr(float(v) + 0.0)


def _origin(xyz: tuple[float, float, float], rpy: tuple[float, float, float]) -> str:
    return (f'<origin xyz="{" ".join(_num(v) for v in xyz)}" '
            f'rpy="{" ".join(_num(v) for v in rpy)}"/>')


def _link(name: str, visuals: list[str], collisions: list[str] | None = None) -> str:
    elements = visuals + (collisions or [])
    if not elements:
        return f"  <link name={quoteattr(name)}/>"
    body = "\n".join(elements)
    return f"  <link name={quoteattr(name)}>\n{body}\n  </link>"


def collision_link(frame: int) -> str:
    """The URDF link a collision body of DH frame ``frame`` (0 base .. 6 flange) sits on."""
    if frame == 0:
        return BASE_LINK
    if 1 <= frame < NUM_JOINTS:
        return ROS_JOINT_NAMES[frame - 1]
    if frame == NUM_JOINTS:
        return FLANGE_LINK
    raise ValueError(f"frame must be 0..{NUM_JOINTS}, got {frame!r}")


def dh_frame_in_link(model: RobotModel, frame: int) -> NDArray[np.float64]:
    """The 4x4 pose (metres) of DH frame ``frame`` in its link :func:`collision_link` (frame):
    the identity for the base (0) and the flange (6); for 1..5 the rest of DH row ``frame``
    after its joint's turn, ``Tz(d) Tx(a) Rx(alpha)``."""
    if frame in (0, NUM_JOINTS):
        return np.eye(4)
    row: DHRow = model.dh[frame - 1]
    ca, sa = math.cos(row.alpha), math.sin(row.alpha)
    return np.array([[1.0, 0.0, 0.0, row.a],
                     [0.0, ca, -sa, 0.0],
                     [0.0, sa, ca, row.d],
                     [0.0, 0.0, 0.0, 1.0]])


def _collision(name: str, xyz: tuple[float, float, float], rpy: tuple[float, float, float], geometry: str) -> str:
    return (f"    <collision name={quoteattr(name)}>\n      {_origin(xyz, rpy)}\n"
            f"      <geometry>{geometry}</geometry>\n    </collision>")


def _point(m: NDArray[np.float64], p_mm: tuple[float, float, float]) -> NDArray[np.float64]:
    """``p_mm`` (mm, in a DH frame) in its link, metres; rounding dust below 1e-15 m (1e-12
    mm, what the FK's exact right angles leave) written as 0, so an axis along z reads as z."""
    out: NDArray[np.float64] = m[:3, :3] @ (np.asarray(p_mm, dtype=np.float64) / 1000.0) + m[:3, 3]
    out[np.abs(out) < 1e-15] = 0.0
    return out


def _xyz(v: NDArray[np.float64]) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _body_collisions(model: RobotModel, body: Body) -> list[str]:
    """``<collision>`` elements of one body in its link's frame (metres): a box, or a capsule as
    a cylinder along its axis and a sphere at each end (one sphere for a zero-length axis)."""
    m = dh_frame_in_link(model, body.frame)
    if body.size is not None:
        size = " ".join(_num(v / 1000.0) for v in body.size)
        return [_collision(body.name, _xyz(_point(m, body.start)), (0.0, 0.0, 0.0), f'<box size="{size}"/>')]
    a, b = _point(m, body.start), _point(m, body.end)
    radius = f'radius="{_num(body.radius / 1000.0)}"'
    axis = b - a
    length = float(np.linalg.norm(axis))
    if length < 1e-12:
        return [_collision(body.name, _xyz(a), (0.0, 0.0, 0.0), f"<sphere {radius}/>")]
    # the cylinder's z along the axis: Rz(yaw) Ry(pitch) turns z to (cos y sin p, sin y sin p, cos p)
    pitch = math.atan2(math.hypot(float(axis[0]), float(axis[1])), float(axis[2]))
    yaw = math.atan2(float(axis[1]), float(axis[0]))
    return [
        _collision(body.name, _xyz((a + b) / 2), (0.0, pitch, yaw),
                   f'<cylinder {radius} length="{_num(length)}"/>'),
        _collision(f"{body.name} start", _xyz(a), (0.0, 0.0, 0.0), f"<sphere {radius}/>"),
        _collision(f"{body.name} end", _xyz(b), (0.0, 0.0, 0.0), f"<sphere {radius}/>"),
    ]


def tool_settings(tool: str | Tool | None, config: Config | None) -> ToolSettings | None:
    """The config entry of ``tool`` (by name), whose shape is the tool's body; None if none."""
    name = tool if isinstance(tool, str) else (tool.name if isinstance(tool, Tool) else None)
    if name is None or config is None:
        return None
    return next((t for t in config.tools if t.name == name), None)


def _cylinder(length: float, along: str, z_offset: float = 0.0) -> str | None:
    """A display cylinder of ``length`` metres (signed) from the link origin along its z axis
    (``along="z"``) or along x at height ``z_offset`` (``along="x"``); None for length 0."""
    if abs(length) < 1e-9:
        return None
    if along == "z":
        xyz, rpy = (0.0, 0.0, length / 2), (0.0, 0.0, 0.0)
    else:
        xyz, rpy = (length / 2, 0.0, z_offset), (0.0, math.pi / 2, 0.0)
    return (f"    <visual>\n      {_origin(xyz, rpy)}\n"
            f'      <geometry><cylinder radius="{_num(_RADIUS_M)}" length="{_num(abs(length))}"/></geometry>\n'
            f'      <material name="parol_grey"/>\n    </visual>')


def make_urdf(model: RobotModel = PAROL6, tool: str | Tool | None = None, name: str = "parol6",
              config: Config | None = None, collision_model: CollisionModel | None = None, *,
              rate_hz: float | None = None, convention: str | JointConvention | None = None) -> str:
    """The URDF document (XML text) of ``model`` with ``tool`` at link ``tcp`` (a name is
    looked up in ``config.tools``, then the built-in tools), and the collision shapes of
    ``collision_model`` (default: the stock envelope on ``model``) plus the tool's body when
    its config entry has a ``shape`` (module docstring).  ``rate_hz``: the control rate the
    velocity limits are for (:func:`urdf_rate_hz`); ``convention``: the joint convention
    (:func:`urdf_convention`)."""
    dh = model.dh
    cm = collision_model if collision_model is not None else CollisionModel(model)
    settings = tool_settings(tool, config)
    tb = tool_body(settings)
    collisions: dict[str, list[str]] = {}
    for body in (*cm.bodies, *((tb,) if tb is not None else ())):
        collisions.setdefault(collision_link(body.frame), []).extend(_body_collisions(model, body))
    conv = urdf_convention(config, convention)
    limits_rad = np.radians(conv.limits_deg(model.safe_limits_deg))
    vel_rad_s = trajectory_velocity_limits_rad_s(model, urdf_rate_hz(config, rate_hz))
    out = [
        '<?xml version="1.0"?>',
        "<!-- Generated by `parolkit urdf` from parolkit.robot (DH table, limits, speeds). Do not edit. -->",
        *((f"<!-- Joint convention: {conv.name} (parolkit.ros2.convention) -->",) if not conv.is_identity else ()),
        f"<robot name={quoteattr(name)}>",
        '  <material name="parol_grey"><color rgba="0.75 0.75 0.78 1"/></material>',
        _link(BASE_LINK, [v for v in (_cylinder(dh[0].d, "z"),) if v], collisions.get(BASE_LINK)),
    ]
    parent = BASE_LINK
    for i, jname in enumerate(ROS_JOINT_NAMES):
        sign = conv.signs[i]
        turn = -sign * math.radians(conv.offsets_deg[i])  # q = sign * q_ros + turn
        if i == 0:
            xyz, rpy = (0.0, 0.0, 0.0), _joint_rpy(0.0, turn)
        else:
            prev = dh[i - 1]
            xyz, rpy = (prev.a, 0.0, prev.d), _joint_rpy(prev.alpha, turn)
        lo, hi = (float(v) for v in limits_rad[i])
        out.append(
            f'  <joint name={quoteattr(jname)} type="revolute">\n'
            f"    <parent link={quoteattr(parent)}/>\n    <child link={quoteattr(jname)}/>\n"
            f"    {_origin(xyz, rpy)}\n"
            f'    <axis xyz="0 0 {1 if sign > 0 else -1}"/>\n'
            "    <!-- effort: not known for the PAROL6 steppers (URDF requires the attribute) -->\n"
            f'    <limit lower="{_num(lo)}" upper="{_num(hi)}" velocity="{_num(float(vel_rad_s[i]))}" effort="0"/>\n'
            "  </joint>")
        row = dh[i]
        d, a = (row.d, row.a) if i < NUM_JOINTS - 1 else (0.0, 0.0)
        visuals = [v for v in (_cylinder(d, "z"), _cylinder(a, "x", d)) if v]
        if i == 0:
            visuals = [v for v in (_cylinder(a, "x", d),) if v]  # the column is drawn on base_link
        out.append(_link(jname, visuals, collisions.get(jname)))
        parent = jname
    # flange: the rest of row 6 without its tool point (d and a), as fk_frames' frame 6
    out.append(
        f'  <joint name="flange_joint" type="fixed">\n    <parent link={quoteattr(parent)}/>\n'
        f"    <child link={quoteattr(FLANGE_LINK)}/>\n"
        f"    {_origin((0.0, 0.0, 0.0), (dh[-1].alpha, 0.0, 0.0))}\n  </joint>")
    out.append(_link(FLANGE_LINK, [], collisions.get(FLANGE_LINK)))
    t = get_tool(tool, config).matrix
    out.append(
        f'  <joint name="tcp_joint" type="fixed">\n    <parent link={quoteattr(FLANGE_LINK)}/>\n'
        f"    <child link={quoteattr(TCP_LINK)}/>\n"
        f"    {_origin((float(t[0, 3]), float(t[1, 3]), float(t[2, 3])), rot_to_rpy(t[:3, :3]))}\n  </joint>")
    out.append(_link(TCP_LINK, []))
    out.append("</robot>")
    return "\n".join(out) + "\n"
