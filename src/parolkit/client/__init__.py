"""Clients of the parolkit controller.

* :mod:`parolkit.client.robot_api`: the original function API (standard library only; also
  importable as ``robot_api``).
* :class:`parolkit.client.robot.Robot`: the object API (sync) and
  :class:`parolkit.client.async_robot.AsyncRobot` (asyncio), sharing one protocol core
  (:mod:`parolkit.client.core`).
* :mod:`parolkit.client.errors`: ``RobotError`` and its subclasses.

Attributes are loaded lazily so ``import parolkit.client`` stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the real names for type checkers; at run time __getattr__ loads them lazily
    from parolkit.client.async_robot import AsyncRobot
    from parolkit.client.core import AckStatus, CommandResult, PlanInfo, RobotState, RobotStatus
    from parolkit.client.errors import (
        CommandCancelled,
        CommandFailed,
        CommandInvalid,
        CommandNotCompleted,
        CommandTimeout,
        ControllerUnreachable,
        RobotError,
    )
    from parolkit.client.robot import Robot

__all__ = ["Robot", "AsyncRobot", "RobotError", "CommandNotCompleted", "CommandFailed", "CommandInvalid",
           "CommandCancelled", "CommandTimeout", "ControllerUnreachable", "CommandResult",
           "AckStatus", "RobotStatus", "RobotState", "PlanInfo"]

_WHERE = {
    "Robot": "parolkit.client.robot",
    "AsyncRobot": "parolkit.client.async_robot",
    "RobotError": "parolkit.client.errors",
    "CommandNotCompleted": "parolkit.client.errors",
    "CommandFailed": "parolkit.client.errors",
    "CommandInvalid": "parolkit.client.errors",
    "CommandCancelled": "parolkit.client.errors",
    "CommandTimeout": "parolkit.client.errors",
    "ControllerUnreachable": "parolkit.client.errors",
    "CommandResult": "parolkit.client.core",
    "AckStatus": "parolkit.client.core",
    "RobotStatus": "parolkit.client.core",
    "RobotState": "parolkit.client.core",
    "PlanInfo": "parolkit.client.core",
}


def __getattr__(name: str) -> object:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'parolkit.client' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)
