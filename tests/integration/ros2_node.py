"""A real ROS 2 Jazzy rclpy node (run with the ROS test venv's python, NOT parolkit's).

Driven by tests/integration/test_ros2.py through stdin/stdout, one JSON object per line:

    {"cmd": "description"}                       -> {"urdf": "<robot ...>"}
    {"cmd": "joint_states", "n": 20}             -> {"msgs": [{"name", "position", "velocity", "stamp"}...]}
    {"cmd": "publish", "names": [...], "points": [[t, [q...]] or [t, [q...], [v...]], ...]}   -> {"ok": true}
    {"cmd": "event", "timeout": 10}              -> {"event": "refused: ..."} (next parolkit/events)
    {"cmd": "graph", "node": "parolkit_bridge", "publishers": [topics], "subscriptions": [topics]}
        -> {"nodes": [[name, namespace]...], "publishers": {topic: [endpoint...]}, "subscriptions": {...}}
           (once the node is listed and every topic has an endpoint of it, or after "wait" s, default 20)
    {"cmd": "quit"}

It imports only rclpy and ROS message packages: the parolkit side is reached over DDS alone.
"""

from __future__ import annotations

import json
import sys
import time

import rclpy
from builtin_interfaces.msg import Duration
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint


def _endpoint(info) -> dict:  # type: ignore[no-untyped-def]
    return {"node_name": info.node_name, "node_namespace": info.node_namespace, "topic_type": info.topic_type,
            "topic_type_hash": str(info.topic_type_hash), "endpoint_gid": list(info.endpoint_gid),
            "durability": info.qos_profile.durability.name, "reliability": info.qos_profile.reliability.name}


def graph(node, req: dict) -> dict:  # type: ignore[no-untyped-def]
    """What rclpy's graph API says about ``req["node"]`` and the topics named: node names and
    namespaces, and each topic's publishers / subscriptions as rmw reports them."""
    def snapshot() -> dict:
        return {"nodes": [list(n) for n in node.get_node_names_and_namespaces()],
                "publishers": {t: [_endpoint(i) for i in node.get_publishers_info_by_topic(t)]
                               for t in req.get("publishers", [])},
                "subscriptions": {t: [_endpoint(i) for i in node.get_subscriptions_info_by_topic(t)]
                                  for t in req.get("subscriptions", [])}}

    def complete(snap: dict) -> bool:
        return (any(n[0] == req["node"] for n in snap["nodes"])
                and all(any(e["node_name"] == req["node"] for e in ends)
                        for kind in ("publishers", "subscriptions") for ends in snap[kind].values()))

    end = time.monotonic() + req.get("wait", 20)
    snap = snapshot()
    while not complete(snap) and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.1)
        snap = snapshot()
    return snap


def main() -> None:
    ns = sys.argv[1] if len(sys.argv) > 1 else ""
    pre = f"/{ns}" if ns else ""
    rclpy.init()
    node = rclpy.create_node("parolkit_test_node")
    states: list[JointState] = []
    desc: list[str] = []
    events: list[str] = []
    node.create_subscription(JointState, f"{pre}/joint_states", states.append, 10)
    node.create_subscription(
        String, f"{pre}/robot_description", lambda m: desc.append(m.data),
        QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE))
    node.create_subscription(String, f"{pre}/parolkit/events", lambda m: events.append(m.data), 10)
    status: list[dict] = []
    node.create_subscription(String, f"{pre}/parolkit/status", lambda m: status.append(json.loads(m.data)), 10)
    pub = node.create_publisher(JointTrajectory, f"{pre}/joint_trajectory", 10)

    def spin_until(pred, timeout: float) -> bool:  # type: ignore[no-untyped-def]
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if pred():
                return True
            rclpy.spin_once(node, timeout_sec=0.05)
        return bool(pred())

    def reply(obj: object) -> None:
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()

    reply({"ready": True})
    for line in sys.stdin:
        req = json.loads(line)
        cmd = req["cmd"]
        if cmd == "quit":
            break
        if cmd == "description":
            ok = spin_until(lambda: bool(desc), req.get("timeout", 20))
            reply({"urdf": desc[-1] if ok else None})
        elif cmd == "joint_states":
            n = req["n"]
            states.clear()
            spin_until(lambda n=n: len(states) >= n, req.get("timeout", 20))
            reply({"msgs": [{"name": list(m.name), "position": list(m.position), "velocity": list(m.velocity),
                             "stamp": m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                             "received": time.time()} for m in states]})
        elif cmd == "watch":
            # collect joint states for `seconds` (the whole of a trajectory)
            states.clear()
            end = time.monotonic() + req["seconds"]
            spin_until(lambda end=end: time.monotonic() > end, req["seconds"] + 1)
            reply({"msgs": [{"position": list(m.position),
                             "stamp": m.header.stamp.sec + m.header.stamp.nanosec * 1e-9} for m in states]})
        elif cmd == "publish":
            # wait until the bridge's reader is matched, so the message is not lost
            # wait until BOTH sides matched (our writer sees the bridge's reader, and the bridge's
            # status says its reader sees a publisher), or a volatile message can be lost
            status.clear()
            spin_until(lambda: pub.get_subscription_count() > 0
                       and bool(status) and status[-1]["trajectory_publishers"] > 0, 30)
            msg = JointTrajectory()
            msg.joint_names = req["names"]
            for t, q, *vel in req["points"]:
                p = JointTrajectoryPoint()
                p.positions = [float(v) for v in q]
                if vel:
                    p.velocities = [float(v) for v in vel[0]]
                p.time_from_start = Duration(sec=int(t), nanosec=int(round((t - int(t)) * 1e9)))
                msg.points.append(p)
            events.clear()
            pub.publish(msg)
            reply({"ok": True, "matched": pub.get_subscription_count(), "sent": time.time()})
        elif cmd == "graph":
            reply(graph(node, req))
        elif cmd == "event":
            ok = spin_until(lambda: bool(events), req.get("timeout", 20))
            reply({"event": events.pop(0) if ok else None})
        else:
            reply({"error": f"unknown command {cmd!r}"})
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
