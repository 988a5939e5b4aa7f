"""What an action server of the bridge needs from it: :class:`ActionHost`.

The FollowJointTrajectory and GripperCommand servers (:mod:`parolkit.ros2.follow_joint_trajectory`,
:mod:`parolkit.ros2.gripper_action`) run inside :class:`~parolkit.ros2.bridge.Ros2Bridge`, which
makes them; they type their host as this protocol, so the bridge depends on them and not the
other way round.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from cyclonedds.domain import DomainParticipant

    from parolkit.client.core import RobotStatus
    from parolkit.client.robot import CommandHandle, Robot
    from parolkit.config import Config
    from parolkit.ros2.convention import JointConvention

__all__ = ["ActionHost"]


class ActionHost(Protocol):
    """The bridge, as its action servers see it."""

    #: the DDS participant (the ROS 2 node's)
    dp: DomainParticipant
    #: the bridge's namespace, without slashes at either end
    namespace: str
    #: the connected client that sends the commands
    robot: Robot
    cfg: Config
    #: joint values on the ROS side (``[ros2] joint_convention``)
    convention: JointConvention
    #: the clock of message stamps, ns
    clock_ns: Callable[[], int]

    def latest(self) -> RobotStatus | None:
        """The newest status of the controller (None before the first)."""
        ...

    def topic_trajectory(self) -> CommandHandle | None:
        """The trajectory from the ``joint_trajectory`` topic that was sent last (None: none)."""
        ...

    def event(self, text: str, level: int = logging.INFO) -> None:
        """Log ``text`` and publish it on ``parolkit/events``."""
        ...
