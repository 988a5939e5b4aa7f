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
    from parolkit.client.async_robot import AsyncCommandHandle, AsyncRobot, AsyncStatusSubscription
    from parolkit.client.core import (
        AckStatus,
        ActiveCommand,
        AsyncResult,
        BoardInfo,
        CommandResult,
        ControlInfo,
        ErrorInfo,
        GripperState,
        HeldInfo,
        IOState,
        LoopStats,
        PlanInfo,
        Pose,
        QueueInfo,
        RobotState,
        RobotStatus,
        ToolInfo,
        ToolShapeInfo,
        ZoneInfo,
        ZonesInfo,
    )
    from parolkit.client.errors import (
        CommandCancelled,
        CommandFailed,
        CommandInvalid,
        CommandNotCompleted,
        CommandTimeout,
        ControllerUnreachable,
        ReplyError,
        RobotError,
    )
    from parolkit.client.robot import CommandHandle, DatagramChannel, Robot, StatusSubscription

__all__ = [
    "Robot", "CommandHandle", "StatusSubscription", "AsyncRobot", "AsyncCommandHandle",
    "AsyncStatusSubscription", "RobotError", "CommandNotCompleted", "CommandFailed",
    "CommandInvalid", "CommandCancelled", "CommandTimeout", "ControllerUnreachable", "ReplyError",
    "CommandResult", "AckStatus", "AsyncResult", "RobotStatus", "RobotState", "Pose", "IOState",
    "GripperState", "ErrorInfo", "BoardInfo", "LoopStats", "ActiveCommand", "PlanInfo", "QueueInfo",
    "ToolInfo", "ControlInfo", "DatagramChannel", "ZonesInfo", "ZoneInfo", "HeldInfo", "ToolShapeInfo",
]

_WHERE = {
    "Robot": "parolkit.client.robot",
    "CommandHandle": "parolkit.client.robot",
    "DatagramChannel": "parolkit.client.robot",
    "StatusSubscription": "parolkit.client.robot",
    "AsyncRobot": "parolkit.client.async_robot",
    "AsyncCommandHandle": "parolkit.client.async_robot",
    "AsyncStatusSubscription": "parolkit.client.async_robot",
    "RobotError": "parolkit.client.errors",
    "CommandNotCompleted": "parolkit.client.errors",
    "CommandFailed": "parolkit.client.errors",
    "CommandInvalid": "parolkit.client.errors",
    "CommandCancelled": "parolkit.client.errors",
    "CommandTimeout": "parolkit.client.errors",
    "ControllerUnreachable": "parolkit.client.errors",
    "ReplyError": "parolkit.client.errors",
    "CommandResult": "parolkit.client.core",
    "AckStatus": "parolkit.client.core",
    "AsyncResult": "parolkit.client.core",
    "RobotStatus": "parolkit.client.core",
    "RobotState": "parolkit.client.core",
    "Pose": "parolkit.client.core",
    "IOState": "parolkit.client.core",
    "GripperState": "parolkit.client.core",
    "ErrorInfo": "parolkit.client.core",
    "BoardInfo": "parolkit.client.core",
    "LoopStats": "parolkit.client.core",
    "ActiveCommand": "parolkit.client.core",
    "PlanInfo": "parolkit.client.core",
    "QueueInfo": "parolkit.client.core",
    "ToolInfo": "parolkit.client.core",
    "ControlInfo": "parolkit.client.core",
    "ZonesInfo": "parolkit.client.core",
    "ZoneInfo": "parolkit.client.core",
    "HeldInfo": "parolkit.client.core",
    "ToolShapeInfo": "parolkit.client.core",
}


def __getattr__(name: str) -> object:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'parolkit.client' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)
