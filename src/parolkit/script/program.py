"""The typed RBTscript program: command objects with source positions, and diagnostics.

A :class:`Program` is an immutable tuple of :class:`Command` objects.  Every command knows
where it came from (``line`` and ``col``, both 1-based, and ``text``, the whole source line)
so that the checker, the dry run and the interpreter can point at it.

Units are those of the language: joint angles and pose angles in degrees, positions in mm,
durations in seconds, speeds and accelerations in percent (0-100) of the joint's range,
``SpeedJoint`` speeds in deg/s, gripper current in mA.

A move statement carries its move as a :mod:`parolkit.moves` value object, exactly as written
(``MoveJoint(90, -90, 180, 0, 0, 180, v=50)`` -> ``MoveJoint(move=JointMove(..., speed_pct=50))``,
unset options None = the language's defaults, resolved by
:func:`parolkit.script.dryrun.effective_timing`).  ``Profile`` and ``Tracking`` are the
:mod:`parolkit.moves` enums, re-exported here.

This module imports nothing heavy; it is safe to use from the GUI and from tests.
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import ClassVar

from parolkit.errors import ParolkitError
from parolkit.moves import CartMove, CartRelTRFMove, JointMove, PoseMove, Profile, SpeedJointMove, Tracking

__all__ = [
    "Severity",
    "ScriptError",
    "ProgramError",
    "Profile",
    "Tracking",
    "Command",
    "Begin",
    "End",
    "Loop",
    "Home",
    "Delay",
    "Speed",
    "Output",
    "Input",
    "Gripper",
    "GripperCalibrate",
    "MoveJoint",
    "MovePose",
    "MoveCart",
    "MoveCartRelTRF",
    "SpeedJoint",
    "MOTION_COMMANDS",
    "Program",
    "ParseResult",
    "format_number",
]


class Severity(enum.Enum):
    """How bad a diagnostic is: errors stop the program from running, warnings do not."""

    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True)
class ScriptError:
    """One diagnostic at a place in a program.

    ``line`` and ``col`` are 1-based; ``text`` is the whole source line (for the caret
    display); ``source_name`` is the file name (or ``<script>``).
    """

    line: int
    col: int
    message: str
    text: str = ""
    severity: Severity = Severity.ERROR
    source_name: str = "<script>"

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR

    def headline(self) -> str:
        """``file:line:col: error: message`` (one line)."""
        return f"{self.source_name}:{self.line}:{self.col}: {self.severity.value}: {self.message}"

    def format(self) -> str:
        """The headline, the offending source line and a caret under the column."""
        out = [self.headline()]
        if self.text.strip():
            shown = self.text.rstrip("\r\n").expandtabs(1)
            out.append(f"    {shown}")
            out.append("    " + " " * max(0, self.col - 1) + "^")
        return "\n".join(out)

    def __str__(self) -> str:
        return self.headline()


class ProgramError(ParolkitError):
    """A program has errors; ``errors`` holds every one of them (never just the first)."""

    def __init__(self, errors: tuple[ScriptError, ...] | list[ScriptError]) -> None:
        self.errors = tuple(errors)
        n = len(self.errors)
        body = "\n".join(e.format() for e in self.errors)
        super().__init__(f"{n} error{'s' if n != 1 else ''} in program:\n{body}")


def format_number(value: float) -> str:
    """Shortest text that reads back as the same float (``90.0`` -> ``90``, ``1.5`` -> ``1.5``)."""
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(float(value))


@dataclass(frozen=True, kw_only=True)
class Command:
    """Base of every command.  ``line``/``col`` (1-based) locate the command name."""

    line: int = 0
    col: int = 0
    text: str = field(default="", compare=False, repr=False)

    #: canonical spelling of the command name (used by the formatter)
    keyword: ClassVar[str] = ""
    #: True for commands that move the arm
    moves: ClassVar[bool] = False

    def arguments(self) -> list[str]:
        """The canonical argument texts (without the name and parentheses)."""
        return []

    def to_source(self) -> str:
        """The command in canonical spelling, e.g. ``MoveJoint(90, -90, 180, 0, 0, 180, t=4)``."""
        return f"{self.keyword}({', '.join(self.arguments())})"


@dataclass(frozen=True, kw_only=True)
class Begin(Command):
    """``Begin()``: the first line of a program."""

    keyword: ClassVar[str] = "Begin"


@dataclass(frozen=True, kw_only=True)
class End(Command):
    """``End()``: the program stops here."""

    keyword: ClassVar[str] = "End"


@dataclass(frozen=True, kw_only=True)
class Loop(Command):
    """``Loop()``: the program restarts from the top."""

    keyword: ClassVar[str] = "Loop"


@dataclass(frozen=True, kw_only=True)
class Home(Command):
    """``Home()``: home the robot (ends in the standby pose)."""

    keyword: ClassVar[str] = "Home"
    moves: ClassVar[bool] = True


@dataclass(frozen=True, kw_only=True)
class Delay(Command):
    """``Delay(t)``: wait ``seconds`` s (at least one control tick)."""

    seconds: float
    keyword: ClassVar[str] = "Delay"

    def arguments(self) -> list[str]:
        return [format_number(self.seconds)]


@dataclass(frozen=True, kw_only=True)
class Speed(Command):
    """``Speed(pct)``: the speed override, 1..100 % of every planned speed, from the move
    running on (it slows down or speeds up on its own path) until the next ``Speed``; the
    controller keeps it after the program ends."""

    percent: float
    keyword: ClassVar[str] = "Speed"

    def arguments(self) -> list[str]:
        return [format_number(self.percent)]


@dataclass(frozen=True, kw_only=True)
class Output(Command):
    """``Output(n, HIGH|LOW)``: set digital output ``port`` (1 or 2)."""

    port: int
    state: bool
    keyword: ClassVar[str] = "Output"

    def arguments(self) -> list[str]:
        return [str(self.port), "HIGH" if self.state else "LOW"]


@dataclass(frozen=True, kw_only=True)
class Input(Command):
    """``Input(n, HIGH|LOW[, timeout])``: wait until input ``port`` (1 or 2) is ``state``.

    ``timeout_s`` None waits without limit; otherwise the program fails after that many s.
    """

    port: int
    state: bool
    timeout_s: float | None = None
    keyword: ClassVar[str] = "Input"

    def arguments(self) -> list[str]:
        out = [str(self.port), "HIGH" if self.state else "LOW"]
        if self.timeout_s is not None:
            out.append(f"t={format_number(self.timeout_s)}")
        return out


@dataclass(frozen=True, kw_only=True)
class Gripper(Command):
    """``Gripper(position, speed, current)``: move the SSG-48 (0-255, 0-255, mA).

    Like the original, the program does not wait for the gripper: add a ``Delay``.
    """

    position: int
    speed: int
    current_ma: int
    keyword: ClassVar[str] = "Gripper"

    def arguments(self) -> list[str]:
        return [str(self.position), str(self.speed), str(self.current_ma)]


@dataclass(frozen=True, kw_only=True)
class GripperCalibrate(Command):
    """``Gripper_cal()``: calibrate and activate the SSG-48 (follow it with a Delay)."""

    keyword: ClassVar[str] = "Gripper_cal"


def _move_options(move: JointMove | PoseMove | CartMove | CartRelTRFMove) -> list[str]:
    """The options of a move statement in canonical order: ``v=``, ``a=``, ``t=``, ``r=`` (the
    blend radius), the profile word and ``speed`` (SPEED tracking); unset options are left out."""
    out = []
    if move.speed_pct is not None:
        out.append(f"v={format_number(move.speed_pct)}")
    accel = move.accel_pct if isinstance(move, (JointMove, PoseMove)) else None
    if accel is not None:
        out.append(f"a={format_number(accel)}")
    if move.duration_s is not None:
        out.append(f"t={format_number(move.duration_s)}")
    blend = move.blend if isinstance(move, (JointMove, PoseMove, CartMove)) else None
    if blend is not None:
        out.append(f"r={format_number(blend)}")
    if isinstance(move.profile, Profile):
        out.append(move.profile.value)
    if move.tracking is Tracking.SPEED:
        out.append("speed")
    return out


@dataclass(frozen=True, kw_only=True)
class MoveJoint(Command):
    """``MoveJoint(j1..j6, ...)``: joint-space move to ``move.target_deg`` (deg).

    ``move``'s ``duration_s`` (s, ``t=``) overrides ``speed_pct``/``accel_pct`` (``v=``/``a=``,
    0-100 % of the leading joint's range); ``profile`` None means the language's default;
    ``tracking`` SPEED is the trailing word ``speed``; ``blend`` (``r=``, deg, 0-100) rounds the
    corner into the next move of the program (a MoveJoint or MovePose) instead of stopping at
    the target.
    """

    move: JointMove
    keyword: ClassVar[str] = "MoveJoint"
    moves: ClassVar[bool] = True

    def arguments(self) -> list[str]:
        return [format_number(v) for v in self.move.target_deg] + _move_options(self.move)


@dataclass(frozen=True, kw_only=True)
class MovePose(Command):
    """``MovePose(x, y, z, A, B, C, ...)``: IK once, joint-space path to ``move.pose`` (mm, deg);
    options as :class:`MoveJoint`'s (``r=`` in deg)."""

    move: PoseMove
    keyword: ClassVar[str] = "MovePose"
    moves: ClassVar[bool] = True

    def arguments(self) -> list[str]:
        return [format_number(v) for v in self.move.pose] + _move_options(self.move)


@dataclass(frozen=True, kw_only=True)
class MoveCart(Command):
    """``MoveCart(x, y, z, A, B, C, ...)``: straight line to ``move.pose`` (mm, deg, WRF);
    ``r=`` (``move.blend``, mm, 0-100) rounds the corner into the next MoveCart of the program."""

    move: CartMove
    keyword: ClassVar[str] = "MoveCart"
    moves: ClassVar[bool] = True

    def arguments(self) -> list[str]:
        return [format_number(v) for v in self.move.pose] + _move_options(self.move)


@dataclass(frozen=True, kw_only=True)
class MoveCartRelTRF(Command):
    """``MoveCartRelTRF(dx, dy, dz, dA, dB, dC, ...)``: straight line by ``move.delta``
    relative to the tool frame (mm, deg)."""

    move: CartRelTRFMove
    keyword: ClassVar[str] = "MoveCartRelTRF"
    moves: ClassVar[bool] = True

    def arguments(self) -> list[str]:
        return [format_number(v) for v in self.move.delta] + _move_options(self.move)


@dataclass(frozen=True, kw_only=True)
class SpeedJoint(Command):
    """``SpeedJoint(s1..s6, t=T)``: constant joint speeds ``move.speeds_deg_s`` (deg/s) for
    ``move.duration_s`` s."""

    move: SpeedJointMove
    keyword: ClassVar[str] = "SpeedJoint"
    moves: ClassVar[bool] = True

    def arguments(self) -> list[str]:
        return ([format_number(v) for v in self.move.speeds_deg_s]
                + [f"t={format_number(self.move.duration_s)}"])


#: The commands that move the arm.
MOTION_COMMANDS = (MoveJoint, MovePose, MoveCart, MoveCartRelTRF, SpeedJoint, Home)


@dataclass(frozen=True)
class Program:
    """A parsed program: its commands in source order and where it came from."""

    commands: tuple[Command, ...]
    source_name: str = "<script>"
    warnings: tuple[ScriptError, ...] = ()

    @property
    def loops(self) -> bool:
        """True when the program ends with ``Loop()``."""
        return bool(self.commands) and isinstance(self.commands[-1], Loop)

    @property
    def lines(self) -> tuple[int, ...]:
        """Source line of each command."""
        return tuple(c.line for c in self.commands)

    def __len__(self) -> int:
        return len(self.commands)

    def __iter__(self) -> Iterator[Command]:
        return iter(self.commands)


@dataclass(frozen=True)
class ParseResult:
    """What :func:`parolkit.script.parse` returns: a program, or every error in the text.

    ``program`` is None exactly when ``errors`` is not empty.  ``warnings`` never stop a run.
    """

    program: Program | None
    errors: tuple[ScriptError, ...] = ()
    warnings: tuple[ScriptError, ...] = ()

    @property
    def ok(self) -> bool:
        return not self.errors

    def diagnostics(self) -> tuple[ScriptError, ...]:
        """Errors and warnings in source order."""
        return tuple(sorted(self.errors + self.warnings, key=lambda d: (d.line, d.col, d.severity.value)))

    def unwrap(self) -> Program:
        """The program, or raise :class:`ProgramError` with every error."""
        if self.errors or self.program is None:
            raise ProgramError(self.errors)
        return self.program
