"""RIHS01 type hashes (REP 2011) of parolkit's ROS 2 types, computed from their cyclonedds structs.

ROS 2 (Iron and later) identifies an interface type by a hash of its *type description*: the
type's fields (name, field type id, capacity, string capacity, nested type name) and, sorted by
name, every type it refers to, directly or not.  The hash is ``RIHS01_`` + the SHA-256 (hex) of
that description as JSON, with the keys in the order of type_description_interfaces' messages,
no default values, ``", "`` and ``": "`` as separators and ASCII only.  A service's description
is a struct of ``request_message``, ``response_message`` and ``event_message``; an action's of
``goal``, ``result``, ``feedback``, ``send_goal_service``, ``get_result_service`` and
``feedback_message``.

Here the description is built from a struct of :mod:`parolkit.ros2.msgs` or
:mod:`parolkit.ros2.action_msgs` (its field annotations), so the hash says whether our
declaration is the ROS type to the field: tests/unit/test_ros2_type_hash.py checks it against
the hashes the ROS 2 Jazzy packages ship, and against those ROS's own generator computes from
control_msgs' published definitions.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import typing
from typing import Any

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, bounded_str, sequence

from parolkit.ros2.action_msgs import ActionTypes, ServiceTypes

__all__ = ["RIHS01_PREFIX", "ros_type_name", "type_description", "type_hash", "action_description",
           "service_description"]

RIHS01_PREFIX = "RIHS01_"

#: type_description_interfaces/msg/FieldType ids of the basic types (arrays add 48, bounded
#: sequences 96, unbounded sequences 144)
_BASIC_IDS = {
    "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7, "int64": 8, "uint64": 9,
    "float32": 10, "float64": 11, "char": 13, "wchar": 14, "byte": 16,
}
_NESTED, _BOOLEAN, _STRING, _BOUNDED_STRING = 1, 15, 17, 21
_ARRAY, _BOUNDED_SEQUENCE, _UNBOUNDED_SEQUENCE = 48, 96, 144

Description = dict[str, Any]


def ros_type_name(cls: type) -> str:
    """``pkg/msg/Name`` of the struct whose DDS typename is ``pkg::msg::dds_::Name_``."""
    dds: str = getattr(cls, "__idl_typename__", "")
    parts = dds.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        raise ValueError(f"{cls.__name__}: not a ROS 2 type (DDS typename {dds!r}, expected pkg::kind::dds_::Name_)")
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


def _field_type(annotation: Any, where: str) -> tuple[dict[str, Any], type | None]:
    """The FieldType dict of one annotation, and the nested struct it refers to (or None)."""
    offset, capacity = 0, 0
    value = annotation
    if typing.get_origin(annotation) is typing.Annotated:
        holder = typing.get_args(annotation)[1]
        if isinstance(holder, array):
            offset, capacity, value = _ARRAY, holder.length, holder.subtype
        elif isinstance(holder, sequence):
            offset, value = (_BOUNDED_SEQUENCE, holder.subtype) if holder.max_length else (_UNBOUNDED_SEQUENCE,
                                                                                          holder.subtype)
            capacity = holder.max_length or 0
    base, string_capacity, nested = _value_type(value, where)
    return ({"type_id": base + offset, "capacity": capacity, "string_capacity": string_capacity,
             "nested_type_name": ros_type_name(nested) if nested is not None else ""}, nested)


def _value_type(value: Any, where: str) -> tuple[int, int, type | None]:
    """(type id, string capacity, nested struct) of a field's value type."""
    if value is bool:
        return _BOOLEAN, 0, None
    if value is str:
        return _STRING, 0, None
    if isinstance(value, type) and issubclass(value, IdlStruct):
        return _NESTED, 0, value
    if typing.get_origin(value) is typing.Annotated:
        tag = typing.get_args(value)[1]
        if isinstance(tag, bounded_str):
            return _BOUNDED_STRING, tag.max_length, None
        if isinstance(tag, str) and tag in _BASIC_IDS:
            return _BASIC_IDS[tag], 0, None
    raise ValueError(f"{where}: no ROS 2 field type for {value!r}")


def _individual(cls: type) -> tuple[Description, list[type]]:
    """The IndividualTypeDescription of one struct and the structs its fields refer to."""
    hints = typing.get_type_hints(cls, include_extras=True)
    fields, nested = [], []
    for f in dataclasses.fields(cls):
        ftype, ref = _field_type(hints[f.name], f"{cls.__name__}.{f.name}")
        fields.append({"name": f.name, "type": ftype})
        if ref is not None:
            nested.append(ref)
    if not fields:
        raise ValueError(f"{cls.__name__}: a ROS 2 struct has at least one field "
                         "(rosidl gives an empty one 'uint8 structure_needs_at_least_one_member')")
    return {"type_name": ros_type_name(cls), "fields": fields}, nested


def _synthetic(name: str, members: list[tuple[str, type]]) -> tuple[Description, list[type]]:
    fields = [{"name": n, "type": {"type_id": _NESTED, "capacity": 0, "string_capacity": 0,
                                   "nested_type_name": ros_type_name(c)}} for n, c in members]
    return {"type_name": name, "fields": fields}, [c for _, c in members]


def _service_members(s: ServiceTypes) -> list[tuple[str, type]]:
    return [("request_message", s.request), ("response_message", s.response), ("event_message", s.event)]


def _full(top: tuple[Description, list[type]], synthetic: dict[str, tuple[Description, list[type]]]) -> Description:
    """The TypeDescription: ``top`` and, sorted by name, every type it refers to."""
    seen: dict[str, Description] = {}
    queue = list(top[1])
    while queue:
        cls = queue.pop()
        name = ros_type_name(cls)
        if name in seen:
            continue
        desc, refs = synthetic[name] if name in synthetic else _individual(cls)
        seen[name] = desc
        queue.extend(refs)
    return {"type_description": top[0], "referenced_type_descriptions": [seen[k] for k in sorted(seen)]}


class _Named:
    """A stand-in struct class for a synthetic (service) type inside an action's description."""

    def __init__(self, name: str) -> None:
        pkg, kind, short = name.split("/")
        self.__idl_typename__ = f"{pkg}::{kind}::dds_::{short}_"
        self.__name__ = short


def type_description(cls: type) -> Description:
    """The TypeDescription (type_description_interfaces/msg/TypeDescription as a dict, without
    default values) of a message struct."""
    return _full(_individual(cls), {})


def service_description(s: ServiceTypes) -> Description:
    """The TypeDescription of a service."""
    return _full(_synthetic(s.name, _service_members(s)), {})


def action_description(a: ActionTypes) -> Description:
    """The TypeDescription of an action."""
    send, get = _Named(a.send_goal.name), _Named(a.get_result.name)
    synthetic = {a.send_goal.name: _synthetic(a.send_goal.name, _service_members(a.send_goal)),
                 a.get_result.name: _synthetic(a.get_result.name, _service_members(a.get_result))}
    top = _synthetic(a.name, [("goal", a.goal), ("result", a.result), ("feedback", a.feedback),
                              ("send_goal_service", send), ("get_result_service", get),  # type: ignore[list-item]
                              ("feedback_message", a.feedback_message)])
    return _full(top, synthetic)


def type_hash(obj: type | ServiceTypes | ActionTypes) -> str:
    """``RIHS01_<sha256 hex>`` of a message struct, a service or an action."""
    if isinstance(obj, ActionTypes):
        desc = action_description(obj)
    elif isinstance(obj, ServiceTypes):
        desc = service_description(obj)
    else:
        desc = type_description(obj)
    text = json.dumps(desc, ensure_ascii=True, allow_nan=False, separators=(", ", ": "))
    return RIHS01_PREFIX + hashlib.sha256(text.encode("utf-8")).hexdigest()
