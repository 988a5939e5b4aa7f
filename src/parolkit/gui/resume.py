"""Resume a program the E-stop interrupted, from the line it was on (no NiceGUI: tested without
a browser).

After an E-stop is released the commander offers "Resume from line N" (next to "Restart")
where that is safe: the program runs on from line N, whose move is planned anew from where the
arm stopped to that line's own target (the check before the run dry-runs it from the current
joints, as every run is checked).  It is not offered when line N's move is relative to where
the arm was (``MoveCartRelTRF``, ``SpeedJoint``): from where it stopped, the same line would
end somewhere else.  A ``Loop()`` program runs the rest of its pass, then from its first line
again, looping as before.
"""

from __future__ import annotations

from dataclasses import dataclass

from parolkit.script.program import End, Loop, MoveCartRelTRF, Program, SpeedJoint

__all__ = ["ResumePlan", "resume_plan"]


@dataclass(frozen=True)
class ResumePlan:
    """The run that resumes at ``line``: ``program`` is the program from that line on (the
    lines keep their numbers), ``then_loop`` says the whole program runs after it, looping
    (it ended with ``Loop()``)."""

    line: int
    program: Program
    then_loop: bool


def resume_plan(program: Program, line: int) -> ResumePlan | str:
    """How to resume ``program`` at source line ``line``; or, as a sentence, why it cannot be
    resumed there (Restart runs it from its first line)."""
    index = next((i for i, c in enumerate(program.commands) if c.line == line), None)
    if index is None:
        return f"line {line} holds no command of this program"
    cmd = program.commands[index]
    if isinstance(cmd, (MoveCartRelTRF, SpeedJoint)):
        return (f"line {line}'s {cmd.keyword} moves relative to where the arm was; from where it stopped it "
                "would end somewhere else")
    rest = program.commands[index:]
    if isinstance(cmd, (End, Loop)):
        return f"the program had reached its end (line {line})"
    then_loop = program.loops
    if then_loop:
        rest = rest[:-1]  # the rest of this pass; the whole program loops after it
    return ResumePlan(line, Program(tuple(rest), program.source_name, program.warnings), then_loop)
