"""Recordings ``ros2 bag`` plays (issue 27, item 6): a 15 s ``parolkit record`` of a moving
robot, read by rosbags (PyPI: rosbag2's formats in pure Python, the types registered from the
file's own schemas) and by mcap-python with mcap-ros2-support (what Foxglove reads):

* every channel is CDR with a ROS 2 message schema (``ros2msg``), and rosbags decodes every
  message of every channel (as many as the file's statistics count);
* /parolkit/status is parolkit_msgs/msg/Status and carries the controller's whole status;
* header stamps are the controller's tick time: consecutive stamps differ by exactly the
  status ``time`` difference, one stamp per tick on every topic of it;
* /tf at every tick and /tf_static compose to parolkit's FK at the recorded angles; the URDF
  on /robot_description is the one the frames are of; a SET_TOOL during the recording writes
  /robot_description and /tf_static again with the new tool at ``tcp``;
* ``offered_qos_profiles`` say transient local for /tf_static and /robot_description.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from tests.unit.test_ros2_tf import world_poses

from conftest import REPO_ROOT, wait_until
from parolkit.client.robot import Robot
from parolkit.kinematics.fk import fk_frames
from parolkit.kinematics.tools import get_tool
from parolkit.record.reader import load_recording
from parolkit.record.schemas import TOPIC_TYPES
from parolkit.ros2.interfaces import hash_of
from parolkit.ros2.tf import FrameTransform

pytestmark = pytest.mark.slow

TARGETS = [[70.0, -75.0, 160.0, 25.0, -35.0, 150.0], [100.0, -100.0, 190.0, -20.0, 30.0, 200.0]]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):  # type: ignore[no-untyped-def]
    from conftest import start_controller

    tmp = tmp_path_factory.mktemp("rosbags")
    ctl = start_controller(log_dir=tmp)
    out = tmp / "run.mcap"
    env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO_ROOT / "src"))
    rec = subprocess.Popen([sys.executable, "-m", "parolkit", "record", "--connect", f"127.0.0.1:{ctl.port}",
                            "-o", str(out), "--duration", "15"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=REPO_ROOT)
    robot = Robot(port=ctl.port, timeout=2.0)
    try:
        wait_until(lambda: out.exists() and out.stat().st_size > 2000, timeout=30, what="the recorder's first chunk")
        robot.move_joints(TARGETS[0], duration=2.0, timeout=30)
        robot.set_tool("flange")
        robot.move_joints(TARGETS[1], duration=2.0, timeout=30)
        text, _ = rec.communicate(timeout=120)
        assert rec.returncode == 0, text
    finally:
        if rec.poll() is None:
            rec.kill()
        robot.close()
        ctl.stop()
    return out


def test_rosbags_reads_every_message_of_every_channel(recording: Path) -> None:
    with open(recording, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    counts = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
    assert set(counts) == set(TOPIC_TYPES), counts
    for ch in summary.channels.values():
        schema = summary.schemas[ch.schema_id]
        assert (ch.message_encoding, schema.encoding, schema.name) == ("cdr", "ros2msg", TOPIC_TYPES[ch.topic])
        assert ch.metadata["topic_type_hash"] == hash_of(schema.name)
    seen: Counter[str] = Counter()
    types: dict[str, str] = {}
    with AnyReader([recording]) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == TOPIC_TYPES
        for conn, _timestamp, raw in reader.messages(connections=reader.connections):
            msg = reader.deserialize(raw, conn.msgtype)
            seen[conn.topic] += 1
            types[conn.topic] = type(msg).__name__
    assert dict(seen) == counts
    assert counts["/parolkit/status"] >= 1000  # 15 s at 100 Hz (less what a loaded machine drops)
    assert counts["/robot_description"] == counts["/tf_static"] == 2  # the start and the SET_TOOL
    print(f"rosbags read {sum(seen.values())} messages: {dict(seen)}")


def _rosbags_messages(recording: Path, topic: str) -> list[object]:
    with AnyReader([recording]) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        return [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]


def test_the_status_is_a_declared_message_carrying_the_whole_status(recording: Path) -> None:
    msgs = _rosbags_messages(recording, "/parolkit/status")
    rec = load_recording(recording)
    assert len(msgs) == len(rec)
    for m, st in zip(msgs[::50], rec.statuses[::50], strict=False):
        assert json.loads(m.json) == st  # type: ignore[attr-defined]
        assert m.seq == st["seq"] and m.state == st["state"]  # type: ignore[attr-defined]
        np.testing.assert_array_equal(m.angles, st["angles"])  # type: ignore[attr-defined]
        np.testing.assert_array_equal(m.steps, st["steps"])  # type: ignore[attr-defined]
        assert m.tool == st["tool"] and m.rate_hz == st["loop"]["rate_hz"]  # type: ignore[attr-defined]
    assert {m.command_name for m in msgs} >= {"", "MOVEJOINT"}  # type: ignore[attr-defined]


def _ns(stamp: object) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)  # type: ignore[attr-defined]


def test_stamps_are_the_controllers_tick_time(recording: Path) -> None:
    statuses = _rosbags_messages(recording, "/parolkit/status")
    joints = _rosbags_messages(recording, "/joint_states")
    tfs = _rosbags_messages(recording, "/tf")
    assert len(statuses) == len(joints) == len(tfs)
    t0, s0 = _ns(statuses[0].header.stamp), statuses[0].time  # type: ignore[attr-defined]
    for st, js, tf in zip(statuses, joints, tfs, strict=True):
        want = t0 + round((st.time - s0) * 1e9)  # type: ignore[attr-defined]
        assert abs(_ns(st.header.stamp) - want) <= 1, (st.seq, _ns(st.header.stamp), want)  # type: ignore[attr-defined]
        assert _ns(js.header.stamp) == _ns(st.header.stamp)  # type: ignore[attr-defined]
        assert {_ns(t.header.stamp) for t in tf.transforms} == {_ns(st.header.stamp)}  # type: ignore[attr-defined]
    # the controller's ticks, not the recorder's receive times: at 100 Hz about 10 ms apart
    steps = np.diff([_ns(s.header.stamp) for s in statuses]) / np.diff([s.seq for s in statuses])  # type: ignore[attr-defined]
    assert 5e6 < float(np.median(steps)) < 15e6


def _frame(t: object) -> FrameTransform:
    tr, r = t.transform.translation, t.transform.rotation  # type: ignore[attr-defined]
    return FrameTransform(t.header.frame_id, t.child_frame_id, (tr.x, tr.y, tr.z), (r.x, r.y, r.z, r.w))  # type: ignore[attr-defined]


def test_tf_composes_to_our_fk_with_the_current_tool(recording: Path) -> None:
    statuses = _rosbags_messages(recording, "/parolkit/status")
    tfs = _rosbags_messages(recording, "/tf")
    statics = _rosbags_messages(recording, "/tf_static")
    descriptions = _rosbags_messages(recording, "/robot_description")
    assert [json.loads(s.json)["tool"] for s in statuses[:1]] == ["default"]  # type: ignore[attr-defined]
    assert len(statics) == 2 and len(descriptions) == 2
    assert 'name="tcp_joint"' in descriptions[0].data  # type: ignore[attr-defined]
    tool_of = {"default": [_frame(t) for t in statics[0].transforms],  # type: ignore[attr-defined]
               "flange": [_frame(t) for t in statics[1].transforms]}  # type: ignore[attr-defined]
    checked = Counter[str]()
    for st, tf in list(zip(statuses, tfs, strict=True))[::25]:
        tool = st.tool  # type: ignore[attr-defined]
        poses = world_poses(tool_of[tool] + [_frame(t) for t in tf.transforms])  # type: ignore[attr-defined]
        frames = fk_frames(list(st.angles), get_tool(tool))  # type: ignore[attr-defined]
        np.testing.assert_allclose(poses["flange"], frames[6], atol=1e-12)
        np.testing.assert_allclose(poses["tcp"], frames[7], atol=1e-12)
        checked[tool] += 1
    assert checked["default"] >= 5 and checked["flange"] >= 5, checked


def test_latched_topics_are_offered_transient_local_and_mcap_python_still_decodes_everything(recording: Path) -> None:
    with open(recording, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        qos = {ch.topic: ch.metadata["offered_qos_profiles"] for ch in summary.channels.values()}
        n = Counter(ch.topic for _, ch, _, _ in reader.iter_decoded_messages())
    assert "durability: 1" in qos["/tf_static"] and "durability: 1" in qos["/robot_description"]
    assert "durability: 2" in qos["/tf"] and "durability: 2" in qos["/joint_states"]
    assert set(n) == set(TOPIC_TYPES)


def test_replay_and_teach_read_it(recording: Path, tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(REPO_ROOT / "src"))
    t = time.monotonic()
    taught = subprocess.run([sys.executable, "-m", "parolkit", "teach", str(recording), "-o", str(tmp_path / "p.rbt")],
                            capture_output=True, text=True, env=env, cwd=REPO_ROOT, timeout=300)
    assert taught.returncode in (0, 1), taught.stderr  # 1: outside the tolerances (still a program)
    prog = (tmp_path / "p.rbt").read_text()
    assert prog.count("MoveJoint") >= 3, (prog, time.monotonic() - t)
