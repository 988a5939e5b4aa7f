"""Position and speed curves per joint, like the seed's figures (matplotlib, imported here)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from parolkit.motion.trajectory import Trajectory
from parolkit.robot import JOINT_NAMES

__all__ = ["plot_trajectory"]


def plot_trajectory(
    traj_or_list: Trajectory | Sequence[Trajectory],
    path_png: str | Path,
    *,
    title: str | None = None,
    dpi: int = 100,
) -> Path:
    """Write a PNG with two panels: joint positions (deg) and joint speeds (deg/s) over time
    (s), one colour per joint.  Several trajectories are drawn one after the other (their
    times chained).  Returns the path written."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    trajs = [traj_or_list] if isinstance(traj_or_list, Trajectory) else list(traj_or_list)
    if not trajs:
        raise ValueError("plot_trajectory needs at least one trajectory")
    fig, (ax_p, ax_v) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    offset = 0.0
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for n, tr in enumerate(trajs):
        t = np.concatenate([[0.0], tr.t]) + offset
        q = np.vstack([tr.start_deg[None, :], tr.positions_deg()])
        v = np.vstack([np.zeros((1, 6)), tr.speeds_deg_s()])
        for j in range(6):
            label = JOINT_NAMES[j] if n == 0 else None
            ax_p.plot(t, q[:, j], color=colours[j % len(colours)], label=label)
            ax_v.step(t, v[:, j], where="post", color=colours[j % len(colours)], label=label)
        if n:
            ax_p.axvline(offset, color="0.7", lw=0.8)
            ax_v.axvline(offset, color="0.7", lw=0.8)
        offset += tr.duration
    ax_p.set_ylabel("position (deg)")
    ax_v.set_ylabel("speed (deg/s)")
    ax_v.set_xlabel("time (s)")
    ax_p.legend(loc="upper right", ncol=6, fontsize="small")
    ax_p.grid(True, alpha=0.3)
    ax_v.grid(True, alpha=0.3)
    names = ", ".join(dict.fromkeys(tr.name for tr in trajs))
    cmds = "/".join(str(c) for c in sorted({int(c) for tr in trajs for c in tr.commands[-1:]}))
    fig.suptitle(title or f"{names} ({offset:.2f} s, board command {cmds})")
    fig.tight_layout()
    out = Path(path_png)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
