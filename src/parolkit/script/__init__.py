"""RBTscript: the PAROL6 program language.

* :func:`parse` / :func:`parse_file` / :func:`load`: text -> typed :class:`Program` (every
  error of a file at once, each with line, column and a caret display),
* :func:`dry_run` (:mod:`parolkit.script.dryrun`): plans every move with the motion layer from
  the predicted start state, without a robot,
* :class:`Interpreter` (:mod:`parolkit.script.interpreter`): runs a program on the controller
  through the client API, with pause/resume, single step and stop,
* :func:`format_program` (:mod:`parolkit.script.formatter`): canonical formatting.

The dry run and the interpreter are imported lazily (they pull in numpy / the motion layer).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from parolkit.script.parser import COMMAND_NAMES, Limits, load, parse, parse_file
from parolkit.script.program import (
    Begin,
    Command,
    Delay,
    End,
    Gripper,
    GripperCalibrate,
    Home,
    Input,
    Loop,
    MoveCart,
    MoveCartRelTRF,
    MoveJoint,
    MovePose,
    Output,
    ParseResult,
    Profile,
    Program,
    ProgramError,
    ScriptError,
    Severity,
    Speed,
    SpeedJoint,
    Tracking,
)

if TYPE_CHECKING:  # the real names for type checkers; at run time __getattr__ loads them lazily
    from parolkit.script.dryrun import DryRunReport, dry_run
    from parolkit.script.formatter import format_program
    from parolkit.script.interpreter import Interpreter, InterpreterState

__all__ = [
    "COMMAND_NAMES", "Limits", "load", "parse", "parse_file",
    "Begin", "Command", "Delay", "End", "Gripper", "GripperCalibrate", "Home", "Input", "Loop",
    "MoveCart", "MoveCartRelTRF", "MoveJoint", "MovePose", "Output", "ParseResult", "Profile",
    "Program", "ProgramError", "ScriptError", "Severity", "Speed", "SpeedJoint", "Tracking",
    "dry_run", "DryRunReport", "Interpreter", "InterpreterState", "format_program",
]

_LAZY = {
    "dry_run": "parolkit.script.dryrun",
    "DryRunReport": "parolkit.script.dryrun",
    "Interpreter": "parolkit.script.interpreter",
    "InterpreterState": "parolkit.script.interpreter",
    "format_program": "parolkit.script.formatter",
}


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'parolkit.script' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)
