"""The control lease: one client controls the robot, any number watch it.

The model of ur_rtde and the xArm SDK.  Queries, status subscriptions, STOP, ESTOP and DISABLE
are open to every client; motion, IO, gripper and configuration commands are accepted from the
lease holder only.  The lease is

* **taken** explicitly (``CONTROL|TAKE``) or implicitly by the first command that needs it
  while nobody holds it, if its sender registered its socket (``ACK_HERE``: the ``Robot``
  classes, the GUI), so a single script needs no change;
* **kept** by the holder's commands (queries, subscriptions and ACK_HERE renewals do not count:
  a commander left open does not hold the robot forever) and, whatever the silence, while the
  robot still runs or queues commands;
* **released** explicitly (``CONTROL|RELEASE``) or after ``timeout_s`` of silence with the
  robot idle;
* **taken over** with ``CONTROL|TAKE|FORCE`` (the commands of the previous holder are
  cancelled by the server), an explicit, logged act for an operator at the commander.

A client is a socket: its address and port (issue 22: any other identity let a second
process on the host move the arm while a script held the lease).  A sender that never
registered its socket (the original robot_api sends each command from a new socket) may send
commands while nobody holds the lease, but is never given the lease implicitly: its next
command comes from another socket, which would then be refused.  Such a script that wants the
robot to itself takes the lease explicitly from one socket (our ``robot_api.take_control()``
sends everything from its acknowledgement listener's socket from then on).

With a shared ``secret`` (config ``controller.secret``, for controllers bound beyond
loopback) the lease is never taken implicitly: ``CONTROL|TAKE|secret`` first.
"""

from __future__ import annotations

import hmac
import ipaddress
from dataclasses import dataclass
from typing import Any

__all__ = ["ClientId", "ControlLease", "LEASE_TIMEOUT_S", "is_loopback"]

#: default silence after which an idle holder loses the lease, s
LEASE_TIMEOUT_S = 10.0


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and ``localhost``."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class ClientId:
    """Who sent a datagram: the sending socket's ``host`` and ``port``."""

    host: str
    port: int

    @property
    def address(self) -> tuple[str, int]:
        return (self.host, self.port)

    def __str__(self) -> str:
        return f"{self.host}:{self.port}"


class ControlLease:
    """Who may command the robot.  Used by the server thread only (no locking)."""

    def __init__(self, timeout_s: float = LEASE_TIMEOUT_S, secret: str | None = None) -> None:
        self.timeout_s = float(timeout_s)
        self.secret = secret or None
        self.holder: ClientId | None = None
        self.since = 0.0
        self.last_heard = 0.0
        #: commands refused because another client held the lease
        self.refused = 0
        #: forced take-overs
        self.taken_over = 0

    # ------------------------------------------------------------------ state

    def _expire(self, now: float, busy: bool) -> None:
        if self.holder is not None and not busy and now - self.last_heard > self.timeout_s:
            self.holder = None

    def _give(self, who: ClientId, now: float) -> None:
        self.holder, self.since, self.last_heard = who, now, now

    def _how_to_take(self) -> str:
        # no "|" here: ack details cannot carry the field separator
        secret = " with the secret" if self.secret else ""
        return (f"it is released when the holder sends CONTROL RELEASE or after {self.timeout_s:g} s of "
                f"silence with the robot idle; then take it with CONTROL TAKE{secret} "
                f"(Robot.take_control(), robot_api.take_control()); CONTROL TAKE FORCE{secret} takes it "
                f"over and cancels the holder's commands; STOP and ESTOP work from any client")

    def refusal(self, now: float) -> str:
        """Why a non-holder's command is refused, and what to do."""
        h = self.holder
        return (f"the robot is controlled by {h} (for {now - self.since:.0f} s, last heard "
                f"{now - self.last_heard:.1f} s ago): {self._how_to_take()}")

    # ------------------------------------------------------------------ decisions

    def check(self, who: ClientId, now: float, busy: bool, registered: bool) -> str | None:
        """May ``who`` send a command that needs the lease?  None: yes; else the refusal text.
        A free lease is taken implicitly by a ``registered`` socket (one that sent ACK_HERE);
        any other sender is let through without it (see the module docstring)."""
        self._expire(now, busy)
        if self.holder is None:
            if self.secret is not None:
                return ("this controller has a shared secret: take control first with CONTROL TAKE and "
                        "the secret (Robot.take_control(secret=...))")
            if registered:
                self._give(who, now)
            return None
        if who == self.holder:
            self.last_heard = now
            return None
        self.refused += 1
        return self.refusal(now)

    def take(self, who: ClientId, now: float, *, force: bool, secret: str | None,
             busy: bool) -> tuple[bool, str, ClientId | None]:
        """``CONTROL|TAKE``: (taken, text for the ack, the holder it was taken from if forced)."""
        if self.secret is not None and (secret is None or not hmac.compare_digest(secret, self.secret)):
            return False, ("wrong or missing secret: CONTROL TAKE needs the controller's secret "
                           "(controller.secret)"), None
        self._expire(now, busy)
        prev = self.holder
        if prev is None or prev == who:
            self._give(who, now)
            return True, f"control taken by {who}", None
        if not force:
            self.refused += 1
            return False, self.refusal(now), None
        self._give(who, now)
        self.taken_over += 1
        return True, f"control taken over from {prev} by {who}", prev

    def release(self, who: ClientId, now: float, busy: bool) -> tuple[bool, str]:
        """``CONTROL|RELEASE``."""
        self._expire(now, busy)
        if self.holder is None:
            return True, "nobody held control"
        if self.holder != who:
            return False, f"control is held by {self.holder}, not by {who}: nothing to release"
        self.holder = None
        return True, "control released"

    def view(self, now: float, busy: bool) -> dict[str, Any]:
        """``GET_CONTROL``: the holder (or None) and the rules in force."""
        self._expire(now, busy)
        h = self.holder
        return {
            "holder": None if h is None else str(h),
            "held_s": None if h is None else round(now - self.since, 1),
            "idle_s": None if h is None else round(now - self.last_heard, 1),
            "timeout_s": self.timeout_s,
            "secret_required": self.secret is not None,
            "refused": self.refused,
            "taken_over": self.taken_over,
        }
