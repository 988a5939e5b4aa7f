"""Cartesian motion from the homed standby pose (J5 = 0, the wrist singularity), measured at
the board: the real controller process on a pty, the emulator in this process; every frame
exchange is recorded (the board's positions after it), and the TCP is the forward kinematics
of those positions.  Frames, not wall-clock sleeps, are the unit of time."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from tests.conftest import wait_until
from tests.integration.test_controller_pty import Bench

from parolkit import kinematics as kin
from parolkit.protocol.frames import BoardCommand
from parolkit.robot import PAROL6

STANDBY = np.array(PAROL6.standby_deg)
RATE = 100.0
AXES = ["X+", "X-", "Y+", "Y-", "Z+", "Z-", "RX+", "RX-", "RY+", "RY-", "RZ+", "RZ-"]


class FrameRecorder:
    """Every frame exchange with the board: (monotonic time, command, positions after it)."""

    def __init__(self, emu) -> None:
        self.emu = emu
        self._lock = threading.Lock()
        self.rows: list[tuple[float, int, tuple[int, ...]]] = []
        emu.add_exchange_listener(self._on)

    def _on(self, cmd, status) -> None:
        with self._lock:
            self.rows.append((time.monotonic(), int(cmd.command), tuple(status.positions)))

    def since(self, t0: float) -> list[tuple[float, int, tuple[int, ...]]]:
        with self._lock:
            return [r for r in self.rows if r[0] >= t0]

    def close(self) -> None:
        self.emu.remove_exchange_listener(self._on)


def _tcp(positions) -> np.ndarray:
    """(N, 4, 4) TCP transforms (m) for board positions (steps)."""
    q = np.asarray(positions, dtype=float) / PAROL6.steps_per_deg
    return kin.fk_batch(np.atleast_2d(q), None, as_matrix=True)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    tr = np.einsum("nij,ij->n", a, b)
    return np.degrees(np.arccos(np.clip((tr - 1) / 2, -1, 1)))


@pytest.fixture
def singular_bench(tmp_path):
    b = Bench(tmp_path)
    rec = FrameRecorder(b.emu)
    yield b, rec
    rec.close()
    b.close()


def _to_standby(bench: Bench) -> None:
    status, details = bench.run("MOVEJOINT|90|-90|180|0|0|180|None|100", timeout=30)  # fastest way back
    assert status == "COMPLETED", details
    # (a position-tracked move may still end a step or two short: issue 14's limits part)
    wait_until(lambda: max(abs(a - b) for a, b in zip(bench.emu.positions, PAROL6.standby_steps)) <= 3,
               timeout=10, what="standby")


def _first_motion_frame(rows, m0: np.ndarray, rotation: bool) -> int | None:
    """Index (frames after the send) of the first exchange whose TCP moved from ``m0``:
    0.05 mm (translations) or 0.005 deg (rotations: 1.5x the largest FK noise of the steps;
    a J6 step turns the tool 0.0056 deg)."""
    m = _tcp([r[2] for r in rows])
    if rotation:
        moved = _angle_deg(m[:, :3, :3], m0[:3, :3]) >= 0.005
    else:
        moved = np.linalg.norm(m[:, :3, 3] - m0[:3, 3], axis=1) * 1e3 >= 0.05
    idx = np.nonzero(moved)[0]
    return int(idx[0]) if len(idx) else None


@pytest.mark.slow
def test_every_cartesian_jog_axis_in_both_frames_moves_within_100_ms_from_standby(singular_bench):
    bench, rec = singular_bench
    # one jog first: the controller process's first Cartesian plan pays one-off start-up costs
    assert bench.run("CARTJOG|WRF|Z-|50|0.1")[0] == "COMPLETED"
    report = []
    for frame in ("WRF", "TRF"):
        for axis in AXES:
            _to_standby(bench)
            m0 = _tcp(bench.emu.positions)[0]
            t_send = time.monotonic()
            cid = bench.send(f"CARTJOG|{frame}|{axis}|50|0.3")
            status, details = bench.acks.terminal(cid, 20)
            assert status == "COMPLETED", (frame, axis, details)
            rows = rec.since(t_send)
            k = _first_motion_frame(rows, m0, axis.startswith("R"))
            report.append((frame, axis, k))
    slow = [r for r in report if r[2] is None or r[2] > RATE * 0.1]
    print("frames until the TCP moved:", report)
    assert not slow, f"frames until the TCP moved (limit 10): {report}"


@pytest.mark.slow
def test_x_jog_from_standby_covers_20_mm_along_x_and_movecarts_keep_their_time(singular_bench):
    bench, rec = singular_bench
    _to_standby(bench)
    m0 = _tcp(bench.emu.positions)[0]
    t_send = time.monotonic()
    status, details = bench.run("CARTJOG|WRF|X+|50|1.0")
    assert status == "COMPLETED", details
    m = _tcp([r[2] for r in rec.since(t_send)])
    d = (m[:, :3, 3] - m0[:3, 3]) * 1e3
    assert d[-1, 0] >= 20.0, f"X+ moved {d[-1, 0]:.2f} mm"
    assert np.abs(d[:, 1:]).max() < 0.5, f"off-axis {np.abs(d[:, 1:]).max():.3f} mm"

    for text in ("MOVECART|0.0|263.23|161.241|-90.0|0.0|-89.499|2.0|None",
                 "MOVECARTRELTRF|-80|0|0|0|0|0|2.0|None"):
        _to_standby(bench)
        m0 = _tcp(bench.emu.positions)[0]
        t_send = time.monotonic()
        cid = bench.send(text)
        status, details = bench.acks.terminal(cid, 30)
        assert status == "COMPLETED", details
        rows = rec.since(t_send)
        moving = [i for i, r in enumerate(rows) if r[1] == BoardCommand.GOTO]
        pos = _tcp([r[2] for r in rows])[:, :3, 3] * 1e3
        p_end = pos[-1]
        # from the first motion frame (GO TO) to the first status at the final position
        start_i = moving[0]
        end_i = next(i for i in range(len(rows)) if rows[i][2] == rows[-1][2])
        frames = end_i - start_i + 1
        assert abs(frames - 200) <= 1, f"{text}: {frames} frames of motion at the board"
        a, b = m0[:3, 3] * 1e3, p_end
        u = (b - a) / np.linalg.norm(b - a)
        rel = pos - a
        off = np.linalg.norm(rel - np.outer(rel @ u, u), axis=1).max()
        assert off <= 0.05, f"{text}: {off:.4f} mm off the line"
        assert moving
