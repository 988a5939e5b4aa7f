"""Issue 14 at the board: the real controller process on a real pty, the board emulator on the
other side.  Position-tracked moves end exactly on their target; a wrist move of the original
commander's programs runs in its time (with a warning when it needs more than a joint's
acceleration limit); a speed violation is refused with the shortest t that works."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from tests.integration.test_controller_pty import Bench

from parolkit.protocol.frames import BoardCommand
from parolkit.robot import PAROL6, deg_to_steps


class FrameRecorder:
    """Every frame the emulator took from the link: (board time s, command, positions)."""

    def __init__(self, emu) -> None:
        self.emu = emu
        self.frames: list[tuple[float, int, tuple[int, ...]]] = []
        self._lock = threading.Lock()
        emu.add_exchange_listener(self._on)

    def _on(self, frame, reply) -> None:
        with self._lock:
            self.frames.append((self.emu._t, int(frame.command), tuple(frame.positions)))

    def since(self, n: int) -> list[tuple[float, int, tuple[int, ...]]]:
        with self._lock:
            return self.frames[n:]

    def __len__(self) -> int:
        with self._lock:
            return len(self.frames)


@pytest.fixture
def bench(tmp_path):
    b = Bench(tmp_path)
    yield b
    b.close()


def _fmt(values) -> str:
    return "|".join(f"{v:.3f}" for v in values)


@pytest.mark.slow
def test_100_random_position_tracked_moves_end_with_0_steps_error_at_the_board(bench):
    rng = np.random.default_rng(1414)
    errors = []
    for k in range(100):
        target = np.round(np.array(PAROL6.standby_deg) + rng.uniform(-2.0, 2.0, 6), 3)
        status, details = bench.run(f"MOVEJOINT|{_fmt(target)}|{rng.uniform(0.25, 0.35):.2f}|None", timeout=30)
        assert status == "COMPLETED", (k, details)
        # nothing else is queued: the board holds what it reached when the move completed
        errors.append(int(np.abs(np.array(bench.emu.positions) - deg_to_steps(target)).max()))
    assert errors == [0] * 100


def test_wrist_move_of_the_original_programs_runs_in_its_time_and_a_speed_violation_names_the_minimum_t(bench):
    rec = FrameRecorder(bench.emu)
    j5 = [90, -90, 180, 0, 59, 180]
    # J5 by 59 deg in 0.8 s (the original commander's demo): within the limits, runs in 0.8 s
    n0 = len(rec)
    status, details = bench.run(f"MOVEJOINT|{_fmt(j5)}|0.8|None")
    assert status == "COMPLETED", details
    assert "warning" not in details
    goto = [f for f in rec.since(n0) if f[1] == BoardCommand.GOTO]
    assert goto[-1][2] == tuple(deg_to_steps(j5).tolist())
    # the planned samples take 80 ticks; the last few steps at the board a few more
    planned = [f for f in goto if f[2] != goto[-1][2]]
    assert 0.8 - 0.03 <= planned[-1][0] - goto[0][0] + 0.01 <= 0.8 + 0.03
    assert bench.emu.positions == tuple(deg_to_steps(j5).tolist())
    # back in 0.5 s: needs 96900 steps/s^2 on J5 (limit 66000): runs in 0.5 s with the warning
    back = list(PAROL6.standby_deg)
    n0 = len(rec)
    status, details = bench.run(f"MOVEJOINT|{_fmt(back)}|0.5|None")
    assert status == "COMPLETED", details
    assert details.startswith("MoveJoint finished successfully; warning: J5 needs an acceleration of ")
    assert "above its limit 66000 steps/s^2" in details and "the move runs in the t=0.5 s given" in details
    goto = [f for f in rec.since(n0) if f[1] == BoardCommand.GOTO]
    planned = [f for f in goto if f[2] != goto[-1][2]]
    assert 0.5 - 0.03 <= planned[-1][0] - goto[0][0] + 0.01 <= 0.5 + 0.03
    assert bench.emu.positions == PAROL6.standby_steps
    # in 0.3 s J5 would exceed its speed limit: refused, nothing moves, with the minimum t
    n0 = len(rec)
    status, details = bench.run(f"MOVEJOINT|{_fmt(j5)}|0.3|None")
    assert status == "FAILED"
    assert "J5 would need a speed of" in details and details.endswith("give t >= 0.47 s.")
    assert not [f for f in rec.since(n0) if f[1] == BoardCommand.GOTO]
    # (0.47 s itself plans J5 at 99.7 % of its position-tracking maximum: the rig test runs it;
    # here, on a loaded machine, a tick late by more than the 1 ms the tracking margin allows
    # may make the guard refuse a frame at that speed, so the board side is tested with room)
    status, details = bench.run(f"MOVEJOINT|{_fmt(j5)}|0.55|None")
    assert status == "COMPLETED", details
    assert bench.emu.positions == tuple(deg_to_steps(j5).tolist())
