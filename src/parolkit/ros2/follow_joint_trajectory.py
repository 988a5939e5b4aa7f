"""The arm's ``FollowJointTrajectory`` action (control_msgs), as MoveIt's controller manager uses it.

``/<ns>/parol6_arm_controller/follow_joint_trajectory`` (:mod:`parolkit.ros2.action_server`):

* a goal's trajectory is checked and planned exactly as one on ``/<ns>/joint_trajectory``
  (:func:`parolkit.ros2.trajectory.plan_joint_trajectory`: all or nothing, before anything
  moves) and runs as ONE ``MOVEJOINTPATH``; a goal that cannot run is accepted and ends at once
  ABORTED with control_msgs' error code and the reason in ``error_string`` (ROS's goal response
  has no room for a reason): ``INVALID_JOINTS`` (joint names, tolerance names, a multi-DOF
  part), ``OLD_HEADER_TIMESTAMP`` (a ``header.stamp`` whose trajectory has already begun),
  ``INVALID_GOAL`` (anything else: the planner's refusal, a robot that cannot move, an
  acceleration tolerance);
* feedback at the status rate: ``desired`` (the planned sample the controller commands at that
  tick), ``actual`` (the board's position and speed), ``error`` = desired - actual, in the
  ``[ros2] joint_convention``;
* ``path_tolerance`` (position, velocity; 0 = not checked, as no default is configured; -1 =
  not checked): a violation stops the arm (a controlled stop) and ends the goal ABORTED,
  ``PATH_TOLERANCE_VIOLATED``, naming the joint, the error and the tick; ``goal_tolerance`` at
  the end, within ``goal_time_tolerance`` after the last point's time, else
  ``GOAL_TOLERANCE_VIOLATED``; success is ``SUCCESSFUL`` with the ticks the path took;
* cancel: a controlled stop (STOP: the arm slows down on its path within the acceleration
  limits; the controller applies it in the first frame after it arrives), the goal ends
  CANCELED once the arm is at rest, its ``error_string`` giving the controller ticks of the
  request, of the stop and of the rest; a new goal preempts the running one the same way (the
  old one ends CANCELED, ``INVALID_GOAL``, "preempted by goal ..."; the new one is planned from
  where the arm came to rest);
* an empty JointTrajectory on ``/<ns>/joint_trajectory`` stops whatever moves the same way
  (:meth:`ArmTrajectoryAction.stop_all`).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from parolkit.client.errors import RobotError
from parolkit.errors import ParolkitError
from parolkit.ros2 import msgs
from parolkit.ros2.action_msgs import (
    FOLLOW_JOINT_TRAJECTORY,
    FollowJointTrajectory_Feedback,
    FollowJointTrajectory_Goal,
    FollowJointTrajectory_Result,
)
from parolkit.ros2.action_server import ActionServer, GoalHandle, GoalResponse
from parolkit.ros2.trajectory import TrajectoryPath, TrajectoryPoint, TrajectoryRefused, plan_joint_trajectory
from parolkit.ros2.urdf import ROS_JOINT_NAMES

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.client.core import RobotStatus
    from parolkit.client.robot import CommandHandle
    from parolkit.motion.trajectory import Trajectory
    from parolkit.ros2.action_host import ActionHost

__all__ = ["ArmTrajectoryAction", "ACTION_NAME", "GoalRefused", "JointTolerances", "StopTicks"]

log = logging.getLogger("parolkit.ros2.action")

#: the action's name under the bridge's namespace (moveit_controllers.yaml: controller + action_ns)
ACTION_NAME = "parol6_arm_controller/follow_joint_trajectory"
R = FollowJointTrajectory_Result
#: a preempted goal waits at most this long for the arm to come to rest, s
REST_WAIT_S = 10.0
#: a header.stamp at most this far ahead is waited for, s (further: INVALID_GOAL)
MAX_FUTURE_START_S = 10.0


class GoalRefused(ParolkitError):
    """A goal that cannot run: control_msgs' ``code`` and the reason."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code = code


@dataclass(frozen=True)
class JointTolerances:
    """Per joint (L1..L6 order) position and velocity tolerances, rad and rad/s; 0 = not checked."""

    position: tuple[float, ...] = (0.0,) * 6
    velocity: tuple[float, ...] = (0.0,) * 6

    @classmethod
    def from_msg(cls, items: list[Any], what: str) -> JointTolerances:
        """From JointTolerance messages; GoalRefused for an unknown joint or an acceleration tolerance."""
        pos, vel = [0.0] * 6, [0.0] * 6
        for t in items:
            if t.name not in ROS_JOINT_NAMES:
                raise GoalRefused(R.INVALID_JOINTS,
                                  f"{what}: unknown joint {t.name!r} (joints: {list(ROS_JOINT_NAMES)})")
            j = ROS_JOINT_NAMES.index(t.name)
            for value, name in ((t.position, "position"), (t.velocity, "velocity"), (t.acceleration, "acceleration")):
                if not math.isfinite(value) or (value < 0 and value != -1.0):
                    raise GoalRefused(R.INVALID_GOAL,
                                      f"{what}: {t.name} {name} tolerance must be >= 0 or -1, got {value}")
            if t.acceleration > 0:
                raise GoalRefused(R.INVALID_GOAL,
                                  f"{what}: {t.name} has an acceleration tolerance ({t.acceleration}): parolkit "
                                  "cannot check it (the board reports positions and speeds only); give 0 or -1")
            pos[j] = max(t.position, 0.0)
            vel[j] = max(t.velocity, 0.0)
        return cls(tuple(pos), tuple(vel))

    def violation(self, err_pos: NDArray[np.float64], err_vel: NDArray[np.float64] | None) -> str | None:
        """The first joint outside its tolerance, in words, or None."""
        for j in range(6):
            if self.position[j] > 0 and abs(err_pos[j]) > self.position[j]:
                return (f"{ROS_JOINT_NAMES[j]} position error {err_pos[j]:+.5f} rad exceeds the tolerance "
                        f"{self.position[j]:g} rad")
            if err_vel is not None and self.velocity[j] > 0 and abs(err_vel[j]) > self.velocity[j]:
                return (f"{ROS_JOINT_NAMES[j]} velocity error {err_vel[j]:+.5f} rad/s exceeds the tolerance "
                        f"{self.velocity[j]:g} rad/s")
        return None


@dataclass(frozen=True)
class StopTicks:
    """A controlled stop in controller ticks (status ``seq``): the controller's tick just before
    the bridge sent the STOP, and just after the controller acked it (it applies a STOP in the
    first frame after the datagram arrives)."""

    requested: int
    applied: int

    def words(self) -> str:
        return f"stop asked at tick {self.requested}, applied by tick {self.applied}"


@dataclass(eq=False)
class _Run:
    """A goal on its way: planned, sent, followed status by status."""

    goal: GoalHandle
    path: TrajectoryPath | None = None
    plan: Trajectory | None = None
    command: CommandHandle | None = None
    path_tol: JointTolerances = field(default_factory=JointTolerances)
    goal_tol: JointTolerances = field(default_factory=JointTolerances)
    goal_time_s: float = 0.0
    #: why it was stopped: (CANCELED or ABORTED, error code, text), set by whoever stopped it
    stopped: tuple[str, int, str] | None = None
    stop_ticks: StopTicks | None = None
    #: set once whoever stopped the arm for this run has its StopTicks (the result names them)
    stop_recorded: threading.Event = field(default_factory=threading.Event)
    stopping: bool = False
    done: threading.Event = field(default_factory=threading.Event)


class ArmTrajectoryAction:
    """The FollowJointTrajectory action server of a :class:`~parolkit.ros2.bridge.Ros2Bridge`."""

    def __init__(self, bridge: ActionHost) -> None:
        self.bridge = bridge
        self._lock = threading.RLock()
        self._run: _Run | None = None
        self._statuses: deque[RobotStatus] = deque(maxlen=1000)
        self._wake = threading.Condition()
        self.server = ActionServer(bridge.dp, bridge.namespace, ACTION_NAME, FOLLOW_JOINT_TRAJECTORY,
                                   on_goal=self._on_goal, on_accepted=self._on_accepted, on_cancel=self._on_cancel,
                                   clock_ns=bridge.clock_ns)

    # ---- the bridge's hooks ----
    @property
    def running(self) -> bool:
        """True while a goal runs or waits to (the topic's trajectories are refused as busy)."""
        with self._lock:
            return self._run is not None

    def on_status(self, st: RobotStatus) -> None:
        """Every status the bridge receives (its status thread)."""
        if self._run is None:
            return
        with self._wake:
            self._statuses.append(st)
            self._wake.notify_all()

    def stop_all(self, why: str) -> StopTicks | None:
        """Stop what moves (an empty JointTrajectory): the running goal ends CANCELED; None
        when nothing moved."""
        with self._lock:
            run = self._run
            sent = run is not None and self._mark(run, "canceled", R.SUCCESSFUL, f"stopped by {why}")
        if sent:
            assert run is not None
            self._stop_run(run)
            return run.stop_ticks
        st = self.bridge.latest()
        if st is None or not st.moving:
            return None
        return self._controlled_stop()

    def close(self) -> None:
        self.server.close()

    # ---- the action server's callbacks (its thread) ----
    def _on_goal(self, h: GoalHandle) -> GoalResponse:
        return GoalResponse(True)  # every goal is taken; one that cannot run ends ABORTED with the reason

    def _on_accepted(self, h: GoalHandle) -> None:
        run = _Run(h)
        with self._lock:
            before, self._run = self._run, run
            sent = before is not None and self._mark(before, "canceled", R.INVALID_GOAL,
                                                     f"preempted by goal {h.id_hex}")
        if sent:  # preemption: stop the running goal now, on the server's thread
            assert before is not None
            self._stop_run(before)
        threading.Thread(target=self._execute, args=(run, before), daemon=True,
                         name=f"parolkit-ros2-goal-{h.id_hex[:8]}").start()

    def _on_cancel(self, h: GoalHandle) -> bool:
        with self._lock:
            run = self._run if self._run is not None and self._run.goal is h else None
            sent = run is not None and self._mark(run, "canceled", R.SUCCESSFUL, "canceled")
        if sent:
            assert run is not None
            self._stop_run(run)
        return True  # a goal not started yet sees the request in its thread

    @staticmethod
    def _mark(run: _Run, how: str, code: int, text: str) -> bool:
        """Record why ``run`` stops (the first reason wins); True when its command was sent
        (then the caller stops the arm).  Under the lock: a goal's thread sends its command
        under it too, so a goal is either stopped before it sends or after."""
        if run.stopped is None:
            run.stopped = (how, code, text)
        if run.command is None or run.command.done() or run.stopping:
            return False
        run.stopping = True
        return True

    def _stop_run(self, run: _Run) -> None:
        """The controlled stop of a run :meth:`_mark` said to stop."""
        try:
            run.stop_ticks = self._controlled_stop()
        finally:
            run.stop_recorded.set()

    def _controlled_stop(self) -> StopTicks:
        """STOP, between two status queries (answered at once, from the controller's latest
        tick; the status stream the bridge reads may lag behind on a busy machine)."""
        robot = self.bridge.robot
        try:
            before = robot.status().seq
        except RobotError:
            before = self._seq()
        try:
            robot.stop()
        except RobotError as exc:
            log.error("STOP failed: %s", exc)
        try:
            after = robot.status().seq
        except RobotError:
            after = self._seq()
        return StopTicks(before, after)

    def _seq(self) -> int:
        st = self.bridge.latest()
        return st.seq if st is not None else -1

    # ---- one goal's thread ----
    def _execute(self, run: _Run, before: _Run | None) -> None:
        h = run.goal
        try:
            if before is not None:
                before.done.wait(REST_WAIT_S + 5.0)
                self._wait_rest()
            if h.cancel_requested or run.stopped is not None:
                self._end(run, "canceled", R.SUCCESSFUL, "canceled before it started")
                return
            self._prepare(run)
            if run.stopped is not None:  # canceled or preempted while waiting for its start
                self._end(run, run.stopped[0], run.stopped[1], run.stopped[2])
                return
            self._start(run)
            self._follow(run)
        except GoalRefused as exc:
            self._end(run, "aborted", exc.code, str(exc))
        except Exception as exc:  # never leave a goal without a result
            log.exception("goal %s failed", h.id_hex)
            self._end(run, "aborted", R.INVALID_GOAL, f"internal error: {exc}")
        finally:
            run.done.set()
            with self._lock:
                if self._run is run:
                    self._run = None

    def _prepare(self, run: _Run) -> None:
        """Check and plan the goal (GoalRefused when it cannot run); wait for a future stamp."""
        goal: FollowJointTrajectory_Goal = run.goal.goal
        if goal.multi_dof_trajectory.joint_names or goal.multi_dof_trajectory.points:
            raise GoalRefused(R.INVALID_JOINTS,
                              "the PAROL6 has no multi-DOF joints: multi_dof_trajectory must be empty")
        if goal.component_path_tolerance or goal.component_goal_tolerance:
            raise GoalRefused(R.INVALID_JOINTS, "component tolerances are for multi-DOF joints; the PAROL6 has none")
        traj = goal.trajectory
        names = list(traj.joint_names)
        if sorted(names) != sorted(ROS_JOINT_NAMES):
            raise GoalRefused(R.INVALID_JOINTS, f"joint_names must name each of {list(ROS_JOINT_NAMES)} once, "
                              f"got {names}")
        if not traj.points:
            raise GoalRefused(R.INVALID_GOAL, "the trajectory has no points (to stop the arm, cancel the goal or "
                              "publish an empty JointTrajectory)")
        run.path_tol = JointTolerances.from_msg(list(goal.path_tolerance), "path_tolerance")
        run.goal_tol = JointTolerances.from_msg(list(goal.goal_tolerance), "goal_tolerance")
        run.goal_time_s = msgs.duration_to_s(goal.goal_time_tolerance)
        if run.goal_time_s < 0:
            raise GoalRefused(R.INVALID_GOAL, f"goal_time_tolerance must be >= 0, got {run.goal_time_s} s")
        self._wait_for_stamp(run, traj)

    def _wait_for_stamp(self, run: _Run, traj: msgs.JointTrajectory) -> None:
        stamp_ns = traj.header.stamp.sec * 1_000_000_000 + traj.header.stamp.nanosec
        if stamp_ns == 0:
            return
        now = self.bridge.clock_ns()
        end_s = (stamp_ns - now) / 1e9 + msgs.duration_to_s(traj.points[-1].time_from_start)
        if stamp_ns < now:
            raise GoalRefused(R.OLD_HEADER_TIMESTAMP, (
                f"header.stamp is {(now - stamp_ns) / 1e9:.3f} s in the past (the trajectory "
                + (f"ended {-end_s:.3f} s ago" if end_s < 0 else "has begun") + "): parolkit runs a trajectory "
                "from its start; give stamp 0 (now) or a time to come"))
        wait_s = (stamp_ns - now) / 1e9
        if wait_s > MAX_FUTURE_START_S:
            raise GoalRefused(R.INVALID_GOAL, f"header.stamp is {wait_s:.1f} s ahead; at most {MAX_FUTURE_START_S:g} s")
        end = time.monotonic() + wait_s
        while time.monotonic() < end and run.stopped is None and not run.goal.cancel_requested:
            time.sleep(min(0.005, max(0.0, end - time.monotonic())))
        if run.goal.cancel_requested and run.stopped is None:
            run.stopped = ("canceled", R.SUCCESSFUL, "canceled before its start time")

    def _start(self, run: _Run) -> None:
        """Plan from where the arm is and send the MOVEJOINTPATH."""
        from parolkit.motion import plan

        b = self.bridge
        st = b.robot.status()
        why = self._busy(st)
        if why is not None:
            raise GoalRefused(R.INVALID_GOAL, why)
        rate = st.loop.rate_hz or b.cfg.controller.rate_hz
        traj = run.goal.goal.trajectory
        points = [TrajectoryPoint(list(p.positions), msgs.duration_to_s(p.time_from_start), list(p.velocities))
                  for p in traj.points]
        try:
            path = plan_joint_trajectory(list(traj.joint_names), points, st.angles, b.cfg.robot, rate,
                                         start_tolerance_rad=b.cfg.ros2.start_tolerance_rad, convention=b.convention)
        except TrajectoryRefused as exc:
            raise GoalRefused(R.INVALID_GOAL, str(exc)) from None
        run.path = path
        run.plan = plan(path.move, st.angles, model=b.cfg.robot, rate_hz=rate)
        with self._lock:
            if run.stopped is not None:  # canceled meanwhile: nothing was sent
                return
            move = path.move
            try:
                run.command = b.robot.move_joint_path(move.points_deg, move.times_s, move.velocities_deg_s, wait=False)
            except RobotError as exc:
                raise GoalRefused(R.INVALID_GOAL, f"refused by the controller: {exc}") from None
        run.goal.execute()
        b.event(f"goal {run.goal.id_hex[:8]} accepted: {path.points} points, {path.ticks} ticks "
                f"({path.ticks / rate:.3f} s)" + "".join(f"; {n}" for n in path.notes))

    def _busy(self, st: RobotStatus) -> str | None:
        """Why a goal cannot start now (the robot, the controller, the topic's trajectory), or None."""
        if not st.can_move:
            return (f"the robot cannot move (state {st.state}, enabled={st.enabled}, homed={st.all_homed}, "
                    f"E-stop={'yes' if st.estop_pressed or st.estop_latched else 'no'})")
        topic = self.bridge.topic_trajectory()
        if topic is not None and not topic.done():
            return "busy: a trajectory from joint_trajectory is running (cancel it with an empty JointTrajectory)"
        if st.command is not None or st.queue:
            return f"busy: the controller runs {st.command.name if st.command else 'a queued command'}"
        return None

    def _follow(self, run: _Run) -> None:
        """Feedback and the path tolerance status by status until the command ends; then the result."""
        if run.command is None:
            assert run.stopped is not None
            self._end(run, *run.stopped)
            return
        assert run.path is not None and run.plan is not None
        command, ticks = run.command, run.path.ticks
        last: RobotStatus | None = None
        while True:
            for st in self._drain():
                last = st
                if st.command is None or st.command.id != command.id or st.command.progress is None:
                    continue
                k = min(round(st.command.progress * ticks), ticks) - 1
                why = self._feedback(run, st, max(k, 0))
                if why is not None:
                    with self._lock:
                        sent = self._mark(run, "aborted", R.PATH_TOLERANCE_VIOLATED, f"{why} at tick {st.seq} "
                                          f"(t = {max(k, 0) / run.plan.rate_hz:.2f} s into the path)")
                    if sent:
                        self._stop_run(run)
            if command.done():
                break
            with self._wake:
                self._wake.wait(0.5)
        try:
            command.result(timeout=0)
        except RobotError as exc:
            if run.stopped is not None:
                if run.stopping:
                    run.stop_recorded.wait(REST_WAIT_S)
                rest = self._wait_rest()
                text = run.stopped[2] + (f"; {run.stop_ticks.words()}" if run.stop_ticks else "")
                self._end(run, run.stopped[0], run.stopped[1], f"{text}; at rest at tick {rest}")
            else:
                self._end(run, "aborted", R.INVALID_GOAL, f"the controller ended the trajectory: {exc}")
            return
        self._finish_goal(run, last)

    def _finish_goal(self, run: _Run, last: RobotStatus | None) -> None:
        """The command completed: the goal tolerance within goal_time_tolerance, then the result."""
        assert run.path is not None
        b = self.bridge
        target = b.convention.to_ros_rad(np.asarray(run.path.move.points_deg[-1]))
        deadline = time.monotonic() + run.goal_time_s
        while True:
            st = self._drain()[-1:] or ([last] if last is not None else [b.robot.status()])
            cur = st[-1]
            assert cur is not None
            err = target - b.convention.to_ros_rad(np.asarray(cur.angles))
            vel = -b.convention.rate_to_ros(np.radians(np.asarray(cur.speeds_deg_s)))
            why = run.goal_tol.violation(err, vel)
            if why is None:
                self._end(run, "succeeded", R.SUCCESSFUL, f"{run.path.points} points, {run.path.ticks} ticks")
                return
            if time.monotonic() >= deadline:
                self._end(run, "aborted", R.GOAL_TOLERANCE_VIOLATED,
                          f"{why} {run.goal_time_s:g} s after the trajectory's end (tick {cur.seq})")
                return
            with self._wake:
                self._wake.wait(0.05)
            last = cur

    def _feedback(self, run: _Run, st: RobotStatus, k: int) -> str | None:
        """Publish one feedback message; the path tolerance violation in words, or None."""
        from parolkit.robot import steps_s_to_deg_s, steps_to_deg

        assert run.plan is not None
        conv = self.bridge.convention
        model = self.bridge.cfg.robot
        want_deg = steps_to_deg(run.plan.positions[k], model)
        want = conv.to_ros_rad(want_deg)
        want_v = conv.rate_to_ros(np.radians(steps_s_to_deg_s(run.plan.speeds[k], model)))
        have = conv.to_ros_rad(np.asarray(st.angles))
        have_v = conv.rate_to_ros(np.radians(np.asarray(st.speeds_deg_s)))
        err, err_v = want - have, want_v - have_v
        header = msgs.MsgHeader(stamp=msgs.time_from_ns(self.bridge.clock_ns()), frame_id="")
        dur = msgs.Duration(sec=int((k + 1) / run.plan.rate_hz),
                            nanosec=int(round(((k + 1) / run.plan.rate_hz % 1) * 1e9)) % 1_000_000_000)
        run.goal.publish_feedback(FollowJointTrajectory_Feedback(
            header=header, joint_names=list(ROS_JOINT_NAMES),
            desired=msgs.JointTrajectoryPoint(positions=list(want), velocities=list(want_v), time_from_start=dur),
            actual=msgs.JointTrajectoryPoint(positions=list(have), velocities=list(have_v), time_from_start=dur),
            error=msgs.JointTrajectoryPoint(positions=list(err), velocities=list(err_v), time_from_start=dur)))
        return run.path_tol.violation(err, err_v)

    def _drain(self) -> list[RobotStatus]:
        with self._wake:
            out = list(self._statuses)
            self._statuses.clear()
        return out

    def _wait_rest(self) -> int:
        """Wait until the controller runs nothing and the arm stands still; its tick."""
        end = time.monotonic() + REST_WAIT_S
        while time.monotonic() < end:
            st = self.bridge.latest()
            if st is not None and st.command is None and not any(st.speeds):
                return st.seq
            time.sleep(0.005)
        raise GoalRefused(R.INVALID_GOAL, f"the arm did not come to rest within {REST_WAIT_S:g} s")

    def _end(self, run: _Run, how: str, code: int, text: str) -> None:
        h = run.goal
        result = R(error_code=code, error_string=text)
        if not h.active:
            return
        {"succeeded": h.succeed, "aborted": h.abort, "canceled": h.canceled}[how](result)
        level = logging.INFO if how == "succeeded" else logging.WARNING
        self.bridge.event(f"goal {h.id_hex[:8]} {how}: {text}", level)
