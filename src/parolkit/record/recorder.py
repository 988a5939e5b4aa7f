"""A recorder: a client of the controller's status stream that writes an MCAP recording.

It is an observer (issue 13): it sends only what is open to every client (``ACK_HERE``,
``SUBSCRIBE`` renewed every 3 s from its own socket, ``GET_PLAN``, ``UNSUBSCRIBE``), never
takes the control lease, so any number of recorders run at once (the controller serves at
most 16 subscribers).  Per status (every ``every_n`` ticks) it writes ``/joint_states``,
``/tcp_pose``, ``/tf`` (every link of the URDF, :mod:`parolkit.ros2.tf`) and
``/parolkit/status``; with the first status, and again when the controller's tool changes,
``/robot_description`` (the URDF with that tool) and ``/tf_static`` (its fixed frames); it
writes ``/parolkit/commands`` when the active command (of any client) starts or ends and for
each datagram it sends itself, ``/parolkit/acks`` for the acks it receives (those of its own
commands: the controller sends other clients' acks only to them) and ``/parolkit/plans`` when
a new motion starts.  Every message's MCAP ``sequence`` is the controller tick, so dropped
samples show as gaps.

Times: a message's log time is when the recorder received it (UNIX ns, as rosbag2 records);
the header stamps and publish times of what a status carries are the controller's tick time:
its ``time`` (s since its first tick) on the UNIX clock, anchored at the first status received.
"""

from __future__ import annotations

import json
import math
import socket
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from parolkit.client import robot_api as wire
from parolkit.client.core import SUBSCRIBE_RENEW_S, bind_address
from parolkit.client.errors import ControllerUnreachable, ReplyError
from parolkit.errors import ParolkitError
from parolkit.kinematics.fk import fk_frames
from parolkit.kinematics.pose import pose_to_matrix
from parolkit.kinematics.tools import TOOLS, Tool
from parolkit.record import messages
from parolkit.record.schemas import (
    ACK,
    COMMAND_EVENT,
    JOINT_STATE,
    PLAN,
    POSE_STAMPED,
    STRING,
    TF_MESSAGE,
    TOPIC_ACKS,
    TOPIC_COMMANDS,
    TOPIC_JOINT_STATES,
    TOPIC_PLANS,
    TOPIC_ROBOT_DESCRIPTION,
    TOPIC_TCP_POSE,
    TOPIC_TF,
    TOPIC_TF_STATIC,
)
from parolkit.record.writer import RecordingWriter
from parolkit.robot import PAROL6
from parolkit.ros2.convention import PAROLKIT
from parolkit.ros2.tf import TfTree
from parolkit.ros2.urdf import make_urdf

__all__ = ["Recorder", "RecorderStats", "RecorderError", "status_tool"]

_RAD = math.pi / 180.0
_STATUS = b"STATUS_JSON|"
_PLAN = b"PLAN|"
_ACK = b"ACK|"


#: a built-in tool is taken as the status's when the TCP the status reports is this close to it, m
_TOOL_MATCH_M = 1e-5


def status_tool(status: dict[str, Any]) -> Tool:
    """The tool of a status: the TCP it reports in the flange frame of its joint angles (the
    status does not say what a config's tool is), the built-in tool of that name exactly
    when it matches (within :data:`_TOOL_MATCH_M`; the status rounds its pose)."""
    name = str(status.get("tool") or "tool")
    flange = fk_frames(status["angles"])[6]
    derived = np.linalg.inv(flange) @ pose_to_matrix(status["pose"])
    derived[3] = (0.0, 0.0, 0.0, 1.0)
    u, _, vt = np.linalg.svd(derived[:3, :3])  # the nearest rotation (the status's rounding)
    derived[:3, :3] = u @ vt
    built_in = TOOLS.get(name)
    if built_in is not None and float(np.abs(built_in.matrix - derived).max()) <= _TOOL_MATCH_M:
        return built_in
    return Tool(name, derived)


#: what :meth:`Recorder.run` raises: no status for ``silence_timeout_s`` (ControllerUnreachable)
#: or the subscription refused / an ``ERROR|`` answer (ReplyError)
RecorderError = (ControllerUnreachable, ReplyError)


@dataclass
class RecorderStats:
    """What a recording holds (printed and written as its closing summary).

    ``dropped_ticks``: ticks between the first and the last status received that never
    arrived (with ``every_n`` > 1 only the expected ticks count).
    """

    path: str
    controller: str
    every_n: int
    statuses: int = 0
    first_tick: int | None = None
    last_tick: int | None = None
    dropped_ticks: int = 0
    duplicates: int = 0
    commands_seen: int = 0
    acks: int = 0
    plans: int = 0
    messages: int = 0
    duration_s: float = 0.0
    bytes: int = 0
    closed_by: str = ""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def text(self) -> str:
        span = "-" if self.first_tick is None else f"{self.first_tick}..{self.last_tick}"
        per_min = self.bytes / self.duration_s * 60 / 1e6 if self.duration_s > 0 else 0.0
        return (f"recorded {self.statuses} statuses (ticks {span}, {self.dropped_ticks} dropped, "
                f"{self.duplicates} duplicates) in {self.duration_s:.1f} s from {self.controller}: "
                f"{self.messages} messages, {self.commands_seen} command events, {self.acks} acks, "
                f"{self.plans} plans; {self.path} {self.bytes / 1e6:.2f} MB ({per_min:.2f} MB/min)")


class Recorder:
    """Record ``host:port`` into ``path`` until :meth:`stop` is called or ``duration_s`` passes."""

    def __init__(self, host: str, port: int, path: str | Path, *, every_n: int = 1,
                 flush_interval_s: float = 1.0, silence_timeout_s: float = 5.0) -> None:
        if every_n < 1:
            raise ValueError(f"every_n must be >= 1, got {every_n}")
        self.host, self.port, self.every_n = host, port, every_n
        self.path = Path(path)
        self.silence_timeout_s = silence_timeout_s
        self._sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
        self._sock.bind((bind_address(host), 0))
        # connected: the kernel delivers only the controller's datagrams
        self._sock.connect((host, port))
        self._sock.settimeout(0.1)
        self.local_port: int = self._sock.getsockname()[1]
        self.writer = RecordingWriter(self.path, flush_interval_s=flush_interval_s)
        self.stats = RecorderStats(path=str(self.path), controller=f"{host}:{port}", every_n=every_n)
        self._stop = False
        self._last_command: tuple[Any, Any] | None = None
        self._plan_seq: Any = None
        self._last_renew = 0.0
        #: the controller's last COOKIE answer (echoed in every SUBSCRIBE)
        self._cookie: str | None = None
        #: UNIX ns of the controller's time 0 (the first status's receive time minus its time)
        self._epoch_ns: int | None = None
        #: the tool the last /robot_description and /tf_static were written for, and their TF tree
        self._tool_name: str | None = None
        self._tree: TfTree | None = None

    def stop(self) -> None:
        """Ask :meth:`run` to finish (safe from a signal handler: one attribute store)."""
        self._stop = True

    # ------------------------------------------------------------------ sending

    def _send(self, body: str, with_id: bool = True) -> None:
        text = f"{wire.new_command_id()}|{body}" if with_id else body
        try:
            self._sock.send(text.encode())
        except ConnectionRefusedError:  # an earlier datagram found nobody listening: retried
            return
        now = time.time_ns()
        event = {"source": "recorder", "sent": text, "tick": self.stats.last_tick}
        self.writer.write_ros(TOPIC_COMMANDS, COMMAND_EVENT, messages.command_event(event, now), now,
                              self.stats.last_tick or 0)

    def _renew(self) -> None:
        self._send(wire.build_subscribe(self.local_port, self.every_n, self._cookie))
        self._last_renew = time.monotonic()

    # ------------------------------------------------------------------ receiving

    def _on_status(self, payload: bytes, now_ns: int) -> None:
        status = json.loads(payload)
        seq = int(status["seq"])
        st = self.stats
        if st.last_tick is not None:
            if seq <= st.last_tick:
                st.duplicates += 1
                return
            gap = seq - st.last_tick
            if gap > self.every_n:
                st.dropped_ticks += gap // self.every_n - 1
        else:
            st.first_tick = seq
        st.last_tick = seq
        st.statuses += 1
        w = self.writer
        tick_ns = self._tick_ns(status, now_ns)
        tree = self._describe(status, now_ns, tick_ns, seq)

        def put(topic: str, datatype: str, message: dict[str, Any]) -> None:
            w.write_ros(topic, datatype, message, now_ns, seq, tick_ns)

        put(TOPIC_JOINT_STATES, JOINT_STATE, messages.joint_state(status, tick_ns))
        put(TOPIC_TCP_POSE, POSE_STAMPED, messages.pose_stamped(status, tick_ns))
        put(TOPIC_TF, TF_MESSAGE, messages.tf_message(tree.transforms([a * _RAD for a in status["angles"]]), tick_ns))
        w.write_status(status, now_ns, seq, json_text=payload.decode(), publish_time_ns=tick_ns)
        cmd = status.get("command") or {}
        key = (cmd.get("id"), cmd.get("name"))
        if key != self._last_command:
            if self._last_command is not None and self._last_command[1] is not None:
                put(TOPIC_COMMANDS, COMMAND_EVENT, messages.command_event(
                    {"source": "status", "event": "ended", "tick": seq, "id": self._last_command[0],
                     "name": self._last_command[1]}, tick_ns))
                st.commands_seen += 1
            if key[1] is not None:
                put(TOPIC_COMMANDS, COMMAND_EVENT, messages.command_event(
                    {"source": "status", "event": "started", "tick": seq, "id": key[0], "name": key[1]}, tick_ns))
                st.commands_seen += 1
            self._last_command = key
        plan_seq = status.get("plan_seq")
        if plan_seq != self._plan_seq:
            self._plan_seq = plan_seq
            if self._plan_seq is not None and key[1] is not None:
                try:
                    self._sock.send(b"GET_PLAN")
                except ConnectionRefusedError:
                    pass

    def _tick_ns(self, status: dict[str, Any], now_ns: int) -> int:
        """The controller's tick time of ``status`` on the UNIX clock (module docstring)."""
        t_ns = round(float(status.get("time", 0.0)) * 1e9)
        if self._epoch_ns is None:
            self._epoch_ns = now_ns - t_ns
        return self._epoch_ns + t_ns

    def _describe(self, status: dict[str, Any], now_ns: int, tick_ns: int, seq: int) -> TfTree:
        """The TF tree of the status's tool; /robot_description and /tf_static written when
        the tool is new (the first status, a SET_TOOL)."""
        name = str(status.get("tool") or "")
        if self._tree is not None and name == self._tool_name:
            return self._tree
        try:
            tool = status_tool(status)
        except (KeyError, ValueError, ParolkitError):
            tool = TOOLS["default"]  # a status without angles or pose: the URDF's default tool
        rate = float((status.get("loop") or {}).get("rate_hz") or 0.0) or None
        urdf = make_urdf(PAROL6, tool, rate_hz=rate, convention=PAROLKIT)
        self._tree = TfTree(urdf)
        self._tool_name = name
        self.writer.write_ros(TOPIC_ROBOT_DESCRIPTION, STRING, {"data": urdf}, now_ns, seq, tick_ns)
        self.writer.write_ros(TOPIC_TF_STATIC, TF_MESSAGE,
                              messages.tf_message(self._tree.static_transforms(), tick_ns), now_ns, seq, tick_ns)
        return self._tree

    def _on_datagram(self, data: bytes) -> None:
        now = time.time_ns()
        if data.startswith(_STATUS):
            self._on_status(data[len(_STATUS):], now)
        elif data.startswith(_ACK):
            parts = data.decode(errors="replace").split("|", 3)
            ack = {"id": parts[1] if len(parts) > 1 else None, "status": parts[2] if len(parts) > 2 else None,
                   "details": parts[3] if len(parts) > 3 else "", "tick": self.stats.last_tick}
            self.writer.write_ros(TOPIC_ACKS, ACK, messages.ack_message(ack, now), now, self.stats.last_tick or 0)
            self.stats.acks += 1
            if ack["status"] == "FAILED" and "SUBSCRIBE" in str(ack["details"]).upper():
                raise ReplyError(f"the controller refused the subscription: {ack['details']}")
        elif data.startswith(_PLAN):
            plan = json.loads(data[len(_PLAN):])
            plan["tick"] = self.stats.last_tick
            self.writer.write_ros(TOPIC_PLANS, PLAN, messages.plan_message(plan, now), now, self.stats.last_tick or 0)
            self.stats.plans += 1
        elif data.startswith(b"ERROR|"):
            raise ReplyError(f"the controller answered: {data.decode(errors='replace')}")
        else:
            cookie = wire.parse_cookie(data.decode(errors="replace"))
            if cookie is not None:  # the stream starts once this socket echoes it
                self._cookie = cookie
                self._renew()

    # ------------------------------------------------------------------ main loop

    def run(self, duration_s: float | None = None,
            on_progress: Callable[[RecorderStats], None] | None = None) -> RecorderStats:
        """Record until :meth:`stop` or ``duration_s`` (s, from the first status); close the file.

        Raises ControllerUnreachable when no status arrives for ``silence_timeout_s``, ReplyError
        when the controller refuses the subscription (the file is closed either way).
        """
        start = time.monotonic()
        first: float | None = None
        last_rx = start
        closed_by = "stop"
        try:
            self._send("ACK_HERE")
            self._renew()
            while not self._stop:
                now = time.monotonic()
                if now - self._last_renew >= SUBSCRIBE_RENEW_S:
                    self._renew()
                if duration_s is not None and first is not None and now - first >= duration_s:
                    closed_by = "duration"
                    break
                if now - last_rx > self.silence_timeout_s:
                    raise ControllerUnreachable(f"no status from {self.host}:{self.port} for "
                                        f"{self.silence_timeout_s:g} s: is the controller running?")
                try:
                    data = self._sock.recv(65536)
                except TimeoutError:
                    self.writer.maybe_flush()
                    continue
                except ConnectionRefusedError:  # ICMP: nothing listens there (yet)
                    time.sleep(0.1)
                    continue
                last_rx = time.monotonic()
                if first is None and data.startswith(_STATUS):
                    first = last_rx
                self._on_datagram(data)
                self.writer.maybe_flush()
                if on_progress is not None:
                    on_progress(self.stats)
            else:
                closed_by = "signal or stop()"
        except RecorderError:
            closed_by = "error"
            raise
        finally:
            try:
                self._sock.send(f"UNSUBSCRIBE|{self.local_port}".encode())
            except OSError:
                pass
            self._sock.close()
            self.stats.duration_s = round(time.monotonic() - (first or start), 3)
            self.stats.closed_by = closed_by
            self.stats.messages = self.writer.messages
            self.writer.close(self.stats.as_dict())
            self.stats.bytes = self.path.stat().st_size
        return self.stats
