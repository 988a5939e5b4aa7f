"""The Record tab (NiceGUI): record the controller's status stream to MCAP, list the recordings
(newest first) with Download, Teach and Delete.

Recording is ``parolkit record`` in the GUI process (:class:`~parolkit.gui.recordings.RecordingSession`,
one at a time for every tab); Teach is ``parolkit teach``: the fit runs in a worker thread (a
long recording takes seconds; the page stays live), the program is saved in the programs
folder and opened in the Program tab with the deviation it achieves.  Every file access goes
through :class:`~parolkit.gui.recordings.RecordingsFolder`; a download is a plain link to the
commander's ``/parolkit-recordings/<name>`` route (:mod:`parolkit.gui.app`).
"""

from __future__ import annotations

import asyncio
import time
import urllib.parse
from collections.abc import Callable
from datetime import datetime

from nicegui import ui

from parolkit.errors import ParolkitError
from parolkit.gui.commander import Commander
from parolkit.gui.eventlog import Level
from parolkit.gui.programs import ProgramNameError
from parolkit.gui.recordings import (
    RECORDINGS_URL,
    RecordingInfo,
    RecordingNameError,
    size_text,
    teach_recording,
)

__all__ = ["RecordingsPanel", "LIST_CHECK_S"]

#: how often the list looks at the folder for changes made elsewhere (another tab, a file copied in), s
LIST_CHECK_S = 2.0


def _duration(info: RecordingInfo) -> str:
    if info.duration_s is None or info.ticks is None:
        return "not closed (no summary)"
    return f"{info.duration_s:.1f} s · {info.ticks} ticks"


def _elapsed(seconds: float) -> str:
    m, s = divmod(seconds, 60.0)
    return f"{int(m)}:{s:04.1f}"


class RecordingsPanel:
    """Record / Stop with elapsed time and file size, the recordings list and its actions;
    :meth:`update` every 0.1 s.  ``on_program_opened``: show the Program tab (a taught
    program was opened in the editor)."""

    def __init__(self, commander: Commander, on_program_opened: Callable[[], None]) -> None:
        self.c = commander
        self.session = commander.recording
        self.folder = commander.recordings
        self.on_program_opened = on_program_opened
        self._online: bool | None = None
        self._active: bool | None = None
        self._status = ""
        self._rows: list[RecordingInfo] | None = None
        self._list_key: tuple[int, bool] | None = None
        self._list_checked = 0.0
        self._teaching: str | None = None
        self._teach_buttons: list[ui.button] = []
        with ui.column().classes("gap-2 w-full"):
            with ui.row().classes("w-full items-center gap-3"):
                self.toggle = ui.button("Record", icon="fiber_manual_record", on_click=self.toggle_recording) \
                    .props('unelevated no-caps color=negative aria-label="Record" data-testid=rec-toggle')
                self.toggle.tooltip("record the controller's status stream to an MCAP file (parolkit record)")
                self.rec_status = ui.label("not recording").classes("text-sm pk-mono pk-muted") \
                    .props("data-testid=rec-status role=status")
            ui.label(f"recordings folder: {self.folder.root}").classes("text-xs text-slate-400 pk-mono") \
                .props("data-testid=rec-folder")
            self.teach_status = ui.label("").classes("text-sm pk-mono").style("white-space: normal") \
                .props("data-testid=teach-status role=status")
            ui.label("Recordings").classes("pk-title")
            self.list_box = ui.column().classes("gap-1 w-full").props("data-testid=rec-list")
        self.update()

    # ---- recording ----

    def toggle_recording(self) -> None:
        """Start a recording, or stop the one that runs (every tab shares it)."""
        s = self.session
        if s.active:
            s.stop()
            return
        if not self.c.link.link_up:
            self.c.log.error("not recording: no link to the controller")
            return
        try:
            s.start()
        except (OSError, RuntimeError, ParolkitError) as exc:
            text = f"cannot start recording: {exc}"
            self.c.log.error(text)
            ui.notify(text, type="negative", multi_line=True)

    def set_online(self, online: bool) -> None:
        """Record needs a link to the controller; Stop works without (see :meth:`update`)."""
        self._online = online

    def _show_toggle(self, active: bool) -> None:
        if active == self._active:
            return
        self._active = active
        if active:
            self.toggle.set_text("Stop recording")
            self.toggle.props('icon=stop color=grey-8 aria-label="Stop recording"')
        else:
            self.toggle.set_text("Record")
            self.toggle.props('icon=fiber_manual_record color=negative aria-label="Record"')

    def _status_text(self, active: bool) -> tuple[str, str]:
        s = self.session
        if active:
            return (f"● REC {s.active_name} · {_elapsed(s.elapsed_s)} · {s.ticks} ticks · {size_text(s.size)}",
                    "text-red-300")
        if s.last_message:
            return s.last_message, "text-green-400" if s.last_ok else "text-red-300"
        return "not recording", "pk-muted"

    def update(self) -> None:
        """Follow the recording (button, elapsed time, ticks, size) and the folder's list."""
        s = self.session
        active = s.active
        self._show_toggle(active)
        self.toggle.set_enabled(active or bool(self._online))
        text, colour = self._status_text(active)
        if text != self._status:
            self._status = text
            self.rec_status.set_text(text)
            self.rec_status.classes(replace=f"text-sm pk-mono {colour}")
        key = (s.version, active)
        now = time.monotonic()
        if key != self._list_key or now - self._list_checked >= LIST_CHECK_S:
            self._list_key = key
            self._list_checked = now
            self.refresh_list()

    # ---- the list ----

    def refresh_list(self, force: bool = False) -> None:
        """Show the folder's recordings, newest first (redrawn only when they changed)."""
        rows = self.folder.entries(exclude=self.session.active_name)
        if rows == self._rows and not force:
            return
        self._rows = rows
        self._teach_buttons = []
        self.list_box.clear()
        with self.list_box:
            if not rows:
                ui.label("no recordings yet: press Record, move the robot, press Stop") \
                    .classes("text-sm pk-muted").props("data-testid=rec-empty")
            for info in rows:
                self._row(info)

    def _row(self, info: RecordingInfo) -> None:
        name = info.name
        when = datetime.fromtimestamp(info.modified).strftime("%Y-%m-%d %H:%M:%S")
        with ui.element("div").classes("pk-rec-row").props(f'data-testid=rec-item data-name="{name}"'):
            ui.label(name).classes("pk-mono pk-rec-name").props("data-testid=rec-name")
            with ui.element("div").classes("pk-rec-meta"):
                ui.label(when).classes("pk-mono text-xs pk-muted").props("data-testid=rec-date")
                ui.label(_duration(info)).classes("pk-mono text-xs").props("data-testid=rec-duration")
                ui.label(size_text(info.size)).classes("pk-mono text-xs").props("data-testid=rec-size")
            with ui.element("div").classes("pk-rec-actions"):
                url = f"{RECORDINGS_URL}/{urllib.parse.quote(name)}"
                ui.link("Download", url).classes("pk-rec-link") \
                    .props(f'download="{name}" aria-label="Download {name}" data-testid=rec-download')
                teach = ui.button("Teach", icon="school", on_click=lambda n=name: self.teach(n)) \
                    .props(f'outline dense no-caps color=grey-4 aria-label="Teach a program from {name}" '
                           "data-testid=rec-teach")
                teach.tooltip("fit an RBTscript program to this recording (parolkit teach) and open it")
                teach.set_enabled(self._teaching is None)
                self._teach_buttons.append(teach)
                ui.button(icon="delete", on_click=lambda n=name: self.confirm_delete(n)) \
                    .props(f'flat dense round color=grey-4 aria-label="Delete {name}" data-testid=rec-delete') \
                    .tooltip("delete this recording")

    # ---- delete ----

    async def confirm_delete(self, name: str) -> None:
        with ui.dialog().props('aria-label="Delete recording"') as dlg, ui.card().classes("pk-card"):
            ui.label(f"Delete {name}?").classes("font-bold")
            ui.label(f"in {self.folder.root}; this cannot be undone").classes("text-xs text-slate-400 pk-mono")
            with ui.row():
                ui.button("Delete", on_click=lambda: dlg.submit(True)) \
                    .props("unelevated color=negative data-testid=rec-delete-confirm")
                ui.button("Cancel", on_click=lambda: dlg.submit(False)).props("flat data-testid=rec-delete-cancel")
        if await dlg:
            self.delete(name)

    def delete(self, name: str) -> bool:
        """Remove the listed recording ``name``; False (and a message) when refused."""
        try:
            self.folder.delete(name)
        except RecordingNameError as exc:
            self._message(f"cannot delete {name!r}: {exc}", ok=False)
            return False
        except OSError as exc:
            self._message(f"cannot delete {name!r}: {exc}", ok=False)
            return False
        self.c.log.info(f"deleted recording {name}")
        self.refresh_list()
        return True

    # ---- teach ----

    def _message(self, text: str, ok: bool) -> None:
        self.teach_status.set_text(text)
        self.teach_status.classes(replace="text-sm pk-mono " + ("text-green-400" if ok else "text-red-300"))
        if ok:
            self.c.log.add(text, Level.SUCCESS)
        else:
            self.c.log.error(text)
            ui.notify(text, type="negative", multi_line=True)

    def _set_teaching(self, name: str | None) -> None:
        self._teaching = name
        for b in self._teach_buttons:
            b.set_enabled(name is None)

    async def teach(self, name: str) -> None:
        """Fit a program to the recording ``name`` in the teach process, save it in the programs
        folder and open it in the editor; a recording with nothing to teach (the robot never
        moves, no status) is a message, never a crash."""
        if self._teaching is not None:
            return
        self._set_teaching(name)
        self.teach_status.set_text(f"teaching from {name} ...")
        self.teach_status.classes(replace="text-sm pk-mono text-amber-300")
        c = self.c
        try:
            taught = await asyncio.to_thread(teach_recording, c.recordings, c.programs, name,
                                             fit=c.teach_process.fit)
        except RecordingNameError as exc:
            self._message(f"cannot teach from {name!r}: {exc}", ok=False)
            return
        except ProgramNameError as exc:
            self._message(f"cannot save the program taught from {name}: {exc}", ok=False)
            return
        except (ParolkitError, ValueError) as exc:
            self._message(f"nothing taught from {name}: {exc}", ok=False)
            return
        except OSError as exc:
            self._message(f"cannot save the program taught from {name}: {exc}", ok=False)
            return
        except Exception as exc:  # the fit itself failed: say so, keep the page alive
            self._message(f"teaching from {name} failed: {type(exc).__name__}: {exc}", ok=False)
            return
        finally:
            self._set_teaching(None)
        c.doc.opened(taught.path.name, taught.text)
        self._message(taught.text_summary(), ok=True)
        ui.notify(f"{taught.text_summary()}; opened in the Program tab", type="positive", multi_line=True)
        self.on_program_opened()
