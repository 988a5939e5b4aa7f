"""The commander's recordings folder, its one recording at a time, and teaching from a recording.

No NiceGUI here (tested without a browser).  The page names a recording; it never gives a
path: names follow the programs folder's rules (:func:`~parolkit.gui.programs.folder_file_name`,
``.mcap`` appended when missing), and a name the browser sends for download, delete or teach
must also be one the folder lists (:meth:`RecordingsFolder.listed`), so nothing outside the
folder, and nothing in it that is not a recording, is ever read or removed.

:class:`RecordingSession` runs the recorder of ``parolkit record``
(:class:`~parolkit.record.recorder.Recorder`, an observer of the status stream: it never takes
the control lease) in a thread; :func:`teach_recording` runs ``parolkit teach``'s fit and saves
the program in the programs folder.  Both are slow or blocking: the page calls them off its
event loop.  The page's fit runs in :class:`TeachProcess`, a process of its own: a fit is
seconds of numpy and Python, and in a thread of the commander it would share the interpreter
lock with the event loop that serves every page (both slower, the page's updates stalled).
"""

from __future__ import annotations

import multiprocessing
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.programs import (
    MAX_NAME_LEN,
    FolderNameError,
    NamedFolder,
    ProgramsFolder,
    default_programs_dir,
    folder_file_name,
)

if TYPE_CHECKING:
    from parolkit.record.recorder import Recorder
    from parolkit.record.teach import TeachResult

__all__ = ["EXTENSION", "RECORDINGS_URL", "RecordingInfo", "RecordingNameError", "RecordingNotListed",
           "RecordingSession", "RecordingsFolder", "TaughtProgram", "default_recordings_dir", "fit_text",
           "TeachProcess", "fit_recording", "free_program_name", "recording_name", "size_text",
           "teach_recording"]

#: file extension of recordings (MCAP)
EXTENSION = ".mcap"
#: where the commander's web server serves a listed recording for download (``<url>/<name>``)
RECORDINGS_URL = "/parolkit-recordings"
#: the teach tolerances the commander uses (``parolkit teach``'s defaults): TCP mm, joint deg
TEACH_TOL_MM = 5.0
TEACH_TOL_DEG = 2.0


class RecordingNameError(FolderNameError):
    """A recording name the commander refuses (the message names the rule)."""


class RecordingNotListed(RecordingNameError):
    """A well-formed name that is not a recording of the folder (HTTP 404, not 400)."""


def default_recordings_dir() -> Path:
    """``recordings`` beside the default programs folder: ``$XDG_DATA_HOME/parolkit/recordings``,
    else ``~/.local/share/parolkit/recordings``."""
    return default_programs_dir().parent / "recordings"


def recording_name(text: str) -> str:
    """The file name for the recording named ``text`` (``.mcap`` appended when missing);
    raises :class:`RecordingNameError` saying which rule ``text`` breaks."""
    return folder_file_name(text, kind="recording", extension=EXTENSION, error=RecordingNameError)


@dataclass(frozen=True)
class RecordingInfo:
    """One row of the recordings list: file name, modification time (UNIX s), size (bytes)
    and, from the closing summary of a recording closed properly, its duration (s) and the
    number of statuses (ticks) it holds (None without a summary: a recorder that was killed)."""

    name: str
    modified: float
    size: int
    duration_s: float | None
    ticks: int | None


def _summary(path: Path) -> tuple[float | None, int | None]:
    """(duration s, statuses) from the ``parolkit.recording`` metadata of the file's summary
    section; (None, None) when it has none.  Reads only the summary: never the messages."""
    from mcap.exceptions import McapError
    from mcap.reader import SeekingReader

    from parolkit.record.schemas import RECORDING_METADATA

    try:
        with open(path, "rb") as f:
            reader = SeekingReader(f)
            if reader.get_summary() is None:
                return None, None
            for meta in reader.iter_metadata():
                if meta.name == RECORDING_METADATA:
                    return float(meta.metadata["duration_s"]), int(meta.metadata["statuses"])
    except (OSError, McapError, ValueError, KeyError, EOFError):
        pass
    return None, None


class RecordingsFolder(NamedFolder):
    """The recordings folder (``.mcap`` files; created, with its parents, when the first
    recording starts)."""

    KIND = "recording"
    EXTENSION = EXTENSION
    ERROR = RecordingNameError

    def __init__(self, root: str | Path) -> None:
        super().__init__(root)
        self._summaries: dict[tuple[str, int, int], tuple[float | None, int | None]] = {}

    def listed(self, text: str) -> Path:
        """The file of the recording named ``text`` that the folder lists: what a name from
        the browser must be.  RecordingNameError for a refused name, RecordingNotListed for
        a name the folder does not list."""
        path = self.path(text)
        if path.name not in self.names():
            raise RecordingNotListed(f"there is no recording {recording_name(text)!r} in {self.root}")
        return path

    def entries(self, exclude: str | None = None) -> list[RecordingInfo]:
        """The rows of the recordings list, newest first (``exclude``: the file still being
        recorded).  A summary is read once per file version (name, size, mtime)."""
        rows = []
        for name in self.names():
            if name == exclude:
                continue
            try:
                st = self.path(name).stat()
            except (OSError, RecordingNameError):
                continue  # removed meanwhile
            key = (name, st.st_size, st.st_mtime_ns)
            if key not in self._summaries:
                self._summaries[key] = _summary(self.root / name)
            duration, ticks = self._summaries[key]
            rows.append(RecordingInfo(name, st.st_mtime, st.st_size, duration, ticks))
        rows.sort(key=lambda r: (r.modified, r.name), reverse=True)
        return rows

    def new_path(self, now: datetime | None = None) -> Path:
        """A new file for a recording: ``rec-YYYYMMDD-HHMMSS.mcap`` (local time), ``-2``,
        ``-3``, ... added when taken."""
        stamp = (now or datetime.now()).strftime("rec-%Y%m%d-%H%M%S")
        taken = set(self.names())
        name, n = f"{stamp}{EXTENSION}", 2
        while name in taken or (self.root / name).exists():
            name, n = f"{stamp}-{n}{EXTENSION}", n + 1
        return self.path(name)

    def delete(self, text: str) -> Path:
        """Remove the listed recording ``text``; returns its path."""
        path = self.listed(text)
        path.unlink()
        return path


# ---------------------------------------------------------------------------- recording


class RecordingSession:
    """At most one recording of the controller ``host:port`` at a time, for every tab.

    :meth:`start` creates the file and runs the recorder in a thread; :meth:`stop` asks it to
    finish (it closes the file with its summary within about 0.1 s).  :attr:`version` counts
    starts and ends, so a page redraws its list only when something changed."""

    def __init__(self, folder: RecordingsFolder, host: str, port: int, log: EventLog) -> None:
        self.folder = folder
        self.host, self.port = host, port
        self.log = log
        self._recorder: Recorder | None = None
        self._thread: threading.Thread | None = None
        self._started = 0.0
        #: the file being recorded (None when not recording)
        self.path: Path | None = None
        #: what the last recording ended with (shown until the next one starts)
        self.last_message = ""
        self.last_ok = True
        self.version = 0

    @property
    def active(self) -> bool:
        """A recording runs (or is closing its file)."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def active_name(self) -> str | None:
        return self.path.name if self.active and self.path is not None else None

    @property
    def elapsed_s(self) -> float:
        return time.monotonic() - self._started if self.active else 0.0

    @property
    def ticks(self) -> int:
        """Statuses (controller ticks) recorded so far."""
        rec = self._recorder
        return rec.stats.statuses if rec is not None else 0

    @property
    def size(self) -> int:
        """Bytes in the file so far (the writer hands a chunk to the OS once a second)."""
        path = self.path
        try:
            return path.stat().st_size if path is not None else 0
        except OSError:
            return 0

    def start(self) -> Path:
        """Start recording into a new file of the folder; returns its path.  RuntimeError when
        one runs already, OSError when the folder or the file cannot be created."""
        from parolkit.record.recorder import Recorder

        if self.active:
            raise RuntimeError(f"already recording {self.path.name if self.path else ''}")
        self.folder.create()
        path = self.folder.new_path()
        recorder = Recorder(self.host, self.port, path)
        self._recorder, self.path = recorder, path
        self._started = time.monotonic()
        self.last_message, self.last_ok = "", True
        self._thread = threading.Thread(target=self._run, args=(recorder,), name="recorder", daemon=True)
        self._thread.start()
        self.version += 1
        self.log.info(f"recording {path.name} ({self.folder.root})")
        return path

    def _run(self, recorder: Recorder) -> None:
        from parolkit.record.recorder import RecorderError

        name = recorder.path.name
        try:
            stats = recorder.run()
        except RecorderError as exc:
            self.last_ok = False
            self.last_message = f"recording {name} ended: {exc} (the file is closed and readable)"
            self.log.error(self.last_message)
        except Exception as exc:  # a page must never see a dead thread without a word
            self.last_ok = False
            self.last_message = f"recording {name} failed: {type(exc).__name__}: {exc}"
            self.log.error(self.last_message)
        else:
            self.last_message = (f"saved {name}: {stats.statuses} ticks in {stats.duration_s:.1f} s, "
                                 f"{size_text(stats.bytes)}")
            self.log.add(self.last_message, Level.SUCCESS)
        finally:
            self.version += 1

    def stop(self) -> None:
        """Ask the recording to finish (returns at once; :attr:`active` turns False once the
        file is closed)."""
        if self._recorder is not None and self.active:
            self._recorder.stop()

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop and wait for the file to be closed (the commander shutting down)."""
        self.stop()
        thread = self._thread
        if thread is not None:
            thread.join(timeout_s)


def size_text(n: int) -> str:
    """Bytes in words: ``812 B``, ``12.3 kB``, ``4.56 MB``."""
    if n < 1000:
        return f"{n} B"
    if n < 1_000_000:
        return f"{n / 1000:.1f} kB"
    return f"{n / 1e6:.2f} MB"


# ---------------------------------------------------------------------------- teach


def fit_text(result: TeachResult, tol_mm: float, tol_deg: float) -> str:
    """The fit in words, as ``parolkit teach`` prints it: moves, delays and the deviation of the
    program's dry run from the recording, against the tolerances."""
    within = result.deviation_mm <= tol_mm and result.deviation_deg <= tol_deg
    return (f"{result.moves} moves, {result.delays} delays; deviation along the path "
            f"{result.deviation_mm:.2f} mm TCP, {result.deviation_deg:.3f} deg joint "
            f"({'within' if within else 'OUTSIDE'} {tol_mm:g} mm / {tol_deg:g} deg)")


@dataclass(frozen=True)
class TaughtProgram:
    """What teaching from a recording gave: the program's file in the programs folder, the
    text saved there and the fit (moves, delays, deviation achieved in TCP mm and joint deg)."""

    path: Path
    text: str
    result: TeachResult
    tol_mm: float
    tol_deg: float

    def text_summary(self) -> str:
        return f"taught {self.path.name}: {fit_text(self.result, self.tol_mm, self.tol_deg)}"


def free_program_name(programs: ProgramsFolder, stem: str) -> str:
    """``stem.rbt``, or ``stem-2.rbt``, ... when taken: teaching never overwrites a program."""
    taken = {n.lower() for n in programs.names()}
    n = 1
    while True:
        suffix = "" if n == 1 else f"-{n}"
        name = f"{stem[:MAX_NAME_LEN - len(suffix) - 4]}{suffix}.rbt"
        if name.lower() not in taken and not (programs.root / name).exists():
            return name
        n += 1


#: what fits a recording: (path, tol_mm, tol_deg) -> (the fit, the damage warning or "")
Fit = Callable[[Path, float, float], "tuple[TeachResult, str]"]


def fit_recording(path: Path, tol_mm: float, tol_deg: float) -> tuple[TeachResult, str]:
    """``parolkit teach``'s fit of the recording at ``path``, and a ``# warning:`` line when
    only part of it could be read (empty when whole).  Blocking: seconds for a long recording."""
    from parolkit.record.reader import load_recording
    from parolkit.record.teach import teach

    rec = load_recording(path)
    result = teach(rec, tol_mm=tol_mm, tol_deg=tol_deg)
    # the fit stays with the program: the editor shows where it came from and how close it is,
    # and that only part of the recording was read when it ends early or is damaged
    damage = f"# warning: {rec.damage.replace(str(path), path.name)}\n" if rec.damage else ""
    return result, damage


def teach_recording(recordings: RecordingsFolder, programs: ProgramsFolder, name: str, *,
                    tol_mm: float = TEACH_TOL_MM, tol_deg: float = TEACH_TOL_DEG,
                    fit: Fit = fit_recording) -> TaughtProgram:
    """Fit a program to the listed recording ``name`` (``parolkit teach``; ``fit`` does it, in
    this thread by default) and save it in the programs folder under the recording's name
    (never over an existing program).  Blocking: call it in a worker thread.  Raises
    RecordingNameError for a refused name, ParolkitValueError / ValueError when there is
    nothing to teach (no status, the robot never moves), ProgramNameError / OSError when the
    program cannot be saved."""
    path = recordings.listed(name)
    result, damage = fit(path, tol_mm, tol_deg)
    text = f"# taught from {path.name}: {fit_text(result, tol_mm, tol_deg)}\n{damage}{result.text}"
    program = free_program_name(programs, path.name[:-len(EXTENSION)])
    saved = programs.write(program, text)
    return TaughtProgram(saved, text, result, tol_mm, tol_deg)


class TeachProcess:
    """The commander's teach fits, in one process of their own (spawned at the first fit, kept
    for the next; :meth:`close` at shutdown).  :meth:`fit` is a :data:`Fit`: it blocks the
    calling thread (not the interpreter) until the process has the answer, and raises what
    the fit raised.  A process that died (killed, out of memory) is replaced at the next fit."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._pool: ProcessPoolExecutor | None = None

    def fit(self, path: Path, tol_mm: float, tol_deg: float) -> tuple[TeachResult, str]:
        with self._lock:
            if self._pool is None:
                self._pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"))
            pool = self._pool
        try:
            return pool.submit(fit_recording, path, tol_mm, tol_deg).result()
        except BrokenProcessPool:
            with self._lock:
                if self._pool is pool:
                    self._pool = None
            pool.shutdown(wait=False)
            raise

    def close(self) -> None:
        with self._lock:
            pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
