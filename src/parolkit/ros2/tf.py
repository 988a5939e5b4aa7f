"""The robot's TF tree from its URDF: what robot_state_publisher would broadcast, without ROS.

:class:`TfTree` reads the joints of a URDF (the one :func:`parolkit.ros2.urdf.make_urdf`
writes and ``/robot_description`` carries, so the frames are that URDF's links in its joint
convention) and gives

* :meth:`TfTree.static_transforms`: the fixed frames, for ``/tf_static`` (transient local):
  ``world`` -> ``base_link`` (the identity: the robot's base is the world frame; another
  placement is a static transform of the user's) and every fixed joint of the URDF
  (``L6`` -> ``flange``, ``flange`` -> ``tcp``: the tool the URDF was made with);
* :meth:`TfTree.transforms`: the moving frames for one set of joint positions (radians, in
  the URDF's convention), for ``/tf``: ``base_link`` -> ``L1`` ... ``L5`` -> ``L6``.

A revolute joint's transform is its origin (``xyz``, ``rpy``) followed by the rotation about
its axis by the joint position, as robot_state_publisher computes it.  Every robot frame gets
the same ``frame_prefix`` (e.g. ``"parol6/"``: ``parol6/base_link``), as robot_state_publisher's
``frame_prefix`` parameter does; ``world`` is shared by every robot and gets none.

Plain floats and the standard library: it runs at the status rate.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

from parolkit.errors import ParolkitValueError

__all__ = ["WORLD_FRAME", "Quat", "Vec3", "UrdfJoint", "FrameTransform", "TfTree", "urdf_joints",
           "check_frame_prefix", "quat_from_rpy", "quat_multiply", "quat_about_axis"]

#: the frame the robot's base is placed in (no prefix)
WORLD_FRAME = "world"

Vec3 = tuple[float, float, float]
#: a unit quaternion (x, y, z, w), as geometry_msgs/Quaternion
Quat = tuple[float, float, float, float]

_PREFIX_RE = re.compile(r"[A-Za-z0-9_/]*")


def check_frame_prefix(prefix: str) -> str:
    """``prefix`` if it is a valid frame prefix (letters, digits, ``_`` and ``/``, not starting
    with ``/``; e.g. ``"parol6/"``), else an error naming the rule."""
    if not isinstance(prefix, str) or not _PREFIX_RE.fullmatch(prefix) or prefix.startswith("/"):
        raise ParolkitValueError(f"frame prefix must be letters, digits, _ and / and not start with / "
                                 f"(e.g. \"parol6/\"), got {prefix!r}")
    return prefix


def quat_multiply(a: Quat, b: Quat) -> Quat:
    """Hamilton product ``a * b`` of (x, y, z, w) quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def quat_about_axis(axis: Vec3, angle: float) -> Quat:
    """The rotation by ``angle`` (rad) about the unit vector ``axis``."""
    s = math.sin(angle / 2.0)
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2.0))


def quat_from_rpy(roll: float, pitch: float, yaw: float) -> Quat:
    """URDF's ``rpy``: ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    return quat_multiply(quat_multiply(quat_about_axis((0.0, 0.0, 1.0), yaw), quat_about_axis((0.0, 1.0, 0.0), pitch)),
                         quat_about_axis((1.0, 0.0, 0.0), roll))


@dataclass(frozen=True)
class UrdfJoint:
    """One joint of a URDF: its type, parent and child links, origin and (unit) axis."""

    name: str
    type: str
    parent: str
    child: str
    xyz: Vec3
    rotation: Quat
    axis: Vec3


@dataclass(frozen=True)
class FrameTransform:
    """``child``'s pose in ``parent``: translation (m) and rotation (x, y, z, w)."""

    parent: str
    child: str
    translation: Vec3
    rotation: Quat


def _floats3(text: str | None, default: Vec3, where: str) -> Vec3:
    if text is None:
        return default
    try:
        x, y, z = (float(v) for v in text.split())
    except ValueError:
        raise ParolkitValueError(f"URDF {where}: expected three numbers, got {text!r}") from None
    return (x, y, z)


def urdf_joints(urdf: str) -> list[UrdfJoint]:
    """The joints of a URDF document, in document order (a parent before its children in
    what :func:`parolkit.ros2.urdf.make_urdf` writes)."""
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise ParolkitValueError(f"URDF: not XML: {exc}") from None
    out = []
    for j in root.findall("joint"):
        name = j.get("name", "")
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            raise ParolkitValueError(f"URDF joint {name!r}: needs a parent and a child link")
        origin, axis_el = j.find("origin"), j.find("axis")
        xyz = _floats3(origin.get("xyz") if origin is not None else None, (0.0, 0.0, 0.0), f"joint {name!r} origin xyz")
        rpy = _floats3(origin.get("rpy") if origin is not None else None, (0.0, 0.0, 0.0), f"joint {name!r} origin rpy")
        ax = _floats3(axis_el.get("xyz") if axis_el is not None else None, (1.0, 0.0, 0.0), f"joint {name!r} axis")
        norm = math.sqrt(ax[0] ** 2 + ax[1] ** 2 + ax[2] ** 2)
        if norm == 0.0:
            raise ParolkitValueError(f"URDF joint {name!r}: its axis is zero")
        out.append(UrdfJoint(name, j.get("type", ""), parent.get("link", ""), child.get("link", ""), xyz,
                             quat_from_rpy(*rpy), (ax[0] / norm, ax[1] / norm, ax[2] / norm)))
    return out


class TfTree:
    """The TF frames of a URDF with a frame prefix (module docstring)."""

    def __init__(self, urdf: str, frame_prefix: str = "") -> None:
        self.prefix = check_frame_prefix(frame_prefix)
        joints = urdf_joints(urdf)
        self.moving = [j for j in joints if j.type in ("revolute", "continuous")]
        self.fixed = [j for j in joints if j.type == "fixed"]
        other = [j.name for j in joints if j not in self.moving and j not in self.fixed]
        if other:
            raise ParolkitValueError(f"URDF joints {other} are neither revolute nor fixed: TfTree handles only those")
        children = {j.child for j in joints}
        roots = [j.parent for j in joints if j.parent not in children]
        if len(set(roots)) != 1:
            raise ParolkitValueError(f"URDF: expected one root link, got {sorted(set(roots))}")
        self.root = roots[0]
        #: names of the moving joints, in the order :meth:`transforms` takes their positions
        self.joint_names = [j.name for j in self.moving]

    def frame(self, link: str) -> str:
        """The TF frame of a URDF link: the prefix and the link's name."""
        return self.prefix + link

    def _transform(self, j: UrdfJoint, position: float) -> FrameTransform:
        rot = j.rotation if position == 0.0 else quat_multiply(j.rotation, quat_about_axis(j.axis, position))
        return FrameTransform(self.frame(j.parent), self.frame(j.child), j.xyz, rot)

    def static_transforms(self) -> list[FrameTransform]:
        """``world`` -> the root link (identity), then every fixed joint."""
        return [FrameTransform(WORLD_FRAME, self.frame(self.root), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
                *(self._transform(j, 0.0) for j in self.fixed)]

    def transforms(self, positions: Sequence[float]) -> list[FrameTransform]:
        """One transform per moving joint at ``positions`` (rad, in :attr:`joint_names` order)."""
        if len(positions) != len(self.moving):
            raise ParolkitValueError(f"expected {len(self.moving)} joint positions ({', '.join(self.joint_names)}), "
                                     f"got {len(positions)}")
        return [self._transform(j, float(q)) for j, q in zip(self.moving, positions, strict=True)]
