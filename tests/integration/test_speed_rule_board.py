"""Issue 24, item 7 (the seed's speed rule) on the wire: a move within every joint's maximum
speed runs.  The real controller process drives a simulated board in lockstep with its frames
(each frame runs it exactly one period); a ``spy+`` link logs every frame both ways and every
GO TO frame is judged with the board's reply, as in ``test_guard_wire.py``.

Position-tracked plans keep to the position-tracking maximum (75-76 % of each joint's maximum
at 100 Hz: the bounded GO TO frames' margin).  A MoveJoint with the seed's t that needs more
than that but no more than the maximum (5,473 of J1's 6,500 steps/s; 20,805 of J5's 22,000)
used to be refused; it now runs stretched, COMPLETED with a warning naming the joint, the
speed, that maximum and the stretched duration, and ends exactly on its target, the board never
over a joint's maximum.  A move over a joint's maximum speed is still refused, nothing moving."""

from __future__ import annotations

import time

import pytest
from tests.integration.test_guard_wire import WireBench, check_wire, read_wire

from parolkit.protocol.frames import BoardCommand
from parolkit.robot import PAROL6, deg_to_steps

RATE = 100.0


@pytest.fixture
def bench(tmp_path):
    b = WireBench(tmp_path)
    yield b
    b.close()


def _fmt(values) -> str:
    return "|".join(f"{v:.3f}" for v in values)


def _steps(bench: WireBench) -> tuple[int, ...]:
    return tuple(bench.status()["steps"])


def test_a_movejoint_over_the_tracking_margin_but_within_the_maximum_runs_stretched_with_a_warning(bench):
    runs: list[tuple[str, str, str, float, float]] = []

    def move(text: str, timeout: float = 60.0) -> tuple[str, str]:
        t0 = time.monotonic()
        cid = bench.send(text)
        status, details = bench.acks.terminal(cid, timeout)
        runs.append((text, status, details, t0, time.monotonic()))
        return status, details

    assert _steps(bench) == PAROL6.standby_steps
    # J1 from 90 deg by 102.62 deg in the seed's t=4 (poly): 1.875 x 11676 steps / 4 s = 5473
    # steps/s, within J1's maximum 6500, over its position-tracking maximum 4884: stretched
    # to 1.875 x 11676 / 4884 = 4.483 s, rounded up to 4.49 s
    j1 = list(PAROL6.standby_deg)
    j1[0] = -12.62
    status, details = move(f"MOVEJOINT|{_fmt(j1)}|4|None")
    assert status == "COMPLETED", details
    assert details == ("MoveJoint finished successfully; warning: J1 needs 5473 steps/s to finish in the t=4 s "
                       "given, above its position-tracking maximum 4884 steps/s (75 % of its maximum speed 6500 "
                       "steps/s: the board's GO TO loop starts each tick up to 1.33x faster than the stream "
                       "moves): the move runs stretched to 4.49 s")
    assert _steps(bench) == tuple(deg_to_steps(j1).tolist())  # exactly on its target

    # J5 to -78.02 deg (within every limit: no warning), then across 156.04 deg in t=1:
    # 1.875 x 11096 steps / 1 s = 20805 of J5's 22000 steps/s: stretched to 1.25 s
    j5a = list(j1)
    j5a[4] = -78.02
    status, details = move(f"MOVEJOINT|{_fmt(j5a)}|2|None")
    assert (status, details) == ("COMPLETED", "MoveJoint finished successfully")
    j5b = list(j1)
    j5b[4] = 78.02
    status, details = move(f"MOVEJOINT|{_fmt(j5b)}|1|None")
    assert status == "COMPLETED", details
    assert details.startswith("MoveJoint finished successfully; warning: J5 needs 20805 steps/s to finish in "
                              "the t=1 s given, above its position-tracking maximum 16714 steps/s (76 % of its "
                              "maximum speed 22000 steps/s"), details
    assert "the move runs stretched to 1.25 s" in details
    assert _steps(bench) == tuple(deg_to_steps(j5b).tolist())

    # over J5's maximum speed (1.875 x 11096 / 0.9 = 23117 > 22000): refused, nothing moves,
    # naming the shortest t accepted and the t from which it runs as given
    status, details = move(f"MOVEJOINT|{_fmt(j5a)}|0.9|None")
    assert status == "FAILED"
    assert "J5 would need a speed of 23117 steps/s, above its maximum speed 22000 steps/s" in details
    assert details.endswith("give t >= 0.95 s (a t below 1.25 s runs stretched to 1.25 s: J5 position-tracking "
                            "maximum 16714 steps/s).")
    assert _steps(bench) == tuple(deg_to_steps(j5b).tolist())

    wire = read_wire(bench.log_path)
    goto_frames = [sum(1 for t, f, _ in wire if t0 <= t <= t1 and f.command == BoardCommand.GOTO)
                   for _, _, _, t0, t1 in runs]
    # the stretched moves took their stretched durations in frames (449 and 125 samples, then
    # the few ticks in which the board closes its last steps); the refused one sent none
    assert 449 <= goto_frames[0] <= 449 + 15, goto_frames
    assert 125 <= goto_frames[2] <= 125 + 15, goto_frames
    assert goto_frames[3] == 0, goto_frames
    # every frame within the maxima, the board starting no period faster than a joint's maximum
    report = check_wire(wire)
    print("wire:", report, "GO TO frames per command:", goto_frames)
    # ... and the stretched moves ran J1 and J5 near their maxima, not at 76 % of them
    assert report["peak"][0] > 0.9 and report["peak"][4] > 0.9, report
    stats = bench.status()
    assert stats["enabled"], stats
