"""The 3D view (NiceGUI scene): the arm drawn from the DH table, world and tool frames, and
during a move a translucent ghost at the target with the planned TCP path.

Scene units: :data:`parolkit.gui.geometry.SCENE_SCALE` per metre.  The view fills its card's
width (the stylesheet sizes ``.pk-scene``; the scene resizes its renderer with the window).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from nicegui import ui

from parolkit.client.core import RobotState, RobotStatus
from parolkit.errors import ParolkitError
from parolkit.gui import geometry
from parolkit.gui.link import ControllerLink
from parolkit.robot import PAROL6

if TYPE_CHECKING:
    from nicegui.elements.scene.scene_object3d import Object3D

__all__ = ["ArmView", "arm_frames", "SCENE_FPS", "IDLE_FPS", "IDLE_AFTER_S"]

#: frame rate of the view's updates, and of its drawing while something in it changes, Hz
SCENE_FPS = 30.0
#: the drawing's frame rate once nothing in the view has changed for :data:`IDLE_AFTER_S`, Hz:
#: an idle page drawn at 30 frames/s cost 1.3 cores of Chromium under software WebGL
#: (SwiftShader: no GPU, as on many school PCs), at 2 frames/s next to nothing
IDLE_FPS = 2.0
#: seconds without a change before the drawing slows to :data:`IDLE_FPS`
IDLE_AFTER_S = 1.0


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

    def __init__(self, link: ControllerLink) -> None:
        self.link = link
        self._last_seq = -1
        self._last_pose: tuple[tuple[float, ...], str] | None = None
        self._last_plan_key: tuple[object, ...] | None = None
        self._last_plan_seq: tuple[int | None, bool] | None = None  # (plan seq, shown)
        with ui.card().classes("pk-card w-full p-2 gap-1").props('role=region aria-label="3D view"'):
            with ui.row().classes("w-full items-center"):
                ui.label("3D view").classes("pk-title")
                ui.space()
                self.fps_label = ui.label("").classes("text-xs pk-muted pk-mono")
            self.scene = ui.scene(width=684, height=430, grid=(20, 20), background_color="#0d1526", fps=30) \
                .classes("pk-scene").props('data-testid=scene role=img aria-label="3D view of the arm"')
            with self.scene:
                self.scene.axes_helper(length=1.2)  # world frame
                self.groups = self._arm(opacity=1.0)
                self.ghost = self._arm(opacity=0.22, ghost=True)
                for g in self.ghost:
                    g.visible(False)
                self.path = self.scene.point_cloud([], point_size=0.14).material("#22d3ee")
                # the checked program's TCP path (the dry run), shown before it runs
                self.preview = self.scene.point_cloud([], point_size=0.1).material("#facc15")
            # the page's scene objects by id, for the browser tests: the path preview and the
            # TCP axes gizmo (the tool frame's axes, moved with the TCP frame)
            self.scene.props(f"data-preview-id={self.preview.id} data-tcp-axes-id={self.tcp_axes.id}")
            self.scene.move_camera(x=4.6, y=-4.2, z=3.9, look_at_x=0, look_at_y=0.8, look_at_z=1.7, duration=0)
            for g, t in zip(self.groups, geometry.dh_frames(PAROL6.standby_deg)):
                pos, rot = geometry.frame_pose_for_scene(t)
                g.move(*pos).rotate_R(rot)
        self._frames_t = time.monotonic()
        self._frames_n = 0
        # the drawing's rate (the scene's fps prop): SCENE_FPS from a change until IDLE_AFTER_S
        # after the last one, then IDLE_FPS.  The scene's own loop only takes a new rate at its
        # next frame (up to 1 / IDLE_FPS s on), so until then every change is drawn at once.
        self.draw_fps = SCENE_FPS
        self._changed_t = self._frames_t
        self._woken_t = self._frames_t

    def show_preview(self, joint_samples_deg: Any, tool: str = "default") -> None:
        """Draw the TCP path of planned joint samples (deg, one row per sample; at most 300
        drawn); an empty list clears it."""
        rows = list(joint_samples_deg)
        step = max(1, len(rows) // 300)
        pts = [geometry.frame_pose_for_scene(arm_frames(q, tool)[-1])[0] for q in rows[::step]]
        self.preview.set_points(pts)
        self._changed()

    def _changed(self) -> None:
        """Something in the view changed (sent to the page just before): draw at
        :data:`SCENE_FPS`, and draw this change now if the scene's loop may still be waiting out
        an idle frame."""
        now = time.monotonic()
        self._changed_t = now
        if self.draw_fps != SCENE_FPS:
            self._set_draw_fps(SCENE_FPS)
            self._woken_t = now
        if now - self._woken_t < 1.0 / IDLE_FPS:
            # commander.js: one draw at the next animation frame (after the calls just sent)
            self.scene.client.run_javascript(f"window.pkSceneDraw && window.pkSceneDraw({self.scene.id})")

    def _set_draw_fps(self, fps: float) -> None:
        self.draw_fps = fps
        self.scene.props["fps"] = fps  # the scene's own loop reads it at each frame

    def _arm(self, *, opacity: float, ghost: bool = False) -> list[Any]:
        colours = {"base": "#475569", "joint": "#f97316", "link": "#cbd5e1", "tool": "#38bdf8"}
        if ghost:
            colours = {k: "#a5f3fc" for k in colours}
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
        if not ghost:
            with groups[7]:
                self.tcp_axes = self.scene.axes_helper(length=0.6)  # tool frame
        return groups

    def update(self) -> None:
        """Move the arm (and the ghost / path) to the newest status; nothing when it is old.
        The drawing slows to :data:`IDLE_FPS` once nothing has changed for :data:`IDLE_AFTER_S`."""
        if self._move_arm():
            self._changed()
        elif self.draw_fps != IDLE_FPS and time.monotonic() - self._changed_t >= IDLE_AFTER_S:
            self._set_draw_fps(IDLE_FPS)
            self.fps_label.set_text(f"idle · drawn {IDLE_FPS:g} fps")

    def _move_arm(self) -> bool:
        """Send the newest status's arm (ghost, path) to the page; False if nothing changed."""
        st = self.link.status
        if st is None or st.seq == self._last_seq:
            return False
        self._last_seq = st.seq
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
