"""The commander's programs folder: the only place its Open and Save read and write.

The page names a program; it never gives a path.  A name is letters, digits, spaces and
``- _ .`` (at most :data:`MAX_NAME_LEN` characters, not starting with ``.``); ``.rbt`` is
appended when missing.  Absolute paths, ``..``, path separators, and files that resolve
outside the folder (a symbolic link pointing elsewhere) are refused with a
:class:`ProgramNameError` that names the rule.  No NiceGUI here: tested without a browser.

:func:`folder_file_name` and :func:`file_inside` are the one name check of every folder the
commander names files in from the browser (this one and the recordings folder,
:mod:`parolkit.gui.recordings`).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from parolkit.errors import ParolkitValueError

__all__ = ["AUTOSAVE_DIR", "EXTENSION", "MAX_NAME_LEN", "MAX_PROGRAM_BYTES", "FolderNameError", "NamedFolder",
           "ProgramNameError",
           "ProgramsFolder", "STUDENTS_DIR", "default_programs_dir", "file_inside", "folder_file_name", "name_rule",
           "program_name", "student_folder", "student_names"]

#: file extension of RBTscript programs
EXTENSION = ".rbt"
#: longest accepted program name, characters (with the extension)
MAX_NAME_LEN = 100
#: the folder, inside the programs folder, that keeps unsaved edits (one file per program name)
AUTOSAVE_DIR = ".autosave"
#: largest program the commander opens or saves, bytes
MAX_PROGRAM_BYTES = 1_000_000

_NAME = re.compile(r"[A-Za-z0-9 _.\-]+")


def name_rule(kind: str, extension: str) -> str:
    """The naming rule of the files of one commander folder, stated in every refusal."""
    return (f"a {kind} is named by letters, digits, spaces, '-', '_' and '.' only (no folders, "
            f"no '..', no absolute path), at most {MAX_NAME_LEN} characters"
            + (f"; '{extension}' is added when missing" if extension else ""))


RULE = name_rule("program", EXTENSION)


class FolderNameError(ParolkitValueError):
    """A file name the commander refuses for one of its folders (the message names the rule)."""


class ProgramNameError(FolderNameError):
    """A program name or file the commander refuses (the message names the rule)."""


def default_programs_dir() -> Path:
    """``$XDG_DATA_HOME/parolkit/programs``, else ``~/.local/share/parolkit/programs``."""
    base = os.environ.get("XDG_DATA_HOME", "").strip()
    root = Path(base) if base and Path(base).is_absolute() else Path.home() / ".local" / "share"
    return root / "parolkit" / "programs"


def folder_file_name(text: str, *, kind: str, extension: str,
                     error: type[FolderNameError] = FolderNameError) -> str:
    """The file name for the ``kind`` (program, recording) named ``text`` in a commander folder
    (``extension`` appended when missing); raises ``error`` saying which rule ``text`` breaks.
    The one name check of every folder the browser names files in (programs, recordings)."""
    rule = name_rule(kind, extension)
    if not isinstance(text, str):
        raise error(f"{kind} name must be text, got {type(text).__name__}")
    name = text.strip()
    if not name:
        raise error(f"no {kind} name given: {rule}")
    if name.startswith(("/", "\\", "~/", "~\\")) or re.match(r"^[A-Za-z]:[/\\]", name):
        raise error(f"{text!r} is an absolute path: only names inside the {kind}s folder are "
                    f"allowed ({rule})")
    if "/" in name or "\\" in name:
        raise error(f"{text!r} contains a path separator: {rule}")
    if ".." in name:
        raise error(f"{text!r} contains '..': {rule}")
    if name.startswith("."):
        raise error(f"{text!r} starts with '.' (a hidden file): {rule}")
    bad = sorted({c for c in name if not _NAME.fullmatch(c)})
    if bad:
        shown = " ".join(repr(c) for c in bad[:5])
        raise error(f"{text!r} contains {shown}: {rule}")
    if not name.lower().endswith(extension):
        name += extension
    if len(name) > MAX_NAME_LEN:
        raise error(f"{text!r} is {len(name)} characters long with its extension: {rule}")
    return name


def file_inside(root: Path, name: str, *, kind: str, error: type[FolderNameError] = FolderNameError) -> Path:
    """``root / name`` resolved, checked to be (and, for a symbolic link, to resolve) directly
    inside ``root`` and not to be something other than a regular file; raises ``error``.
    ``name`` must have passed :func:`folder_file_name`."""
    folder = root.resolve()
    resolved = (folder / name).resolve()
    if resolved.parent != folder:
        raise error(f"{name} is a link to {resolved}, outside the {kind}s folder {folder}: refused "
                    "(the commander reads and writes only files inside that folder)")
    if resolved.exists() and not resolved.is_file():
        raise error(f"{name} in the {kind}s folder is not a regular file")
    return resolved


def program_name(text: str) -> str:
    """The file name for the program named ``text`` (``.rbt`` appended when missing);
    raises :class:`ProgramNameError` saying which rule ``text`` breaks."""
    return folder_file_name(text, kind="program", extension=EXTENSION, error=ProgramNameError)


class NamedFolder:
    """A folder ``root`` of files the page names (created, with its parents, by :meth:`create`):
    ``KIND`` ("program"), ``EXTENSION`` and ``ERROR`` (the FolderNameError subclass raised for
    a refused name) set by the subclass; :meth:`path` is the only way from a name to a file."""

    KIND = "file"
    EXTENSION = ""
    ERROR: type[FolderNameError] = FolderNameError

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root).expanduser().absolute()

    def create(self) -> None:
        """Create the folder (and its parents) if it does not exist; raises OSError naming it
        when that fails or the path is not a folder."""
        self.root.mkdir(parents=True, exist_ok=True)
        if not self.root.is_dir():
            raise NotADirectoryError(f"the {self.KIND}s folder {self.root} is not a folder")

    def file_name(self, text: str) -> str:
        """The file name for ``text`` (the extension appended when missing); raises ``ERROR``
        saying which rule ``text`` breaks."""
        return folder_file_name(text, kind=self.KIND, extension=self.EXTENSION, error=self.ERROR)

    def path(self, text: str) -> Path:
        """The file named ``text``, checked to be (and, for a symbolic link, to resolve)
        directly inside the folder; raises ``ERROR``."""
        return file_inside(self.root, self.file_name(text), kind=self.KIND, error=self.ERROR)

    def names(self) -> list[str]:
        """The files of the folder the page may name: ``EXTENSION`` files whose names the
        commander accepts as they are and that resolve inside it, sorted case-insensitively;
        [] if the folder is missing."""
        if not self.root.is_dir():
            return []
        out = []
        for entry in self.root.iterdir():
            if not entry.name.lower().endswith(self.EXTENSION):
                continue
            try:
                if self.file_name(entry.name) != entry.name or not self.path(entry.name).is_file():
                    continue
            except self.ERROR:
                continue
            out.append(entry.name)
        return sorted(out, key=str.lower)


class ProgramsFolder(NamedFolder):
    """The programs folder (``.rbt`` files)."""

    KIND = "program"
    EXTENSION = EXTENSION
    ERROR = ProgramNameError

    def read(self, text: str) -> tuple[Path, str]:
        """(path, contents) of the program named ``text``; ProgramNameError for a refused
        name, OSError / UnicodeDecodeError for an unreadable file."""
        path = self.path(text)
        size = path.stat().st_size
        if size > MAX_PROGRAM_BYTES:
            raise ProgramNameError(f"{path.name} is {size} bytes: the commander opens programs of at most "
                                   f"{MAX_PROGRAM_BYTES} bytes")
        return path, path.read_text(encoding="utf-8-sig")

    def write(self, text: str, program: str) -> Path:
        """Save ``program`` as the program named ``text``; returns its path."""
        path = self.path(text)
        data = program.encode("utf-8")
        if len(data) > MAX_PROGRAM_BYTES:
            raise ProgramNameError(f"the program is {len(data)} bytes: the commander saves programs of at "
                                   f"most {MAX_PROGRAM_BYTES} bytes")
        self.create()
        path.write_bytes(data)
        return path


    # ---- autosave: unsaved edits, one file per program name, in <folder>/.autosave ----

    @property
    def autosave_root(self) -> Path:
        """``<folder>/.autosave`` (never listed by :meth:`names`: it is not a program)."""
        return self.root / AUTOSAVE_DIR

    def autosave_path(self, text: str) -> Path:
        """The autosave file of the program named ``text`` (same name rules as :meth:`path`),
        checked to resolve directly inside :attr:`autosave_root`; raises ProgramNameError."""
        name = program_name(text)
        box = self.autosave_root.resolve()
        if box.parent != self.root.resolve():
            raise ProgramNameError(f"the autosave folder {self.autosave_root} resolves to {box}, outside the "
                                   f"programs folder {self.root}: refused")
        resolved = (box / name).resolve()
        if resolved.parent != box:
            raise ProgramNameError(f"autosave of {name} resolves to {resolved}, outside {box}: refused")
        return resolved

    def write_autosave(self, text: str, program: str) -> Path:
        """Keep ``program`` as the unsaved edits of the program named ``text``."""
        path = self.autosave_path(text)
        data = program.encode("utf-8")
        if len(data) > MAX_PROGRAM_BYTES:
            raise ProgramNameError(f"the program is {len(data)} bytes: the commander keeps programs of at "
                                   f"most {MAX_PROGRAM_BYTES} bytes")
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_bytes(data)
        os.replace(tmp, path)
        return path

    def read_autosave(self, text: str) -> str | None:
        """The unsaved edits of the program named ``text``, None when there are none."""
        path = self.autosave_path(text)
        if not path.is_file() or path.stat().st_size > MAX_PROGRAM_BYTES:
            return None
        return path.read_text(encoding="utf-8")

    def drop_autosave(self, text: str) -> None:
        """Forget the unsaved edits of the program named ``text`` (it was saved)."""
        self.autosave_path(text).unlink(missing_ok=True)

    def latest_autosave(self) -> str | None:
        """Name of the program whose unsaved edits were kept last, None when there are none."""
        box = self.autosave_root
        if not box.is_dir():
            return None
        best: tuple[float, str] | None = None
        for entry in box.iterdir():
            if not entry.name.lower().endswith(EXTENSION):
                continue
            try:
                path = self.autosave_path(entry.name)
            except ProgramNameError:
                continue
            if path.is_file():
                mtime = path.stat().st_mtime
                if best is None or mtime > best[0]:
                    best = (mtime, entry.name)
        return None if best is None else best[1]

    # ---- the program shown last (a restarted commander reopens it): <folder>/.autosave/last ----

    def _last_path(self) -> Path:
        """``<folder>/.autosave/last`` (the autosave folder checked as for every autosave)."""
        return self.autosave_path(LAST_FILE).parent / LAST_FILE

    def remember_last(self, text: str) -> None:
        """Remember the program named ``text`` as the one shown last."""
        name = program_name(text)
        path = self._last_path()
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.is_symlink() or (path.exists() and not path.is_file()):
            raise ProgramNameError(f"{path} is not a regular file: refused")
        tmp = path.with_name(LAST_FILE + ".tmp")
        tmp.write_text(name + "\n", encoding="utf-8")
        os.replace(tmp, path)

    def last_program(self) -> str | None:
        """The name remembered by :meth:`remember_last` (checked by the name rules), None when
        there is none."""
        path = self._last_path()
        if path.is_symlink() or not path.is_file() or path.stat().st_size > MAX_NAME_LEN + 2:
            return None
        return program_name(path.read_text(encoding="utf-8").strip())


#: the file in the autosave folder naming the program shown last
LAST_FILE = "last"
__all__ += ["LAST_FILE", "uploaded_program"]


def uploaded_program(data: bytes) -> str:
    """The text of an uploaded program file: at most :data:`MAX_PROGRAM_BYTES`, UTF-8 text (a
    byte-order mark dropped) without NUL or other control characters but tab and line ends;
    raises ProgramNameError saying which rule it breaks."""
    if len(data) > MAX_PROGRAM_BYTES:
        raise ProgramNameError(f"the file is {len(data)} bytes: programs are at most {MAX_PROGRAM_BYTES} bytes")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ProgramNameError(f"the file is not UTF-8 text (byte {exc.start}): an RBTscript program is "
                               "plain text") from None
    bad = sorted({c for c in text if (ord(c) < 32 and c not in "\t\r\n") or ord(c) == 127})
    if bad:
        raise ProgramNameError(f"the file holds control characters ({', '.join(f'{ord(c):#04x}' for c in bad[:5])}): "
                               "an RBTscript program is plain text")
    return text


# ---- a class (gui/classroom.py): each student's programs in a folder of their own ----

#: the folder, inside the programs folder, that holds one folder per student
STUDENTS_DIR = "students"


def student_folder(root: Path, name: str) -> Path:
    """``root/students/<name>``: the programs folder of the student ``name`` (the programs
    folder's name rules, without an extension); a folder that exists must resolve directly
    inside ``root/students`` (not a link elsewhere).  Raises ProgramNameError naming the rule."""
    folder = folder_file_name(name, kind="student", extension="", error=ProgramNameError)
    box = Path(root).expanduser().absolute() / STUDENTS_DIR
    path = box / folder
    if path.exists() or path.is_symlink():
        resolved = path.resolve()
        if resolved.parent != box.resolve():
            raise ProgramNameError(f"the folder of {folder} resolves to {resolved}, outside {box}: refused "
                                   "(a student's programs stay inside the programs folder)")
        if not resolved.is_dir():
            raise ProgramNameError(f"{path} is not a folder")
    return path


def student_names(root: Path) -> list[str]:
    """The students who have a programs folder in ``root/students`` (names the rules accept,
    folders that resolve inside it), sorted case-insensitively; [] if there is none."""
    box = Path(root).expanduser().absolute() / STUDENTS_DIR
    if not box.is_dir():
        return []
    out = []
    for entry in box.iterdir():
        try:
            if folder_file_name(entry.name, kind="student", extension="", error=ProgramNameError) != entry.name:
                continue
            if student_folder(root, entry.name).is_dir():
                out.append(entry.name)
        except ProgramNameError:
            continue
    return sorted(out, key=str.lower)
