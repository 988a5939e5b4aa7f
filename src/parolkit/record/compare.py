"""Compare two recordings tick by tick, aligned by their first motion (the round-trip check)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from parolkit.record.reader import Recording

__all__ = ["Comparison", "first_motion_tick", "compare_recordings"]


def first_motion_tick(rec: Recording) -> int:
    """The first tick at which a joint position differs from the one before (ValueError if none)."""
    mv = np.nonzero(np.any(rec.steps[1:] != rec.steps[:-1], axis=1))[0]
    if len(mv) == 0:
        raise ValueError(f"{rec.path}: the robot never moves")
    return int(rec.ticks[mv[0] + 1])


@dataclass(frozen=True)
class Comparison:
    """``ticks_compared``: ticks present in both (aligned); ``max_error_steps`` over them and the
    joint / tick (of ``a``) where it occurs; ``span``: aligned ticks from first motion to the
    end of the shorter recording."""

    ticks_compared: int
    span: int
    max_error_steps: int
    worst_joint: int
    worst_tick: int
    offset: int

    def text(self) -> str:
        return (f"{self.ticks_compared} of {self.span} aligned ticks compared: largest difference "
                f"{self.max_error_steps} steps (J{self.worst_joint + 1} at tick {self.worst_tick})")


def compare_recordings(a: Recording, b: Recording, *, moving_only_until_rest: bool = False) -> Comparison:
    """Joint steps of ``a`` and ``b`` at every tick both hold, ``b`` shifted so both first
    motions fall on the same tick, from that first motion to the end of the shorter one."""
    ta, tb = first_motion_tick(a), first_motion_tick(b)
    offset = tb - ta
    end = min(int(a.ticks[-1]), int(b.ticks[-1]) - offset)
    bi = {int(t) - offset: i for i, t in enumerate(b.ticks)}
    worst = (0, 0, ta)
    n = 0
    for i, t in enumerate(a.ticks):
        t = int(t)
        if t < ta - 1 or t > end:
            continue
        j = bi.get(t)
        if j is None:
            continue
        d = np.abs(a.steps[i] - b.steps[j])
        n += 1
        k = int(np.argmax(d))
        if int(d[k]) > worst[0]:
            worst = (int(d[k]), k, t)
    return Comparison(n, end - ta + 2, worst[0], worst[1], worst[2], offset)

