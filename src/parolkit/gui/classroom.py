"""A class at the commander: the teacher, the students and the turn queue (docs/gui.md, "A
class: teacher, students and turns").

Plain state and its transitions, no NiceGUI, no threads and no clock of its own: every call
that depends on time takes ``now`` (s, a monotonic clock the caller reads).  The commander's
glue (:mod:`parolkit.gui.class_service`) applies what changes here to the robot (a turn that
ends stops it) and the programs folder; the login (:mod:`parolkit.gui.security`) opens the
sessions; the page (:mod:`parolkit.gui.components.class_panel`) shows :meth:`Classroom.view`.

* One **teacher** role (any number of the teacher's own pages and devices) and **students**,
  each known by a name typed at the login (no account; the programs folder's name rules).
* Who may move the robot, :meth:`Classroom.may_drive`: the teacher while no student has a turn,
  else the student whose turn it is, and nobody else.  Everything else is watching.
* The **queue**: a student asks for a turn and is put at its end; the teacher orders it,
  removes a name, and hands the robot to the first (or any) student in it; the teacher takes it
  back at any moment; the student ends the turn; a turn with a time limit ends when it runs
  out.  Every end of a turn is a :class:`TurnEnd` (the caller stops the robot).
* Every refusal is a :class:`ClassroomError` whose message says why and what to do instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum

from parolkit.config import TURN_MINUTES_RANGE
from parolkit.errors import ParolkitValueError
from parolkit.gui.programs import ProgramNameError, folder_file_name

__all__ = ["PRESENCE_GRACE_S", "TEACHER", "ClassView", "Classroom", "ClassroomError", "Member", "Role", "Turn",
           "TurnEnd", "student_name", "turn_limit_s"]

#: the teacher's name wherever the page names who has the robot
TEACHER = "the teacher"
#: a student's name stays theirs this long after their last page closed (a reload, a browser
#: restarted), s; after that the same name may log in again (and gets its place back)
PRESENCE_GRACE_S = 30.0


class Role(str, Enum):
    TEACHER = "teacher"
    STUDENT = "student"


class ClassroomError(ParolkitValueError):
    """A class action refused: the message says why (and what to do instead)."""


def student_name(text: str) -> str:
    """The student name ``text`` checked with the programs folder's name rules (it names the
    student's folder, ``students/<name>``); raises ClassroomError naming the rule."""
    try:
        name = folder_file_name(text, kind="student", extension="", error=ProgramNameError)
    except ProgramNameError as exc:
        raise ClassroomError(str(exc)) from None
    if name.casefold() in ("teacher", TEACHER.casefold()):
        raise ClassroomError(f"{name!r} is the teacher's name: a student types their own name")
    return name


def turn_limit_s(minutes: float | None) -> float | None:
    """A turn's time limit in s from ``minutes`` (None or 0: no limit); ClassroomError when it
    is not a number in TURN_MINUTES_RANGE."""
    if minutes is None or (not isinstance(minutes, bool) and isinstance(minutes, (int, float)) and minutes == 0):
        return None
    lo, hi = TURN_MINUTES_RANGE
    if isinstance(minutes, bool) or not isinstance(minutes, (int, float)) or not math.isfinite(minutes) \
            or not lo <= minutes <= hi:
        raise ClassroomError(f"a turn's time limit must be {lo:g}..{hi:g} minutes, or 0 for no limit; "
                             f"got {minutes!r}")
    return float(minutes) * 60.0


@dataclass
class Member:
    """One login: the teacher or a student (``name``); ``pages``: its open pages."""

    key: str
    role: Role
    name: str
    pages: int = 0
    #: when its last page closed (or it logged in), s
    last_seen: float = 0.0

    def present(self, now: float, grace_s: float) -> bool:
        return self.pages > 0 or now - self.last_seen < grace_s


@dataclass(frozen=True)
class Turn:
    """The student ``name`` has the robot since ``started`` (s); ``limit_s``: None = no limit."""

    name: str
    started: float
    limit_s: float | None

    def left_s(self, now: float) -> float | None:
        """Seconds left of the turn (0 once it ran out), None without a limit."""
        return None if self.limit_s is None else max(0.0, self.started + self.limit_s - now)

    def over(self, now: float) -> bool:
        return self.limit_s is not None and now >= self.started + self.limit_s


@dataclass(frozen=True)
class TurnEnd:
    """The turn of ``name`` ended at ``at`` (s) because of ``reason`` (a plain sentence)."""

    name: str
    reason: str
    at: float


@dataclass(frozen=True)
class ClassView:
    """What one member's page shows of the class."""

    role: Role
    name: str
    #: this member may move the robot now
    may_drive: bool
    #: the student who has the robot; None: the teacher has it
    holder: str | None
    #: seconds left of the turn (None: no limit, or the teacher has the robot)
    left_s: float | None
    #: the waiting students, first first
    queue: tuple[str, ...]
    #: this student's place in the queue (1 = next), None when not in it
    place: int | None
    #: the time limit of a turn handed over now, s (None: no limit)
    limit_s: float | None
    #: the students logged in and present, sorted
    students: tuple[str, ...]
    #: the last turn that ended (None: none yet)
    last_end: TurnEnd | None


class Classroom:
    """The members, the queue and the turn.  Every change increments :attr:`version`."""

    def __init__(self, turn_limit_s: float | None = None, grace_s: float = PRESENCE_GRACE_S) -> None:
        if turn_limit_s is not None and not turn_limit_s > 0:
            raise ClassroomError(f"turn_limit_s must be > 0 s or None, got {turn_limit_s!r}")
        self.members: dict[str, Member] = {}
        self.queue: list[str] = []
        self.turn: Turn | None = None
        self.limit_s = turn_limit_s
        self.grace_s = grace_s
        self.last_end: TurnEnd | None = None
        self.version = 0

    def _changed(self) -> None:
        self.version += 1

    # ---- members ----

    def member(self, key: str) -> Member | None:
        return self.members.get(key)

    def join_teacher(self, key: str, now: float) -> Member:
        """A login with the teacher's password."""
        m = Member(key, Role.TEACHER, TEACHER, last_seen=now)
        self.members[key] = m
        self._changed()
        return m

    def join_student(self, key: str, text: str, now: float) -> Member:
        """A student's login with the name ``text``.  A name in use by a present student is
        refused; a name whose student is gone (no page for :attr:`grace_s`) is taken over, with
        its place in the queue and its turn (the same student back after a browser restart)."""
        name = student_name(text)
        for other in list(self.members.values()):
            if other.role is Role.STUDENT and other.name.casefold() == name.casefold():
                if other.present(now, self.grace_s):
                    raise ClassroomError(f"the name {other.name!r} is in use on another page: type another name, "
                                         "or log out on that page first")
                del self.members[other.key]
                name = other.name  # the same folder, queue place and turn
        m = Member(key, Role.STUDENT, name, last_seen=now)
        self.members[key] = m
        self._changed()
        return m

    def leave(self, key: str, now: float) -> TurnEnd | None:
        """The member logged out: a student leaves the queue, and a turn of theirs ends."""
        m = self.members.pop(key, None)
        if m is None:
            return None
        self._changed()
        if m.role is not Role.STUDENT:
            return None
        if m.name in self.queue:
            self.queue.remove(m.name)
        if self.turn is not None and self.turn.name == m.name:
            return self._end(f"{m.name} logged out", now)
        return None

    def page_opened(self, key: str, now: float) -> None:
        m = self.members.get(key)
        if m is not None:
            m.pages += 1
            m.last_seen = now
            self._changed()

    def page_closed(self, key: str, now: float) -> None:
        m = self.members.get(key)
        if m is not None:
            m.pages = max(0, m.pages - 1)
            m.last_seen = now
            self._changed()

    def _need(self, key: str, role: Role, what: str) -> Member:
        m = self.members.get(key)
        if m is None:
            raise ClassroomError(f"{what}: this page is logged out (log in again)")
        if m.role is not role:
            who = "the teacher" if role is Role.TEACHER else "a student"
            raise ClassroomError(f"{what}: only {who} may do that")
        return m

    # ---- who may move the robot ----

    def holder(self, now: float) -> str | None:
        """The student who has the robot now (None: the teacher has it; a turn that ran out
        counts as over even before :meth:`tick` ended it)."""
        turn = self.turn
        return None if turn is None or turn.over(now) else turn.name

    def may_drive(self, key: str | None, now: float) -> bool:
        """True when the member ``key`` may move or change the robot now: the teacher while no
        student has a turn, the student whose turn it is; nobody else, and no unknown key."""
        m = self.members.get(key) if key is not None else None
        if m is None:
            return False
        holder = self.holder(now)
        if m.role is Role.TEACHER:
            return holder is None
        return holder == m.name

    # ---- the queue ----

    def ask(self, key: str, now: float) -> int:
        """A student asks for a turn: put at the end of the queue; their place (1 = next)."""
        m = self._need(key, Role.STUDENT, "ask for a turn")
        if self.holder(now) == m.name:
            raise ClassroomError("ask for a turn: you have the robot now")
        if m.name not in self.queue:
            self.queue.append(m.name)
            self._changed()
        return self.queue.index(m.name) + 1

    def withdraw(self, key: str) -> None:
        """A student leaves the queue."""
        m = self._need(key, Role.STUDENT, "leave the queue")
        if m.name not in self.queue:
            raise ClassroomError("leave the queue: you are not in it")
        self.queue.remove(m.name)
        self._changed()

    def _queued(self, name: str, what: str) -> int:
        if name not in self.queue:
            raise ClassroomError(f"{what}: {name!r} is not in the queue"
                                 + (f" (waiting: {', '.join(self.queue)})" if self.queue else " (nobody waits)"))
        return self.queue.index(name)

    def move(self, key: str, name: str, places: int) -> None:
        """The teacher moves ``name`` ``places`` up (negative) or down (positive) the queue."""
        self._need(key, Role.TEACHER, "reorder the queue")
        i = self._queued(name, "reorder the queue")
        j = i + places
        if places == 0 or not 0 <= j < len(self.queue):
            raise ClassroomError(f"reorder the queue: {name} is number {i + 1} of {len(self.queue)} and cannot "
                                 f"move {places:+d}")
        self.queue.insert(j, self.queue.pop(i))
        self._changed()

    def dequeue(self, key: str, name: str) -> None:
        """The teacher takes ``name`` out of the queue."""
        self._need(key, Role.TEACHER, "remove from the queue")
        self.queue.pop(self._queued(name, "remove from the queue"))
        self._changed()

    # ---- turns ----

    def _end(self, reason: str, now: float) -> TurnEnd:
        turn = self.turn
        if turn is None:
            raise RuntimeError("Classroom._end without a turn")
        self.turn = None
        self.last_end = TurnEnd(turn.name, reason, now)
        self._changed()
        return self.last_end

    def hand_over(self, key: str, name: str | None, now: float) -> TurnEnd | None:
        """The teacher hands the robot to ``name`` (None: the first in the queue), who leaves
        the queue; a turn in progress ends first (returned).  The turn's limit is the one set
        now (:meth:`set_limit`)."""
        self._need(key, Role.TEACHER, "hand over")
        if name is None:
            if not self.queue:
                raise ClassroomError("hand over: nobody is waiting (a student presses Ask for a turn first)")
            name = self.queue[0]
        i = self._queued(name, "hand over")
        ended = self.tick(now)
        if self.turn is not None:
            ended = self._end(f"handed over to {name}", now)
        self.queue.pop(i)
        self.turn = Turn(name, now, self.limit_s)
        self._changed()
        return ended

    def take_back(self, key: str, now: float) -> TurnEnd:
        """The teacher takes the robot back (at any moment)."""
        self._need(key, Role.TEACHER, "take back")
        ended = self.tick(now)
        if ended is not None:
            return ended
        if self.turn is None:
            raise ClassroomError("take back: no student has the robot (the teacher has it)")
        return self._end("the teacher took the robot back", now)

    def end_turn(self, key: str, now: float) -> TurnEnd:
        """The student whose turn it is ends it (the robot goes back to the teacher)."""
        m = self._need(key, Role.STUDENT, "end the turn")
        if self.turn is None or self.turn.name != m.name:
            raise ClassroomError("end the turn: you do not have the robot")
        return self._end(f"{m.name} ended the turn", now)

    def set_limit(self, key: str, minutes: float | None) -> None:
        """The teacher sets the time limit of a turn (None or 0: none): for the turns handed
        over from now on and for the turn in progress (counted from its start)."""
        self._need(key, Role.TEACHER, "set the time limit")
        self.limit_s = turn_limit_s(minutes)
        if self.turn is not None:
            self.turn = replace(self.turn, limit_s=self.limit_s)
        self._changed()

    def tick(self, now: float) -> TurnEnd | None:
        """End a turn whose time ran out (returned: the caller stops the robot)."""
        turn = self.turn
        if turn is None or not turn.over(now):
            return None
        minutes = (turn.limit_s or 0.0) / 60.0
        return self._end(f"{turn.name}'s time is up ({minutes:g} min)", now)

    # ---- what a page shows ----

    def students(self, now: float) -> tuple[str, ...]:
        return tuple(sorted((m.name for m in self.members.values()
                             if m.role is Role.STUDENT and m.present(now, self.grace_s)), key=str.casefold))

    def view(self, key: str, now: float) -> ClassView | None:
        """The class as the member ``key`` sees it; None for an unknown key (logged out)."""
        m = self.members.get(key)
        if m is None:
            return None
        holder = self.holder(now)
        turn = self.turn
        left = turn.left_s(now) if turn is not None and holder is not None else None
        place = self.queue.index(m.name) + 1 if m.role is Role.STUDENT and m.name in self.queue else None
        return ClassView(role=m.role, name=m.name, may_drive=self.may_drive(key, now), holder=holder, left_s=left,
                         queue=tuple(self.queue), place=place, limit_s=self.limit_s,
                         students=self.students(now), last_end=self.last_end)
