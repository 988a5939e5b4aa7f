"""parolkit: an open-source control stack for the PAROL6 robot arm.

Importing the package is cheap (no numpy): the sub-packages load what they need.
The object API for scripts is ``parolkit.Robot`` / ``parolkit.AsyncRobot`` (loaded lazily).
"""

from __future__ import annotations

#: (not ``typing.TYPE_CHECKING``: importing typing would cost the controller's start-up path a few ms)
TYPE_CHECKING = False
if TYPE_CHECKING:  # the real names for type checkers; at run time __getattr__ loads them lazily
    from parolkit.client import robot_api as robot_api
    from parolkit.client.async_robot import AsyncRobot
    from parolkit.client.robot import Robot

__version__ = "0.1.0"

__all__ = ["__version__", "Robot", "AsyncRobot"]


def __getattr__(name: str) -> object:
    if name == "Robot":
        from parolkit.client.robot import Robot

        return Robot
    if name == "AsyncRobot":
        from parolkit.client.async_robot import AsyncRobot

        return AsyncRobot
    if name == "robot_api":
        import importlib

        return importlib.import_module("parolkit.client.robot_api")
    raise AttributeError(f"module 'parolkit' has no attribute {name!r}")
