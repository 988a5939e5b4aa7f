"""A ROS 2 action client on plain DDS, as a node on rmw_cyclonedds_cpp calls an action.

PyPI has no rmw_cyclonedds_cpp wheel and ROS 2's Fast DDS RMW carries a service's request id
out of band (an inline QoS that Cyclone DDS cannot write), so the test drives the services of
parolkit's action server the way rmw_cyclonedds_cpp does: request topics ``rq/...Request``
with the header ``{uint64 guid; int64 seq}`` in front of the message, replies matched by that
header; endpoints' user data ``clientid=...;``.  The action's protocol (goal, result, cancel,
status, feedback) is rcl_action's.  Used by tests/integration/test_ros2_action.py.
"""

from __future__ import annotations

import os
import threading
import time
from typing import Any

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from parolkit.ros2 import msgs
from parolkit.ros2.action_msgs import (
    CANCEL_GOAL,
    UUID,
    ActionTypes,
    GoalInfo,
    GoalStatusArray,
    service_wire_type,
    unwrap,
    wrap,
)
from parolkit.ros2.action_server import action_topics, feedback_qos, service_qos, status_qos

_next_guid = int.from_bytes(os.urandom(7), "little") << 8


class ActionClient:
    """Send goals to the action ``/<namespace>/<name>`` and collect its replies, feedback and status."""

    def __init__(self, dp: DomainParticipant, namespace: str, name: str, types: ActionTypes) -> None:
        global _next_guid
        self.types = types
        t = action_topics(namespace, name)
        ud = f"clientid={os.urandom(16).hex()};"
        self._services: dict[str, tuple[DataWriter[Any], DataReader[Any]]] = {}
        self._reply_types: dict[str, type] = {}
        for s, (req, resp) in {"send_goal": (types.send_goal.request, types.send_goal.response),
                               "get_result": (types.get_result.request, types.get_result.response),
                               "cancel_goal": (CANCEL_GOAL.request, CANCEL_GOAL.response)}.items():
            w = DataWriter(dp, Topic(dp, t[f"{s}_request"], service_wire_type(req)), service_qos(ud))
            r = DataReader(dp, Topic(dp, t[f"{s}_reply"], service_wire_type(resp)), service_qos(ud))
            self._services[s] = (w, r)
            self._reply_types[s] = resp
        _next_guid += 1
        self.guid = _next_guid
        self._seq = 0
        self._replies: dict[tuple[str, int], Any] = {}
        self.feedback: list[tuple[bytes, Any]] = []
        self.statuses: list[dict[bytes, int]] = []
        # a deep history: the test's thread may be slower than the status rate for a while
        self._fb = DataReader(dp, Topic(dp, t["feedback"], types.feedback_message),
                              feedback_qos(ud) + Qos(Policy.History.KeepLast(2000)))
        self._st = DataReader(dp, Topic(dp, t["status"], GoalStatusArray), status_qos(ud))
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)
        self._thread.start()

    def _poll(self) -> None:
        while not self._stop.is_set():
            got = False
            for s, (_, r) in self._services.items():
                for sample in r.take(N=16):
                    got = True
                    if hasattr(sample, "guid") and sample.guid == self.guid:
                        with self._lock:
                            self._replies[(s, int(sample.seq))] = unwrap(sample, self._reply_types[s])
            for m in self._fb.take(N=64):
                got = True
                if hasattr(m, "feedback"):
                    with self._lock:
                        self.feedback.append((bytes(m.goal_id.uuid), m.feedback))
            for st in self._st.take(N=16):
                got = True
                if hasattr(st, "status_list"):
                    with self._lock:
                        self.statuses.append({bytes(s.goal_info.goal_id.uuid): s.status for s in st.status_list})
            if not got:
                time.sleep(0.002)

    def wait_for_server(self, timeout: float = 30.0) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if all(len(w.get_matched_subscriptions()) and len(r.get_matched_publications())
                   for w, r in self._services.values()) and len(self._st.get_matched_publications()):
                return
            time.sleep(0.02)
        raise AssertionError(f"the action server was not matched within {timeout} s")

    def _call(self, service: str, body: Any) -> int:
        self._seq += 1
        w, _ = self._services[service]
        w.write(wrap(body, self.guid, self._seq))
        return self._seq

    def reply(self, service: str, seq: int, timeout: float = 30.0) -> Any:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            with self._lock:
                if (service, seq) in self._replies:
                    return self._replies.pop((service, seq))
            time.sleep(0.002)
        raise AssertionError(f"no {service} reply within {timeout} s")

    def send_goal(self, goal: Any, goal_id: bytes | None = None, timeout: float = 30.0) -> tuple[bytes, Any]:
        """Send ``goal``; (its id, the SendGoal reply)."""
        gid = goal_id or os.urandom(16)
        seq = self._call("send_goal", self.types.send_goal.request(goal_id=UUID(uuid=list(gid)), goal=goal))
        return gid, self.reply("send_goal", seq, timeout)

    def request_result(self, goal_id: bytes) -> int:
        return self._call("get_result", self.types.get_result.request(goal_id=UUID(uuid=list(goal_id))))

    def get_result(self, goal_id: bytes, timeout: float = 60.0) -> Any:
        return self.reply("get_result", self.request_result(goal_id), timeout)

    def cancel(self, goal_id: bytes | None = None, stamp_ns: int = 0, timeout: float = 30.0) -> Any:
        info = GoalInfo(goal_id=UUID(uuid=list(goal_id or bytes(16))), stamp=msgs.time_from_ns(stamp_ns))
        return self.reply("cancel_goal", self._call("cancel_goal", CANCEL_GOAL.request(goal_info=info)), timeout)

    def status_of(self, goal_id: bytes) -> list[int]:
        """Every status the goal had in the status arrays received, in order, repeats removed."""
        with self._lock:
            seen = [s[goal_id] for s in self.statuses if goal_id in s]
        return [v for i, v in enumerate(seen) if i == 0 or seen[i - 1] != v]

    def feedback_of(self, goal_id: bytes) -> list[Any]:
        with self._lock:
            return [f for g, f in self.feedback if g == goal_id]

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)

