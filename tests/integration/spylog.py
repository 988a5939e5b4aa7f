"""The controller's own record of its board link, read back: a ``spy+`` log with ``raw=1``.

A test that judges how soon the controller reacts to a status frame counts frames on the PC
side: the frames *written* after the status was *read*, in the order the controller did both.
Counted at the board instead, a pty adds its own lag: the kernel hands a pty's bytes over in a
worker thread that two CPU hogs held back up to a second, so frames the controller wrote before
it read the status arrived at the board after the board sent it, and were counted against the
controller.  The board's own record still says whether a frame arrived at all.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from parolkit.protocol.frames import CommandFrame, StatusFrame

__all__ = ["Crossing", "spy_port", "read_spy_log", "written_after_read"]


def spy_port(link: Path | str, log: Path) -> str:
    """The ``--port`` URL that logs every frame crossing ``link`` to ``log`` (bytes included)."""
    return f"spy+{link}?log={log}&raw=1"


@dataclass(frozen=True)
class Crossing:
    """One frame that crossed the link: when (monotonic s: ``write`` called, ``read``
    returned), which way and what."""

    t: float
    to_board: bool
    frame: CommandFrame | StatusFrame


def read_spy_log(path: Path) -> list[Crossing]:
    """Every frame of a ``spy+`` log written with ``raw=1``, in order."""
    out = []
    for line in path.read_text(errors="replace").splitlines():
        parts = line.split(" ")
        raw = next((p[4:] for p in parts if p.startswith("raw=")), None)
        if raw is None or len(parts) < 4 or parts[2] not in ("PC>BOARD", "BOARD>PC"):
            continue
        to_board = parts[2] == "PC>BOARD"
        data = bytes.fromhex(raw)
        out.append(Crossing(float(parts[1]), to_board, CommandFrame.decode(data) if to_board
                            else StatusFrame.decode(data)))
    return out


def written_after_read(crossings: list[Crossing], showing: Callable[[StatusFrame], bool]) -> list[CommandFrame]:
    """The frames written after the controller read the first status frame for which
    ``showing`` is true, in order; the test fails if no status showed it."""
    for i, c in enumerate(crossings):
        if not c.to_board and showing(c.frame):  # type: ignore[arg-type]
            return [x.frame for x in crossings[i + 1:] if x.to_board]  # type: ignore[misc]
    raise AssertionError("no status frame the controller read showed it")
