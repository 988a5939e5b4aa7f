"""``parolkit plot run.mcap``: joints (deg), speeds (deg/s), the TCP path (3-D, mm) and loop
timing (period p99/max, ms; dropped ticks marked) in one figure: a PNG (or any format
matplotlib writes) or a self-contained HTML page embedding it as SVG."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from parolkit.errors import ParolkitValueError
from parolkit.record.reader import Recording

__all__ = ["plot_recording", "check_plot_file"]


def _figure(rec: Recording) -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = (rec.ticks - rec.ticks[0]) / rec.rate_hz
    fig = plt.figure(figsize=(13, 9))
    ax1 = fig.add_subplot(2, 2, 1)
    for j in range(6):
        ax1.plot(t, rec.angles_deg[:, j], label=f"J{j + 1}")
    ax1.set(title="joint angles", xlabel="t (s, from ticks)", ylabel="deg")
    ax1.legend(fontsize="small")
    ax2 = fig.add_subplot(2, 2, 2)
    for j in range(6):
        ax2.plot(t, rec.speeds_deg_s[:, j], label=f"J{j + 1}")
    ax2.set(title="joint speeds", xlabel="t (s)", ylabel="deg/s")
    ax3 = fig.add_subplot(2, 2, 3, projection="3d")
    ax3.plot(rec.pose[:, 0], rec.pose[:, 1], rec.pose[:, 2])
    ax3.set(title="TCP path (mm)", xlabel="x", ylabel="y", zlabel="z")
    ax4 = fig.add_subplot(2, 2, 4)
    p99 = [float((s.get("loop") or {}).get("period_p99_ms", np.nan)) for s in rec.statuses]
    pmax = [float((s.get("loop") or {}).get("period_max_ms", np.nan)) for s in rec.statuses]
    late = [float((s.get("loop") or {}).get("late_p99_ms", np.nan)) for s in rec.statuses]
    ax4.plot(t, p99, label="period p99")
    ax4.plot(t, pmax, label="period max")
    ax4.plot(t, late, label="late p99")
    gaps = np.nonzero(np.diff(rec.ticks) > 1)[0]
    for g in gaps:
        ax4.axvline(t[g], color="red", alpha=0.3)
    ax4.set(title=f"loop timing ({rec.dropped_ticks} dropped ticks, red)", xlabel="t (s)", ylabel="ms")
    ax4.legend(fontsize="small")
    fig.suptitle(f"{rec.path.name}: {len(rec)} ticks at {rec.rate_hz:g} Hz")
    fig.tight_layout()
    return fig


_HTML = (".html", ".htm")


def check_plot_file(out: str | Path) -> None:
    """ParolkitValueError unless ``out`` names a format :func:`plot_recording` writes (checked
    before the recording is read)."""
    from matplotlib.backend_bases import FigureCanvasBase

    suffix = Path(out).suffix.lower()
    formats = FigureCanvasBase.get_supported_filetypes()
    if suffix and suffix not in _HTML and suffix[1:] not in formats:
        raise ParolkitValueError(f"{out}: cannot write a plot as {suffix!r}: use .html or one of "
                                 + ", ".join(f".{k}" for k in sorted(formats)))


def plot_recording(rec: Recording, out: str | Path) -> Path:
    """Write the figure to ``out`` (``.html``: an HTML page with the SVG inline)."""
    import matplotlib.pyplot as plt

    check_plot_file(out)
    out = Path(out)
    fig = _figure(rec)
    try:
        if out.suffix.lower() in _HTML:
            buf = io.StringIO()
            fig.savefig(buf, format="svg")
            out.write_text(f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{rec.path.name}</title>"
                           f"</head><body>{buf.getvalue()}</body></html>", encoding="utf-8")
        else:
            fig.savefig(out, dpi=90)
    finally:
        plt.close(fig)
    return out
