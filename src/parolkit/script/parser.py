"""RBTscript parser: text -> typed :class:`~parolkit.script.program.Program`, or every error.

Parsing happens in two steps, both on one source line at a time, so that a bad line never
hides the errors of the lines after it:

1. The lark grammar (``rbtscript.lark``, LALR) checks the shape of the line: a call
   ``Name(arg, arg, key=value, word)`` with optional whitespace and a ``#``/``//`` comment.
   Lark's exceptions are turned into a :class:`ScriptError` with the column and a message
   that says what was expected (``missing ')'``, ``unexpected '.' after the number 141.983``).
2. The builder checks the call against the command's signature (names are case-insensitive;
   the original spellings are the canonical ones) and the argument ranges that do not depend
   on the robot's state: joint limits, speed/acceleration percentages, durations, gripper
   ranges, I/O ports.  Reachability and path checks need the motion layer and happen in the
   dry run (:mod:`parolkit.script.dryrun`).

Finally the program structure is checked: ``Begin()`` first, ``End()``/``Loop()`` last.

:func:`parse` never raises for any input text: it returns a :class:`ParseResult` holding a
program or the list of errors.
"""

from __future__ import annotations

import difflib
import re
import threading
import unicodedata
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from parolkit.errors import ParolkitValueError
from parolkit.moves import MAX_BLEND, CartMove, CartRelTRFMove, JointMove, PoseMove, Profile, SpeedJointMove, Tracking
from parolkit.number_syntax import parse_number
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
    Program,
    ProgramError,
    ScriptError,
    Severity,
    Speed,
    SpeedJoint,
    format_number,
)

if TYPE_CHECKING:  # lark is imported when the first program is parsed
    from lark import Lark, Token, Tree
    from lark.exceptions import LarkError

    from parolkit.robot import RobotModel

__all__ = ["parse", "parse_file", "read_source", "load", "Limits", "COMMAND_NAMES", "line_comment"]

GRAMMAR_PATH = Path(__file__).with_name("rbtscript.lark")

#: Canonical command names, as the original software spells them.
COMMAND_NAMES = (
    "Begin",
    "End",
    "Loop",
    "MoveJoint",
    "MovePose",
    "MoveCart",
    "MoveCartRelTRF",
    "SpeedJoint",
    "Delay",
    "Speed",
    "Output",
    "Input",
    "Gripper",
    "Gripper_cal",
    "Home",
)


@dataclass(frozen=True)
class Limits:
    """The ranges the parser checks (defaults: the stock PAROL6 at 100 Hz).

    ``joint_limits_deg``: (low, high) per joint, deg (the robot model's safe limits);
    ``max_joint_speed_deg_s``: per joint, deg/s; ``tick_s``: one control tick, s (the
    shortest Delay); ``max_duration_s``: the longest move / SpeedJoint, s;
    ``max_wait_s``: the longest Delay / Input timeout, s.
    """

    joint_limits_deg: tuple[tuple[float, float], ...]
    max_joint_speed_deg_s: tuple[float, ...]
    tick_s: float = 0.01
    max_duration_s: float = 3600.0
    max_wait_s: float = 86400.0
    gripper_current_ma: tuple[int, int] = (0, 1300)

    @classmethod
    def from_model(cls, model: RobotModel | None = None, *, rate_hz: float = 100.0) -> Limits:
        """Limits of a :class:`parolkit.robot.RobotModel` (default the stock PAROL6)."""
        from parolkit.robot import PAROL6

        m = model or PAROL6
        lim = m.safe_limits_deg
        return cls(
            joint_limits_deg=tuple((float(lo), float(hi)) for lo, hi in lim),
            max_joint_speed_deg_s=tuple(float(v) for v in m.max_speed_deg_s),
            tick_s=1.0 / rate_hz,
        )


_default_limits: Limits | None = None


def _limits(limits: Limits | None) -> Limits:
    global _default_limits
    if limits is not None:
        return limits
    if _default_limits is None:
        _default_limits = Limits.from_model()
    return _default_limits


# ------------------------------------------------------------------------------------------
# lark
# ------------------------------------------------------------------------------------------

_lark_lock = threading.Lock()
_lark: Lark | None = None


def _parser() -> Lark:
    global _lark
    if _lark is None:
        from lark import Lark

        _lark = Lark(
            GRAMMAR_PATH.read_text(encoding="utf-8"),
            parser="lalr",
            maybe_placeholders=False,
        )
    return _lark


_TERMINALS = {
    "LPAR": "'('",
    "COMMA": "','",
    "RPAR": "')'",
    "EQUAL": "'='",
    "NAME": "a name",
    "NUMBER": "a number",
    "STRING": "a quoted word",
    "$END": "the end of the line",
    "<END-OF-FILE>": "the end of the line",
}
_END_TYPES = ("$END", "<END-OF-FILE>")


def _expected_text(names: Iterable[str]) -> str:
    order = list(_TERMINALS)
    words: list[str] = []
    for n in sorted(set(names), key=lambda n: order.index(n) if n in order else len(order)):
        w = _TERMINALS.get(n, n)
        if w not in words:
            words.append(w)
    if not words:
        return "nothing"
    if len(words) == 1:
        return words[0]
    return ", ".join(words[:-1]) + " or " + words[-1]


def line_comment(text: str) -> tuple[str, str]:
    """Split a source line into (code, comment).  The comment keeps its ``#`` or ``//``."""
    quote = None
    i = 0
    while i < len(text):
        ch = text[i]
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch == "#" or text.startswith("//", i):
            return text[:i], text[i:]
        i += 1
    return text, ""


def _end_col(text: str) -> int:
    code, _ = line_comment(text)
    return len(code.rstrip()) + 1


def _syntax_error(exc: LarkError, text: str) -> tuple[int, str]:
    """(column, message) for a lark exception on one line."""
    from lark import UnexpectedCharacters, UnexpectedToken

    if isinstance(exc, UnexpectedCharacters):
        col = exc.column
        ch = exc.char
        allowed = getattr(exc, "allowed", None) or set()
        before = text[: col - 1]
        m = re.search(r"[+-]?(\d+(\.\d*)?|\.\d+)$", before)
        if ch == "." and m:
            msg = (
                f"unexpected '.' after the number {m.group(0)}: a number has one decimal point"
                f"; expected {_expected_text(allowed)}"
            )
        elif ch == ";":
            msg = "unexpected ';': RBTscript has one command per line and no ';'"
        else:
            msg = f"unexpected character {ch!r}"
            if not (ch.isascii() and ch.isprintable()):  # a control character, a look-alike, a no-break space
                name = unicodedata.name(ch, "")
                msg += f" (U+{ord(ch):04X} {name})" if name else f" (U+{ord(ch):04X})"
            if allowed:
                msg += f": expected {_expected_text(allowed)}"
        return col, msg
    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        expected = set(exc.expected or ())
        if tok.type in _END_TYPES:
            col = _end_col(text)
            if "RPAR" in expected:
                return col, "missing ')' at the end of the command"
            if "LPAR" in expected:
                code = line_comment(text)[0].strip()
                example = f"{code}()" if re.fullmatch(r"[A-Za-z_]\w*", code) else "End()"
                return col, f"missing '(': a command is written Name(arguments), e.g. {example}"
            return col, f"unexpected end of the line: expected {_expected_text(expected)}"
        col = tok.column if tok.column else 1
        value = str(tok)
        if expected <= set(_END_TYPES):
            return col, (
                f"unexpected {value!r} after the command: one command per line "
                "(start a comment with # or //)"
            )
        if "LPAR" in expected:
            return col, f"expected '(' after the command name, got {value!r}"
        if tok.type == "NUMBER" and "NAME" in expected and "NUMBER" not in expected:
            return col, f"a line must start with a command name, got {value!r}"
        key = re.search(r"([A-Za-z_]\w*)\s*=\s*$", text[: col - 1])
        if key and tok.type in ("COMMA", "RPAR"):
            return col, f"missing value after '{key.group(1)}='"
        if tok.type == "COMMA" and "NUMBER" in expected:
            return col, "missing value: two ',' in a row (or ',' right after '(')"
        if tok.type == "RPAR" and "NUMBER" in expected:
            return col, "missing value after ',' before ')'"
        return col, f"unexpected {value!r}: expected {_expected_text(expected)}"
    col = getattr(exc, "column", 1) or 1
    return (col if col > 0 else 1), f"syntax error: {exc}"


# ------------------------------------------------------------------------------------------
# builder
# ------------------------------------------------------------------------------------------


@dataclass
class _Arg:
    """One argument of a call as written.  ``kind``: number, word, string or keyword."""

    kind: str
    col: int
    raw: str
    key: str = ""
    value: _Arg | None = None

    @property
    def keyword_value(self) -> _Arg:
        """The value of a ``key=value`` argument."""
        if self.value is None:
            raise TypeError(f"internal error: {self.raw!r} is not a key=value argument")
        return self.value

    @property
    def word(self) -> str:
        """The lower-case text of a word or quoted string ('' for numbers)."""
        if self.kind == "word":
            return self.raw.lower()
        if self.kind == "string":
            return self.raw[1:-1].strip().lower()
        return ""


class _Reject(Exception):
    """Internal: stop building this line (the error is already recorded)."""


class _Line:
    """Diagnostics collector and typed-argument helpers for one source line."""

    def __init__(self, line: int, text: str, source_name: str, limits: Limits) -> None:
        self.line = line
        self.text = text
        self.source_name = source_name
        self.limits = limits
        self.errors: list[ScriptError] = []
        self.warnings: list[ScriptError] = []

    def _diag(self, col: int, message: str, severity: Severity) -> ScriptError:
        return ScriptError(self.line, col, message, self.text, severity, self.source_name)

    def error(self, col: int, message: str) -> None:
        self.errors.append(self._diag(col, message, Severity.ERROR))

    def warn(self, col: int, message: str) -> None:
        self.warnings.append(self._diag(col, message, Severity.WARNING))

    def fail(self, col: int, message: str) -> NoReturn:
        self.error(col, message)
        raise _Reject

    # -- typed values --------------------------------------------------------------------

    def number(self, arg: _Arg, what: str) -> float:
        if arg.kind == "keyword":
            self.fail(arg.col, f"{what} must be a plain number here, not {arg.key}=...")
        if arg.kind != "number":
            self.fail(arg.col, f"{what} must be a number, got {arg.raw!r}")
        try:
            return parse_number(arg.raw, what)
        except ParolkitValueError as exc:
            self.fail(arg.col, str(exc))

    def ranged(self, arg: _Arg, what: str, lo: float, hi: float, unit: str = "", *, lo_open: bool = False) -> float:
        value = self.number(arg, what)
        low_bad = value <= lo if lo_open else value < lo
        if low_bad or value > hi:
            u = f" {unit}" if unit else ""
            rng = f"{'>' if lo_open else ''}{format_number(lo)} .. {format_number(hi)}{u}"
            self.error(arg.col, f"{what} = {arg.raw}{u} is out of range (allowed {rng})")
        return value

    def integer(self, arg: _Arg, what: str, lo: int, hi: int, unit: str = "") -> int:
        value = self.number(arg, what)
        if not value.is_integer():
            self.fail(arg.col, f"{what} must be a whole number in {lo} .. {hi}, got {arg.raw}")
        u = f" {unit}" if unit else ""
        if not lo <= value <= hi:
            self.fail(arg.col, f"{what} = {arg.raw}{u} is out of range (allowed {lo} .. {hi}{u})")
        return int(value)

    def level(self, arg: _Arg, what: str) -> bool:
        if arg.kind == "number":
            if arg.raw.lstrip("+") in ("0", "1"):
                return arg.raw.lstrip("+") == "1"
            self.fail(arg.col, f"{what} must be HIGH or LOW (or 1 / 0), got {arg.raw}")
        w = arg.word
        if w in ("high", "on", "true"):
            return True
        if w in ("low", "off", "false"):
            return False
        self.fail(arg.col, f"{what} must be HIGH or LOW (or 1 / 0), got {arg.raw!r}")
        return False  # unreachable


def _split_args(ln: _Line, name: str, args: list[_Arg]) -> tuple[list[_Arg], list[_Arg]]:
    """Positional values first, then options (keywords and words).  A value after an option
    is an error naming it."""
    positional: list[_Arg] = []
    options: list[_Arg] = []
    for a in args:
        if a.kind == "number" and options:
            ln.fail(a.col, f"{name}: the value {a.raw} comes after an option; values go first, then options")
        (options if options or a.kind != "number" else positional).append(a)
    return positional, options


def _exact_count(ln: _Line, name: str, call_col: int, values: list[_Arg], n: int, what: str) -> None:
    if len(values) < n:
        ln.fail(call_col, f"{name} takes {n} {what}, got {len(values)}")
    if len(values) > n:
        extra = values[n]
        ln.fail(extra.col, f"{name} takes {n} {what}, got {len(values)}: {extra.raw} is one too many")


#: a command's builder: (line, name as written, column of the name, arguments) -> the command
_Builder = Callable[[_Line, str, int, list[_Arg]], Command]


def _no_args(cls: type[Command]) -> _Builder:
    def build(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
        if args:
            n = len(args)
            ln.fail(args[0].col, f"{cls.keyword}() takes no arguments, got {n}")
        return cls(line=ln.line, col=col, text=ln.text)

    return build


_PROFILE_WORDS = {p.value: p for p in Profile}


def _move_builder(cls: type[Command], values_what: str, *, joint_values: bool, allow_va: bool,
                  allow_a: bool, blend_unit: str | None) -> _Builder:
    """Builder for the four moves: 6 values, then v=/a=/t=, r= (the blend radius in
    ``blend_unit``; None: the move does not blend), a profile word and ``speed``."""

    def build(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
        kw = cls.keyword
        values, options = _split_args(ln, kw, args)
        _exact_count(ln, kw, col, values, 6, values_what)
        nums: list[float] = []
        for i, a in enumerate(values):
            if joint_values:
                lo, hi = ln.limits.joint_limits_deg[i]
                v = ln.number(a, f"J{i + 1}")
                if not lo <= v <= hi:
                    ln.error(
                        a.col,
                        f"J{i + 1} = {a.raw} deg is outside the joint limits "
                        f"({lo:.3f} .. {hi:.3f} deg)",
                    )
                nums.append(v)
            else:
                nums.append(ln.number(a, ("x", "y", "z", "A", "B", "C")[i] if kw != "MoveCartRelTRF"
                                      else ("dx", "dy", "dz", "dA", "dB", "dC")[i]))
        seen: dict[str, _Arg] = {}
        speed: float | None = None
        accel: float | None = None
        duration: float | None = None
        blend: float | None = None
        profile: Profile | None = None
        tracking = Tracking.POSITION
        allowed_kw = (["t"] + (["v"] if allow_va else []) + (["a"] if allow_a else [])
                      + (["r"] if blend_unit is not None else []))
        for opt in options:
            if opt.kind == "keyword":
                key = opt.key.lower()
                if key == "func":
                    target = opt.keyword_value
                    slot = "profile"
                else:
                    target = opt
                    slot = key
                if key not in allowed_kw and key != "func":
                    words = ", ".join(f"{k}=" for k in allowed_kw)
                    hint = ""
                    if key == "a" and not allow_a:
                        hint = f" ({kw} takes no acceleration; give t= for the duration)"
                    elif key == "r" and blend_unit is None:
                        hint = f" ({kw} does not blend: r= is for MoveJoint, MovePose and MoveCart)"
                    ln.fail(opt.col, f"{kw} has no option {opt.key}=: allowed {words}, a profile "
                                     f"({', '.join(_PROFILE_WORDS)}) and speed{hint}")
            else:
                target = opt
                w = opt.word
                if w in _PROFILE_WORDS:
                    slot = "profile"
                elif w == "speed":
                    slot = "speed"
                else:
                    close = difflib.get_close_matches(w, [*_PROFILE_WORDS, "speed"], n=1)
                    hint = f"; did you mean {close[0]!r}?" if close else ""
                    ln.fail(opt.col, f"{kw}: unknown option {opt.raw!r}: expected "
                                     f"{', '.join(f'{k}=' for k in allowed_kw)}, "
                                     f"{', '.join(_PROFILE_WORDS)} or speed{hint}")
            if slot in seen:
                ln.fail(opt.col, f"{kw}: {slot if len(slot) > 1 else slot + '='} is given twice "
                                 f"(first at column {seen[slot].col})")
            seen[slot] = opt
            # an explicit 0 is the seed's "not given" (its signature: v=0, a=0, t=0)
            if slot == "t":
                duration = _unless_zero(ln, target.keyword_value, "t", ln.limits.max_duration_s, "s")
            elif slot == "v":
                speed = _unless_zero(ln, target.keyword_value, "v", 100.0, "%")
            elif slot == "a":
                accel = _unless_zero(ln, target.keyword_value, "a", 100.0, "%")
            elif slot == "r" and blend_unit is not None:
                # 0 is "no blending" (the move stops at its target), as on the wire
                blend = ln.ranged(target.keyword_value, "r", 0.0, MAX_BLEND, blend_unit) or None
            elif slot == "profile":
                w = target.word
                if w not in _PROFILE_WORDS:
                    ln.fail(target.col, f"func must be one of {', '.join(_PROFILE_WORDS)}, got {target.raw!r}")
                profile = _PROFILE_WORDS[w]
            elif slot == "speed":
                tracking = Tracking.SPEED
        if duration is not None and (speed is not None or accel is not None):
            which = " and ".join(k + "=" for k, v in (("v", speed), ("a", accel)) if v is not None)
            ln.warn(seen["t"].col, f"t= overrides {which}: the move takes exactly {format_number(duration)} s")
        if ln.errors:
            raise _Reject
        line, text = ln.line, ln.text
        six = tuple(nums)
        if cls is MoveJoint:
            return MoveJoint(move=JointMove(six, duration, speed, accel, profile, tracking, blend=blend),
                             line=line, col=col, text=text)
        if cls is MovePose:
            return MovePose(move=PoseMove(six, duration, speed, accel, profile, tracking, blend=blend),
                            line=line, col=col, text=text)
        if cls is MoveCart:
            return MoveCart(move=CartMove(six, duration, speed, profile, tracking, blend=blend),
                            line=line, col=col, text=text)
        return MoveCartRelTRF(move=CartRelTRFMove(six, duration, speed, profile, tracking),
                              line=line, col=col, text=text)

    return build


def _unless_zero(ln: _Line, arg: _Arg, what: str, hi: float, unit: str) -> float | None:
    """A move's ``t=`` / ``v=`` / ``a=`` value in (0, ``hi``], or None for an explicit 0: the
    seed's signature ``MoveJoint(j1, ..., v=0, a=0, t=0)`` writes "not given" as 0."""
    if ln.number(arg, what) == 0.0:
        return None
    return ln.ranged(arg, what, 0.0, hi, unit, lo_open=True)


def _build_speed_joint(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
    values, options = _split_args(ln, "SpeedJoint", args)
    _exact_count(ln, "SpeedJoint", col, values, 6, "joint speeds (deg/s) and then t=duration")
    speeds: list[float] = []
    for i, a in enumerate(values):
        hi = ln.limits.max_joint_speed_deg_s[i]
        speeds.append(ln.ranged(a, f"J{i + 1} speed", -hi, hi, "deg/s"))
    duration: float | None = None
    for opt in options:
        if opt.kind == "keyword" and opt.key.lower() == "t":
            if duration is not None:
                ln.fail(opt.col, "SpeedJoint: t= is given twice")
            duration = ln.ranged(opt.keyword_value, "t", 0.0, ln.limits.max_duration_s, "s", lo_open=True)
        else:
            ln.fail(opt.col, f"SpeedJoint has no option {opt.raw!r}: it takes 6 speeds (deg/s) and t=duration (s)")
    if duration is None:
        ln.fail(col, "SpeedJoint needs the duration: SpeedJoint(s1, s2, s3, s4, s5, s6, t=seconds)")
    if ln.errors:
        raise _Reject
    if all(s == 0 for s in speeds):
        ln.warn(col, "all SpeedJoint speeds are 0: the robot holds still for the duration")
    return SpeedJoint(line=ln.line, col=col, text=ln.text, move=SpeedJointMove(tuple(speeds), duration))


def _build_delay(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
    values, options = _split_args(ln, "Delay", args)
    if options:
        ln.fail(options[0].col, f"Delay takes one number of seconds, got {options[0].raw!r}")
    _exact_count(ln, "Delay", col, values, 1, "value (seconds)")
    tick = ln.limits.tick_s
    seconds = ln.ranged(values[0], "Delay", tick, ln.limits.max_wait_s, "s")
    if ln.errors:
        if 0 < seconds < tick:
            ln.errors[-1] = ln._diag(values[0].col, f"Delay = {values[0].raw} s is shorter than one control "
                                     f"tick (minimum {format_number(tick)} s)", Severity.ERROR)
        raise _Reject
    return Delay(line=ln.line, col=col, text=ln.text, seconds=seconds)


def _build_speed(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
    values, options = _split_args(ln, "Speed", args)
    if options:
        ln.fail(options[0].col, f"Speed takes one number, the override in % (1 .. 100), got {options[0].raw!r}")
    _exact_count(ln, "Speed", col, values, 1, "value (the speed override, %)")
    percent = ln.ranged(values[0], "Speed", 1.0, 100.0, "%")
    if ln.errors:
        raise _Reject
    return Speed(line=ln.line, col=col, text=ln.text, percent=percent)


def _port(ln: _Line, arg: _Arg, kind: str) -> int:
    value = ln.number(arg, f"{kind} number")
    if value not in (1.0, 2.0):
        ln.fail(arg.col, f"{kind} number must be 1 or 2, got {arg.raw}")
    return int(value)


def _build_output(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
    if len(args) != 2:
        where = args[2].col if len(args) > 2 else col
        ln.fail(where, f"Output takes 2 arguments (port 1|2, HIGH|LOW), got {len(args)}")
    port = _port(ln, args[0], "output")
    state = ln.level(args[1], "output state")
    return Output(line=ln.line, col=col, text=ln.text, port=port, state=state)


def _build_input(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
    if len(args) not in (2, 3):
        where = args[3].col if len(args) > 3 else col
        ln.fail(where, f"Input takes 2 or 3 arguments (port 1|2, HIGH|LOW[, timeout s]), got {len(args)}")
    port = _port(ln, args[0], "input")
    state = ln.level(args[1], "input state")
    timeout = None
    if len(args) == 3:
        t = args[2]
        if t.kind == "keyword":
            if t.key.lower() not in ("t", "timeout"):
                ln.fail(t.col, f"Input has no option {t.key}=: the third argument is the timeout in s")
            t = t.keyword_value
        timeout = ln.ranged(t, "Input timeout", 0.0, ln.limits.max_wait_s, "s", lo_open=True)
        if ln.errors:
            raise _Reject
    return Input(line=ln.line, col=col, text=ln.text, port=port, state=state, timeout_s=timeout)


def _build_gripper(ln: _Line, name: str, col: int, args: list[_Arg]) -> Command:
    values, options = _split_args(ln, "Gripper", args)
    if options:
        ln.fail(options[0].col, f"Gripper takes 3 numbers (position, speed, current), got {options[0].raw!r}")
    _exact_count(ln, "Gripper", col, values, 3, "values (position 0-255, speed 0-255, current mA)")
    lo_ma, hi_ma = ln.limits.gripper_current_ma
    position = ln.integer(values[0], "gripper position", 0, 255)
    speed = ln.integer(values[1], "gripper speed", 0, 255)
    current = ln.integer(values[2], "gripper current", lo_ma, hi_ma, "mA")
    if current < 150:
        ln.warn(values[2].col, f"gripper current {current} mA is usually too weak to move the gripper")
    if current > 700 and speed > 127:
        ln.warn(values[2].col, f"gripper current {current} mA with speed {speed} is dangerous for the "
                               "gripper and the object (keep current <= 700 mA at high speed)")
    return Gripper(line=ln.line, col=col, text=ln.text, position=position, speed=speed, current_ma=current)


def _norm(name: str) -> str:
    return name.lower().replace("_", "")


_BUILDERS: dict[str, _Builder] = {
    "begin": _no_args(Begin),
    "end": _no_args(End),
    "loop": _no_args(Loop),
    "home": _no_args(Home),
    "grippercal": _no_args(GripperCalibrate),
    "delay": _build_delay,
    "speed": _build_speed,
    "output": _build_output,
    "input": _build_input,
    "gripper": _build_gripper,
    "speedjoint": _build_speed_joint,
    "movejoint": _move_builder(MoveJoint, "joint values (j1..j6, deg)", joint_values=True, allow_va=True,
                               allow_a=True, blend_unit="deg"),
    "movepose": _move_builder(
        MovePose, "pose values (x, y, z mm, A, B, C deg)", joint_values=False, allow_va=True, allow_a=True,
        blend_unit="deg",
    ),
    "movecart": _move_builder(
        MoveCart, "pose values (x, y, z mm, A, B, C deg)", joint_values=False, allow_va=True, allow_a=False,
        blend_unit="mm",
    ),
    "movecartreltrf": _move_builder(
        MoveCartRelTRF, "values (dx, dy, dz mm, dA, dB, dC deg)", joint_values=False, allow_va=True, allow_a=False,
        blend_unit=None,
    ),
}
_CANONICAL = {_norm(n): n for n in COMMAND_NAMES}


# The shape of a line's parse tree is fixed by rbtscript.lark: these two say which kind of
# node the grammar puts at a place (a rule, or a token with its column).


def _rule(node: Tree[Token] | Token) -> Tree[Token]:
    from lark import Tree

    if not isinstance(node, Tree):
        raise TypeError(f"internal error: the RBTscript grammar gave a token {node!r} where a rule belongs")
    return node


def _token(node: Tree[Token] | Token) -> tuple[str, int]:
    """(text, column) of a token."""
    from lark import Token

    if not isinstance(node, Token) or node.column is None:
        raise TypeError(f"internal error: the RBTscript grammar gave {node!r} where a token belongs")
    return str(node), node.column


def _args_of(tree: Tree[Token]) -> list[_Arg]:
    out = []
    for child in tree.children:
        node = _rule(child)
        kind = node.data
        if kind == "keyword":
            key_node, val_child = node.children
            key, key_col = _token(key_node)
            val_node = _rule(val_child)
            val, val_col = _token(val_node.children[0])
            value = _Arg(val_node.data, val_col, val)
            out.append(_Arg("keyword", key_col, f"{key}={val}", key, value))
        else:
            text, col = _token(node.children[0])
            out.append(_Arg(kind, col, text))
    return out


def _build_line(ln: _Line, tree: Tree[Token]) -> Command | None:
    if not tree.children:
        return None
    call = _rule(tree.children[0])
    name, col = _token(call.children[0])
    args = _args_of(_rule(call.children[1])) if len(call.children) > 1 else []
    builder = _BUILDERS.get(_norm(name))
    if builder is None:
        close = difflib.get_close_matches(_norm(name), list(_CANONICAL), n=1, cutoff=0.6)
        hint = f"; did you mean {_CANONICAL[close[0]]}?" if close else f" (known: {', '.join(COMMAND_NAMES)})"
        ln.error(col, f"unknown command {name!r}{hint}")
        return None
    try:
        return builder(ln, name, col, args)
    except _Reject:
        return None


# ------------------------------------------------------------------------------------------
# structure
# ------------------------------------------------------------------------------------------


def _structure(commands: list[Command], source_name: str, errors: list[ScriptError],
               warnings: list[ScriptError]) -> None:
    def diag(cmd: Command, msg: str, sev: Severity) -> ScriptError:
        return ScriptError(cmd.line, cmd.col, msg, cmd.text, sev, source_name)

    if not commands:
        return
    first = commands[0]
    if not isinstance(first, Begin):
        warnings.append(diag(first, "the program does not start with Begin(); it starts here", Severity.WARNING))
    for i, cmd in enumerate(commands):
        if isinstance(cmd, Begin) and i > 0:
            errors.append(diag(cmd, f"Begin() must be the first command (line {commands[0].line} comes before it)",
                               Severity.ERROR))
        if isinstance(cmd, (End, Loop)) and i < len(commands) - 1:
            nxt = commands[i + 1]
            errors.append(diag(cmd, f"{cmd.keyword}() must be the last command, but line {nxt.line} "
                                    f"({nxt.keyword}) follows it", Severity.ERROR))
    last = commands[-1]
    if not isinstance(last, (End, Loop)):
        warnings.append(diag(last, f"the program has no End() or Loop(): it ends after line {last.line}",
                             Severity.WARNING))


# ------------------------------------------------------------------------------------------
# public
# ------------------------------------------------------------------------------------------


def parse(text: str, source_name: str = "<script>", *, limits: Limits | None = None) -> ParseResult:
    """Parse RBTscript ``text`` into a :class:`ParseResult`; never raises for any text.

    Every line is checked, so the result lists ALL errors (each with line, column, message
    and the source line).  ``program`` is set only when there is no error.  ``limits`` are the
    ranges checked (default: the stock PAROL6, see :class:`Limits`).
    """
    from lark.exceptions import LarkError

    lim = _limits(limits)
    if not isinstance(text, str):
        raise TypeError(f"parse() needs text (str), got {type(text).__name__}")
    lines = text.split("\n")
    commands: list[Command] = []
    errors: list[ScriptError] = []
    warnings: list[ScriptError] = []
    parser = _parser()
    for number, raw in enumerate(lines, start=1):
        line_text = raw[:-1] if raw.endswith("\r") else raw
        if not line_text.strip():
            continue
        ln = _Line(number, line_text, source_name, lim)
        with _lark_lock:
            try:
                tree = parser.parse(line_text)
            except LarkError as exc:
                col, msg = _syntax_error(exc, line_text)
                ln.error(col, msg)
                tree = None
        if tree is not None:
            cmd = _build_line(ln, tree)
            if cmd is not None and not ln.errors:
                commands.append(cmd)
        errors.extend(ln.errors)
        warnings.extend(ln.warnings)
    if not commands and not errors:
        errors.append(ScriptError(1, 1, "the program has no commands", lines[0] if lines else "",
                                  Severity.ERROR, source_name))
    _structure(commands, source_name, errors, warnings)
    errors.sort(key=lambda e: (e.line, e.col))
    warnings.sort(key=lambda e: (e.line, e.col))
    if errors:
        return ParseResult(None, tuple(errors), tuple(warnings))
    return ParseResult(Program(tuple(commands), source_name, tuple(warnings)), (), tuple(warnings))


def read_source(path: str | Path) -> str | ScriptError:
    """The text of a program file (UTF-8; a byte-order mark is allowed), or the error that says
    why it cannot be read or decoded (at the line of the first bad byte; the source name is the
    path as given)."""
    p = Path(path)
    try:
        data = p.read_bytes()
        return data.decode("utf-8-sig")
    except OSError as exc:
        return ScriptError(1, 1, f"cannot read the file: {exc.strerror or exc}", "", Severity.ERROR, str(path))
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        return ScriptError(line, 1, f"the file is not UTF-8 text ({exc.reason} at byte {exc.start})", "",
                           Severity.ERROR, str(path))


def parse_file(path: str | Path, *, limits: Limits | None = None) -> ParseResult:
    """Parse a program file (see :func:`read_source`); a file that cannot be read or decoded
    is reported as an error."""
    text = read_source(path)
    if isinstance(text, ScriptError):
        return ParseResult(None, (text,))
    return parse(text, str(path), limits=limits)


def load(path: str | Path, *, limits: Limits | None = None) -> Program:
    """Parse a program file and return the program, or raise :class:`ProgramError` (all errors)."""
    return parse_file(path, limits=limits).unwrap()


__all__ += ["ProgramError"]
