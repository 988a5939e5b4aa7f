"""Completion items of the program editor: every RBTscript command of the parser's table
(:data:`parolkit.script.parser.COMMAND_NAMES`) with its arguments, and the argument words
(no NiceGUI: tested without a browser; commander.js shows them as you type).

Every command is inserted as a line that is valid as it stands (never ``MoveJoint(j1, ...)``,
an error at once): the moves to a target take the robot's current joints or TCP pose, as the
Insert menu's templates do (:data:`parolkit.gui.templates.TEMPLATES`; the page fills
``{joints}`` / ``{pose}`` from the Program tab's live values when the item is chosen, and
``insert`` holds the line for the standby pose when there are none), the others example values
inside their ranges."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

from parolkit.gui.templates import TEMPLATES
from parolkit.robot import PAROL6
from parolkit.script.parser import COMMAND_NAMES

__all__ = ["Completion", "COMPLETIONS", "ARGUMENTS", "LIVE", "completion_table", "filled", "values_text"]

#: the arguments of each command, as inserted after its name (deg, mm, s, %, mA): the moves to a
#: target as the Insert templates write them (``{joints}``: the current joints, ``{pose}``: the
#: current TCP pose), the others valid example values
ARGUMENTS: dict[str, str] = {
    "Begin": "()",
    "End": "()",
    "Loop": "()",
    **{t.name: t.pattern[len(t.name):] for t in TEMPLATES if t.name in ("MoveJoint", "MovePose", "MoveCart")},
    "MoveCartRelTRF": "(0,0,10,0,0,0,t=1)",
    "SpeedJoint": "(10,0,0,0,0,0,t=1)",
    "Delay": "(1)",
    "Speed": "(50)",
    "Output": "(1,HIGH)",
    "Input": "(1,HIGH)",
    "Gripper": "(100,60,600)",
    "Gripper_cal": "()",
    "Home": "()",
}
#: the live value an item's arguments take ("joints" or "pose"), by command
LIVE: dict[str, str] = {name: ("joints" if "{joints}" in args else "pose")
                        for name, args in ARGUMENTS.items() if "{" in args}
#: what the item's detail says for a live value
_LIVE_WORDS = {"joints": "the current joints", "pose": "the current TCP pose"}

#: words inside a call: keyword arguments, profiles, levels
_WORDS: tuple[tuple[str, str], ...] = (
    ("t=", "duration, s"), ("v=", "speed, % of the maximum"), ("a=", "acceleration, % of the maximum"),
    ("r=", "blend radius into the next move: mm (MoveCart), deg (MoveJoint, MovePose)"),
    ("trap", "trapezoidal profile"), ("poly", "polynomial profile"), ("HIGH", "level high"), ("LOW", "level low"),
)


def values_text(values: Sequence[float]) -> str:
    """Six values as the Insert templates write them (3 decimals): the live values the page fills in."""
    return ",".join(f"{float(v):.3f}" for v in values)


def filled(pattern: str, joints_deg: Sequence[float], pose: Sequence[float]) -> str:
    """An item's ``pattern`` with ``{joints}`` / ``{pose}`` filled (deg; mm, deg)."""
    return pattern.replace("{joints}", values_text(joints_deg)).replace("{pose}", values_text(pose))


def _standby_pose() -> tuple[float, ...]:
    from parolkit.kinematics import fk

    return tuple(float(v) for v in fk(PAROL6.standby_deg))


@dataclass(frozen=True)
class Completion:
    """One item: ``label`` shown and matched, ``insert`` typed in, ``detail`` explained;
    ``call`` items are offered at the start of a line, the others inside a call.  ``live``
    ("joints", "pose" or ""): ``pattern`` is inserted with that live value filled in (the
    page's), ``insert`` being the same line for the standby pose."""

    label: str
    insert: str
    detail: str
    call: bool
    live: str = ""
    pattern: str = ""


def _call(name: str, standby_pose: Sequence[float]) -> Completion:
    args = ARGUMENTS[name]
    live = LIVE.get(name, "")
    detail = f"{name}({_LIVE_WORDS[live]}{args[args.index('}') + 1:]}" if live else f"{name}{args}"
    return Completion(name, filled(name + args, PAROL6.standby_deg, standby_pose), detail, True, live,
                      name + args if live else "")


def completions() -> tuple[Completion, ...]:
    """Every item: the commands (their moves filled for the standby pose), then the words."""
    pose = _standby_pose()
    return tuple(_call(name, pose) for name in COMMAND_NAMES) + tuple(Completion(w, w, d, False) for w, d in _WORDS)


COMPLETIONS: tuple[Completion, ...] = completions()


def completion_table() -> list[dict[str, object]]:
    """The items as JSON-ready dicts (the page's ``pk-completions`` data island)."""
    return [asdict(c) for c in COMPLETIONS]
