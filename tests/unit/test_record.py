"""parolkit.record without a controller: message conversion, the writer/reader round trip,
a file cut short, fitting planned moves, comparison, teach on a planned demonstration, CLI
argument errors, CSV export and plots."""

from __future__ import annotations

import argparse
import csv
import math

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from parolkit.kinematics.pose import pose_to_matrix
from parolkit.motion import plan
from parolkit.moves import JointMove
from parolkit.record import messages
from parolkit.record.cli import parse_host_port
from parolkit.record.compare import compare_recordings, first_motion_tick
from parolkit.record.export import CSV_HEADER, write_csv
from parolkit.record.plot import plot_recording
from parolkit.record.reader import load_recording
from parolkit.record.schemas import JOINT_NAMES, JOINT_STATE, POSE_STAMPED, TOPIC_JOINT_STATES
from parolkit.record.segments import command_segments, fit_joint_move, rest_segments, steps_to_deg
from parolkit.record.teach import teach
from parolkit.record.writer import RecordingWriter
from parolkit.robot import PAROL6

STANDBY = np.array(PAROL6.standby_deg)


def _quat_matrix(q: tuple[float, float, float, float]) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@pytest.mark.parametrize("abc", [(0, 0, 0), (-90, 0, -90), (30, -45, 170), (12.5, 89, -3)])
def test_quaternion_is_the_rotation_of_the_pose_convention(abc):
    q = messages.quaternion_from_abc(*abc)
    assert math.isclose(sum(v * v for v in q), 1.0, rel_tol=1e-12)
    r = pose_to_matrix([0, 0, 0, *abc])[:3, :3]
    assert np.allclose(_quat_matrix(q), r, atol=1e-12)


def _status(seq: int, steps: np.ndarray, command: dict | None = None, out1: int = 0) -> dict:
    deg = steps_to_deg(steps)
    return {"seq": seq, "time": seq / 100, "state": "MOVING" if command else "IDLE",
            "angles": deg.tolist(), "steps": [int(v) for v in steps], "speeds_deg_s": [0.0] * 6,
            "pose": [1.0, 262.5, 288.75, -90.0, 0.0, -90.0], "command": command,
            "io": {"in1": 0, "in2": 0, "out1": out1, "out2": 0, "estop": 1},
            "gripper": {"position": 0, "activated": False}, "loop": {"rate_hz": 100.0, "period_p99_ms": 10.1}}


def _write(path, statuses, *, close=True, flush_every=None):
    w = RecordingWriter(path, flush_interval_s=3600)
    for i, s in enumerate(statuses):
        t = 1_700_000_000_000_000_000 + s["seq"] * 10_000_000
        w.write_ros(TOPIC_JOINT_STATES, JOINT_STATE, messages.joint_state(s, t), t, s["seq"])
        w.write_ros("/tcp_pose", POSE_STAMPED, messages.pose_stamped(s, t), t, s["seq"])
        w.write_status(s, t, s["seq"])
        if flush_every and (i + 1) % flush_every == 0:
            w.flush()
    if close:
        w.close({"statuses": len(statuses)})
    return w


def _planned_recording(tmp_path, moves, name="demo.mcap", gap=30):
    """Statuses whose steps are exactly the planner's samples of ``moves`` (with ``gap`` ticks
    at rest before, between and after), each shown as an active command with its progress."""
    statuses, seq = [], 100
    q = STANDBY.copy()
    steps = np.rint(q * PAROL6.steps_per_deg).astype(np.int64)
    for _ in range(gap):
        statuses.append(_status(seq, steps))
        seq += 1
    for k, move in enumerate(moves):
        traj = plan(move, q)
        n = len(traj.positions)  # the controller's progress: (k + 1) / n at the k-th sample
        for j, p in enumerate(traj.positions):
            cmd = {"id": f"id{k}", "name": "MOVEJOINT", "progress": round((j + 1) / n, 4)}
            statuses.append(_status(seq, p, cmd))
            seq += 1
        steps = traj.positions[-1]
        q = steps_to_deg(steps)
        for _ in range(gap):
            statuses.append(_status(seq, steps))
            seq += 1
    path = tmp_path / name
    _write(path, statuses)
    return path, statuses


def test_writer_output_reads_back_with_mcap_and_ros2_decoding(tmp_path):
    statuses = [_status(i, np.array([10240, -32000, 57905, 0, 0, 32000]) + i) for i in range(50)]
    path = tmp_path / "x.mcap"
    _write(path, statuses)
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        decoded = [(m.sequence, d) for _, _, m, d in reader.iter_decoded_messages(topics=[TOPIC_JOINT_STATES])]
        assert reader.get_summary().statistics.message_count == 150
    assert [s for s, _ in decoded] == list(range(50))
    assert list(decoded[7][1].name) == list(JOINT_NAMES)
    assert np.allclose(np.degrees(decoded[7][1].position), statuses[7]["angles"], atol=1e-12)
    rec = load_recording(path)
    assert rec.complete and len(rec) == 50 and rec.dropped_ticks == 0
    assert rec.metadata["parolkit.recording"] == {"statuses": "50"}


def test_a_file_cut_short_reads_up_to_its_last_complete_chunk(tmp_path):
    statuses = [_status(i, np.array([10240, -32000, 57905, 0, 0, 32000]) + i) for i in range(100)]
    path = tmp_path / "cut.mcap"
    w = _write(path, statuses, close=False, flush_every=25)
    w._file.flush()
    data = path.read_bytes()
    (tmp_path / "cut2.mcap").write_bytes(data[: int(len(data) * 0.8)])  # torn inside the 4th chunk
    rec = load_recording(path)
    assert not rec.complete and len(rec) == 100
    torn = load_recording(tmp_path / "cut2.mcap")
    assert not torn.complete and len(torn) == 75 and torn.read_error
    assert torn.ticks.tolist() == list(range(75))


def test_dropped_ticks_are_counted_from_the_tick_numbers(tmp_path):
    base = np.array([10240, -32000, 57905, 0, 0, 32000])
    seqs = [1, 2, 3, 7, 8, 10]
    _write(tmp_path / "d.mcap", [_status(s, base) for s in seqs])
    assert load_recording(tmp_path / "d.mcap").dropped_ticks == 4


def test_fit_recovers_the_planned_duration_and_default_speed(tmp_path):
    a = JointMove([86, -94, 176, 4, 3, 178], duration_s=1.37)
    b = JointMove([92, -88, 179, -3, 2, 182], speed_pct=45, accel_pct=27)
    path, _ = _planned_recording(tmp_path, [a, b])
    rec = load_recording(path)
    segs = command_segments(rec)
    assert [s.planned_ticks for s in segs] == [137, len(plan(b, a.target_deg).positions)]
    fits = [fit_joint_move(rec, s) for s in segs]
    # within 1 step: the fit plans from the recorded steps, the demonstration from exact degrees
    assert fits[0].duration_s == pytest.approx(1.37) and fits[0].error_steps <= 1
    assert fits[1].duration_s is None and fits[1].error_steps <= 1
    # the target is where the motion came to rest, to the step
    assert np.array_equal(np.rint(np.array(fits[0].target_deg) * PAROL6.steps_per_deg), rec.steps[segs[0].end])


def test_fit_without_command_progress_searches_the_duration(tmp_path):
    a = JointMove([86, -94, 176, 4, 3, 178], duration_s=1.2)
    path, _ = _planned_recording(tmp_path, [a])
    rec = load_recording(path)
    seg = rest_segments(rec, 10)[0]
    fit = fit_joint_move(rec, seg)
    assert fit.error_steps <= 1 and fit.duration_s == pytest.approx(1.2, abs=0.02)


def test_compare_aligns_by_first_motion(tmp_path):
    a = JointMove([86, -94, 176, 4, 3, 178], duration_s=1.0)
    p1, _ = _planned_recording(tmp_path, [a], "a.mcap", gap=20)
    p2, _ = _planned_recording(tmp_path, [a], "b.mcap", gap=45)
    r1, r2 = load_recording(p1), load_recording(p2)
    assert first_motion_tick(r2) - first_motion_tick(r1) == 25
    cmp = compare_recordings(r1, r2)
    assert cmp.max_error_steps == 0 and cmp.offset == 25 and cmp.ticks_compared > 100


def test_teach_on_a_planned_demonstration_writes_moves_delays_and_outputs(tmp_path):
    a = JointMove([86, -94, 176, 4, 3, 178], duration_s=1.0)
    b = JointMove([92, -88, 179, -3, 2, 182], duration_s=1.5)
    path, statuses = _planned_recording(tmp_path, [a, b], gap=40)
    rec = load_recording(path)
    res = teach(rec)
    lines = res.text.splitlines()
    assert lines[0] == "Begin()" and lines[-1] == "End()"
    assert res.moves == 2 and res.delays == 1
    delay = [ln for ln in lines if ln.startswith("Delay(")]
    assert len(delay) == 1 and 0.38 <= float(delay[0][6:-1]) <= 0.5  # 40 ticks at rest, give or take the
    # ticks at the ends of the plans that do not move a step
    assert res.deviation_mm < 0.5 and res.deviation_deg < 0.05


def test_host_port_arguments_are_checked():
    assert parse_host_port("10.0.0.2:5001") == ("10.0.0.2", 5001)
    assert parse_host_port("6001") == ("127.0.0.1", 6001)
    with pytest.raises(argparse.ArgumentTypeError, match="port 70000 is outside 1..65535"):
        parse_host_port("h:70000")
    with pytest.raises(argparse.ArgumentTypeError, match="not a number"):
        parse_host_port("h:abc")


def test_export_csv_has_one_row_per_tick(tmp_path):
    a = JointMove([86, -94, 176, 4, 3, 178], duration_s=0.5)
    path, statuses = _planned_recording(tmp_path, [a], gap=5)
    rec = load_recording(path)
    out = tmp_path / "x.csv"
    assert write_csv(rec, out) == len(statuses)
    rows = list(csv.reader(out.open()))
    assert rows[0] == CSV_HEADER and len(rows) == len(statuses) + 1
    assert int(rows[10][CSV_HEADER.index("J1_steps")]) == statuses[9]["steps"][0]


@pytest.mark.parametrize("suffix", [".png", ".html"])
def test_plot_writes_png_or_html(tmp_path, suffix):
    a = JointMove([86, -94, 176, 4, 3, 178], duration_s=0.5)
    path, _ = _planned_recording(tmp_path, [a], gap=5)
    out = plot_recording(load_recording(path), tmp_path / f"p{suffix}")
    data = out.read_bytes()
    assert data.startswith(b"\x89PNG") if suffix == ".png" else b"<svg" in data
