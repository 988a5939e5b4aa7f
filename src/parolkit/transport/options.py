"""Typed options of transport URLs: one :class:`Option` per ``name=value`` a scheme accepts.

An option knows its URL name, the constructor keyword it feeds, its kind and bounds, and turns
either URL text (``"0.01"``) or a Python value (``0.01``) into the checked value, raising
:class:`TransportURLError` that names the option and its allowed range.

Standard library only: :mod:`parolkit.config` checks ``serial.port`` URLs with it.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from enum import Enum

from parolkit.errors import ParolkitValueError
from parolkit.transport.base import TransportError

__all__ = ["TransportURLError", "OptionKind", "Option"]


class TransportURLError(TransportError, ParolkitValueError):
    """A transport URL (or an option given for one) is malformed: the message names the part.

    It is both a :class:`TransportError` (the link cannot be opened) and a
    :class:`ParolkitValueError` (a value given by the user is wrong), so callers catching
    either see it.
    """


class OptionKind(str, Enum):
    """How an option's text is read."""

    FLOAT = "float"
    INT = "int"
    BOOL = "bool"
    CHOICE = "choice"
    PATH = "path"


_TRUE = frozenset({"1", "true", "yes", "on"})
_FALSE = frozenset({"0", "false", "no", "off"})


@dataclass(frozen=True)
class Option:
    """One ``name=value`` of a scheme.

    * ``name``: the URL spelling (``drop``); ``keyword``: the constructor keyword it is passed
      as (``drop_rate``).
    * ``kind`` and its bounds: ``low``/``high`` for FLOAT and INT (inclusive), ``choices`` for
      CHOICE; ``unit`` is shown in messages (``" s"``).
    * ``aliases``: other names accepted from Python keywords only (the old call forms), never
      in URL text.
    * ``help``: one line for the docs and for error messages.
    """

    name: str
    keyword: str
    kind: OptionKind
    help: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    unit: str = ""
    aliases: tuple[str, ...] = ()

    @property
    def allowed(self) -> str:
        """The allowed values in words, e.g. ``0..1`` or ``realtime|virtual``."""
        if self.kind is OptionKind.INT:
            return f"{self.low:.0f}..{self.high:.0f}{self.unit}"
        if self.kind is OptionKind.FLOAT:
            return f"{self.low:g}..{self.high:g}{self.unit}"
        if self.kind is OptionKind.BOOL:
            return "1|0 (true|false, yes|no, on|off)"
        if self.kind is OptionKind.CHOICE:
            return "|".join(self.choices)
        return "a file path, or - for stderr"

    def _fail(self, scheme: str, value: object) -> TransportURLError:
        return TransportURLError(
            f"{scheme} option {self.name}={value!r} is not allowed: "
            f"expected {self.allowed} ({self.help})")

    def convert(self, value: object, scheme: str) -> object:
        """URL text or a Python value -> the checked value (float, int, bool or str).

        ``scheme`` (e.g. ``"faulty+"``) is only used in the error message.
        """
        if isinstance(value, str):
            return self._from_text(value.strip(), scheme)
        return self._from_python(value, scheme)

    def _from_text(self, text: str, scheme: str) -> object:
        kind = self.kind
        if kind is OptionKind.FLOAT:
            try:
                number: float = float(text)
            except ValueError:
                raise self._fail(scheme, text) from None
            return self._in_range(number, scheme, text)
        if kind is OptionKind.INT:
            try:
                integer = int(text, 10)
            except ValueError:
                raise self._fail(scheme, text) from None
            return self._in_range(integer, scheme, text)
        if kind is OptionKind.BOOL:
            low = text.lower()
            if low in _TRUE:
                return True
            if low in _FALSE:
                return False
            raise self._fail(scheme, text)
        if kind is OptionKind.CHOICE:
            if text in self.choices:
                return text
            raise self._fail(scheme, text)
        if not text:
            raise self._fail(scheme, text)
        return text

    def _from_python(self, value: object, scheme: str) -> object:
        kind = self.kind
        if kind is OptionKind.FLOAT:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise self._fail(scheme, value)
            return self._in_range(float(value), scheme, value)
        if kind is OptionKind.INT:
            if isinstance(value, bool) or not isinstance(value, int):
                raise self._fail(scheme, value)
            return self._in_range(value, scheme, value)
        if kind is OptionKind.BOOL:
            if isinstance(value, bool):
                return value
            raise self._fail(scheme, value)
        if kind is OptionKind.PATH and isinstance(value, os.PathLike):
            return self._from_text(os.fspath(value), scheme)
        raise self._fail(scheme, value)  # a CHOICE or PATH given as a non-string

    def _in_range(self, number: int | float, scheme: str, shown: object) -> int | float:
        assert self.low is not None and self.high is not None
        if isinstance(number, float) and math.isnan(number) or not self.low <= number <= self.high:
            raise self._fail(scheme, shown)
        return number
