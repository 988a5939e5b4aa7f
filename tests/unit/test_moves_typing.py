"""The move classes' constructor signatures for type checkers agree with the real constructor.

``parolkit.moves`` types each enum field as the enum it holds after construction and states,
in an ``if TYPE_CHECKING:`` block that never runs, the wider constructor that also takes the
words (``profile="trap"``).  These tests keep those hand-written signatures honest: same
parameters, order and defaults as the generated dataclass ``__init__``, and each annotation the
field's own, widened by ``| str`` exactly where the field is an enum.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
from enum import Enum
from pathlib import Path

import pytest

import parolkit.moves as moves

_ENUMS = {name for name, obj in vars(moves).items() if isinstance(obj, type) and issubclass(obj, Enum)}
_MOVE_CLASSES = [obj for obj in vars(moves).values() if dataclasses.is_dataclass(obj) and isinstance(obj, type)]


def _stubs() -> dict[str, ast.FunctionDef]:
    tree = ast.parse(Path(moves.__file__).read_text(encoding="utf-8"))
    out = {}
    for node in tree.body:
        if not isinstance(node, ast.ClassDef):
            continue
        for stmt in node.body:
            if isinstance(stmt, ast.If) and ast.unparse(stmt.test) == "TYPE_CHECKING":
                (init,) = [s for s in stmt.body if isinstance(s, ast.FunctionDef) and s.name == "__init__"]
                out[node.name] = init
    return out


def _enum_of(annotation: str) -> str | None:
    """The enum an annotation names (``"Profile | None"`` -> ``"Profile"``), else None."""
    names = [part.strip() for part in annotation.split("|")]
    found = [n for n in names if n in _ENUMS]
    return found[0] if found else None


def _widened(annotation: str) -> str:
    enum = _enum_of(annotation)
    return annotation if enum is None else annotation.replace(enum, f"{enum} | str", 1)


STUBS = _stubs()


def test_every_move_with_an_enum_field_states_its_wider_constructor():
    with_enum = {cls.__name__ for cls in _MOVE_CLASSES
                 if any(_enum_of(str(f.type)) for f in dataclasses.fields(cls))}
    assert with_enum  # (the check below must not pass vacuously)
    assert set(STUBS) == with_enum


@pytest.mark.parametrize("name", sorted(STUBS))
def test_the_stated_constructor_matches_the_generated_one(name):
    cls = getattr(moves, name)
    stub = STUBS[name]
    assert not stub.args.kwonlyargs and not stub.args.vararg and not stub.args.kwarg
    params = stub.args.args[1:]  # without self
    fields = [f for f in dataclasses.fields(cls) if f.init]
    assert [p.arg for p in params] == [f.name for f in fields]
    assert list(inspect.signature(cls).parameters) == [f.name for f in fields]
    # defaults: the last len(defaults) parameters, as in the generated __init__
    defaults = stub.args.defaults
    assert len(defaults) == sum(f.default is not dataclasses.MISSING for f in fields)
    for p, default in zip(params[len(params) - len(defaults):], defaults):
        field = next(f for f in fields if f.name == p.arg)
        assert eval(ast.unparse(default), vars(moves)) == field.default, p.arg
    for p, f in zip(params, fields):
        assert ast.unparse(p.annotation) == _widened(str(f.type)), p.arg


def test_the_words_are_parsed_into_the_enums_the_fields_are_typed_as():
    m = moves.CircleMove((0, 0, 0), 10, plane="xz", frame="trf", profile="TRAP", tracking="speed")
    assert (m.plane, m.frame, m.profile, m.tracking) == (
        moves.Plane.XZ, moves.Frame.TRF, moves.Profile.TRAP, moves.Tracking.SPEED)
    j = moves.CartJog("wrf", "rz-", 50, 1)
    assert (j.frame, j.axis) == (moves.Frame.WRF, moves.CartAxis.RZ_NEG)
