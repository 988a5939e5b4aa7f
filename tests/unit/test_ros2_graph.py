"""parolkit.ros2.graph without another process: which DDS domain (flag, config file,
ROS_DOMAIN_ID, default) and what the node announces (its GIDs are its entities' GUIDs, every
endpoint carries its type hash).  Against a real rclpy node: tests/integration/test_ros2_graph.py."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from cyclonedds.core import Policy

from parolkit.config import load_config
from parolkit.errors import ParolkitValueError
from parolkit.ros2 import msgs
from parolkit.ros2.bridge import ros_qos
from parolkit.ros2.graph import ENCLAVE_USER_DATA, NODE_NAME, RosGraph, make_participant, resolve_domain
from parolkit.ros2.interfaces import hash_of
from parolkit.ros2.typehash import parse_user_data_hash


def _cfg(tmp_path: Path, text: str):  # type: ignore[no-untyped-def]
    f = tmp_path / "parolkit.toml"
    f.write_text(text)
    return load_config(f)


def test_the_flag_wins_then_the_config_file_then_ROS_DOMAIN_ID_then_0(tmp_path: Path) -> None:
    with_domain = _cfg(tmp_path, "[ros2]\ndomain = 0\n")  # 0 written in the file is a choice
    assert resolve_domain(7, with_domain, {"ROS_DOMAIN_ID": "9"}).source == "--domain"
    choice = resolve_domain(None, with_domain, {"ROS_DOMAIN_ID": "9"})
    assert choice.domain == 0 and choice.source.startswith("[ros2] domain in ")
    without = _cfg(tmp_path, "[ros2]\nnamespace = \"arm\"\n")
    assert resolve_domain(None, without, {"ROS_DOMAIN_ID": " 9 "}).domain == 9
    assert resolve_domain(None, without, {"ROS_DOMAIN_ID": "9"}).source == "ROS_DOMAIN_ID"
    assert resolve_domain(None, without, {"ROS_DOMAIN_ID": ""}).domain == 0
    default = resolve_domain(None, load_config(None, search_default_paths=False), {})
    assert default.domain == 0 and default.source.startswith("the default")


@pytest.mark.parametrize(("env", "message"), [
    ("x", "ROS_DOMAIN_ID must be an integer 0..232, got 'x'"),
    ("-1", "ROS_DOMAIN_ID must be an integer 0..232, got '-1'"),
    ("233", "ROS_DOMAIN_ID must be an integer 0..232, got 233"),
])
def test_a_bad_ROS_DOMAIN_ID_is_refused_naming_it(env: str, message: str) -> None:
    with pytest.raises(ParolkitValueError) as exc:
        resolve_domain(None, load_config(None, search_default_paths=False), {"ROS_DOMAIN_ID": env})
    assert str(exc.value) == message


def test_a_bad_flag_is_refused_naming_it() -> None:
    with pytest.raises(ParolkitValueError, match="--domain must be an integer 0..232, got 300"):
        resolve_domain(300, load_config(None, search_default_paths=False), {})


def test_the_node_announces_its_participant_and_endpoints_by_their_guids() -> None:
    dp = make_participant(200 + os.getpid() % 30)
    graph = RosGraph(dp, namespace="lab/arm")
    w = graph.writer("rt/lab/arm/joint_states", msgs.JointState, ros_qos())
    r = graph.reader("rt/lab/arm/joint_trajectory", msgs.JointTrajectory, ros_qos())
    info = graph.info()
    assert bytes(info.gid.data) == dp.guid.bytes
    (node,) = info.node_entities_info_seq
    assert (node.node_namespace, node.node_name) == ("/lab/arm", NODE_NAME)
    assert [bytes(g.data) for g in node.writer_gid_seq] == [w.guid.bytes]
    assert [bytes(g.data) for g in node.reader_gid_seq] == [r.guid.bytes]
    assert parse_user_data_hash(w.get_qos()[Policy.Userdata].data) == hash_of("sensor_msgs/msg/JointState")
    assert parse_user_data_hash(r.get_qos()[Policy.Userdata].data) == hash_of("trajectory_msgs/msg/JointTrajectory")
    assert dp.get_qos()[Policy.Userdata].data == ENCLAVE_USER_DATA
    graph.close()

