"""The one program document of a ``parolkit gui`` process (no NiceGUI: tested without a browser).

Every browser tab edits the same document: its text, the program name it belongs to and the
text last saved under that name.  Every edit is kept at once in the programs folder's
autosave place (:meth:`ProgramsFolder.write_autosave`) until the program is saved, so a
reload, a second tab or a restarted GUI finds the unsaved work again.  :attr:`version`
counts changes; a page shows the document again when it differs from the one it showed.
"""

from __future__ import annotations

from parolkit.gui.eventlog import EventLog
from parolkit.gui.programs import ProgramNameError, ProgramsFolder

__all__ = ["ProgramDoc", "DEFAULT_NAME"]

#: the name of a program that was never saved
DEFAULT_NAME = "program.rbt"


class ProgramDoc:
    """The shared editor text, its program name and whether it differs from the saved file."""

    def __init__(self, folder: ProgramsFolder, log: EventLog, default_text: str) -> None:
        self.folder = folder
        self.log = log
        self.name = DEFAULT_NAME
        self.text = default_text
        #: the text of the file as last opened or saved (None: never saved)
        self.saved_text: str | None = None
        self.version = 0
        self._restore(default_text)

    def _restore(self, default_text: str) -> None:
        """Start from the unsaved edits kept last (a restarted GUI), else ``default_text``."""
        try:
            name = self.folder.latest_autosave()
            kept = None if name is None else self.folder.read_autosave(name)
        except (OSError, UnicodeDecodeError, ProgramNameError) as exc:
            self.log.error(f"cannot read the kept unsaved edits: {exc}")
            return
        if name is None or kept is None:
            return
        self.name, self.text = name, kept
        try:
            self.saved_text = self.folder.read(name)[1]
        except (OSError, UnicodeDecodeError, ProgramNameError):
            self.saved_text = None
        self.log.info(f"restored the unsaved edits of {name}")

    @property
    def dirty(self) -> bool:
        """True when the text differs from the saved file (or was never saved)."""
        return self.text != self.saved_text

    def edit(self, text: str) -> bool:
        """A tab changed the text: keep it (autosave); False when it was already the text."""
        if text == self.text:
            return False
        self.text = text
        self.version += 1
        self._keep()
        return True

    def _keep(self) -> None:
        try:
            if self.dirty:
                self.folder.write_autosave(self.name, self.text)
            else:
                self.folder.drop_autosave(self.name)
        except (OSError, ProgramNameError) as exc:
            self.log.error(f"cannot keep the unsaved edits of {self.name}: {exc}")

    def opened(self, name: str, text: str) -> None:
        """The file ``name`` was opened with contents ``text``; its unsaved edits, if kept,
        are shown instead (the file itself is unchanged until saved)."""
        self.name, self.saved_text = name, text
        try:
            kept = self.folder.read_autosave(name)
        except (OSError, UnicodeDecodeError, ProgramNameError):
            kept = None
        self.text = text if kept is None else kept
        if kept is not None and kept != text:
            self.log.info(f"{name}: showing its unsaved edits (Save writes them to the file)")
        self.version += 1

    def saved(self, name: str) -> None:
        """The text was saved as ``name``: no unsaved edits are kept for it any more."""
        old = self.name
        self.name, self.saved_text = name, self.text
        self.version += 1
        try:
            self.folder.drop_autosave(name)
            if old != name:
                self.folder.drop_autosave(old)  # its edits are the file `name` now
        except (OSError, ProgramNameError) as exc:
            self.log.error(f"cannot drop the kept edits of {name}: {exc}")

    def replace(self, text: str) -> None:
        """An example or template replaced the text (kept like an edit)."""
        self.edit(text)
