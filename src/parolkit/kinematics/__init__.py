"""PAROL6 kinematics: pose conventions, FK, closed-form IK (every branch), Jacobian, tools.

Units at the edges: joints in degrees, poses ``[x, y, z mm, A, B, C deg]`` with
``R = Rx(C) Ry(B) Rz(A)`` (the original software's convention), 4x4 matrices in metres.
``tool=None`` everywhere means the original commander's TCP (:data:`TOOLS` ``['default']``).

Importing this package costs numpy only (no JIT, no roboticstoolbox).
"""

from __future__ import annotations

from parolkit.kinematics.fk import fk, fk_batch, fk_frames, fk_matrix
from parolkit.kinematics.ik import ik, ik_all, ik_batch
from parolkit.kinematics.jacobian import jacobian, manipulability, singularity_distance
from parolkit.kinematics.pose import matrix_to_pose, pose_to_matrix
from parolkit.kinematics.tools import TOOLS, Tool, get_tool
from parolkit.kinematics.types import Branch, IKError, IKFailure, IKSolution, SingularityInfo

__all__ = [
    "fk", "fk_matrix", "fk_batch", "fk_frames",
    "ik", "ik_all", "ik_batch",
    "IKSolution", "Branch", "IKError", "IKFailure",
    "pose_to_matrix", "matrix_to_pose",
    "jacobian", "manipulability", "singularity_distance", "SingularityInfo",
    "Tool", "get_tool", "TOOLS",
]
