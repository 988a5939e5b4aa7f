"""The collision world the controller checks motion in, and the per-tick stop check.

The *world* (:class:`CollisionWorld`) is plain frozen data: the keep-out zones of the config,
the current tool's shape and the objects held at the flange (ATTACH / DETACH).  The core owns
it and changes it (SET_TOOL, and ATTACH / DETACH when the queue reaches them); it never builds
the compiled :class:`parolkit.collision.Scene` of a world itself (~80 ms the first time a shape
is seen: the self-pair table is sampled).  It asks (:class:`SceneRequest` in its tick output),
the driver runs :func:`build_scene` in its planner pool (or inline) and the answer comes back
in a later tick input (:class:`SceneResult`), as plans do.  Planned moves are checked whole by
the planner (:func:`check_plan`, with the same cached scenes), jogs and servo streams every
tick by the core (:func:`stop_check`).

The per-tick check (docs/collision.md, "Jogs and servo streams"): before a jog's or a servo
stream's frame goes out, where would the arm come to rest if a controlled stop began at the
next tick?  :class:`StopPlan` is that stop, joint positions tick by tick (steps):

* a jog (JOG, MULTIJOG, SPEEDJOINT, CARTJOG) stops on its own path (the joint line, or the
  Cartesian line's joint path), its path speed ramped down as fast as every joint's
  acceleration limit allows there (as STOP and PAUSE slow a planned move down);
* a servo stream stops each joint on its own at its acceleration limit.

The poses from where the last frame took the arm, through this frame's goal, along the stop
to its rest are checked swept (a few poses: ~5-15 us with the C kernel).  Clear: the frame goes
out and the stop is kept.  Not clear: the frame is not sent; the stop kept from the previous
tick (checked then: it begins now) is played instead, and the command ends FAILED naming the
pair.  A motion that begins within a margin (after an ATTACH, a tool change, a stop that
ended there) is checked with those pairs' margins lowered to where they are (never below the
clearance they had when first found inside): it may move out or along, never further in.

Units: joint positions in steps and steps/s as the frames carry them, angles in radians for
the kernel, distances in mm.  No I/O, threads or clocks (the core calls what is here from its
update).
"""

from __future__ import annotations

import functools
import math
from array import array
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from parolkit._frozen import quick_init
from parolkit.collision.shapes import ToolShape, Zone

if TYPE_CHECKING:  # pragma: no cover
    from parolkit.collision import Scene

__all__ = ["HeldItem", "CollisionWorld", "SceneRequest", "SceneResult", "MAX_HELD", "build_scene", "scene_for",
           "check_plan", "StopPlan", "StopVerdict", "stop_check", "path_stop", "joint_stop", "held_item",
           "CollisionView", "INSIDE_SLACK_MM"]

#: Most objects held at the flange at once (ATTACH refuses more).
MAX_HELD = 16
#: A motion that starts within a margin may come this much closer (mm) than where the pair was
#: when first found inside: the sweep's own tolerance and rounding, not a creep.
INSIDE_SLACK_MM = 0.05
#: The stop of a jog ramps its path speed down at this share of what each joint's acceleration
#: limit allows (the path's own acceleration and the ramp's steps take the rest).
_STOP_ACCEL_SHARE = 0.9
#: Poses checked along a stop that is not a straight joint line (its rest among them).
_STOP_POSES = 5


@quick_init
@dataclass(frozen=True)
class HeldItem:
    """An object held at the flange as ATTACH gave it: ``kind`` "sphere" or "capsule", the
    capsule's axis from ``start`` to ``end`` (mm, flange frame; a sphere's centre is both),
    ``radius`` mm."""

    name: str
    kind: str
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float

    def as_dict(self) -> dict[str, Any]:
        if self.kind == "sphere":
            return {"name": self.name, "kind": "sphere", "center": list(self.start), "radius": self.radius}
        return {"name": self.name, "kind": "capsule", "start": list(self.start), "end": list(self.end),
                "radius": self.radius}

    def describe(self) -> str:
        """``sphere, radius 25 mm, centre (0, 0, 170) mm`` / ``capsule, radius 8 mm, from (...) to (...) mm``."""
        def pt(p: Sequence[float]) -> str:
            return "(" + ", ".join(f"{v:g}" for v in p) + ")"

        if self.kind == "sphere":
            return f"sphere, radius {self.radius:g} mm, centre {pt(self.start)} mm"
        return f"capsule, radius {self.radius:g} mm, from {pt(self.start)} to {pt(self.end)} mm"


def held_item(command: Any) -> HeldItem:
    """The :class:`HeldItem` an ATTACH command (:class:`parolkit.protocol.commands.Attach`) describes."""
    return HeldItem(command.object_name, command.shape, tuple(command.start_mm), tuple(command.end_mm),
                    float(command.radius_mm))


@dataclass(frozen=True)
class CollisionWorld:
    """What motion is checked against: ``zones`` (base frame, the enabled ones), the tool's
    ``tool`` shape (None: no body) and the ``held`` objects, in the order attached.  Frozen and
    hashable: equal worlds share one compiled scene."""

    zones: tuple[Zone, ...] = ()
    tool: ToolShape | None = None
    held: tuple[HeldItem, ...] = ()

    def with_held(self, item: HeldItem) -> CollisionWorld:
        """``item`` held (one of the same name replaced, in its place)."""
        held = list(self.held)
        for i, h in enumerate(held):
            if h.name == item.name:
                held[i] = item
                break
        else:
            held.append(item)
        return CollisionWorld(self.zones, self.tool, tuple(held))

    def without(self, name: str | None) -> CollisionWorld:
        """``name`` (None: every held object) let go."""
        return CollisionWorld(self.zones, self.tool, tuple(h for h in self.held if name is not None and h.name != name))

    def with_tool(self, tool: ToolShape | None) -> CollisionWorld:
        return CollisionWorld(self.zones, tool, self.held)

    def as_dict(self, tool_name: str) -> dict[str, Any]:
        """GET_ZONES's ``zones``, ``tool`` and ``held`` (docs/protocol.md)."""
        t = self.tool
        shape = None if t is None else {"kind": "capsule", "start": list(t.start), "end": list(t.end),
                                         "radius": t.radius}
        return {"zones": [_zone_dict(z) for z in self.zones], "tool": {"name": tool_name, "shape": shape},
                "held": [h.as_dict() for h in self.held]}


def _zone_dict(z: Zone) -> dict[str, Any]:
    d: dict[str, Any] = {"name": z.name, "kind": z.kind}
    for key in {"box": ("center", "size", "rpy"), "plane": ("point", "normal"),
                "cylinder": ("center", "axis", "radius", "height")}[z.kind]:
        v = getattr(z, key)
        d[key] = list(v) if isinstance(v, tuple) else v
    d["margin"] = z.margin
    return d


@quick_init
@dataclass(frozen=True)
class CollisionView:
    """The collision part of a snapshot: the world in force, its number (``seq``: changes with
    the world), whether its scene is ready, and why motion waits for it (or None)."""

    world: CollisionWorld = field(default_factory=CollisionWorld)
    seq: int = 0
    ready: bool = False
    waiting: str | None = None
    self_margin: float = 0.0

    def status_dict(self) -> dict[str, Any]:
        return {"seq": self.seq, "ready": self.ready, "held": [h.name for h in self.world.held],
                "waiting": self.waiting}

    def zones_dict(self, tool_name: str) -> dict[str, Any]:
        out: dict[str, Any] = {"seq": self.seq, "ready": self.ready, "units": "mm, deg"}
        out.update(self.world.as_dict(tool_name))
        out["self_margin"] = self.self_margin
        return out


# ---------------------------------------------------------------------------- scenes


@quick_init
@dataclass(frozen=True)
class SceneRequest:
    """Build the scene of ``world`` (the core's tick output; the driver runs :func:`build_scene`)."""

    world: CollisionWorld


@quick_init
@dataclass(frozen=True)
class SceneResult:
    """The answer to a :class:`SceneRequest`: the ``scene`` of ``world``, or the ``error`` why
    none could be built; ``seconds`` it took (measured by whoever ran it)."""

    world: CollisionWorld
    scene: object | None = None
    error: str | None = None
    seconds: float = 0.0


@functools.lru_cache(maxsize=16)
def scene_for(world: CollisionWorld) -> Scene:
    """The compiled scene of ``world`` (the stock arm's model, the world's zones, tool and held
    objects), cached: equal worlds share one.  ~80 ms the first time a tool or held shape is
    seen (its pairs with the arm sampled), ~1 ms after that."""
    from parolkit.collision import Scene, held_object

    held = tuple(held_object(h.name, h.start, h.end, h.radius, h.kind) for h in world.held)
    return Scene(zones=world.zones, tool=world.tool, held=held)


def build_scene(req: SceneRequest) -> SceneResult:
    """Run ``req`` (the driver, off the tick); every error becomes the result's ``error``."""
    try:
        return SceneResult(req.world, scene_for(req.world))
    except Exception as exc:
        return SceneResult(req.world, None, f"the collision check could not be built: {exc}")


# ---------------------------------------------------------------------------- plan admission


def _inside_margins(scene: Scene, q_rad: Sequence[float], floors: Mapping[int, float] | None = None
                    ) -> dict[int, float]:
    """The pairs within their margin at ``q_rad`` -> the margin (mm) a motion from there is
    checked against for them: where they are (or ``floors``' clearance, where a pair was first
    found inside), less :data:`INSIDE_SLACK_MM`."""
    d, _, _ = scene.distances(q_rad)
    out: dict[int, float] = {}
    for k, (dk, m) in enumerate(zip(d.tolist(), scene.kernel_margins_mm)):
        if dk <= m:
            floor = dk if floors is None else floors.get(k, dk)
            out[k] = min(floor, dk) - INSIDE_SLACK_MM
    return out


def check_plan(world: CollisionWorld, positions_deg: object, rate_hz: float, start_deg: Sequence[float],
               speed_pct: float = 100.0) -> str | None:
    """A planned move's admission (the planner, off the tick): its samples (deg at
    ``rate_hz``) from ``start_deg``, swept, in ``world``.  None when clear; else the
    :func:`~parolkit.collision.collision_message` of the first pose within a margin, its times
    at the speed override ``speed_pct``.  A move that starts within a margin is checked with
    those pairs' margins lowered to where they are: it may leave, not go further in."""
    from parolkit.collision import check_trajectory, collision_message

    scene = scene_for(world)
    verdict = check_trajectory(positions_deg, rate_hz, scene, start_deg=start_deg)
    if verdict.clear:
        return None
    if verdict.path.index == 0 and verdict.path.fraction == 0.0:  # the start itself is inside
        relaxed = scene.with_margins(_inside_margins(scene, [math.radians(v) for v in start_deg]))
        verdict = check_trajectory(positions_deg, rate_hz, relaxed, start_deg=start_deg)
        if verdict.clear:
            return None
    if verdict.pair is None:
        return None
    scale = 100.0 / max(speed_pct, 1e-9)
    t = None if verdict.time_s is None else verdict.time_s * scale
    td = None if verdict.deepest_time_s is None else verdict.deepest_time_s * scale
    return collision_message(verdict.pair, t, verdict.deepest, td)


# ---------------------------------------------------------------------------- the per-tick stop


class StopPlan:
    """A controlled stop that begins at the next tick: one frame per tick, the last at rest.
    Only its parameters are kept: :meth:`poses` gives the few positions the check sweeps (every
    tick), :meth:`samples` the frames (steps, steps/s) when the stop is played."""

    #: the number of ticks it takes (its frames)
    ticks: int = 0
    #: its positions lie on one straight joint-space line (a joint jog's): its rest is enough
    straight: bool = False

    def position(self, i: int) -> list[float]:  # pragma: no cover - abstract
        """Where its frame ``i`` (0: the next tick's) puts the joints, steps."""
        raise NotImplementedError

    def speed(self, i: int) -> list[float]:  # pragma: no cover - abstract
        """Its frame ``i``'s feed-forward, steps/s."""
        raise NotImplementedError

    def poses(self) -> list[list[float]]:
        """The positions the check sweeps: its rest alone on a straight joint line, else at
        most :data:`_STOP_POSES` of them, evenly spread, its rest last."""
        n = self.ticks
        if self.straight:
            return [self.position(n - 1)]
        if n <= _STOP_POSES:
            return [self.position(i) for i in range(n)]
        return [self.position(min(n, int(round(n * (i + 1) / _STOP_POSES))) - 1) for i in range(_STOP_POSES)]

    def samples(self) -> tuple[list[list[int]], list[list[int]], list[int]]:
        """The stop as a trajectory's samples (``activities.Samples``): GO TO frames, the last
        at rest on whole steps."""
        n = self.ticks
        pos = [[int(round(x)) for x in self.position(i)] for i in range(n)]
        spd = [[int(round(v)) for v in self.speed(i)] for i in range(n - 1)] + [[0] * 6]
        return pos, spd, [156] * n


class _PathStop(StopPlan):
    """Along a trajectory's samples from sample coordinate ``s`` at path speed ``k``, slowing by
    ``per_tick`` a tick: tick ``i`` (0: the next) at path speed ``k - (i + 1) per_tick`` and
    sample coordinate ``s + (i + 1) k - per_tick (i + 1)(i + 2) / 2``, never past ``last``."""

    def __init__(self, positions: Sequence[Sequence[int]], speeds: Sequence[Sequence[int]], s: float, k: float,
                 per_tick: float, straight: bool) -> None:
        self._p, self._v = positions, speeds
        self._s, self._k, self._d = float(s), float(k), float(per_tick)
        self._last = len(positions) - 1.0
        self.straight = straight
        if k <= 0.0 or s >= self._last or not per_tick < math.inf:
            self.ticks, self._k, self._d, self._full = 1, 0.0, 0.0, 0
            return
        #: the ticks with a path speed above 0 (then it is at rest)
        self._full = int(math.floor(self._k / self._d + 1e-12))
        n = self._full + 1  # ticks until at rest
        # ... or until the path's end is reached, if sooner (the first tick at or past it)
        if self._coord(n - 1) >= self._last:
            lo, hi = 0, n - 1
            while lo < hi:
                mid = (lo + hi) // 2
                if self._coord(mid) >= self._last:
                    hi = mid
                else:
                    lo = mid + 1
            n = lo + 1
        self.ticks = n

    def _coord(self, i: int) -> float:
        m = min(i + 1, self._full)
        return min(self._last, self._s + m * self._k - self._d * m * (m + 1) / 2.0)

    def _at(self, rows: Sequence[Sequence[int]], x: float, scale: float) -> list[float]:
        j = int(x)
        f = x - j
        if f > 1e-9 and j + 1 < len(rows):
            a, b = rows[j], rows[j + 1]
            return [scale * (u + f * (w - u)) for u, w in zip(a, b)]
        return [scale * u for u in rows[j]]

    def position(self, i: int) -> list[float]:
        return self._at(self._p, self._coord(i), 1.0)

    def speed(self, i: int) -> list[float]:
        return self._at(self._v, self._coord(i), max(0.0, self._k - (i + 1) * self._d))


def path_stop(positions: Sequence[Sequence[int]], speeds: Sequence[Sequence[int]], s: float, k: float,
              accel: Sequence[float], rate_hz: float, *, straight: bool = False) -> StopPlan:
    """The stop of a path-following jog whose frame's target is at sample coordinate ``s`` and
    path speed ``k`` (the share of the plan's speed it runs at; the samples are one tick
    apart, at ``rate_hz``): from the next tick the path speed drops by ``kdot / rate_hz`` per
    tick, ``kdot`` (1/s) the largest every joint's acceleration limit (``accel``, steps/s^2, at
    :data:`_STOP_ACCEL_SHARE`) allows at the plan's speeds there (``speeds``, steps/s at full
    speed), and each tick moves ``k`` samples on: the joints keep to the path (a joint line
    stays a line) and stop within its last sample.  ``straight``: the samples lie on one
    straight joint-space line (a joint jog's), so the check needs its rest alone."""
    v = speeds[min(int(s), len(speeds) - 1)]
    kdot = math.inf
    for vj, aj in zip(v, accel):
        if abs(vj) >= 1.0:
            kdot = min(kdot, _STOP_ACCEL_SHARE * float(aj) / abs(vj))
    return _PathStop(positions, speeds, s, k, kdot / rate_hz, straight)


class _JointStop(StopPlan):
    """Each joint on its own at constant deceleration ``a`` from ``v``, frames ``dt`` apart."""

    def __init__(self, p: Sequence[float], v: Sequence[float], a: Sequence[float], dt: float) -> None:
        self._p0 = [float(x) for x in p]
        self._v0 = [float(x) for x in v]
        self._a = [float(x) if abs(vv) > 1e-9 else 0.0 for x, vv in zip(a, v)]
        self._dt = dt
        self._t = [abs(vv) / aa if aa > 0.0 else 0.0 for vv, aa in zip(self._v0, self._a)]
        self.ticks = max(1, int(math.ceil(max(self._t) / dt - 1e-9)))

    def position(self, i: int) -> list[float]:
        t = (i + 1) * self._dt
        out = []
        for p, v, a, tj in zip(self._p0, self._v0, self._a, self._t):
            u = min(t, tj)
            out.append(p + v * u - math.copysign(0.5 * a * u * u, v))
        return out

    def speed(self, i: int) -> list[float]:
        t = (i + 1) * self._dt
        return [v - math.copysign(a * min(t, tj), v) for v, a, tj in zip(self._v0, self._a, self._t)]


def joint_stop(positions: Sequence[float], speeds: Sequence[float], accel: Sequence[float],
               rate_hz: float) -> StopPlan:
    """The stop of a servo stream from ``positions`` (steps) at ``speeds`` (steps/s): from the
    next tick each joint slows down on its own at its acceleration limit (``accel``,
    steps/s^2) until at rest."""
    return _JointStop(positions, speeds, accel, 1.0 / rate_hz)


@dataclass(frozen=True)
class StopVerdict:
    """A motion frame the stop check refused: the pair (its index in the scene's pairs and its
    words), its clearance where the motion is now (mm) and its margin."""

    pair: str
    a: str
    b: str
    clearance_mm: float
    margin_mm: float

    def words(self) -> str:
        """``J5 link 12.0 mm from zone 'table' (margin 10 mm)``, or ``... touching ... (2.0 mm
        overlap)``."""
        d = self.clearance_mm
        where = f"{self.a} {d:.1f} mm from {self.b}" if d > 0.05 else (
            f"{self.a} touching {self.b}" + (f" ({-d:.1f} mm overlap)" if d < -0.05 else ""))
        return f"{where} (margin {self.margin_mm:g} mm)"


def stop_check(scene: Scene, origin_steps: Sequence[float], goal_steps: Sequence[float], stop: StopPlan,
               rad_per_step: Sequence[float], floors: dict[int, float]) -> StopVerdict | None:
    """Sweep the poses from ``origin_steps`` (where the last frame takes the arm), through
    ``goal_steps`` (this frame's goal) and along ``stop`` to its rest, in ``scene``.  None when
    clear.  A start within a margin is checked with those pairs' margins lowered to where they
    are (``floors``: the clearance each such pair had when first found inside, kept by the
    caller and updated here; cleared when the start is clear of every margin)."""
    rad = rad_per_step
    flat = array("d", [x * r for pose in (origin_steps, goal_steps, *stop.poses()) for x, r in zip(pose, rad)])
    status, index, frac, k, _ = scene.path_raw(flat)
    if status == 0:
        floors.clear()
        return None
    q0 = flat[:6].tolist()
    if index == 0 and frac == 0.0:
        # the start is inside a margin: the pairs there may not come any closer
        inside = _inside_margins(scene, q0, floors)
        for kk, m in inside.items():
            floors.setdefault(kk, m + INSIDE_SLACK_MM)
        for kk in [kk for kk in floors if kk not in inside]:
            del floors[kk]
        status, index, frac, k, _ = scene.with_margins(inside).path_raw(flat)
        if status == 0:
            return None
    else:
        floors.clear()
    pair = scene.pairs[k]
    d, _, _ = scene.distances(q0)
    return StopVerdict(str(pair), pair.a, pair.b, float(d[k]), pair.margin_mm)
