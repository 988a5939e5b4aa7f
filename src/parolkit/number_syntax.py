"""What a number is, written as text: the one definition the UDP command parser
(:mod:`parolkit.protocol.commands`) and RBTscript (:mod:`parolkit.script.parser`) share.

A number is ASCII: an optional sign, the digits ``0``-``9`` with at most one decimal point,
and an optional exponent::

    1   -2.5   .5   3.   +1e-3   2E6

Nothing else is a number: no other script's digits (Arabic-Indic ``٨٠``, full-width ``８０``,
mathematical ``𝟖𝟎``), no surrounding whitespace or control characters, no ``1_000``,
``0x10``, ``nan`` or ``inf``.  Python's :func:`float` and :func:`int` accept every one of those
(``float("٨٠") == 80.0``, ``float("8\\x1c") == 8.0``), so they are only ever called here, on
text that matched :data:`NUMBER_PATTERN` first.

This module imports only the standard library and :mod:`parolkit.errors` (the controller's
start-up path parses datagrams with it).
"""

from __future__ import annotations

import math
import re
import unicodedata

from parolkit.errors import ParolkitValueError

__all__ = ["NUMBER_PATTERN", "INTEGER_PATTERN", "MAX_NUMBER_CHARS", "shown", "parse_number", "parse_integer"]

#: A decimal number (a regular expression, no anchors; ASCII digits spelled out, as ``\d``
#: would match any script's digits).
NUMBER_PATTERN = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
#: A whole number: an optional sign and the digits 0-9.
INTEGER_PATTERN = r"[+-]?[0-9]+"
#: Longest number accepted, characters (checked before any conversion: Python refuses to
#: convert integers of more than 4,300 digits, and no PAROL6 value needs more than a few dozen)
MAX_NUMBER_CHARS = 40
#: Longest piece of text quoted back in an error message, characters
_MAX_SHOWN_CHARS = 40

_NUMBER = re.compile(NUMBER_PATTERN)
_INTEGER = re.compile(INTEGER_PATTERN)


def shown(text: str) -> str:
    """``text`` quoted for an error message, cut to 40 characters (a 60 KB field is not echoed)."""
    if len(text) <= _MAX_SHOWN_CHARS:
        return repr(text)
    return f"{text[:_MAX_SHOWN_CHARS]!r}... ({len(text)} characters)"


def _stray_character(text: str) -> str:
    """Why ``text`` cannot be a number when it holds a character outside printable ASCII
    (``""`` when it does not): names the first such character."""
    for ch in text:
        if ch.isascii() and ch.isprintable():
            continue
        if ch.isascii():
            what = f"control character U+{ord(ch):04X}"
        else:
            kind = "digit " if unicodedata.category(ch) == "Nd" else ""
            what = f"{kind}character {ch!r} (U+{ord(ch):04X} {unicodedata.name(ch, 'unnamed')}) is not ASCII"
        return f": the {what}: numbers are written with the ASCII characters 0-9 + - . e"
    return ""


def parse_number(text: str, what: str) -> float:
    """``text`` (exactly, see the module docstring) as a finite float.

    Raises :class:`ParolkitValueError` naming ``what`` (the field or argument), quoting the
    text and, for a look-alike digit or a control character, naming that character."""
    if len(text) > MAX_NUMBER_CHARS:
        raise ParolkitValueError(f"{what} must be a decimal number of at most {MAX_NUMBER_CHARS} characters, "
                                 f"got {len(text)} characters")
    if not _NUMBER.fullmatch(text):
        raise ParolkitValueError(f"{what} must be a decimal number, got {shown(text)}{_stray_character(text)}")
    value = float(text)
    if not math.isfinite(value):
        raise ParolkitValueError(f"{what} must be a finite number, got {shown(text)}: too large for a number")
    return value


def parse_integer(text: str, what: str, lo: int, hi: int) -> int:
    """``text`` as a whole number in ``lo..hi`` (digits only: ``2.0`` is refused).

    Raises :class:`ParolkitValueError` naming ``what`` and the range."""
    if len(text) > MAX_NUMBER_CHARS:
        raise ParolkitValueError(f"{what} must be an integer in {lo}..{hi}, got {len(text)} characters")
    if not _INTEGER.fullmatch(text):
        raise ParolkitValueError(f"{what} must be an integer in {lo}..{hi}, got {shown(text)}"
                                 f"{_stray_character(text)}")
    value = int(text)
    if not lo <= value <= hi:
        raise ParolkitValueError(f"{what} = {value} is out of range {lo}..{hi}")
    return value
