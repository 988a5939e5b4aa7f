"""Exceptions of the object API (``parolkit.Robot`` / ``parolkit.AsyncRobot``).

Every command failure carries the command's ID, its name and the controller's reason, word
for word from the acknowledgement (``ACK|ID|FAILED|reason``)::

    try:
        robot.move_pose([500, 0, 0, 0, 0, 0], duration=2)
    except CommandFailed as exc:
        print(exc.reason)        # e.g. "IK: pose out of reach ..."

Hierarchy (the whole parolkit tree is drawn in :mod:`parolkit.errors`)::

    ParolkitError
      RobotError
        CommandNotCompleted (command_id, command, status, reason)
          CommandFailed      FAILED: the controller could not execute it
          CommandInvalid     INVALID: parse/validation error (also a ValueError)
          CommandCancelled   CANCELLED: STOP, E-stop or link lost
          CommandTimeout     no terminal acknowledgement in time (the command may still run)
        ControllerUnreachable  no reply to a query / no acknowledgement at all
        ReplyError             a reply that does not follow docs/protocol.md, or ERROR|...

Client-side argument checks raise :class:`parolkit.errors.ParolkitValueError` before
anything is sent.

``CommandError``, the old name of :class:`CommandNotCompleted`, still works here but is
deprecated (a DeprecationWarning says so): it was also the name of the controller's parse
error, a different thing.
"""

from __future__ import annotations

import warnings

from parolkit.errors import ParolkitError

__all__ = [
    "RobotError",
    "CommandNotCompleted",
    "CommandFailed",
    "CommandInvalid",
    "CommandCancelled",
    "CommandTimeout",
    "ControllerUnreachable",
    "ReplyError",
]


class RobotError(ParolkitError):
    """Base class of every object-API error."""


class CommandNotCompleted(RobotError):
    """A command ended without COMPLETED (or no terminal acknowledgement came in time).

    Attributes: ``command_id`` (8 characters), ``command`` (its name, e.g. ``MOVEJOINT``),
    ``status`` (the ack status text or ``TIMEOUT``), ``reason`` (the controller's details).
    """

    def __init__(self, command_id: str, command: str, status: str, reason: str) -> None:
        self.command_id = command_id
        self.command = command
        self.status = status
        self.reason = reason
        super().__init__(f"{command} [{command_id}] {status}: {reason}" if reason
                         else f"{command} [{command_id}] {status}")


class CommandFailed(CommandNotCompleted):
    """FAILED: the controller accepted the command but could not execute it (reason given)."""


class CommandInvalid(CommandNotCompleted, ValueError):
    """INVALID: the controller refused the command; the reason names the field and range."""


class CommandCancelled(CommandNotCompleted):
    """CANCELLED: by STOP, E-stop or a lost board link (the reason says which)."""


class CommandTimeout(CommandNotCompleted):
    """No terminal acknowledgement within the timeout.  The command may still be running:
    send ``stop()`` to cancel it."""


class ControllerUnreachable(RobotError):
    """The controller did not answer (not running, wrong host/port, or a firewall)."""


class ReplyError(RobotError):
    """The controller's reply was malformed or an ``ERROR|...`` answer (message included)."""


def __getattr__(name: str) -> type[CommandNotCompleted]:
    """``CommandError``: deprecated alias of :class:`CommandNotCompleted` (for code written
    against parolkit 0.1's object API)."""
    if name == "CommandError":
        warnings.warn(
            "parolkit.client.errors.CommandError is deprecated: catch CommandNotCompleted "
            "(the same class) instead",
            DeprecationWarning,
            stacklevel=2,
        )
        return CommandNotCompleted
    raise AttributeError(f"module 'parolkit.client.errors' has no attribute {name!r}")
