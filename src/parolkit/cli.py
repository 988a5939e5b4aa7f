"""The ``parolkit`` command.

Each sub-command lives in the module that owns it; this file only dispatches.  A parolkit
error or an OSError that a sub-command does not handle itself (a bad value, a file that is
missing, damaged, of the wrong kind or cannot be written) ends it with one line on stderr,
``parolkit COMMAND: message``, and exit code 2 (a bad value) or 1, never a traceback.  A module in
:data:`SUBCOMMANDS` provides ``register(subparsers) -> argparse.ArgumentParser`` and the
parser it returns has ``func(args) -> int`` set as a default.  Modules are imported only when
needed, so ``parolkit serve`` does not pay for the GUI's imports.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from parolkit import __version__
from parolkit.errors import ParolkitError, ParolkitValueError

#: sub-command name -> (module, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "serve": ("parolkit.controller.cli", "run the headless controller (UDP server + 100 Hz loop)"),
    "board-sim": ("parolkit.board.cli", "emulate a PAROL6 control board on a pseudo-terminal"),
    "board-test": ("parolkit.boardtest", "exercise one board function at a time"),
    "gui": ("parolkit.gui.cli", "start the browser commander"),
    "run": ("parolkit.script.cli", "run an RBTscript program"),
    "check": ("parolkit.script.cli", "check RBTscript programs without running them"),
    "fmt": ("parolkit.script.cli", "format RBTscript programs"),
    "plan": ("parolkit.motion.cli", "plan one move and print or plot its trajectory"),
    "record": ("parolkit.record.cli", "record the controller's status stream to an MCAP file"),
    "replay": ("parolkit.record.cli", "play a recorded joint trajectory into a controller"),
    "plot": ("parolkit.record.cli", "plot a recording: joints, speeds, TCP path, loop timing"),
    "export": ("parolkit.record.cli", "export a recording (--csv)"),
    "teach": ("parolkit.record.cli", "fit an RBTscript program to a recorded demonstration"),
}
# ROS 2 (issue 17): the URDF and the DDS bridge (the bridge needs the optional cyclonedds)
SUBCOMMANDS.update({
    "urdf": ("parolkit.ros2.cli", "write the PAROL6 URDF generated from the robot model"),
    "ros2": ("parolkit.ros2.cli", "bridge a controller to ROS 2: joint states out, trajectories in"),
})
# MoveIt (issue 27): a MoveIt 2 configuration generated from the robot and collision models
SUBCOMMANDS["moveit-config"] = ("parolkit.ros2.moveit_config", "write a MoveIt 2 configuration for the PAROL6")


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The full parser of sub-command ``only``; the others get light placeholders (so that
    ``parolkit --help`` lists every command without importing them all)."""
    parser = argparse.ArgumentParser(
        prog="parolkit",
        description="parolkit: control stack for the PAROL6 robot arm.",
    )
    parser.add_argument("--version", action="version", version=f"parolkit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_text) in SUBCOMMANDS.items():
        if name != only:
            # a light placeholder keeps `parolkit --help` complete without importing everything
            sub.add_parser(name, help=help_text, add_help=False)
            continue
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name and exc.name.startswith("parolkit"):
                sub.add_parser(name, help=f"{help_text} (not available in this build)")
                continue
            raise
        mod.register(sub, name)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(only=command if command in SUBCOMMANDS else None)
    if command not in SUBCOMMANDS:
        # no or unknown command: let argparse print help / the error with every choice
        if command is None and not argv:
            parser.print_help()
            return 2
        parser.parse_args(argv)
        return 2
    args = parser.parse_args(argv)
    func = getattr(args, "func", None)
    if func is None:
        parser.error(f"'{command}' is not available in this build")
    try:
        return int(func(args) or 0)
    except KeyboardInterrupt:
        return 130
    except (ParolkitError, OSError) as exc:
        # bad input (a value, a file that is missing, damaged or of the wrong kind) or a file that
        # cannot be written: one line naming it, never a traceback
        print(f"parolkit {command}: {_one_line(exc)}", file=sys.stderr)
        return 2 if isinstance(exc, ParolkitValueError) else 1


def _one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line; an OSError as ``FILE: what went wrong``."""
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}" if exc.filename is not None else exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


def serve_main() -> int:
    """``headless-commander``: the same as ``parolkit serve``."""
    return main(["serve", *sys.argv[1:]])


if __name__ == "__main__":
    sys.exit(main())
