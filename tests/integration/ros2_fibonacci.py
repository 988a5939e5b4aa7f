"""test_msgs/action/Fibonacci (ROS 2's own test action, on PyPI as ros-jazzy-test-msgs) as
cyclonedds structs, and an executor for it: parolkit's generic action server
(:mod:`parolkit.ros2.action_server`) serves it in tests/integration/test_ros2_action.py as it
serves FollowJointTrajectory.  No ``from __future__ import annotations`` (cyclonedds)."""

import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import int32

from parolkit.ros2.action_msgs import action_types
from parolkit.ros2.action_server import GoalHandle, GoalResponse

if TYPE_CHECKING:
    from builtins import list as seq_
else:
    from cyclonedds.idl.types import sequence as seq_


@dataclass
class Fibonacci_Goal(IdlStruct, typename="test_msgs::action::dds_::Fibonacci_Goal_"):
    order: int32 = 0


@dataclass
class Fibonacci_Result(IdlStruct, typename="test_msgs::action::dds_::Fibonacci_Result_"):
    sequence: seq_[int32] = field(default_factory=list)


@dataclass
class Fibonacci_Feedback(IdlStruct, typename="test_msgs::action::dds_::Fibonacci_Feedback_"):
    sequence: seq_[int32] = field(default_factory=list)


FIBONACCI = action_types("test_msgs/action/Fibonacci", Fibonacci_Goal, Fibonacci_Result, Fibonacci_Feedback)

#: orders above this are rejected (as a server refuses a goal it cannot meet)
MAX_ORDER = 40


class FibonacciExecutor:
    """Computes the sequence one term per ``step_s`` (feedback after each), ends SUCCEEDED
    with it, or CANCELED with the terms so far once a cancel was taken."""

    def __init__(self, step_s: float = 0.05) -> None:
        self.step_s = step_s
        self.cancelled = threading.Event()

    def on_goal(self, h: GoalHandle) -> GoalResponse:
        order = h.goal.order
        if not 0 <= order <= MAX_ORDER:
            return GoalResponse(False, f"order must be 0..{MAX_ORDER}, got {order}")
        return GoalResponse(True)

    def on_accepted(self, h: GoalHandle) -> None:
        threading.Thread(target=self._run, args=(h,), daemon=True).start()

    def on_cancel(self, h: GoalHandle) -> bool:
        return True

    def _run(self, h: GoalHandle) -> None:
        h.execute()
        seq = [0, 1]
        stop = threading.Event()
        for _ in range(1, h.goal.order):
            if h.cancel_requested:
                h.canceled(Fibonacci_Result(sequence=seq))
                return
            seq.append(seq[-1] + seq[-2])
            h.publish_feedback(Fibonacci_Feedback(sequence=list(seq)))
            stop.wait(self.step_s)
        h.succeed(Fibonacci_Result(sequence=seq))
