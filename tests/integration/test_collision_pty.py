"""The collision guard over a real pseudo-terminal (issue 25, part 2b): ``parolkit board-sim`` in
its own process with its exchange log on, the real controller process on the pty with keep-out
zones in its config, commands and acks over real UDP (the rig of
tests/integration/test_live_motion_pty.py).

Judged on the frames the board received (in order, from its exchange log) and on the board's
own reports of where it is, never on wall-clock sleeps (the wall clock only bounds the waits):

* a MoveJoint and a MoveCart into a box are FAILED naming the pair and nothing reaches the
  board: no GO TO frame after the mark, while the board received 30 more frames;
* a joint target that folds the arm into itself is refused the same way;
* a Cartesian jog toward a plane stops at least the margin short: the pose the board reports at
  the end is clear of every zone by its margin (parolkit.collision.check);
* a SERVOL stream into a zone stops the same way.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from tests.conftest import wait_until
from tests.integration.boardsim import REPO_ROOT
from tests.integration.test_live_motion_pty import _SENDER, MotionBench

from parolkit.collision import TABLE_ZONE, BoxZone, PlaneZone, Scene, check
from parolkit.kinematics import fk
from parolkit.robot import PAROL6, goto_goal

SPD = np.asarray(PAROL6.steps_per_deg, dtype=float)
STANDBY = (90.0, -90.0, 180.0, 0.0, 0.0, 180.0)
#: a box the arm sweeps through when J1 turns from 90 to 0 deg
BOX = BoxZone("box", center=(250, 150, 250), size=(60, 60, 300), margin=10)
#: a flat crate under the standby TCP (0, 262.6, 288.8) mm
CRATE = BoxZone("crate", center=(0, 262.6, 208.8), size=(80, 80, 30), margin=5)
#: a wall in front of the arm: its forbidden side y >= 330 mm
WALL = PlaneZone("wall", point=(0, 330, 0), normal=(0, -1, 0), margin=10)
#: a clear pose, and from it a J2 swing that folds the wrist into the base
FOLD_START = (119.0, -90.0, 108.0, 3.0, 5.0, 187.0)
FOLD_TARGET = (119.0, -33.0, 108.0, 3.0, 5.0, 187.0)


def _toml(*zones: BoxZone | PlaneZone) -> str:
    out = []
    for z in zones:
        if isinstance(z, BoxZone):
            out.append(f'[[zones]]\nname = "{z.name}"\nkind = "box"\ncenter = {list(z.center)}\n'
                       f"size = {list(z.size)}\nmargin = {z.margin}\n")
        else:
            out.append(f'[[zones]]\nname = "{z.name}"\nkind = "plane"\npoint = {list(z.point)}\n'
                       f"normal = {list(z.normal)}\nmargin = {z.margin}\n")
    return "\n".join(out)


def _bench(tmp_path, *zones) -> MotionBench:
    return MotionBench(tmp_path, config_text=_toml(*zones))


def _move(angles, t: float) -> str:
    return "MOVEJOINT|" + "|".join(f"{v:g}" for v in angles) + f"|{t:g}|None"


def _no_goto_after(bench: MotionBench, mark: int, frames: int = 30) -> None:
    """The board received ``frames`` more frames after ``mark`` (the controller ticked on) and
    none of the frames after the mark is a GO TO."""
    ex = bench.exchange
    wait_until(lambda: ex.update().ins and ex.ins[-1][0] >= mark + frames, 20,
               what=f"{frames} frames at the board after the mark")
    assert not ex.gotos(after=mark), "a refused move sent GO TO frames to the board"


def _board_deg(bench: MotionBench) -> np.ndarray:
    """Where the board says it is, in its reply to the newest frame it received (deg)."""
    ex = bench.exchange.update()
    return np.asarray(ex.board[max(ex.board)], dtype=float) / SPD


def _wall_clearance(deg: np.ndarray) -> float:
    sc = Scene(zones=(TABLE_ZONE, WALL))
    d, _, _ = sc.distances(np.radians(deg))
    return float(min(x for x, p in zip(d, sc.pairs) if p.b == "zone 'wall'"))


def test_a_movejoint_and_a_movecart_into_a_box_are_refused_and_nothing_reaches_the_board(tmp_path):
    bench = _bench(tmp_path, BOX, CRATE)
    try:
        mark = bench.exchange.idle_mark()
        status, details = bench.run(_move((0, -90, 180, 0, 0, 180), 5), 30)
        assert status == "FAILED" and details.startswith("would collide: J6 link vs zone 'box' at "), details
        assert "s into the move (enters its 10 mm margin" in details
        pose = fk(list(STANDBY))
        target = (pose[0], pose[1], pose[2] - 130, pose[3], pose[4], pose[5])
        status, details = bench.run("MOVECART|" + "|".join(f"{v:.4f}" for v in target) + "|2|None", 30)
        assert status == "FAILED" and details.startswith("would collide: ") and "vs zone 'crate' at " in details
        _no_goto_after(bench, mark)
        # the robot stands where it stood, and moves that clear the zones run
        assert np.allclose(_board_deg(bench), STANDBY, atol=0.01)
        assert bench.run(_move((60, -90, 180, 0, 0, 180), 2), 30)[0] == "COMPLETED"
    finally:
        bench.close()


def test_a_joint_target_that_folds_the_arm_into_itself_is_refused(tmp_path):
    bench = _bench(tmp_path)  # the table only (on by default)
    try:
        assert bench.run(_move(FOLD_START, 4), 30)[0] == "COMPLETED"
        mark = bench.exchange.idle_mark()
        status, details = bench.run(_move(FOLD_TARGET, 3), 30)
        assert status == "FAILED" and details.startswith("would collide: base vs J6 link at "), details
        _no_goto_after(bench, mark)
    finally:
        bench.close()


def test_a_cartesian_jog_toward_a_plane_stops_at_least_the_margin_short(tmp_path):
    bench = _bench(tmp_path, WALL)
    try:
        mark = bench.exchange.idle_mark()
        status, details = bench.run("CARTJOG|WRF|Y+|50|5", 30)
        assert status == "FAILED", details
        assert details.startswith("jog stopped: J6 link ") and "from zone 'wall' (margin 10 mm)" in details
        assert len(bench.exchange.gotos(after=mark)) > 20, "the jog ran before it stopped"
        # the job ends once the board reports the stop's last target at rest
        final = _board_deg(bench)
        assert check(np.radians(final), (TABLE_ZONE, WALL)).clear
        assert _wall_clearance(final) >= 10.0
        # further in: refused before it moves, or (when the first stop came to rest a little
        # further out than its bound, as replies late on a busy machine make it: 10.2 mm
        # once) stopped again before the margin; either way the margin is kept.  Out: it runs
        mark = bench.exchange.idle_mark()
        status, details = bench.run("CARTJOG|WRF|Y+|20|1", 30)
        assert status == "FAILED", details
        if details.startswith("jog refused: "):
            assert all(f.speeds == (0,) * 6 for _, f in bench.exchange.gotos(after=mark))
        else:
            assert details.startswith("jog stopped: J6 link ") and "from zone 'wall' (margin 10 mm)" in details
            again = _board_deg(bench)
            assert check(np.radians(again), (TABLE_ZONE, WALL)).clear and _wall_clearance(again) >= 10.0
            print(f"\nthe jog further in ran {_wall_clearance(final) - _wall_clearance(again):.2f} mm before it "
                  f"stopped (clearance {_wall_clearance(again):.2f} mm)")
        assert bench.run("CARTJOG|WRF|Y-|50|0.5", 30)[0] == "COMPLETED"
    finally:
        bench.close()


def _servol_lines(bench: MotionBench, targets: list) -> tuple[list[str], list[str]]:
    ids = [bench.new_id() for _ in targets]
    return ids, [f"{cid}|SERVOL|" + "|".join(f"{v:.4f}" for v in p) for cid, p in zip(ids, targets)]


def test_a_servol_stream_into_a_zone_stops_at_least_the_margin_short(tmp_path):
    bench = _bench(tmp_path, WALL)
    try:
        # the TCP 100 mm along +y from the standby pose over 150 targets, then held for 60:
        # through the wall's margin at 68 mm (the J6 link reaches it first) to 22 mm into the
        # wall, every target within reach (from 110 mm on the IK refuses them: with 120 mm, a
        # controller whose follower was held back by late replies took such a target in before
        # the margin, and the stream ended "out of reach" instead)
        mark = bench.exchange.idle_mark()
        p0 = np.asarray(fk(list(STANDBY)), dtype=float)
        targets = [p0 + np.array([0, 100.0 * min(1.0, k / 150), 0, 0, 0, 0]) for k in range(210)]
        ids, lines = _servol_lines(bench, targets)
        out = subprocess.run([sys.executable, "-c", _SENDER, bench.ctl.host, str(bench.ctl.port)],
                             input="\n".join(lines), capture_output=True, text=True, timeout=60, cwd=REPO_ROOT)
        assert out.returncode == 0, out.stderr
        for c in ids:
            bench.acks.terminal(c, 20)
        acks = bench.acks.acks
        stopped = [c for c in ids if acks[c][-1][0] == "FAILED" and acks[c][-1][1].startswith("servo stream stopped: ")]
        assert stopped, [acks[c][-1] for c in ids[-5:]]
        assert "from zone 'wall' (margin 10 mm)" in acks[stopped[0]][-1][1]
        wait_until(lambda: bench.status()["command"] is None, 20, what="the controller idle")
        # no frame the board received took the arm into the margin: every GO TO's goal (where
        # the board heads and stops) keeps the margin, the targets held at the end too
        goals = [np.asarray(goto_goal(f.positions, f.speeds)) / SPD for _, f in bench.exchange.gotos(after=mark)]
        assert goals and min(_wall_clearance(g) for g in goals) >= 10.0 - 0.05
        final = _board_deg(bench)
        assert check(np.radians(final), (TABLE_ZONE, WALL)).clear
        assert _wall_clearance(final) >= 10.0
    finally:
        bench.close()


@pytest.mark.parametrize("text", ["GET_ZONES"])
def test_get_zones_over_udp_lists_the_configs_zones(tmp_path, text):
    bench = _bench(tmp_path, WALL)
    try:
        import json

        reply = bench.query(text)
        assert reply is not None and reply.startswith("ZONES|")
        z = json.loads(reply.split("|", 1)[1])
        assert [q["name"] for q in z["zones"]] == ["table", "wall"]
        assert z["zones"][1] == {"name": "wall", "kind": "plane", "point": [0, 330, 0], "normal": [0, -1, 0],
                                 "margin": 10}
        assert z["tool"] == {"name": "default", "shape": None} and z["held"] == []
    finally:
        bench.close()
