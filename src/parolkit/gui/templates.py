"""RBTscript command templates for the program editor, filled with the robot's current values.

Joint angles in degrees (3 decimals), positions in mm (3 decimals), angles in degrees.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from parolkit.errors import ParolkitValueError

__all__ = ["Template", "TEMPLATES", "render_template", "SEED_EXAMPLES"]


@dataclass(frozen=True)
class Template:
    """A menu entry: ``name`` shown to the user, ``pattern`` with {joints}/{pose} placeholders."""

    name: str
    pattern: str
    description: str


TEMPLATES: tuple[Template, ...] = (
    Template("MoveJoint", "MoveJoint({joints},t=2)", "joint-space move to the current joints"),
    Template("MovePose", "MovePose({pose},t=2)", "joint-space move to the current TCP pose"),
    Template("MoveCart", "MoveCart({pose},t=2)", "straight line to the current TCP pose"),
    Template("MoveCartRelTRF", "MoveCartRelTRF(0,0,10,0,0,0,t=1)", "relative move in the tool frame"),
    Template("Delay", "Delay(1)", "wait, seconds"),
    Template("Speed", "Speed(50)", "speed override for the moves after it, %"),
    Template("Output HIGH", "Output(1,HIGH)", "set an output"),
    Template("Output LOW", "Output(1,LOW)", "clear an output"),
    Template("Gripper", "Gripper(100,60,600)", "SSG-48 position, speed, current mA"),
    Template("Gripper_cal", "Gripper_cal()", "calibrate the SSG-48"),
    Template("Home", "Home()", "home the robot"),
    Template("Begin", "Begin()", "program start"),
    Template("End", "End()", "program end"),
    Template("Loop", "Loop()", "restart from the top"),
)


def _fmt(values: Sequence[float], name: str) -> str:
    vals = [float(v) for v in values]
    if len(vals) != 6:
        raise ParolkitValueError(f"{name} must have 6 values, got {len(vals)}")
    return ",".join(f"{v:.3f}" for v in vals)


def render_template(name: str, joints_deg: Sequence[float], pose: Sequence[float]) -> str:
    """The template line ``name`` filled with the current joints (deg) and pose (mm, deg)."""
    for t in TEMPLATES:
        if t.name == name:
            return t.pattern.format(joints=_fmt(joints_deg, "joints_deg"), pose=_fmt(pose, "pose"))
    raise ParolkitValueError(f"unknown template {name!r}; one of {', '.join(t.name for t in TEMPLATES)}")


#: The seed's example programs (facts from the public documentation), offered in the editor.
SEED_EXAMPLES: dict[str, str] = {
    "Simple joint space move": (
        "Begin()\nDelay(1)\nMoveJoint(85.078,-111.195,143.513,-32.92,18.084,129.448,t=3)\nDelay(1)\n"
        "MoveJoint(66.129,-117.368,136.77,46.28,-29.588,149.293)\nDelay(1)\nLoop()\n"),
    "Cartesian TRF example": (
        "Begin()\nDelay(1)\nMoveJoint(90.0,-90.0,180.001,0.0,0.0,180.0,t=4)\nDelay(1)\n"
        "MoveCart(0.0,263.23,161.241,-90.0,0.0,-89.499)\nDelay(1)\n"
        "MoveCart(81.565,262.804,161.047,-90.135,-0.029,-89.578)\nDelay(1)\n"
        "MoveCart(81.649,194.981,160.077,-90.14,-0.043,-89.593)\nDelay(1)\n"
        "MoveCart(83.598,194.356,161.493,-91.155,1.306,-80.28)\nDelay(1)\n"
        "MoveCart(84.56,194.131,162.347,-48.387,1.261,-80.188)\nDelay(1)\n"
        "MoveCart(82.89,191.698,162.369,-40.587,26.026,-107.028)\nDelay(1)\nEnd()\n"),
    "Cartesian relative TRF": (
        "Begin()\nDelay(1)\nMoveJoint(90.0,-90.0,180.001,0.0,0.0,180.0,t=4)\nDelay(1)\n"
        "MoveCartRelTRF(-80,0,0,0,0,0)\nDelay(1)\nEnd()\n"),
    "Output click": "Begin()\nOutput(1,HIGH)\nDelay(1)\nOutput(1,LOW)\nDelay(1)\nLoop()\n",
    "SSG48 gripper test": (
        "Begin()\nGripper_cal()\nDelay(3)\nGripper(100,60,600)\nDelay(2)\nGripper(200,60,600)\nDelay(2)\n"
        "MoveJoint(85.192,-104.451,158.769,-1.983,-46.491,179.899,t=6)\nDelay(1)\n"
        "MoveCart(4.317,103.384,192.319,-84.465,1.447,-143.154)\nGripper(100,60,600)\nDelay(2)\nEnd()\n"),
}
