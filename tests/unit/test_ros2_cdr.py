"""parolkit.ros2.cdr writes, byte for byte, what mcap-ros2-support's dynamic encoder writes, for
every type of parolkit.ros2.interfaces with random values (empty and long sequences, unicode
strings, every alignment), and the recorder's real messages decode back."""

from __future__ import annotations

import random
import struct
from typing import Any

import pytest
from mcap.records import Schema
from mcap_ros2._dynamic import serialize_dynamic
from mcap_ros2.decoder import DecoderFactory

from parolkit.errors import ParolkitValueError
from parolkit.ros2.cdr import encode, encoder
from parolkit.ros2.interfaces import DEFINITIONS, concatenated_definition
from parolkit.ros2.typehash import ARRAY_OFFSET, BOUNDED_SEQUENCE_OFFSET, UNBOUNDED_SEQUENCE_OFFSET, parse_msg

_INTS = {2: (-128, 127), 3: (0, 255), 4: (-32768, 32767), 5: (0, 65535), 6: (-2**31, 2**31 - 1), 7: (0, 2**32 - 1),
         8: (-2**63, 2**63 - 1), 9: (0, 2**64 - 1), 16: (0, 255)}
#: .msg ``char`` is rosidl's uint8, which mcap-ros2-support writes as int8: compared where both agree
_CHAR = (0, 127)


def _value(base: int, nested: str, rng: random.Random, char: bool = False) -> Any:
    if base == 1:
        return _message(nested, rng)
    if char:
        return rng.randint(*_CHAR)
    if base in (17, 21):
        return rng.choice(["", "a", "base_link", "L6 ∠ 90°", "x" * rng.randrange(0, 40)])
    if base == 15:
        return rng.random() < 0.5
    if base in (10, 11):
        v = rng.uniform(-1e3, 1e3)
        return struct.unpack("<f", struct.pack("<f", v))[0] if base == 10 else v
    lo, hi = _INTS[base]
    return rng.randint(lo, hi)


def _message(type_name: str, rng: random.Random) -> dict[str, Any]:
    out: dict[str, Any] = {}
    lines = [line.split() for line in DEFINITIONS[type_name].splitlines() if line and not line.startswith("#")]
    chars = {words[1] for words in lines if words[0].startswith("char")}
    for f in parse_msg(type_name, DEFINITIONS[type_name]).fields:
        tid = f.type.type_id
        if tid > UNBOUNDED_SEQUENCE_OFFSET or tid > BOUNDED_SEQUENCE_OFFSET:
            base = tid - (UNBOUNDED_SEQUENCE_OFFSET if tid > UNBOUNDED_SEQUENCE_OFFSET else BOUNDED_SEQUENCE_OFFSET)
            n = rng.choice([0, 1, 2, 5])
            out[f.name] = [_value(base, f.type.nested_type_name, rng) for _ in range(n)]
        elif tid > ARRAY_OFFSET:
            out[f.name] = [_value(tid - ARRAY_OFFSET, f.type.nested_type_name, rng, f.name in chars)
                           for _ in range(f.type.capacity)]
        else:
            out[f.name] = _value(tid, f.type.nested_type_name, rng)
    return out


@pytest.mark.parametrize("type_name", sorted(DEFINITIONS))
def test_the_bytes_are_mcap_ros2s_for_random_messages(type_name: str) -> None:
    reference = serialize_dynamic(type_name, concatenated_definition(type_name))[type_name]
    ours = encoder(type_name)
    rng = random.Random(type_name)
    for _ in range(60):
        msg = _message(type_name, rng)
        assert ours(msg) == reference(msg), msg


def test_a_status_decodes_back_with_mcap_ros2() -> None:
    msg = _message("parolkit_msgs/msg/Status", random.Random(1))
    schema = Schema(id=1, name="parolkit_msgs/msg/Status", encoding="ros2msg",
                    data=concatenated_definition("parolkit_msgs/msg/Status").encode())
    decode = DecoderFactory().decoder_for("cdr", schema)
    assert decode is not None
    back = decode(encode("parolkit_msgs/msg/Status", msg))
    assert back.json == msg["json"] and list(back.steps) == msg["steps"]
    assert back.header.frame_id == msg["header"]["frame_id"]


def test_bad_input_is_refused_naming_the_field() -> None:
    msg = _message("parolkit_msgs/msg/Plan", random.Random(2))
    msg["target_angles"] = [1.0, 2.0]
    with pytest.raises(ParolkitValueError, match="field 'target_angles' needs 6 values, got 2"):
        encode("parolkit_msgs/msg/Plan", msg)
    with pytest.raises(ParolkitValueError, match="unknown ROS 2 type 'x/msg/Y'"):
        encoder("x/msg/Y")
