"""``parolkit ros2``: a ROS 2 node in plain Python (cyclonedds), a client of the controller.

Publishes (ROS names under the namespace ``ns`` of config ``[ros2]`` / ``--namespace``):

* ``/<ns>/joint_states`` (sensor_msgs/msg/JointState): names ``L1``..``L6``, positions in rad,
  velocities in rad/s, stamped with the wall-clock time the status arrived, for every
  ``joint_states_every_n``-th control tick (1: the controller's status rate);
* ``/<ns>/robot_description`` (std_msgs/msg/String, transient local): the URDF of
  :mod:`parolkit.ros2.urdf`, so a late subscriber (RViz, robot_state_publisher) still gets it;
* ``/tf`` (tf2_msgs/msg/TFMessage), with every joint state: every moving link of the URDF
  (``base_link`` -> ``L1`` ... ``L5`` -> ``L6``, :mod:`parolkit.ros2.tf`) and ``base_link`` ->
  ``parolkit_tcp``, the controller's TCP (its active tool) as it reports it;
* ``/tf_static`` (tf2_msgs/msg/TFMessage, transient local): ``world`` -> ``base_link`` and the
  URDF's fixed joints (``L6`` -> ``flange`` -> ``tcp``); every robot frame carries the frame
  prefix (``--frame-prefix``, default none: the URDF's link names);
* ``/<ns>/parolkit/status`` (std_msgs/msg/String): a JSON summary of the controller's status
  every ``status_every_n``-th tick;
* ``/<ns>/parolkit/events`` (std_msgs/msg/String): one line per trajectory: ``accepted ...``,
  ``refused: <reason>``, ``done ...``, ``failed: <reason>``.

Subscribes to ``/<ns>/joint_trajectory`` (trajectory_msgs/msg/JointTrajectory) and runs each
trajectory through the controller as ONE ``MOVEJOINTPATH`` (see
:mod:`parolkit.ros2.trajectory`: all-or-nothing pre-check with the controller's planner; the
controller plans the path again and guards every frame), so the points are passed without
stopping and the last one is reached on its tick.  A trajectory arriving while the robot runs a
command is refused (busy); an empty one stops the arm (a controlled stop, as a cancel).

Actions (:mod:`parolkit.ros2.follow_joint_trajectory`, :mod:`parolkit.ros2.gripper_action`):
``/<ns>/parol6_arm_controller/follow_joint_trajectory`` (control_msgs/FollowJointTrajectory, what
MoveIt's controller manager executes through) and ``/<ns>/parol6_gripper_controller/gripper_cmd``
(control_msgs/GripperCommand, the SSG-48).

QoS as ROS 2's defaults: reliable, keep last 10, volatile; the description and /tf_static
transient local, keep last 1 (as robot_state_publisher).  The bridge is the ROS 2 node
``/<ns>/parolkit_bridge`` (:mod:`parolkit.ros2.graph`: announced on ``ros_discovery_info``,
every topic with its type hash); its DDS domain is ``--domain``, else ``[ros2] domain`` from
the config file, else ``ROS_DOMAIN_ID``, else 0 (logged with its source).

Joint values on the ROS side are in ``[ros2] joint_convention`` (:mod:`parolkit.ros2.convention`):
parolkit's own angles, or the community PAROL6 URDF's zeros and signs; /joint_states,
/robot_description and the trajectories taken all use it.  A trajectory's start point may be
``[ros2] start_tolerance_rad`` from the current position.
"""

from __future__ import annotations

import json
import logging
import math
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.pub import DataWriter
from cyclonedds.util import duration

from parolkit.client.core import RobotStatus
from parolkit.client.errors import RobotError
from parolkit.client.robot import CommandHandle, Robot
from parolkit.config import Config
from parolkit.errors import ParolkitError
from parolkit.kinematics.pose import pose_to_matrix
from parolkit.ros2 import msgs
from parolkit.ros2.convention import get_convention
from parolkit.ros2.graph import NODE_NAME, RosGraph, make_participant, resolve_domain
from parolkit.ros2.tf import FrameTransform, TfTree, check_frame_prefix
from parolkit.ros2.trajectory import TrajectoryPoint, TrajectoryRefused, plan_joint_trajectory
from parolkit.ros2.urdf import BASE_LINK, ROS_JOINT_NAMES, make_urdf

if TYPE_CHECKING:
    from parolkit.ros2.follow_joint_trajectory import ArmTrajectoryAction
    from parolkit.ros2.gripper_action import GripperAction

__all__ = ["Ros2Bridge", "run_bridge", "ros_qos", "description_qos", "quaternion_from_matrix"]

log = logging.getLogger("parolkit.ros2")

_DEG = math.pi / 180.0
#: ``parolkit ros2`` exits (status 1) when the controller's status stream is silent this long, s
STATUS_SILENCE_S = 5.0


def ros_qos() -> Qos:
    """ROS 2's default QoS: reliable, keep last 10, volatile."""
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               Policy.History.KeepLast(10), Policy.Durability.Volatile)


def description_qos() -> Qos:
    """robot_state_publisher's QoS for /robot_description: reliable, keep last 1, transient local."""
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               Policy.History.KeepLast(1), Policy.Durability.TransientLocal)


def quaternion_from_matrix(m: Any) -> msgs.Quaternion:
    """Unit quaternion (x, y, z, w) of the rotation part of a 4x4 / 3x3 matrix."""
    r00, r01, r02 = float(m[0][0]), float(m[0][1]), float(m[0][2])
    r10, r11, r12 = float(m[1][0]), float(m[1][1]), float(m[1][2])
    r20, r21, r22 = float(m[2][0]), float(m[2][1]), float(m[2][2])
    tr = r00 + r11 + r22
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return msgs.Quaternion((r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s, 0.25 * s)
    if r00 > r11 and r00 > r22:
        s = math.sqrt(1.0 + r00 - r11 - r22) * 2
        return msgs.Quaternion(0.25 * s, (r01 + r10) / s, (r02 + r20) / s, (r21 - r12) / s)
    if r11 > r22:
        s = math.sqrt(1.0 + r11 - r00 - r22) * 2
        return msgs.Quaternion((r01 + r10) / s, 0.25 * s, (r12 + r21) / s, (r02 - r20) / s)
    s = math.sqrt(1.0 + r22 - r00 - r11) * 2
    return msgs.Quaternion((r02 + r20) / s, (r12 + r21) / s, 0.25 * s, (r10 - r01) / s)


class Ros2Bridge:
    """The DDS side of ``parolkit ros2``: writers, the trajectory reader and their threads.

    ``robot``: a connected :class:`Robot` (the bridge subscribes to its status and sends its
    commands); ``cfg``: the config (``[ros2]`` section, robot model).  :meth:`start` subscribes
    and starts the trajectory thread; :meth:`close` stops both.
    """

    def __init__(self, cfg: Config, robot: Robot, clock_ns: Callable[[], int] = time.time_ns, *,
                 domain: int | None = None, frame_prefix: str = "") -> None:
        self.cfg = cfg
        self.robot = robot
        self.clock_ns = clock_ns
        r = cfg.ros2
        self.namespace = r.namespace.strip("/")
        #: the frame prefix of every robot frame on /tf and /tf_static (parolkit.ros2.tf)
        self.frame_prefix = check_frame_prefix(frame_prefix)
        self.dp = make_participant(r.domain if domain is None else domain)
        #: the ROS 2 node: every reader and writer below is announced as its own
        self.graph = RosGraph(self.dp, NODE_NAME, self.namespace)
        qos = ros_qos()

        def writer(name: str, typ: type, q: Qos = qos) -> DataWriter[Any]:
            return self.graph.writer(msgs.topic_name(self.namespace, name), typ, q)

        self.joint_states = writer("joint_states", msgs.JointState)
        self.description = writer("robot_description", msgs.String, description_qos())
        self.tf = self.graph.writer("rt/tf", msgs.TFMessage, qos)
        self.tf_static = self.graph.writer("rt/tf_static", msgs.TFMessage, description_qos())
        self.status_out = writer("parolkit/status", msgs.String)
        self.events = writer("parolkit/events", msgs.String)
        self.trajectories = self.graph.reader(msgs.topic_name(self.namespace, "joint_trajectory"),
                                              msgs.JointTrajectory, qos)
        self.tcp_frame = f"{self.frame_prefix}parolkit_tcp"
        self.tf_tree: TfTree | None = None  # from the URDF, in start()
        self._names = list(ROS_JOINT_NAMES)
        #: joint values on the ROS side ([ros2] joint_convention): q_ros = sign * q + offset
        self.convention = get_convention(r.joint_convention)
        self._signs = [float(v) for v in self.convention.signs]
        self._offsets_rad = [math.radians(v) for v in self.convention.offsets_deg]
        self._latest: RobotStatus | None = None
        self._latest_lock = threading.Lock()
        self._latest_at = time.monotonic()
        self._tick = 0
        self._active: CommandHandle | None = None
        self._last_event = ""
        self._stop = threading.Event()
        self._sub: Any = None
        self._thread: threading.Thread | None = None
        self.published = 0
        #: publishers of joint_trajectory this node has matched (in parolkit/status)
        self.trajectory_publishers = 0
        #: the FollowJointTrajectory and GripperCommand action servers
        self.arm_action, self.gripper_action = self._make_actions()

    # ---- status -> topics ----
    def start(self) -> None:
        """Publish the description, subscribe to the status and start reading trajectories."""
        with self._latest_lock:
            self._latest_at = time.monotonic()
        rate = self.robot.status().loop.rate_hz or self.cfg.controller.rate_hz  # the URDF's velocity limits' rate
        urdf = make_urdf(self.cfg.robot, config=self.cfg, rate_hz=rate)
        self.description.write(msgs.String(data=urdf))
        self.tf_tree = TfTree(urdf, self.frame_prefix)
        stamp = msgs.time_from_ns(self.clock_ns())
        self.tf_static.write(msgs.TFMessage(transforms=[_stamped(t, stamp) for t in self.tf_tree.static_transforms()]))
        self._sub = self.robot.subscribe(self.cfg.ros2.joint_states_every_n, callback=self.on_status)
        self._thread = threading.Thread(target=self._trajectory_loop, daemon=True, name="parolkit-ros2-trajectories")
        self._thread.start()

    def latest(self) -> RobotStatus | None:
        with self._latest_lock:
            return self._latest

    def topic_trajectory(self) -> CommandHandle | None:
        """The trajectory from the ``joint_trajectory`` topic that was sent last (None: none)."""
        return self._active

    def status_age_s(self) -> float:
        """Seconds since the last status arrived (since :meth:`start` before the first)."""
        with self._latest_lock:
            return time.monotonic() - self._latest_at

    def on_status(self, st: RobotStatus) -> None:
        """Publish one status: joint_states and tf at once (the latency-critical part)."""
        stamp = msgs.time_from_ns(self.clock_ns())
        header = msgs.MsgHeader(stamp=stamp, frame_id="")
        a = st.angles
        v = st.speeds_deg_s
        sg, off = self._signs, self._offsets_rad
        position = [sg[j] * a[j] * _DEG + off[j] for j in range(6)]
        self.joint_states.write(msgs.JointState(
            header=header, name=self._names, position=position,
            velocity=[sg[j] * v[j] * _DEG for j in range(6)],
            effort=[]))
        self.published += 1
        with self._latest_lock:
            self._latest = st
            self._latest_at = time.monotonic()
        m = pose_to_matrix(tuple(st.pose))
        links = [_stamped(t, stamp) for t in self.tf_tree.transforms(position)] if self.tf_tree is not None else []
        self.tf.write(msgs.TFMessage(transforms=[*links, msgs.TransformStamped(
            header=msgs.MsgHeader(stamp=stamp, frame_id=self.frame_prefix + BASE_LINK), child_frame_id=self.tcp_frame,
            transform=msgs.Transform(
                translation=msgs.Vector3(float(m[0, 3]), float(m[1, 3]), float(m[2, 3])),
                rotation=quaternion_from_matrix(m)))]))
        self._tick += 1
        if self._tick % self.cfg.ros2.status_every_n == 0:
            self.status_out.write(msgs.String(data=json.dumps(self.status_summary(st), separators=(",", ":"))))
        self.arm_action.on_status(st)
        self.gripper_action.on_status(st)

    def status_summary(self, st: RobotStatus) -> dict[str, Any]:
        """The JSON object of ``parolkit/status``."""
        return {
            "seq": st.seq, "state": str(st.state), "enabled": st.enabled, "all_homed": st.all_homed,
            "estop": st.estop_pressed or st.estop_latched, "can_move": st.can_move,
            "command": st.command.name if st.command is not None else None, "queue": st.queue,
            "tool": st.tool, "trajectory": self._last_event,
            "trajectory_publishers": self.trajectory_publishers,
        }

    def event(self, text: str, level: int = logging.INFO) -> None:
        """Log ``text`` and publish it on ``parolkit/events``."""
        log.log(level, "trajectory: %s", text)
        self._last_event = text
        self.events.write(msgs.String(data=text))

    # ---- joint_trajectory -> controller ----
    def _trajectory_loop(self) -> None:
        ws = WaitSet(self.dp)
        cond = ReadCondition(self.trajectories, SampleState.NotRead | ViewState.Any | InstanceState.Any)
        ws.attach(cond)
        matched = 0
        while not self._stop.is_set():
            ws.wait(duration(milliseconds=200))
            now = len(self.trajectories.get_matched_publications())
            if now != matched:
                log.info("joint_trajectory: %d publisher(s) matched", now)
                matched = now
                self.trajectory_publishers = now
            for sample in self.trajectories.take(N=16):
                if isinstance(sample, msgs.JointTrajectory):
                    try:
                        self.execute(sample)
                    except RobotError as exc:
                        self.event(f"failed: {exc}", logging.ERROR)

    def busy(self) -> str | None:
        """Why a new trajectory cannot start now, or None."""
        if self._active is not None and not self._active.done():
            return "busy: a trajectory is running"
        if self.arm_action.running:
            return "busy: a FollowJointTrajectory goal is running"
        st = self.robot.status()
        if not st.can_move:
            return (f"the robot cannot move (state {st.state}, enabled={st.enabled}, homed={st.all_homed}, "
                    f"E-stop={'yes' if st.estop_pressed or st.estop_latched else 'no'})")
        if st.command is not None or st.queue:
            return f"busy: the controller runs {st.command.name if st.command else 'a queued command'}"
        return None

    def execute(self, traj: msgs.JointTrajectory) -> bool:
        """Check ``traj`` and send it as one MOVEJOINTPATH; False (with an event) when refused.
        An empty trajectory (no points) is ROS's stop: it stops what moves (True)."""
        if not traj.points:
            ticks = self.arm_action.stop_all("an empty JointTrajectory")
            self.event("stopped: an empty JointTrajectory; " + (ticks.words() if ticks else "nothing was moving"))
            return True
        why = self.busy()
        if why is not None:
            self.event(f"refused: {why}", logging.WARNING)
            return False
        st = self.robot.status()
        points = [TrajectoryPoint(list(p.positions), msgs.duration_to_s(p.time_from_start), list(p.velocities))
                  for p in traj.points]
        rate = st.loop.rate_hz or self.cfg.controller.rate_hz
        try:
            path = plan_joint_trajectory(list(traj.joint_names), points, st.angles, self.cfg.robot, rate,
                                         start_tolerance_rad=self.cfg.ros2.start_tolerance_rad,
                                         convention=self.convention)
        except TrajectoryRefused as exc:
            self.event(f"refused: {exc}", logging.WARNING)
            return False
        move = path.move
        try:
            handle = self.robot.move_joint_path(move.points_deg, move.times_s, move.velocities_deg_s, wait=False)
        except RobotError as exc:
            self.event(f"refused by the controller: {exc}", logging.WARNING)
            return False
        self._active = handle
        shape = "the message's velocities" if move.velocities_deg_s is not None else "spline velocities"
        notes = "".join(f"; {n}" for n in path.notes)
        self.event(f"accepted: {path.points} points, {path.ticks} ticks ({path.ticks / rate:.3f} s), {shape}{notes}")
        threading.Thread(target=self._watch, args=(handle, path.points), daemon=True,
                         name="parolkit-ros2-watch").start()
        return True

    def _watch(self, handle: CommandHandle, points: int) -> None:
        try:
            handle.result(timeout=None)
        except RobotError as exc:
            self.event(f"failed: {exc}", logging.ERROR)
            return
        self.event(f"done: {points} points")

    def _make_actions(self) -> tuple[ArmTrajectoryAction, GripperAction]:
        """The action servers, their endpoints announced as the node's (imported here: they
        import this module)."""
        from parolkit.ros2.follow_joint_trajectory import ArmTrajectoryAction
        from parolkit.ros2.gripper_action import GripperAction

        arm, gripper = ArmTrajectoryAction(self), GripperAction(self)
        for server in (arm.server, gripper.server):
            readers, writers = server.endpoints()
            self.graph.add(readers=list(readers), writers=list(writers))
        return arm, gripper

    def close(self) -> None:
        self.arm_action.close()
        self.gripper_action.close()
        self._stop.set()
        if self._sub is not None:
            self._sub.close()
        if self._thread is not None:
            self._thread.join(2.0)
        self.graph.close()


def _stamped(t: FrameTransform, stamp: msgs.Time) -> msgs.TransformStamped:
    """A :class:`parolkit.ros2.tf.FrameTransform` as a geometry_msgs/TransformStamped."""
    return msgs.TransformStamped(
        header=msgs.MsgHeader(stamp=stamp, frame_id=t.parent), child_frame_id=t.child,
        transform=msgs.Transform(translation=msgs.Vector3(*t.translation), rotation=msgs.Quaternion(*t.rotation)))


def run_bridge(cfg: Config, host: str, port: int, *, domain_flag: int | None = None, frame_prefix: str = "") -> int:
    """``parolkit ros2``: run until SIGINT/SIGTERM; 1 if the controller cannot be reached, 2 for
    a bad domain or frame prefix.  ``domain_flag``: ``--domain`` (None: not given, see
    :func:`parolkit.ros2.graph.resolve_domain`)."""
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        choice = resolve_domain(domain_flag, cfg)
        check_frame_prefix(frame_prefix)
    except ParolkitError as exc:
        print(f"parolkit ros2: {exc}", file=sys.stderr)
        return 2
    try:
        robot = Robot(host, port)
        first = robot.status()
    except RobotError as exc:
        log.error("cannot reach the controller at %s:%d: %s", host, port, exc)
        return 1
    bridge = Ros2Bridge(cfg, robot, domain=choice.domain, frame_prefix=frame_prefix)
    stop = threading.Event()

    def _on_signal(signum: int, frame: object) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, _on_signal)
    signal.signal(signal.SIGINT, _on_signal)
    bridge.start()
    ns = bridge.namespace or "(none)"
    log.info("ROS 2 bridge up: node %s, domain %d (from %s), namespace %s, controller %s:%d (state %s, %g Hz)",
             bridge.graph.namespace.rstrip("/") + "/" + bridge.graph.name, choice.domain, choice.source, ns,
             host, port, first.state, first.loop.rate_hz)
    print(f"parolkit ros2: ready (domain {choice.domain} from {choice.source}, namespace {ns})", flush=True)
    try:
        while not stop.wait(0.5):
            if bridge.status_age_s() > STATUS_SILENCE_S:
                log.error("no status from the controller at %s:%d for %g s: exiting (restart me when it is back)",
                          host, port, STATUS_SILENCE_S)
                return 1
    finally:
        bridge.close()
        robot.close()
    return 0
