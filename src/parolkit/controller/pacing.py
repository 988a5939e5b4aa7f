"""Playing planned motion against real time: where the board is now, and how far a frame may go.

The board runs each frame's command until the next frame arrives (board-firmware.md), so what
a frame does depends on how long it actually runs, not on the nominal period.  A tick that
comes late must therefore not push the rest of a move back: the activities play "the sample
for the time it actually runs" (docs/controller.md, *Timing*), with these small pure pieces
(plain floats, no allocation beyond a few short lists: they run in the tick):

* :func:`board_position` -- where one frame takes a joint after ``dt`` s: 123 JOG runs at its
  speed, 156 GO TO is the firmware's P loop ``v = 0.5 * v_ff + 50 * (target - position)``;
* :class:`SentLog` -- the last frames an activity sent and when, to estimate the board's
  position *now* from the newest status frame (which shows the board when it accepted the
  frame it answers);
* :func:`goto_fits` -- the catch-up bound of position tracking: may a 156 frame follow the
  previous one after ``dt`` s without asking the board for more than its maximum speed;
* :func:`tracking_speed` -- the 123 speed that takes a joint from where it is estimated to be
  to where the plan has it at the next deadline, within a speed bound.

:func:`goto_fits` states the same two rules the safety guard applies to every 156 frame (a
target steps at most ``max speed x real time since the previous frame``; the board's speed
right after it, ``|0.5 * v_ff + 50 * (target - position)|``, stays within the maximum); a
caller may pass the guard's own predicate instead (``fits=``) so the two never disagree.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from parolkit.controller.guard import goto_position_after, goto_start_speed
from parolkit.protocol.frames import BoardCommand, StatusFrame
from parolkit.robot import GOTO_GAIN_PER_S

__all__ = ["GOTO_GAIN_PER_S", "board_position", "SentLog", "goto_fits", "tracking_speed", "GotoFits"]

_JOG = int(BoardCommand.JOG)
_GOTO = int(BoardCommand.GOTO)


def board_position(x: float, command: int, target: float, speed: float, dt: float) -> float:
    """Where one joint is ``dt`` s after the board accepted a frame, from position ``x``
    (steps): 123 moves at ``speed`` steps/s; 156 follows the P loop towards
    ``target + speed / 100`` (where a stopped stream settles) with time constant 20 ms; any
    other command holds still.  (The firmware's +-50,000 steps/s clamp is not modelled: no
    frame the guard lets through comes near it.)"""
    if dt <= 0.0:
        return x
    if command == _JOG:
        return x + speed * dt
    if command == _GOTO:
        return goto_position_after(x, target, speed, dt)  # the guard's model of the board
    return x


class SentLog:
    """The last ``size`` frames one activity asked for, with the time it asked (the tick's
    ``now``; the loop writes the frame right after), for :meth:`estimate`.

    Which frame a status frame answers: the board answers every frame at once, and the loop
    reads the reply within the same tick or at the start of the next one, so a status frame
    that is new at a step answers the newest frame sent before it; while no new one comes
    (replies lost or rejected), the last one keeps answering the frame it answered, and the
    frames sent since are run forward on the board model.  (On a link whose replies take
    longer than a tick this is off by the frames in flight: the estimate is then one or two
    ticks of travel behind, and the next replies correct it.)
    """

    __slots__ = ("size", "_t", "_cmd", "_pos", "_spd", "_n", "_status", "_answered")

    def __init__(self, size: int = 4) -> None:
        self.size = size
        self._t = [0.0] * size
        self._cmd = [0] * size
        self._pos: list[Sequence[int]] = [()] * size
        self._spd: list[Sequence[int]] = [()] * size
        #: frames recorded so far
        self._n = 0
        self._status: StatusFrame | None = None
        #: index of the frame the newest status answers (-1: one sent before this log's first)
        self._answered = -1

    @property
    def sent(self) -> int:
        """Frames recorded so far."""
        return self._n

    def last_time(self) -> float | None:
        """When the newest frame was asked for (None before the first)."""
        return self._t[(self._n - 1) % self.size] if self._n else None

    def record(self, t: float, command: int, positions: Sequence[int], speeds: Sequence[int]) -> None:
        """The frame asked for at time ``t`` (s)."""
        i = self._n % self.size
        self._t[i], self._cmd[i], self._pos[i], self._spd[i] = t, int(command), positions, speeds
        self._n += 1

    def estimate(self, status: StatusFrame | None, now: float) -> list[float] | None:
        """Every joint's position (steps) at ``now`` by the board model, from the newest status
        frame and the frames sent since the one it answers; None without a status frame."""
        if status is None:
            return None
        if status is not self._status:
            self._status = status
            self._answered = self._n - 1
        x = [float(p) for p in status.positions]
        first = max(self._answered, 0, self._n - self.size)
        for k in range(first, self._n):
            i = k % self.size
            t_end = self._t[(k + 1) % self.size] if k + 1 < self._n else now
            dt = t_end - self._t[i]
            cmd, pos, spd = self._cmd[i], self._pos[i], self._spd[i]
            if cmd == _JOG:
                for j in range(6):
                    x[j] += spd[j] * dt
            elif cmd == _GOTO:
                for j in range(6):
                    x[j] = board_position(x[j], cmd, pos[j], spd[j], dt)
        return x


#: ``fits(target, ff, prev_target, dt, position, vmax) -> bool``: the catch-up bound
GotoFits = Callable[[Sequence[int], Sequence[int], Sequence[int], float, Sequence[float], Sequence[float]], bool]


def goto_fits(target: Sequence[int], ff: Sequence[int], prev_target: Sequence[int], dt: float,
              position: Sequence[float], vmax: Sequence[float]) -> bool:
    """True when a 156 frame (``target`` steps, feed-forward ``ff`` steps/s) may follow the
    previous 156 target ``prev_target`` sent ``dt`` s ago, the joints being at ``position``
    (estimated, steps): no target steps further than ``vmax x dt`` (+1 step of rounding) and the
    board's speed right after it, ``|0.5 * ff + 50 * (target - position)|``, stays within
    ``vmax`` (steps/s), for every joint."""
    for j in range(6):
        if abs(target[j] - prev_target[j]) > vmax[j] * dt + 1.0:
            return False
        if abs(goto_start_speed(target[j], ff[j], position[j])) > vmax[j]:
            return False
    return True


def tracking_speed(planned: float, position: float, interval: float, lo: float, hi: float) -> int:
    """The whole steps/s that take a joint from ``position`` to ``planned`` (steps) in
    ``interval`` s, kept within ``lo .. hi`` steps/s (``lo <= 0 <= hi``; the bound is part of
    the design -- a joint that fell behind catches up over several ticks -- not a correction
    of anyone's input)."""
    v = (planned - position) / interval
    if v > hi:
        return int(math.floor(hi))
    if v < lo:
        return int(math.ceil(lo))
    return int(round(v))
