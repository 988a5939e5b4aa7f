"""parolkit.ros2.struct_hash (RIHS01 type descriptions) and the wire form of parolkit.ros2.action_msgs.

The hashes themselves are checked against ROS 2's own (the hashes the Jazzy packages ship and
those rosidl's generator computes from control_msgs' definitions) in
tests/integration/test_ros2_action.py, which needs the ROS venv; here: the description's
structure, field by field, and the service wire layout.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from typing import Any

import pytest
from cyclonedds.idl import IdlStruct

from parolkit.ros2 import action_msgs as am
from parolkit.ros2 import msgs
from parolkit.ros2.struct_hash import (
    action_description,
    description_dict,
    ros_type_name,
    service_description,
    struct_description,
    struct_hash,
)


def type_description(cls: type) -> dict[str, Any]:
    return description_dict(struct_description(cls))


type_hash = struct_hash


def _field(desc: dict[str, Any], name: str) -> dict[str, Any]:
    return next(f["type"] for f in desc["type_description"]["fields"] if f["name"] == name)


def test_field_type_ids_capacities_and_nested_names_follow_type_description_interfaces() -> None:
    uuid = type_description(am.UUID)
    assert uuid == {"type_description": {"type_name": "unique_identifier_msgs/msg/UUID", "fields": [
        {"name": "uuid", "type": {"type_id": 51, "capacity": 16, "string_capacity": 0, "nested_type_name": ""}}]},
        "referenced_type_descriptions": []}
    ev = type_description(am.CancelGoal_Event)
    assert _field(ev, "request") == {"type_id": 97, "capacity": 1, "string_capacity": 0,
                                     "nested_type_name": "action_msgs/srv/CancelGoal_Request"}
    traj = type_description(msgs.JointTrajectory)
    assert _field(traj, "joint_names") == {"type_id": 161, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}
    assert _field(traj, "points")["type_id"] == 145
    point = next(d for d in traj["referenced_type_descriptions"] if d["type_name"].endswith("JointTrajectoryPoint"))
    assert [f["type"]["type_id"] for f in point["fields"]] == [155, 155, 155, 155, 1]  # float64 sequences, Duration
    res = type_description(am.GripperCommand_Result)
    assert [f["type"]["type_id"] for f in res["type_description"]["fields"]] == [11, 11, 15, 15]
    assert _field(type_description(am.JointComponentTolerance), "component")["type_id"] == 5  # uint16


def test_referenced_types_are_every_nested_type_once_sorted_by_name() -> None:
    names = [d["type_name"] for d in type_description(am.FollowJointTrajectory_Goal)["referenced_type_descriptions"]]
    assert names == sorted(names) and len(names) == len(set(names))
    assert {"builtin_interfaces/msg/Duration", "builtin_interfaces/msg/Time", "std_msgs/msg/Header",
            "geometry_msgs/msg/Twist", "geometry_msgs/msg/Vector3", "trajectory_msgs/msg/JointTrajectoryPoint",
            "control_msgs/msg/JointTolerance"} <= set(names)


def test_a_service_and_an_action_are_structs_of_their_parts() -> None:
    srv = description_dict(service_description(am.CANCEL_GOAL))["type_description"]
    assert srv["type_name"] == "action_msgs/srv/CancelGoal"
    assert [f["name"] for f in srv["fields"]] == ["request_message", "response_message", "event_message"]
    act = description_dict(action_description(am.FOLLOW_JOINT_TRAJECTORY))
    assert [f["name"] for f in act["type_description"]["fields"]] == [
        "goal", "result", "feedback", "send_goal_service", "get_result_service", "feedback_message"]
    refs = {d["type_name"]: d for d in act["referenced_type_descriptions"]}
    send = refs["control_msgs/action/FollowJointTrajectory_SendGoal"]
    assert [f["type"]["nested_type_name"] for f in send["fields"]] == [
        "control_msgs/action/FollowJointTrajectory_SendGoal_Request",
        "control_msgs/action/FollowJointTrajectory_SendGoal_Response",
        "control_msgs/action/FollowJointTrajectory_SendGoal_Event"]
    assert "service_msgs/msg/ServiceEventInfo" in refs


def test_the_hash_is_the_sha256_of_the_description_and_changes_with_any_field() -> None:
    import hashlib

    text = json.dumps(type_description(am.UUID), separators=(", ", ": "))
    assert type_hash(am.UUID) == "RIHS01_" + hashlib.sha256(text.encode()).hexdigest()

    @dataclass
    class Renamed(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
        uid: am.Bytes16

    assert type_hash(Renamed) != type_hash(am.UUID)
    assert len({type_hash(am.FOLLOW_JOINT_TRAJECTORY), type_hash(am.GRIPPER_COMMAND),
                type_hash(am.FollowJointTrajectory_Goal)}) == 3


def test_a_type_that_is_not_a_ros_type_is_refused_by_name() -> None:
    @dataclass
    class Plain(IdlStruct, typename="Plain"):
        x: int = 0

    with pytest.raises(ValueError, match=r"Plain: not a ROS 2 type \(DDS typename 'Plain'"):
        ros_type_name(Plain)
    with pytest.raises(ValueError, match="the goal type must be a::action::dds_::B_Goal_"):
        am.action_types("a/action/B", am.GripperCommand_Goal, am.GripperCommand_Result, am.GripperCommand_Feedback)


def test_a_service_message_travels_with_the_request_header_in_front() -> None:
    req = am.FOLLOW_JOINT_TRAJECTORY.get_result.request(goal_id=am.UUID(uuid=list(range(16))))
    wire = am.wrap(req, guid=0x0102030405060708, seq=42)
    data = wire.serialize()
    assert type(wire).__idl_typename__ == "control_msgs::action::dds_::FollowJointTrajectory_GetResult_Request_"
    assert data[:4] == b"\x00\x01\x00\x00"  # CDR little endian, as ROS 2's middlewares write
    assert struct.unpack("<Qq", data[4:20]) == (0x0102030405060708, 42)
    assert data[20:] == req.serialize()[4:]  # the message itself, unchanged (header: 16 bytes, 8-aligned)
    back = am.unwrap(type(wire).deserialize(data), type(req))
    assert isinstance(back, type(req)) and bytes(back.goal_id.uuid) == bytes(range(16))
    assert not hasattr(back, "guid")
