"""A MoveCart after a Cartesian jog from standby (issue 24, item 8), over real UDP: the real
controller process on a simulated board in lockstep with its frames; the status stream gives
the frame written and the board's counters at every tick.  ``CARTJOG|WRF|X+|40|0.3`` leaves the
wrist 0.5 deg from J5 = 0 (J5 < 0) and ``MOVECART|0|262.57|250|-90|0|-90|None|50`` used to be
refused ("J4 would be -125.2 deg"): it now runs to its pose on the in-range wrist branch."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tests.conftest import wait_until
from tests.integration.status_log import StatusLog, client_and_status_log
from tests.integration.test_controller_sim import Client

from parolkit import kinematics as kin
from parolkit.robot import PAROL6

SPD = np.asarray(PAROL6.steps_per_deg, dtype=float)
LIMITS_STEPS = np.asarray(PAROL6.limits_steps)
TARGET = [0.0, 262.57, 250.0, -90.0, 0.0, -90.0]


@pytest.fixture
def bench(controller_factory):
    with client_and_status_log(controller_factory(lockstep=True)) as pair:
        yield pair


def _run(client: Client, text: str) -> tuple[str, str, str]:
    cid = client.send(text)
    return (cid, *client.acks.terminal(cid, 30))


def _ticks(log: StatusLog, cid: str) -> tuple[np.ndarray, np.ndarray]:
    """(frames' commanded steps, board counters) of every tick command ``cid`` ran."""
    wait_until(lambda: (lambda s: s and s[-1].command is None)(log.snapshot()), what="the status after the move")
    rows = [st.raw for st in log.snapshot() if st.command is not None and st.command.id == cid]
    sent = np.array([r["sent"]["steps"] for r in rows if r["sent"]])
    return sent, np.array([r["steps"] for r in rows])


def _in_limits(steps: np.ndarray) -> bool:
    return bool(np.all(steps >= LIMITS_STEPS[:, 0]) and np.all(steps <= LIMITS_STEPS[:, 1]))


def test_movecart_after_a_cartesian_jog_from_standby_completes_on_its_pose_within_the_limits(bench):
    client, log = bench
    cid, status, details = _run(client, "CARTJOG|WRF|X+|40|0.3")
    assert status == "COMPLETED", details
    after_jog = np.array(client.json("GET_STATUS_JSON")["steps"])
    assert -0.6 < after_jog[4] / SPD[4] < -0.4  # J5 < 0, next to the wrist singularity

    log.clear()
    cid, status, details = _run(client, "MOVECART|0|262.57|250|-90|0|-90|None|50")
    assert status == "COMPLETED", details
    sent, board = _ticks(log, cid)
    assert len(sent) > 100 and len(board) > 100
    assert _in_limits(sent), "a frame commanded a joint outside its limits"
    assert _in_limits(board), "the board went outside a joint's limits"
    # the in-range branch: J4 stays near 0 (on the start's branch it swept towards -180 deg)
    assert np.abs(board[:, 3] / SPD[3]).max() < 14.0

    final = wait_until(lambda: (lambda st: st if st["state"] == "IDLE" else None)(
        client.json("GET_STATUS_JSON")), what="idle")
    q = np.array(final["steps"]) / SPD
    assert q[3] == pytest.approx(0.0, abs=0.1) and q[4] == pytest.approx(12.33, abs=0.1)
    m = kin.fk_matrix(q)
    want = kin.pose_to_matrix(TARGET)
    assert np.linalg.norm(m[:3, 3] - want[:3, 3]) * 1e3 < 0.1
    err = math.degrees(math.acos(np.clip((np.trace(m[:3, :3].T @ want[:3, :3]) - 1) / 2, -1, 1)))
    assert err < 0.1
