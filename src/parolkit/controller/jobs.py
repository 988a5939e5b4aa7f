"""Accepted commands (:class:`Job`) and their queue (:class:`JobQueue`): admission, order, the
running one, and every ack after QUEUED.

One owner (the controller core's update); no locking.  Acks are collected, never sent from
here: the driver sends them after it published the snapshot of the same tick (an ack never
reports what the status does not show yet).
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, field

from parolkit._frozen import quick_init
from parolkit.controller.activities import WARNING_PREFIX, Activity, Samples
from parolkit.controller.messages import Ack, AckRoute
from parolkit.protocol.commands import AckStatus, Command

__all__ = ["Job", "JobQueue", "QueueEntry", "QueueView"]

log = logging.getLogger("parolkit.controller")


@dataclass
class Job:
    """One accepted command, from QUEUED to its terminal ack."""

    seq: int
    command: Command
    command_id: str | None
    #: where acks go: one or more (host, port) pairs, or None without a command ID
    ack_addr: AckRoute | None
    #: who sent it (see Submission.client)
    client: str = ""
    #: the plan: start/final joint angles (deg) it assumes, or None
    start_deg: tuple[float, ...] | None = None
    final_deg: tuple[float, ...] | None = None
    planned: bool = False
    plan_error: str | None = None
    trajectory: object | None = None
    #: trajectory samples as Python lists (positions, speeds, commands), built off the tick
    samples: Samples | None = None
    notes: tuple[str, ...] = ()
    #: a plan was asked for (its request key), not yet answered
    planning: int | None = None
    #: the key of the plan the server asked for ahead of the tick, until it is answered
    ahead: int | None = None
    #: streaming jog (replaces the previous one instead of queueing)
    streamed: bool = False
    #: streamed Cartesian jog planned from where the running streamed jog was commanded:
    #: (that jog's activity, its sample index then), to line the two up when it takes over
    stream_anchor: tuple[Activity, int] | None = None
    #: streamed Cartesian jog: where the running jog's plan was when this one was planned
    #: from its commanded position (a ``parolkit.motion.cartesian.JogStart``: its path's
    #: orientation and joint speeds there), so the update continues it; None otherwise
    jog_start: object | None = None
    terminal: AckStatus | None = None
    #: blending (issue 24): the numbers of the queued jobs this one's plan blends into, as
    #: asked (``chain_asked``) and as planned (``chain``); ``marks``: for it and each of them
    #: but the last, the sample after which it is done; ``rider_of``: the number of the job
    #: whose plan plays this one (a follower of a blended chain)
    chain_asked: tuple[int, ...] = ()
    chain: tuple[int, ...] = ()
    marks: tuple[int, ...] = ()
    rider_of: int | None = None
    #: the collision world its plan was checked in (``parolkit.controller.world.CollisionWorld``;
    #: None: not planned): it runs only in that world, else it is planned again
    world: object | None = None

    @property
    def name(self) -> str:
        return self.command.name

    @property
    def warnings(self) -> tuple[str, ...]:
        """The plan's notes that are warnings (``warning: ...``, e.g. a move with t that needs
        more than a joint's acceleration limit): added to the details of this job's EXECUTING
        and COMPLETED acks (see :meth:`ack_details`)."""
        return tuple(n for n in self.notes if n.startswith(WARNING_PREFIX))

    @property
    def label(self) -> str:
        """The command in ack details: its class name (``MoveJoint``, ``SmoothCircle``, ``CartJog``)."""
        return type(self.command).__name__.removesuffix("Command")

    def ack_details(self, status: AckStatus, details: str) -> str:
        """The details text of this job's ack with ``status``, built here only.

        COMPLETED says ``details`` or, when the activity gave none, ``<label> finished
        successfully`` (the original controller's "MoveJointCommand finished successfully");
        EXECUTING and COMPLETED then carry :attr:`warnings`, joined with ``"; "`` (a text
        already in ``details`` is not repeated).  Other statuses keep ``details`` as they are."""
        if status is AckStatus.COMPLETED and not details:
            details = f"{self.label} finished successfully"
        if status not in (AckStatus.EXECUTING, AckStatus.COMPLETED) or not self.warnings:
            return details
        parts = [details] if details else []
        parts += [w for w in self.warnings if w and w not in details]
        return "; ".join(parts)

    def set_plan(self, start: tuple[float, ...], trajectory: object, samples: Samples,
                 final: tuple[float, ...], notes: tuple[str, ...]) -> None:
        self.trajectory, self.samples, self.start_deg, self.final_deg = trajectory, samples, start, final
        self.notes = notes
        self.plan_error = None
        self.planned = True

    def set_plan_error(self, start: tuple[float, ...], error: str) -> None:
        self.start_deg, self.final_deg, self.planned, self.plan_error = start, start, True, error

    def ride(self, head: Job) -> None:
        """This job is played by ``head``'s blended plan: planned, ending where it ends."""
        self.rider_of = head.seq
        self.trajectory, self.samples = head.trajectory, head.samples
        self.start_deg, self.final_deg = head.start_deg, head.final_deg
        self.planned, self.plan_error = True, None


@quick_init
@dataclass(frozen=True)
class QueueEntry:
    """One command in the queue view: its ID (shown to its own client only), name, client."""

    command_id: str | None
    name: str
    client: str


@quick_init
@dataclass(frozen=True)
class QueueView:
    """GET_QUEUE as plain data (the snapshot formats it per viewer)."""

    active: QueueEntry | None = None
    progress: float = 0.0
    waiting: tuple[QueueEntry, ...] = field(default_factory=tuple)


class JobQueue:
    """The accepted commands in order, the running one (with its activity) and the acks they
    produced since the driver last took them."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.waiting: deque[Job] = deque()
        self.active: Job | None = None
        self.activity: Activity | None = None
        #: a streamed CARTJOG waiting for its plan (stream mode: it replaces the running jog)
        self.stream_cart: Job | None = None
        self._acks: list[Ack] = []
        self._seq = 0

    def new_job(self, command: Command, command_id: str | None, route: AckRoute | None, client: str = "") -> Job:
        self._seq += 1
        return Job(self._seq, command, command_id, route, client)

    def ack(self, job: Job, status: AckStatus, details: str = "") -> None:
        """``job``'s ack (nothing after its terminal one)."""
        if job.terminal is not None:
            return
        details = job.ack_details(status, details)
        if status.terminal:
            job.terminal = status
        if job.command_id is not None and job.ack_addr is not None:
            self._acks.append(Ack(job.command_id, job.ack_addr, status, details))
        elif status is AckStatus.FAILED:
            log.warning("%s failed: %s", job.name, details)

    def take_acks(self) -> list[Ack]:
        acks, self._acks = self._acks, []
        return acks

    @property
    def busy(self) -> bool:
        """Something runs or waits."""
        return self.active is not None or bool(self.waiting) or self.stream_cart is not None

    def admit(self, job: Job) -> bool:
        """Queue ``job`` (QUEUED ack, with its position) or refuse it when full (FAILED ack)."""
        if len(self.waiting) >= self.size:
            self.ack(job, AckStatus.FAILED, f"queue full ({self.size} commands): wait for acks or send STOP")
            return False
        self.waiting.append(job)
        ahead = len(self.waiting) + (1 if self.active is not None else 0)
        self.ack(job, AckStatus.QUEUED, f"Position {ahead} in queue")
        return True

    def start(self, job: Job, activity: Activity, details: str = "") -> None:
        """``job`` runs from now on (EXECUTING)."""
        self.active, self.activity = job, activity
        self.ack(job, AckStatus.EXECUTING, details)

    def hand_over(self, job: Job, details: str = "") -> None:
        """The running job is done where ``job`` (the next waiting one, planned with it and
        played by the same activity: a blended chain) goes on: COMPLETED for it, EXECUTING for
        ``job``; the activity runs on."""
        assert self.waiting and self.waiting[0] is job
        self.waiting.popleft()
        old = self.active
        self.active = job
        if old is not None:
            self.ack(old, AckStatus.COMPLETED, details)
        self.ack(job, AckStatus.EXECUTING, "blended: the arm did not stop")

    def end_active(self, status: AckStatus, details: str = "") -> Job | None:
        """The running job ends with ``status`` (its activity's warnings join its acks)."""
        job, act = self.active, self.activity
        self.active = self.activity = None
        if job is not None:
            if act is not None and act.warnings:
                job.notes = (*job.notes, *act.warnings)
            self.ack(job, status, details)
        return job

    def cancel_all(self, reason: str) -> int:
        """Cancel the running job, every waiting one and a streamed jog waiting for its plan
        (CANCELLED acks).  Returns how many."""
        n = 0
        if self.active is not None:
            self.end_active(AckStatus.CANCELLED, reason)
            n += 1
        return n + self.cancel_waiting(reason)

    def cancel_waiting(self, reason: str) -> int:
        """Cancel every waiting job and a streamed jog waiting for its plan (CANCELLED acks),
        not the running one.  Returns how many."""
        n = 0
        while self.waiting:
            self.ack(self.waiting.popleft(), AckStatus.CANCELLED, reason)
            n += 1
        if self.stream_cart is not None:
            self.ack(self.stream_cart, AckStatus.CANCELLED, reason)
            self.stream_cart = None
            n += 1
        return n

    def fail_waiting(self, reason: str) -> None:
        """Every waiting job (and a streamed jog waiting for its plan) FAILED with ``reason``."""
        while self.waiting:
            self.ack(self.waiting.popleft(), AckStatus.FAILED, reason)
        if self.stream_cart is not None:
            self.ack(self.stream_cart, AckStatus.FAILED, reason)
            self.stream_cart = None

    def view(self) -> QueueView:
        def entry(job: Job) -> QueueEntry:
            return QueueEntry(job.command_id, job.name, job.client)

        a = self.active
        return QueueView(entry(a) if a is not None else None,
                         self.activity.progress if self.activity is not None else 0.0,
                         tuple(entry(j) for j in self.waiting))
