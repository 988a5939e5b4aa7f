"""parolkit.record's ROS 2 schemas without a controller: every topic is CDR with its ros2msg
schema and rosbag2's channel metadata, parolkit_msgs round-trip to the dicts the tools read,
the recorder's tool and tick stamps, and recordings of the old layout (JSON channels) still load.
The whole recorder against a controller, read by rosbags: tests/integration/test_record_rosbags.py."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import Writer
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from parolkit.kinematics.fk import fk_frames
from parolkit.kinematics.pose import matrix_to_pose
from parolkit.kinematics.tools import TOOLS, Tool
from parolkit.record import messages
from parolkit.record.reader import load_recording
from parolkit.record.recorder import Recorder, status_tool
from parolkit.record.schemas import (
    ACK,
    COMMAND_EVENT,
    PLAN,
    TOPIC_ACKS,
    TOPIC_COMMANDS,
    TOPIC_JOINT_STATES,
    TOPIC_PLANS,
    TOPIC_ROBOT_DESCRIPTION,
    TOPIC_STATUS,
    TOPIC_TF,
    TOPIC_TF_STATIC,
    TOPIC_TYPES,
    channel_metadata,
)
from parolkit.record.writer import RecordingWriter
from parolkit.robot import PAROL6
from parolkit.ros2.interfaces import hash_of
from parolkit.ros2.urdf import BASE_LINK, ROS_JOINT_NAMES

STANDBY = list(PAROL6.standby_deg)


def _status(seq: int, angles: list[float] | None = None, tool: str = "default") -> dict:
    q = angles or STANDBY
    frames = fk_frames(q, tool)
    return {"seq": seq, "time": round(seq / 100 + 0.0003, 4), "state": "IDLE", "enabled": True, "homed": [True] * 6,
            "all_homed": True, "angles": q, "steps": [int(a * 100) for a in q], "speeds_deg_s": [0.0] * 6,
            "pose": [round(float(v), 4) for v in matrix_to_pose(frames[7])], "tool": tool,
            "io": {"in1": 1, "in2": 0, "out1": 0, "out2": 1, "estop": 1}, "gripper": {"position": 42},
            "errors": {"message": None}, "loop": {"rate_hz": 100.0}, "command": None, "queue": 0, "extra": {"a": [1]}}


def test_the_schema_names_are_the_urdfs() -> None:
    from parolkit.record.schemas import BASE_FRAME, JOINT_NAMES

    assert JOINT_NAMES == ROS_JOINT_NAMES and BASE_FRAME == BASE_LINK


def test_channel_metadata_is_rosbag2s() -> None:
    latched = channel_metadata(TOPIC_TF_STATIC, "tf2_msgs/msg/TFMessage")
    assert latched["topic_type_hash"] == hash_of("tf2_msgs/msg/TFMessage")
    assert "durability: 1" in latched["offered_qos_profiles"] and "depth: 1" in latched["offered_qos_profiles"]
    volatile = channel_metadata(TOPIC_TF, "tf2_msgs/msg/TFMessage")["offered_qos_profiles"]
    assert "durability: 2" in volatile and "reliability: 1" in volatile
    yaml = pytest.importorskip("yaml")
    (profile,) = yaml.safe_load(latched["offered_qos_profiles"])
    assert profile["history"] == 1 and profile["deadline"] == {"sec": 0, "nsec": 0}


def test_the_recorder_writes_every_topic_as_cdr_with_tick_stamps(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    rec = Recorder("127.0.0.1", 9, path)
    recv = 1_700_000_000_000_000_000
    statuses = [_status(s) for s in range(10, 20)] + [_status(s, tool="flange") for s in range(20, 25)]
    for k, st in enumerate(statuses):
        rec._on_status(json.dumps(st).encode(), recv + k * 10_000_000 + (k % 3) * 700_000)  # receive jitter
    rec._on_datagram(b"ACK|abc|COMPLETED|ok")
    rec._on_datagram(b'PLAN|{"seq": 3, "command": "MOVEJOINT", "target_angles": [1, 2, 3, 4, 5, 6], '
                     b'"tcp_path": [[1.5, 2, 3], [4, 5, 6.25]]}')
    rec.writer.close()
    rec._sock.close()
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        assert {ch.topic for ch in summary.channels.values()} == set(TOPIC_TYPES) - {TOPIC_COMMANDS}
        assert all(ch.message_encoding == "cdr" for ch in summary.channels.values())
        assert all(s.encoding == "ros2msg" for s in summary.schemas.values())
        by_topic: dict[str, list] = {}
        for _, ch, m, d in reader.iter_decoded_messages():
            by_topic.setdefault(ch.topic, []).append((m, d))
    # stamps: the controller's time on the UNIX clock anchored at the first status, not the jitter
    stamps = [d.header.stamp.sec * 10**9 + d.header.stamp.nanosec for _, d in by_topic[TOPIC_JOINT_STATES]]
    assert stamps == [recv + round((st["time"] - statuses[0]["time"]) * 1e9) for st in statuses]
    assert [m.publish_time for m, _ in by_topic[TOPIC_STATUS]] == stamps
    assert [m.sequence for m, _ in by_topic[TOPIC_TF]] == [st["seq"] for st in statuses]
    assert len(by_topic[TOPIC_ROBOT_DESCRIPTION]) == len(by_topic[TOPIC_TF_STATIC]) == 2  # start, new tool
    tcp = [t for t in by_topic[TOPIC_TF_STATIC][1][1].transforms if t.child_frame_id == "tcp"][0]
    assert (tcp.transform.translation.x, tcp.transform.translation.y, tcp.transform.translation.z) == (0, 0, 0)
    loaded = load_recording(path)
    assert loaded.statuses == statuses
    assert loaded.acks == [{"id": "abc", "status": "COMPLETED", "details": "ok", "tick": 24}]
    assert loaded.plans == [{"seq": 3, "command": "MOVEJOINT", "target_angles": [1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                             "tcp_path": [[1.5, 2.0, 3.0], [4.0, 5.0, 6.25]], "tick": 24}]
    with AnyReader([path]) as ar:  # rosbags reads it with the types from the file's own schemas
        n = sum(1 for _ in ar.messages(connections=ar.connections))
    assert n == sum(len(v) for v in by_topic.values())


@pytest.mark.parametrize("event", [
    {"source": "status", "event": "started", "tick": 5, "id": "1a2b3c4d", "name": "MOVEJOINT"},
    {"source": "status", "event": "ended", "tick": 9, "id": None, "name": "HOME"},
    {"source": "recorder", "sent": "ab12cd34|ACK_HERE", "tick": None},
])
def test_command_events_round_trip(tmp_path: Path, event: dict) -> None:
    w = RecordingWriter(tmp_path / "c.mcap")
    w.write_ros(TOPIC_COMMANDS, COMMAND_EVENT, messages.command_event(event, 7), 7, 0)
    w.write_ros(TOPIC_ACKS, ACK, messages.ack_message({"id": None, "status": "FAILED", "details": "x", "tick": None},
                                                      7), 7, 0)
    w.write_ros(TOPIC_PLANS, PLAN, messages.plan_message({"seq": None, "command": None, "target_angles": None,
                                                          "tcp_path": []}, 7), 7, 0)
    w.write_status(_status(1), 8, 1)
    w.close()
    rec = load_recording(tmp_path / "c.mcap")
    assert rec.commands == [event]
    assert rec.acks == [{"id": None, "status": "FAILED", "details": "x", "tick": None}]
    assert rec.plans == [{"seq": None, "command": None, "target_angles": None, "tcp_path": [], "tick": None}]


def test_a_topic_keeps_its_type(tmp_path: Path) -> None:
    w = RecordingWriter(tmp_path / "t.mcap")
    w.write_ros("/x", "std_msgs/msg/String", {"data": "a"}, 1, 1)
    with pytest.raises(ValueError, match="topic /x carries std_msgs/msg/String, not parolkit_msgs/msg/Ack"):
        w.write_ros("/x", ACK, messages.ack_message({}, 1), 1, 1)
    w.close()


def test_the_status_tool_is_a_built_in_exactly_or_what_the_status_reports() -> None:
    q = [80.0, -70.0, 160.0, 20.0, -30.0, 150.0]
    assert status_tool(_status(1, q)) is TOOLS["default"]
    assert status_tool(_status(1, q, tool="flange")) is TOOLS["flange"]
    gripper = Tool.from_pose("gripper", [10.0, -5.0, 120.0, 0.0, 90.0, 0.0])
    st = _status(1, q)
    st["tool"] = "gripper"
    st["pose"] = [round(float(v), 4) for v in matrix_to_pose(fk_frames(q)[6] @ gripper.matrix)]
    derived = status_tool(st)
    assert derived.name == "gripper"
    np.testing.assert_allclose(derived.matrix, gripper.matrix, atol=2e-6)  # the status rounds to 1e-4 mm/deg


def test_a_recording_of_the_old_layout_json_channels_still_loads(tmp_path: Path) -> None:
    path = tmp_path / "old.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="parolkit (before parolkit_msgs)")
        sid = w.register_schema("parolkit/json", SchemaEncoding.JSONSchema, b'{"type": "object"}')
        status_ch = w.register_channel(TOPIC_STATUS, MessageEncoding.JSON, sid)
        cmd_ch = w.register_channel(TOPIC_COMMANDS, MessageEncoding.JSON, sid)
        sts = [_status(s) for s in range(3)]
        for st in sts:
            w.add_message(status_ch, log_time=st["seq"], publish_time=st["seq"], sequence=st["seq"],
                          data=json.dumps(st).encode())
        ev = {"source": "status", "event": "started", "tick": 1, "id": "x", "name": "HOME"}
        w.add_message(cmd_ch, log_time=2, publish_time=2, sequence=1, data=json.dumps(ev).encode())
        w.finish()  # type: ignore[no-untyped-call]
    rec = load_recording(path)
    assert rec.statuses == sts and rec.commands == [ev] and rec.complete
