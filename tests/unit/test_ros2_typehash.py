"""parolkit.ros2.typehash: RIHS01 hashes (REP 2011) of .msg definitions.

The expected hashes are those ROS 2 Jazzy's own generator wrote into the message packages'
``share/<pkg>/msg/<Name>.json`` (the ros-jazzy-* wheels of .venv-ros); the integration test
tests/integration/test_ros2_graph.py compares every definition those wheels ship.
"""

from __future__ import annotations

import hashlib

import pytest

from parolkit.errors import ParolkitValueError
from parolkit.ros2.typehash import (
    Field,
    FieldType,
    IndividualTypeDescription,
    parse_msg,
    parse_user_data_hash,
    type_description,
    type_description_json,
    type_hash,
    type_hash_of,
    user_data,
)

TIME = "int32 sec\nuint32 nanosec\n"
HEADER = "# Standard metadata\nbuiltin_interfaces/Time stamp\n\nstring frame_id  # the frame\n"
GID = "char[16] data\n"
NODE = "string<=256 node_namespace\nstring<=256 node_name\nGid[] reader_gid_seq\nGid[] writer_gid_seq\n"
PARTICIPANT = "Gid gid\nNodeEntitiesInfo[] node_entities_info_seq\n"
JOINT_STATE = "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"

DEFS = {
    "builtin_interfaces/msg/Time": TIME,
    "std_msgs/msg/Header": HEADER,
    "std_msgs/msg/Empty": "# nothing\n",
    "rmw_dds_common/msg/Gid": GID,
    "rmw_dds_common/msg/NodeEntitiesInfo": NODE,
    "rmw_dds_common/msg/ParticipantEntitiesInfo": PARTICIPANT,
    "sensor_msgs/msg/JointState": JOINT_STATE,
}

# from the Jazzy wheels' share/<pkg>/msg/<Name>.json ("type_hashes")
JAZZY = {
    "builtin_interfaces/msg/Time": "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
    "std_msgs/msg/Header": "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
    "std_msgs/msg/Empty": "RIHS01_20b625256f32d5dbc0d04fee44f43c41e51c70d3502f84b4a08e7a9c26a96312",
    "rmw_dds_common/msg/Gid": "RIHS01_ab6f21cfbb0a6dbb837161e1110c2051a2850ed9f9c53944d7115d9bcebedf71",
    "rmw_dds_common/msg/ParticipantEntitiesInfo":
        "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e",
    "sensor_msgs/msg/JointState": "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e",
}


@pytest.mark.parametrize("name", sorted(JAZZY))
def test_hashes_equal_the_ones_ros2_jazzy_generated(name: str) -> None:
    assert type_hash(name, DEFS) == JAZZY[name]


def test_constants_comments_and_defaults_are_not_part_of_the_hash() -> None:
    noisy = ("# a comment\nint32 SECONDS_PER_MINUTE=60  # constant\nstring FOO = \"a # b\"\n"
             "int32 sec 5  # default\nuint32 nanosec\n")
    defs = dict(DEFS, **{"builtin_interfaces/msg/Time": noisy})
    assert type_hash("builtin_interfaces/msg/Time", defs) == JAZZY["builtin_interfaces/msg/Time"]
    assert type_hash("std_msgs/msg/Header", defs) == JAZZY["std_msgs/msg/Header"]


def test_the_hashed_text_is_the_rep_2011_json() -> None:
    desc = type_description("std_msgs/msg/Header", lambda n: parse_msg(n, DEFS[n]))
    text = type_description_json(desc)
    assert text == (
        '{"type_description": {"type_name": "std_msgs/msg/Header", "fields": ['
        '{"name": "stamp", "type": {"type_id": 1, "capacity": 0, "string_capacity": 0, '
        '"nested_type_name": "builtin_interfaces/msg/Time"}}, '
        '{"name": "frame_id", "type": {"type_id": 17, "capacity": 0, "string_capacity": 0, '
        '"nested_type_name": ""}}]}, '
        '"referenced_type_descriptions": [{"type_name": "builtin_interfaces/msg/Time", "fields": ['
        '{"name": "sec", "type": {"type_id": 6, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}, '
        '{"name": "nanosec", "type": {"type_id": 7, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}]}]}')
    assert type_hash_of(desc) == "RIHS01_" + hashlib.sha256(text.encode()).hexdigest()


def test_field_types_arrays_sequences_and_bounded_strings() -> None:
    d = parse_msg("p/msg/T", "uint8[4] a\nfloat64[<=3] b\nstring<=5[] c\nwstring<=2[<=7] d\nbyte e\nchar f\n"
                  "Other[2] g\nq/Thing h\nHeader i\nbool[] j\n")
    types = {f.name: f.type for f in d.fields}
    assert types["a"] == FieldType(3 + 48, 4)
    assert types["b"] == FieldType(11 + 96, 3)
    assert types["c"] == FieldType(21 + 144, 0, 5)
    assert types["d"] == FieldType(22 + 96, 7, 2)
    assert types["e"] == FieldType(16) and types["f"] == FieldType(3)
    assert types["g"] == FieldType(1 + 48, 2, 0, "p/msg/Other")
    assert types["h"] == FieldType(1, 0, 0, "q/msg/Thing")
    assert types["i"] == FieldType(1, 0, 0, "std_msgs/msg/Header")
    assert types["j"] == FieldType(15 + 144)


def test_a_type_built_by_hand_hashes_as_its_msg_text() -> None:
    by_hand = IndividualTypeDescription("builtin_interfaces/msg/Time", (
        Field("sec", FieldType(6)), Field("nanosec", FieldType(7))))
    desc = type_description("builtin_interfaces/msg/Time", {"builtin_interfaces/msg/Time": by_hand})
    assert type_hash_of(desc) == JAZZY["builtin_interfaces/msg/Time"]


@pytest.mark.parametrize(("text", "message"), [
    ("int32", "expected 'TYPE NAME'"),
    ("int32[x] a", "cannot read the type 'int32[x]'"),
    ("int32<=4 a", "only string and wstring take a bound"),
    ("Foo<=4 a", "only string and wstring take a bound"),
    ("int32[<=] a", "a bounded sequence needs its bound"),
    ("int32 Bad", "a field name is lower case"),
])
def test_malformed_lines_are_refused_naming_the_line(text: str, message: str) -> None:
    with pytest.raises(ParolkitValueError, match="p/msg/T line 2") as exc:
        parse_msg("p/msg/T", "int32 ok\n" + text)
    assert message in str(exc.value)


def test_a_missing_definition_names_the_type_that_needs_it() -> None:
    with pytest.raises(ParolkitValueError, match="std_msgs/msg/Header refers to builtin_interfaces/msg/Time"):
        type_hash("sensor_msgs/msg/JointState", {k: v for k, v in DEFS.items() if "Time" not in k})
    with pytest.raises(ParolkitValueError, match="pkg/msg/Name"):
        parse_msg("JointState", JOINT_STATE)


def test_user_data_round_trips_and_refuses_a_bad_hash() -> None:
    h = JAZZY["sensor_msgs/msg/JointState"]
    assert user_data(h) == f"typehash={h};".encode()
    assert parse_user_data_hash(b"enclave=/;typehash=" + h.encode() + b";") == h
    assert parse_user_data_hash(b"enclave=/;") is None
    with pytest.raises(ParolkitValueError, match="RIHS01_ and 64 hex digits"):
        user_data("RIHS01_abc")
