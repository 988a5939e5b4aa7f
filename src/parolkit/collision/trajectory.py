"""A planned move checked for collisions, and the one-line message every caller shows.

:func:`check_trajectory` is the one check the dry run (``parolkit check``, ``run --dry-run``,
the commander's program check) and the controller's plan admission use: a trajectory's
samples, joint angles in DEGREES at ``rate_hz`` (as :class:`parolkit.motion.Trajectory` holds
them), swept (every pose on the straight joint-space segments between the samples, so a thin
zone cannot be jumped over).  It is a pure function of its arguments: no I/O, no clock, no
state beyond the compiled scene the module-level queries cache.

:func:`collision_message` words a violation the same way everywhere::

    J5 link vs zone 'monitor' at 1.23 s into the move (2.1 mm inside its 10 mm margin)
    J2 link vs J6 link at 0.84 s into the move (in contact, 4.2 mm overlap)
    tool 'pen' vs zone 'table' at 0.50 s into the move (touching)

Times: a trajectory's samples are at ``1/rate_hz, 2/rate_hz, ...`` s after the move starts
(``Trajectory.t``); ``start_deg``, when given, is the pose at 0 s (checked too, with the
segment from it to the first sample).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from parolkit.collision import _reference as ref
from parolkit.collision.scene import PairDistance, PathStatus, PathVerdict, Scene, _scene
from parolkit.errors import ParolkitValueError
from parolkit.robot import as_joint_array

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    from parolkit.collision.model import CollisionModel, HeldObject
    from parolkit.collision.shapes import ToolShape, Zone
    from parolkit.config import ToolSettings

__all__ = ["TrajectoryVerdict", "check_trajectory", "collision_message"]

#: Depths (mm) below this are worded "touching" / "at its margin" rather than "0.0 mm ...".
_SHOWN_MM = 0.05


def _inside(d: float, margin: float) -> str:
    """How deep a clearance ``d`` (mm) lies inside a ``margin`` (mm): "12.0 mm overlap",
    "2.1 mm inside its 10 mm margin", "touching", "at its 10 mm margin"."""
    if d <= 0.0 or margin < _SHOWN_MM:
        return "touching" if -d < _SHOWN_MM else f"{-d:.1f} mm overlap"
    if margin - d < _SHOWN_MM:
        return f"at its {margin:g} mm margin"
    return f"{margin - d:.1f} mm inside its {margin:g} mm margin"


def collision_message(found: PairDistance, time_s: float | None = None, deepest: PairDistance | None = None,
                      deepest_time_s: float | None = None) -> str:
    """One line naming the pair, when, and how deep: ``"J5 link vs zone 'monitor' at 1.23 s
    into the move (2.1 mm inside its 10 mm margin)"``.

    ``found``: the pair within its margin and its clearance there (mm; NaN when the sweep
    could not prove the pose clear); ``time_s``: seconds into the move (None: a single pose,
    no time is written).  ``deepest`` / ``deepest_time_s``: the same pair where the move takes
    it deepest and when; shown when deeper than at ``found``::

        J5 link vs zone 'monitor' at 0.92 s into the move (enters its 10 mm margin; deepest 35.2 mm overlap at 1.40 s)
        base vs J6 link at 3.09 s into the move (comes into contact; deepest 12.0 mm overlap at 3.50 s)
    """
    when = "" if time_s is None else f" at {time_s:.2f} s into the move"
    d, margin = found.distance_mm, found.margin_mm
    if math.isnan(d):
        return f"{found.pair}{when} (not proven clear: the check gave up after its most evaluations)"
    if deepest is None or math.isnan(deepest.distance_mm) or not deepest.distance_mm < d - _SHOWN_MM:
        detail = _inside(d, margin)
        if d <= 0.0 and -d >= _SHOWN_MM:
            detail = "in contact, " + detail + (f"; margin {margin:g} mm" if margin >= _SHOWN_MM else "")
        return f"{found.pair}{when} ({detail})"
    if d <= 0.0 and -d >= _SHOWN_MM:
        entry = "in contact"
    elif margin >= _SHOWN_MM and d > 0.0:
        entry = f"enters its {margin:g} mm margin"
    else:
        entry = "comes into contact"
    dd = deepest.distance_mm
    depth = f"{-dd:.1f} mm overlap" if dd <= 0.0 else f"{margin - dd:.1f} mm inside it"
    at = "" if deepest_time_s is None else f" at {deepest_time_s:.2f} s"
    return f"{found.pair}{when} ({entry}; deepest {depth}{at})"


@dataclass(frozen=True)
class TrajectoryVerdict:
    """The outcome of :func:`check_trajectory`.

    ``path``: the :class:`PathVerdict` over the poses checked (``start_deg`` first when it was
    given, then the samples); ``time_s``: seconds into the move of the first pose found within
    a margin (None when clear); ``rate_hz``: the sample rate.
    """

    path: PathVerdict
    time_s: float | None
    rate_hz: float
    #: the same pair at the sample (from the violation on) where it is deepest, and when (s)
    deepest: PairDistance | None = None
    deepest_time_s: float | None = None

    @property
    def clear(self) -> bool:
        """No pose of the move (samples and between them) brings a pair within its margin."""
        return self.path.clear

    @property
    def status(self) -> PathStatus:
        return self.path.status

    @property
    def pair(self) -> PairDistance | None:
        """The pair within its margin and its clearance there (mm), None when clear."""
        return self.path.pair

    @property
    def message(self) -> str:
        """:func:`collision_message` of the violation ("" when clear)."""
        if self.path.pair is None:
            return ""
        return collision_message(self.path.pair, self.time_s, self.deepest, self.deepest_time_s)

    def __str__(self) -> str:
        return "clear" if self.clear else self.message


def _pair_clearances(scene: Scene, k: int, rad: NDArray[np.float64]) -> NDArray[np.float64]:
    """Clearance (mm) of pair ``k`` of ``scene`` at each configuration of ``rad`` ((N, 6),
    rad): the scene's packed array cut down to that one pair (layout:
    :mod:`parolkit.collision._reference`), so the kernel computes nothing else."""
    buf = scene.packed
    m, s, p = int(buf[1]), int(buf[2]), int(buf[3])
    if not 0 <= k < p:
        raise IndexError(f"pair {k} of a scene with {p} pairs")
    o = ref.HEADER + m * ref.BODY_W + s * ref.STATIC_W
    one = np.concatenate([buf[:o], buf[o + k * ref.PAIR_W:o + (k + 1) * ref.PAIR_W]])
    one[3] = 1.0
    rad = np.ascontiguousarray(rad, dtype=np.float64)
    n = rad.shape[0]
    if scene._kernel is not None:
        d = np.empty((n, 1))
        scene._kernel.distances(one, rad, d, np.empty((n, 1, 3)), np.empty((n, 1, 3)))
    else:
        d = ref.pair_distances(ref.unpack(one), rad)[0]
    out: NDArray[np.float64] = d[:, 0] * 1e3
    return out


def check_trajectory(positions_deg: object, rate_hz: float, scene: Scene | None = None, *,
                     start_deg: object = None, zones: Iterable[Zone] = (),
                     tool: ToolShape | ToolSettings | None = None, held: Sequence[HeldObject] | None = None,
                     model: CollisionModel | None = None, swept: bool = True) -> TrajectoryVerdict:
    """Check a planned move: ``positions_deg`` ((N, 6) joint angles, DEGREES, sample k at
    ``(k + 1) / rate_hz`` s into the move) and, when given, ``start_deg`` (6 values, deg, the
    pose at 0 s).  Swept (every pose between the samples too) unless ``swept`` is False.

    The setup is ``scene`` (a :class:`Scene` the caller keeps: the fast path) or, without one,
    ``zones``, ``tool`` (a :class:`ToolShape` or a config tool), ``held`` and ``model`` as for
    :func:`parolkit.collision.check_path` (a scene compiled and cached for the next call with
    equal arguments).  A 600-sample move takes ~0.2 ms with the compiled kernel.

    Returns a :class:`TrajectoryVerdict`: ``.clear``, ``.time_s``, ``.pair``, ``.message``.
    """
    if isinstance(rate_hz, bool) or not isinstance(rate_hz, (int, float)) or not 0.0 < rate_hz < math.inf:
        raise ParolkitValueError(f"rate_hz must be a positive number (Hz), got {rate_hz!r}")
    if scene is not None and (tuple(zones) or tool is not None or held is not None or model is not None):
        raise ParolkitValueError("check_trajectory: give a scene or zones/tool/held/model, not both "
                                 "(a scene already holds them)")
    qs = as_joint_array(positions_deg, "positions_deg")
    if qs.ndim == 1:
        qs = qs[None, :]
    first_s = 1.0  # the row the path's index 0 stands for, in samples after the start
    if start_deg is not None:
        qs = np.vstack([as_joint_array(start_deg, "start_deg", allow_batch=False)[None, :], qs])
        first_s = 0.0
    if scene is None:
        scene = _scene(zones, tool, held, model)
    if not len(qs):
        return TrajectoryVerdict(PathVerdict(PathStatus.CLEAR, None, 0.0, None, 0), None, float(rate_hz))
    rad = np.radians(qs)
    path = scene.check_path(rad, swept=swept)
    if path.index is None or path.pair is None:
        return TrajectoryVerdict(path, None, float(rate_hz))
    rate = float(rate_hz)
    time_s = (path.index + path.fraction + first_s) / rate
    # how deep the move takes that pair: its clearance at every sample from the violation on
    # (that pair alone: ~0.2 us a sample, paid only for a move that is refused)
    k = scene.pairs.index(path.pair.pair)
    first = path.index + (1 if path.fraction > 0.0 else 0)
    if first >= len(rad):
        return TrajectoryVerdict(path, time_s, rate)
    d = _pair_clearances(scene, k, rad[first:])
    j = int(np.argmin(d))
    deepest = PairDistance(path.pair.pair, float(d[j]))
    return TrajectoryVerdict(path, time_s, rate, deepest, (first + j + first_s) / rate)
