"""The arm's collision model, keep-out zones and fast checks.

Units: joint vectors in radians (``q``: 6 values; ``qs``: an (N, 6) array); distances, sizes
and margins in millimetres; angles of zones and poses in degrees; everything in the base frame
(origin on the surface the arm stands on, z up) unless a docstring says the flange frame.

::

    from parolkit.collision import check, check_path, BoxZone, TABLE_ZONE

    monitor = BoxZone("monitor", center=(300, -250, 200), size=(400, 60, 300), margin=10)
    v = check(q, zones=(TABLE_ZONE, monitor))      # q: 6 joint angles, rad
    v.clear, v.worst                                # False, J5 link vs zone 'monitor': 3.2 mm (margin 10 mm)
    check_path(qs, zones=config.zones).index        # the first sample (or the segment) that is not clear

* :class:`CollisionModel`: the base, six link capsules (lengths from ``parolkit.robot``'s DH
  table, placed by parolkit's FK), the tool's shape (``[tools.NAME] shape``) and held objects
  (:meth:`CollisionModel.attach` / :meth:`CollisionModel.detach`); :meth:`CollisionModel.pair_table`
  lists the self-collision pairs checked and why the others are not (computed by sampling).
* Zones: :class:`BoxZone`, :class:`PlaneZone`, :class:`CylinderZone` (``[[zones]]`` in the
  config; :data:`TABLE_ZONE` is on by default).
* Queries: :func:`check` -> :class:`Verdict`; :func:`check_swept` and :func:`check_path` ->
  :class:`PathVerdict`; :class:`Scene` is the compiled form they use (keep one per setup).
* A planned move: :func:`check_trajectory` (samples in degrees at a rate, swept) ->
  :class:`TrajectoryVerdict` with the time into the move and :func:`collision_message`'s
  one line ("J5 link vs zone 'monitor' at 1.23 s into the move (2.1 mm inside its 10 mm
  margin)"), what the dry run and the controller's plan admission report.

docs/collision.md has the model's sizes, the pair list, the zone syntax, the sweep's guarantee
and the benchmark figures.
"""

from __future__ import annotations

import importlib

from parolkit.collision.shapes import (
    TABLE_ZONE,
    BoxZone,
    Capsule,
    CylinderZone,
    HeldShape,
    PlaneZone,
    Sphere,
    ToolShape,
    Zone,
)

#: (not ``typing.TYPE_CHECKING``: the config imports the zones on the controller's start-up path)
TYPE_CHECKING = False
if TYPE_CHECKING:  # the real names for type checkers; at run time __getattr__ loads them lazily
    from parolkit.collision.model import (
        PAIR_SAMPLE_SEED,
        PAIR_SAMPLES,
        ArmEnvelope,
        Body,
        BodyRole,
        CollisionModel,
        HeldObject,
        PairInfo,
        PairTable,
        default_model,
        held_object,
    )
    from parolkit.collision.scene import (
        Pair,
        PairDistance,
        PairKind,
        PathStatus,
        PathVerdict,
        Scene,
        Verdict,
        check,
        check_path,
        check_swept,
        kernel_name,
    )
    from parolkit.collision.trajectory import TrajectoryVerdict, check_trajectory, collision_message

__all__ = [
    "CollisionModel", "ArmEnvelope", "Body", "BodyRole", "HeldObject", "PairInfo", "PairTable", "default_model",
    "held_object", "PAIR_SAMPLES", "PAIR_SAMPLE_SEED",
    "Scene", "Verdict", "PathVerdict", "PathStatus", "Pair", "PairDistance", "PairKind",
    "check", "check_swept", "check_path", "kernel_name",
    "check_trajectory", "collision_message", "TrajectoryVerdict",
    "BoxZone", "PlaneZone", "CylinderZone", "Zone", "TABLE_ZONE", "ToolShape", "Capsule", "Sphere", "HeldShape",
]

#: name -> the module that defines it (loaded when first asked for: the zone types above are
#: all the config needs, and they cost no numpy)
_LAZY = {name: "parolkit.collision.model" for name in (
    "PAIR_SAMPLE_SEED", "PAIR_SAMPLES", "ArmEnvelope", "Body", "BodyRole", "CollisionModel", "HeldObject",
    "PairInfo", "PairTable", "default_model", "held_object")}
_LAZY.update({name: "parolkit.collision.scene" for name in (
    "Pair", "PairDistance", "PairKind", "PathStatus", "PathVerdict", "Scene", "Verdict", "check", "check_path",
    "check_swept", "kernel_name")})
_LAZY.update({name: "parolkit.collision.trajectory" for name in (
    "TrajectoryVerdict", "check_trajectory", "collision_message")})


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'parolkit.collision' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
