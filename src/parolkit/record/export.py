"""``parolkit export run.mcap --csv``: one row per tick received, for spreadsheets.

Columns: tick, time_s (controller time), state, J1..J6 angles (deg), J1..J6 steps,
J1..J6 speeds (deg/s), TCP x, y, z (mm), A, B, C (deg), IO (in1, in2, out1, out2, estop),
gripper position, the active command, and the loop's period p99 (ms).
"""

from __future__ import annotations

import csv
from pathlib import Path

from parolkit.record.reader import Recording

__all__ = ["write_csv", "CSV_HEADER"]

_J = range(1, 7)
CSV_HEADER = (["tick", "time_s", "state"] + [f"J{j}_deg" for j in _J] + [f"J{j}_steps" for j in _J]
              + [f"J{j}_deg_s" for j in _J] + ["x_mm", "y_mm", "z_mm", "A_deg", "B_deg", "C_deg"]
              + ["in1", "in2", "out1", "out2", "estop", "gripper_position", "command", "period_p99_ms"])


def write_csv(rec: Recording, path: str | Path) -> int:
    """Write ``rec`` as CSV to ``path``; returns the number of data rows."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(CSV_HEADER)
        for i, s in enumerate(rec.statuses):
            io = s.get("io") or {}
            cmd = s.get("command") or {}
            w.writerow([int(rec.ticks[i]), f"{rec.time_s[i]:.4f}", s.get("state", "")]
                       + [f"{v:.4f}" for v in rec.angles_deg[i]] + [int(v) for v in rec.steps[i]]
                       + [f"{v:.4f}" for v in rec.speeds_deg_s[i]] + [f"{v:.4f}" for v in rec.pose[i]]
                       + [io.get(k, "") for k in ("in1", "in2", "out1", "out2", "estop")]
                       + [(s.get("gripper") or {}).get("position", ""), cmd.get("name") or "",
                          (s.get("loop") or {}).get("period_p99_ms", "")])
    return len(rec.statuses)
