"""The status snapshot: one immutable value per tick, and every reply format built from it.

The controller core builds a :class:`Snapshot` at the end of each tick (cheap: references and
a few scalars, plain data) and the driver publishes it by assignment.  Query threads format
replies from the latest snapshot without waiting for the next tick: the status queries,
GET_QUEUE (per viewer), GET_PLAN and GET_LOOP_STATS.  Expensive derived values (angles in
degrees, forward kinematics) are computed on first use and cached inside the snapshot (two
threads asking at once may both compute them: the same values, assigned whole).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from parolkit._frozen import quick_init
from parolkit.controller.integrity import IntegrityView
from parolkit.controller.jobs import QueueView
from parolkit.controller.world import CollisionView
from parolkit.protocol.commands import dumps, format_floats
from parolkit.protocol.frames import CommandFrame, IOBits, StatusFrame

__all__ = ["RobotState", "CommandInfo", "BoardInfo", "PlanView", "Snapshot", "PoseProvider", "SNAPSHOT_QUERIES"]

log = logging.getLogger("parolkit.controller")


_IDENTITY = (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)


class RobotState(str, Enum):
    """What the controller is doing (``STATE=`` in GET_STATUS, ``state`` in JSON)."""

    IDLE = "IDLE"
    MOVING = "MOVING"
    HOMING = "HOMING"
    DISABLED = "DISABLED"
    ESTOP = "ESTOP"
    ERROR = "ERROR"
    DISCONNECTED = "DISCONNECTED"


@quick_init
@dataclass(frozen=True)
class CommandInfo:
    """The active command: ID (or None), name, progress 0..1; a servo stream's newest target
    taken (its ID, or None: not a stream, or a target sent without one)."""

    command_id: str | None
    name: str
    progress: float
    target_id: str | None = None

    def as_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"id": self.command_id, "name": self.name, "progress": round(self.progress, 4)}
        if self.target_id is not None:
            d["target"] = self.target_id
        return d


@quick_init
@dataclass(frozen=True)
class BoardInfo:
    """The board link."""

    connected: bool
    simulated: bool
    port: str


#: ``(angles_deg, tool_name) -> (pose_mm_deg[6], matrix_m[16])`` computed by kinematics.
PoseProvider = Callable[[Sequence[float], str], tuple[tuple[float, ...], tuple[float, ...]]]


@quick_init
@dataclass(frozen=True)
class PlanView:
    """GET_PLAN as data: the plan counter, the running command (name, ID), its target angles
    (deg) and its trajectory (immutable arrays; its TCP path is computed when asked)."""

    seq: int = 0
    command: str | None = None
    command_id: str | None = None
    target_deg: tuple[float, ...] | None = None
    trajectory: object | None = field(default=None, repr=False)

    def as_dict(self, tool: object = None) -> dict[str, Any]:
        traj = self.trajectory
        if traj is None:
            return {"seq": self.seq, "command": self.command, "target_angles": None, "tcp_path": None}
        try:
            path = traj.tcp_path_mm(tool, max_points=400)  # type: ignore[attr-defined]
            tcp = [[round(float(v), 3) for v in p[:3]] for p in path]
        except Exception as exc:  # kinematics trouble must not stop a query
            log.warning("GET_PLAN: could not compute the TCP path: %s", exc)
            tcp = None
        final = self.target_deg
        return {"seq": self.seq, "command": self.command, "id": self.command_id,
                "target_angles": [round(v, 4) for v in final] if final else None, "tcp_path": tcp}


class Snapshot:
    """Everything a query or the status stream needs, as of one tick.

    Angles in degrees, pose in mm/deg (tool frame of ``tool``), speeds in steps/s.
    """

    __slots__ = (
        "seq", "time", "state", "enabled", "estop_pressed", "estop_latched", "status", "board",
        "error", "command", "queue", "stream_mode", "speed_pct", "paused", "queue_held", "tool", "plan_seq",
        "outputs", "loop_view",
        "server_view", "integrity", "state_known", "sent", "queue_view", "plan", "collision", "_steps_per_deg",
        "_pose_provider", "_angles", "_pose", "_matrix", "_replies",
    )

    def __init__(
        self,
        *,
        seq: int,
        time: float,
        state: RobotState,
        enabled: bool,
        estop_pressed: bool,
        estop_latched: bool,
        status: StatusFrame | None,
        board: BoardInfo,
        error: str | None,
        command: CommandInfo | None,
        queue: int,
        stream_mode: bool,
        tool: str,
        plan_seq: int,
        outputs: tuple[bool, bool],
        steps_per_deg: Sequence[float],
        pose_provider: PoseProvider | None,
        loop: Mapping[str, Any] | None = None,
        server: Mapping[str, Any] | None = None,
        integrity: IntegrityView | None = None,
        state_known: bool = True,
        sent: CommandFrame | None = None,
        queue_view: QueueView | None = None,
        plan: PlanView | None = None,
        speed_pct: float = 100.0,
        paused: bool = False,
        queue_held: bool = False,
        collision: CollisionView | None = None,
    ) -> None:
        self.seq = seq
        self.time = time
        self.state = state
        self.enabled = enabled
        self.estop_pressed = estop_pressed
        self.estop_latched = estop_latched
        self.status = status if status is not None else StatusFrame()
        self.board = board
        self.error = error
        self.command = command
        self.queue = queue
        self.stream_mode = stream_mode
        #: the SPEED override (%) and whether motion is paused (PAUSE until RESUME)
        self.speed_pct = speed_pct
        self.paused = paused
        #: PAUSE|QUEUE: nothing queued starts until RESUME (the running command goes on)
        self.queue_held = queue_held
        self.tool = tool
        self.plan_seq = plan_seq
        self.outputs = outputs
        #: the loop statistics (driver and core counters), plain data
        self.loop_view: Mapping[str, Any] = loop if loop is not None else {}
        #: the UDP server's counters
        self.server_view: Mapping[str, Any] = server if server is not None else {}
        #: status frames not taken as the truth, uncommanded motions, age of ``status``
        self.integrity = integrity if integrity is not None else IntegrityView()
        #: False while the start-up probe still asks the board whether it is enabled (a few
        #: ticks after link-up): ``enabled`` and ``state`` are provisional until then
        self.state_known = state_known
        #: the frame written this tick (after the guard): what the board was told, next to
        #: ``status``, its reply (recordings keep both: a replay sends the same frames)
        self.sent = sent
        self.queue_view = queue_view if queue_view is not None else QueueView()
        self.plan = plan if plan is not None else PlanView()
        #: the collision world in force and whether its check is ready (GET_ZONES)
        self.collision = collision if collision is not None else CollisionView()
        self._steps_per_deg = steps_per_deg
        self._pose_provider = pose_provider
        self._angles: tuple[float, ...] | None = None
        self._pose: tuple[float, ...] | None = None
        self._matrix: tuple[float, ...] | None = None
        self._replies: dict[str, str] = {}

    # ---- derived values (cached) ----

    @property
    def angles_deg(self) -> tuple[float, ...]:
        a = self._angles
        if a is None:
            a = tuple(p / s for p, s in zip(self.status.positions, self._steps_per_deg))
            self._angles = a
        return a

    @property
    def speeds_deg_s(self) -> tuple[float, ...]:
        return tuple(v / s for v, s in zip(self.status.speeds, self._steps_per_deg))

    def _fk(self) -> None:
        if self._pose is not None:
            return
        if self._pose_provider is None:
            self._matrix, self._pose = _IDENTITY, (0.0,) * 6
            return
        try:
            pose, matrix = self._pose_provider(self.angles_deg, self.tool)
        except Exception as exc:  # a query must always get an answer
            log.warning("forward kinematics failed: %s", exc)
            pose, matrix = (0.0,) * 6, _IDENTITY
        self._matrix = matrix  # (the matrix first: a reader checks the pose)
        self._pose = pose

    @property
    def pose(self) -> tuple[float, ...]:
        """[x, y, z mm, A, B, C deg] of the current tool."""
        if self._pose is None:
            self._fk()
        return self._pose  # type: ignore[return-value]

    @property
    def matrix_m(self) -> tuple[float, ...]:
        """The 4x4 tool pose, row-major, translation in metres."""
        if self._matrix is None:
            self._fk()
        return self._matrix  # type: ignore[return-value]

    @property
    def homed(self) -> tuple[bool, ...]:
        return self.status.homed_joints

    @property
    def io_values(self) -> tuple[int, int, int, int, int]:
        """(IN1, IN2, OUT1, OUT2, ESTOP) as the board reports them; ESTOP 0 = pressed."""
        io = self.status.io
        return (
            int(bool(io & IOBits.IN1)), int(bool(io & IOBits.IN2)), int(bool(io & IOBits.OUT1)),
            int(bool(io & IOBits.OUT2)), int(bool(io & IOBits.ESTOP)),
        )

    # ---- reply formats (docs/protocol.md) ----

    def reply(self, query: str) -> str:
        """The reply to a status query (one of :data:`SNAPSHOT_QUERIES`), formatted once per
        snapshot: a burst of queries within one tick costs one formatting."""
        text = self._replies.get(query)
        if text is None:
            text = self._replies[query] = getattr(self, SNAPSHOT_QUERIES[query])()
        return text

    def reply_angles(self) -> str:
        return "ANGLES|" + format_floats(self.angles_deg)

    def reply_pose(self) -> str:
        return "POSE|" + format_floats(self.matrix_m, 6)

    def reply_io(self) -> str:
        return "IO|" + ",".join(str(v) for v in self.io_values)

    @property
    def object_detection(self) -> int:
        """GET_GRIPPER's object-detection field: 1 while the gripper's status byte reports an
        object (object code 1 or 2), else 0.  The board's own byte is not used: the stock
        firmware sends a constant 1 (serial-protocol.md)."""
        return int(self.status.gripper.object_detected)

    def _gripper_csv(self) -> str:
        s = self.status
        return ",".join(str(v) for v in (
            s.gripper_id, s.gripper_position, s.gripper_speed, s.gripper_current, s.gripper_status,
            self.object_detection,
        ))

    def reply_gripper(self) -> str:
        return "GRIPPER|" + self._gripper_csv()

    def reply_speeds(self) -> str:
        return "SPEEDS|" + ",".join(str(v) for v in self.status.speeds)

    def reply_ping(self) -> str:
        """``PONG``, exactly as the original controller answered (clients compare the text);
        whether the board link is up is ``SERIAL=`` of GET_STATUS."""
        return "PONG"

    def reply_status(self) -> str:
        cmd = self.command.name if self.command else "None"
        err = (self.error or "None").replace("|", "/")
        return (
            f"STATUS|POSE={format_floats(self.matrix_m, 6)}|ANGLES={format_floats(self.angles_deg)}"
            f"|SPEEDS={','.join(str(v) for v in self.status.speeds)}"
            f"|IO={','.join(str(v) for v in self.io_values)}|GRIPPER={self._gripper_csv()}"
            f"|STATE={self.state.value}|HOMED={','.join(str(int(h)) for h in self.homed)}"
            f"|ESTOP={int(self.estop_pressed or self.estop_latched)}|QUEUE={self.queue}"
            f"|CMD={cmd}|ERROR={err}|OVERLOAD={self.overload}"
            f"|IMPLAUSIBLE={self.integrity.implausible}|UNCOMMANDED={self.integrity.uncommanded}"
            f"|SCHED={self.scheduling}|LINK_LOSSES={self.loop_view.get('link_losses', 0)}"
            f"|SPEED={self.speed_pct:g}|PAUSED={int(self.paused)}|SERIAL={int(self.board.connected)}"
        )

    @property
    def scheduling(self) -> str:
        """The tick thread's scheduling policy ("fifo:10", "nice:-10", "normal")."""
        return str(self.loop_view.get("scheduling", "unknown"))

    @property
    def overload(self) -> int:
        """Datagrams and commands the server refused for load so far, and datagrams the kernel
        dropped before the server could read them (0 without a server)."""
        v = self.server_view
        return int(v.get("shed", 0)) + int(v.get("inbox_refused", 0)) + int(v.get("kernel_dropped", 0))

    def as_dict(self) -> dict[str, Any]:
        s = self.status
        g = s.gripper
        io = self.io_values
        return {
            "seq": self.seq,
            "time": round(self.time, 4),
            "state": self.state.value,
            "enabled": self.enabled,
            "homed": list(self.homed),
            "all_homed": all(self.homed),
            "estop_pressed": self.estop_pressed,
            "estop_latched": self.estop_latched,
            "angles": [round(a, 4) for a in self.angles_deg],
            "steps": list(s.positions),
            "pose": [round(p, 4) for p in self.pose],
            "speeds": list(s.speeds),
            "speeds_deg_s": [round(v, 4) for v in self.speeds_deg_s],
            "io": {"in1": io[0], "in2": io[1], "out1": io[2], "out2": io[3], "estop": io[4]},
            "gripper": {
                "id": s.gripper_id, "position": s.gripper_position, "speed": s.gripper_speed,
                "current": s.gripper_current, "status": s.gripper_status,
                "object_detection": self.object_detection, "activated": g.activated,
                "calibrated": g.calibrated, "object_code": g.object_code,
                "object_detected": g.object_detected,
                "error": g.estop_error or g.temperature_error or g.timeout_error,
            },
            "errors": {
                "temperature": [bool(s.temperature_error & (0x80 >> i)) for i in range(6)],
                "position": [bool(s.position_error & (0x80 >> i)) for i in range(6)],
                "timeout_error": s.timeout_error,
                "message": self.error,
            },
            "board": {
                "connected": self.board.connected, "simulated": self.board.simulated,
                "port": self.board.port, "timing_ticks": s.timing,
                "timing_ms": round(s.timing_s * 1e3, 3), "xtr": s.xtr,
                "state_known": self.state_known,
            },
            "loop": dict(self.loop_view),
            "integrity": self.integrity.as_dict(),
            "scheduling": self.scheduling,
            "server": dict(self.server_view),
            "command": self.command.as_dict() if self.command else None,
            "queue": self.queue,
            "stream_mode": self.stream_mode,
            "speed_pct": self.speed_pct,
            "paused": self.paused,
            "queue_held": self.queue_held,
            "tool": self.tool,
            "plan_seq": self.plan_seq,
            "collision": self.collision.status_dict(),
            "sent": ({"command": int(self.sent.command), "steps": list(self.sent.positions),
                      "speeds": list(self.sent.speeds)} if self.sent is not None else None),
        }

    def reply_status_json(self) -> str:
        return "STATUS_JSON|" + dumps(self.as_dict())

    def reply_queue(self, viewer: str | None = None) -> str:
        """GET_QUEUE: the running and waiting commands; a command's ID only to the client that
        sent it (``viewer``: see Submission.client), ``null`` to everyone else (an ID lets its
        holder follow the command's acks; nobody else needs it)."""
        q = self.queue_view

        def cid(e: Any) -> str | None:
            return e.command_id if viewer is not None and e.client == viewer else None

        act = None
        if q.active is not None:
            act = {"id": cid(q.active), "name": q.active.name, "mine": q.active.client == viewer,
                   "progress": round(q.progress, 4)}
        return "QUEUE|" + dumps({"active": act, "queued": [{"id": cid(e), "name": e.name, "mine": e.client == viewer}
                                                           for e in q.waiting]})

    def reply_zones(self) -> str:
        """GET_ZONES: the collision world in force (docs/protocol.md, "The collision world")."""
        return "ZONES|" + dumps(self.collision.zones_dict(self.tool))

    def reply_loop_stats(self, extra: Mapping[str, Any] | None = None) -> str:
        """GET_LOOP_STATS: the loop statistics (and ``extra``, the server's own)."""
        out = dict(self.loop_view)
        if extra:
            out.update(extra)
        return "LOOP_STATS|" + dumps(out)


#: status queries answered from the snapshot alone -> the method that formats the reply
SNAPSHOT_QUERIES = {
    "PING": "reply_ping", "GET_ANGLES": "reply_angles", "GET_POSE": "reply_pose", "GET_IO": "reply_io",
    "GET_GRIPPER": "reply_gripper", "GET_SPEEDS": "reply_speeds", "GET_STATUS": "reply_status",
    "GET_STATUS_JSON": "reply_status_json", "GET_ZONES": "reply_zones",
}
