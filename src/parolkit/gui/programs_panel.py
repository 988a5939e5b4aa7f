"""The Program tab's file row: open, save, upload and download programs by name in the programs
folder (NiceGUI).

All file access goes through :class:`~parolkit.gui.programs.ProgramsFolder`; a refused name or
file is reported in the row (``file-status``), as a notification and in the event log, with the
rule it breaks.  An upload is a ``.rbt`` file of at most 1 MB of plain text, named by the
folder's rules, written into the folder and opened (a different program of the same name is
not overwritten); a download is the saved file, served by :data:`PROGRAMS_URL` (``gui/app.py``)
as an attachment.
"""

from __future__ import annotations

import urllib.parse
from collections.abc import Awaitable, Callable
from typing import Any

from nicegui import ui

from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.program_doc import ProgramDoc, normalize_newlines
from parolkit.gui.programs import EXTENSION, MAX_PROGRAM_BYTES, ProgramNameError, ProgramsFolder, uploaded_program

__all__ = ["PROGRAMS_URL", "ProgramsPanel"]

#: where the commander's web server serves a listed program for download (``<url>/<name>``)
PROGRAMS_URL = "/parolkit-programs"


class ProgramsPanel:
    """Name input, Open, Save, Save as…, Upload, Download, the list of the folder's programs and
    whether the shared document (``doc``) has unsaved edits (kept in the folder's autosave
    place).  ``get_text``: the program as the page shows it (its typed changes in the document
    first); ``replace_refused``: why the document cannot be replaced now (a program runs), or
    None."""

    def __init__(self, folder: ProgramsFolder, log: EventLog, doc: ProgramDoc,
                 get_text: Callable[[], Awaitable[str]], replace_refused: Callable[[], str | None]) -> None:
        self.folder = folder
        self.doc = doc
        self.log = log
        self.get_text = get_text
        self.replace_refused = replace_refused
        with ui.row().classes("w-full items-center gap-2"):
            self.name_input = ui.input("program name", value=doc.name).classes("grow") \
                .props("dense data-testid=prog-name")
            ui.button("Open", icon="folder_open", on_click=lambda: self.open(self.name_input.value)) \
                .props("flat dense color=grey-4 data-testid=prog-open")
            ui.button("Save", icon="save", on_click=lambda: self.save(self.name_input.value)) \
                .props("flat dense color=grey-4 data-testid=prog-save")
            ui.button("Save as…", icon="save_as", on_click=self.save_as) \
                .props("flat dense color=grey-4 data-testid=prog-save-as")
            ui.button("Programs", icon="list", on_click=self.show_list) \
                .props("flat dense color=grey-4 data-testid=prog-list")
            # the file chooser opens in the page at the click (a browser opens one only then)
            ui.button("Upload", icon="upload_file") \
                .props('flat dense color=grey-4 data-testid=prog-upload '
                       'aria-label="Upload a .rbt program file into the programs folder and open it"') \
                .on("click", js_handler="() => document.querySelector("
                    "'[data-testid=prog-upload-box] input[type=file]').click()")
            ui.button("Download", icon="download", on_click=lambda: self.download(self.name_input.value)) \
                .props('flat dense color=grey-4 data-testid=prog-download '
                       'aria-label="Download the saved program file"')
        # Quasar's uploader does the upload (its own route); hidden, the Upload button opens its chooser
        self.uploader = ui.upload(auto_upload=True, max_file_size=MAX_PROGRAM_BYTES, on_upload=self.uploaded,
                                  on_rejected=self._upload_too_big) \
            .props("data-testid=prog-upload-box").classes("hidden")
        self.status = ui.label(f"programs folder: {folder.root}").classes("text-xs text-slate-400 pk-mono") \
            .props("data-testid=file-status")
        self.doc_state = ui.label("").classes("text-xs text-amber-300 pk-mono") \
            .props("data-testid=doc-state role=status")
        self._shown: tuple[str, bool] | None = None
        self.update()

    def update(self) -> None:
        """Show the document's program name and whether it has unsaved edits (when changed)."""
        key = (self.doc.name, self.doc.dirty)
        if key == self._shown:
            return
        self._shown = key
        if self.name_input.value != self.doc.name:
            self.name_input.value = self.doc.name
        self.doc_state.set_text(f"{self.doc.name}: unsaved edits (kept until saved)" if self.doc.dirty
                                else f"{self.doc.name}: saved")

    def _ok(self, text: str) -> None:
        self.status.set_text(text)
        self.status.classes(replace="text-xs pk-mono text-green-400")
        self.log.add(text, Level.SUCCESS)

    def _refused(self, text: str, *, notify: bool = True) -> None:
        """A refusal in the row and the log, and as a notification unless ``notify`` is False
        (a dialog that shows it itself)."""
        self.status.set_text(text)
        self.status.classes(replace="text-xs pk-mono text-red-400")
        self.log.error(text)
        if notify:
            ui.notify(text, type="negative", multi_line=True)

    def open(self, name: str) -> bool:
        """Load the program ``name`` into the editor; False (and a message) when refused."""
        busy = self.replace_refused()
        if busy is not None:
            self._refused(f"cannot open {name!r}: {busy}")
            return False
        try:
            path, text = self.folder.read(name)
        except ProgramNameError as exc:
            self._refused(f"cannot open {name!r}: {exc}")
            return False
        except FileNotFoundError:
            self._refused(f"cannot open {name!r}: there is no such program in {self.folder.root}")
            return False
        except (OSError, UnicodeDecodeError) as exc:
            self._refused(f"cannot open {name!r}: {exc}")
            return False
        self.doc.opened(path.name, text)
        self.update()
        self._ok(f"opened {path.name} ({self.folder.root})")
        return True

    async def save(self, name: str, *, notify: bool = True) -> str | None:
        """Save the program as the page shows it as the program ``name``; None when saved, else
        the refusal (in the row, the log and, unless ``notify`` is False, a notification)."""
        program = await self.get_text()
        try:
            path = self.folder.write(name, program)
        except (ProgramNameError, OSError) as exc:
            refusal = f"cannot save {name!r}: {exc}"
            self._refused(refusal, notify=notify)
            return refusal
        self.doc.saved(path.name)  # (no await since the text was taken: it is the document's)
        self.update()
        self._ok(f"saved {path.name} ({self.folder.root})")
        ui.notify(f"saved {path.name}", type="positive")
        return None

    async def save_as(self) -> None:
        """A dialog asking the name.  A refused name keeps it open with the reason in it: the
        Esc that dismisses the reason only closes the dialog (Esc with nothing open is E-STOP)."""
        with ui.dialog().props('aria-label="Save program as"') as dlg, ui.card().classes("pk-card"):
            ui.label("Save program as").classes("font-bold")
            ui.label(f"in {self.folder.root}").classes("text-xs text-slate-400 pk-mono")
            name = ui.input("program name", value=self.name_input.value).classes("w-96") \
                .props("data-testid=save-as-name")
            reason = ui.label("").classes("text-sm text-red-300 pk-mono w-96") \
                .style("white-space: normal").props("data-testid=save-as-error role=alert")
            reason.set_visibility(False)

            async def confirm() -> None:
                refusal = await self.save(str(name.value or ""), notify=False)
                if refusal is None:
                    dlg.submit(True)
                else:
                    reason.set_text(refusal)
                    reason.set_visibility(True)

            with ui.row():
                ui.button("Save", on_click=confirm).props("unelevated color=primary data-testid=save-as-confirm")
                ui.button("Cancel", on_click=lambda: dlg.submit(None)).props("flat")
        await dlg

    async def show_list(self) -> None:
        """A dialog listing the folder's programs; clicking one opens it."""
        names = self.folder.names()
        with ui.dialog().props('aria-label="Programs"') as dlg, ui.card().classes("pk-card").style("min-width: 360px"):
            ui.label("Programs").classes("font-bold")
            ui.label(str(self.folder.root)).classes("text-xs text-slate-400 pk-mono")
            if not names:
                ui.label("no programs yet: Save one").classes("text-sm text-slate-400")
            with ui.column().classes("gap-0 w-full").style("max-height: 360px; overflow-y: auto"):
                for n in names:
                    ui.button(n, on_click=lambda n=n: dlg.submit(n)).props("flat no-caps align=left") \
                        .classes("w-full").props("data-testid=program-item")
            ui.button("Close", on_click=lambda: dlg.submit(None)).props("flat")
        chosen = await dlg
        if chosen:
            self.open(str(chosen))

    # ---- files in and out ----

    async def uploaded(self, e: Any) -> None:
        """An uploaded file: a ``.rbt`` name the folder's rules accept, at most 1 MB of plain
        text; written into the folder (a different program of that name is kept: refused) and
        opened."""
        file = e.file
        raw_name = str(file.name or "")
        self.uploader.reset()  # the same file may be chosen again
        try:
            if not raw_name.lower().endswith(EXTENSION):
                raise ProgramNameError(f"only {EXTENSION} files are programs")
            name = self.folder.file_name(raw_name)
            if file.size() > MAX_PROGRAM_BYTES:
                raise ProgramNameError(f"the file is {file.size()} bytes: programs are at most "
                                       f"{MAX_PROGRAM_BYTES} bytes")
            text = normalize_newlines(uploaded_program(await file.read()))
            busy = self.replace_refused()
            if busy is not None:
                raise ProgramNameError(busy)
            path = self.folder.path(name)
            if path.exists():
                if normalize_newlines(self.folder.read(name)[1]) != text:
                    raise ProgramNameError(f"a different program named {name} is in the programs folder already: "
                                           "rename the file (or open that program and save it under another name)")
            else:
                self.folder.write(name, text)
        except (ProgramNameError, OSError, UnicodeDecodeError) as exc:
            self._refused(f"upload refused: {raw_name!r}: {exc}")
            return
        self.doc.opened(name, text)
        self.update()
        self._ok(f"uploaded {name} into {self.folder.root} and opened it")

    def _upload_too_big(self) -> None:
        self._refused(f"upload refused: the file is over {MAX_PROGRAM_BYTES} bytes (programs are at most "
                      f"{MAX_PROGRAM_BYTES // 1_000_000} MB)")

    def download(self, name: str) -> None:
        """Download the saved file of the program ``name`` (an attachment from
        :data:`PROGRAMS_URL`); a refused or missing name is said."""
        try:
            file_name = self.folder.file_name(str(name or ""))
            if file_name not in self.folder.names():
                raise ProgramNameError(f"there is no saved program {file_name} in {self.folder.root}: Save it first")
        except ProgramNameError as exc:
            self._refused(f"cannot download {name!r}: {exc}")
            return
        ui.download.from_url(f"{PROGRAMS_URL}/{urllib.parse.quote(file_name)}")
        if file_name == self.doc.name and self.doc.dirty:
            note = f"downloading {file_name} as last saved: its unsaved edits are not in it (Save first)"
            self.status.set_text(note)
            self.status.classes(replace="text-xs pk-mono text-amber-300")
            self.log.add(note, Level.WARNING)
            ui.notify(note, type="warning", multi_line=True)
        else:
            self._ok(f"downloading {file_name}")
