"""The Program tab's file row: open and save programs by name in the programs folder (NiceGUI).

All file access goes through :class:`~parolkit.gui.programs.ProgramsFolder`; a refused name
is reported in the row (``file-status``), as a notification and in the event log, with the
rule it breaks.
"""

from __future__ import annotations

from collections.abc import Callable

from nicegui import ui

from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.program_doc import ProgramDoc
from parolkit.gui.programs import ProgramNameError, ProgramsFolder

__all__ = ["ProgramsPanel"]


class ProgramsPanel:
    """Name input, Open, Save, Save as…, the list of the folder's programs and whether the
    shared document (``doc``) has unsaved edits (kept in the folder's autosave place)."""

    def __init__(self, folder: ProgramsFolder, log: EventLog, get_text: Callable[[], str],
                 set_text: Callable[[str], None], doc: ProgramDoc) -> None:
        self.folder = folder
        self.doc = doc
        name = doc.name
        self.log = log
        self.get_text = get_text
        self.set_text = set_text
        with ui.row().classes("w-full items-center gap-2"):
            self.name_input = ui.input("program name", value=name).classes("grow") \
                .props("dense data-testid=prog-name")
            ui.button("Open", icon="folder_open", on_click=lambda: self.open(self.name_input.value)) \
                .props("flat dense color=grey-4 data-testid=prog-open")
            ui.button("Save", icon="save", on_click=lambda: self.save(self.name_input.value)) \
                .props("flat dense color=grey-4 data-testid=prog-save")
            ui.button("Save as…", icon="save_as", on_click=self.save_as) \
                .props("flat dense color=grey-4 data-testid=prog-save-as")
            ui.button("Programs", icon="list", on_click=self.show_list) \
                .props("flat dense color=grey-4 data-testid=prog-list")
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
        self.name_input.value = path.name
        self.set_text(self.doc.text)
        self._ok(f"opened {path.name} ({self.folder.root})")
        return True

    def save(self, name: str, *, notify: bool = True) -> str | None:
        """Save the editor's text as the program ``name``; None when saved, else the refusal
        (in the row, the log and, unless ``notify`` is False, a notification)."""
        program = self.get_text()
        try:
            path = self.folder.write(name, program)
        except (ProgramNameError, OSError) as exc:
            refusal = f"cannot save {name!r}: {exc}"
            self._refused(refusal, notify=notify)
            return refusal
        self.doc.edit(program)
        self.doc.saved(path.name)
        self.name_input.value = path.name
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

            def confirm() -> None:
                refusal = self.save(str(name.value or ""), notify=False)
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
