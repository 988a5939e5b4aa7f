"""The compiled collision kernel (``_ccollide``), or None when the numpy reference runs
(not built, or ``PAROLKIT_PURE_PYTHON=1``; see :mod:`parolkit._native`)."""

from __future__ import annotations

from typing import Any

from parolkit import _native

__all__ = ["ccollide", "kernel_name"]

ccollide: Any = _native.load("parolkit.collision._ccollide")


def kernel_name() -> str:
    """``"compiled"`` or why the numpy reference runs."""
    return _native.status().get("parolkit.collision._ccollide", "not loaded")
