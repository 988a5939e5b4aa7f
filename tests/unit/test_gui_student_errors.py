"""Program errors in a student's words (parolkit.gui.student_errors).

Every kind of error message the parser, the dry run (with the planner and the kinematics it
asks), the interpreter and the controller can produce is found in their source code (the
message templates at the places that report an error: ``_Line.fail`` / ``error``, the
parser's syntax errors, the dry run's ``add_error``, ``PlanningError`` and ``IKError``, the
controller's FAILED and CANCELLED acks and the refusal texts they carry), filled with
plausible values and explained: each must match a rule (not the fallback) and read as the
program's name, the line and one plain sentence with its fix, without the engineer's words
("steps/s", "GO TO", "editor:2:1").  A new kind of message fails this test until it has a rule.
Real programs then go through the real parser and dry run to check the sentences themselves.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from parolkit.gui.student_errors import FORBIDDEN_WORDS, KINDS, RULES, StudentError, explain, rule_for
from parolkit.script import parse
from parolkit.script.program import ScriptError

SRC = Path(__file__).resolve().parents[2] / "src" / "parolkit"
#: a placeholder in a template: the source of the value it stands for
_HOLE = re.compile(r"\x00(.*?)\x01", re.DOTALL)


# ------------------------------------------------------------------------------------------
# the message templates, from the source
# ------------------------------------------------------------------------------------------


class _Module:
    def __init__(self, path: Path) -> None:
        self.path = path
        self.tree = ast.parse(path.read_text(encoding="utf-8"))
        self.parents: dict[ast.AST, ast.AST] = {}
        for node in ast.walk(self.tree):
            for child in ast.iter_child_nodes(node):
                self.parents[child] = node

    def function_of(self, node: ast.AST) -> ast.FunctionDef | ast.AsyncFunctionDef | None:
        while node in self.parents:
            node = self.parents[node]
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                return node
        return None


def _name(node: ast.AST) -> str | None:
    if not isinstance(node, ast.Call):
        return None
    f = node.func
    return f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None


def _hole(expr: ast.AST) -> str:
    return f"\x00{ast.unparse(expr)}\x01"


def _local_strings(mod: _Module, name: ast.Name, depth: int) -> list[str]:
    """The texts a local name is given in its function (assignments), else the arguments its
    function is called with when it is a parameter; [] when neither."""
    fn = mod.function_of(name)
    if fn is None:
        return []
    out: list[str] = []
    for node in ast.walk(fn):
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == name.id for t in node.targets):
            out += _templates(mod, node.value, depth + 1)
        elif (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.target.id == name.id
              and node.value is not None):
            out += _templates(mod, node.value, depth + 1)
    params = [a.arg for a in fn.args.args]
    if out or (name.id not in params and name.id not in [a.arg for a in fn.args.kwonlyargs]):
        return out
    index = params.index(name.id) - (1 if params and params[0] == "self" else 0) if name.id in params else None
    for call in ast.walk(mod.tree):
        if _name(call) != fn.name or not isinstance(call, ast.Call):
            continue
        arg = next((k.value for k in call.keywords if k.arg == name.id), None)
        if arg is None and index is not None and index < len(call.args):
            arg = call.args[index]
        if arg is not None:
            out += _templates(mod, arg, depth + 1)
    return out


def _templates(mod: _Module, expr: ast.AST, depth: int = 0) -> list[str]:
    """Every text ``expr`` can be, values it does not fix as placeholders (``\\x00src\\x01``)."""
    if depth > 8:
        return [_hole(expr)]
    if isinstance(expr, ast.Constant) and isinstance(expr.value, str):
        return [expr.value]
    if isinstance(expr, ast.JoinedStr):
        parts = [""]
        for v in expr.values:
            if isinstance(v, ast.Constant):
                inner = [str(v.value)]
            elif isinstance(v, ast.FormattedValue) and isinstance(v.value, (ast.IfExp, ast.JoinedStr)):
                inner = _templates(mod, v.value, depth + 1)
            elif isinstance(v, ast.FormattedValue) and isinstance(v.value, ast.Name) and v.format_spec is None:
                inner = _local_strings(mod, v.value, depth) or [_hole(v.value)]
            else:
                inner = [_hole(v.value if isinstance(v, ast.FormattedValue) else v)]
            parts = [p + i for p in parts for i in inner][:64]
        return parts
    if isinstance(expr, ast.BinOp) and isinstance(expr.op, ast.Add):
        right = _templates(mod, expr.right, depth + 1)
        return [a + b for a in _templates(mod, expr.left, depth + 1) for b in right][:64]
    if isinstance(expr, ast.IfExp):
        return _templates(mod, expr.body, depth + 1) + _templates(mod, expr.orelse, depth + 1)
    if isinstance(expr, ast.BoolOp):
        return [t for v in expr.values for t in _templates(mod, v, depth + 1)]
    if isinstance(expr, ast.Name):
        return _local_strings(mod, expr, depth) or [_hole(expr)]
    return [_hole(expr)]


#: a sink: (module, node) -> the message expressions reported there
_Sink = Callable[[_Module, ast.AST], Iterator[ast.AST]]


def _severity_error(node: ast.AST) -> bool:
    return isinstance(node, ast.Attribute) and node.attr == "ERROR"


def _parser_sink(mod: _Module, node: ast.AST) -> Iterator[ast.AST]:
    """The parser's errors (not its warnings): ``fail`` / ``error`` (a line's errors), ``_diag``
    / ``diag`` / ``ScriptError`` with severity ERROR, the syntax errors' (column, message)."""
    n = _name(node)
    if isinstance(node, ast.Call):
        if n in ("fail", "error") and len(node.args) >= 2:
            yield node.args[1]
        if n in ("_diag", "diag") and len(node.args) == 3 and _severity_error(node.args[2]):
            yield node.args[1]
        if n == "ScriptError" and len(node.args) >= 3 and (len(node.args) < 5 or _severity_error(node.args[4])):
            yield node.args[2]
    if isinstance(node, ast.Return) and isinstance(node.value, ast.Tuple) and len(node.value.elts) == 2:
        fn = mod.function_of(node)
        if fn is not None and fn.name == "_syntax_error":
            yield node.value.elts[1]


def _raised(names: set[str], index: int) -> _Sink:
    def sink(mod: _Module, node: ast.AST) -> Iterator[ast.AST]:
        if isinstance(node, ast.Call) and _name(node) in names and len(node.args) > index:
            yield node.args[index]

    return sink


def _dry_run_sink(mod: _Module, node: ast.AST) -> Iterator[ast.AST]:
    if isinstance(node, ast.Call) and _name(node) == "add_error" and len(node.args) >= 2:
        yield node.args[1]
    if isinstance(node, ast.Call) and _name(node) == "ScriptError" and len(node.args) >= 5 \
            and _severity_error(node.args[4]):
        yield node.args[2]


def _interpreter_sink(mod: _Module, node: ast.AST) -> Iterator[ast.AST]:
    if isinstance(node, ast.Call) and _name(node) == "_error" and len(node.args) == 2:
        yield node.args[1]
    if isinstance(node, ast.Call) and _name(node) == "ScriptError" and len(node.args) >= 5 \
            and _severity_error(node.args[4]):
        yield node.args[2]


def _failed(node: ast.AST) -> bool:
    return isinstance(node, ast.Attribute) and node.attr in ("FAILED", "CANCELLED")


#: the controller's functions whose returned text is a refusal (None: no refusal)
_REFUSALS = {"refusal", "_refusal", "_judge_link", "_scene_error", "_speed_joint_range", "_violation",
             "_goto_violation", "check"}
#: its functions that cancel or fail the commands with the reason they are given
_CANCELLERS = {"_cancel_all", "_estop", "_lose", "fail_waiting", "cancel_port_switch", "_lose_link"}


def _controller_sink(mod: _Module, node: ast.AST) -> Iterator[ast.AST]:
    """The reason of every FAILED or CANCELLED ack (positional after the status, or
    ``details=``), of the cancellations, of a failed plan (``PlanResult(error=)``), the
    refusal functions' texts and ``(None, why)`` of the held-object changes."""
    if isinstance(node, ast.Call):
        for i, a in enumerate(node.args):
            status = _failed(a) or (isinstance(a, ast.IfExp) and (_failed(a.body) or _failed(a.orelse)))
            if status and i + 1 < len(node.args):
                yield node.args[i + 1]
        kws = {k.arg: k.value for k in node.keywords}
        if any(key in kws and _failed(kws[key]) for key in ("done", "status")) and "details" in kws:
            yield kws["details"]
        if _name(node) in _CANCELLERS and node.args:
            yield node.args[0]
        if _name(node) == "PlanResult" and "error" in kws:
            yield kws["error"]
    if isinstance(node, ast.Return) and node.value is not None:
        v = node.value
        if isinstance(v, ast.Tuple) and len(v.elts) == 2 and _failed(v.elts[0]):
            yield v.elts[1]
        if isinstance(v, ast.Tuple) and len(v.elts) == 2 and isinstance(v.elts[0], ast.Constant) \
                and v.elts[0].value is None:
            yield v.elts[1]  # (None, why): the held-object change cannot be done
        fn = mod.function_of(node)
        if fn is not None and fn.name in _REFUSALS and not isinstance(v, ast.Tuple) \
                and not (isinstance(v, ast.Constant) and v.value is None):
            yield v


def _files(*globs: str) -> list[Path]:
    out: list[Path] = []
    for g in globs:
        out += sorted(SRC.glob(g))
    return out


def _returned_by(names: set[str]) -> _Sink:
    def sink(mod: _Module, node: ast.AST) -> Iterator[ast.AST]:
        fn = mod.function_of(node) if isinstance(node, ast.Return) else None
        if fn is not None and fn.name in names and isinstance(node, ast.Return) and node.value is not None:
            yield node.value

    return sink


#: (origin, files, sink, the text the message follows): the collision check's words follow
#: "would collide: " in the dry run's and the controller's messages
SOURCES: tuple[tuple[str, list[Path], _Sink, str], ...] = (
    ("parser", _files("script/parser.py"), _parser_sink, ""),
    ("parser", _files("number_syntax.py"), _raised({"ParolkitValueError"}, 0), ""),
    ("dry run", _files("script/dryrun.py"), _dry_run_sink, ""),
    ("dry run", _files("errors.py"), _raised({"__init__"}, 0), ""),  # JointLimitError's text
    ("collision", _files("collision/trajectory.py"), _returned_by({"collision_message"}), "MoveJoint would collide: "),
    ("planner", _files("motion/**/*.py"), _raised({"PlanningError"}, 1), ""),
    ("planner", _files("kinematics/**/*.py"), _raised({"IKError"}, 0), ""),
    ("run", _files("script/interpreter.py"), _interpreter_sink, ""),
    ("controller", _files("controller/*.py"), _controller_sink, ""),
)


def message_templates() -> dict[str, tuple[str, str]]:
    """template (placeholders as ``\\x00src\\x01``) -> (origin, where in the source)."""
    found: dict[str, tuple[str, str]] = {}
    for origin, files, sink, prefix in SOURCES:
        for path in files:
            mod = _Module(path)
            for node in ast.walk(mod.tree):
                for expr in sink(mod, node):
                    for t in _templates(mod, expr):
                        found.setdefault(prefix + t, (origin, f"{path.relative_to(SRC)}:{getattr(node, 'lineno', 0)}"))
    return found


def shown(template: str) -> str:
    return _HOLE.sub("{}", template)


# ------------------------------------------------------------------------------------------
# plausible values for the placeholders
# ------------------------------------------------------------------------------------------

#: (words in the value's source, the value) in order: the first that fits
_FILLERS: tuple[tuple[tuple[str, ...], str], ...] = (
    (("JOINT_NAMES", "joint_name"), "J2"),
    (("unit",), "deg"),
    (("keyword", "cmd.name", "kw", "move.name", "name}", "what}"), "MoveJoint"),
    (("level", "self.state", "self.on"), "1"),
    (("ch",), "'%'"),
    (("exc", "reason", "why", "err"), "no solution"),
)

#: templates whose text is another message: every word they show is that message's (an
#: interpreter's ``{what}: {reason}``, a command's ``{name}: {exc}``, the lease refusal
#: ``{cmd} refused: {text}``), filled with one real inner message each
WRAPPERS: dict[str, str] = {
    "{}: {}": "MoveJoint failed: robot is not homed: send HOME first",
    "{} failed: {}": "MoveJoint failed: robot is not homed: send HOME first",
    "{} {}: {}": "MoveJoint cancelled: stopped by STOP",
    "{} refused: {}": "MOVEJOINT refused: the robot is controlled by 127.0.0.1:5002 (for 3 s, last heard 0.1 s ago): "
                      "take it with CONTROL TAKE",
}


def _fill(expr_source: str) -> str:
    for words, value in _FILLERS:
        if any(w in expr_source for w in words):
            return value
    return "2"


def sample(template: str) -> str:
    """The template as a message: a wrapper with its inner message, else each placeholder
    filled with a plausible value."""
    key = shown(template)
    if key in WRAPPERS:
        return WRAPPERS[key]
    return _HOLE.sub(lambda m: _fill(m.group(1)), template)


def _opaque(template: str) -> bool:
    """A template that is only placeholders and punctuation: the message is entirely another
    one (found at its own source)."""
    return shown(template) not in WRAPPERS and not re.search(r"[A-Za-z]", _HOLE.sub("", template))


#: success words that reach a refusal function's return (not errors)
_NOT_ERRORS = re.compile(r"^(attached|detached|nothing was held)")

TEMPLATES = message_templates()
#: the templates that are a kind of error of their own
KIND_TEMPLATES = sorted(t for t in TEMPLATES if not _opaque(t) and not _NOT_ERRORS.match(shown(t)))


def _diag(message: str, line: int = 4, source: str = "MovePose(0, 350, 50, 180, 0, 0)") -> ScriptError:
    return ScriptError(line, 1, message, source, source_name="editor")


def _plain(err: StudentError, line: int, program: str) -> None:
    """The student's text: the program's name and line, one sentence, a fix, no engineer's words."""
    text = err.text()
    assert text.startswith(f"{program}: "), text
    assert f"line {line}" in err.sentence.lower() or f"(line {line})" in err.sentence, text
    assert err.fix and err.sentence, text
    for word in FORBIDDEN_WORDS:
        assert word not in err.sentence and word not in err.fix, (word, text)
    assert not re.search(r"\w+:\d+:\d+", text), text  # no "editor:2:1"


# ------------------------------------------------------------------------------------------
# tests
# ------------------------------------------------------------------------------------------


def test_the_sources_are_found():
    """The enumeration reads real code: each source gives templates (a moved function or a
    renamed sink would silently give none)."""
    origins = {o for o, _ in TEMPLATES.values()}
    assert {"parser", "dry run", "planner", "run", "controller"} <= origins
    kinds = [shown(t) for t in KIND_TEMPLATES]
    for known in ("missing ')' at the end of the command", "robot is not homed: send HOME first",
                  "E-stop latched: release it and send ENABLE", "queue full ({} commands): wait for acks or send STOP",
                  "Begin() must be the first command (line {} comes before it)"):
        assert known in kinds, known
    assert len(KIND_TEMPLATES) > 120, len(KIND_TEMPLATES)


@pytest.mark.parametrize("template", KIND_TEMPLATES, ids=lambda t: shown(t)[:70])
def test_every_kind_of_message_has_a_plain_sentence(template):
    message = sample(template)
    found = rule_for(message)
    origin, where = TEMPLATES[template]
    assert found is not None, f"no rule for {origin} message {shown(template)!r} ({where}): sample {message!r}"
    err = explain(_diag(message), "pick.rbt")
    assert err.kind == found[0].kind != "unknown"
    _plain(err, 4, "pick.rbt")


def test_every_rule_is_used_by_some_message():
    """No rule for a message the code cannot produce (a rule left behind when a message went)."""
    used = {rule_for(sample(t))[0].kind for t in KIND_TEMPLATES if rule_for(sample(t)) is not None}  # type: ignore[index]
    assert set(KINDS) - used == set()
    assert len(RULES) >= len(KINDS)


def test_the_wrappers_inner_messages_are_real():
    """A wrapper's inner message is one the code produces (it matches a template)."""
    def matches(message: str) -> bool:
        for t in KIND_TEMPLATES:
            pattern = "".join(re.escape(p) if i % 2 == 0 else ".*?" for i, p in enumerate(_HOLE.split(t)))
            if re.fullmatch(pattern, message, re.DOTALL):
                return True
        return False

    for key, inner in WRAPPERS.items():
        assert any(shown(t) == key for t in TEMPLATES), f"wrapper {key!r} is no longer in the code"
        tail = inner.split(": ", 1)[1] if ": " in key else inner
        assert matches(tail) or matches(inner), (key, inner)


def test_an_unknown_message_gets_the_plain_fallback():
    err = explain(_diag("the flux capacitor overheated at 88 steps/s"), "pick.rbt")
    assert err.kind == "unknown"
    _plain(err, 4, "pick.rbt")
    assert err.technical == "the flux capacitor overheated at 88 steps/s"


# ---- real programs through the real parser and dry run ----

def _parse_errors(text: str) -> list[ScriptError]:
    return list(parse(text, "editor").errors)


def _dry_errors(text: str, start: list[float] | None = None) -> list[ScriptError]:
    from parolkit.script import dry_run

    result = parse(text, "editor")
    assert result.program is not None, result.errors
    return list(dry_run(result.program, start).errors)


def test_a_j2_limit_at_line_4_says_try_a_higher_z():
    errors = _dry_errors("Begin()\nMoveJoint(90, -90, 180, 0, 0, 180, t=3)\nDelay(0.5)\n"
                         "MovePose(0, 350, 50, 180, 0, 0)\nEnd()\n")
    assert [e.line for e in errors] == [4]
    assert "J2" in errors[0].message and "deg" in errors[0].message  # the engineer's message
    err = explain(errors[0], "pick.rbt")
    assert err.text() == "pick.rbt: J2 would pass its limit at line 4: try a higher Z"
    assert err.kind == "joint_limit"


def test_parse_errors_read_as_sentences():
    cases = {
        "Begin()\nDelay(1)\nMoveJoint(90,-90,180,0,0\nEnd()\n":
            "prog.rbt: Line 3 is missing its closing ')': add ')' at the end of the command",
        "Begin()\nMoveCart(81.565,262.804,161.047,-90.135,-0.029,141.983.t=9)\nEnd()\n":
            "prog.rbt: Line 2 has a number with two decimal points (141.983.): write one '.' in a number and ',' "
            "between two values",
        "Begin()\nMoveJiont(90,-90,180,0,0,180)\nEnd()\n":
            "prog.rbt: Line 2 uses 'MoveJiont', which is not an RBTscript command: did you mean MoveJoint?",
        "Begin()\nMoveJoint(90,-150,180,0,0,180)\nEnd()\n":
            "prog.rbt: J2 would pass its limit at line 2: use a J2 angle from -145 to -3.4 degrees",
        "Begin()\nDelay(0.001)\nEnd()\n":
            "prog.rbt: The Delay at line 2 is shorter than the robot can wait: use at least 0.01 s",
        "Begin()\nOutput(3, HIGH)\nEnd()\n": "prog.rbt: There is no output 3 (line 2): use output 1 or 2",
        "Begin()\nMoveJoint(90,-90,180,0,0,180,t=5000)\nEnd()\n":
            "prog.rbt: The move time t= at line 2 is outside what the robot allows: use a value from more than 0 "
            "to 3600 s",
        "Begin()\nDelay(1);\nEnd()\n": "prog.rbt: Line 2 has a ';': put each command on a line of its own, without ';'",
        "Delay(1)\nBegin()\nEnd()\n": "prog.rbt: Begin() at line 2 must be the first command: move it to the top, "
                                     "or delete it",
    }
    for text, want in cases.items():
        errors = _parse_errors(text)
        assert errors, text
        got = explain(errors[0], "prog.rbt")
        assert got.text() == want, (text, errors[0].message)
        _plain(got, errors[0].line, "prog.rbt")


def test_dry_run_errors_read_as_sentences():
    too_fast = _dry_errors("Begin()\nMoveJoint(0, -90, 180, 0, 0, 180, t=0.1)\nEnd()\n")
    err = explain(too_fast[0], "a.rbt")
    assert err.kind == "too_fast" and err.sentence == "Line 2 asks J1 to move faster than it can"
    assert re.fullmatch(r"give t=\d+(\.\d)? or more \(or leave t= out and the robot picks a safe time\)", err.fix)
    assert "steps" not in err.text()
    table = _dry_errors("Begin()\nMoveJoint(90, -10, 180, 0, 0, 180)\nEnd()\n")
    err = explain(table[0], "a.rbt")
    assert err.kind == "collision"
    assert re.fullmatch(r"a\.rbt: The \w+ \(J\d\) would hit the table [\d.]+ s into the move at line 2: "
                        r"try a higher Z", err.text()), err.text()
    far = _dry_errors("Begin()\nMovePose(0, 900, 200, 180, 0, 0)\nEnd()\n")
    err = explain(far[0], "a.rbt")
    assert re.fullmatch(r"a\.rbt: The point at line 2 is out of the arm's reach \(51\d mm too far\): try a point "
                        r"closer to the robot's base", err.text()), err.text()
    line = _dry_errors("Begin()\nMoveCart(0, 600, 200, 180, 0, 0)\nEnd()\n")
    err = explain(line[0], "a.rbt")
    assert err.kind == "reach" and "straight line at line 2 leaves the arm's reach" in err.sentence
    for e in (*too_fast, *table, *far, *line):
        _plain(explain(e, "a.rbt"), e.line, "a.rbt")


def test_runtime_errors_from_the_controller_read_as_sentences():
    """The interpreter's error of a line the controller cancelled or refused."""
    cases = {
        "MoveJoint cancelled: E-stop: software E-stop (ESTOP command)":
            "p.rbt: The E-stop stopped the program at line 3: release it with Enable, then resume from that line "
            "or restart",
        "MoveJoint failed: E-stop latched: release it and send ENABLE":
            "p.rbt: The E-stop is latched, so line 3 could not run: press Enable to release it, then run the "
            "program again",
        "MoveJoint failed: robot is not homed: send HOME first":
            "p.rbt: The robot is not homed, so line 3 could not run: press Home, then run the program again",
        "MoveJoint failed: MoveJoint refused at t=0.420 s: J2 speed 21000 steps/s exceeds the maximum speed "
        "18000 steps/s; give a longer duration.":
            "p.rbt: Line 3 asks J2 to move faster than it can: give a longer time t=",
        "MoveJoint failed: would collide: J5 link vs zone 'monitor' at 1.06 s into the move (enters its 10 mm "
        "margin; deepest 26.0 mm overlap at 1.31 s)":
            "p.rbt: The wrist (J5) would hit the zone 'monitor' 1.06 s into the move at line 3: go around it: add "
            "a point in between, or move the target away from the zone 'monitor'",
        "Input failed: IN1 did not become 1 within 5 s":
            "p.rbt: Input 1 did not become HIGH in time at line 3: check what is wired to input 1, or give Input "
            "a longer timeout",
        "MoveJoint failed: safety guard: J1 goal 12.00 steps (target 5, feed-forward 3 steps/s) is 9.0 steps from "
        "where the board may be (1.0..3.0 steps): the board would start it at 450 steps/s, above its maximum 400 "
        "(a goal may lie 8.0 steps away)":
            "p.rbt: The controller's safety check stopped line 3: run the program again; if it happens again, tell "
            "your teacher",
    }
    for message, want in cases.items():
        got = explain(ScriptError(3, 1, message, "MoveJoint(0, -90, 180, 0, 0, 180, t=2)"), "p.rbt")
        assert got.text() == want, message
        _plain(got, 3, "p.rbt")


def test_the_sentence_names_the_command_written_at_the_line():
    """The fix of a limit depends on the command: a joint value to change, or a pose."""
    msg = "J1 = 150.000 deg is outside the joint range -123.046 .. 123.046 deg"
    joint = explain(ScriptError(2, 1, "MoveJoint failed: MoveJoint refused: target " + msg,
                                "movejoint(150,-90,180,0,0,180)"), "p.rbt")
    assert joint.fix == "use a J1 angle from -123 to 123 degrees"
    pose = explain(ScriptError(2, 1, "MovePose failed: MovePose refused: target " + msg,
                               "MovePose(0,-300,200,180,0,0)"), "p.rbt")
    assert pose.fix == "try a point more in front of the robot"
