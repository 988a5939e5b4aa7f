"""The one program document of a ``parolkit gui`` process (no NiceGUI: tested without a browser).

Every browser tab edits the same document: its text, the program name it belongs to and the
text last saved under that name.  Every change is kept at once in the programs folder's
autosave place (:meth:`ProgramsFolder.write_autosave`) until the program is saved, so a
reload, a second tab or a restarted GUI finds the unsaved work again; the name of the program
shown last is remembered there too (:meth:`ProgramsFolder.remember_last`), so a restarted GUI
reopens it.

**Concurrent edits merge; nothing typed is lost.**  The text changes only by *updates*, each a
:class:`Change` (the ranges of the text it replaces, in the UTF-16 offsets the browser's editor
counts in); :attr:`ProgramDoc.revision` counts them and the document keeps the recent ones.  A
page (commander.js ``pkDoc``) sends the changes typed in its editor together with the revision
they were typed on (:meth:`ProgramDoc.push`).  They are applied only when that is still the
document's revision, all of them or none; otherwise they are refused as *behind*, the page
receives the updates it is missing (:meth:`ProgramDoc.since`), moves its own unsent changes
over them (CodeMirror's ``ChangeSet.map``: the server's order wins) and sends them again.  The
server never transforms anything: it only checks the revision, so two pages pushing at the same
moment cannot both be applied to the same text, and every change it accepts applies to exactly
the text it was made on.  Changes made on the server (a file opened, an example, a template)
are updates of their own (:meth:`ProgramDoc.edit`).  Line ends are ``\\n`` (CodeMirror's).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from parolkit.errors import ParolkitValueError
from parolkit.gui.eventlog import EventLog
from parolkit.gui.programs import MAX_PROGRAM_BYTES, ProgramNameError, ProgramsFolder

__all__ = ["Change", "DEFAULT_NAME", "EditRefused", "MAX_HISTORY", "ProgramDoc", "SERVER", "Update",
           "normalize_newlines", "utf16_len"]

#: the name of a program that was never saved
DEFAULT_NAME = "program.rbt"
#: the editor id of changes made on the server (a file opened, an example, a template)
SERVER = 0
#: updates kept for pages that are behind; a page further behind gets the whole text again
MAX_HISTORY = 20_000
#: longest text an edit may make, UTF-16 units (the programs folder's limit, in characters)
MAX_TEXT_UNITS = MAX_PROGRAM_BYTES


class EditRefused(ParolkitValueError):
    """A page's edit that cannot be applied (malformed, or not made on the text it names)."""


def utf16_len(text: str) -> int:
    """Length of ``text`` in UTF-16 code units (how the browser's editor counts)."""
    return len(text) + sum(1 for c in text if ord(c) > 0xFFFF)


def normalize_newlines(text: str) -> str:
    """``\\r\\n`` and ``\\r`` as ``\\n``: the editor's line ends (CodeMirror keeps no ``\\r``)."""
    return text.replace("\r\n", "\n").replace("\r", "\n")


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


@dataclass(frozen=True, slots=True)
class Change:
    """One edit of a text of :attr:`length` UTF-16 units: each range ``(start, end, insert)``
    replaces the units ``start..end`` of that text by ``insert``; ranges in order, not
    overlapping, all in the offsets of the text before the change (as CodeMirror's
    ``ChangeSet.iterChanges`` gives them)."""

    length: int
    ranges: tuple[tuple[int, int, str], ...]

    @classmethod
    def from_wire(cls, obj: object) -> Change:
        """A change as a page sends it, ``{"n": length, "c": [[start, end, insert], ...]}``;
        raises :class:`EditRefused` naming what is malformed."""
        if not isinstance(obj, dict) or set(obj) != {"n", "c"}:
            raise EditRefused(f"a change must be {{'n': length, 'c': ranges}}, got {str(obj)[:80]!r}")
        n, raw = obj["n"], obj["c"]
        if not _is_int(n) or n < 0:
            raise EditRefused(f"change length n must be an integer >= 0, got {n!r}")
        if not isinstance(raw, list):
            raise EditRefused(f"change ranges c must be a list, got {type(raw).__name__}")
        ranges: list[tuple[int, int, str]] = []
        end_before = 0
        for item in raw:
            if not (isinstance(item, list) and len(item) == 3 and _is_int(item[0]) and _is_int(item[1])
                    and isinstance(item[2], str)):
                raise EditRefused(f"a change range must be [start, end, text], got {str(item)[:80]!r}")
            start, end, insert = item[0], item[1], item[2]
            if not end_before <= start <= end <= n:
                raise EditRefused(f"change range {start}..{end} is out of order or outside 0..{n} "
                                  f"(the previous range ends at {end_before})")
            if "\r" in insert:
                raise EditRefused("an inserted text holds '\\r': the editor's line ends are '\\n'")
            ranges.append((start, end, insert))
            end_before = end
        return cls(n, tuple(ranges))

    def to_wire(self) -> dict[str, object]:
        """As :meth:`from_wire` reads it (and commander.js ``ChangeSet.of``)."""
        return {"n": self.length, "c": [list(r) for r in self.ranges]}

    def apply(self, text: str) -> str:
        """``text`` changed; raises :class:`EditRefused` when ``text`` is not :attr:`length`
        units long or a range would split a character in two."""
        units = text.encode("utf-16-le")
        if len(units) // 2 != self.length:
            raise EditRefused(f"the change is for a text of {self.length} units, the text has {len(units) // 2}")
        parts: list[bytes] = []
        pos = 0
        for start, end, insert in self.ranges:
            parts += [units[2 * pos:2 * start], insert.encode("utf-16-le", "surrogatepass")]
            pos = end
        parts.append(units[2 * pos:])
        try:
            return b"".join(parts).decode("utf-16-le")
        except UnicodeDecodeError as exc:
            raise EditRefused(f"the change splits a character in two: {exc}") from None

    @classmethod
    def between(cls, old: str, new: str) -> Change | None:
        """The one range that turns ``old`` into ``new`` (their common start and end kept);
        None when they are equal."""
        if old == new:
            return None
        head = 0
        limit = min(len(old), len(new))
        while head < limit and old[head] == new[head]:
            head += 1
        tail = 0
        while tail < limit - head and old[len(old) - 1 - tail] == new[len(new) - 1 - tail]:
            tail += 1
        start = utf16_len(old[:head])
        end = start + utf16_len(old[head:len(old) - tail])
        return cls(utf16_len(old), ((start, end, new[head:len(new) - tail]),))


@dataclass(frozen=True, slots=True)
class Update:
    """One change of the document, in order: revision ``r`` is the text after update ``r``."""

    change: Change
    #: the editor (page) it came from (:meth:`ProgramDoc.attach`), :data:`SERVER` for the server's
    editor: int


class ProgramDoc:
    """The shared editor text, its program name, whether it differs from the saved file, and the
    updates that made it (pages follow them and push theirs: see the module's docstring)."""

    def __init__(self, folder: ProgramsFolder, log: EventLog, default_text: str) -> None:
        self.folder = folder
        self.log = log
        self.name = DEFAULT_NAME
        self.text = normalize_newlines(default_text)
        #: the text of the file as last opened or saved (None: never saved)
        self.saved_text: str | None = None
        #: the number of updates so far (0: the text the document started with)
        self.revision = 0
        self._history: deque[Update] = deque(maxlen=MAX_HISTORY)
        self._editors = SERVER
        self._listeners: list[Callable[[], None]] = []
        self._restore()

    # ---- start: the program shown last (a restarted GUI) ----

    def _restore(self) -> None:
        """Reopen the program shown last, with its kept unsaved edits; else the program whose
        edits were kept last; else the default text."""
        try:
            name = self.folder.last_program() or self.folder.latest_autosave()
            kept = None if name is None else self.folder.read_autosave(name)
        except (OSError, UnicodeDecodeError, ProgramNameError) as exc:
            self.log.error(f"cannot read the program shown last: {exc}")
            return
        if name is None:
            return
        try:
            saved: str | None = normalize_newlines(self.folder.read(name)[1])
        except (OSError, UnicodeDecodeError, ProgramNameError):
            saved = None
        text = saved if kept is None else normalize_newlines(kept)
        if text is None:
            return  # the file is gone and nothing was kept for it
        self.name, self.saved_text, self.text = name, saved, text
        self.log.info(f"reopened {name}" + (" with its unsaved edits" if kept is not None else ""))

    @property
    def dirty(self) -> bool:
        """True when the text differs from the saved file (or was never saved)."""
        return self.text != self.saved_text

    # ---- pages: attach, follow, push ----

    def attach(self) -> int:
        """A new editor id for a page (its updates are marked with it)."""
        self._editors += 1
        return self._editors

    def subscribe(self, listener: Callable[[], None]) -> None:
        """Call ``listener()`` after every update (a page sends it on at once)."""
        self._listeners.append(listener)

    def unsubscribe(self, listener: Callable[[], None]) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def since(self, revision: int) -> list[Update] | None:
        """The updates after ``revision`` (a page that has seen that far); None when they are
        no longer kept (the page must take the whole text) or ``revision`` is in the future."""
        count = len(self._history)
        if not self.revision - count <= revision <= self.revision:
            return None
        return [self._history[i] for i in range(count - (self.revision - revision), count)]

    def push(self, editor: int, base: object, changes: object) -> bool:
        """The changes a page typed, in order, on the text of revision ``base``.  Applied (all,
        as one update each) when ``base`` is still the revision: True.  False when other updates
        came first (the page moves its changes over them and pushes again).  Raises
        :class:`EditRefused` (nothing applied) for a malformed change, a ``base`` the document
        never had, or a change that does not fit the text of ``base``."""
        if not isinstance(base, int) or isinstance(base, bool) or not 0 <= base <= self.revision:
            raise EditRefused(f"base revision must be an integer in 0..{self.revision}, got {base!r}")
        if not isinstance(changes, list) or not changes:
            raise EditRefused("a push holds a non-empty list of changes")
        parsed = [Change.from_wire(c) for c in changes]
        if base != self.revision:
            return False
        text = self.text
        for change in parsed:
            text = change.apply(text)
        if utf16_len(text) > MAX_TEXT_UNITS:
            raise EditRefused(f"the program would be {utf16_len(text)} characters long: the commander keeps "
                              f"programs of at most {MAX_TEXT_UNITS}")
        self._commit(text, [Update(c, editor) for c in parsed])
        return True

    def _commit(self, text: str, updates: list[Update]) -> None:
        self.text = text
        self._history.extend(updates)
        self.revision += len(updates)
        self._keep()
        for listener in list(self._listeners):
            listener()

    def _keep(self) -> None:
        try:
            if self.dirty:
                self.folder.write_autosave(self.name, self.text)
            else:
                self.folder.drop_autosave(self.name)
        except (OSError, ProgramNameError) as exc:
            self.log.error(f"cannot keep the unsaved edits of {self.name}: {exc}")

    # ---- the server's own changes ----

    def edit(self, text: str) -> bool:
        """The server changed the whole text (an example, a template, a file): one update (the
        range that differs), kept (autosave); False when it was already the text."""
        text = normalize_newlines(text)
        change = Change.between(self.text, text)
        if change is None:
            return False
        self._commit(text, [Update(change, SERVER)])
        return True

    def opened(self, name: str, text: str) -> None:
        """The file ``name`` was opened with contents ``text``; its unsaved edits, if kept,
        are shown instead (the file itself is unchanged until saved)."""
        text = normalize_newlines(text)
        try:
            kept = self.folder.read_autosave(name)
        except (OSError, UnicodeDecodeError, ProgramNameError):
            kept = None
        self.name, self.saved_text = name, text
        self._remember(name)
        if kept is not None and normalize_newlines(kept) != text:
            self.log.info(f"{name}: showing its unsaved edits (Save writes them to the file)")
        if not self.edit(text if kept is None else kept):
            self._keep()  # the same text: still drop or keep its autosave for the new name

    def saved(self, name: str) -> None:
        """The text was saved as ``name``: no unsaved edits are kept for it any more."""
        old = self.name
        self.name, self.saved_text = name, self.text
        self._remember(name)
        try:
            self.folder.drop_autosave(name)
            if old != name:
                self.folder.drop_autosave(old)  # its edits are the file `name` now
        except (OSError, ProgramNameError) as exc:
            self.log.error(f"cannot drop the kept edits of {name}: {exc}")

    def _remember(self, name: str) -> None:
        try:
            self.folder.remember_last(name)
        except (OSError, ProgramNameError) as exc:
            self.log.error(f"cannot remember {name} as the program shown last: {exc}")
