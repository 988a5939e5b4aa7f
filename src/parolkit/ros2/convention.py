"""Joint conventions on the ROS side: parolkit's joint angles, or the community PAROL6 URDF's.

Both name the joints ``L1``..``L6``; they differ in where each joint's zero is and which way
it turns.  A convention is a per-joint affine map from parolkit's angle ``q`` (deg) to the
ROS-side angle ``q_ros = sign * q + offset`` (deg), applied to positions (and ``sign`` alone
to velocities and accelerations).

* ``parolkit``: the identity.  ``parolkit urdf`` / ``/robot_description`` are generated from
  parolkit's DH table with no offsets (:mod:`parolkit.ros2.urdf`).
* ``community``: the URDF exported from the PAROL6 CAD that the community MoveIt
  configurations use::

      q_comm = (q1, q2 + 90, 180 - q3, -q4, -q5, 180 - q6)   deg

  Derived from the FK of both models (docs/ros2.md, "Joint conventions"): with this map the
  community URDF's chain puts its wrist centre (the origin of its link ``L6``) on parolkit's
  (DH frame 6, the flange) to within 0.002 mm at any joint angles, and its ``L6`` frame is
  parolkit's flange frame turned by 180 deg about the flange's y axis, the same at every pose.
  J3 and J6 are each fixed only up to a multiple of 360 deg by the FK; the offsets above are the
  ones that put parolkit's joint ranges where the community URDF's limits are (J3
  107.9..287.9 deg -> -107.9..72.1 deg; J6 0..360 deg -> -180..180 deg) and parolkit's standby
  pose (90, -90, 180, 0, 0, 180) at (90, 0, 0, 0, 0, 0).  (The issue text wrote ``-q3 - 180``:
  the same FK, 360 deg away, outside every community joint limit.)

Pure functions of numbers (numpy only); nothing here knows about DDS or MoveIt.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from parolkit.errors import ParolkitValueError
from parolkit.robot import NUM_JOINTS

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = ["JointConvention", "PAROLKIT", "COMMUNITY", "CONVENTIONS", "get_convention"]


@dataclass(frozen=True)
class JointConvention:
    """``q_ros = signs * q + offsets_deg`` per joint (deg); ``signs`` are +1 or -1."""

    name: str
    signs: tuple[float, ...]
    offsets_deg: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.signs) != NUM_JOINTS or len(self.offsets_deg) != NUM_JOINTS:
            raise ParolkitValueError(f"joint convention {self.name!r}: signs and offsets need {NUM_JOINTS} values each")
        if any(s not in (1.0, -1.0) for s in self.signs):
            raise ParolkitValueError(f"joint convention {self.name!r}: signs must be +1 or -1, got {self.signs!r}")

    @property
    def is_identity(self) -> bool:
        return all(s == 1.0 for s in self.signs) and not any(self.offsets_deg)

    # ---- positions ----

    def to_ros_deg(self, q_deg: Sequence[float] | NDArray[np.float64]) -> NDArray[np.float64]:
        """parolkit joint angles (deg; 6 values or (N, 6)) -> this convention's (deg)."""
        q = np.asarray(q_deg, dtype=np.float64)
        out: NDArray[np.float64] = q * np.asarray(self.signs) + np.asarray(self.offsets_deg)
        return out

    def from_ros_deg(self, q_ros_deg: Sequence[float] | NDArray[np.float64]) -> NDArray[np.float64]:
        """This convention's joint angles (deg; 6 values or (N, 6)) -> parolkit's (deg)."""
        q = np.asarray(q_ros_deg, dtype=np.float64)
        out: NDArray[np.float64] = (q - np.asarray(self.offsets_deg)) * np.asarray(self.signs)
        return out

    def to_ros_rad(self, q_deg: Sequence[float] | NDArray[np.float64]) -> NDArray[np.float64]:
        """parolkit joint angles (deg) -> this convention's, radians (what ROS carries)."""
        return np.radians(self.to_ros_deg(q_deg))

    def from_ros_rad(self, q_ros_rad: Sequence[float] | NDArray[np.float64]) -> NDArray[np.float64]:
        """This convention's joint angles (rad, as ROS carries them) -> parolkit's, radians."""
        return np.radians(self.from_ros_deg(np.degrees(np.asarray(q_ros_rad, dtype=np.float64))))

    # ---- rates (velocities, accelerations): the sign only ----

    def rate_to_ros(self, v: Sequence[float] | NDArray[np.float64]) -> NDArray[np.float64]:
        """A joint rate (any unit: velocity, acceleration) from parolkit's convention to this one."""
        out: NDArray[np.float64] = np.asarray(v, dtype=np.float64) * np.asarray(self.signs)
        return out

    def rate_from_ros(self, v: Sequence[float] | NDArray[np.float64]) -> NDArray[np.float64]:
        """A joint rate from this convention to parolkit's (the signs are their own inverse)."""
        return self.rate_to_ros(v)

    def limits_deg(self, limits_deg: Sequence[Sequence[float]] | NDArray[np.float64]) -> NDArray[np.float64]:
        """parolkit's (6, 2) (lower, upper) joint limits (deg) in this convention: mapped, and
        swapped where a joint turns the other way."""
        lim = np.asarray(limits_deg, dtype=np.float64)
        mapped = self.to_ros_deg(lim.T).T  # (6, 2): each column is one bound of every joint
        return np.sort(mapped, axis=1)


#: parolkit's own joint angles (the identity).
PAROLKIT = JointConvention("parolkit", (1.0,) * NUM_JOINTS, (0.0,) * NUM_JOINTS)
#: The community PAROL6 URDF's zeros and signs (module docstring).
COMMUNITY = JointConvention("community", (1.0, 1.0, -1.0, -1.0, -1.0, -1.0), (0.0, 90.0, 180.0, 0.0, 0.0, 180.0))
#: By name, as ``[ros2] joint_convention`` and ``--joint-convention`` spell them.
CONVENTIONS = {c.name: c for c in (PAROLKIT, COMMUNITY)}


def get_convention(name: str | JointConvention) -> JointConvention:
    """The convention named ``name`` (or ``name`` itself); an error naming the known ones."""
    if isinstance(name, JointConvention):
        return name
    try:
        return CONVENTIONS[name]
    except (KeyError, TypeError):
        raise ParolkitValueError(f"joint convention must be one of {sorted(CONVENTIONS)}, got {name!r}") from None
