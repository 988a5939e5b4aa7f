"""Resume after an E-stop (parolkit.gui.resume): from the interrupted line, where that is safe."""

from __future__ import annotations

from parolkit.gui.resume import ResumePlan, resume_plan
from parolkit.script import parse
from parolkit.script.program import Loop, MoveJoint


def _program(text: str):
    result = parse(text, "p.rbt")
    assert result.program is not None, result.errors
    return result.program


def test_resume_runs_the_rest_from_the_interrupted_line_with_its_numbers():
    prog = _program("Begin()\nMoveJoint(80,-90,180,0,0,180,t=2)\nDelay(0.5)\n"
                    "MoveJoint(90,-90,180,0,0,180,t=2)\nOutput(1,HIGH)\nEnd()\n")
    plan = resume_plan(prog, 4)
    assert isinstance(plan, ResumePlan) and not plan.then_loop
    assert [c.line for c in plan.program.commands] == [4, 5, 6]
    assert isinstance(plan.program.commands[0], MoveJoint)  # planned again from where the arm is
    assert plan.program.source_name == "p.rbt"


def test_a_loop_program_finishes_its_pass_then_loops_from_the_top():
    prog = _program("Begin()\nMoveJoint(80,-90,180,0,0,180,t=2)\nDelay(1)\nLoop()\n")
    plan = resume_plan(prog, 3)
    assert isinstance(plan, ResumePlan) and plan.then_loop
    assert [c.line for c in plan.program.commands] == [3]
    assert not plan.program.loops and not any(isinstance(c, Loop) for c in plan.program.commands)


def test_no_resume_where_it_is_not_safe():
    prog = _program("Begin()\nMoveCartRelTRF(0,0,10,0,0,0,t=1)\nSpeedJoint(5,0,0,0,0,0,t=1)\nDelay(1)\nEnd()\n")
    for line, words in ((2, "MoveCartRelTRF moves relative"), (3, "SpeedJoint moves relative"),
                        (7, "holds no command"), (5, "reached its end")):
        why = resume_plan(prog, line)
        assert isinstance(why, str) and words in why, (line, why)
    assert isinstance(resume_plan(prog, 4), ResumePlan)
