"""The commander's link to the controller: a thin GUI layer over :class:`AsyncRobot`.

Everything on the wire (sockets, command IDs, ack matching, the ``ACK_HERE`` registration,
the renewed ``SUBSCRIBE`` stream, status and plan parsing) is the client's
(:mod:`parolkit.client`).  This module adds only what the page needs: the newest
:class:`~parolkit.client.core.RobotStatus`, a short history for the plots, the active plan
(``GET_PLAN`` whenever ``plan_seq`` changes), link up/down detection, status listeners and
event-log lines for acks and state transitions.
"""

from __future__ import annotations

import asyncio
import logging
import re
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from parolkit.client.async_robot import AsyncCommandHandle, AsyncRobot, AsyncStatusSubscription
from parolkit.client.core import AckRecord, AckStatus, PlanInfo, RobotState, RobotStatus
from parolkit.client.errors import ControllerUnreachable, ReplyError, RobotError
from parolkit.gui.eventlog import EventLog, Level, level_of_ack

__all__ = ["Sample", "ControllerLink", "joints_known"]

log = logging.getLogger(__name__)

#: no status for this long = link down, s
LINK_TIMEOUT_S = 1.0
#: while the link is down, re-send SUBSCRIBE and ACK_HERE this often (s), so a (re)started
#: controller is picked up at once rather than at the next regular renewal
RETRY_S = 0.25

#: figures in a note (replaced to tell one kind of note from another)
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?")


def joints_known(status: RobotStatus) -> bool:
    """Whether ``status``'s joint angles (and the TCP pose from them) are where the arm is.
    Not while the board homes: the firmware zeroes each joint's counter at its limit switch
    and moves from there (/work/shared/spec/board-firmware.md, "Homing"), so until the counters
    are overwritten with the standby counts at the end they count from the switches: at the
    standby pose J2 reads +55.1° (19588 steps) and J4 -143.4° (-10200).  The board emulator
    does the same; the commander shows no angles then (docs/gui.md)."""
    return status.state is not RobotState.HOMING


@dataclass(frozen=True)
class Sample:
    """One plot sample: monotonic time (s), joint angles (deg), joint speeds (deg/s);
    ``homing``: the angles count from the limit switches (:func:`joints_known`)."""

    t: float
    angles: tuple[float, ...]
    speeds: tuple[float, ...]
    homing: bool = False


class ControllerLink:
    """The commander's connection to one controller at ``host:port``.

    Commands and queries go through one :class:`AsyncRobot` on an ephemeral socket: acks of
    our commands come back to it through the controller's (ext) ``ACK_HERE`` registration,
    which the status subscription repeats with every renewal (a restarted controller learns
    it again).  ``ack_port`` is the controller's fixed ack port, kept for information only;
    the link never occupies it, so scripts and the program runner can.
    """

    def __init__(self, host: str, port: int, ack_port: int, *, every_n_ticks: int = 3,
                 event_log: EventLog | None = None, history_s: float = 30.0) -> None:
        self.host, self.port, self.ack_port = host, int(port), int(ack_port)
        self.every_n_ticks = every_n_ticks
        self.robot = AsyncRobot(host, self.port, ack_port=0, timeout=1.0)
        self.log = event_log if event_log is not None else EventLog()
        self.status: RobotStatus | None = None
        self.status_monotonic = 0.0
        self.status_count = 0
        self.history: deque[Sample] = deque()
        self.history_s = history_s
        self.plan: PlanInfo | None = None
        self._labels: dict[str, str] = {}
        self._quiet: set[str] = set()
        self._last_note: tuple[str, float] = ("", 0.0)
        self._sub: AsyncStatusSubscription | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._plan_seq_seen: int | None = None
        self._was_up = False
        self._last_error: str | None = None
        self._listeners: list[Callable[[RobotStatus], None]] = []
        #: implausible status frames already reported in the log, and when (monotonic s)
        self._implausible_logged = (0, -1e9)

    # ---- lifecycle ----

    async def start(self) -> None:
        """Open the client, subscribe to the status stream and start watching it."""
        await self.robot.open()
        self.robot.add_ack_listener(self._on_ack)
        self._sub = self.robot.subscribe(every_n=self.every_n_ticks, timeout=RETRY_S)
        await self._sub.start()
        self._tasks.append(asyncio.create_task(self._status_loop()))
        self.log.info(f"connecting to controller at {self.host}:{self.port}")

    async def close(self) -> None:
        """Stop watching, unsubscribe and close the client (idempotent)."""
        await _cancel_all(self._tasks)
        self._tasks.clear()
        if self._sub is not None:
            await self._sub.close()
        self.robot.remove_ack_listener(self._on_ack)
        await self.robot.close()

    async def _status_loop(self) -> None:
        assert self._sub is not None
        while True:
            try:
                status = await self._sub.next(timeout=RETRY_S)
            except ControllerUnreachable:  # nothing for RETRY_S
                self._check_link()
                if not self.link_up:
                    self._sub.renew()
                continue
            except ReplyError as exc:  # one bad datagram: say so once, keep going
                if str(exc) != self._last_error:
                    self._last_error = str(exc)
                    self.log.error(f"bad status datagram: {exc}")
                continue
            except StopAsyncIteration:
                return
            try:
                self._on_status(status)
            except Exception:  # a bug in a listener must not stop the link
                log.exception("status handling failed")
            self._check_link()

    def _check_link(self) -> None:
        up = self.link_up
        if up != self._was_up:
            self._was_up = up
            if up:
                self.log.add(f"controller link up ({self.host}:{self.port})", Level.SUCCESS)
            else:
                self.log.add("controller link lost: no status for 1 s", Level.ERROR)

    # ---- receiving ----

    def _on_status(self, status: RobotStatus) -> None:
        prev = self.status
        self.status = status
        self.status_monotonic = time.monotonic()
        self.status_count += 1
        self.history.append(Sample(self.status_monotonic, status.angles, status.speeds_deg_s,
                                   homing=not joints_known(status)))
        cutoff = self.status_monotonic - self.history_s
        while self.history and self.history[0].t < cutoff:
            self.history.popleft()
        self._log_transitions(prev, status)
        if status.plan_seq != self._plan_seq_seen:
            self._plan_seq_seen = status.plan_seq
            self._tasks = [t for t in self._tasks if not t.done()]
            self._tasks.append(asyncio.ensure_future(self._fetch_plan()))
        for listener in list(self._listeners):
            listener(status)

    def _log_transitions(self, prev: RobotStatus | None, new: RobotStatus) -> None:
        if prev is None:
            self.log.info(f"state {new.state}, {'simulated board' if new.board.simulated else new.board.port}")
            self._integrity_baseline(new)
            return
        if new.estop_latched and not prev.estop_latched:
            self.log.error("E-STOP latched: press Enable after releasing it")
        elif prev.estop_latched and not new.estop_latched:
            self.log.add("E-stop latch cleared", Level.SUCCESS)
        if new.errors.message and new.errors.message != prev.errors.message:
            self.log.error(f"robot error: {new.errors.message}")
        for name, bits, pbits in (("temperature", new.errors.temperature, prev.errors.temperature),
                                  ("position", new.errors.position, prev.errors.position)):
            for j, (b, pb) in enumerate(zip(bits, pbits)):
                if b and not pb:
                    self.log.error(f"J{j + 1} {name} error")
        self._log_integrity(prev, new)
        # IDLE <-> MOVING is the normal rhythm of every move and jog: not worth a log line
        routine = {prev.state, new.state} <= {RobotState.IDLE, RobotState.MOVING}
        if new.state != prev.state and not routine:
            self.log.info(f"state {prev.state} -> {new.state}")

    #: implausible status frames are reported at most this often (s): under heavy corruption
    #: they come every few ticks
    IMPLAUSIBLE_LOG_S = 5.0

    def _integrity_baseline(self, first: RobotStatus) -> None:
        """The first status of the link: the implausible frames the controller counted before
        we connected are its history, not news: only those after are logged (a GUI started
        beside a controller that had counted some logged them all at every connection)."""
        now_i = first.raw.get("integrity")
        try:
            bad = int(now_i.get("implausible", 0)) if isinstance(now_i, dict) else 0
        except (TypeError, ValueError):
            bad = 0
        self._implausible_logged = (bad, -1e9)
        if bad:
            self.log.info(f"board link: the controller has ignored {bad} implausible status frame(s) since it "
                          "started (before this commander connected)")

    def _log_integrity(self, prev: RobotStatus, new: RobotStatus) -> None:
        """Board link integrity (the status object's ``integrity``, see docs/protocol.md):
        each uncommanded motion as an error; implausible status frames as a warning with
        their count, at most every :attr:`IMPLAUSIBLE_LOG_S` s."""
        now_i = new.raw.get("integrity")
        if not isinstance(now_i, dict):
            return
        before = prev.raw.get("integrity")
        before = before if isinstance(before, dict) else {}
        try:
            unc, unc0 = int(now_i.get("uncommanded", 0)), int(before.get("uncommanded", 0))
            bad = int(now_i.get("implausible", 0))
        except (TypeError, ValueError):
            return
        if unc > unc0:
            self.log.error(f"uncommanded motion #{unc}, robot disabled: {now_i.get('last')}")
        logged, when = self._implausible_logged
        now = time.monotonic()
        if bad < logged:  # a restarted controller counts from 0 again
            self._implausible_logged = (bad, now)
        elif bad > logged and now - when >= self.IMPLAUSIBLE_LOG_S:
            self.log.add(f"board link: {bad - logged} status frame(s) ignored as implausible "
                         f"(corrupted?), {bad} in all", Level.WARNING)
            self._implausible_logged = (bad, now)

    #: the same EXECUTING note (a jog stream's every update carries it, with its own figures)
    #: is logged again only after this long (s)
    NOTE_REPEAT_S = 5.0

    def _on_ack(self, record: AckRecord) -> None:
        """Ack listener of the client: log the terminal ack of each command we labelled, and
        the notes an EXECUTING ack carries (a Cartesian jog limited in the wrist's singular
        area, a move stretched or over an acceleration limit), quiet commands included."""
        if record.id not in self._labels:
            return
        if record.terminal is None:
            latest = record.latest
            if latest is not None and latest[0] is AckStatus.EXECUTING and latest[1]:
                self._note(self._labels[record.id], latest[1])
            return
        status, details = record.terminal
        label = self._labels.pop(record.id)
        quiet = record.id in self._quiet
        self._quiet.discard(record.id)
        level = level_of_ack(status.value)
        if not quiet or level is Level.ERROR:
            self.log.add(f"{label} {status.value.lower()}{f': {details}' if details else ''}", level)

    def _note(self, label: str, details: str) -> None:
        now = time.monotonic()
        kind = _NUMBER.sub("#", details)  # each update's figures differ: the same note all the same
        last, when = self._last_note
        if kind == last and now - when < self.NOTE_REPEAT_S:
            return
        self._last_note = (kind, now)
        level = Level.WARNING if "warning" in details or "stopped" in details else Level.INFO
        self.log.add(f"{label}: {details}", level)

    async def _fetch_plan(self) -> None:
        try:
            self.plan = await self.robot.plan_info()
        except RobotError as exc:
            self.plan = None
            log.debug("GET_PLAN failed: %s", exc)

    # ---- state and sending ----

    @property
    def link_up(self) -> bool:
        """True while statuses arrive (the last one less than LINK_TIMEOUT_S ago)."""
        return self.status is not None and time.monotonic() - self.status_monotonic < LINK_TIMEOUT_S

    def add_listener(self, listener: Callable[[RobotStatus], None]) -> None:
        """Call ``listener(status)`` for every status received."""
        self._listeners.append(listener)

    def remove_listener(self, listener: Callable[[RobotStatus], None]) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def send(self, text: str, *, label: str | None = None, quiet: bool = False) -> str:
        """Send one command body (``JOG|...``) with a fresh ID and return the ID at once.

        Its terminal ack is logged, labelled ``label`` (default: the command word); with
        ``quiet`` only FAILED / INVALID acks are logged.  Raises
        :class:`~parolkit.client.errors.RobotError` when the link is not started."""
        return self.submit(text, label=label, quiet=quiet).id

    def submit(self, text: str, *, label: str | None = None, quiet: bool = False) -> AsyncCommandHandle:
        """:meth:`send`, returning the command's handle (``await handle.result(...)`` waits
        for its terminal ack, ``handle.done()`` says whether it came)."""
        handle = self.robot.send_nowait(text)
        self._labels[handle.id] = label or text.split("|", 1)[0]
        if quiet:
            self._quiet.add(handle.id)
        return handle


async def _cancel_all(tasks: list[asyncio.Task[None]], limit_s: float = 2.0) -> None:
    """Cancel ``tasks`` and wait until they have ended, cancelling again while they run: on
    Python 3.11 ``asyncio.wait_for`` (used by a subscription's ``next``) can swallow a
    cancellation that arrives just as its datagram does (a race fixed in 3.12), and a plain
    ``await task`` would then wait forever, holding up the commander's shutdown. Gives up
    after ``limit_s``."""
    pending = set(tasks)
    deadline = time.monotonic() + limit_s
    while pending:
        for t in pending:
            t.cancel()
        done, pending = await asyncio.wait(pending, timeout=0.05)
        for t in done:
            if not t.cancelled() and t.exception() is not None:
                log.debug("link task ended with %r", t.exception())
        if pending and time.monotonic() > deadline:
            log.warning(
                "%d link task(s) did not stop within %g s", len(pending), limit_s)
            return
