"""Optional compiled kernels: find one, or say why the pure-Python reference runs instead.

parolkit's hot single-call paths (one IK solve, filling a joint move's sample arrays) have a
small C kernel next to their pure-Python reference.  The kernel is built when parolkit is
installed on a machine with a C compiler; without one the install still succeeds and the
Python reference runs (same results, slower).  ``PAROLKIT_PURE_PYTHON=1`` forces the
reference, e.g. to compare the two.
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

__all__ = ["load", "status"]

#: module name -> None (loaded) or the reason it is not used
_STATUS: dict[str, str | None] = {}


def load(module: str) -> ModuleType | None:
    """The compiled module ``module`` (e.g. ``"parolkit.kinematics._cik"``), or None when it is
    not built or ``PAROLKIT_PURE_PYTHON`` is set (the caller then runs its Python reference)."""
    if os.environ.get("PAROLKIT_PURE_PYTHON", "") not in ("", "0"):
        _STATUS[module] = "PAROLKIT_PURE_PYTHON is set"
        return None
    try:
        mod = importlib.import_module(module)
    except ImportError as exc:
        _STATUS[module] = f"not built ({exc})"
        return None
    _STATUS[module] = None
    return mod


def status() -> dict[str, str]:
    """For each kernel tried so far: ``"compiled"`` or why the Python reference runs."""
    return {name: "compiled" if why is None else f"pure Python: {why}" for name, why in _STATUS.items()}
