"""Program errors in words a student understands (no NiceGUI: tested without a browser).

The parser, the dry run (Check, and the check before every run) and the controller during a
run say what is wrong in an engineer's words: ``editor:4:1: error: MovePose cannot be planned
from [90.00, ...] deg: pose [...] is not reachable: joint J2 would be 34.0 deg > -3.375
(allowed -145 .. -3.375 deg) in the closest branch (front down noflip)``, ``J1 speed 19200
steps/s exceeds ...``, ``... the bounded GO TO frames ...``.  The commander shows each one as
the program's name and line, one plain sentence and the fix::

    pick.rbt: J2 would pass its limit at line 4: try a higher Z

:func:`explain` turns one :class:`~parolkit.script.ScriptError` (a parse error, a dry-run
error, or the error of the line the controller refused, cancelled or failed) into a
:class:`StudentError`.  The messages are matched by :data:`RULES`, one per kind of error,
most specific first; the words a message carries (the joint, the limit, the time a move
needs, the two things that would collide) go into the sentence.  Every kind of message the
parser, the dry run, the planner and the controller can produce has a rule
(``tests/unit/test_gui_student_errors.py`` finds them in the source: a new kind fails that
test until it has one); the technical message itself stays in the event log.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Protocol

__all__ = ["StudentError", "Rule", "RULES", "KINDS", "explain", "explain_all", "rule_for", "command_of",
           "FORBIDDEN_WORDS"]

#: words a student never reads in a sentence or a fix (the engineer's units and board words)
FORBIDDEN_WORDS = ("steps/s", "steps", "GO TO", "TOPP-RA", "editor:", "col ", "feed-forward", "(156)",
                   "(123)", "(100)", "ACK_HERE", "datagram", "sample ", "branch '", "Ruckig")

#: the canonical command names (RBTscript's table), lower-case -> canonical
_COMMANDS = {n.lower().replace("_", ""): n for n in (
    "Begin", "End", "Loop", "MoveJoint", "MovePose", "MoveCart", "MoveCartRelTRF", "SpeedJoint", "Delay",
    "Speed", "Output", "Input", "Gripper", "Gripper_cal", "Home")}

#: how each command is written (the fix of a line whose arguments are wrong)
_USAGE = {
    "Begin": "Begin()", "End": "End()", "Loop": "Loop()", "Home": "Home()", "Gripper_cal": "Gripper_cal()",
    "MoveJoint": "MoveJoint(90, -90, 180, 0, 0, 180, t=2)",
    "MovePose": "MovePose(0, 263, 289, -90, 0, -90, t=2)",
    "MoveCart": "MoveCart(0, 263, 289, -90, 0, -90, t=2)",
    "MoveCartRelTRF": "MoveCartRelTRF(0, 0, 10, 0, 0, 0, t=1)",
    "SpeedJoint": "SpeedJoint(10, 0, 0, 0, 0, 0, t=1)",
    "Delay": "Delay(1)", "Speed": "Speed(50)", "Output": "Output(1, HIGH)", "Input": "Input(1, HIGH, 5)",
    "Gripper": "Gripper(100, 60, 600)",
}

#: a value's name in the parser's messages -> what a student calls it
_VALUE_NAMES = {
    "t": "the move time t=", "v": "the speed v=", "a": "the acceleration a=", "r": "the blend radius r=",
    "Delay": "the Delay", "Speed": "the speed override", "Input timeout": "the Input timeout",
    "gripper position": "the gripper position", "gripper speed": "the gripper speed",
    "gripper current": "the gripper current",
}

#: the collision model's bodies (docs/gui.md "Collisions in the 3D view") in a student's words
_BODIES = {
    "base": "the base", "J1 link": "the column (J1)", "J2 link": "the upper arm (J2)", "J3 link": "the elbow (J3)",
    "J4 link": "the forearm (J4)", "J5 link": "the wrist (J5)", "J6 link": "the flange (J6)",
}


class _Diagnostic(Protocol):
    """What :func:`explain` needs of a diagnostic (a :class:`parolkit.script.ScriptError`)."""

    @property
    def line(self) -> int: ...

    @property
    def message(self) -> str: ...

    @property
    def text(self) -> str: ...


@dataclass(frozen=True)
class StudentError:
    """One program error for a student: ``program`` (its name) and ``line``, ``sentence`` (what
    is wrong, naming the line) and ``fix`` (what to do); ``kind`` is the rule that matched and
    ``technical`` the message it was made from (for the log)."""

    program: str
    line: int
    sentence: str
    fix: str
    kind: str
    technical: str

    def text(self) -> str:
        """``pick.rbt: J2 would pass its limit at line 4: try a higher Z``."""
        return f"{self.program}: {self.sentence}: {self.fix}"


@dataclass(frozen=True)
class _Context:
    """What a rule may use besides its match: the line, the command written there (canonical
    name, "" when unknown), the source line and the whole message."""

    line: int
    command: str
    source: str
    message: str


#: (match, context) -> (sentence, fix)
_Render = Callable[["re.Match[str]", _Context], tuple[str, str]]


@dataclass(frozen=True)
class Rule:
    """One kind of error: ``pattern`` is searched in the message; ``render`` writes the sentence
    and the fix."""

    kind: str
    pattern: re.Pattern[str]
    render: _Render


# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------


def command_of(source_line: str) -> str:
    """The canonical name of the command a source line starts with ("" when none)."""
    m = re.match(r"\s*([A-Za-z_]\w*)", source_line or "")
    return _COMMANDS.get(m.group(1).lower().replace("_", ""), "") if m else ""


def _num(text: str, digits: int = 1) -> str:
    """A number as a student reads it: at most ``digits`` decimals, no trailing zeros."""
    try:
        v = float(text)
    except ValueError:
        return text
    if not math.isfinite(v):
        return text
    s = f"{v:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _up(text: str) -> str:
    """A time rounded up to a tenth of a second (a time that is enough)."""
    try:
        v = float(text)
    except ValueError:
        return text
    return _num(str(math.ceil(v * 10.0 - 1e-9) / 10.0))


def _cap(text: str) -> str:
    return text[:1].upper() + text[1:]


def _cmd(ctx: _Context, fallback: str = "the command") -> str:
    return ctx.command or fallback


def _joint(text: str, default: str = "a joint") -> str:
    m = re.search(r"\bJ([1-6])\b", text)
    return f"J{m.group(1)}" if m else default


def _body(name: str) -> str:
    """A collision body's name in a student's words."""
    name = name.strip()
    if name in _BODIES:
        return _BODIES[name]
    m = re.fullmatch(r"zone '(.*)'", name)
    if m:
        return "the table" if m.group(1) == "table" else f"the zone '{m.group(1)}'"
    m = re.fullmatch(r"tool(?: '(.*)')?", name)
    if m:
        return "the tool"
    m = re.fullmatch(r"held '(.*)'", name)
    if m:
        return f"the held object '{m.group(1)}'"
    return f"the {name}" if name else "something"


def _rx(pattern: str) -> re.Pattern[str]:
    return re.compile(pattern, re.IGNORECASE | re.DOTALL)


# ------------------------------------------------------------------------------------------
# the fixes that depend on the command and the joint
# ------------------------------------------------------------------------------------------


def _limit_fix(ctx: _Context, joint: str, above: bool | None) -> str:
    """What to change when ``joint`` would pass its limit (``above``: its upper one; None:
    unknown) at a line of command ``ctx.command``."""
    cmd = ctx.command
    if cmd == "SpeedJoint":
        return f"give a shorter time t= or a lower {joint} speed"
    if cmd == "MoveCartRelTRF":
        return "try a smaller step"
    if cmd not in ("MoveCart", "MovePose", ""):
        return f"use a {joint} angle inside its range"
    if joint == "J1":
        return "try a point more in front of the robot"
    if joint == "J2":
        return "try a higher Z" if above in (True, None) else "try a point further in front of the robot"
    if joint == "J3":
        return "try a higher Z or a point closer to the base"
    return "try a different tool angle (A, B, C)"


def _side(m: re.Match[str], name: str = "side") -> bool | None:
    text = (m.groupdict().get(name) or "").lower()
    if text in (">", "above", "upper"):
        return True
    if text in ("<", "below", "lower"):
        return False
    return None


# ------------------------------------------------------------------------------------------
# rules: the controller, the E-stop and collisions first (their messages may carry planner or
# parser words), then the planner's, then the parser's
# ------------------------------------------------------------------------------------------


def _estop(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    if re.search(r"still pressed", ctx.message, re.I):
        return (f"The E-stop button is still pressed, so line {ctx.line} could not run",
                "release the button, press Enable, then resume or restart")
    if re.search(r"latched|disabled or E-stopped", ctx.message, re.I):
        return (f"The E-stop is latched, so line {ctx.line} could not run",
                "press Enable to release it, then run the program again")
    return (f"The E-stop stopped the program at line {ctx.line}",
            "release it with Enable, then resume from that line or restart")


def _collision_stop(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    near = re.search(r"(?:from|touching) (zone '[^']*'|base|J\d link|tool(?: '[^']*')?|held '[^']*')", ctx.message)
    thing = _body(near.group(1)) if near else "a zone"
    return (f"At line {ctx.line} the arm is already too close to {thing} to move on",
            f"jog the arm away from {thing}, then run the program again")


def _collision(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    if m.group("a") is None:
        return (f"The arm would hit something at line {ctx.line}",
                "Check the program: the red points in the 3D view show where, then go around it")
    raw_a, raw_b = m.group("a").strip(), m.group("b").strip()
    a, b = _body(raw_a), _body(raw_b)
    at = f" {_num(m.group('t'), 2)} s into the move" if m.group("t") else ""
    if "zone 'table'" in (raw_a, raw_b):
        part = a if raw_b == "zone 'table'" else b
        return f"{_cap(part)} would hit the table{at} at line {ctx.line}", "try a higher Z"
    if raw_b.startswith("zone '"):
        return (f"{_cap(a)} would hit {b}{at} at line {ctx.line}",
                f"go around it: add a point in between, or move the target away from {b}")
    return (f"{_cap(a)} would hit {b}{at} at line {ctx.line}",
            "try a different target: in this pose the robot would hit itself or its tool")


def _not_proven(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return (f"The move at line {ctx.line} could not be checked for collisions",
            "split it into shorter moves")


def _singularity(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    fix = ("try MovePose instead of MoveCart, or a slightly different target"
           if ctx.command in ("MoveCart", "MoveCartRelTRF", "") else "try a slightly different target")
    return (f"At line {ctx.line} the arm would pass through a pose where its wrist joints line up and "
            "cannot turn fast enough", fix)


def _limit(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    joint = _joint(m.group("joint"))
    if ctx.command == "MoveJoint" and m.groupdict().get("lo") and m.groupdict().get("hi"):
        return (f"{joint} would pass its limit at line {ctx.line}",
                f"use a {joint} angle from {_num(m.group('lo'))} to {_num(m.group('hi'))} degrees")
    return f"{joint} would pass its limit at line {ctx.line}", _limit_fix(ctx, joint, _side(m))


def _limit_by_value(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    """A limit named by value and range only: above when the value is above the range."""
    joint = _joint(m.group("joint"))
    above: bool | None = None
    try:
        above = float(m.group("value")) > float(m.group("hi"))
    except (TypeError, ValueError, IndexError):
        above = None
    if ctx.command == "MoveJoint":
        return (f"{joint} would pass its limit at line {ctx.line}",
                f"use a {joint} angle from {_num(m.group('lo'))} to {_num(m.group('hi'))} degrees")
    return f"{joint} would pass its limit at line {ctx.line}", _limit_fix(ctx, joint, above)


def _too_fast(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    text = ctx.message
    joint = _joint(text, "")
    who = f"{joint} to move" if joint else "the arm to move"
    need = re.search(r"t >= ([\d.]+) s|at least ([\d.]+) s", text)
    if need:
        seconds = _up(need.group(1) or need.group(2))
        return (f"Line {ctx.line} asks {who} faster than it can",
                f"give t={seconds} or more (or leave t= out and the robot picks a safe time)")
    if ctx.command == "SpeedJoint":
        return f"Line {ctx.line} asks {who} faster than it can", "give lower speeds"
    if "t=" in ctx.source.replace(" ", ""):
        return f"Line {ctx.line} asks {who} faster than it can", "give a longer time t="
    return f"Line {ctx.line} asks {who} faster than it can", "give a lower speed v= or a time t="


def _blend(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    if re.search(r"nothing to blend", m.group(0), re.I):
        return (f"The rounded moves (r=) from line {ctx.line} go nowhere",
                "remove r= or give targets that differ")
    return (f"The rounded corners (r=) from line {ctx.line} are too tight for the robot",
            "give smaller r= values or a lower speed")


def _reach(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    text = ctx.message
    by = re.search(r"out of reach by ([\d.]+) mm", text)
    far = f" ({_num(by.group(1), 0)} mm too far)" if by and float(by.group(1)) >= 1.0 else ""
    if ctx.command == "MoveCart" and re.search(r"path leaves", text):
        return (f"The straight line at line {ctx.line} leaves the arm's reach{far}",
                "try MovePose instead of MoveCart, or a point closer to the base")
    if re.search(r"within the joint limits", text):
        return (f"The pose at line {ctx.line} cannot be reached with every joint inside its range",
                "try a different tool angle (A, B, C) or a point closer to the base")
    return f"The point at line {ctx.line} is out of the arm's reach{far}", "try a point closer to the robot's base"


def _controller(sentence: str, fix: str) -> _Render:
    def render(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
        return sentence.format(line=ctx.line, cmd=_cmd(ctx)), fix.format(line=ctx.line, cmd=_cmd(ctx))

    return render


def _input_timeout(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    level = {"1": "HIGH", "0": "LOW"}.get(m.group("level"), m.group("level").upper())
    return (f"Input {m.group('n')} did not become {level} in time at line {ctx.line}",
            f"check what is wired to input {m.group('n')}, or give Input a longer timeout")


def _output_timeout(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return (f"Output {m.group('n')} did not switch at line {ctx.line}",
            "check the cable to the robot's board, then run the program again")


# -- parser ---------------------------------------------------------------------------------


def _two_points(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return (f"Line {ctx.line} has a number with two decimal points ({m.group('num')}.)",
            "write one '.' in a number and ',' between two values")


def _bad_char(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    ch = m.group("ch")
    shown = ch if ch.strip("'\"").isprintable() and ch.strip("'\"").strip() else "an invisible character"
    return (f"Line {ctx.line} has a character RBTscript does not read: {shown}",
            "delete it and type it again with plain digits, letters, ',' and brackets")


def _missing_paren(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return f"Line {ctx.line} is missing its closing ')'", "add ')' at the end of the command"


def _missing_open(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    example = m.group("example").strip() if m.groupdict().get("example") else "End()"
    return f"Line {ctx.line} is missing '(' after the command name", f"write it like {example}"


def _unknown_command(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    name = m.group("name")
    hint = re.search(r"did you mean (\w+)\?", ctx.message)
    if hint:
        return f"Line {ctx.line} uses {name}, which is not an RBTscript command", f"did you mean {hint.group(1)}?"
    return (f"Line {ctx.line} uses {name}, which is not an RBTscript command",
            "pick a command from the Insert menu")


def _parser_limit(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    joint = f"J{m.group('j')}"
    return (f"{joint} would pass its limit at line {ctx.line}",
            f"use a {joint} angle from {_num(m.group('lo'))} to {_num(m.group('hi'))} degrees")


def _range(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    what = m.group("what").strip()
    if what in _VALUE_NAMES:
        name = _VALUE_NAMES[what]
    elif re.fullmatch(r"J\d speed", what):
        name = f"the {what}"
    else:
        name = f"the value {what}"
    allowed = re.sub(r"^>", "more than ", m.group("allowed").strip())
    allowed = re.sub(r"\s*\.\.\s*", " to ", allowed)
    return f"{_cap(name)} at line {ctx.line} is outside what the robot allows", f"use a value from {allowed}"


def _not_a_number(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return (f"Line {ctx.line} has a value that is not a number",
            "write numbers with the digits 0-9, one '.' and an optional '-'")


def _plain_number(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return (f"Line {ctx.line} has a named option where a plain value belongs",
            f"write the values first, then the options, like {_USAGE.get(ctx.command, 'MoveJoint(..., t=2)')}")


def _too_large(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return f"Line {ctx.line} has a number too long or too large to use", "write a shorter number"


def _whole(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return (f"Line {ctx.line} needs a whole number",
            f"use a whole number from {m.group('lo')} to {m.group('hi')}")


def _level(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return f"Line {ctx.line} needs HIGH or LOW", "write HIGH or LOW"


def _port(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    kind = m.group("kind")
    return f"There is no {kind} {m.group('got')} (line {ctx.line})", f"use {kind} 1 or 2"


def _count(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    cmd = m.group("cmd")
    return (f"{cmd} at line {ctx.line} needs {m.group('n')} values and has {m.group('got')}",
            f"write it like {_USAGE.get(cmd, cmd + '(...)')}")


def _no_args(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    cmd = m.group("cmd")
    return f"{cmd}() at line {ctx.line} takes nothing between its brackets", f"write {cmd}()"


def _wrong_args(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    cmd = _COMMANDS.get(m.group("cmd").lower().replace("_", ""), m.group("cmd"))
    return f"{cmd} at line {ctx.line} has the wrong values", f"write it like {_USAGE.get(cmd, cmd + '(...)')}"


def _no_option(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    cmd = _COMMANDS.get((m.groupdict().get("cmd") or ctx.command).lower().replace("_", ""), ctx.command)
    opt = (m.groupdict().get("opt") or "").strip("'")
    what = f" {opt}" if opt else ""
    options = {"MoveCart": "t=, v=, r=", "MoveCartRelTRF": "t=, v="}.get(cmd, "t=, v=, a=, r=")
    if cmd in ("SpeedJoint", "Input"):
        return f"{cmd} at line {ctx.line} has no option{what}", f"write it like {_USAGE[cmd]}"
    return (f"{cmd or 'The command'} at line {ctx.line} has no option{what}",
            f"use {options}, trap or poly (or remove it)")


def _twice(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return f"Line {ctx.line} gives {m.group('opt')} twice", "remove one of them"


def _value_after_option(m: re.Match[str], ctx: _Context) -> tuple[str, str]:
    return (f"Line {ctx.line} has the value {m.group('value')} after an option",
            "write all the values first, then options like t=2")


def _rules() -> tuple[Rule, ...]:
    r = Rule
    c = _controller
    return (
        # ---- the E-stop, collisions (controller, dry run) ----
        r("estop", _rx(r"E-stop|ESTOP command"), _estop),
        r("collision_stop", _rx(r"stopping short of a collision|moving on would bring it within the margin|"
                                r"a controlled stop from here would end within the margin"), _collision_stop),
        r("collision_unproven", _rx(r"would collide: .*not proven clear"), _not_proven),
        r("collision", _rx(r"would collide(?:: (?P<a>.+?) vs (?P<b>.+?)(?: at (?P<t>[\d.]+) s into the move)? \()?"),
          _collision),
        # ---- the controller's refusals and failures during a run ----
        r("safety_guard", _rx(r"safety guard: |position commands \(156\)|board command \d+ is not one|"
                              r"may be sent in one frame only|in a JOG \(123\) frame|goal .* steps from where "
                              r"the board may be|target -?\d+ steps is outside the limits"),
          c("The controller's safety check stopped line {line}",
            "run the program again; if it happens again, tell your teacher")),
        r("not_homed", _rx(r"not homed"),
          c("The robot is not homed, so line {line} could not run", "press Home, then run the program again")),
        r("disabled", _rx(r"robot is disabled|disabled by DISABLE"),
          c("The robot was switched off (disabled) at line {line}", "press Enable, then run the program again")),
        r("supervisor", _rx(r"motion refused: .*a new one is starting|stop supervisor"),
          c("The controller was restarting its safety stop at line {line}",
            "wait a second, then run the program again")),
        r("uncommanded", _rx(r"uncommanded motion"),
          c("The robot moved on its own at line {line}, so the controller stopped it",
            "check the robot, then press Enable and Home")),
        r("other_client", _rx(r"controlled by |shared secret: take control"),
          c("Someone else controls the robot, so line {line} could not run",
            "wait for your turn, or ask your teacher to hand you the robot")),
        r("stopped", _rx(r"^(?:\w+ \w+: )?stopped(?: by STOP|: )|received after it"),
          c("The program was stopped at line {line}", "run it again when you are ready")),
        r("busy", _rx(r"queue full|controller busy|robot is busy"),
          c("The controller was too busy to take line {line}",
            "run the program again; if it happens again, tell your teacher")),
        r("board_link", _rx(r"board link|link lost|frames in a row unanswered|SET_PORT|position was not known"),
          c("The controller lost touch with the robot's board at line {line}",
            "check the robot's USB cable and power, then press Enable and Home")),
        r("shutdown", _rx(r"controller shutting down"),
          c("The controller shut down at line {line}", "restart it, then run the program again")),
        r("homing_timeout", _rx(r"homing did not finish|did not start homing"),
          c("Homing did not finish at line {line}", "check the robot, press Enable, then Home again")),
        r("input_timeout", _rx(r"IN(?P<n>\d) did not become (?P<level>\w+) within"), _input_timeout),
        r("output_timeout", _rx(r"did not report OUT(?P<n>\d) = "), _output_timeout),
        r("gripper_calibration", _rx(r"gripper did not report calibrated"),
          c("The gripper did not finish calibrating at line {line}",
            "check the gripper's cable and power, then calibrate it again")),
        r("held_objects", _rx(r"^(?:\w+ \w+: )?(?:ATTACH|DETACH): "),
          c("The controller could not attach or detach the object at line {line}",
            "detach an object first, or check the object's name")),
        r("connection", _rx(r"ACK_HERE refused|applies to the socket that sends it"),
          c("The controller refused this commander's connection at line {line}", "tell your teacher")),
        r("check_failed", _rx(r"cannot check the program against the robot"),
          c("The program could not be checked before running (line {line})",
            "check the link to the controller, then run the program again")),
        # ---- the planner (the dry run, and the controller's plan of a move) ----
        r("blend", _rx(r"blended path|nothing to blend"), _blend),
        r("singularity", _rx(r"singularit|J5 = 0|J5 near 0|jumps [\d.]+ deg within one tick|"
                             r"cannot turn out of it"), _singularity),
        r("joint_limit", _rx(r"joint (?P<joint>J\d) would be -?[\d.]+ deg (?P<side>[<>])"), _limit),
        r("joint_limit", _rx(r"(?P<joint>J\d) = -?[\d.]+ deg \(-?\d+ steps\) is (?P<side>above|below)"), _limit),
        r("joint_limit", _rx(r"(?P<joint>J\d) = (?P<value>-?[\d.eE+]+) (?:deg|steps) is out of range: .*?"
                             r"\(allowed (?P<lo>-?[\d.eE+]+) \.\. (?P<hi>-?[\d.eE+]+) (?:deg|steps)\)"),
          _limit_by_value),
        r("joint_limit", _rx(r"(?P<joint>J\d) = (?P<value>-?[\d.]+) deg is outside the joint range "
                             r"(?P<lo>-?[\d.]+) \.\. (?P<hi>-?[\d.]+) deg"), _limit_by_value),
        r("joint_limit", _rx(r"(?P<joint>J\d) would reach (?P<value>-?[\d.]+) deg, beyond its range "
                             r"(?P<lo>-?[\d.]+) \.\. (?P<hi>-?[\d.]+) deg"), _limit_by_value),
        r("too_fast", _rx(r"too fast|J\d speed [\d.]+ steps/s|steps/s is out of range|acceleration [\d.]+ "
                          r"steps/s\^2 exceeds|no feasible timing|no jerk-limited timing|TOPP-RA"), _too_fast),
        r("reach", _rx(r"out of reach|out of the arm's reach|leaves the arm's reach|leaves the robot's reach|"
                       r"not reachable|no solution within the joint limits"), _reach),
        r("path_points", _rx(r"the path leaves the joint range (?:at|between)|too abrupt (?:at|between)"),
          c("The path through the points at line {line} turns too sharply for the robot's joints",
            "add a point where it turns, or give the points more time")),
        r("timing", _rx(r"falls on tick \d+"),
          c("Two points of the path at line {line} are closer in time than the robot's tick",
            "space the points further apart in time")),
        r("internal", _rx(r"internal error|the planner failed|could not be computed|plans to zero samples|"
                          r"cannot be executed|unsupported path element|check_limits=False|continuous=True|"
                          r"seed_deg has|config must be a Branch|4x4 matrix|angle_deg .* does not match|"
                          r"arc start and end|radius_mm .* is too small|not on one circle|arc's start lies|"
                          r"spline waypoints"),
          c("Line {line} could not be planned because of a problem inside parolkit",
            "tell your teacher (the details are in the log)")),
        # ---- the parser ----
        r("two_points", _rx(r"unexpected '\.' after the number (?P<num>\S+): a number has one decimal point"),
          _two_points),
        r("semicolon", _rx(r"unexpected ';'"),
          c("Line {line} has a ';'", "put each command on a line of its own, without ';'")),
        r("bad_character", _rx(r"unexpected character (?P<ch>'.*?'|\S+)"), _bad_char),
        r("missing_close", _rx(r"missing '\)'"), _missing_paren),
        r("missing_open", _rx(r"missing '\(': a command is written Name\(arguments\)(?:, e\.g\. (?P<example>.*))?"),
          _missing_open),
        r("ends_early", _rx(r"unexpected end of the line"),
          c("Line {line} ends before its command does", "finish the command: values, then ')'")),
        r("after_command", _rx(r"after the command: one command per line"),
          c("Line {line} has more after the command's ')'",
            "put the next command on a new line, or start a comment with #")),
        r("paren_expected", _rx(r"expected '\(' after the command name"),
          c("Line {line} needs '(' right after the command name", "write it like Delay(1)")),
        r("starts_with_number", _rx(r"a line must start with a command name"),
          c("Line {line} starts with a number instead of a command", "start the line with a command, like MoveJoint(")),
        r("missing_value", _rx(r"missing value after '(?P<key>\w+)='"),
          c("Line {line} has an option with no value after its '='", "write a number after it, like t=2")),
        r("missing_value", _rx(r"missing value: two ','|missing value after ','"),
          c("Line {line} is missing a value between two commas or before ')'",
            "write the missing value, or remove the extra ','")),
        r("unknown_command", _rx(r"unknown command (?P<name>'[^']*'|\S+)"), _unknown_command),
        r("joint_value", _rx(r"^J(?P<j>\d) = \S+ deg is outside the joint limits \((?P<lo>-?[\d.]+) \.\. "
                             r"(?P<hi>-?[\d.]+) deg\)"), _parser_limit),
        r("delay_tick", _rx(r"Delay = \S+ s is shorter than one control tick"),
          c("The Delay at line {line} is shorter than the robot can wait", "use at least 0.01 s")),
        r("range", _rx(r"^(?P<what>[\w ]+?) = .+? is out of range (?:\(allowed )?(?P<allowed>[^)]*)\)?$"), _range),
        r("not_a_number", _rx(r"must be a (?:decimal )?number, got|must be a number, got"), _not_a_number),
        r("plain_number", _rx(r"must be a plain number here"), _plain_number),
        r("too_large", _rx(r"too large for a number|must be a decimal number of at most|must be an integer in"),
          _too_large),
        r("whole_number", _rx(r"must be a whole number in (?P<lo>-?\d+) \.\. (?P<hi>-?\d+)"), _whole),
        r("level", _rx(r"must be HIGH or LOW"), _level),
        r("port", _rx(r"(?P<kind>output|input) number must be 1 or 2, got (?P<got>\S+)"), _port),
        r("value_count", _rx(r"^(?P<cmd>\w+) takes (?P<n>\d+) .*?, got (?P<got>\d+)"), _count),
        r("no_arguments", _rx(r"^(?P<cmd>\w+)\(\) takes no arguments"), _no_args),
        r("wrong_arguments", _rx(r"^(?P<cmd>Delay|Speed|Gripper|Output|Input) takes "), _wrong_args),
        r("speedjoint_time", _rx(r"SpeedJoint needs the duration"),
          c("SpeedJoint at line {line} needs its time", "add t=seconds, like SpeedJoint(10, 0, 0, 0, 0, 0, t=1)")),
        r("twice", _rx(r"(?P<opt>\w+=?) is given twice"), _twice),
        r("value_after_option", _rx(r"the value (?P<value>\S+) comes after an option"), _value_after_option),
        r("unknown_option", _rx(r"^(?P<cmd>\w+):? (?:has no option|unknown option) (?P<opt>'[^']*'|\S+?)(?:=|:)|"
                                r"func must be one of"), _no_option),
        r("begin_first", _rx(r"Begin\(\) must be the first command"),
          c("Begin() at line {line} must be the first command", "move it to the top, or delete it")),
        r("end_last", _rx(r"\(\) must be the last command"),
          c("Line {line} ends the program, but more lines follow it",
            "move the lines after it above it, or delete them")),
        r("empty", _rx(r"the program has no commands"),
          c("There is no command in the program (line {line})", "write Begin(), your commands, then End()")),
        r("file", _rx(r"cannot read the file|not UTF-8 text"),
          c("The program file cannot be read (line {line})", "save it again as plain text")),
        r("syntax", _rx(r"syntax error|^unexpected "),
          c("Line {line} cannot be read as a command", "write it as Name(values), like Delay(1)")),
    )


#: every rule, most specific first
RULES: tuple[Rule, ...] = _rules()
#: the kinds of error, in rule order
KINDS: tuple[str, ...] = tuple(dict.fromkeys(r.kind for r in RULES))

_FALLBACK = ("Line {line} has a problem", "read the details in the log, or ask your teacher")


def rule_for(message: str) -> tuple[Rule, re.Match[str]] | None:
    """The first rule whose pattern is found in ``message`` and its match (None: no rule)."""
    for rule in RULES:
        m = rule.pattern.search(message)
        if m is not None:
            return rule, m
    return None


def _clean(text: str) -> str:
    """One plain sentence or fix: no trailing full stop, no doubled spaces."""
    return re.sub(r"\s+", " ", text).strip().rstrip(".")


def explain(error: _Diagnostic, program: str) -> StudentError:
    """``error`` (a parse, dry-run or run error of the program ``program``) for a student."""
    message = str(error.message)
    line = int(error.line)
    source = str(error.text or "")
    ctx = _Context(line, command_of(source), source, message)
    found = rule_for(message)
    if found is None:
        sentence, fix = _FALLBACK[0].format(line=line), _FALLBACK[1]
        kind = "unknown"
    else:
        rule, m = found
        sentence, fix = rule.render(m, ctx)
        kind = rule.kind
    return StudentError(program or "the program", line, _clean(sentence), _clean(fix), kind, message)


def explain_all(errors: Iterable[_Diagnostic], program: str) -> list[StudentError]:
    """:func:`explain` for each error, in order."""
    return [explain(e, program) for e in errors]
