"""The commander's view of the collision world: what the controller checks motion against,
which parts of the live arm are within a margin now, and where a checked program collides.

* :class:`CollisionWatch` (one per commander process) follows the controller through the
  link: whenever the status's ``collision.seq`` or tool changes (an ATTACH, a DETACH, a tool
  change, a restarted controller) it asks ``GET_ZONES`` (the client's ``zones()``) and
  compiles the world's :class:`parolkit.collision.Scene` off the event loop.  At every status
  whose joints changed it checks the arm's pose (:func:`bodies_within_margin`: ~4 us when
  clear) and keeps the set of bodies within a margin, which every page's 3D view draws red.
  An older controller (no ``collision`` in its status, no answer to ``GET_ZONES``): the
  default table, said once in the log.
* :func:`path_preview`: a dry run's planned moves as the TCP path to draw, each move with its
  program line and the samples where it collides (within a margin), so the preview draws them
  red.

No NiceGUI here: tested without a browser (tests/unit/test_gui_collision.py).
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from parolkit.client.core import ZoneInfo, ZonesInfo
from parolkit.client.errors import RobotError
from parolkit.errors import ParolkitError
from parolkit.gui.link import joints_known

if TYPE_CHECKING:
    from parolkit.client.core import RobotStatus
    from parolkit.collision import Scene, ToolShape, Zone
    from parolkit.gui.link import ControllerLink
    from parolkit.script.dryrun import DryRunReport
    from parolkit.script.interpreter import CollisionSetup

__all__ = ["CollisionWatch", "bodies_within_margin", "PreviewSegment", "PathPreview", "path_preview",
           "DEFAULT_WORLD", "RETRY_S", "MAX_PREVIEW_POINTS"]

log = logging.getLogger(__name__)

#: a GET_ZONES that failed on a controller that has a collision world is asked again after this, s
RETRY_S = 0.5
#: most points the path preview draws (the samples are thinned, keeping every colliding one)
MAX_PREVIEW_POINTS = 300

#: what the commander shows and checks when the controller does not say (an older controller):
#: the default table (the plane under the base, as the config's default)
DEFAULT_WORLD = ZonesInfo(seq=-1, ready=True, tool="default", tool_shape=None, held=(),
                          zones=(ZoneInfo("table", "plane", 0.0, point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)),))


def bodies_within_margin(scene: Scene, q_rad: Sequence[float]) -> frozenset[str]:
    """The names of the bodies (and zones) of every pair within its margin at ``q_rad`` (6
    joint angles, rad): ``{"J5 link", "zone 'post'"}``, ``{"base", "J6 link"}``; empty when the
    pose is clear.  One kernel check (~4 us) when clear, every pair's clearance otherwise."""
    if scene.check(q_rad).clear:
        return frozenset()
    d, _, _ = scene.distances(q_rad)
    names: set[str] = set()
    for pair, dist, margin in zip(scene.pairs, d.tolist(), scene.kernel_margins_mm):
        if dist <= margin:
            names.add(pair.a)
            names.add(pair.b)
    return frozenset(names)


def _build_scene(setup: CollisionSetup) -> Scene:
    from parolkit.collision import Scene

    return Scene(zones=setup.zones, tool=setup.tool_shape, held=setup.held)


def _default_setup() -> CollisionSetup:
    from parolkit.script.interpreter import collision_setup

    return collision_setup(DEFAULT_WORLD)


class CollisionWatch:
    """The controller's collision world and the live arm's bodies within a margin.

    ``info``: the world as ``GET_ZONES`` gave it (:data:`DEFAULT_WORLD` when the controller
    does not say; None until known); ``version`` changes whenever it does (the 3D view redraws
    the zones, the tool's shape and the held objects then); ``within``: the bodies within a
    margin at the newest joints (the view draws them red); ``unavailable``: why the world is
    the default one (None while the controller answers).  ``check_count`` and
    ``check_seconds``: the margin checks made and their CPU time (s), for the docs' figure.
    """

    def __init__(self, link: ControllerLink) -> None:
        self.link = link
        self.info: ZonesInfo | None = None
        self.setup: CollisionSetup | None = None
        self.scene: Scene | None = None
        self.version = 0
        self.within: frozenset[str] = frozenset()
        self.unavailable: str | None = None
        self.check_count = 0
        self.check_seconds = 0.0
        #: the world the newest status names (restarts seen, its collision.seq, its tool) and
        #: the one fetched
        self._want: tuple[int, int | None, str] | None = None
        self._have: tuple[int, int | None, str] | None = None
        self._epoch = 0
        self._last_time = -math.inf
        self._q: tuple[float, ...] | None = None
        self._task: asyncio.Task[None] | None = None
        self._said_unavailable = False
        link.add_listener(self.on_status)

    # ---- following the controller ----

    def on_status(self, st: RobotStatus) -> None:
        """Link listener (the event loop): fetch the world when the status names another one;
        check the pose when the joints changed."""
        if st.time < self._last_time - 1e-6:
            self._epoch += 1  # a restarted controller counts its worlds from 0 again
        self._last_time = st.time
        coll = st.raw.get("collision")
        seq = coll.get("seq") if isinstance(coll, dict) else None
        self._want = (self._epoch, seq if isinstance(seq, int) else None, st.tool)
        if self._want != self._have and (self._task is None or self._task.done()):
            self._task = asyncio.ensure_future(self._follow())
        if st.angles != self._q and joints_known(st):  # (homing: counts from the limit switches)
            self._q = st.angles
            self._check()

    def _check(self) -> None:
        scene, q = self.scene, self._q
        if scene is None or q is None:
            return
        t0 = time.process_time()
        self.within = bodies_within_margin(scene, [math.radians(a) for a in q])
        self.check_seconds += time.process_time() - t0
        self.check_count += 1

    async def _follow(self) -> None:
        """Fetch worlds until the one fetched is the one the newest status names."""
        while self._want is not None and self._want != self._have:
            want = self._want
            try:
                info = await self.link.robot.zones()
            except RobotError as exc:
                if want[1] is not None:  # its status has a collision world: a passing failure, ask again
                    log.debug("GET_ZONES failed: %s", exc)
                    await asyncio.sleep(RETRY_S)
                    continue
                await self._fall_back(f"the controller does not answer GET_ZONES ({exc}): an older controller?")
                self._have = want
                continue
            try:
                setup = await asyncio.to_thread(_setup_of, info)
                scene = await asyncio.to_thread(_build_scene, setup)
            except (ParolkitError, ValueError) as exc:
                await self._fall_back(f"the controller's collision world cannot be read here ({exc})")
                self._have = want
                continue
            self.info, self.setup, self.scene = info, setup, scene
            self.unavailable = None
            self._said_unavailable = False
            self._have = want
            self.version += 1
            self._check()

    async def _fall_back(self, why: str) -> None:
        setup = await asyncio.to_thread(_default_setup)
        self.scene = await asyncio.to_thread(_build_scene, setup)
        self.info, self.setup = DEFAULT_WORLD, setup
        self.unavailable = why
        self.version += 1
        self._check()
        if not self._said_unavailable:
            self._said_unavailable = True
            from parolkit.gui.eventlog import Level

            self.link.log.add(f"collision world: {why}; the 3D view and the program check use the default "
                              "table only", Level.WARNING)

    async def for_check(self) -> tuple[CollisionSetup | None, str | None]:
        """The world a program check uses: the controller's, asked now (``GET_ZONES``), or
        (None, why) when it does not answer (the dry run's default table then)."""
        try:
            info = await self.link.robot.zones()
            return await asyncio.to_thread(_setup_of, info), None
        except (RobotError, ParolkitError, ValueError) as exc:
            return None, f"the controller did not answer GET_ZONES ({exc})"

    async def close(self) -> None:
        self.link.remove_listener(self.on_status)
        task, self._task = self._task, None
        if task is not None and not task.done():
            task.cancel()
            try:
                await task
            except (asyncio.CancelledError, Exception):
                pass


def _setup_of(info: ZonesInfo) -> CollisionSetup:
    from parolkit.script.interpreter import collision_setup

    return collision_setup(info)


# ---- the path preview ----------------------------------------------------------------------


@dataclass(frozen=True)
class PreviewSegment:
    """One planned move of the preview: its program ``line``, the joint samples drawn (deg,
    thinned) and for each whether it collides (within a margin, or between it and the next
    sample drawn); ``collides``: the dry run refused the move for a collision."""

    line: int | None
    rows_deg: tuple[tuple[float, ...], ...]
    red: tuple[bool, ...]
    collides: bool


@dataclass(frozen=True)
class PathPreview:
    """The checked program's TCP path, move by move (:func:`path_preview`)."""

    segments: tuple[PreviewSegment, ...]

    @property
    def points(self) -> int:
        return sum(len(s.rows_deg) for s in self.segments)


_MOTION = ("MoveJoint", "MovePose", "MoveCart", "MoveCartRelTRF", "SpeedJoint")


def _segment_lines(report: DryRunReport) -> list[tuple[int | None, bool]]:
    """(line, refused for a collision) of each of the report's segments, in order: the dry run
    plans a segment for every motion row it did not refuse ("refused": could not be planned)."""
    by_line = {c.line: c for c in report.program.commands}
    out: list[tuple[int | None, bool]] = []
    for row in report.rows:
        cmd = by_line.get(row.line)
        if cmd is None or type(cmd).__name__ not in _MOTION or (row.failed and row.note == "refused"):
            continue
        out.append((row.line, row.failed))
    if len(out) != len(report.segments):  # not the dry run this was written for: no lines, no red
        return [(None, False)] * len(report.segments)
    return out


def _colliding_samples(scene: Scene, positions_deg: Any, rate_hz: float) -> list[bool]:
    """For each sample (deg), whether some pair is within its margin there; at least the sample
    where the swept check found the move's first violation."""
    import numpy as np

    from parolkit.collision import check_trajectory

    rad = np.radians(np.asarray(positions_deg, dtype=float))
    if not len(rad):
        return []
    d, _, _ = scene.distances_batch(rad)
    inside = np.asarray(d <= np.asarray(scene.kernel_margins_mm)[None, :]).any(axis=1)
    red: list[bool] = [bool(r) for r in np.atleast_1d(inside)]
    if not any(red):  # between samples only (a thin zone): the sample after the violation
        v = check_trajectory(positions_deg, rate_hz, scene)
        k = 0 if v.path.index is None else min(len(red) - 1, v.path.index + (1 if v.path.fraction > 0 else 0))
        red[k] = True
    return red


def path_preview(report: DryRunReport, zones: Iterable[Zone] | None = None, tool_shape: ToolShape | None = None,
                 max_points: int = MAX_PREVIEW_POINTS) -> PathPreview:
    """The dry run's planned moves as a path preview: each move's samples (thinned to about
    ``max_points`` in all, a drawn point red when any sample it stands for is), its program
    line, and, for a move the dry run refused for a collision, the samples within a margin of
    the same world (``zones``: None the default table; ``tool_shape``), the ones to draw red."""
    from parolkit.collision import Scene
    from parolkit.config import default_zones

    lines = _segment_lines(report)
    total = sum(len(traj) for _, traj in report.segments)
    step = max(1, -(-total // max(1, max_points)))  # rounded up: at most about max_points
    scene: Scene | None = None
    out = []
    for (line, collides), (_, traj) in zip(lines, report.segments):
        pos = traj.positions_deg()
        n = len(pos)
        if not n:
            continue
        red = [False] * n
        if collides:
            if scene is None:
                scene = Scene(zones=default_zones() if zones is None else zones, tool=tool_shape)
            red = _colliding_samples(scene, pos, traj.rate_hz)
        keep = list(range(0, n, step))
        if keep[-1] != n - 1:
            keep.append(n - 1)
        ends = keep[1:] + [n]
        out.append(PreviewSegment(
            line, tuple(tuple(float(v) for v in pos[i]) for i in keep),
            tuple(any(red[i:max(i + 1, e)]) for i, e in zip(keep, ends)), collides))
    return PathPreview(tuple(out))
