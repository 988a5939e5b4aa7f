"""quick_init: the same constructor as the frozen dataclass's own, with one __dict__ update."""

from __future__ import annotations

import dataclasses
import inspect
from dataclasses import FrozenInstanceError, dataclass, field

import pytest

from parolkit._frozen import quick_init


def _pair() -> tuple[type, type]:
    """The same frozen dataclass twice: as generated, and with quick_init."""
    marker: list[int] = [7]

    def make() -> type:
        @dataclass(frozen=True)
        class Value:
            a: int
            b: float = 1.5
            c: list[int] = field(default_factory=lambda: list(marker))
            d: tuple[int, ...] = ()
            e: str = field(default="e", kw_only=True)
            f: int = field(default=0, kw_only=True, compare=False)

        return Value

    return make(), quick_init(make())


def test_quick_init_has_the_dataclass_signature() -> None:
    plain, quick = _pair()
    ps = inspect.signature(plain.__init__).parameters
    qs = inspect.signature(quick.__init__).parameters
    assert [(p.name, p.kind) for p in ps.values()] == [(p.name, p.kind) for p in qs.values()]
    # the same defaults (a factory's parameter shows a placeholder in both)
    assert [p.default for p in ps.values() if p.name not in ("c",)] == \
        [p.default for p in qs.values() if p.name not in ("c",)]


@pytest.mark.parametrize(("args", "kwargs"), [
    ((1,), {}),
    ((1, 2.5, [3], (4,)), {"e": "x", "f": 9}),
    ((), {"a": 2, "d": (1, 2), "e": "y"}),
])
def test_quick_init_stores_what_the_dataclass_init_stores(args: tuple[object, ...], kwargs: dict[str, object]) -> None:
    plain, quick = _pair()
    p, q = plain(*args, **kwargs), quick(*args, **kwargs)
    assert vars(p) == vars(q)
    assert repr(p).split("(", 1)[1] == repr(q).split("(", 1)[1]


def test_a_default_factory_runs_for_each_instance() -> None:
    _, quick = _pair()
    x, y = quick(1), quick(1)
    assert x.c == [7] and x.c is not y.c


def test_the_class_stays_frozen_and_replace_goes_through_the_new_init() -> None:
    _, quick = _pair()
    v = quick(1, e="k")
    with pytest.raises(FrozenInstanceError):
        v.a = 2
    w = dataclasses.replace(v, a=5)
    assert (w.a, w.e, w.b) == (5, "k", 1.5)
    assert v == quick(1, e="k") and hash(v.d) == hash(())


def test_the_wrong_arguments_are_refused_as_by_the_dataclass() -> None:
    _, quick = _pair()
    with pytest.raises(TypeError):
        quick()  # a is required
    with pytest.raises(TypeError):
        quick(1, 2.0, [], (), "e")  # e is keyword-only
    with pytest.raises(TypeError):
        quick(1, z=3)


def test_classes_it_cannot_reproduce_are_refused() -> None:
    @dataclass
    class Mutable:
        a: int

    @dataclass(frozen=True, slots=True)
    class Slotted:
        a: int

    @dataclass(frozen=True)
    class Post:
        a: int

        def __post_init__(self) -> None:
            pass

    @dataclass(frozen=True)
    class Hidden:
        a: int
        b: int = field(default=0, init=False)

    for cls, what in ((Mutable, "not a frozen dataclass"), (Slotted, "__slots__"), (Post, "__post_init__"),
                      (Hidden, "left out of __init__")):
        with pytest.raises(TypeError, match=what):
            quick_init(cls)
