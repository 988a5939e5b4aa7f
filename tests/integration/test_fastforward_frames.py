"""``parolkit run PROG --sim --fast`` writes the same frames as ``parolkit run PROG --sim``
paced at real time: the two ``--frame-log`` files are equal byte for byte (through the real
CLI, codec, guard, integrity check and emulator, each run in its own process)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]

#: a few seconds of motion and everything else a program sends: moves, delays, outputs, the
#: gripper (calibration and a move)
PROGRAM = """Begin()
MoveJoint(85, -95, 170, 5, -5, 175, t=1.0)
Output(1, HIGH)
Gripper_cal()
Delay(0.5)
Gripper(100, 60, 600)
MoveJoint(90, -90, 180, 0, 0, 180)
MoveCartRelTRF(0, 0, -20, 0, 0, 0)
Delay(0.3)
Output(1, LOW)
End()
"""


def _run(program: Path, log: Path, *fast: str) -> str:
    out = subprocess.run([sys.executable, "-m", "parolkit", "run", str(program), "--sim", *fast,
                          "--frame-log", str(log), "--quiet"],
                         capture_output=True, text=True, timeout=180, cwd=REPO_ROOT)
    assert out.returncode == 0, out.stdout + out.stderr
    return out.stdout


@pytest.mark.parametrize("name", ["small.rbt", "examples/cartesian_relative_trf.rbt"])
def test_fast_forward_writes_the_frames_of_a_real_time_run(tmp_path, name):
    if name == "small.rbt":
        program = tmp_path / name
        program.write_text(PROGRAM)
    else:
        program = REPO_ROOT / name
    paced, fast = tmp_path / "paced.log", tmp_path / "fast.log"
    said_paced = _run(program, paced)
    said_fast = _run(program, fast, "--fast")
    frames = paced.read_text().splitlines()
    assert len(frames) > 300  # seconds of frames at 100 Hz (and more for the homing before)
    assert fast.read_bytes() == paced.read_bytes()
    # the runs ended in the same place
    assert said_paced.splitlines()[-1] == said_fast.splitlines()[-1]
