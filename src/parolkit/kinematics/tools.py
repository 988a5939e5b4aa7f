"""Tools: rigid transforms from the flange to the tool centre point (TCP).

Built-ins (:data:`TOOLS`):

* ``'default'``: the original commander's TCP (DH row 6: d = -62.8 mm, a = -45.25 mm), i.e.
  the point ``(-45.25, 0, 62.8) mm`` in the flange frame, no rotation.  Existing programs
  and poses were written against it; ``tool=None`` means this tool everywhere.
* ``'flange'``: the bare flange (identity).

User tools come from the config file (``[tools.NAME] pose = [x, y, z, A, B, C]``, the TCP pose
in the flange frame in mm/deg) and are looked up with :func:`get_tool` given the
:class:`parolkit.config.Config`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from parolkit.errors import ParolkitValueError
from parolkit.kinematics.model import TOOL_DEFAULT_T
from parolkit.kinematics.pose import as_matrix_array, as_pose_array, matrix_to_pose, pose_to_matrix

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    from parolkit.config import Config

__all__ = ["Tool", "TOOLS", "get_tool"]


@dataclass(frozen=True, eq=False)
class Tool:
    """A tool: ``name`` and ``matrix``, the 4x4 transform flange -> TCP in metres.

    The matrix is validated (proper rotation, last row ``[0, 0, 0, 1]``) and stored read-only.
    """

    name: str
    matrix: NDArray[np.float64]
    # plain-float caches for the scalar hot paths (derived, not part of the identity)
    _rot: tuple[float, ...] = field(init=False, repr=False)
    _t: tuple[float, float, float] = field(init=False, repr=False)
    _identity_rot: bool = field(init=False, repr=False)
    _native: tuple[float, ...] = field(init=False, repr=False)  # for the compiled IK kernel

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ParolkitValueError(f"Tool.name must be a non-empty string, got {self.name!r}")
        m = np.array(as_matrix_array(self.matrix, f"tool {self.name!r} matrix", allow_batch=False))
        m.setflags(write=False)
        object.__setattr__(self, "matrix", m)
        rot = tuple(float(v) for v in m[:3, :3].ravel())
        object.__setattr__(self, "_rot", rot)
        object.__setattr__(self, "_t", (float(m[0, 3]), float(m[1, 3]), float(m[2, 3])))
        object.__setattr__(self, "_identity_rot", bool(np.array_equal(m[:3, :3], np.eye(3))))
        object.__setattr__(self, "_native", (1.0 if self._identity_rot else 0.0, *rot, *self._t))

    @classmethod
    def from_pose(cls, name: str, pose: object) -> Tool:
        """A tool from the TCP pose in the flange frame, ``[x, y, z mm, A, B, C deg]``."""
        arr = as_pose_array(pose, f"tool {name!r} pose", allow_batch=False)
        return cls(name, pose_to_matrix(arr))

    @property
    def pose(self) -> NDArray[np.float64]:
        """The TCP pose in the flange frame, ``[x, y, z mm, A, B, C deg]``."""
        return matrix_to_pose(self.matrix)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Tool):
            return NotImplemented
        return self.name == other.name and np.array_equal(self.matrix, other.matrix)

    def __hash__(self) -> int:
        return hash((self.name, self.matrix.tobytes()))

    def __repr__(self) -> str:
        p = ", ".join(f"{v:g}" for v in self.pose)
        return f"Tool({self.name!r}, pose=[{p}])"


def _translation(t: tuple[float, float, float]) -> NDArray[np.float64]:
    m = np.eye(4)
    m[:3, 3] = t
    return m


DEFAULT_TOOL = Tool("default", _translation(TOOL_DEFAULT_T))
FLANGE = Tool("flange", np.eye(4))

#: Built-in tools by name.
TOOLS: dict[str, Tool] = {"default": DEFAULT_TOOL, "flange": FLANGE}


_USER_TOOLS: dict[tuple[str, tuple[float, ...]], Tool] = {}


def _user_tool(name: str, pose: tuple[float, ...]) -> Tool:
    key = (name, pose)
    tool = _USER_TOOLS.get(key)
    if tool is None:
        tool = Tool.from_pose(name, pose)
        if len(_USER_TOOLS) > 256:  # a config reloaded many times: do not grow without bound
            _USER_TOOLS.clear()
        _USER_TOOLS[key] = tool
    return tool


def get_tool(tool: str | Tool | None = None, config: Config | None = None) -> Tool:
    """Resolve a tool argument.

    ``None`` -> the default tool; a :class:`Tool` -> itself; a name -> a user tool from
    ``config.tools`` (``ToolSettings(name, pose)``; a user tool of the same name shadows a
    built-in) or a built-in (``'default'``, ``'flange'``).  Unknown names raise
    :class:`ParolkitValueError` listing the known ones.  User tools are cached by
    (name, pose), so resolving one per call is cheap.
    """
    if tool is None:
        return DEFAULT_TOOL
    if isinstance(tool, Tool):
        return tool
    if isinstance(tool, str):
        if config is not None:
            for settings in getattr(config, "tools", ()):
                if settings.name == tool:
                    return _user_tool(settings.name, tuple(settings.pose))
        found = TOOLS.get(tool)
        if found is not None:
            return found
        known = sorted(TOOLS) + sorted(s.name for s in getattr(config, "tools", ()) or ())
        raise ParolkitValueError(f"unknown tool {tool!r} (known: {', '.join(known)})")
    raise ParolkitValueError(f"tool must be a name, a Tool or None, got {type(tool).__name__}")

