"""``from robot_api import move_robot_joints, ...`` exactly as existing PAROL6 scripts do.

The implementation is :mod:`parolkit.client.robot_api` (standard library only); this module
re-exports all of it so the original import line keeps working unchanged.
"""

from parolkit.client.robot_api import *  # noqa: F401,F403
from parolkit.client.robot_api import __all__  # noqa: F401
