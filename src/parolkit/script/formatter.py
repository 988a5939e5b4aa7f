"""``parolkit fmt``: rewrite an RBTscript program in canonical form.

Canonical form: one command per line in the original spelling (``MoveJoint``,
``Gripper_cal``), arguments separated by ``", "``, numbers in their shortest exact form
(``90.0`` -> ``90``), options in the order ``v= a= t= r= profile speed``, ``HIGH``/``LOW`` for
levels, no indentation, comments kept (two spaces before a trailing comment), at most one
blank line in a row and none at the start or end, a final newline.

Formatting never changes what a program does: the formatted text parses to the same commands.
A program with errors is not formatted (:class:`ProgramError` lists them all).
"""

from __future__ import annotations

from parolkit.script.parser import Limits, line_comment, parse
from parolkit.script.program import ProgramError

__all__ = ["format_program"]


def format_program(text: str, source_name: str = "<script>", *, limits: Limits | None = None) -> str:
    """The canonical text of program ``text``; raises :class:`ProgramError` when it has errors."""
    result = parse(text, source_name, limits=limits)
    if not result.ok or result.program is None:
        raise ProgramError(result.errors)
    by_line = {cmd.line: cmd for cmd in result.program.commands}
    out: list[str] = []
    for number, raw in enumerate(text.split("\n"), start=1):
        line = raw[:-1] if raw.endswith("\r") else raw
        code, comment = line_comment(line)
        comment = comment.rstrip()
        cmd = by_line.get(number)
        if cmd is not None:
            out.append(cmd.to_source() + (f"  {comment}" if comment else ""))
        elif comment:
            out.append(comment)
        elif out and out[-1] != "":
            out.append("")
    while out and out[-1] == "":
        out.pop()
    return "\n".join(out) + "\n"
