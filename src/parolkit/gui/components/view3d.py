"""The 3D view (NiceGUI scene): the arm drawn from the DH table, world and tool frames, and
during a move a translucent ghost at the target with the planned TCP path; the controller's
collision world (its keep-out zones, the tool's shape, the objects held at the flange:
:mod:`parolkit.gui.zone_shapes`), every part of the arm within a margin drawn red
(:class:`parolkit.gui.collision.CollisionWatch`), and the checked program's TCP path with the
part that collides in red.

Scene units: :data:`parolkit.gui.geometry.SCENE_SCALE` per metre.  The view fills its card's
width (the stylesheet sizes ``.pk-scene``; the scene resizes its renderer with the window).

For the browser tests the scene element names its objects: ``data-body-ids`` (the arm's
solids by the collision body they stand for), ``data-world-ids`` (the zones', the tool's
shape's and the held objects' primitives by owner and part), ``data-preview-id`` and
``data-preview-lines`` (the preview's point ranges by program line), ``data-tcp-axes-id`` and
``data-sim-ids`` (the simulation's ghost arm: its frame groups and its solids).

Simulate (the Program tab) plays the program's planned run on a ghost arm of its own, violet,
red while the line it plays collides (:attr:`ArmView.sim_source`, asked at every update).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from nicegui import ui

from parolkit.client.core import RobotState, RobotStatus
from parolkit.config import DEFAULT_VIEW_FPS
from parolkit.errors import ParolkitError
from parolkit.gui import geometry
from parolkit.gui.link import ControllerLink, joints_known
from parolkit.gui.zone_shapes import COLLISION_RED, Shape, held_shapes, tool_shapes, zone_shapes
from parolkit.robot import PAROL6

if TYPE_CHECKING:
    from nicegui.elements.scene.scene_object3d import Object3D

    from parolkit.gui.collision import CollisionWatch, PathPreview
    from parolkit.gui.simulate import SimFrame

__all__ = ["ArmView", "arm_frames", "SCENE_FPS", "IDLE_FPS", "IDLE_AFTER_S", "PREVIEW_RGB", "COLLIDES_RGB",
           "SIM_GHOST_COLOUR"]

#: frame rate of the view's updates, and of its drawing while something in it changes, Hz
#: (the default: ``gui.view_fps`` sets a commander's, :class:`ArmView`'s ``fps``)
SCENE_FPS = DEFAULT_VIEW_FPS
#: the drawing's frame rate once nothing in the view has changed for :data:`IDLE_AFTER_S`, Hz:
#: an idle page drawn at 30 frames/s cost 1.3 cores of Chromium under software WebGL
#: (SwiftShader: no GPU, as on many school PCs), at 2 frames/s next to nothing
IDLE_FPS = 2.0
#: seconds without a change before the drawing slows to :data:`IDLE_FPS`
IDLE_AFTER_S = 1.0
#: the path preview's points: the planned path, and where it collides (red)
PREVIEW_RGB = (0.980, 0.800, 0.082)  # #facc15
COLLIDES_RGB = (0.937, 0.267, 0.267)  # #ef4444
#: the simulation's ghost arm (Simulate in the Program tab) and its opacity
SIM_GHOST_COLOUR = "#c4b5fd"
SIM_GHOST_OPACITY = 0.4


def arm_frames(angles_deg: Any, tool: str = "default") -> Any:
    """The 8 drawing frames (base, 1..5, flange, TCP) from ``parolkit.kinematics.fk_frames``
    with the controller's current tool (the default TCP if the name is unknown here)."""
    from parolkit.kinematics import fk_frames

    try:
        return fk_frames(angles_deg, None if tool == "default" else tool)
    except (ParolkitError, KeyError, ValueError):
        return fk_frames(angles_deg, None)


class ArmView:
    """The 3D view card; :meth:`update` moves the arm to the newest status."""

    def __init__(self, link: ControllerLink, collision: CollisionWatch | None = None, *,
                 fps: float = SCENE_FPS) -> None:
        #: updates and drawing while something changes, Hz; the idle drawing is the lower of
        #: this and :data:`IDLE_FPS`
        self.fps = fps
        self.idle_fps = min(IDLE_FPS, fps)
        self.link = link
        self.collision = collision
        self._last_seq = -1
        self._last_pose: tuple[tuple[float, ...], str] | None = None
        self._last_plan_key: tuple[object, ...] | None = None
        self._last_plan_seq: tuple[int | None, bool] | None = None  # (plan seq, shown)
        #: the arm's solids by the collision body they stand for, with their own colour and opacity
        self._bodies: dict[str, list[tuple[Object3D, str, float]]] = {}
        #: the collision world's primitives by owner ("zone 'monitor'", "tool 'pen'", "held 'ball'")
        self._world: dict[str, list[tuple[Object3D, Shape]]] = {}
        self._world_version = -1
        self._red: frozenset[str] = frozenset()
        #: the simulation's frame to show (None: no simulation shown), asked at every update
        self.sim_source: Callable[[], SimFrame | None] | None = None
        self._sim_key: tuple[tuple[float, ...], bool, str] | None = None
        self._sim_solids: list[Object3D] = []
        with ui.card().classes("pk-card w-full p-2 gap-1").props('role=region aria-label="3D view"'):
            with ui.row().classes("w-full items-center"):
                ui.label("3D view").classes("pk-title")
                ui.space()
                self.fps_label = ui.label("").classes("text-xs pk-muted pk-mono")
            self.scene = ui.scene(width=684, height=430, grid=(20, 20), background_color="#0d1526") \
                .classes("pk-scene").props('data-testid=scene role=img aria-label="3D view of the arm"')
            self.scene.props["fps"] = fps  # (the scene's own argument is a whole number)
            with self.scene:
                self.scene.axes_helper(length=1.2)  # world frame
                self.groups = self._arm(opacity=1.0)
                self.ghost = self._arm(opacity=0.22, ghost=True)
                for g in self.ghost:
                    g.visible(False)
                # the simulation's ghost (Simulate): hidden until a simulation plays
                self.sim_ghost = self._arm(opacity=SIM_GHOST_OPACITY, ghost=True, colour=SIM_GHOST_COLOUR,
                                           solids=self._sim_solids)
                for g in self.sim_ghost:
                    g.visible(False)
                self.path = self.scene.point_cloud([], point_size=0.14).material("#22d3ee")
                # the checked program's TCP path (the dry run), shown before it runs; where it
                # collides in red (per-point colours)
                self.preview = self.scene.point_cloud([], [], point_size=0.1)
                # the keep-out zones (base frame) and what the flange carries (flange frame)
                self.zone_group = self.scene.group()
                with self.groups[6]:
                    self.attached_group = self.scene.group()
            # the page's scene objects by id, for the browser tests: the path preview and the
            # TCP axes gizmo (the tool frame's axes, moved with the TCP frame)
            self.scene.props(f"data-preview-id={self.preview.id} data-tcp-axes-id={self.tcp_axes.id}")
            self.scene.props["data-body-ids"] = json.dumps(
                {body: [o.id for o, _, _ in objs] for body, objs in self._bodies.items()})
            self.scene.props["data-world-ids"] = "{}"
            self.scene.props["data-preview-lines"] = "[]"
            self.scene.props["data-sim-ids"] = json.dumps(
                {"groups": [g.id for g in self.sim_ghost], "solids": [o.id for o in self._sim_solids]})
            self.scene.move_camera(x=4.6, y=-4.2, z=3.9, look_at_x=0, look_at_y=0.8, look_at_z=1.7, duration=0)
            for g, t in zip(self.groups, geometry.dh_frames(PAROL6.standby_deg)):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot)
        self._frames_t = time.monotonic()
        self._frames_n = 0
        # the drawing's rate (the scene's fps prop): fps from a change until IDLE_AFTER_S
        # after the last one, then idle_fps.  The scene's own loop only takes a new rate at its
        # next frame (up to 1 / idle_fps s on), so until then every change is drawn at once.
        self.draw_fps = fps
        self._changed_t = self._frames_t
        self._woken_t = self._frames_t

    def show_preview(self, preview: PathPreview | None, tool: str = "default") -> None:
        """Draw the checked program's TCP path (:func:`parolkit.gui.collision.path_preview`):
        yellow points, red where a move collides; None clears it.  The scene's
        ``data-preview-lines`` lists ``[line, first point, points, red points]`` per move."""
        pts: list[list[float]] = []
        colours: list[list[float]] = []
        lines: list[list[int | None]] = []
        for seg in preview.segments if preview is not None else ():
            first = len(pts)
            for q, red in zip(seg.rows_deg, seg.red):
                pts.append(geometry.frame_pose_for_scene(arm_frames(q, tool)[-1])[0])
                colours.append(list(COLLIDES_RGB if red else PREVIEW_RGB))
            lines.append([seg.line, first, len(pts) - first, sum(seg.red)])
        with self.scene._batch_calls():
            self.preview.set_points(pts, colours)
        self.scene.props["data-preview-lines"] = json.dumps(lines)
        self._changed()

    def _changed(self) -> None:
        """Something in the view changed (sent to the page just before): draw at
        :attr:`fps`, and draw this change now if the scene's loop may still be waiting out
        an idle frame."""
        now = time.monotonic()
        self._changed_t = now
        if self.draw_fps != self.fps:
            self._set_draw_fps(self.fps)
            self._woken_t = now
        if now - self._woken_t < 1.0 / self.idle_fps:
            # commander.js: one draw at the next animation frame (after the calls just sent)
            self.scene.client.run_javascript(f"window.pkSceneDraw && window.pkSceneDraw({self.scene.id})")

    def _set_draw_fps(self, fps: float) -> None:
        self.draw_fps = fps
        self.scene.props["fps"] = fps  # the scene's own loop reads it at each frame

    def _arm(self, *, opacity: float, ghost: bool = False, colour: str = "#a5f3fc",
             solids: list[Object3D] | None = None) -> list[Any]:
        """The arm's solids in one group per drawing frame; a ``ghost`` all in ``colour``
        (its solids appended to ``solids``)."""
        colours = {"base": "#475569", "joint": "#f97316", "link": "#cbd5e1", "tool": "#38bdf8"}
        if ghost:
            colours = {k: colour for k in colours}
        groups = [self.scene.group() for _ in range(geometry.N_FRAMES)]
        s = geometry.SCENE_SCALE
        for solid in geometry.arm_solids(PAROL6):
            with groups[solid.frame]:
                obj: Object3D
                if solid.shape == "cylinder":
                    obj = self.scene.cylinder(solid.radius * s, solid.radius * s, solid.length * s, 28)
                    obj.move(*(v * s for v in solid.center)).rotate_R(solid.rotation_y_to_axis())
                elif solid.shape == "sphere":
                    obj = self.scene.sphere(solid.radius * s).move(*(v * s for v in solid.start))
                else:
                    width, height, depth = (v * s for v in solid.size)
                    obj = self.scene.box(width, height, depth).move(*(v * s for v in solid.start))
                obj.material(colours[solid.role], opacity=opacity)
                if solids is not None:
                    solids.append(obj)
                if not ghost and solid.body:
                    self._bodies.setdefault(solid.body, []).append((obj, colours[solid.role], opacity))
        if not ghost:
            with groups[7]:
                self.tcp_axes = self.scene.axes_helper(length=0.6)  # tool frame
        return groups

    # ---- the collision world ----

    def _make(self, sh: Shape) -> Object3D:
        """One primitive of :mod:`parolkit.gui.zone_shapes` in the scene (inside the group
        entered by the caller)."""
        obj: Object3D
        if sh.kind == "box":
            w, h, d = (float(v) for v in sh.args)  # type: ignore[arg-type]
            obj = self.scene.box(w, h, d, wireframe=sh.wireframe)
        elif sh.kind == "cylinder":
            r, length = (float(v) for v in sh.args)  # type: ignore[arg-type]
            if sh.wireframe:  # an outline: 12 sides around the cylinder (a round one is all edge lines)
                r /= math.cos(math.pi / 12)
            obj = self.scene.cylinder(r, r, length, 12 if sh.wireframe else 32, wireframe=sh.wireframe)
        elif sh.kind == "sphere":
            obj = self.scene.sphere(float(sh.args[0]), 20, 12)  # type: ignore[arg-type]
        elif sh.kind == "line":
            a, b = sh.args
            obj = self.scene.line(list(a), list(b))  # type: ignore[arg-type]
        else:
            text, style = sh.args
            obj = self.scene.text(str(text), str(style))
        obj.move(*sh.position)
        if sh.rotation != ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
            obj.rotate_R([list(r) for r in sh.rotation])
        if sh.kind != "text":
            obj.material(sh.color, opacity=sh.opacity)
        return obj

    def _draw_world(self) -> bool:
        """Redraw the zones, the tool's shape and the held objects when the controller's world
        changed (an ATTACH, a DETACH, a tool change); False if it did not."""
        watch = self.collision
        if watch is None or watch.version == self._world_version:
            return False
        self._world_version = watch.version
        info = watch.info
        for group in (self.zone_group, self.attached_group):
            for child in list(group.children):
                child.delete()
        self._world = {}
        if info is not None:
            with self.zone_group:
                for zone in info.zones:
                    for sh in zone_shapes(zone):
                        self._world.setdefault(sh.owner, []).append((self._make(sh), sh))
            with self.attached_group:
                for sh in tool_shapes(info.tool, info.tool_shape) + held_shapes(info.held):
                    self._world.setdefault(sh.owner, []).append((self._make(sh), sh))
        ids: dict[str, dict[str, list[str]]] = {}
        for owner, objs in self._world.items():
            for obj, sh in objs:
                ids.setdefault(owner, {}).setdefault(sh.part, []).append(obj.id)
        self.scene.props["data-world-ids"] = json.dumps(ids)
        self._paint(self._red, force=True)
        return True

    def _paint(self, red: frozenset[str], *, force: bool = False) -> bool:
        """Draw the bodies in ``red`` (names of the collision check: "J5 link", "tool 'pen'",
        "held 'ball'", "zone 'post'") red and the others in their own colours; a zone in
        ``red`` gets its margin outline (or, without a margin, its body) red.  False if nothing
        changed."""
        if red == self._red and not force:
            return False
        old, self._red = self._red, red
        tool_red = any(n.startswith("tool ") for n in red)
        for body, objs in self._bodies.items():
            now = tool_red if body == "tool" else body in red
            was = any(n.startswith("tool ") for n in old) if body == "tool" else body in old
            if now != was or force:
                for obj, colour, opacity in objs:
                    obj.material(COLLISION_RED if now else colour, opacity=opacity)
        for owner, prims in self._world.items():
            now = owner in red
            if now == (owner in old) and not force:
                continue
            parts = {sh.part for _, sh in prims}
            mark = "margin" if owner.startswith("zone ") and "margin" in parts else "body"
            for obj, sh in prims:
                if sh.part == mark and sh.kind != "text":
                    obj.material(COLLISION_RED if now else sh.color,
                                 opacity=max(sh.opacity, 0.8) if now else sh.opacity)
        return True

    def update(self) -> None:
        """Move the arm (and the ghost / path) to the newest status; nothing when it is old.
        Redraw the collision world when it changed and colour what is within a margin.
        The drawing slows to :data:`IDLE_FPS` once nothing has changed for :data:`IDLE_AFTER_S`."""
        changed = self._move_arm()
        changed = self._move_sim() | changed
        if self.collision is not None:
            with self.scene._batch_calls():
                changed = self._draw_world() | changed
                changed = self._paint(self.collision.within) | changed
        if changed:
            self._changed()
        elif self.draw_fps != self.idle_fps and time.monotonic() - self._changed_t >= IDLE_AFTER_S:
            self._set_draw_fps(self.idle_fps)
            self.fps_label.set_text(f"idle · drawn {self.idle_fps:g} fps")

    def _move_sim(self) -> bool:
        """Put the simulation's ghost where :attr:`sim_source` says (red while its line
        collides), or hide it; False if nothing changed."""
        frame = self.sim_source() if self.sim_source is not None else None
        st = self.link.status
        tool = st.tool if st is not None else "default"
        key = None if frame is None else (tuple(round(a, 2) for a in frame.joints_deg), frame.collides, tool)
        if key == self._sim_key:
            return False
        old, self._sim_key = self._sim_key, key
        with self.scene._batch_calls():
            if frame is None:
                for g in self.sim_ghost:
                    g.visible(False)
                return True
            for g, t in zip(self.sim_ghost, arm_frames(frame.joints_deg, tool)):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot)
                if old is None:
                    g.visible(True)
            if old is None or old[1] != frame.collides:
                for obj in self._sim_solids:
                    obj.material(COLLISION_RED if frame.collides else SIM_GHOST_COLOUR, opacity=SIM_GHOST_OPACITY)
        return True

    def _move_arm(self) -> bool:
        """Send the newest status's arm (ghost, path) to the page; False if nothing changed."""
        st = self.link.status
        if st is None or st.seq == self._last_seq:
            return False
        self._last_seq = st.seq
        if not joints_known(st):  # homing: the board's counters count from its limit switches
            self.fps_label.set_text("homing · the arm is drawn as it was before")
            return False
        pose_key = (tuple(round(a, 3) for a in st.angles), st.tool)
        plan_key = (self.link.plan.seq if self.link.plan else None, st.state, st.plan_seq)
        if pose_key == self._last_pose and plan_key == self._last_plan_key:
            return False  # the arm stands still: nothing to send (an idle page costs next to nothing)
        self._last_pose, self._last_plan_key = pose_key, plan_key
        frames = arm_frames(st.angles, st.tool)
        with self.scene._batch_calls():  # one websocket message per update
            for g, t in zip(self.groups, frames):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot)
            self._update_plan(st)
        self._frames_n += 1
        now = time.monotonic()
        if now - self._frames_t >= 1.0:
            self.fps_label.set_text(f"{self._frames_n / (now - self._frames_t):.0f} fps · seq {st.seq}")
            self._frames_t, self._frames_n = now, 0
        return True

    def _update_plan(self, st: RobotStatus) -> None:
        plan = self.link.plan
        # the ghost and path show while the robot is in motion (state MOVING or HOMING)
        moving = st.state in (RobotState.MOVING, RobotState.HOMING)
        shown = plan if plan is not None and moving and plan.seq == st.plan_seq else None
        show = shown is not None
        key = (plan.seq if plan else None, show)
        if key == self._last_plan_seq:
            return
        self._last_plan_seq = key
        s = geometry.SCENE_SCALE / 1000.0
        if shown is not None and shown.target_angles:
            for g, t in zip(self.ghost, arm_frames(shown.target_angles, st.tool)):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot).visible(True)
        else:
            for g in self.ghost:
                g.visible(False)
        pts = [[p[0] * s, p[1] * s, p[2] * s] for p in shown.tcp_path] if shown is not None else []
        self.path.set_points(pts)
