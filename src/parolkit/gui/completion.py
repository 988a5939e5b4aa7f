"""Completion items of the program editor: every RBTscript command of the parser's table
(:data:`parolkit.script.parser.COMMAND_NAMES`) with its arguments, and the argument words
(no NiceGUI: tested without a browser; commander.js shows them as you type)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from parolkit.script.parser import COMMAND_NAMES

__all__ = ["Completion", "COMPLETIONS", "ARGUMENTS", "completion_table"]

#: the arguments of each command, as inserted after its name (deg, mm, s, %, mA)
ARGUMENTS: dict[str, str] = {
    "Begin": "()",
    "End": "()",
    "Loop": "()",
    "MoveJoint": "(j1,j2,j3,j4,j5,j6,t=2)",
    "MovePose": "(x,y,z,rx,ry,rz,t=2)",
    "MoveCart": "(x,y,z,rx,ry,rz,t=2)",
    "MoveCartRelTRF": "(dx,dy,dz,drx,dry,drz,t=1)",
    "SpeedJoint": "(v1,v2,v3,v4,v5,v6,t=1)",
    "Delay": "(1)",
    "Speed": "(50)",
    "Output": "(1,HIGH)",
    "Input": "(1,HIGH)",
    "Gripper": "(position,speed,current_mA)",
    "Gripper_cal": "()",
    "Home": "()",
}

#: words inside a call: keyword arguments, profiles, levels
_WORDS: tuple[tuple[str, str], ...] = (
    ("t=", "duration, s"), ("v=", "speed, % of the maximum"), ("a=", "acceleration, % of the maximum"),
    ("r=", "blend radius into the next move: mm (MoveCart), deg (MoveJoint, MovePose)"),
    ("trap", "trapezoidal profile"), ("poly", "polynomial profile"), ("HIGH", "level high"), ("LOW", "level low"),
)


@dataclass(frozen=True)
class Completion:
    """One item: ``label`` shown and matched, ``insert`` typed in, ``detail`` explained;
    ``call`` items are offered at the start of a line, the others inside a call."""

    label: str
    insert: str
    detail: str
    call: bool


COMPLETIONS: tuple[Completion, ...] = tuple(
    Completion(name, name + ARGUMENTS[name], f"{name}{ARGUMENTS[name]}", True) for name in COMMAND_NAMES
) + tuple(Completion(w, w, d, False) for w, d in _WORDS)


def completion_table() -> list[dict[str, object]]:
    """The items as JSON-ready dicts (the page's ``pk-completions`` data island)."""
    return [asdict(c) for c in COMPLETIONS]
