"""One record of the board link: the frames written, which reply answered which, and where the
board can be when the next frame arrives.

The guard (is a frame a bounded commitment?), the motion activities (which goal may the next
frame carry?) and the link supervision (how many frames are unanswered?) all read this one
record; nothing else keeps its own account of the link.

Where the board can be: a reply answers one frame (the board sends it as it accepts the frame)
and carries the joints' positions at that moment.  Between frames the board runs the last one
it accepted: a GO TO (156) moves each joint towards the frame's *goal* ``target + v_ff / 100``
(the firmware's law ``v = 0.5 v_ff + 50 (target - x)`` is ``v = 50 (goal - x)``) and never past
it; IDLE, DISABLE, ENABLE and CLEAR_ERROR hold it still; a JOG (123) with a speed runs without
bound; a HOME runs the homing.  So from the newest *trusted* reply (the one the integrity check
took as the truth, answering frame ``k``), if frames ``k .. n-1`` were GO TO or standing-still
frames, each joint is somewhere in the interval spanned by the reply's position and the goals
of those frames (:meth:`LinkHistory.window`).  When every one of them was a GO TO whose goal lies
on the same side and the reply shows the joint already running that way (the board follows
GO TO frames: a disabled board ignores them and reports no speed), the board has also moved
towards the nearest goal for at least the time between reading that reply and writing the next
frame (the reply was sent after frame ``k`` arrived; frame ``n`` arrives after it is written):
that raises the near end of the interval.
This uses nothing the board might do late or early (a frame held back by the operating system,
several delivered at once), only the order of events.

Times (s) are the caller's clock: the monotonic clock on a real link, the board's own time
(ticks x period) on a simulated board in lockstep with the frames, where a reply is produced
at the time its frame is written.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from parolkit._frozen import quick_init
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.robot import FIRMWARE_PASS_MAX_S, GOTO_GAIN_PER_S, goto_goal

__all__ = ["LinkHistory", "Sent", "Anchor"]

_GOTO = int(BoardCommand.GOTO)
_JOG = int(BoardCommand.JOG)
_HOME = int(BoardCommand.HOME)
#: frames remembered (a window longer than this is unknown: the link counts as lost long before)
_SIZE = 128


@quick_init
@dataclass(frozen=True)
class Sent:
    """Frame number ``n`` (from 1 in a session), written at ``t`` (s); ``window``: where each
    joint could be as it arrived, as known when it was written (None: not known)."""

    n: int
    frame: CommandFrame
    t: float
    window: tuple[tuple[float, float], ...] | None = None
    #: a GO TO frame's goals (:func:`~parolkit.robot.goto_goal`), computed once as it is
    #: written (every window from an older reply spans them); None for any other frame
    goals: tuple[float, ...] | None = None


@quick_init
@dataclass(frozen=True)
class Anchor:
    """A trusted reply: the board's ``status`` as it accepted frame ``n``, read at ``t`` (s)."""

    n: int
    status: StatusFrame
    t: float


class LinkHistory:
    """The frames written in this link session, the replies that answered them and the
    newest trusted reply (see the module docstring).  One owner (the tick); no locking."""

    def __init__(self) -> None:
        self._written: deque[Sent] = deque(maxlen=_SIZE)
        self.reset()

    def reset(self) -> None:
        """A new link session: nothing is known of the board."""
        self._written.clear()
        self._n = 0
        #: frames written since the last structurally valid reply arrived
        self.unanswered = 0
        #: frames written whose replies have not arrived yet (which frame the next reply answers:
        #: the board answers in order; see :meth:`answered_range`)
        self._backlog = 0
        #: the oldest frame a reply read from now on can answer (replies come in order, one
        #: per frame the board accepted; some may be lost)
        self._pending_min = 1
        self.anchor: Anchor | None = None
        #: a homing may be running (the board moves on its own): set when HOME is written,
        #: cleared by the owner when the integrity check has seen it end (it judges the homing
        #: from the raw replies: :attr:`parolkit.controller.integrity.StatusIntegrity.homing`)
        self.homing = False
        #: the last :meth:`window` computed and what it was computed from (it is asked for
        #: several times a tick with the same arguments)
        self._window_key: tuple[float, int] | None = None
        self._window_anchor: Anchor | None = None
        self._window_value: tuple[tuple[float, float], ...] | None = None
        #: the last :meth:`goal_box`: the window and reach it was made from, and the box
        self._box_from: tuple[tuple[tuple[float, float], ...], Sequence[float]] | None = None
        self._box_value: tuple[tuple[float, float], ...] = ()

    # ------------------------------------------------------------------ events

    @property
    def frames_written(self) -> int:
        """Number of the newest frame written (they count from 1; 0: none yet)."""
        return self._n

    @property
    def last(self) -> CommandFrame | None:
        """The newest frame written (None before the first of the session)."""
        return self._written[-1].frame if self._written else None

    def sent(self, frame: CommandFrame, t: float) -> int:
        """``frame`` was written at ``t``; returns its number."""
        win = self.window(t)
        self._n += 1
        goals = tuple(goto_goal(frame.positions, frame.speeds)) if int(frame.command) == _GOTO else None
        self._written.append(Sent(self._n, frame, t, win, goals))
        if int(frame.command) == _HOME:
            self.homing = True
        self.unanswered += 1
        self._backlog += 1
        return self._n

    def answered_range(self, count: int, index: int, *, after_write: bool = False) -> tuple[int, int]:
        """The frames that the ``index``-th (from 0) of ``count`` replies read together can
        answer: ``(lo, hi)``, numbers of frames written.

        The board answers every frame it accepts with one reply, in order, as it takes the frame
        in (the stock firmware drains its serial input once a pass: after a stall it answers its
        whole backlog at once, oldest first).  So the replies read answer the oldest frames still
        unanswered, one each: ``lo``, the oldest frame it can answer, counts them.  Replies can be
        lost (bytes dropped on the way back, a frame the board never accepted): then it answers a
        newer frame than counted, at most the newest written less one for each reply read after
        it in this batch, ``hi``.  ``lo`` never runs ahead of the frame answered and ``hi`` never
        behind it.  ``after_write`` (read in the reply wait of the frame just written, else at the
        start of a tick) changes nothing: a reply read right after a frame was written may still
        answer an older one (the board stalled and took its backlog in late; seen: the replies to
        frames 69-71 read in frame 74's reply wait, taken as the answers to 72-74, and the next
        true reply judged against frames it could not have answered)."""
        n = self._n
        hi = n - (count - 1 - index)
        lo = n - self._backlog + 1
        if lo > hi:  # more replies than frames left to answer (none this session could): the newest
            lo = hi
        self._backlog = max(0, n - lo)
        self.unanswered = 0  # any structurally valid reply proves the board answered
        return max(0, min(n, lo)), max(0, min(n, hi))

    def answered(self, count: int, index: int, *, after_write: bool = False) -> int:
        """The oldest frame that the ``index``-th of ``count`` replies read together can answer
        (:meth:`answered_range`'s ``lo``: the one it answers when no reply was lost)."""
        return self.answered_range(count, index, after_write=after_write)[0]

    def earliest(self, status: StatusFrame) -> int:
        """The oldest frame that the reply ``status`` (the next one read) can answer, by the
        order of replies and by where the board was: a reply carries the board's position as
        the frame it answers arrived, which lay in that frame's window.  Which frame a reply
        answers is not known for sure (a reply the operating system held back reads like a
        prompt one; lost replies shift the count): the window of the board from a reply counts
        every goal from the oldest frame it can answer on, so a delayed reply taken for a newer
        frame's can never let a goal run ahead of the board.  Call once per reply read, in order."""
        lo = max(1, min(self._pending_min, self._n))
        for w in self.since(lo) or ():
            win = w.window
            if win is None or all(a - 1.0 <= p <= b + 1.0 for p, (a, b) in zip(status.positions, win)):
                self._pending_min = w.n + 1
                return w.n
        self._pending_min = lo + 1
        return lo

    def trust(self, n: int, status: StatusFrame, t: float) -> None:
        """The integrity check took ``status`` (answering frame ``n`` at the earliest, read at
        ``t``) as the truth: where the board's position is known from."""
        a = self.anchor
        if a is None or n >= a.n:
            self.anchor = Anchor(n, status, t)

    # ------------------------------------------------------------------ where the board can be

    def since(self, n: int) -> list[Sent] | None:
        """The frames written from number ``n`` on, oldest first; None if any of them is no
        longer remembered."""
        w = self._written
        if not w:
            return []
        first = w[0].n
        if first > max(n, 1):
            return None
        # numbers are consecutive: frame n sits at n - first
        return list(itertools.islice(w, max(0, n - first), None))

    def window(self, t_write: float) -> tuple[tuple[float, float], ...] | None:
        """Per joint, the interval (steps) the board's position lies in when a frame written at
        ``t_write`` (s) arrives; None when that is not known (no trusted reply in this session,
        frames since then forgotten, a homing or a speed (JOG) frame since then)."""
        a = self.anchor
        if a is None or self.homing:
            return None
        key = (t_write, self._n)
        if key != self._window_key or a is not self._window_anchor:
            win = self._window(a, t_write)
            self._window_value = None if win is None else tuple(win)
            self._window_key, self._window_anchor = key, a
        return self._window_value

    def _window(self, a: Anchor, t_write: float) -> list[tuple[float, float]] | None:
        frames = self.since(a.n)
        if frames is None:
            return None
        # per joint, the lowest and highest goal of the GO TO frames since the reply
        lows: list[float] | None = None
        highs: list[float] = []
        all_goto = True
        for w in frames:
            gs = w.goals
            if gs is not None:
                if lows is None:
                    lows, highs = list(gs), list(gs)
                else:
                    for j in range(6):
                        g = gs[j]
                        if g < lows[j]:
                            lows[j] = g
                        elif g > highs[j]:
                            highs[j] = g
                continue
            code = int(w.frame.command)
            if code == _HOME or (code == _JOG and any(w.frame.speeds)):
                return None
            all_goto = False  # stood still from that frame on
        status = a.status
        if lows is None:
            return [(float(p), float(p)) for p in status.positions]
        # the time it moved for at least: since the reply was read, less the pass that the
        # newest frame may have waited for (the law runs once a pass, a step at a time)
        moved_s = t_write - a.t - FIRMWARE_PASS_MAX_S
        rise = 1.0 - math.exp(-GOTO_GAIN_PER_S * moved_s) if all_goto and moved_s > 0.0 else 0.0
        out = []
        for j in range(6):
            p = float(status.positions[j])
            g_lo, g_hi = lows[j], highs[j]
            # a joint holding a goal between two whole steps steps back and forth across it
            # (it settles on the fraction only on average): it may stand on either step
            lo, hi = min(p, math.floor(g_lo)), max(p, math.ceil(g_hi))
            if rise > 0.0:
                # every goal ahead and the reply shows the joint running that way (the board
                # follows: a disabled one ignores GO TO and reports no speed): it moved towards
                # them for at least the time since
                v = status.speeds[j]
                if g_lo > p and v > 0:
                    lo = max(p, p + (g_lo - p) * rise - 1.0)  # (one step: a joint steps whole)
                elif g_hi < p and v < 0:
                    hi = min(p, p + (g_hi - p) * rise + 1.0)
            out.append((lo, hi))
        return out

    def goal_box(self, t_write: float, reach: Sequence[float]) -> tuple[tuple[float, float], ...] | None:
        """Per joint, the goals (steps) a GO TO frame written at ``t_write`` may carry so that the
        board starts it within its maximum speed wherever it is in :meth:`window`: within
        ``reach[j]`` (the maximum speed / 50, i.e. 20 ms of travel at it) of both ends.  An
        empty interval (low > high) means no goal is safe on that joint (cannot happen for a
        stream of frames that each passed this box: see the docs).  None: unknown."""
        win = self.window(t_write)
        if win is None:
            return None
        made = self._box_from
        if made is None or made[0] is not win or made[1] is not reach:
            self._box_value = tuple((hi - r, lo + r) for (lo, hi), r in zip(win, reach))
            self._box_from = (win, reach)
        return self._box_value
