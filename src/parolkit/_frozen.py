"""A cheaper ``__init__`` for the frozen dataclasses built on every controller tick.

A frozen dataclass's generated ``__init__`` stores each field with ``object.__setattr__`` (its
own ``__setattr__`` refuses), one call per field: the value objects a tick builds (its input,
the activities' context, the guard's result, the snapshot's parts) spent more time there than
in the work they carry.  :func:`quick_init` gives such a class an ``__init__`` with the same
parameters, defaults and order that fills the instance's ``__dict__`` in one update.  The class
stays a frozen dataclass (assignment refused, ``replace``, equality, hashing as declared).
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

__all__ = ["quick_init"]

_T = TypeVar("_T")


class _Factory:
    """The default of a parameter whose field has a ``default_factory`` (as dataclasses do)."""

    def __repr__(self) -> str:
        return "<factory>"


_FACTORY = _Factory()


def quick_init(cls: type[_T]) -> type[_T]:
    """Class decorator, applied above ``@dataclass(frozen=True)``: the same ``__init__``
    signature, the fields stored with one ``__dict__`` update.  Refuses a class it cannot
    reproduce exactly: not a frozen dataclass, with ``__slots__`` (no ``__dict__``), a
    ``__post_init__``, or a field left out of ``__init__``."""
    params = getattr(cls, "__dataclass_params__", None)
    if params is None or not params.frozen:
        raise TypeError(f"quick_init: {cls.__name__} is not a frozen dataclass")
    if "__slots__" in cls.__dict__:
        raise TypeError(f"quick_init: {cls.__name__} has __slots__ (no __dict__ to fill)")
    if hasattr(cls, "__post_init__"):
        raise TypeError(f"quick_init: {cls.__name__} has a __post_init__")
    fields = dataclasses.fields(cls)  # type: ignore[arg-type]
    if any(not f.init for f in fields):
        raise TypeError(f"quick_init: {cls.__name__} has a field left out of __init__")
    env: dict[str, Any] = {"_FACTORY": _FACTORY}
    positional: list[str] = []
    keyword: list[str] = []
    body: list[str] = []
    for f in fields:
        if f.default is not dataclasses.MISSING:
            env[f"_d_{f.name}"] = f.default
            param = f"{f.name}=_d_{f.name}"
        elif f.default_factory is not dataclasses.MISSING:
            env[f"_f_{f.name}"] = f.default_factory
            param = f"{f.name}=_FACTORY"
            body.append(f"    if {f.name} is _FACTORY:\n        {f.name} = _f_{f.name}()\n")
        else:
            param = f.name
        (keyword if f.kw_only else positional).append(param)
    signature = ", ".join(["self", *positional, *(["*", *keyword] if keyword else [])])
    store = ", ".join(f"{f.name}={f.name}" for f in fields)
    source = f"def __init__({signature}) -> None:\n{''.join(body)}    self.__dict__.update({store})\n"
    exec(source, env)  # (as dataclasses builds its own __init__)
    init = env["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__module__ = cls.__module__
    init.__doc__ = cls.__init__.__doc__
    cls.__init__ = init  # type: ignore[method-assign]
    return cls
