"""RIHS01 type hashes of ROS 2 interfaces (REP 2011), computed from ``.msg`` definitions.

Since Iron a ROS 2 middleware puts every topic's type hash in the USER_DATA QoS of its readers
and writers (``typehash=RIHS01_<64 hex digits>;``) and tools report it
(``get_publishers_info_by_topic``); a reader whose hash differs from the writer's is told the
types differ.  The hash is version 1 of the ROS Interface Hashing Standard:

1. the **type description** of a type: its own *individual description* (its name, e.g.
   ``sensor_msgs/msg/JointState``, and its fields: name and field type) and the individual
   descriptions of every type it refers to, directly or through another, sorted by name;
2. a field type is four numbers and a name: ``type_id`` (the primitive's number of
   type_description_interfaces/msg/FieldType, plus 48 for a fixed array, 96 for a bounded
   sequence, 144 for an unbounded one; 1 for a nested type), ``capacity`` (the array's size or
   the sequence's bound), ``string_capacity`` (a bounded string's bound) and
   ``nested_type_name``;
3. that structure as JSON with the keys in the order above, ``", "`` and ``": "`` as separators,
   ASCII only, default values left out; its SHA-256 in lower-case hex after ``RIHS01_``.

Definitions are parsed here from the ``.msg`` text (:func:`parse_msg`): comments, constants and
default values are not part of the hash; ``char`` is ``uint8`` and ``byte`` an octet, as
rosidl maps them; a message with no field gets rosidl's placeholder field
``structure_needs_at_least_one_member`` (``uint8``).  Types that are not written as ``.msg``
(the request, response and event of a service, an action's goal services) can be built as
:class:`IndividualTypeDescription` values directly and hashed the same way
(:func:`type_hash_of`).

Pure standard library; nothing here knows about DDS.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

from parolkit.errors import ParolkitValueError

__all__ = [
    "FieldType", "Field", "IndividualTypeDescription", "TypeDescription", "FIELD_TYPE_NESTED",
    "ARRAY_OFFSET", "BOUNDED_SEQUENCE_OFFSET", "UNBOUNDED_SEQUENCE_OFFSET", "PRIMITIVE_TYPE_IDS",
    "full_type_name", "parse_msg", "msg_dependencies", "type_description", "type_description_json",
    "type_hash_of", "type_hash", "user_data", "parse_user_data_hash", "TYPE_HASH_RE",
]

#: type_description_interfaces/msg/FieldType: a nested (message) type
FIELD_TYPE_NESTED = 1
#: added to a base type id for a fixed-size array, a bounded and an unbounded sequence
ARRAY_OFFSET = 48
BOUNDED_SEQUENCE_OFFSET = 96
UNBOUNDED_SEQUENCE_OFFSET = 144
_BOUNDED_STRING = 21
_BOUNDED_WSTRING = 22

#: the primitive types of a ``.msg`` file and their FieldType ids (``char`` is rosidl's uint8)
PRIMITIVE_TYPE_IDS: dict[str, int] = {
    "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7, "int64": 8, "uint64": 9,
    "float32": 10, "float64": 11, "char": 3, "bool": 15, "byte": 16, "string": 17, "wstring": 18,
}

#: what a valid RIHS01 hash looks like
TYPE_HASH_RE = re.compile(r"RIHS01_[0-9a-f]{64}")

_NAME = r"[A-Za-z][A-Za-z0-9_]*"
_FIELD_NAME_RE = re.compile(r"[a-z][a-z0-9_]*")
# TYPE NAME[=CONSTANT | DEFAULT]: the type is the first token, the name the second
_LINE_RE = re.compile(rf"^(?P<type>\S+)\s+(?P<name>{_NAME})\s*(?P<const>=)?")
_TYPE_RE = re.compile(rf"^(?P<base>{_NAME}(?:/{_NAME}){{0,2}})(?:<=(?P<strbound>\d+))?"
                      r"(?:\[(?P<array>(?:<=)?\d*)\])?$")
_PLACEHOLDER = "structure_needs_at_least_one_member"


@dataclass(frozen=True)
class FieldType:
    """One field's type as REP 2011 describes it (see the module docstring)."""

    type_id: int
    capacity: int = 0
    string_capacity: int = 0
    nested_type_name: str = ""

    def as_dict(self) -> dict[str, int | str]:
        return {"type_id": self.type_id, "capacity": self.capacity, "string_capacity": self.string_capacity,
                "nested_type_name": self.nested_type_name}


@dataclass(frozen=True)
class Field:
    name: str
    type: FieldType


@dataclass(frozen=True)
class IndividualTypeDescription:
    """A type's name (``pkg/msg/Name``) and its fields, in order."""

    type_name: str
    fields: tuple[Field, ...]

    def as_dict(self) -> dict[str, object]:
        return {"type_name": self.type_name,
                "fields": [{"name": f.name, "type": f.type.as_dict()} for f in self.fields]}

    @property
    def nested_type_names(self) -> list[str]:
        """The types this one's fields refer to, in field order, each once."""
        out: list[str] = []
        for f in self.fields:
            n = f.type.nested_type_name
            if n and n not in out:
                out.append(n)
        return out


@dataclass(frozen=True)
class TypeDescription:
    """A type and every type it refers to (directly or not), sorted by name."""

    type_description: IndividualTypeDescription
    referenced_type_descriptions: tuple[IndividualTypeDescription, ...]


def full_type_name(name: str, package: str) -> str:
    """``pkg/msg/Name`` of a type as a ``.msg`` field names it: ``Name`` (in ``package``),
    ``pkg/Name``, ``pkg/msg/Name``, or ``Header`` (always std_msgs's)."""
    parts = name.split("/")
    if len(parts) == 1:
        return "std_msgs/msg/Header" if name == "Header" else f"{package}/msg/{name}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name


def _field_type(token: str, package: str, where: str) -> FieldType:
    m = _TYPE_RE.match(token)
    if m is None:
        raise ParolkitValueError(f"{where}: cannot read the type {token!r}")
    base, strbound, array = m.group("base"), m.group("strbound"), m.group("array")
    nested = ""
    string_capacity = 0
    if base in PRIMITIVE_TYPE_IDS:
        type_id = PRIMITIVE_TYPE_IDS[base]
        if strbound is not None:
            if base not in ("string", "wstring"):
                raise ParolkitValueError(f"{where}: only string and wstring take a bound (<=N), got {token!r}")
            type_id = _BOUNDED_STRING if base == "string" else _BOUNDED_WSTRING
            string_capacity = int(strbound)
    elif strbound is not None:
        raise ParolkitValueError(f"{where}: only string and wstring take a bound (<=N), got {token!r}")
    else:
        type_id = FIELD_TYPE_NESTED
        nested = full_type_name(base, package)
    capacity = 0
    if array is not None:
        if array == "":
            type_id += UNBOUNDED_SEQUENCE_OFFSET
        elif array.startswith("<="):
            if not array[2:]:
                raise ParolkitValueError(f"{where}: a bounded sequence needs its bound, got {token!r}")
            type_id += BOUNDED_SEQUENCE_OFFSET
            capacity = int(array[2:])
        else:
            type_id += ARRAY_OFFSET
            capacity = int(array)
    return FieldType(type_id, capacity, string_capacity, nested)


def parse_msg(type_name: str, text: str) -> IndividualTypeDescription:
    """The individual description of ``type_name`` (``pkg/msg/Name``) from its ``.msg`` text:
    one field per ``TYPE NAME [DEFAULT]`` line; comments, blank lines and constants
    (``TYPE NAME=VALUE``) are not fields.  A malformed line is an error naming it."""
    parts = type_name.split("/")
    if len(parts) != 3 or not all(parts):
        raise ParolkitValueError(f"a type name must be pkg/msg/Name, got {type_name!r}")
    package = parts[0]
    fields: list[Field] = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        where = f"{type_name} line {lineno}"
        m = _LINE_RE.match(line)
        if m is None:
            raise ParolkitValueError(f"{where}: expected 'TYPE NAME', got {raw!r}")
        if m.group("const"):
            continue  # a constant: not a field, not in the hash
        if not _FIELD_NAME_RE.fullmatch(m.group("name")):
            raise ParolkitValueError(
                f"{where}: a field name is lower case letters, digits and _, got {m.group('name')!r}")
        fields.append(Field(m.group("name"), _field_type(m.group("type"), package, where)))
    if not fields:
        fields.append(Field(_PLACEHOLDER, FieldType(PRIMITIVE_TYPE_IDS["uint8"])))
    return IndividualTypeDescription(type_name, tuple(fields))


def type_description(type_name: str,
                     lookup: Callable[[str], IndividualTypeDescription] | Mapping[str, IndividualTypeDescription]
                     ) -> TypeDescription:
    """``type_name`` with every type it refers to: ``lookup`` gives an individual description
    by name (a mapping or a function; a missing one is an error naming who needs it)."""
    get = lookup.__getitem__ if isinstance(lookup, Mapping) else lookup

    def find(name: str, needed_by: str) -> IndividualTypeDescription:
        try:
            return get(name)
        except KeyError:
            raise ParolkitValueError(f"{needed_by} refers to {name}, whose definition is not known") from None

    main = find(type_name, "the request")
    seen: dict[str, IndividualTypeDescription] = {}
    todo = [(n, type_name) for n in main.nested_type_names]
    while todo:
        name, parent = todo.pop()
        if name in seen or name == type_name:
            continue
        seen[name] = find(name, parent)
        todo.extend((n, name) for n in seen[name].nested_type_names)
    return TypeDescription(main, tuple(seen[n] for n in sorted(seen)))


def type_description_json(desc: TypeDescription) -> str:
    """The text REP 2011 hashes (module docstring, step 3)."""
    obj = {"type_description": desc.type_description.as_dict(),
           "referenced_type_descriptions": [d.as_dict() for d in desc.referenced_type_descriptions]}
    return json.dumps(obj, ensure_ascii=True, allow_nan=False, separators=(", ", ": "), sort_keys=False)


def type_hash_of(desc: TypeDescription) -> str:
    """``RIHS01_<sha256 hex>`` of a type description."""
    return "RIHS01_" + hashlib.sha256(type_description_json(desc).encode("utf-8")).hexdigest()


def msg_dependencies(type_name: str, definitions: Mapping[str, str]) -> list[str]:
    """Every type ``type_name`` refers to (directly or not), by parsing ``definitions``
    (``pkg/msg/Name`` -> ``.msg`` text), sorted by name."""
    desc = type_description(type_name, lambda n: parse_msg(n, definitions[n]))
    return [d.type_name for d in desc.referenced_type_descriptions]


def type_hash(type_name: str, definitions: Mapping[str, str]) -> str:
    """The RIHS01 hash of ``type_name`` given the ``.msg`` texts of it and every type it refers to."""
    return type_hash_of(type_description(type_name, lambda n: parse_msg(n, definitions[n])))


def user_data(type_hash_str: str) -> bytes:
    """The USER_DATA of a ROS 2 reader or writer carrying ``type_hash_str``, as Jazzy's rmw writes it."""
    if not TYPE_HASH_RE.fullmatch(type_hash_str):
        raise ParolkitValueError(f"a type hash must be RIHS01_ and 64 hex digits, got {type_hash_str!r}")
    return f"typehash={type_hash_str};".encode("ascii")


def parse_user_data_hash(data: bytes | Iterable[int]) -> str | None:
    """The ``typehash`` of a USER_DATA value (``key=value;`` pairs), or None without one."""
    text = bytes(data).decode("ascii", errors="replace")
    for pair in text.split(";"):
        key, sep, value = pair.partition("=")
        if sep and key == "typehash":
            return value
    return None
