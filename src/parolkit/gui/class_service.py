"""The class at work in a ``parolkit gui`` process: :mod:`parolkit.gui.classroom`'s state
applied to the robot and the programs folder (no NiceGUI here).

* **Who acts.**  Every event of a page runs with :data:`ACTING` set to that page's member (the
  page's event gate sets it, :mod:`parolkit.gui.components.class_panel`); the commander asks
  :meth:`ClassService.refuse` before it sends anything for a page, so an action that reaches
  the robot after its turn ended (a handler that waited for the page) is refused too.
* **A turn that changes stops the robot** (:meth:`ClassService.follow`): the held jog ends, a
  program running or starting is stopped, and ``STOP`` ends the move (it slows down on its own
  path and the queue is cleared).  Then the programs folder is the new driver's: the programs
  folder itself for the teacher, ``students/<name>/`` for a student.
* **The editor follows the driver**: a student gets back the unsaved edits kept in their folder
  (else the program they saved last, else the program the teacher had when handing over); the
  teacher gets back the program they had.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Callable
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from parolkit.gui.classroom import TEACHER, ClassroomError, ClassView, Member, Role, Turn
from parolkit.gui.eventlog import Level
from parolkit.gui.programs import ProgramNameError, ProgramsFolder, student_folder, student_names

if TYPE_CHECKING:
    from parolkit.gui.classroom import Classroom
    from parolkit.gui.eventlog import EventLog
    from parolkit.gui.program_doc import ProgramDoc

__all__ = ["ACTING", "TICK_S", "ClassService"]

#: the member (session key) a page's event runs for; None outside a page's event (timers, the
#: commander itself): what the commander does of its own is never refused
ACTING: ContextVar[str | None] = ContextVar("parolkit_class_member", default=None)
#: how often a turn's time limit is checked, s (a turn that ran out cannot act before that:
#: :meth:`Classroom.may_drive` already says so)
TICK_S = 0.25


def _turn_key(turn: Turn | None) -> tuple[str, float] | None:
    """One turn, whatever its limit (the teacher may change the limit of a running turn)."""
    return None if turn is None else (turn.name, turn.started)


class _Runner(Protocol):
    def stop(self, reason: str = "stopped") -> None: ...


class ClassHost(Protocol):
    """What the class needs of the commander (:class:`parolkit.gui.commander.Commander`, which
    holds the class: typed as this, the commander module is not imported here)."""

    @property
    def doc(self) -> ProgramDoc: ...

    @property
    def log(self) -> EventLog: ...

    @property
    def programs(self) -> ProgramsFolder: ...

    @property
    def program(self) -> _Runner: ...

    def stop(self) -> None: ...


class ClassService:
    """The classroom of one commander process; every page action goes through it."""

    def __init__(self, room: Classroom, commander: ClassHost, clock: Callable[[], float] = time.monotonic) -> None:
        self.room = room
        self.c = commander
        self.clock = clock
        #: the teacher's folder: the programs folder as configured
        self.root: Path = commander.programs.root
        self._applied = _turn_key(room.turn)
        #: the program the teacher had when the robot last left the teacher (name, text)
        self._teacher_doc: tuple[str, str] | None = None
        self._task: asyncio.Task[None] | None = None

    # ---- who may act ----

    def member(self, key: str | None) -> Member | None:
        return None if key is None else self.room.member(key)

    def may_drive(self, key: str | None) -> bool:
        return self.room.may_drive(key, self.clock())

    def view(self, key: str) -> ClassView | None:
        return self.room.view(key, self.clock())

    def watching_text(self, key: str | None) -> str:
        """Why the member ``key`` may not act now, in a few words."""
        m = self.member(key)
        if m is None:
            return "this page is logged out (log in again)"
        holder = self.room.holder(self.clock())
        who = f"{holder} has" if holder is not None else f"{TEACHER} has"
        return f"{m.name} is watching: {who} the robot"

    def refuse(self, what: str) -> bool:
        """True (and logged) when the page this runs for (:data:`ACTING`) may not move or change
        the robot now; False for the driver and outside a page's event."""
        key = ACTING.get()
        if key is None or self.may_drive(key):
            return False
        self.c.log.error(f"{what} refused: {self.watching_text(key)}")
        return True

    # ---- the pages' actions (each names the member who acts) ----

    def act(self, key: str, action: Callable[[float], object]) -> None:
        """Run a class transition for ``key`` (``action(now)``; ClassroomError propagates to
        the page), then apply a change of turn to the robot."""
        action(self.clock())
        self.follow()

    def ask(self, key: str) -> None:
        self.act(key, lambda now: self.room.ask(key, now))

    def withdraw(self, key: str) -> None:
        self.act(key, lambda now: self.room.withdraw(key))

    def end_turn(self, key: str) -> None:
        self.act(key, lambda now: self.room.end_turn(key, now))

    def hand_over(self, key: str, name: str | None = None) -> None:
        self.act(key, lambda now: self.room.hand_over(key, name, now))

    def take_back(self, key: str) -> None:
        self.act(key, lambda now: self.room.take_back(key, now))

    def move(self, key: str, name: str, places: int) -> None:
        self.act(key, lambda now: self.room.move(key, name, places))

    def dequeue(self, key: str, name: str) -> None:
        self.act(key, lambda now: self.room.dequeue(key, name))

    def set_limit(self, key: str, minutes: float | None) -> None:
        self.act(key, lambda now: self.room.set_limit(key, minutes))
        limit = self.room.limit_s
        self.c.log.info("turns have no time limit" if limit is None else f"a turn lasts {limit / 60:g} min")

    # ---- the students' programs (the teacher sees all) ----

    def student_programs(self) -> dict[str, list[str]]:
        """Every student's programs: {student: [program, ...]} (folders that exist)."""
        out: dict[str, list[str]] = {}
        for name in student_names(self.root):
            try:
                out[name] = ProgramsFolder(student_folder(self.root, name)).names()
            except (ProgramNameError, OSError):
                continue
        return out

    def open_student_program(self, key: str, student: str, program: str) -> str:
        """The teacher opens a student's program in the editor, as an unsaved copy named
        ``<student> <program>`` (Save keeps it in the teacher's folder); its name."""
        m = self.member(key)
        if m is None or m.role is not Role.TEACHER:
            raise ClassroomError("open a student's program: only the teacher may do that")
        if not self.may_drive(key):
            raise ClassroomError(f"open a student's program: {self.room.holder(self.clock())} has the robot "
                                 "(take it back first: the editor is theirs now)")
        try:
            _, text = ProgramsFolder(student_folder(self.root, student)).read(program)
        except (ProgramNameError, OSError, UnicodeDecodeError) as exc:
            raise ClassroomError(f"open {student}'s {program}: {exc}") from None
        name = f"{student} {program}"
        doc = self.c.doc
        doc.opened(name, "")  # not a file of the teacher's folder: unsaved
        doc.edit(text)  # the student's program as it is now (not edits kept from an earlier copy)
        self.c.log.info(f"opened {student}'s {program} as {name} (a copy: Save keeps it in the teacher's folder)")
        return name

    # ---- a change of turn ----

    def follow(self) -> None:
        """End a turn whose time ran out, and apply a change of who has the robot: stop what
        runs, then switch the programs folder and the editor to the new driver's."""
        self.room.tick(self.clock())
        turn = self.room.turn
        key = _turn_key(turn)
        if key == self._applied:
            return
        before, self._applied = self._applied, key
        end = self.room.last_end
        why = end.reason if end is not None and (turn is None or end.at >= turn.started) else \
            f"handed over to {turn.name if turn else TEACHER}"
        self._stop(why)
        if turn is None:
            self.c.log.add(f"{TEACHER} has the robot ({why})", Level.WARNING)
        else:
            limit = "no time limit" if turn.limit_s is None else f"{turn.limit_s / 60:g} min"
            self.c.log.add(f"{turn.name} has the robot ({limit})", Level.SUCCESS)
        if before is None:  # the robot leaves the teacher: remember the teacher's program
            doc = self.c.doc
            self._teacher_doc = (doc.name, doc.text)
        try:
            self._use_folder(None if turn is None else turn.name)
        except (OSError, ProgramNameError, UnicodeDecodeError) as exc:
            self.c.log.error(f"programs folder of {turn.name if turn else TEACHER}: {exc}")

    def _stop(self, why: str) -> None:
        """Stop whatever the previous driver runs, as the header's Stop does (the held jog, the
        program running or starting, ``STOP``: the move slows down on its path and the queue
        is cleared); the program's status line says why."""
        self.c.program.stop(reason=f"stopped: {why}")
        self.c.stop()

    def _use_folder(self, student: str | None) -> None:
        folder = self.c.programs
        target = self.root if student is None else student_folder(self.root, student)
        if folder.root == target:
            return
        folder.root = target  # the one folder object Open, Save and the editor's autosave use
        folder.create()
        teacher = self._teacher_doc
        if student is None:
            if teacher is not None:
                self._show(teacher[0], self._saved(folder, teacher[0]), teacher[1])
            return
        kept = folder.latest_autosave()
        if kept is not None and folder.read_autosave(kept) is not None:
            self._show(kept, self._saved(folder, kept))  # the unsaved edits kept there
            return
        saved = [(p.stat().st_mtime, p.name) for p in (folder.root / n for n in folder.names()) if p.is_file()]
        if saved:
            newest = max(saved)[1]
            self._show(newest, folder.read(newest)[1])
        elif teacher is not None:
            self._show(teacher[0], None, teacher[1])

    def _show(self, name: str, file_text: str | None, text: str | None = None) -> None:
        """The editor shows the program ``name`` of the current folder (whose file holds
        ``file_text``; None: there is no such file): its unsaved edits kept in the folder, else
        ``text`` (unsaved), else the file."""
        doc = self.c.doc
        doc.opened(name, "" if file_text is None else file_text)
        kept = self.c.programs.read_autosave(name)
        if text is not None and kept is None and doc.text != text:
            doc.edit(text)

    @staticmethod
    def _saved(folder: ProgramsFolder, name: str) -> str | None:
        try:
            return folder.read(name)[1]
        except (OSError, UnicodeDecodeError, ProgramNameError):
            return None

    # ---- the time limit ----

    def start(self) -> None:
        if self._task is None:
            self._task = asyncio.ensure_future(self._run())

    async def _run(self) -> None:
        while True:
            await asyncio.sleep(TICK_S)
            try:
                self.follow()
            except Exception as exc:  # never let the turn watch die: the limits depend on it
                self.c.log.error(f"class: {type(exc).__name__}: {exc}")

    async def stop(self) -> None:
        task, self._task = self._task, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
