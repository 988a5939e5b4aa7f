"""parolkit.ros2.interfaces: the .msg definitions are the cyclonedds structs' (field by field),
their MCAP schemas parse with mcap-ros2-support and rosbags, and the names map both ways.

Hashes against ROS 2's own generator: tests/integration/test_ros2_graph.py."""

from __future__ import annotations

import typing

import pytest
from cyclonedds.idl import IdlStruct
from cyclonedds.idl._type_normalize import get_extended_type_hints
from cyclonedds.idl.types import array, bounded_str, sequence
from mcap_ros2._dynamic import serialize_dynamic

from parolkit.errors import ParolkitValueError
from parolkit.ros2 import graph_types, msgs
from parolkit.ros2.interfaces import (
    DEFINITIONS,
    PAROLKIT_MSGS,
    concatenated_definition,
    dds_type_name,
    definition,
    hash_of,
    ros_type_name,
)
from parolkit.ros2.typehash import (
    ARRAY_OFFSET,
    FIELD_TYPE_NESTED,
    PRIMITIVE_TYPE_IDS,
    TYPE_HASH_RE,
    UNBOUNDED_SEQUENCE_OFFSET,
    FieldType,
    parse_msg,
)

STRUCTS = [c for mod in (msgs, graph_types) for c in vars(mod).values()
           if isinstance(c, type) and issubclass(c, IdlStruct) and c is not IdlStruct
           and c.__module__ == mod.__name__]


def _field_type(t: object) -> FieldType:
    """The REP 2011 field type of a cyclonedds annotation."""
    if isinstance(t, sequence):
        inner = _field_type(t.subtype)
        return FieldType(inner.type_id + UNBOUNDED_SEQUENCE_OFFSET, 0, inner.string_capacity, inner.nested_type_name)
    if isinstance(t, array):
        inner = _field_type(t.subtype)
        return FieldType(inner.type_id + ARRAY_OFFSET, t.length, inner.string_capacity, inner.nested_type_name)
    if isinstance(t, bounded_str):
        return FieldType(21, 0, t.max_length)
    if t is str:
        return FieldType(PRIMITIVE_TYPE_IDS["string"])
    if isinstance(t, type) and issubclass(t, IdlStruct):
        return FieldType(FIELD_TYPE_NESTED, 0, 0, ros_type_name(t.__idl_typename__))
    args = typing.get_args(t)
    if len(args) == 2 and isinstance(args[1], str):
        return FieldType(PRIMITIVE_TYPE_IDS[args[1]])
    raise AssertionError(f"unexpected annotation {t!r}")


def test_every_struct_is_checked() -> None:
    names = {c.__name__ for c in STRUCTS}
    assert {"JointState", "TFMessage", "ParticipantEntitiesInfo", "Gid", "NodeEntitiesInfo"} <= names, names


@pytest.mark.parametrize("cls", STRUCTS, ids=lambda c: c.__name__)
def test_the_cyclonedds_structs_are_the_definitions(cls: type) -> None:
    name = ros_type_name(cls.__idl_typename__)  # type: ignore[attr-defined]
    want = [(f.name, f.type) for f in parse_msg(name, definition(name)).fields]
    got = [(k, _field_type(v)) for k, v in get_extended_type_hints(cls).items()]
    assert got == want


@pytest.mark.parametrize("name", sorted(DEFINITIONS))
def test_every_schema_parses_with_mcap_ros2_and_has_a_hash(name: str) -> None:
    text = concatenated_definition(name)
    assert name in serialize_dynamic(name, text)
    assert TYPE_HASH_RE.fullmatch(hash_of(name))


def test_the_concatenated_form_is_rosbag2s() -> None:
    text = concatenated_definition("geometry_msgs/msg/PoseStamped")
    sections = text.split("\n" + "=" * 80 + "\n")
    assert sections[0] == "std_msgs/Header header\nPose pose"
    assert [s.splitlines()[0] for s in sections[1:]] == [
        "MSG: builtin_interfaces/Time", "MSG: geometry_msgs/Point", "MSG: geometry_msgs/Pose",
        "MSG: geometry_msgs/Quaternion", "MSG: std_msgs/Header"]


def test_rosbags_reads_every_definition() -> None:
    from rosbags.typesys import get_types_from_msg

    for name in PAROLKIT_MSGS + ("tf2_msgs/msg/TFMessage",):
        types = get_types_from_msg(definition(name), name)
        assert name in types


def test_names_map_both_ways_and_unknown_names_are_refused() -> None:
    assert dds_type_name("tf2_msgs/msg/TFMessage") == "tf2_msgs::msg::dds_::TFMessage_"
    assert ros_type_name("tf2_msgs::msg::dds_::TFMessage_") == "tf2_msgs/msg/TFMessage"
    with pytest.raises(ParolkitValueError, match="not the DDS name of a ROS 2 type"):
        ros_type_name("JointState")
    with pytest.raises(ParolkitValueError, match="unknown ROS 2 type 'x/msg/Y'"):
        hash_of("x/msg/Y")
