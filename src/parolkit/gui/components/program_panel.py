"""The Program tab (NiceGUI): the RBTscript editor with syntax colouring, Run / Pause / Step /
Stop with the executing line highlighted, Check (parse + dry run in the controller's collision
world: errors at their line, a collision with the pair and the time, the planned joint
positions and speeds, and the TCP path in the 3D view, red where it collides), Insert
(templates with the current joints / pose), Examples (the seed programs) and the programs folder's file row.

Errors (the parser's as you type, Check's, a run's) read as the program's name and line, one
plain sentence and the fix (:mod:`parolkit.gui.student_errors`); they clear when their cause is
gone (an edit, a new run).  The offer line under the status line says what to do next: "E-STOP
latched" (Run and Step greyed until Enable), "Resume from line N" / "Restart" after the E-stop
interrupted a run (:mod:`parolkit.gui.resume`), "Move to start" when the program is valid from
the home pose but not from where the arm is (held, as "Go to start pose": the same move).

Simulate plays the checked program on a ghost arm in the 3D view (:mod:`parolkit.gui.simulate`)
at 1x, 2x or 5x without sending anything to the controller: the line it plays highlighted, its
errors and collisions marked as Check marks them.  Run speed (10..100 %) is the speed a Run
runs the program at; "Go to start pose" moves the arm to the program's first pose while held.

Pause is the controller's PAUSE: the running move slows down on its own path and holds there,
and no new line starts; Run resumes it (RESUME) on the same path to the same target; Step
while paused lets the arm finish the line it paused in and run the next one, then pauses
between lines; Stop ends it all (STOP also ends the controller's pause).  See
:class:`~parolkit.gui.commander.ProgramRunner`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from nicegui import ui

from parolkit.errors import ParolkitError
from parolkit.gui.collision import PathPreview, path_preview
from parolkit.gui.commander import ACTIVE_STATES, Commander
from parolkit.gui.components.telemetry import plan_options
from parolkit.gui.editor_sync import EditorSync
from parolkit.gui.eventlog import Level
from parolkit.gui.highlight import line_decorations, mark_decorations
from parolkit.gui.programs_panel import ProgramsPanel
from parolkit.gui.resume import ResumePlan, resume_plan
from parolkit.gui.simulate import (
    RUN_SPEED_MAX_PCT,
    RUN_SPEED_MIN_PCT,
    SIM_SPEEDS,
    SimFrame,
    SimTimeline,
    Simulation,
    StartPose,
    start_pose,
)
from parolkit.gui.student_errors import explain, explain_all
from parolkit.gui.templates import SEED_EXAMPLES, TEMPLATES, render_template
from parolkit.robot import PAROL6

if TYPE_CHECKING:
    import parolkit.gui.simulate as gui_simulate
    from parolkit.script.dryrun import DryRunReport
    from parolkit.script.interpreter import CollisionSetup

__all__ = ["ProgramPanel", "DIAG_DELAY_S", "PAUSE_LABEL", "program_status"]

#: the parser's diagnostics are shown this long after the last keystroke, s
DIAG_DELAY_S = 0.4
#: the Pause button's name (aria-label and tooltip): what it does
PAUSE_LABEL = "Pause: the arm slows down on its path and holds"
#: what the run speed does, said under it
RUN_SPEED_NOTE = ("Run speed: Run sets the speed override to this for the program (its Speed() lines are "
                  "scaled by it) and sets the override back when the program ends.")
#: the hold-to-move button's name
START_POSE_LABEL = "Go to start pose: hold to move the arm to the program's first pose, release stops it"
MOVE_START_LABEL = "Move to start: hold to move the arm to the program's first pose, release stops it"


def program_status(state: str, line: int | None, held: bool, by_us: bool) -> str:
    """The status line of a running program: ``state`` the runner's ("running", "pausing",
    "paused"), ``line`` the executing line, ``held`` the controller reports itself paused,
    ``by_us`` our Pause or Step paused the program (not another client's PAUSE)."""
    at = f"line {line}" if line is not None else "line —"
    if state == "pausing":
        return f"⏸ pausing: the arm slows down on its path · {at}"
    if state == "paused" and held:
        who = "" if by_us else " (PAUSE from another client)"
        return f"⏸ paused on the path at {at}{who} · Run resumes"
    if state == "paused":
        return f"⏸ paused before {at} · Run resumes, Step runs one line"
    return f"▶ running · {at}"


def _tool(icon: str, label: str, testid: str, props: str, on_click: Any) -> ui.button:
    """An icon-only toolbar button named by ``label`` (aria-label and tooltip)."""
    b = ui.button(icon=icon, on_click=on_click).props(f'{props} aria-label="{label}" data-testid={testid}')
    b.tooltip(label)
    return b


class ProgramPanel:
    """Editor, runner controls, diagnostics and plan charts; :meth:`update` every 0.1 s."""

    def __init__(self, commander: Commander) -> None:
        self.c = commander
        self.link = commander.link
        self._prog_version: tuple[int, bool] | None = None
        self._revealed: int | None = None
        self._locked = False
        self._online: bool | None = None
        self._diag_at: float | None = None
        self._plan_shown = False
        #: draws the checked program's TCP path in the 3D view (None clears it; the tool)
        self.on_preview: Callable[[PathPreview | None, str], None] | None = None
        self._shown_errors: list[str] | None = None
        self._reveal_at: float | None = None
        self._errors: dict[int, str] = {}
        #: the text the last Check checked (its errors and preview stand until it changes)
        self._checked_text: str | None = None
        #: where the errors shown come from: "parse" (as you type), "check" (Check) or "run" (the
        #: last run: its check or the line that failed); "" when none is shown
        self._error_source = ""
        #: the run whose start cleared the last run's and Check's errors (a new interpreter: a new run)
        self._run_seen: object = None
        #: "Move to start": the program's start, when it is valid from the home pose and not from
        #: where the arm is (Check, or a run's check, found that)
        self._move_start: gui_simulate.StartPose | None = None
        #: the E-stop interrupted the run of this text, at (line, how to resume or why not)
        self._interrupt: tuple[int, str, ResumePlan | str] | None = None
        self._interrupt_key: tuple[int, str] | None = None
        self._offer_shown: tuple[object, ...] | None = None
        #: the live values completion fills in (joints, pose), as the page has them
        self._live_shown: tuple[str, str] | None = None
        #: Simulate: the last dry run, the simulation shown (None: none) and its playback speed
        self._report: DryRunReport | None = None
        self.simulation: Simulation | None = None
        self.sim_speed = SIM_SPEEDS[0]
        self._sim_shown: tuple[int | None, str] | None = None
        self._sim_enabled: bool | None = None
        #: the run speed of the next Run, % of the planned speed
        self.run_speed = RUN_SPEED_MAX_PCT
        #: "go to start pose": the program's start pose (or why it has none), for which text,
        #: when to work it out again, whether it is held, what the button and its note show
        self._start: StartPose | str = "the program has no move"
        self._start_text: str | None = None
        self._start_due: float | None = None
        self._start_held = False
        #: the hold's move was sent (and not yet released)
        self._start_moving = False
        self._start_shown: tuple[bool, str] | None = None
        with ui.row().classes("w-full items-center gap-2"):
            self._run_btn = _tool("play_arrow", "Run or resume the program", "prog-run", "unelevated color=positive",
                                  lambda: self.run_program(step=False))
            # the controller's PAUSE: the move in progress slows down on its path and holds
            _tool("pause", PAUSE_LABEL, "prog-pause", "unelevated color=warning", self.c.program.pause)
            self._step_btn = _tool("skip_next", "Step one line", "prog-step", "unelevated color=info",
                                   lambda: self.run_program(step=True))
            _tool("stop", "Stop the program", "prog-stop", "unelevated color=negative", self.stop_program)
            ui.button("Check", icon="rule", on_click=self.check_program) \
                .props("outline no-caps color=grey-4 data-testid=prog-check")
            ui.space()
            with ui.button("Record point", icon="add_location_alt") \
                    .props('outline no-caps color=grey-4 data-testid=prog-record '
                           'aria-label="Record point: the current pose at the cursor"'):
                with ui.menu():
                    ui.menu_item("as MoveJoint (the current joints)", on_click=lambda: self.record_point("MoveJoint")) \
                        .props("data-testid=record-movejoint")
                    ui.menu_item("as MoveCart (the current TCP pose)", on_click=lambda: self.record_point("MoveCart")) \
                        .props("data-testid=record-movecart")
            with ui.button("Insert", icon="add").props("outline no-caps color=grey-4 data-testid=prog-insert"):
                with ui.menu():
                    for t in TEMPLATES:
                        ui.menu_item(f"{t.name} — {t.description}", on_click=lambda t=t: self.insert_template(t.name))
            with ui.button("Examples", icon="library_books") \
                    .props("outline no-caps color=grey-4 data-testid=prog-examples"):
                with ui.menu():
                    for name, text in SEED_EXAMPLES.items():
                        ui.menu_item(name, on_click=lambda text=text: self.set_program(text))
        #: the page's editor and the shared document (every tab's edits merge: nothing typed is lost)
        self.sync = EditorSync(self.c.doc, self.c.log)
        self._build_simulate_row()
        self.files = ProgramsPanel(self.c.programs, self.c.log, self.c.doc, self.page_text, self._replace_refused)
        self.editor = ui.codemirror(self.c.doc.text, on_change=self.on_edit, theme="githubLight") \
            .classes("w-full pk-editor").props("data-testid=editor")  # commander.js names its text box
        self.prog_status = ui.label("").classes("text-sm pk-mono").props("data-testid=prog-status role=status")
        self._build_offers()
        self.diag_box = ui.column().classes("gap-0 w-full").props("data-testid=diagnostics")
        with ui.element("div").classes("pk-two"):
            self.plan_chart = ui.echart(plan_options("deg", "planned positions")).style("height: 200px") \
                .props('data-testid=plan-chart role=img aria-label="planned joint positions"')
            self.plan_speed_chart = ui.echart(plan_options("deg/s", "planned speeds")).style("height: 200px") \
                .props('data-testid=plan-speed-chart role=img aria-label="planned joint speeds"')
        self.on_edit()

    def _build_offers(self) -> None:
        """The offer line (hidden while it has nothing to say) and the live values completion
        fills in (hidden; commander.js reads its data-joints / data-pose)."""
        with ui.element("div").classes("pk-wrap items-center") as self.offer_row:
            self.offer_note = ui.label("").classes("text-sm").props("data-testid=offer-note role=status")
            # held, as "Go to start pose" (the same move, the same press and release): one way
            # to move the arm to the start, never a click that leaves it moving
            self._move_start_btn = ui.button("Move to start", icon="near_me").classes("pk-start-pose") \
                .props('unelevated no-caps color=primary data-testid=prog-move-start '
                       f'aria-label="{MOVE_START_LABEL}"')
            self._move_start_btn.tooltip(MOVE_START_LABEL)
            self._hold_to_start(self._move_start_btn)
            self._resume_btn = ui.button("Resume", icon="play_circle", on_click=self.resume_program) \
                .props("unelevated no-caps color=positive data-testid=prog-resume")
            self._restart_btn = ui.button("Restart", icon="replay", on_click=lambda: self.run_program(step=False)) \
                .props('outline no-caps color=grey-4 data-testid=prog-restart '
                       'aria-label="Restart: run the program from its first line"')
        self.offer_row.set_visibility(False)
        self._live = ui.element("div").props("data-testid=pk-live-values aria-hidden=true")
        self._live.set_visibility(False)

    def _build_simulate_row(self) -> None:
        """Simulate (with its speed and Stop), the run speed and "go to start pose"."""
        with ui.element("div").classes("pk-wrap items-center pk-sim-row"):
            self._sim_btn = ui.button("Simulate", icon="visibility", on_click=self.simulate) \
                .props('outline no-caps color=purple-3 data-testid=prog-simulate '
                       'aria-label="Simulate: play the program on a ghost arm; the robot does not move"')
            self._sim_btn.tooltip("Play the checked program on a ghost arm in the 3D view; the robot does not move")
            ui.toggle({s: f"{s:g}x" for s in SIM_SPEEDS}, value=self.sim_speed, on_change=self._on_sim_speed) \
                .props('dense no-caps data-testid=sim-speed aria-label="simulation speed"')
            self._sim_stop = ui.button("Stop simulation", icon="stop_circle", on_click=self.stop_simulation) \
                .props("outline no-caps color=grey-4 data-testid=sim-stop")
            self._sim_stop.set_enabled(False)
            self.sim_status = ui.label("").classes("text-xs pk-mono pk-sim-status") \
                .props("data-testid=sim-status role=status")
        with ui.element("div").classes("pk-wrap items-center"):
            with ui.column().classes("gap-0 pk-grow pk-run-speed"):
                ui.label().bind_text_from(self, "run_speed", lambda v: f"Run speed {v:.0f} %") \
                    .classes("text-xs pk-muted").props("data-testid=run-speed-value")
                ui.slider(min=RUN_SPEED_MIN_PCT, max=RUN_SPEED_MAX_PCT, step=5).bind_value(self, "run_speed") \
                    .props('data-testid=run-speed aria-label="run speed, percent of the planned speed"')
            self._start_btn = ui.button("Go to start pose", icon="pin_drop").classes("pk-start-pose") \
                .props("unelevated no-caps color=blue-grey-8 data-testid=prog-start-pose "
                       f'aria-label="{START_POSE_LABEL}"')
            self._start_btn.tooltip(START_POSE_LABEL)
            self._start_btn.set_enabled(False)
            self._hold_to_start(self._start_btn)
            self.start_note = ui.label("").classes("text-xs pk-muted").props("data-testid=start-pose-note")
        ui.label(RUN_SPEED_NOTE).classes("text-xs pk-muted").props("data-testid=run-speed-note")

    # ---- editing ----

    def set_program(self, text: str) -> None:
        """An example or a template replaces the shared program's text (one update, in every tab)."""
        refused = self._replace_refused()
        if refused is not None:
            self.c.log.error(refused)
            return
        self.c.doc.edit(text)

    def _replace_refused(self) -> str | None:
        """Why the program's text cannot be replaced now (None: it can)."""
        return "the editor is read-only while a program runs: stop it first" if self._program_active() else None

    def insert_template(self, name: str) -> None:
        st = self.link.status
        joints = st.angles if st else PAROL6.standby_deg
        pose = st.pose if st else (0.0,) * 6
        line = render_template(name, joints, pose)
        text = self.c.doc.text
        if text and not text.endswith("\n"):
            text += "\n"
        self.set_program(text + line + "\n")

    def record_point(self, kind: str) -> None:
        """Teach by jogging: insert the robot's current joints (``MoveJoint``) or TCP pose
        (``MoveCart``) as a new line after the cursor's line (commander.js ``pkInsertLine``)."""
        st = self.link.status
        if st is None or not self.link.link_up:
            self.c.log.error("record point: no status from the controller")
            return
        if self._program_active():
            self.c.log.error("record point: the editor is read-only while a program runs")
            return
        line = render_template(kind, st.angles, st.pose)
        ui.run_javascript(f"window.pkInsertLine && window.pkInsertLine({json.dumps(line)})")
        self.c.log.info(f"recorded {line}")

    def _program_active(self) -> bool:
        return self.c.program.active

    def on_edit(self, *_: Any) -> None:
        """Re-colour the text the page's editor shows (its edits reach the shared document
        through :class:`EditorSync`); old error marks go (their lines may have moved): Check again."""
        text = self.editor.value or ""
        if text == self._checked_text:
            # the text Check just checked, arriving from the page after it (the server's copy
            # lags behind the page): Check's errors, marks and preview stand; the parser's
            # diagnostics as you type would wipe a collision it found
            self._diag_at = None
            return
        self._checked_text = None
        if self._error_source in ("check", "run") or self.prog_status.text.startswith("✗"):
            self.prog_status.set_text("")  # it spoke of the text before this edit
        self._move_start = None
        self.stop_simulation()  # its lines are not this text's
        self._diag_at = time.monotonic() + DIAG_DELAY_S  # the parser's diagnostics once typing pauses
        self._clear_plan()
        self._refresh_decorations()

    def _clear_plan(self) -> None:
        """The planned charts belong to the program that was checked: an edit clears them."""
        if not self._plan_shown:
            return
        self._plan_shown = False
        if self.on_preview is not None:
            self.on_preview(None, "default")
        for chart in (self.plan_chart, self.plan_speed_chart):
            for series in chart.options["series"]:
                series["data"] = []
            chart.update()

    def _diagnose(self) -> None:
        """Parse the text with the real parser and show its errors (line:col) at their lines;
        none left clears the marks and the list."""
        from parolkit.script import parse

        result = parse(self.editor.value or "", "editor")
        self._show_errors(list(result.errors), "parse")

    def _refresh_decorations(self) -> None:
        text = self.editor.value or ""
        runner = self.c.program
        cur = runner.current_line if self._program_active() else None
        decos = mark_decorations(text) + line_decorations(text, current_line=cur, error_lines=self._errors)
        sim_line = self._sim_shown[0] if self._sim_shown is not None and cur is None else None
        if sim_line is not None and 1 <= sim_line <= text.count("\n") + 1:
            decos.append({"kind": "line", "line": sim_line, "class": "rbt-sim"})  # the simulated line
        self.editor.decorations = decos
        self.editor.line_tooltips = dict(self._errors)

    def _show_errors(self, errors: list[Any], source: str = "parse", name: str | None = None) -> None:
        """List ``errors`` under the editor and mark their lines, each as a student reads it: the
        program's name (``name``, default the shared program's) and line, one sentence and the
        fix (:func:`~parolkit.gui.student_errors.explain`; the line's tooltip: the sentence and
        the fix).  ``source``: "parse", "check" or "run", what clears them."""
        said = explain_all(errors, name or self.c.doc.name)
        self._error_source = source if said else ""
        shown = [e.text() for e in said]
        if shown == self._shown_errors:
            return  # the same list: nothing to send
        self._shown_errors = shown
        self._errors = {}
        self.diag_box.clear()
        with self.diag_box:
            for e in said:
                self._errors.setdefault(e.line, f"{e.sentence}: {e.fix}")
                ui.label(e.text()).classes("text-sm text-red-300").props("data-testid=diagnostic")
        self._refresh_decorations()

    def _first_error(self) -> str:
        """The status line's words for the errors shown: the first one, and how many more."""
        shown = self._shown_errors or []
        if not shown:
            return "error"
        more = f" (and {len(shown) - 1} more below)" if len(shown) > 1 else ""
        return shown[0] + more

    # ---- check, run, stop ----

    async def page_text(self) -> str:
        """The shared program once the changes typed in this page have reached it
        (:meth:`EditorSync.flush`).  Check, Run and Save use it: a Check right after typing
        checks what was typed."""
        await self.sync.flush()
        return self.c.doc.text

    async def check_program(self) -> bool:
        from parolkit.script import parse

        text = await self.page_text()
        result = parse(text, "editor")
        errors = list(result.errors)
        note = ""
        self._move_start = None
        if not errors:
            # the controller's zones and tool shape, asked now (an older controller: the table)
            setup, why = await self.c.collision.for_check()
            errors = self._dry_run(result.program, setup)
            self._move_start = self._start_offer(result.program, setup, errors)
            if why is not None:
                note = " (collisions checked against the default table only: the controller does not say its zones)"
                self.c.log.add(f"check: {why}: collisions checked against the default table only", Level.WARNING)
        self._show_errors(errors, "check")
        self._checked_text = text
        self._diag_at = None  # the parser's diagnostics of this text are in the list already
        ok = not errors
        self.prog_status.set_text(("✓ program OK" if ok else f"✗ {self._first_error()}") + note)
        self.prog_status.classes(replace="text-sm pk-mono " + ("text-green-400" if ok else "text-red-300"))
        return ok

    def _dry_run(self, program: Any, setup: CollisionSetup | None = None) -> list[Any]:
        """Plan the program without the robot (from the current joints), every move checked for
        collisions in ``setup`` (the controller's zones and tool shape; None: the default
        table); returns its errors, fills the planned position/speed charts and draws the TCP
        path, red where a move collides."""
        from parolkit.script import dry_run

        st = self.link.status
        zones = None if setup is None else setup.zones
        tool_shape = None if setup is None else setup.tool_shape
        try:
            report = dry_run(program, st.angles if st else None, zones=zones, tool_shape=tool_shape)
        except (ParolkitError, ValueError) as exc:
            self.c.log.error(f"dry run: {exc}")
            return []
        self._report = report  # Simulate plays it
        if report.segments:
            t, q, v = report.series()
            self._plot_plan(t, q, v)
            self._plan_shown = True
            if self.on_preview is not None:
                self.on_preview(path_preview(report, zones, tool_shape), st.tool if st else "default")
        return list(report.errors)

    def _start_offer(self, program: Any, setup: CollisionSetup | None,
                     errors: list[Any]) -> gui_simulate.StartPose | None:
        """The program's start when its ``errors`` (from where the arm is) are all moves that
        cannot be done and the program is valid from the home pose (the standby joints, where
        Home() ends): then "Move to start" is offered.  None otherwise."""
        from parolkit.gui.simulate import StartPose, start_pose
        from parolkit.script import dry_run

        moves = ("joint_limit", "reach", "too_fast", "singularity", "collision", "blend")
        if program is None or not errors or any(e.kind not in moves for e in explain_all(errors, "")):
            return None
        try:
            home = dry_run(program, None, zones=None if setup is None else setup.zones,
                           tool_shape=None if setup is None else setup.tool_shape)
        except (ParolkitError, ValueError):
            return None
        start = start_pose(program)
        return start if home.ok and isinstance(start, StartPose) else None

    @staticmethod
    def _parsed(text: str) -> Any:
        """The program of ``text`` (None when it has errors)."""
        from parolkit.script import parse

        return parse(text, "program").program

    def _plot_plan(self, t: Any, q: Any, v: Any) -> None:
        step = max(1, len(t) // 400)
        idx = range(0, len(t), step)
        for chart, data in ((self.plan_chart, q), (self.plan_speed_chart, v)):
            opts = chart.options
            for j in range(6):
                opts["series"][j]["data"] = [[round(float(t[i]), 3), round(float(data[i][j]), 3)] for i in idx]
            chart.update()

    async def run_program(self, step: bool) -> None:
        """Run (or resume, or step) the program the page shows.  From the press on, Space and
        Stop stop it (``ProgramRunner.announce_start``), even before it runs."""
        runner = self.c.program
        text = self.editor.value or ""
        if not self._program_active():
            self.stop_simulation()
            runner.announce_start()
            try:
                text = await self.page_text()
            except BaseException:
                runner.starting = False
                raise
        errors = await runner.start(text, step=step, name=self.c.doc.name, run_speed=float(self.run_speed))
        self._show_errors(errors, "run")
        if errors:
            self.prog_status.set_text(f"✗ {self._first_error()} · nothing was run")

    async def resume_program(self) -> None:
        """Resume from the line the E-stop interrupted: that line's move planned again from
        where the arm is to its own target, then the rest (:mod:`parolkit.gui.resume`)."""
        info = self._interrupt
        if info is None or not isinstance(info[2], ResumePlan) or self._program_active():
            return
        runner = self.c.program
        runner.resume_line = info[0]
        try:
            await self.run_program(step=False)
        finally:
            runner.resume_line = None  # (taken by the start; a start that did not happen leaves none)

    # ---- simulate ----

    async def simulate(self) -> None:
        """Check the program (the dry run from the current joints, in the controller's
        collision world: its errors and collisions marked at their lines) and play the planned
        run on the simulation's ghost arm; nothing is sent to the controller."""
        if self._program_active():
            self.c.log.info("simulate: a program runs; simulate it once it has ended")
            return
        self.stop_simulation()
        self._report = None
        await self.check_program()
        report = self._report
        if report is None:
            self.sim_status.set_text("nothing to simulate: fix the errors first")
            return
        try:
            timeline = SimTimeline.from_report(report)
        except ValueError as exc:
            self.c.log.error(f"simulate: {exc}")
            return
        if not timeline.steps:
            self.sim_status.set_text("nothing to simulate: the program has no move and no Delay")
            return
        self.simulation = Simulation(timeline, self.sim_speed)
        self.simulation.start(time.monotonic())
        self._sim_stop.set_enabled(True)
        self.c.log.info(f"simulating the program ({timeline.duration_s:.1f} s at {self.sim_speed:g}x): "
                        "the robot does not move")

    def stop_simulation(self) -> None:
        """End the simulation and hide its ghost."""
        if self.simulation is None:
            return
        self.simulation.stop()
        self.simulation = None
        self._sim_stop.set_enabled(False)
        self._update_simulation()

    def _on_sim_speed(self, e: Any) -> None:
        try:
            speed = float(e.value)
            if self.simulation is not None:
                self.simulation.set_speed(speed, time.monotonic())
            self.sim_speed = speed
        except (ParolkitError, TypeError, ValueError) as exc:
            self.c.log.error(f"simulate: {exc}")

    def sim_frame(self) -> SimFrame | None:
        """The simulation's frame now (the 3D view's ghost), None when none is shown."""
        sim = self.simulation
        return None if sim is None else sim.frame(time.monotonic())

    def _update_simulation(self) -> None:
        """The simulated line highlighted and the simulation's status line."""
        sim = self.simulation
        shown: tuple[int | None, str] | None = None
        if sim is not None:
            f = sim.frame(time.monotonic())
            total = sim.timeline.duration_s
            if f.done:
                text = f"◇ simulation finished: {total:.1f} s at 1x · the robot did not move"
            else:
                at = f"line {f.line}" if f.line is not None else "line —"
                text = (f"◇ simulating {at}{' (collides)' if f.collides else ''} · {f.time_s:.1f} / {total:.1f} s "
                        f"at {sim.speed:g}x · the robot does not move")
            shown = (f.line, text)
        if shown == self._sim_shown:
            return
        line_changed = (shown[0] if shown else None) != (self._sim_shown[0] if self._sim_shown else None)
        self._sim_shown = shown
        if shown is not None or self.sim_status.text.startswith("◇"):
            self.sim_status.set_text(shown[1] if shown is not None else "")
        if line_changed:
            self._refresh_decorations()

    # ---- go to start pose (hold to move) ----

    def _hold_to_start(self, button: Any) -> None:
        """``button`` moves the arm to the start pose while held ("Go to start pose", and "Move
        to start" of the offer line): pressed, :meth:`_start_press`; let go, :meth:`_start_release`."""
        button.on("pointerdown", self._start_press, ["button"])
        for ev in ("pointerup", "pointerleave", "pointercancel"):
            button.on(ev, lambda _: self._start_release(), [])

    def _mark_held(self, held: bool) -> None:
        for b in (self._start_btn, self._move_start_btn):
            if held:
                b.classes(add="pk-held")
            else:
                b.classes(remove="pk-held")

    async def _start_press(self, e: Any) -> None:
        """Held: the start pose of the program this page shows now (not the one worked out a
        moment ago: it may be the text before the last keys), then the move while it is held."""
        from parolkit.script import parse

        args = e.args if isinstance(e.args, dict) else {}
        if args.get("button", 0) != 0 or self._program_active():  # a right or middle button does not move
            return
        self._start_held = True
        self._mark_held(True)
        text = await self.page_text()
        result = parse(text, "editor")
        start = (start_pose(result.program) if result.ok and result.program is not None
                 else "the program has errors: Check shows them")
        self._start, self._start_text, self._start_due = start, text, None
        if not self._start_held:  # let go while the page's text was on its way
            return
        if not isinstance(start, StartPose):
            self.c.log.error(f"go to start pose: {start}")
            self._start_release()
            return
        self.c.hold_move(start.command(), f"go to start pose ({start.describe()} {start.target_text()})")
        self._start_moving = self.c.jogging

    def _start_release(self) -> None:
        if not self._start_held:
            return
        self._start_held = self._start_moving = False
        self._mark_held(False)
        self.c.jog_release()  # STOP

    def _update_start_pose(self) -> None:
        """Work out the start pose once typing pauses; grey the button when the arm is there
        or cannot move (or the program has none) and say why."""
        from parolkit.script import parse

        now = time.monotonic()
        text = self.c.doc.text  # the shared program (a running one's start needs no button)
        if text != self._start_text:
            self._start_text, self._start_due = text, now + DIAG_DELAY_S
        if self._start_due is not None and now >= self._start_due:
            self._start_due = None
            result = parse(text, "editor")
            self._start = (start_pose(result.program) if result.ok and result.program is not None
                           else "the program has errors: Check shows them")
        if self._start_moving and not self.c.jogging:  # released elsewhere (the page, a key, blur)
            self._start_held = self._start_moving = False
            self._mark_held(False)
        st, start = self.link.status, self._start
        if not isinstance(start, StartPose):
            shown = (False, f"no start pose: {start}")
        elif self._program_active():
            shown = (False, f"start pose: {start.describe()} · a program runs")
        elif st is None or not self.link.link_up or not st.can_move:
            shown = (False, f"start pose: {start.describe()} · the robot cannot move now")
        elif start.reached(st.angles, st.pose):
            shown = (False, f"at the start pose ({start.describe()})")
        elif self._start_held:
            shown = (True, f"moving to the start pose ({start.describe()}) while held")
        else:
            shown = (True, f"start pose: {start.describe()} {start.target_text()} · hold the button to move there, "
                           "release stops")
        if shown != self._start_shown:
            self._start_shown = shown
            self._start_btn.set_enabled(shown[0])
            self.start_note.set_text(shown[1])

    def stop_program(self) -> None:
        """Stop the program run and send STOP (cancels the move in progress and the queue)."""
        self.c.stop()

    def _follow_text(self) -> None:
        """The editor is read-only while a program runs (it shows the program that runs: Run
        runs the shared document); its text follows the document through :class:`EditorSync`."""
        active = self._program_active()
        if active != self._locked:
            self._locked = active
            if active:
                self.editor.disable()
            else:
                self.editor.enable()
        self.files.update()

    def set_online(self, online: bool) -> None:
        """Run and Step only with a link to the controller and no E-stop latched or pressed
        (the offer line says so)."""
        st = self.link.status
        can = online and not (st is not None and (st.estop_latched or st.estop_pressed))
        if can != self._online:
            self._online = can
            self._run_btn.set_enabled(can)
            self._step_btn.set_enabled(can)

    def _interrupted(self) -> tuple[int, str, ResumePlan | str] | None:
        """The E-stop interrupted the last run of the shared program's text: (line, the
        program's name, how to resume there or why not); None otherwise (or once edited)."""
        from parolkit.script import parse

        runner = self.c.program
        if runner.state not in ("stopped", "error") or self._program_active() or runner.text != self.c.doc.text:
            self._interrupt_key = None
            return None
        line = runner.estop_line if runner.state == "stopped" else None
        if runner.state == "error" and runner.errors:
            first = explain(runner.errors[0], runner.name)
            line = first.line if first.kind == "estop" else None
        if line is None:
            self._interrupt_key = None
            return None
        key = (runner.version, runner.text)
        if key != self._interrupt_key or self._interrupt is None:
            self._interrupt_key = key
            result = parse(runner.text, runner.name or "program")
            how: ResumePlan | str = ("the program has errors" if result.program is None
                                     else resume_plan(result.program, line))
            self._interrupt = (line, runner.name or self.c.doc.name, how)
        return self._interrupt

    def _update_offers(self) -> None:
        """The offer line: "E-STOP latched" (Run greyed until Enable); after the E-stop
        interrupted a run, "Resume from line N" (where safe) and "Restart"; "Move to start" when
        the program is valid from the home pose and not from where the arm is."""
        st = self.link.status
        up = st is not None and self.link.link_up
        latched = st is not None and up and (st.estop_latched or st.estop_pressed)
        can_move = st is not None and up and st.can_move and not self.c.program.starting
        info = self._interrupted()
        self._interrupt = info
        note, resume, restart, move = "", "", False, False
        if info is not None:
            line, name, how = info
            if latched:
                note = (f"E-STOP: {name} stopped at line {line}. Release the E-stop with Enable, then resume "
                        "or restart.")
            elif isinstance(how, ResumePlan):
                note = (f"The E-stop stopped {name} at line {line}. Resume plans line {line}'s move again from "
                        "where the arm is; Restart runs it from its first line.")
                resume = f"Resume from line {line}"
            else:
                note = f"The E-stop stopped {name} at line {line}. It cannot resume there: {how}. Restart runs it."
            restart = True
        elif latched:
            note = "E-STOP latched: Run and Step are greyed until you release it with Enable."
        elif self._move_start is not None and not self._program_active():
            start = self._move_start
            if st is not None and start.reached(st.angles, st.pose):
                note = f"The arm is at {self.c.doc.name}'s start ({start.describe()}): Check or Run again."
            else:
                note = (f"{self.c.doc.name} works from the home pose but not from where the arm is now. Hold "
                        f"Move to start to take the arm to {start.describe()}.")
                move = True
        if (restart or resume or move) and not can_move and not latched:
            note += " (The robot cannot move now: press Enable, then Home if it asks.)"
        key = (note, resume, restart, move, can_move)
        if key == self._offer_shown:
            return
        self._offer_shown = key
        self.offer_row.set_visibility(bool(note))
        self.offer_note.set_text(note)
        self._resume_btn.set_visibility(bool(resume))
        if resume:
            self._resume_btn.set_text(resume)
            self._resume_btn.props(f'aria-label="{resume}: its move planned again from where the arm is"')
        self._restart_btn.set_visibility(restart)
        self._move_start_btn.set_visibility(move)
        for b in (self._resume_btn, self._restart_btn, self._move_start_btn):
            b.set_enabled(can_move)

    def _update_live_values(self) -> None:
        """The joints and TCP pose completion fills in, sent when the arm is at rest somewhere new."""
        from parolkit.gui.completion import values_text

        st = self.link.status
        if st is None or not self.link.link_up or max((abs(v) for v in st.speeds_deg_s), default=0.0) > 0.2:
            return
        shown = (values_text(st.angles), values_text(st.pose))
        if shown != self._live_shown:
            self._live_shown = shown
            self._live.props(f'data-joints="{shown[0]}" data-pose="{shown[1]}"')

    def shown(self) -> None:
        """The Program tab was opened (its editor is created then): scroll the executing line
        into view once the editor is on the page."""
        self._revealed = None
        self._reveal_at = time.monotonic() + 0.3  # update() does it (no new element on the page)

    def _reveal(self) -> None:
        runner = self.c.program
        line = runner.current_line if self._program_active() else None
        if line is not None:
            self.editor.reveal_line(line)
        self._revealed = line

    def update(self) -> None:
        """Follow the shared document and the program runner: text, status line, error
        marks, the executing line (scrolled into view)."""
        self._follow_text()
        self._update_simulation()
        self._update_start_pose()
        sim_ok = not self._program_active()
        if sim_ok != self._sim_enabled:
            self._sim_enabled = sim_ok
            self._sim_btn.set_enabled(sim_ok)
        self._update_offers()
        self._update_live_values()
        if self._diag_at is not None and time.monotonic() >= self._diag_at:
            self._diag_at = None
            self._diagnose()
        if self._reveal_at is not None and time.monotonic() >= self._reveal_at:
            self._reveal_at = None
            self._reveal()
        runner = self.c.program
        st = self.link.status
        held = st is not None and st.paused and self.link.link_up
        key = (runner.version, held)
        if key == self._prog_version:
            return
        self._prog_version = key
        if runner.interpreter is not None and runner.interpreter is not self._run_seen:
            # a new run: what the last run and the last Check marked is gone with its cause
            self._run_seen = runner.interpreter
            if self._error_source in ("check", "run"):
                self._show_errors([], "run")
            self._move_start = None
        if runner.state in ACTIVE_STATES:
            where = f" · {runner.name}" if runner.name else ""
            self.prog_status.set_text(program_status(runner.state, runner.current_line, held,
                                                     runner.paused_by_us) + where)
            self.prog_status.classes(replace="text-sm pk-mono text-amber-300")
        elif runner.state == "error":
            if runner.errors:
                self._show_errors(runner.errors, "run", runner.name)
                self._move_start = self._start_offer(self._parsed(runner.text), self.c.collision.setup, runner.errors)
            self.prog_status.set_text(f"✗ {self._first_error() if self._error_source == 'run' else runner.message}")
            self.prog_status.classes(replace="text-sm pk-mono text-red-300")
        elif runner.state == "finished":
            self.prog_status.set_text("✓ finished")
            self.prog_status.classes(replace="text-sm pk-mono text-green-400")
        elif runner.state == "stopped":
            self.prog_status.set_text(f"■ {runner.message or 'stopped'}")
            self.prog_status.classes(replace="text-sm pk-mono text-slate-300")
        self._refresh_decorations()
        line = runner.current_line if self._program_active() else None
        if line is not None and line != self._revealed:
            self.editor.reveal_line(line)
        self._revealed = line
