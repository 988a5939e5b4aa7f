"""The one exception a planner raises when a move cannot be done as asked."""

from __future__ import annotations

from parolkit.errors import ParolkitError

__all__ = ["PlanningError"]

_JOINT_NAMES = ("J1", "J2", "J3", "J4", "J5", "J6")


class PlanningError(ParolkitError):
    """A move was refused before anything moved.

    Attributes:
        move: name of the move kind (``"MoveJoint"``, ``"MoveCart"``, ...).
        time_s: time from the start of the move (s) of the first offending sample, or None
            when the problem is not tied to one sample (e.g. an unreachable target).
        joint: 0-based joint index (0 = J1) or None.
        value: the offending value (unit in ``reason``) or None.
        point: for a path through points (``MoveJointPath``), the 0-based index of the point
            the problem belongs to (or of the point that ends the offending segment), else
            None: a caller that numbers the points otherwise (the ROS 2 bridge) re-labels it.
        reason: what is wrong and, where it helps, what to do.

    ``str(err)`` is one complete sentence for a user, e.g. ``"MoveJoint refused at t=0.420 s:
    J2 = 21000 steps/s exceeds the maximum speed 18000 steps/s; give a longer duration."``
    """

    def __init__(
        self,
        move: str,
        reason: str,
        *,
        time_s: float | None = None,
        joint: int | None = None,
        value: float | None = None,
        point: int | None = None,
    ) -> None:
        self.move = move
        self.reason = reason
        self.time_s = time_s
        self.joint = joint
        self.value = value
        self.point = point
        where = f" at t={time_s:.3f} s" if time_s is not None else ""
        text = f"{move} refused{where}: {reason}"
        if not text.endswith("."):
            text += "."
        super().__init__(text)

    @property
    def joint_name(self) -> str | None:
        """``"J1"``..``"J6"`` or None."""
        return None if self.joint is None else _JOINT_NAMES[self.joint]
