"""The editor's completion items (parolkit.gui.completion): every command is inserted as a line
that is valid as it stands (issue 26: completion inserted ``MoveJoint(j1,...,j6,t=2)``, an error
at once), the moves to a target with the robot's current joints or pose, as Insert does."""

from __future__ import annotations

from parolkit.gui.completion import COMPLETIONS, LIVE, completion_table, filled
from parolkit.gui.templates import render_template
from parolkit.robot import PAROL6
from parolkit.script import dry_run, parse
from parolkit.script.parser import COMMAND_NAMES

#: a pose the arm reaches that is not the standby one (joints, deg) and its TCP pose
ELSEWHERE = (80.0, -100.0, 170.0, 5.0, -20.0, 170.0)


def _program(line: str) -> str:
    if line in ("Begin()", "End()", "Loop()"):
        return {"Begin()": "Begin()\nEnd()\n", "End()": "Begin()\nEnd()\n", "Loop()": "Begin()\nLoop()\n"}[line]
    return f"Begin()\n{line}\nEnd()\n"


def test_every_command_is_offered_with_valid_arguments():
    calls = [c for c in COMPLETIONS if c.call]
    assert [c.label for c in calls] == list(COMMAND_NAMES)
    for c in calls:
        result = parse(_program(c.insert), "completion")
        assert result.ok, (c.insert, [e.message for e in result.errors])
        assert not any(w in c.insert for w in ("j1", "x,y", "position,", "v1")), c.insert


def test_the_moves_to_a_target_take_the_current_joints_or_pose_as_insert_does():
    from parolkit.kinematics import fk

    pose = tuple(float(v) for v in fk(ELSEWHERE))
    assert LIVE == {"MoveJoint": "joints", "MovePose": "pose", "MoveCart": "pose"}
    for c in COMPLETIONS:
        if not c.live:
            assert c.pattern == ""
            continue
        line = filled(c.pattern, ELSEWHERE, pose)
        assert line == render_template(c.label, ELSEWHERE, pose)  # the Insert menu's line
        result = parse(_program(line), "completion")
        assert result.ok and result.program is not None, [e.message for e in result.errors]
        # valid from where the arm is: the move goes to where it stands
        assert dry_run(result.program, ELSEWHERE).ok, line
        assert c.insert == render_template(c.label, PAROL6.standby_deg, tuple(float(v) for v in fk(PAROL6.standby_deg)))
        assert "current" in c.detail and "{" not in c.detail


def test_the_table_is_json_ready():
    import json

    table = json.loads(json.dumps(completion_table()))
    assert {"label", "insert", "detail", "call", "live", "pattern"} <= set(table[0])
    assert any(item["label"] == "t=" and not item["call"] for item in table)
