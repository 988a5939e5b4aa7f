"""The electric gripper's ``GripperCommand`` action (control_msgs), for MoveIt's gripper controller.

``/<ns>/parol6_gripper_controller/gripper_cmd`` (:mod:`parolkit.ros2.action_server`) drives the
SSG-48 through the controller's ``ELECTRICGRIPPER move``:

* ``command.position`` is the jaw opening in metres (control_msgs: "the gripper gap size"),
  0 .. 0.048 m, mapped to the gripper's position 0..255 as the SSG-48 does (0 = fully open,
  48 mm; 255 = closed): ``position = round(255 * (1 - gap / 0.048))``;
* ``command.max_effort`` is the motor current limit in amperes (the SSG-48 has no force
  sensor; its current limits the grip force): 0 = the default 0.5 A, at most 1.3 A;
* feedback and result: ``position`` (the opening the gripper reports, m), ``effort`` (its
  current, A), ``stalled`` (it met an object: the jaws stopped before the position),
  ``reached_goal`` (at the position).  The goal SUCCEEDS when the gripper reports either (a
  grasp is the usual end of a closing move) and is ABORTED when the gripper is not calibrated,
  reports an error, or reports neither within the move's time at its speed plus 1 s;
* cancel holds the jaws where they are (a move to the position the gripper reports).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from typing import TYPE_CHECKING

from parolkit.client.errors import RobotError
from parolkit.ros2.action_msgs import GRIPPER_COMMAND, GripperCommand_Feedback, GripperCommand_Result
from parolkit.ros2.action_server import ActionServer, GoalHandle, GoalResponse

if TYPE_CHECKING:
    from parolkit.client.core import GripperState, RobotStatus
    from parolkit.ros2.action_host import ActionHost

__all__ = ["GripperAction", "GRIPPER_ACTION_NAME", "STROKE_M", "gap_to_position", "position_to_gap",
           "effort_to_current_ma"]

log = logging.getLogger("parolkit.ros2.action")

GRIPPER_ACTION_NAME = "parol6_gripper_controller/gripper_cmd"
#: the SSG-48's jaw opening at position 0 (fully open), m
STROKE_M = 0.048
#: the SSG-48's current ceiling and parolkit's default current, A
MAX_CURRENT_A = 1.3
DEFAULT_CURRENT_A = 0.5
#: the speed byte of the moves (the client's default): about 300 units/s, a full stroke in 0.85 s
SPEED = 150
#: slack on top of the move's own time before an unfinished goal is ABORTED, s
SLACK_S = 1.0


def gap_to_position(gap_m: float) -> int:
    """Gripper position 0..255 for a jaw opening in metres; ValueError naming the range."""
    if not math.isfinite(gap_m) or not 0.0 <= gap_m <= STROKE_M:
        raise ValueError(f"command.position (the jaw opening) must be 0 .. {STROKE_M} m, got {gap_m}")
    return round(255 * (1.0 - gap_m / STROKE_M))


def position_to_gap(position: int) -> float:
    """The jaw opening (m) at a gripper position 0..255."""
    return STROKE_M * (255 - position) / 255.0


def effort_to_current_ma(max_effort: float) -> int:
    """The current setpoint (mA) for ``max_effort`` (A; 0 = the default); ValueError naming the range."""
    if not math.isfinite(max_effort) or not 0.0 <= max_effort <= MAX_CURRENT_A:
        raise ValueError(f"command.max_effort (the current limit) must be 0 .. {MAX_CURRENT_A} A "
                         f"(0 = the default {DEFAULT_CURRENT_A} A), got {max_effort}")
    return round(1000 * (max_effort or DEFAULT_CURRENT_A))


class GripperAction:
    """The GripperCommand action server of a :class:`~parolkit.ros2.bridge.Ros2Bridge`."""

    def __init__(self, bridge: ActionHost) -> None:
        self.bridge = bridge
        self._lock = threading.Lock()
        self._current: GoalHandle | None = None
        self._wake = threading.Condition()
        self.server = ActionServer(bridge.dp, bridge.namespace, GRIPPER_ACTION_NAME, GRIPPER_COMMAND,
                                   on_goal=lambda h: GoalResponse(True), on_accepted=self._on_accepted,
                                   on_cancel=lambda h: True, clock_ns=bridge.clock_ns)

    def on_status(self, st: RobotStatus) -> None:
        if self._current is not None:
            with self._wake:
                self._wake.notify_all()

    def close(self) -> None:
        self.server.close()

    def _on_accepted(self, h: GoalHandle) -> None:
        with self._lock:
            before, self._current = self._current, h
        if before is not None and before.active:  # preempted: its thread ends it
            log.info("gripper goal %s preempted by %s", before.id_hex[:8], h.id_hex[:8])
        threading.Thread(target=self._run, args=(h,), daemon=True,
                         name=f"parolkit-ros2-gripper-{h.id_hex[:8]}").start()

    def _result(self, g: GripperState, target: int | None) -> GripperCommand_Result:
        return GripperCommand_Result(position=position_to_gap(g.position), effort=g.current / 1000.0,
                                     stalled=g.object_detected, reached_goal=g.object_code == 3
                                     and (target is None or abs(g.position - target) <= 1))

    def _run(self, h: GoalHandle) -> None:
        b = self.bridge
        cmd = h.goal.command
        try:
            target, current = gap_to_position(cmd.position), effort_to_current_ma(cmd.max_effort)
        except ValueError as exc:
            self._end(h, "aborted", str(exc), None)
            return
        g = b.robot.gripper()
        if not g.calibrated or not g.activated or g.error:
            self._end(h, "aborted", f"the gripper is not ready (calibrated={g.calibrated}, activated={g.activated}, "
                      f"error={g.error}): calibrate it first (GRIPPER calibrate)", g)
            return
        try:
            b.robot.gripper_move(target, SPEED, current, wait=True, timeout=5.0)
        except RobotError as exc:
            self._end(h, "aborted", f"refused by the controller: {exc}", None)
            return
        h.execute()
        from parolkit.board.gripper import jaw_rate_units_s

        deadline = time.monotonic() + abs(target - g.position) / jaw_rate_units_s(SPEED) + SLACK_S
        seen_moving = False
        while True:
            g = b.robot.gripper()
            res = self._result(g, target)
            h.publish_feedback(GripperCommand_Feedback(position=res.position, effort=res.effort, stalled=res.stalled,
                                                       reached_goal=res.reached_goal))
            seen_moving = seen_moving or g.object_code == 0
            if self._current is not h:
                self._end(h, "canceled", "preempted by a new goal", g)
                return
            if h.cancel_requested:
                b.robot.gripper_move(g.position, SPEED, current, wait=True, timeout=5.0)
                self._end(h, "canceled", f"canceled: the jaws held at {res.position * 1000:.1f} mm", g)
                return
            if g.error:
                self._end(h, "aborted", "the gripper reports an error", g)
                return
            if res.reached_goal or (res.stalled and (seen_moving or g.position != target)):
                self._end(h, "succeeded", "reached the position" if res.reached_goal else
                          f"stalled on an object at {res.position * 1000:.1f} mm", g)
                return
            if time.monotonic() > deadline:
                self._end(h, "aborted", f"the gripper did not reach position {target} (at {g.position}) in time", g)
                return
            with self._wake:
                self._wake.wait(0.05)

    def _end(self, h: GoalHandle, how: str, text: str, g: GripperState | None) -> None:
        with self._lock:
            if self._current is h:
                self._current = None
        if not h.active:
            return
        result = self._result(g, None) if g is not None else GripperCommand_Result()
        {"succeeded": h.succeed, "aborted": h.abort, "canceled": h.canceled}[how](result)
        self.bridge.event(f"gripper goal {h.id_hex[:8]} {how}: {text}",
                          logging.INFO if how == "succeeded" else logging.WARNING)
