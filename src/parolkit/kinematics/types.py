"""Value objects of the kinematics package: IK branches, solutions, errors, singularity info.

Branch flags (all defined in joint space, so they are unambiguous for every pose):

* ``shoulder``: ``'front'`` when the wrist centre lies on the side of the J1 axis that the arm
  faces (``J1 = atan2(y, x)`` of the wrist centre), ``'back'`` when J1 is turned by 180 deg and
  the arm reaches over the top to the other side.
* ``elbow``: ``'up'`` is the elbow bend of the standby pose ``[90, -90, 180, 0, 0, 180]`` (the
  elbow above the shoulder-wrist line in the usual working poses), ``'down'`` the other bend.
* ``wrist_flip``: ``True`` when J5 < 0.  At the wrist singularity (J5 = 0) both wrist
  solutions are the same pose; such solutions report ``wrist_flip=False``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from parolkit.errors import ParolkitValueError

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

__all__ = ["Branch", "IKSolution", "IKError", "IKFailure", "SingularityInfo"]

_JOINT_NAMES = ("J1", "J2", "J3", "J4", "J5", "J6")
_SHOULDERS = ("front", "back")
_ELBOWS = ("up", "down")


@dataclass(frozen=True)
class Branch:
    """An IK branch (configuration).  Any field may be ``None`` meaning "not pinned".

    ``Branch(shoulder='front', elbow='up', wrist_flip=False)`` pins all three; as an ``ik``
    ``config`` argument a partly pinned branch (e.g. ``Branch(elbow='up')``) restricts only the
    given flags.  Solutions always carry a fully specified branch.
    """

    shoulder: str | None = None
    elbow: str | None = None
    wrist_flip: bool | None = None

    def __post_init__(self) -> None:
        if self.shoulder is not None and self.shoulder not in _SHOULDERS:
            raise ParolkitValueError(
                f"Branch.shoulder must be 'front', 'back' or None, got {self.shoulder!r}"
            )
        if self.elbow is not None and self.elbow not in _ELBOWS:
            raise ParolkitValueError(f"Branch.elbow must be 'up', 'down' or None, got {self.elbow!r}")
        if self.wrist_flip is not None and not isinstance(self.wrist_flip, (bool, np.bool_)):
            raise ParolkitValueError(
                f"Branch.wrist_flip must be True, False or None, got {self.wrist_flip!r}"
            )
        if self.wrist_flip is not None:
            object.__setattr__(self, "wrist_flip", bool(self.wrist_flip))

    @property
    def is_complete(self) -> bool:
        """True when all three flags are pinned."""
        return self.shoulder is not None and self.elbow is not None and self.wrist_flip is not None

    def matches(self, other: Branch) -> bool:
        """True when every flag pinned in ``self`` equals the flag of ``other``."""
        return (
            (self.shoulder is None or self.shoulder == other.shoulder)
            and (self.elbow is None or self.elbow == other.elbow)
            and (self.wrist_flip is None or self.wrist_flip == other.wrist_flip)
        )

    @classmethod
    def parse(cls, text: str) -> Branch:
        """Parse words such as ``"front up noflip"`` / ``"back,down,flip"`` (any order, any subset).

        Words: ``front``/``back``, ``up``/``down``, ``flip``/``noflip``.
        """
        shoulder = elbow = None
        flip: bool | None = None
        for word in text.replace(",", " ").lower().split():
            if word in _SHOULDERS:
                shoulder = word
            elif word in _ELBOWS:
                elbow = word
            elif word == "flip":
                flip = True
            elif word in ("noflip", "no-flip", "no_flip"):
                flip = False
            else:
                raise ParolkitValueError(
                    f"branch word {word!r} unknown (use front/back, up/down, flip/noflip)"
                )
        return cls(shoulder, elbow, flip)

    def __str__(self) -> str:
        parts = []
        if self.shoulder is not None:
            parts.append(self.shoulder)
        if self.elbow is not None:
            parts.append(self.elbow)
        if self.wrist_flip is not None:
            parts.append("flip" if self.wrist_flip else "noflip")
        return " ".join(parts) if parts else "any"


@dataclass(frozen=True, eq=False)
class IKSolution:
    """One IK solution: joint angles in degrees (inside the safe joint limits) and its branch.

    (Compared by identity: compare ``joints_deg`` with a tolerance instead.)
    """

    joints_deg: NDArray[np.float64]
    config: Branch

    def __repr__(self) -> str:
        q = ", ".join(f"{v:.4f}" for v in self.joints_deg)
        return f"IKSolution(joints_deg=[{q}], config={self.config})"


class IKFailure(enum.Enum):
    """Why an IK request failed (``IKError.kind``)."""

    #: The wrist centre is farther from (or closer to) the shoulder than the arm can reach.
    OUT_OF_REACH = "out_of_reach"
    #: Geometrically reachable, but every solution has a joint outside its limits.
    JOINT_LIMIT = "joint_limit"
    #: The input (pose, seed, tool) is malformed.
    BAD_INPUT = "bad_input"


class IKError(ParolkitValueError):
    """Inverse kinematics failed.  The message says why, in user terms.

    Attributes:

    * ``reason``: the human-readable explanation (also ``str(err)``),
    * ``kind``: an :class:`IKFailure`,
    * ``sample``: index of the failing pose in a batch (``None`` for a single pose),
    * ``joint``: 0-based index of the joint that would leave its range (``None`` otherwise);
      ``joint_name`` is ``"J1".."J6"`` or ``None``,
    * ``value``: the offending joint angle in degrees for ``JOINT_LIMIT``, the distance
      beyond reach in mm for ``OUT_OF_REACH``, else ``None``.
    """

    def __init__(
        self,
        reason: str,
        *,
        kind: IKFailure = IKFailure.JOINT_LIMIT,
        sample: int | None = None,
        joint: int | None = None,
        value: float | None = None,
    ) -> None:
        self.reason = reason
        self.kind = kind
        self.sample = sample
        self.joint = joint
        self.value = value
        where = f"sample {sample}: " if sample is not None else ""
        super().__init__(f"IK failed: {where}{reason}")

    @property
    def joint_name(self) -> str | None:
        return None if self.joint is None else _JOINT_NAMES[self.joint]

    def with_sample(self, sample: int) -> IKError:
        """A copy of this error tagged with a batch sample index."""
        return IKError(self.reason, kind=self.kind, sample=sample, joint=self.joint, value=self.value)


@dataclass(frozen=True)
class SingularityInfo:
    """Distances of a joint configuration from the three PAROL6 singularities.

    * ``wrist_deg``: |J5| folded to 0..90 deg (0 = axes 4 and 6 aligned: wrist singular),
    * ``shoulder_mm``: distance of the wrist centre from the J1 axis in mm (0 = shoulder
      singular: J1 cannot be determined from the position),
    * ``elbow_deg``: how far the elbow is from fully stretched or fully folded, deg
      (0 = elbow singular: the wrist centre is at the edge of the workspace),
    * ``nearest``: ``'wrist'``, ``'shoulder'`` or ``'elbow'``: the one with the smallest
      distance relative to its warning threshold (``thresholds``),
    * ``thresholds``: (wrist deg, shoulder mm, elbow deg) used to rank them,
    * ``near``: True when the nearest one is inside its threshold.
    """

    wrist_deg: float
    shoulder_mm: float
    elbow_deg: float
    nearest: str
    thresholds: tuple[float, float, float] = field(default=(5.0, 20.0, 5.0))

    @property
    def near(self) -> bool:
        idx = ("wrist", "shoulder", "elbow").index(self.nearest)
        value = (self.wrist_deg, self.shoulder_mm, self.elbow_deg)[idx]
        return value < self.thresholds[idx]
