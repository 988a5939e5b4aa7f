"""Who controls the robot, as the commander shows it (the control lease, docs/protocol.md).

The commander is one client of the controller: its :class:`~parolkit.gui.link.ControllerLink`
socket (``ACK_HERE``) takes the lease implicitly with its first command, keeps it while it
commands and lets it lapse when idle (it sends nothing to keep it: queries and subscription
renewals do not count).  Its program runner is a second client (its own ``Robot``); the link
hands the lease over to it when a program starts.

:class:`ControlWatch` asks ``GET_CONTROL`` about once a second (and at once after a command
was refused because another client holds the lease) and turns the answer into a
:class:`ControlView` for the header badge; :meth:`ControlWatch.take_over` is the operator's
"Take control" (``CONTROL|TAKE|FORCE``: the controller cancels the other client's commands).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any

from parolkit.client.core import bind_address
from parolkit.client.errors import RobotError
from parolkit.client.robot_api import build_control

__all__ = ["ControlView", "ControlWatch", "Holder", "describe_control", "local_host_for", "POLL_S"]

log = logging.getLogger(__name__)

#: GET_CONTROL period, s
POLL_S = 1.0


class Holder(str, Enum):
    """Who holds the lease, from the commander's point of view."""

    UNKNOWN = "unknown"  # no answer yet (controller unreachable)
    FREE = "free"
    US = "us"  # the commander's link
    RUNNER = "runner"  # the commander's program runner
    OTHER = "other"


@dataclass(frozen=True)
class ControlView:
    """The badge: ``holder`` kind, the holder's address as the controller names it, the text
    and a Quasar colour; ``can_take`` when the "Take control" button applies."""

    holder: Holder
    address: str | None
    text: str
    colour: str

    @property
    def can_take(self) -> bool:
        return self.holder is Holder.OTHER


def local_host_for(controller_host: str) -> str | None:
    """The address the controller sees our client sockets come from, when it is certain:
    127.0.0.1 for a controller on this machine (client sockets bind loopback for it)."""
    return "127.0.0.1" if bind_address(controller_host) == "127.0.0.1" else None


def _is_address(holder: str, port: int | None, host: str | None) -> bool:
    """True when the controller's name for the holder (``host:port``) is the client socket on
    local ``port`` (and ``host`` when known: through NAT only the port may be recognisable)."""
    if port is None:
        return False
    h, sep, p = holder.rpartition(":")
    if not sep or p != str(port):
        return False
    return host is None or h.strip("[]") == host


def describe_control(info: dict[str, Any] | None, link_port: int | None, runner_port: int | None,
                     local_host: str | None) -> ControlView:
    """The badge for a ``GET_CONTROL`` answer (None: no answer).  ``link_port`` /
    ``runner_port``: local UDP ports of the commander's link and program runner sockets;
    ``local_host``: their address as the controller sees it (127.0.0.1 for a controller on
    this machine), None when unknown."""
    if info is None:
        return ControlView(Holder.UNKNOWN, None, "Control: unknown (no answer)", "grey-8")
    holder = info.get("holder")
    secret = " · secret required" if info.get("secret_required") else ""
    if holder is None:
        return ControlView(Holder.FREE, None, f"Nobody controls the robot{secret}", "blue-grey-8")
    holder = str(holder)
    if _is_address(holder, link_port, local_host):
        return ControlView(Holder.US, holder, "You control the robot", "positive")
    if _is_address(holder, runner_port, local_host):
        return ControlView(Holder.RUNNER, holder, "Your program controls the robot", "positive")
    return ControlView(Holder.OTHER, holder, f"Controlled by {holder}", "deep-orange-10")


class ControlWatch:
    """Polls ``GET_CONTROL`` through the link's client and keeps the current :class:`ControlView`.

    ``robot``: the link's :class:`~parolkit.client.async_robot.AsyncRobot`; ``send``: the
    link's ``send(body, label=..., quiet=...)``; ``runner_port``: a callable giving the
    program runner's local port while it runs (else None); ``secret``: the controller's
    shared secret (``controller.secret``) when it has one.
    """

    def __init__(self, robot: Any, send: Callable[..., str], *, local_host: str | None,
                 runner_port: Callable[[], int | None] = lambda: None, secret: str | None = None,
                 poll_s: float = POLL_S) -> None:
        self.robot = robot
        self._send = send
        self.local_host = local_host
        self.runner_port = runner_port
        self.secret = secret
        self.poll_s = poll_s
        self.info: dict[str, Any] | None = None
        self.view = describe_control(None, None, None, local_host)
        #: bumped on every change of :attr:`view`
        self.version = 0
        self._take_sent = False  # a CONTROL|TAKE|secret not yet confirmed by GET_CONTROL
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

    # ---- polling ----

    def start(self) -> None:
        """Start polling (in the running event loop) and watch the link's acks for refusals."""
        self._loop = asyncio.get_running_loop()
        self.robot.add_ack_listener(self._on_ack)
        self._task = asyncio.ensure_future(self._poll())

    def _on_ack(self, record: Any) -> None:
        """A command of ours refused because another client holds the lease: ask at once."""
        if record.terminal is not None and "controlled by" in (record.terminal[1] or ""):
            self.refresh_soon()

    async def stop(self) -> None:
        self.robot.remove_ack_listener(self._on_ack)
        if self._task is not None:
            self._task.cancel()
            try:
                await self._task
            except (asyncio.CancelledError, Exception):
                pass
            self._task = None

    def refresh_soon(self) -> None:
        """Ask again now (a command was refused, control was taken or released); callable
        from any thread (the program runner's)."""
        loop = self._loop
        if loop is None or loop.is_closed():
            return
        try:
            same = asyncio.get_running_loop() is loop
        except RuntimeError:
            same = False
        if same:
            self._wake.set()
        else:
            loop.call_soon_threadsafe(self._wake.set)

    async def _poll(self) -> None:
        while True:
            await self.refresh()
            self._wake.clear()
            try:
                await asyncio.wait_for(self._wake.wait(), self.poll_s)
            except TimeoutError:
                pass

    async def refresh(self) -> ControlView:
        """One ``GET_CONTROL``; updates :attr:`view`."""
        try:
            info = await self.robot.control()
        except RobotError as exc:
            log.debug("GET_CONTROL failed: %s", exc)
            info = None
        self._set(info if isinstance(info, dict) else None)
        return self.view

    def _set(self, info: dict[str, Any] | None) -> None:
        self.info = info
        self._take_sent = False
        view = describe_control(info, self.robot.ack_port, self.runner_port(), self.local_host)
        if view != self.view:
            self.view = view
            self.version += 1

    # ---- acting ----

    @property
    def mine(self) -> bool:
        """True while the last answer named the commander's link as the holder."""
        return self.view.holder is Holder.US

    def take_over(self) -> str:
        """Send ``CONTROL|TAKE|FORCE`` (with the secret if configured): the controller gives
        the lease to the commander and cancels the previous holder's commands.  Returns the
        command ID; the ack is logged by the link."""
        body = build_control("TAKE", True, self.secret)
        cid = self._send(body, label="Take control")
        self.refresh_soon()
        return cid

    def ensure(self) -> None:
        """Before a command: with a shared secret the lease is never taken implicitly, so take
        it (plain ``CONTROL|TAKE|secret``) unless the commander holds it already.  Without a
        secret nothing is sent (the command itself takes a free lease)."""
        if self.secret is None or self.mine or self._take_sent:
            return
        self._send(build_control("TAKE", False, self.secret), label="Take control", quiet=True)
        self._take_sent = True
        self.refresh_soon()

    def release(self) -> None:
        """Send ``CONTROL|RELEASE`` if the commander's link holds the lease (page closed)."""
        if self.mine:
            self._send("CONTROL|RELEASE", label="Release control", quiet=True)
            self.refresh_soon()

    async def hand_over(self) -> None:
        """Before the program runner (another client) starts: give the lease back and wait
        for the controller's answer, so the runner's CONTROL TAKE finds it free.  Sent
        whatever :attr:`view` says (the link may have taken the lease since the last poll);
        the controller refuses it harmlessly when another client holds the lease."""
        try:
            await self.robot.release_control(timeout=1.0)
        except RobotError as exc:
            log.debug("CONTROL RELEASE before the program: %s", exc)
        self.refresh_soon()
