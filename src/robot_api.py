"""``from robot_api import move_robot_joints, ...`` exactly as existing PAROL6 scripts do.

The implementation is :mod:`parolkit.client.robot_api` (standard library only).  This module
REPLACES itself with it in ``sys.modules``, so ``import robot_api`` gives that very module:
scripts that set ``robot_api.SERVER_IP = "192.168.1.20"`` (as the original allowed) change
the address the functions use, and ``__all__`` is the implementation's, complete.
"""

import sys

from parolkit.client import robot_api as _implementation

#: (not ``typing.TYPE_CHECKING``: this shim imports nothing it does not need)
TYPE_CHECKING = False
if TYPE_CHECKING:  # what type checkers see here: the implementation's names and annotations
    from parolkit.client.robot_api import *  # noqa: F403

sys.modules[__name__] = _implementation
