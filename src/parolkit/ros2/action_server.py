"""A ROS 2 action server on plain DDS (cyclonedds), generic over the action's types.

ROS 2 maps an action ``/<ns>/<name>`` onto five DDS endpoints (rcl_action's design):

* the services ``<name>/_action/send_goal``, ``<name>/_action/get_result`` and
  ``<name>/_action/cancel_goal``: each a request topic ``rq/<ns>/<name>/_action/send_goalRequest``
  (type ``pkg::action::dds_::Name_SendGoal_Request_``) read here and a reply topic
  ``rr/<ns>/<name>/_action/send_goalReply`` written here;
* the topics ``rt/<ns>/<name>/_action/feedback`` (``Name_FeedbackMessage``) and
  ``rt/<ns>/<name>/_action/status`` (action_msgs/GoalStatusArray, transient local, keep last 1).

Requests and replies carry rmw_cyclonedds_cpp's request header in front of the message
(``{uint64 guid; int64 seq}``: the client's id and its request's number, copied into the reply,
by which the client matches it), and the endpoints' user data name the service
(``serviceid=...;``) and the type hash (``typehash=RIHS01_...;``) as rmw_cyclonedds_cpp's do, so
a ROS 2 node on Cyclone DDS (``RMW_IMPLEMENTATION=rmw_cyclonedds_cpp``) calls it as any action
server.  (ROS 2's Fast DDS RMW carries that header out of band, in an inline QoS Cyclone DDS
cannot write: its clients see the server and its topics but get no replies; docs/ros2.md.)

Goal life cycle as rcl_action's: a goal is ACCEPTED or rejected at once (``on_goal``), then
EXECUTING, and ends SUCCEEDED, ABORTED or CANCELED with a result; a cancel request (one goal,
every goal up to a time, or all) moves the goals ``on_cancel`` agrees to to CANCELING.  Every
change publishes the status array; a get_result request is answered when its goal has ended
(at once for an ended or unknown goal, status UNKNOWN for the latter).  Ended goals' results
are kept for ``result_timeout_s`` (rcl_action's default: 15 min).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from parolkit.ros2 import msgs
from parolkit.ros2.action_msgs import (
    CANCEL_GOAL,
    UUID,
    ActionTypes,
    CancelGoal_Response,
    GoalInfo,
    GoalStatus,
    GoalStatusArray,
    service_wire_type,
    unwrap,
    wrap,
)
from parolkit.ros2.struct_hash import struct_hash as type_hash

__all__ = ["ActionServer", "GoalHandle", "GoalResponse", "action_topics", "service_qos", "status_qos",
           "TERMINAL", "status_name"]

log = logging.getLogger("parolkit.ros2.action")

S = GoalStatus
#: the statuses a goal ends in
TERMINAL = (S.STATUS_SUCCEEDED, S.STATUS_CANCELED, S.STATUS_ABORTED)
_NAMES = {S.STATUS_UNKNOWN: "UNKNOWN", S.STATUS_ACCEPTED: "ACCEPTED", S.STATUS_EXECUTING: "EXECUTING",
          S.STATUS_CANCELING: "CANCELING", S.STATUS_SUCCEEDED: "SUCCEEDED", S.STATUS_CANCELED: "CANCELED",
          S.STATUS_ABORTED: "ABORTED"}
#: how long a reply waits for the client's reply reader to be matched (as rmw_cyclonedds_cpp), s
REPLY_MATCH_WAIT_S = 0.1


def status_name(status: int) -> str:
    """``SUCCEEDED`` etc. for a GoalStatus value."""
    return _NAMES.get(status, str(status))


def service_qos(user_data: str) -> Qos:
    """rmw_qos_profile_services_default (reliable, volatile, keep last 10) with ``user_data``."""
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               Policy.History.KeepLast(10), Policy.Durability.Volatile, Policy.Userdata(user_data.encode()))


def status_qos(user_data: str) -> Qos:
    """rcl_action's status QoS: reliable, keep last 1, transient local."""
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               Policy.History.KeepLast(1), Policy.Durability.TransientLocal, Policy.Userdata(user_data.encode()))


def feedback_qos(user_data: str) -> Qos:
    """rcl_action's feedback QoS: ROS 2's default (reliable, keep last 10, volatile)."""
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               Policy.History.KeepLast(10), Policy.Durability.Volatile, Policy.Userdata(user_data.encode()))


def action_topics(namespace: str, name: str) -> dict[str, str]:
    """The DDS topic names of action ``/<namespace>/<name>``."""
    base = "/".join(p for p in (namespace.strip("/"), name.strip("/")) if p) + "/_action/"
    topics = {f"{s}_request": f"rq/{base}{s}Request" for s in ("send_goal", "get_result", "cancel_goal")}
    topics.update({f"{s}_reply": f"rr/{base}{s}Reply" for s in ("send_goal", "get_result", "cancel_goal")})
    topics.update(feedback=f"rt/{base}feedback", status=f"rt/{base}status")
    return topics


@dataclass(frozen=True)
class GoalResponse:
    """``on_goal``'s answer: accept, or reject with the reason (logged; ROS's SendGoal reply
    has only ``accepted``, so a server that wants the reason to reach the client accepts and
    aborts with it)."""

    accept: bool
    reason: str = ""


@dataclass
class _Pending:
    guid: int
    seq: int
    handle: int  # the request writer's instance handle (to find the client's reply reader)


@dataclass(eq=False)
class GoalHandle:
    """One goal: its id, the goal message, the time it was accepted and its status."""

    server: ActionServer
    goal_id: bytes
    goal: Any
    stamp: msgs.Time
    status: int = S.STATUS_ACCEPTED
    result: Any = None
    ended_at: float = 0.0
    waiting: list[_Pending] = field(default_factory=list)

    @property
    def id_hex(self) -> str:
        return self.goal_id.hex()

    @property
    def active(self) -> bool:
        return self.status not in TERMINAL

    @property
    def cancel_requested(self) -> bool:
        return self.status == S.STATUS_CANCELING

    def execute(self) -> None:
        """ACCEPTED -> EXECUTING."""
        self.server._transition(self, S.STATUS_EXECUTING)

    def publish_feedback(self, feedback: Any) -> None:
        self.server._feedback(self, feedback)

    def succeed(self, result: Any) -> None:
        self.server._finish(self, S.STATUS_SUCCEEDED, result)

    def abort(self, result: Any) -> None:
        self.server._finish(self, S.STATUS_ABORTED, result)

    def canceled(self, result: Any) -> None:
        self.server._finish(self, S.STATUS_CANCELED, result)


class ActionServer:
    """The action ``/<namespace>/<name>`` of type ``types`` on participant ``dp``.

    ``on_goal(handle)``: accept or reject a new goal (:class:`GoalResponse`); then
    ``on_accepted(handle)`` starts it (it must not block: the goal ends later through the
    handle).  ``on_cancel(handle)``: True to take a cancel request for an active goal (it is
    CANCELING until the executor ends it).  Callbacks run on the server's thread.
    """

    def __init__(self, dp: DomainParticipant, namespace: str, name: str, types: ActionTypes, *,
                 on_goal: Callable[[GoalHandle], GoalResponse], on_accepted: Callable[[GoalHandle], None],
                 on_cancel: Callable[[GoalHandle], bool], clock_ns: Callable[[], int] = time.time_ns,
                 result_timeout_s: float = 900.0) -> None:
        self.types = types
        self.name = "/" + "/".join(p for p in (namespace.strip("/"), name.strip("/")) if p)
        self._on_goal, self._on_accepted, self._on_cancel = on_goal, on_accepted, on_cancel
        self._clock_ns = clock_ns
        self._result_timeout_s = result_timeout_s
        self._lock = threading.RLock()
        self._goals: dict[bytes, GoalHandle] = {}
        self._stop = threading.Event()
        t = action_topics(namespace, name)
        sid = os.urandom(16).hex()
        services = {"send_goal": (types.send_goal.request, types.send_goal.response),
                    "get_result": (types.get_result.request, types.get_result.response),
                    "cancel_goal": (CANCEL_GOAL.request, CANCEL_GOAL.response)}
        hashes = {"send_goal": type_hash(types.send_goal), "get_result": type_hash(types.get_result),
                  "cancel_goal": type_hash(CANCEL_GOAL)}
        self._readers: dict[str, DataReader[Any]] = {}
        self._writers: dict[str, DataWriter[Any]] = {}
        for s, (req, resp) in services.items():
            ud = f"serviceid={sid};typehash={hashes[s]};"
            self._readers[s] = DataReader(dp, Topic(dp, t[f"{s}_request"], service_wire_type(req)), service_qos(ud))
            self._writers[s] = DataWriter(dp, Topic(dp, t[f"{s}_reply"], service_wire_type(resp)), service_qos(ud))
        self._feedback_writer = DataWriter(dp, Topic(dp, t["feedback"], types.feedback_message),
                                           feedback_qos(f"typehash={type_hash(types.feedback_message)};"))
        self._status_writer = DataWriter(dp, Topic(dp, t["status"], GoalStatusArray),
                                         status_qos(f"typehash={type_hash(GoalStatusArray)};"))
        self._waitset = WaitSet(dp)
        self._conds = {}
        for s, r in self._readers.items():
            cond = ReadCondition(r, SampleState.NotRead | ViewState.Any | InstanceState.Any)
            self._waitset.attach(cond)
            self._conds[s] = cond
        self._publish_status()
        self._thread = threading.Thread(target=self._loop, daemon=True, name=f"parolkit-ros2-action{self.name}")
        self._thread.start()

    # ---- the server's thread ----
    def _loop(self) -> None:
        handlers = {"send_goal": self._send_goal, "get_result": self._get_result, "cancel_goal": self._cancel_goal}
        requests = {"send_goal": self.types.send_goal.request, "get_result": self.types.get_result.request,
                    "cancel_goal": CANCEL_GOAL.request}
        while not self._stop.is_set():
            self._waitset.wait(duration(milliseconds=100))
            for s, reader in self._readers.items():
                for sample in reader.take(N=16):
                    if not hasattr(sample, "guid"):
                        continue  # a disposed instance: no data
                    pending = _Pending(int(sample.guid), int(sample.seq),
                                       int(sample.sample_info.publication_handle))
                    try:
                        handlers[s](pending, unwrap(sample, requests[s]))
                    except Exception:  # a bad callback must not end the server
                        log.exception("%s: %s request failed", self.name, s)
            self._expire()

    def _send_goal(self, req: _Pending, body: Any) -> None:
        goal_id = bytes(body.goal_id.uuid)
        now = self._clock_ns()
        stamp = msgs.time_from_ns(now)
        with self._lock:
            if goal_id in self._goals:
                log.warning("%s: goal %s refused: its id is already in use", self.name, goal_id.hex())
                self._reply("send_goal", req, self.types.send_goal.response(accepted=False, stamp=stamp))
                return
            handle = GoalHandle(self, goal_id, body.goal, stamp)
            answer = self._on_goal(handle)
            if not answer.accept:
                log.warning("%s: goal %s rejected: %s", self.name, goal_id.hex(), answer.reason)
                self._reply("send_goal", req, self.types.send_goal.response(accepted=False, stamp=stamp))
                return
            self._goals[goal_id] = handle
            self._reply("send_goal", req, self.types.send_goal.response(accepted=True, stamp=stamp))
            self._publish_status()
        self._on_accepted(handle)

    def _get_result(self, req: _Pending, body: Any) -> None:
        goal_id = bytes(body.goal_id.uuid)
        with self._lock:
            handle = self._goals.get(goal_id)
            if handle is None:
                self._reply("get_result", req, self.types.get_result.response(status=S.STATUS_UNKNOWN,
                                                                              result=self.types.result()))
            elif not handle.active:
                self._reply("get_result", req, self.types.get_result.response(status=handle.status,
                                                                              result=handle.result))
            else:
                handle.waiting.append(req)

    def _cancel_goal(self, req: _Pending, body: Any) -> None:
        info = body.goal_info
        goal_id = bytes(info.goal_id.uuid)
        until = info.stamp.sec * 1_000_000_000 + info.stamp.nanosec
        zero_id = not any(goal_id)
        with self._lock:
            if not zero_id and until == 0:
                code, chosen = self._one_to_cancel(goal_id)
            else:
                code = CancelGoal_Response.ERROR_NONE
                bound = until if until else 2**63
                chosen = [h for h in self._goals.values() if h.active
                          and (h.stamp.sec * 1_000_000_000 + h.stamp.nanosec <= bound or h.goal_id == goal_id)]
            # a goal already CANCELING is listed again without asking the executor twice
            taken = [h for h in chosen if h.cancel_requested or self._on_cancel(h)]
            if chosen and not taken:
                code = CancelGoal_Response.ERROR_REJECTED
            for h in taken:
                self._transition(h, S.STATUS_CANCELING)
            self._reply("cancel_goal", req, CancelGoal_Response(
                return_code=code, goals_canceling=[GoalInfo(goal_id=UUID(uuid=list(h.goal_id)), stamp=h.stamp)
                                                   for h in taken]))

    def _one_to_cancel(self, goal_id: bytes) -> tuple[int, list[GoalHandle]]:
        handle = self._goals.get(goal_id)
        if handle is None:
            return CancelGoal_Response.ERROR_UNKNOWN_GOAL_ID, []
        if not handle.active:
            return CancelGoal_Response.ERROR_GOAL_TERMINATED, []
        return CancelGoal_Response.ERROR_NONE, [handle]

    def _reply(self, service: str, req: _Pending, body: Any) -> None:
        """Write the reply with the request's header once the client's reply reader is matched
        (as rmw_cyclonedds_cpp: at most REPLY_MATCH_WAIT_S)."""
        writer = self._writers[service]
        participant = self._participant_of(self._readers[service], req.handle)
        deadline = time.monotonic() + REPLY_MATCH_WAIT_S
        while participant is not None and not self._has_reader_of(writer, participant):
            if time.monotonic() > deadline:
                log.warning("%s: the client's %s reply reader is not matched: reply sent anyway", self.name, service)
                break
            time.sleep(0.005)
        writer.write(wrap(body, req.guid, req.seq))

    @staticmethod
    def _participant_of(reader: DataReader[Any], handle: int) -> Any:
        try:
            data = reader.get_matched_publication_data(handle)
        except Exception:  # the writer is gone
            return None
        return None if data is None else data.participant_key

    @staticmethod
    def _has_reader_of(writer: DataWriter[Any], participant: Any) -> bool:
        for h in writer.get_matched_subscriptions():
            try:
                data = writer.get_matched_subscription_data(h)
            except Exception:  # gone meanwhile
                continue
            if data is not None and data.participant_key == participant:
                return True
        return False

    def _expire(self) -> None:
        now = time.monotonic()
        with self._lock:
            old = [k for k, h in self._goals.items() if not h.active and now - h.ended_at > self._result_timeout_s]
            for k in old:
                del self._goals[k]
            if old:
                self._publish_status()

    # ---- called through the goal handles (any thread) ----
    def _transition(self, handle: GoalHandle, status: int) -> None:
        with self._lock:
            if not handle.active or handle.status == status:
                return
            handle.status = status
            self._publish_status()

    def _feedback(self, handle: GoalHandle, feedback: Any) -> None:
        self._feedback_writer.write(self.types.feedback_message(goal_id=UUID(uuid=list(handle.goal_id)),
                                                                feedback=feedback))

    def _finish(self, handle: GoalHandle, status: int, result: Any) -> None:
        with self._lock:
            if not handle.active:
                raise RuntimeError(f"goal {handle.id_hex} already ended {status_name(handle.status)}")
            handle.status, handle.result, handle.ended_at = status, result, time.monotonic()
            self._publish_status()
            waiting, handle.waiting = handle.waiting, []
            for req in waiting:
                self._reply("get_result", req, self.types.get_result.response(status=status, result=result))

    def _publish_status(self) -> None:
        self._status_writer.write(GoalStatusArray(status_list=[
            GoalStatus(goal_info=GoalInfo(goal_id=UUID(uuid=list(h.goal_id)), stamp=h.stamp), status=h.status)
            for h in self._goals.values()]))

    # ---- queries ----
    def endpoints(self) -> tuple[list[DataReader[Any]], list[DataWriter[Any]]]:
        """The server's readers and writers (for a ROS node's graph to announce as its own)."""
        return list(self._readers.values()), [*self._writers.values(), self._feedback_writer, self._status_writer]

    def watchers(self) -> int:
        """How many readers receive both the feedback and the status of the goals (a client's,
        and any node watching): the fewer of the two writers' matched readers."""
        return min(len(self._feedback_writer.get_matched_subscriptions()),
                   len(self._status_writer.get_matched_subscriptions()))

    def goals(self) -> list[GoalHandle]:
        with self._lock:
            return list(self._goals.values())

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
