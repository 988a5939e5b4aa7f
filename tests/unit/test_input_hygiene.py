"""Garbage in, a precise refusal out: look-alike characters, oversized numbers, IDs of
undecodable datagrams, names that look like IDs (issue 13, item 5)."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from parolkit.protocol.commands import (
    _NAMES,
    MAX_MESSAGE_CHARS,
    DatagramError,
    is_command_id,
    parse_datagram,
)


@pytest.mark.parametrize("text, char", [
    ("MOVEJOINT|٩0|-90|180|0|0|180|2|None", "U+0669"),        # Arabic-Indic digit nine
    ("MOVEJOINT|90|-９0|180|0|0|180|2|None", "U+FF19"),        # full-width digit
    ("MОVEJOINT|90|-90|180|0|0|180|2|None", "U+041E"),         # Cyrillic capital O
    ("abcd1234|HOME\u200b", "U+200B"),                          # zero-width space
])
def test_look_alike_characters_are_refused_naming_the_character(text, char):
    with pytest.raises(DatagramError, match=char.replace("+", "\\+")) as info:
        parse_datagram(text.encode("utf-8"))
    assert "not ASCII" in str(info.value)


@pytest.mark.parametrize("text, field, char", [
    ("MOVEJOINT|٨٠|-90|180|0|0|180|2|None", "J1 angle (deg)", "U+0668 ARABIC-INDIC DIGIT EIGHT"),
    ("MOVEJOINT|８０|-90|180|0|0|180|2|None", "J1 angle (deg)", "U+FF18 FULLWIDTH DIGIT EIGHT"),
    ("MOVEJOINT|80|-90|180|0|0|𝟏𝟖𝟎|2|None", "J6 angle (deg)", "U+1D7CF MATHEMATICAL BOLD DIGIT ONE"),
    ("abcd1234|SUBSCRIBE|5٠٠٠", "port", "U+0660 ARABIC-INDIC DIGIT ZERO"),
])
def test_look_alike_digits_are_refused_naming_the_field(text, field, char):
    with pytest.raises(DatagramError) as info:
        parse_datagram(text.encode("utf-8"))
    assert f"{field} must be a" in str(info.value) and f"({char}) is not ASCII" in str(info.value)


@pytest.mark.parametrize("text, fragment", [
    ("SET_PORT|/dev/ttyACM٣", "U+0663 ARABIC-INDIC DIGIT THREE) at position 20 is not ASCII"),
    ("abcd1234|SET_TOOL|pen٣", "tool name must be 1..64 characters of [A-Za-z0-9_.-], got 'pen٣'"),
    ("HOME٣", "unknown command 'HOME٣'"),
])
def test_look_alike_digits_outside_number_fields_are_refused_all_the_same(text, fragment):
    with pytest.raises(DatagramError) as info:
        parse_datagram(text.encode("utf-8"))
    assert fragment in str(info.value)


def test_control_characters_are_refused():
    with pytest.raises(DatagramError, match="control character U\\+001B"):
        parse_datagram(b"HOME|\x1b[2J")


@pytest.mark.parametrize("data, position", [
    (b"\x00JOG|0|20|0.2|None", 0),                  # moved the arm: the NUL was stripped
    (b"JOG|0|20|0.2|None\x00", 17),
    (b"JOG|0|20|0.2\x00|None", 12),
    (b"JOG|0|20|0.2|None\n", 17),
    (b"JOG|0|20|0.2|None\r\n", 17),
    (b"\tJOG|0|20|0.2|None", 0),
    (b"JOG|\t0|20|0.2|None", 4),
    (b"abcd1234|\x00JOG|0|20|0.2|None", 9),
])
def test_nul_tab_and_line_ends_are_refused_even_at_the_ends(data, position):
    with pytest.raises(DatagramError, match=f"control character U\\+00[0-9A-F]{{2}} at position {position}:") as info:
        parse_datagram(data)
    if data.startswith(b"abcd1234|"):
        assert info.value.command_id == "abcd1234"


def test_spaces_around_fields_are_ignored():
    assert parse_datagram(b" JOG | 0 |20|0.2|None ").command == parse_datagram(b"JOG|0|20|0.2|None").command


#: (text, accepted): what a number is, for both parsers (parolkit.number_syntax)
NUMBER_TEXTS = [("1", True), ("+1", True), ("1.", True), (".5", True), ("0.5e1", True), ("5E-1", True),
                ("٣", False), ("８", False), ("𝟖", False), ("1_0", False), ("0x1", False), ("nan", False),
                ("inf", False), ("Infinity", False), ("1e999", False), ("1" * 41, False)]


@pytest.mark.parametrize("text, accepted", NUMBER_TEXTS)
def test_one_number_grammar_for_datagrams_and_programs(text, accepted):
    from parolkit.script.parser import parse

    try:
        parse_datagram(f"DELAY|{text}".encode())
        datagram_ok = True
    except DatagramError:
        datagram_ok = False
    assert datagram_ok is accepted
    assert parse(f"Delay({text})").ok is accepted


def test_a_datagram_that_is_not_text_still_gets_its_id_back():
    with pytest.raises(DatagramError) as info:
        parse_datagram(b"abcd1234|MOVEJOINT|\xff\xfe")
    assert info.value.command_id == "abcd1234"
    assert "byte 0xFF" in str(info.value)


def test_look_alike_text_with_an_id_gets_its_id_back():
    with pytest.raises(DatagramError) as info:
        parse_datagram("abcd1234|HOME|٣".encode())
    assert info.value.command_id == "abcd1234"


@pytest.mark.parametrize("name", ["movecart", "MovePose", "multijog"])
def test_command_names_in_lower_case_are_names_not_ids(name):
    assert not is_command_id(name)
    parsed = parse_datagram(f"{name}|" + ("0|50|2" if name == "multijog" else "100|0|300|0|0|0|2|None"))
    assert parsed.command_id is None and parsed.command.name.upper() == name.upper()


@pytest.mark.parametrize("field", ["9" * 5000, "1" + "0" * 4400, "0." + "1" * 100])
def test_numeric_fields_are_length_capped_before_conversion(field):
    with pytest.raises(DatagramError, match="characters") as info:
        parse_datagram(f"abcd1234|SUBSCRIBE|{field}")
    assert info.value.command_id == "abcd1234"
    with pytest.raises(DatagramError, match="at most 40 characters"):
        parse_datagram(f"MOVEJOINT|{field}|-90|180|0|0|180|2|None")


def test_a_60_kb_field_is_not_echoed_back():
    with pytest.raises(DatagramError) as info:
        parse_datagram("abcd1234|SET_TOOL|" + "x" * 60_000)
    assert len(str(info.value)) <= MAX_MESSAGE_CHARS
    assert "60000 characters" in str(info.value)


_ANY_NAME = st.sampled_from(sorted(_NAMES))
_FIELD = st.one_of(st.text(max_size=20), st.integers().map(str), st.floats().map(str),
                   st.sampled_from(["", "None", "nan", "inf", "-0", "1e999", "0" * 5000, "٣", "1,2,3"]))


@settings(max_examples=3000, deadline=None, suppress_health_check=list(HealthCheck))
@given(name=_ANY_NAME, fields=st.lists(_FIELD, max_size=14), cid=st.sampled_from([None, "abcd1234", "Zz-09azQ"]))
def test_any_fields_after_any_name_parse_or_raise_a_datagram_error_with_the_id(name, fields, cid):
    text = "|".join(([cid] if cid else []) + [name] + fields)
    try:
        parsed = parse_datagram(text.encode("utf-8", "surrogatepass"))
    except DatagramError as exc:
        assert exc.command_id == cid
        assert len(str(exc)) <= MAX_MESSAGE_CHARS
    else:
        assert parsed.command_id == cid


@settings(max_examples=3000, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.binary(max_size=300), cid=st.sampled_from([b"", b"abcd1234|"]))
def test_arbitrary_bytes_parse_or_raise_a_datagram_error_with_the_id(data, cid):
    try:
        parse_datagram(cid + data)
    except DatagramError as exc:
        if cid:
            assert exc.command_id == "abcd1234"


@pytest.mark.parametrize("text", [
    "MOVECART|0|-19.3936|360|-100|0|0|1e-300|None",   # once: "float division by zero"
    "MOVEJOINT|80|-80|170|0|0|170|1e-300|None",
    "MOVECARTRELTRF|0|0|30|0|0|0|1e-300|None",
])
def test_a_vanishing_duration_is_refused_in_words_not_by_an_arithmetic_error(text):
    with pytest.raises(DatagramError, match=r"duration = 1e-300 s is out of range \[1e-09, 3600\] s") as info:
        parse_datagram(text)
    assert "division" not in str(info.value)
    # the move objects refuse it too (the Python API, not only the wire)
    from parolkit.errors import ParolkitValueError
    from parolkit.moves import CartMove

    with pytest.raises(ParolkitValueError, match="duration_s must be in 1e-09..3600 s"):
        CartMove((0, 250, 300, 0, 0, 0), 1e-300)
