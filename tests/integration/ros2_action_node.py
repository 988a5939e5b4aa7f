"""A real ROS 2 Jazzy rclpy node watching parolkit's actions (run with the ROS test venv's python).

Driven by tests/integration/test_ros2_action.py through stdin/stdout, one JSON object per line:

    {"cmd": "actions", "names": [...], "wait": 30}
        -> {"actions": [[name, [types]]...], "services": [[name, [types]]...], "topics": [[name, [types]]...]}
           (rclpy.action.get_action_names_and_types and the node's graph, once every action named is listed)
    {"cmd": "watch", "action": "/ns/fibonacci", "fibonacci": true}   -> {"ok": true}
        subscribes to the action's _action/status (action_msgs/GoalStatusArray) and, for the
        Fibonacci action, its _action/feedback (test_msgs/action/Fibonacci_FeedbackMessage)
    {"cmd": "seen", "action": "/ns/fibonacci", "goal": "hex", "until": 4, "timeout": 30}
        -> {"statuses": [...], "feedback": [[terms...]...]} (once the goal's status reached "until")
    {"cmd": "hashes", "topics": [...]}   -> {topic: [[node_name, type, type_hash]...]} (publishers' hashes)
    {"cmd": "own_hashes"} -> the hashes rclpy gives its own JointTrajectory publisher and Fibonacci
        feedback subscription (its generated type support's)
    {"cmd": "serialize"} -> CDR (hex) of reference messages serialized by rclpy
    {"cmd": "quit"}

It imports only rclpy and ROS message packages: the parolkit side is reached over DDS alone.
"""

from __future__ import annotations

import json
import sys
import threading
import time

import rclpy
import rclpy.action
from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from builtin_interfaces.msg import Time
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from test_msgs.action import Fibonacci
from trajectory_msgs.msg import JointTrajectory
from unique_identifier_msgs.msg import UUID

STATUS_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                        reliability=ReliabilityPolicy.RELIABLE)
GOAL_ID = bytes(range(16))


def reference_messages() -> dict[str, str]:
    """The reference messages (the test builds the same with parolkit's structs)."""
    send = Fibonacci.Impl.SendGoalService.Request()
    send.goal_id = UUID(uuid=list(GOAL_ID))
    send.goal.order = 7
    res = Fibonacci.Impl.GetResultService.Response()
    res.status = GoalStatus.STATUS_SUCCEEDED
    res.result.sequence = [0, 1, 1, 2, 3, 5, 8, 13]
    fb = Fibonacci.Impl.FeedbackMessage()
    fb.goal_id = UUID(uuid=list(GOAL_ID))
    fb.feedback.sequence = [0, 1, 1, 2]
    cancel = CancelGoal.Request()
    cancel.goal_info = GoalInfo(goal_id=UUID(uuid=list(GOAL_ID)), stamp=Time(sec=12, nanosec=345))
    cresp = CancelGoal.Response()
    cresp.return_code = CancelGoal.Response.ERROR_NONE
    cresp.goals_canceling = [cancel.goal_info]
    status = GoalStatusArray(status_list=[GoalStatus(goal_info=cancel.goal_info, status=GoalStatus.STATUS_EXECUTING)])
    return {k: serialize_message(m).hex() for k, m in (
        ("send_goal_request", send), ("get_result_response", res), ("feedback_message", fb),
        ("cancel_request", cancel), ("cancel_response", cresp), ("status_array", status))}


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("parolkit_action_test_node")
    statuses: dict[str, list[dict[str, int]]] = {}
    feedback: dict[str, list[tuple[str, list[int]]]] = {}

    # the node spins on a thread of its own: every message is taken as it arrives (the status
    # topic keeps only the last one), whatever the main thread is waiting for
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()

    def spin_until(pred, timeout: float) -> bool:  # type: ignore[no-untyped-def]
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if pred():
                return True
            time.sleep(0.02)
        return bool(pred())

    def reply(obj: object) -> None:
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()

    def watch(action: str, fibonacci: bool) -> list:  # type: ignore[type-arg]
        statuses[action], feedback[action] = [], []
        subs = [node.create_subscription(
            GoalStatusArray, f"{action}/_action/status",
            lambda m: statuses[action].append({bytes(s.goal_info.goal_id.uuid).hex(): s.status for s in m.status_list}),
            STATUS_QOS)]
        if fibonacci:
            subs.append(node.create_subscription(
                Fibonacci.Impl.FeedbackMessage, f"{action}/_action/feedback",
                lambda m: feedback[action].append((bytes(m.goal_id.uuid).hex(), list(m.feedback.sequence))), 10))
        return subs

    own = node.create_publisher(JointTrajectory, "/parolkit_action_test/own", 10)
    own_fb = node.create_subscription(Fibonacci.Impl.FeedbackMessage, "/parolkit_action_test/own_feedback",
                                      lambda m: None, 10)
    reply({"ready": True})
    for line in sys.stdin:
        req = json.loads(line)
        cmd = req["cmd"]
        if cmd == "quit":
            break
        if cmd == "actions":
            names = set(req["names"])
            spin_until(lambda names=names: names <= {n for n, _ in rclpy.action.get_action_names_and_types(node)},
                       req.get("wait", 30))
            reply({"actions": [[n, list(t)] for n, t in rclpy.action.get_action_names_and_types(node)],
                   "services": [[n, list(t)] for n, t in node.get_service_names_and_types()],
                   "topics": [[n, list(t)] for n, t in node.get_topic_names_and_types()]})
        elif cmd == "watch":  # once every subscription is matched with the server's writer
            # (our reader's count says the reader matched the writer; the status array the
            # server's transient-local writer sent on matching says the writer matched it)
            subs = watch(req["action"], req.get("fibonacci", False))
            action = req["action"]
            ok = spin_until(lambda subs=subs, a=action: all(s.get_publisher_count() > 0 for s in subs)
                            and bool(statuses[a]), req.get("wait", 30))
            reply({"ok": ok})
        elif cmd == "seen":
            action, goal, until = req["action"], req["goal"], req["until"]
            spin_until(lambda a=action, g=goal, u=until: any(s.get(g) == u for s in statuses[a]),
                       req.get("timeout", 30))
            seq = [s[goal] for s in statuses[action] if goal in s]
            reply({"statuses": [v for i, v in enumerate(seq) if i == 0 or seq[i - 1] != v],
                   "feedback": [f for g, f in feedback.get(action, []) if g == goal]})
        elif cmd == "hashes":
            out = {}
            for t in req["topics"]:
                spin_until(lambda t=t: bool(node.get_publishers_info_by_topic(t)), req.get("wait", 20))
                out[t] = [[i.node_name, i.topic_type, str(i.topic_type_hash)]
                          for i in node.get_publishers_info_by_topic(t)]
            reply(out)
        elif cmd == "own_hashes":
            pubs = node.get_publishers_info_by_topic(own.topic_name)
            subs = node.get_subscriptions_info_by_topic(own_fb.topic_name)
            reply({"trajectory_msgs/msg/JointTrajectory": str(pubs[0].topic_type_hash),
                   "test_msgs/action/Fibonacci_FeedbackMessage": str(subs[0].topic_type_hash)})
        elif cmd == "serialize":
            reply(reference_messages())
        else:
            reply({"error": f"unknown command {cmd!r}"})
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
