"""Exceptions shared by every part of parolkit.

Each exception says what went wrong and, where it helps, what to do.  They all derive from
:class:`ParolkitError`; value problems also derive from :class:`ValueError` so generic code
that catches ``ValueError`` keeps working.
"""

from __future__ import annotations

__all__ = ["ParolkitError", "ParolkitValueError", "JointLimitError"]

_JOINT_NAMES = ("J1", "J2", "J3", "J4", "J5", "J6")


class ParolkitError(Exception):
    """Base class of every parolkit error."""


class ParolkitValueError(ParolkitError, ValueError):
    """A value given to a public function is malformed or out of range (the message names it)."""


class JointLimitError(ParolkitValueError):
    """A joint position or speed is outside its allowed range.

    Attributes: ``joint`` (0-based index), ``joint_name`` ("J1".."J6"), ``value``, ``low``,
    ``high``, ``unit`` and, for batches, ``sample`` (row index).
    """

    def __init__(
        self,
        *,
        joint: int,
        value: float,
        low: float,
        high: float,
        unit: str,
        sample: int | None = None,
        what: str = "joints",
    ) -> None:
        self.joint = joint
        self.joint_name = _JOINT_NAMES[joint]
        self.value = value
        self.low = low
        self.high = high
        self.unit = unit
        self.sample = sample
        self.what = what
        side = f"< lower limit {low:g}" if value < low else f"> upper limit {high:g}"
        where = f" (sample {sample})" if sample is not None else ""
        super().__init__(
            f"{what}{where}: {self.joint_name} = {value:g} {unit} is out of range: {side} "
            f"(allowed {low:g} .. {high:g} {unit})"
        )
