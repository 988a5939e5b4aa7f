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


def test_the_runner_resumes_at_the_line_the_estop_interrupted(tmp_path):
    """The commander's E-STOP while line 2 moves: the runner remembers line 2; after Enable a
    run with ``resume_line = 2`` starts at line 2 (planned again from where the arm stopped, to
    line 2's target), runs the rest and never line 1's Output.  A real controller process."""
    import asyncio
    import time

    from tests.conftest import start_controller

    from parolkit.gui.commander import Commander
    from parolkit.gui.link import ControllerLink
    from parolkit.gui.programs import ProgramsFolder

    ctl = start_controller(["--stream-watchdog", "0.15"], log_dir=tmp_path)
    text = ("Begin()\nOutput(1,HIGH)\nMoveJoint(50, -90, 180, 0, 0, 180, t=4)\nMoveJoint(90, -90, 180, 0, 0, 180, t=2)"
            "\nOutput(2,HIGH)\nEnd()\n")

    async def until(cond, timeout: float = 30.0, what: str = "condition") -> None:
        deadline = time.monotonic() + timeout
        while not cond():
            assert time.monotonic() < deadline, f"timed out waiting for {what}"
            await asyncio.sleep(0.02)

    async def main() -> None:
        link = ControllerLink("127.0.0.1", ctl.port, ctl.ack_port)
        c = Commander(link, mode_label="test", programs=ProgramsFolder(tmp_path / "programs"))
        await link.start()
        try:
            await until(lambda: link.link_up and link.status is not None, what="link up")
            runner = c.program
            assert await runner.start(text, name="p.rbt") == []
            await until(lambda: runner.current_line == 3 and link.status.angles[0] < 85, what="line 3 moving")
            c.estop()
            assert runner.estop_line == 3 and runner.state == "stopped" and runner.message == "E-STOP"
            await until(lambda: not runner.running, what="the run ended")
            await until(lambda: link.status.estop_latched, what="E-stop latched")
            stopped = link.status.angles[0]
            assert 50.5 < stopped < 85, stopped
            c.command("ENABLE", "Enable")
            await until(lambda: link.status.can_move, what="enabled again")
            c.command("PNEUMATICGRIPPER|close|1", "OUT1 LOW")  # line 2 set it: it must stay low
            await until(lambda: not link.status.io.out1, what="OUT1 low")
            lines: list[int] = []
            runner.resume_line = 3
            assert await runner.start(text, name="p.rbt") == []
            assert runner.resume_line is None and runner.estop_line is None

            def seen() -> bool:
                if runner.current_line is not None and (not lines or lines[-1] != runner.current_line):
                    lines.append(runner.current_line)
                return runner.state == "finished"

            await until(seen, 60, what="the resumed run finished")
            assert lines and lines[0] == 3 and 2 not in lines, lines
            await until(lambda: bool(link.status.io.out2), what="line 5 ran (OUT2 HIGH)")
            assert abs(link.status.angles[0] - 90.0) < 0.5
            assert not link.status.io.out1  # line 2 did not run again
            assert any("resume from line 3" in e.text for e in c.log)
        finally:
            await link.close()

    try:
        asyncio.run(main())
    finally:
        ctl.stop()
