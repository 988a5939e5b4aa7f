"""RIHS01 type hashes (REP 2011) of parolkit's cyclonedds structs: what goes on the wire.

:mod:`parolkit.ros2.typehash` hashes ROS 2 interface definitions (``.msg`` text); this module
reads the type description straight from a cyclonedds struct of :mod:`parolkit.ros2.msgs` or
:mod:`parolkit.ros2.action_msgs` (its field names and annotations: ``int32``, ``sequence[T]``,
``sequence[T, N]``, ``array[T, N]``, ``bounded_str[N]``, nested structs) and hashes it with
that module's :func:`~parolkit.ros2.typehash.type_hash_of`, so the hash says whether the
struct the bridge sends IS the ROS type, field for field.  A service's description is a
struct of ``request_message``, ``response_message`` and ``event_message``; an action's of
``goal``, ``result``, ``feedback``, ``send_goal_service``, ``get_result_service`` and
``feedback_message`` (as rosidl_generator_type_description builds them).

Checked against ROS 2's own: the hashes the Jazzy packages ship (trajectory_msgs,
action_msgs, test_msgs' Fibonacci action) and those ROS's generator computes from
control_msgs' published definitions (tests/integration/test_ros2_action.py).
"""

from __future__ import annotations

import dataclasses
import json
import typing
from typing import Any

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, bounded_str, sequence

from parolkit.ros2.action_msgs import ActionTypes, ServiceTypes
from parolkit.ros2.typehash import (
    ARRAY_OFFSET,
    BOUNDED_SEQUENCE_OFFSET,
    FIELD_TYPE_NESTED,
    PRIMITIVE_TYPE_IDS,
    UNBOUNDED_SEQUENCE_OFFSET,
    Field,
    FieldType,
    IndividualTypeDescription,
    TypeDescription,
    type_description_json,
    type_hash_of,
)

__all__ = ["ros_type_name", "struct_description", "service_description", "action_description", "struct_hash",
           "description_dict"]

#: cyclonedds' basic annotations -> the FieldType ids (rosidl's ``char`` is uint8 already)
_BASIC = {**{k: v for k, v in PRIMITIVE_TYPE_IDS.items() if k not in ("char", "bool", "string", "wstring")},
          "char": 13, "wchar": 14}
_BOUNDED_STRING = 21


def ros_type_name(cls: object) -> str:
    """``pkg/msg/Name`` of the struct whose DDS typename is ``pkg::msg::dds_::Name_``."""
    dds: str = getattr(cls, "__idl_typename__", "")
    parts = dds.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        raise ValueError(f"{getattr(cls, '__name__', cls)}: not a ROS 2 type (DDS typename {dds!r}, "
                         "expected pkg::kind::dds_::Name_)")
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


def _value_type(value: Any, where: str) -> tuple[int, int, type | None]:
    """(type id, string capacity, nested struct) of a field's value type."""
    if value is bool:
        return PRIMITIVE_TYPE_IDS["bool"], 0, None
    if value is str:
        return PRIMITIVE_TYPE_IDS["string"], 0, None
    if isinstance(value, type) and issubclass(value, IdlStruct):
        return FIELD_TYPE_NESTED, 0, value
    if typing.get_origin(value) is typing.Annotated:
        tag = typing.get_args(value)[1]
        if isinstance(tag, bounded_str):
            return _BOUNDED_STRING, tag.max_length, None
        if isinstance(tag, str) and tag in _BASIC:
            return _BASIC[tag], 0, None
    raise ValueError(f"{where}: no ROS 2 field type for {value!r}")


def _field_type(annotation: Any, where: str) -> tuple[FieldType, type | None]:
    """The FieldType of one annotation, and the nested struct it refers to (or None)."""
    offset, capacity, value = 0, 0, annotation
    if typing.get_origin(annotation) is typing.Annotated:
        holder = typing.get_args(annotation)[1]
        if isinstance(holder, array):
            offset, capacity, value = ARRAY_OFFSET, holder.length, holder.subtype
        elif isinstance(holder, sequence):
            capacity = holder.max_length or 0
            offset = BOUNDED_SEQUENCE_OFFSET if capacity else UNBOUNDED_SEQUENCE_OFFSET
            value = holder.subtype
    base, string_capacity, nested = _value_type(value, where)
    return FieldType(base + offset, capacity, string_capacity, ros_type_name(nested) if nested else ""), nested


def _individual(cls: type) -> tuple[IndividualTypeDescription, list[Any]]:
    """A struct's individual description and the structs its fields refer to."""
    hints = typing.get_type_hints(cls, include_extras=True)
    fields, nested = [], []
    for f in dataclasses.fields(cls):
        ftype, ref = _field_type(hints[f.name], f"{cls.__name__}.{f.name}")
        fields.append(Field(f.name, ftype))
        if ref is not None:
            nested.append(ref)
    if not fields:
        raise ValueError(f"{cls.__name__}: a ROS 2 struct has at least one field "
                         "(rosidl gives an empty one 'uint8 structure_needs_at_least_one_member')")
    return IndividualTypeDescription(ros_type_name(cls), tuple(fields)), nested


def _composite(name: str, members: list[tuple[str, Any]]) -> tuple[IndividualTypeDescription, list[Any]]:
    """A service or action: a struct of nested members."""
    fields = tuple(Field(n, FieldType(FIELD_TYPE_NESTED, nested_type_name=ros_type_name(c))) for n, c in members)
    return IndividualTypeDescription(name, fields), [c for _, c in members]


class _Named:
    """A stand-in for a service inside an action's description (it has no struct of its own)."""

    def __init__(self, name: str) -> None:
        pkg, kind, short = name.split("/")
        self.__idl_typename__ = f"{pkg}::{kind}::dds_::{short}_"
        self.__name__ = short


def _service_members(s: ServiceTypes) -> list[tuple[str, Any]]:
    return [("request_message", s.request), ("response_message", s.response), ("event_message", s.event)]


def _closure(top: tuple[IndividualTypeDescription, list[Any]],
             composites: dict[str, tuple[IndividualTypeDescription, list[Any]]]) -> TypeDescription:
    seen: dict[str, IndividualTypeDescription] = {}
    todo = list(top[1])
    while todo:
        cls = todo.pop()
        name = ros_type_name(cls)
        if name in seen:
            continue
        desc, refs = composites[name] if name in composites else _individual(cls)
        seen[name] = desc
        todo.extend(refs)
    return TypeDescription(top[0], tuple(seen[n] for n in sorted(seen)))


def struct_description(cls: type) -> TypeDescription:
    """The type description of a message struct."""
    return _closure(_individual(cls), {})


def service_description(s: ServiceTypes) -> TypeDescription:
    """The type description of a service."""
    return _closure(_composite(s.name, _service_members(s)), {})


def action_description(a: ActionTypes) -> TypeDescription:
    """The type description of an action."""
    composites = {s.name: _composite(s.name, _service_members(s)) for s in (a.send_goal, a.get_result)}
    top = _composite(a.name, [("goal", a.goal), ("result", a.result), ("feedback", a.feedback),
                              ("send_goal_service", _Named(a.send_goal.name)),
                              ("get_result_service", _Named(a.get_result.name)),
                              ("feedback_message", a.feedback_message)])
    return _closure(top, composites)


def struct_hash(obj: type | ServiceTypes | ActionTypes) -> str:
    """``RIHS01_<sha256 hex>`` of a message struct, a service or an action."""
    if isinstance(obj, ActionTypes):
        return type_hash_of(action_description(obj))
    if isinstance(obj, ServiceTypes):
        return type_hash_of(service_description(obj))
    return type_hash_of(struct_description(obj))


def description_dict(desc: TypeDescription) -> dict[str, Any]:
    """The description as the JSON object that is hashed."""
    out: dict[str, Any] = json.loads(type_description_json(desc))
    return out
