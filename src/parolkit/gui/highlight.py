"""RBTscript syntax colouring for the editor: text -> CodeMirror mark decorations.

A small regular-expression tokenizer (the real grammar lives in :mod:`parolkit.script`); it
only decides colours, so it never rejects text.  Offsets are Python ``str`` indices, as the
NiceGUI CodeMirror ``decorations`` expect.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import Enum

__all__ = ["TokenKind", "Token", "tokenize", "mark_decorations", "line_decorations", "COMMANDS"]

#: Command names known to RBTscript (case-insensitive match for colouring).
COMMANDS = ("Begin", "End", "Loop", "MoveJoint", "MovePose", "MoveCart", "MoveCartRelTRF",
            "SpeedJoint", "Delay", "Speed", "Output", "Input", "Gripper", "Gripper_cal", "Home")
_WORDS = ("HIGH", "LOW", "poly", "trap", "speed", "ruckig", "toppra", "position")


class TokenKind(str, Enum):
    COMMAND = "command"
    NUMBER = "number"
    KEYWORD = "keyword"
    PARAM = "param"
    COMMENT = "comment"
    UNKNOWN = "unknown"


@dataclass(frozen=True)
class Token:
    kind: TokenKind
    start: int
    end: int


_TOKEN_RE = re.compile(
    r"(?P<comment>(?:#|//).*)"
    r"|(?P<param>\b[A-Za-z]\w*\s*=)"
    r"|(?P<number>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
    r"|(?P<word>[A-Za-z_]\w*)"
)
_COMMANDS_LOWER = {c.lower() for c in COMMANDS}
_WORDS_LOWER = {w.lower() for w in _WORDS}


def tokenize(text: str) -> list[Token]:
    """Colour tokens of ``text`` in order (punctuation and spaces are not tokens)."""
    out: list[Token] = []
    for m in _TOKEN_RE.finditer(text):
        kind = m.lastgroup
        if kind == "comment":
            out.append(Token(TokenKind.COMMENT, m.start(), m.end()))
        elif kind == "param":
            out.append(Token(TokenKind.PARAM, m.start(), m.end()))
        elif kind == "number":
            out.append(Token(TokenKind.NUMBER, m.start(), m.end()))
        else:
            w = m.group().lower()
            # a command name only where it is called: ``speed`` inside a move is the
            # tracking word, ``Speed(50)`` the command
            called = text[m.end():].lstrip().startswith("(")
            k = (TokenKind.COMMAND if w in _COMMANDS_LOWER and (called or w not in _WORDS_LOWER)
                 else TokenKind.KEYWORD if w in _WORDS_LOWER else TokenKind.UNKNOWN)
            out.append(Token(k, m.start(), m.end()))
    return out


def mark_decorations(text: str) -> list[dict[str, int | str]]:
    """CodeMirror mark decorations (class ``rbt-<kind>``) for every token of ``text``."""
    return [{"kind": "mark", "from": t.start, "to": t.end, "class": f"rbt-{t.kind.value}"}
            for t in tokenize(text) if t.end > t.start]


def line_decorations(text: str, *, current_line: int | None = None,
                     error_lines: dict[int, str] | None = None) -> list[dict[str, int | str]]:
    """Line decorations: ``rbt-current`` on the executing line, ``rbt-error`` on error lines
    (1-based line numbers; lines beyond the text are ignored)."""
    n_lines = text.count("\n") + 1
    out: list[dict[str, int | str]] = []
    for line in sorted(error_lines or {}):
        if 1 <= line <= n_lines:
            out.append({"kind": "line", "line": line, "class": "rbt-error"})
    if current_line is not None and 1 <= current_line <= n_lines:
        out.append({"kind": "line", "line": current_line, "class": "rbt-current"})
    return out
