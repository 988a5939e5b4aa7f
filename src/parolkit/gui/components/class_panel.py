"""A class on one page (NiceGUI): who this page is, the turn queue, the greyed controls of a
page that watches, and the server's gate in front of every event of the page.

* **The header** shows this page's part (``class-chip``: *Bob · watching · Alice has the robot*,
  *Alice · your turn · 4:32 left*, *Teacher · you have the robot*) and the one action it needs
  most (``class-action``: Ask for a turn, Leave the queue, End my turn; the teacher's Hand over
  to <next> or Take back).
* **The Class card** lists the queue; the teacher orders it, removes a name, hands the robot to
  anyone in it, takes it back, sets the time limit and opens the students' programs.
* **Watching**: every control that moves or changes the robot is greyed (``inert``, so it takes
  no click, tap, key or focus, and ``aria-disabled``), Stop and E-STOP never.
* **The gate** (:func:`install_gate`): every event the page sends is checked on the server
  against the class as it is when the event arrives, never against what the page shows: a page
  that may not move the robot gets only the events of Stop, E-STOP, the keys' Stop / E-STOP
  (:meth:`~parolkit.gui.app.CommanderPage.on_key` judges those), the view (tabs, dialogs, menus,
  tooltips, the 3D view asking for its objects, the editor following the program) and its class
  controls (whose handlers check the role) through; every other event
  is refused, logged and said on the page.  Each event runs with
  :data:`~parolkit.gui.class_service.ACTING` set to the page's member, so what the commander
  sends later for it is checked again (:meth:`ClassService.refuse`).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable
from typing import Any

from nicegui import ui
from nicegui.client import Client
from nicegui.element import Element

from parolkit.config import TURN_MINUTES_RANGE
from parolkit.gui.class_service import ACTING, ClassService
from parolkit.gui.classroom import TEACHER, ClassroomError, ClassView, Role

__all__ = ["ClassPanel", "OPEN_EVENTS", "OPEN_TESTIDS", "VIEW_EVENTS", "VIEW_ONLY", "install_gate"]

#: the controls every page may press, watching or not (Stop, E-STOP, help, log out)
OPEN_TESTIDS = frozenset({"btn-stop", "btn-estop", "help-button", "btn-logout"})
#: elements whose events change only what this page shows (their value: the open tab, a dialog
#: or menu opened or closed, a tooltip)
VIEW_ONLY: tuple[type[Element], ...] = (ui.tabs, ui.tab, ui.tab_panels, ui.dialog, ui.menu, ui.tooltip,
                                        ui.expansion)
#: the events of elements that draw what the page shows, which a watching page needs too: the 3D
#: view's scene asks for its objects (``init``), the editor reports where its lines are
VIEW_EVENTS: tuple[tuple[type[Element], frozenset[str]], ...] = (
    (ui.scene, frozenset({"init"})), (ui.codemirror, frozenset({"anchor-positions"})))
#: the page's own events (commander.js) a watching page may send: E-STOP, and the keys (on_key
#: lets only Stop and E-STOP through for a page that watches)
OPEN_EVENTS = frozenset({"pk_estop", "pk_key",
                         # the gamepad's state: its indicator follows it on every page; the drive
                         # itself starts only for a page that may move the robot (may_start)
                         "pk_gamepad"})
#: the editor's messages (gui/editor_sync.py) a watching page may send: it follows the program
#: live; a change it pushes is refused and answered as a hello (the page gets the text back)
DOC_EVENT, DOC_FOLLOW = "pk_doc", frozenset({"hello", "since"})
#: a refused event is said on the page at most this often, s (a pointer sends several)
NOTIFY_EVERY_S = 1.0


def _describe(sender: Element, kind: str) -> str:
    props = sender.props
    name = props.get("data-testid") or props.get("aria-label") or type(sender).__name__
    return f"{name} ({kind})" if kind else str(name)


def _doc_op(msg: dict[str, Any]) -> object:
    """The ``op`` of an editor message (its one argument, JSON as NiceGUI sends it)."""
    args = msg.get("args")
    try:
        obj = json.loads(args[0]) if isinstance(args, list) and len(args) == 1 and isinstance(args[0], str) else None
    except ValueError:
        return None
    return obj.get("op") if isinstance(obj, dict) else None


def install_gate(client: Client, service: ClassService, key: str, open_ids: set[int],
                 on_refused: Callable[[str], None]) -> None:
    """Put the class's check in front of every event of ``client`` (the page of the member
    ``key``): see the module's docstring.  ``open_ids``: the ids of the page's class controls."""
    handle = client.handle_event
    layout_id = client.layout.id

    def allowed(sender: Element, kind: str, msg: dict[str, Any]) -> bool:
        if service.may_drive(key) or sender.id in open_ids or isinstance(sender, VIEW_ONLY):
            return True
        if any(isinstance(sender, t) and kind in kinds for t, kinds in VIEW_EVENTS):
            return True
        if sender.id == layout_id:
            if kind == DOC_EVENT:
                return _doc_op(msg) in DOC_FOLLOW
            return kind in OPEN_EVENTS
        return sender.props.get("data-testid") in OPEN_TESTIDS

    def gated(msg: dict[str, Any]) -> None:
        sender = client.elements.get(msg.get("id", -1))
        token = ACTING.set(key)
        try:
            if sender is None:
                handle(msg)  # nothing to run: NiceGUI drops it
                return
            listener = sender._event_listeners.get(msg.get("listener_id", ""))  # the event's type
            kind = listener.type if listener is not None else ""
            if allowed(sender, kind, msg):
                handle(msg)
                return
            with client:
                on_refused(_describe(sender, kind))
            if kind == DOC_EVENT:  # the page's editor gets the document's text back
                handle({**msg, "args": [json.dumps({"op": "hello"})]})
        finally:
            ACTING.reset(token)

    client.handle_event = gated  # type: ignore[method-assign]


def _clock(seconds: float) -> str:
    s = int(seconds + 0.999)
    return f"{s // 60}:{s % 60:02d}"


def chip_text(view: ClassView | None) -> str:
    """The header's word on this page's part in the class."""
    if view is None:
        return "logged out · log in again"
    left = f" · {_clock(view.left_s)} left" if view.left_s is not None else ""
    if view.role is Role.TEACHER:
        if view.holder is None:
            return "Teacher · you have the robot"
        return f"Teacher · {view.holder} has the robot{left}"
    if view.may_drive:
        return f"{view.name} · your turn{left}"
    holder = view.holder or TEACHER
    place = f" · number {view.place} in the queue" if view.place is not None else ""
    return f"{view.name} · watching · {holder} has the robot{place}"


class ClassPanel:
    """This page's part in the class: the header chip and action, the Class card, the locks."""

    def __init__(self, service: ClassService, key: str, *, header_box: Element, card_box: Element,
                 lockable: Iterable[Element]) -> None:
        self.s = service
        self.key = key
        self.lockable = list(lockable)
        self.open_ids: set[int] = set()
        #: the queue's rows by student name
        self._rows: dict[str, _QueueRow] = {}
        self._shown: tuple[object, ...] | None = None
        self._locked: bool | None = None
        self._last_notice = (0.0, "")
        with header_box:
            self.chip = ui.chip("", icon="school", color="blue-grey-9") \
                .props('data-testid=class-chip role=status aria-live=polite').classes("pk-class-chip")
            self.action = self._open(ui.button("", on_click=self._main_action)
                                     .props("unelevated dense no-caps color=teal-9 data-testid=class-action")
                                     .classes("px-2"))
        with card_box, ui.card().classes("pk-card w-full pk-class-card") \
                .props('role=region aria-label="Class" data-testid=class-card'):
            with ui.row().classes("items-center gap-2 w-full"):
                ui.label("Class").classes("pk-title")
                self.state = ui.label("").classes("text-sm").props("data-testid=class-state")
            self.notice = ui.label("").classes("text-xs pk-muted").props("data-testid=class-notice")
            self.empty = ui.label("Nobody is waiting: a student presses Ask for a turn.") \
                .classes("text-sm pk-muted").props("data-testid=class-queue-empty")
            self.queue_box = ui.column().classes("gap-1 w-full").props('data-testid=class-queue role=list '
                                                                       'aria-label="Queue"')
            view = self.s.view(key)
            self.teacher_row: Element | None = None
            if view is not None and view.role is Role.TEACHER:
                with ui.row().classes("items-center gap-2 w-full") as self.teacher_row:
                    lo, hi = TURN_MINUTES_RANGE
                    limit = view.limit_s / 60 if view.limit_s is not None else 0
                    self.limit_input = self._open(
                        ui.number("turn (min, 0 = no limit)", value=limit, min=0, max=hi, step=0.5)
                        .props(f'dense data-testid=class-limit aria-label="time limit of a turn, minutes '
                               f'({lo:g}..{hi:g}, 0 = no limit)"').classes("w-44"))
                    self._open(ui.button("Set", on_click=self._set_limit)
                               .props("flat dense no-caps color=grey-4 data-testid=class-limit-set"))
                    self._open(ui.button("Students' programs", icon="folder_shared", on_click=self._programs)
                               .props("flat dense no-caps color=grey-4 data-testid=class-programs"))
        self.update()

    def _open(self, element: Any) -> Any:
        """A class control: its events pass the gate (its handler checks the role)."""
        self.open_ids.add(element.id)
        return element

    # ---- the gate's refusals ----

    def refused(self, what: str) -> None:
        """An event the gate refused: logged and said on the page (the same refusal at most
        once a second: a pointer sends several events)."""
        now = time.monotonic()
        text = f"{what} refused: {self.s.watching_text(self.key)}"
        if text == self._last_notice[1] and now - self._last_notice[0] < NOTIFY_EVERY_S:
            return
        self._last_notice = (now, text)
        self.s.c.log.error(text)
        ui.notify(text, type="warning")

    # ---- actions (each checked by the classroom: role and turn) ----

    def _do(self, action: Callable[[], object]) -> None:
        try:
            action()
        except ClassroomError as exc:
            ui.notify(str(exc), type="negative", multi_line=True)
            self.s.c.log.error(str(exc))
        self.update()

    def _main_action(self) -> None:
        view = self.s.view(self.key)
        if view is None:
            return
        if view.role is Role.TEACHER:
            self._do(lambda: self.s.take_back(self.key) if view.holder is not None else self.s.hand_over(self.key))
        elif view.may_drive:
            self._do(lambda: self.s.end_turn(self.key))
        elif view.place is not None:
            self._do(lambda: self.s.withdraw(self.key))
        else:
            self._do(lambda: self.s.ask(self.key))

    def _set_limit(self) -> None:
        value = self.limit_input.value
        self._do(lambda: self.s.set_limit(self.key, None if value is None else float(value)))

    async def _programs(self) -> None:
        """The teacher's dialog: every student's programs; Open loads one into the editor."""
        programs = self.s.student_programs()
        before = set(self.open_ids)
        with ui.dialog().props('aria-label="Students\' programs"') as dlg, \
                ui.card().classes("pk-card").style("min-width: 360px"):
            ui.label("Students' programs").classes("font-bold")
            ui.label(str(self.s.root / "students")).classes("text-xs pk-muted pk-mono")
            if not programs:
                ui.label("no student has a program yet").classes("text-sm pk-muted")
            with ui.column().classes("gap-0 w-full").style("max-height: 420px; overflow-y: auto"):
                for student, names in programs.items():
                    ui.label(f"{student} ({len(names)})").classes("text-sm font-bold q-mt-sm")
                    for n in names:
                        self._open(ui.button(n, on_click=lambda s=student, n=n: dlg.submit((s, n)))
                                   .props("flat dense no-caps align=left data-testid=class-program-item")
                                   .classes("w-full"))
            self._open(ui.button("Close", on_click=lambda: dlg.submit(None)).props("flat"))
        chosen = await dlg
        dlg.delete()
        self.open_ids &= before
        if isinstance(chosen, tuple):
            student, name = chosen
            self._do(lambda: self.s.open_student_program(self.key, student, name))

    # ---- what the page shows ----

    def update(self) -> None:
        """Follow the class (every 0.1 s; the page changes only when what it shows does)."""
        view = self.s.view(self.key)
        left = None if view is None or view.left_s is None else int(view.left_s + 0.999)
        key = (self.s.room.version, left, None if view is None else view.may_drive)
        if key == self._shown:
            return
        self._shown = key
        self._lock(view is None or not view.may_drive)
        self.chip.set_text(chip_text(view))
        self.chip.props(f"color={'teal-9' if view is not None and view.may_drive else 'blue-grey-9'}")
        self._show_action(view)
        self._show_card(view)

    def _lock(self, locked: bool) -> None:
        if locked == self._locked:
            return
        self._locked = locked
        for el in self.lockable:
            if locked:
                el.props("inert aria-disabled=true").classes(add="pk-locked")
            else:
                el.props(remove="inert aria-disabled").classes(remove="pk-locked")

    def _show_action(self, view: ClassView | None) -> None:
        text = ""
        if view is not None and view.role is Role.TEACHER:
            text = "Take back" if view.holder is not None else (f"Hand over to {view.queue[0]}" if view.queue else "")
        elif view is not None:
            text = "End my turn" if view.may_drive else ("Leave the queue" if view.place is not None
                                                           else "Ask for a turn")
        self.action.set_text(text)
        self.action.props(f'aria-label="{text}"')
        self.action.set_visibility(bool(text))

    def _show_card(self, view: ClassView | None) -> None:
        if view is None:
            self.state.set_text("this page is logged out: log in again")
            self.notice.set_text("")
            self._sync_queue(None)
            return
        holder = view.holder or TEACHER
        left = f", {_clock(view.left_s)} left" if view.left_s is not None else ""
        limit = "no time limit" if view.limit_s is None else f"a turn lasts {view.limit_s / 60:g} min"
        self.state.set_text(f"{holder} has the robot{left} · {len(view.students)} student(s) here · {limit}")
        self.notice.set_text(
            "" if view.may_drive else
            "You are watching: the controls that move or change the robot are greyed. Stop and E-STOP work "
            "from every page.")
        self._sync_queue(view)

    def _sync_queue(self, view: ClassView | None) -> None:
        """The queue's rows, one per waiting student, kept by name: a row is made when its
        student joins and deleted when they leave, and only moved and renumbered otherwise, so a
        button pressed while the queue changes (another student asking) still reaches its row
        (a row made anew would have a new id, and the press on the old one would be lost)."""
        names = list(view.queue) if view is not None else []
        for name in [n for n in self._rows if n not in names]:
            gone = self._rows.pop(name)
            self.open_ids -= gone.ids
            gone.element.delete()
        self.empty.set_visibility(view is not None and not names)
        for i, name in enumerate(names):
            assert view is not None
            row = self._rows.get(name) or self._queue_row(view.role, name)
            self._rows[name] = row
            if self.queue_box.default_slot.children.index(row.element) != i:
                row.element.move(target_index=i)
            row.show(i, len(names), bold=view is not None and name == view.name)

    def _queue_row(self, role: Role, name: str) -> _QueueRow:
        with self.queue_box, ui.row().classes("items-center gap-1 w-full pk-class-row").props(
                f'role=listitem data-testid=class-queue-item data-name="{name}"') as element:
            row = _QueueRow(element, ui.label(name).classes("text-sm grow"), name)
            if role is not Role.TEACHER:
                return row
            k = self.key

            def button(icon: str, label: str, testid: str, action: Callable[[], object], text: str = "") -> Any:
                look = "flat dense no-caps color=teal-4" if text else "flat dense round color=grey-4"
                b = self._open(ui.button(text, icon=icon, on_click=lambda: self._do(action))
                               .props(f'{look} aria-label="{label}" data-testid={testid}'))
                row.ids.add(b.id)
                return b

            button("front_hand", f"Hand the robot to {name}", "class-hand-over", lambda: self.s.hand_over(k, name),
                   "Hand over")
            row.up = button("arrow_upward", f"Move {name} up", "class-up", lambda: self.s.move(k, name, -1))
            row.down = button("arrow_downward", f"Move {name} down", "class-down", lambda: self.s.move(k, name, 1))
            button("close", f"Remove {name} from the queue", "class-remove", lambda: self.s.dequeue(k, name))
        return row


class _QueueRow:
    """One waiting student's row of the Class card (the teacher's has its buttons)."""

    def __init__(self, element: Element, label: ui.label, name: str) -> None:
        self.element = element
        self.label = label
        self.name = name
        self.up: ui.button | None = None
        self.down: ui.button | None = None
        #: the ids of its buttons (open to the gate while the row exists)
        self.ids: set[int] = set()
        self._shown: tuple[int, int, bool] | None = None

    def show(self, i: int, count: int, *, bold: bool) -> None:
        """Its place ``i`` (from 0) of ``count``; the page's own name in bold."""
        if (i, count, bold) == self._shown:
            return
        self._shown = (i, count, bold)
        self.label.set_text(f"{i + 1}. {self.name}")
        if bold:
            self.label.classes(add="font-bold")
        else:
            self.label.classes(remove="font-bold")
        if self.up is not None and self.down is not None:
            self.up.set_enabled(i > 0)
            self.down.set_enabled(i < count - 1)
