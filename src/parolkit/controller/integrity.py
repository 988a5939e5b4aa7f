"""Integrity of the board link: which status frames are the truth, and what the board did that
nobody commanded.

The link has no checksum: a byte changed on the wire passes every framing check.  Corruption
in the replies must never reach the snapshot as the robot's position, and corruption in the
commands (the board executes what it received) must not go unnoticed when it moves the robot.

Two checks, on every pair of status frames that are *adjacent* (the board answered nothing in
between: the parser dropped no bytes between them):

* **Link** (the board against itself): the second frame follows from the first under the
  command the board itself says it ran between them (``xtr`` of the first frame echoes it;
  an echo that is none of the commands just written counts as the newest one written), the
  second frame's own reported speeds and the board's own ``timing`` field:

  - IDLE / ENABLE / DISABLE / CLEAR_ERROR / unknown codes: no step at all, speeds 0;
  - JOG (123): ``p1 = p0 + v1 * dt`` to within a step (exactly, for a speed of 0);
  - GO TO (156): the firmware's P loop ``v = K * (p_ss - p)`` (``p_ss = target + v_ff x
    GOTO_FF_GAIN / K``, ``K`` = ``GOTO_GAIN_PER_S``: 50/s, 1/100 s; the law's constants are
    robot.py's): ``p1 - p_ss = (p0 - p_ss) * exp(-K dt)`` with ``p_ss`` read from ``p1`` and ``v1``;
  - HOMING (a HOME written, then any idle frame while it runs): each joint moves at most its
    fastest homing speed (times the board's homing speed-up), or its counter is zeroed at the
    switch or set to the standby count at the end; the homed bits only rise.

* **Commanded** (the board against the controller): the second frame's positions are compared
  with what the frames the controller wrote produce from the first frame's: every frame the
  first one can answer (the board answers every frame it takes in, in order, so a reply answers
  the oldest frame still unanswered, a newer one only when replies were lost: a reply read
  right after a frame was written may still answer an older one, the board having taken its
  backlog in late), and a few before it.  A frame that links AND matches within the board's own
  precision is the truth (:meth:`StatusIntegrity.accept` returns True); anything else is
  *implausible*: counted, never the truth (the snapshot keeps the last true frame).  The first
  frame of a link session is neither: nothing is there to judge it against (a perfect link
  counts 0); the next frame is checked from it, and the truth starts where two frames agree.  A
  corrupted position byte breaks one check or the other unless it changes a *moving* joint by
  no more than the stepper's own sub-step jitter (a step, two at speed; a joint at rest is
  exact: see :class:`Tolerances`).  Two adjacent frames that link re-establish the truth after a
  gap (checked against the hull of everything the frames written since could reach).

* **Uncommanded motion**: a frame that links to a true one but lies beyond what was commanded
  (wider than the precision above, by what a reply byte that slipped through the link could
  hide) is a suspect: a joint moving while idle, racing to a corrupted target or speed,
  standing still on a disabled board.  It is acted on when a second frame confirms it: the
  next frame links to it, or one of the next two shows the same joints beyond the hull of
  everything commanded (a reply lost in between delays it by a tick).  A frame after lost
  ones that lies beyond that hull and that the next frame links to counts the same.

* **Homing nobody asked for** is judged on two adjacent frames whatever their positions (a
  simulated board's homing may be faster than the controller was told): ``xtr`` = 100 without
  a HOME written, then homed bits falling or a speed while every frame written was idle; the
  same fallen homed byte in two frames in a row; or the homing's own constant speeds in two
  frames in a row while every frame written was idle.

Each uncommanded motion is reported once (:meth:`StatusIntegrity.take_fault`): the controller
core disables the robot with it.

:class:`BoardProbe` finds out at link-up whether the board is enabled (the status frame has no
such bit): a JOG of +1 step/s on one joint, then a zero JOG: an enabled board reports the speed
it set (1) in the reply to the second frame, a disabled one ignores 123 and reports 0.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import Enum
from typing import Any

from parolkit._frozen import quick_init
from parolkit.protocol.frames import TIMER_HZ, BoardCommand, CommandFrame, StatusFrame
from parolkit.robot import FIRMWARE_SPEED_CLAMP_STEPS_S as BOARD_SPEED_CLAMP
from parolkit.robot import GOTO_FF_GAIN, GOTO_GAIN_PER_S, JOINT_NAMES, RobotModel

__all__ = ["StatusIntegrity", "BoardProbe", "Tolerances", "IntegrityView", "LinkMode",
           "HOMING_SEARCH_STEPS_S"]

log = logging.getLogger("parolkit.controller")

#: codes that stop a running homing (any other code lets it continue)
_ABORT = frozenset({int(BoardCommand.ENABLE), int(BoardCommand.DISABLE), int(BoardCommand.CLEAR_ERROR),
                    int(BoardCommand.JOG), int(BoardCommand.GOTO)})
_HOME = int(BoardCommand.HOME)
_JOG = int(BoardCommand.JOG)
_GOTO = int(BoardCommand.GOTO)
_IDLE = int(BoardCommand.IDLE)
#: the homing sequence's search speeds (board-firmware.md), steps/s: the fastest homing
#: speeds besides the joints' maximum speeds (its accelerated moves)
HOMING_SEARCH_STEPS_S = (2050, 2550, 2550, 5550, 5050, 9550)
#: the constant speeds of the homing's segments (searches, back-offs, approaches), steps/s
_HOMING_SEGMENT_SPEEDS = frozenset({750, 2050, 2550, 4050, 5050, 5550, 8050, 9550})
#: a link between two frames further apart than this many periods forgives a few steps (the
#: GO TO law closes most of any gap): what it alone shows beyond the commanded hull waits for
#: a third frame
LONG_LINK_PERIODS = 2.5
#: the ``timing`` field wraps after 65536 board timer ticks (93.2 ms)
_TIMING_WRAP_S = 65536 / TIMER_HZ
#: the GO TO law (robot.py): ``v = K (goal - x)`` with ``goal = target + v_ff x FF_LEAD``
#: (:func:`~parolkit.robot.goto_goal`), so a speed ``v`` means the goal lies ``v / K`` ahead
_K = GOTO_GAIN_PER_S
_FF_LEAD_S = GOTO_FF_GAIN / GOTO_GAIN_PER_S
_ZERO6 = (0, 0, 0, 0, 0, 0)


class LinkMode(str, Enum):
    """What the board did between two status frames (from the first frame's ``xtr``)."""

    NONE = "no motion"
    JOG = "JOG"
    GOTO = "GO TO"
    HOMING = "homing"


@dataclass(frozen=True)
class Tolerances:
    """How far the board may differ from the models above, in steps.

    * ``steps``: the sub-step phase of a stepper (the counter moves in whole steps) plus the
      integer truncation of the firmware's speeds;
    * ``timing_s``: how much the moment the board copies its counters may differ from the
      moment it takes the frame in (a firmware loop pass);
    * ``pass_s``: the longest firmware loop pass: the last pass's step is made after the speed
      the board reports was computed (the emulator runs 0.5 ms passes, the real board many
      passes per ms);
    * ``model``: relative error of the exponential GO TO model against the board's loop passes;
    * ``margin``: the commanded check allows this much more than the link check, so that a
      reply byte that slipped through the link can never look like uncommanded motion;
    * ``gap``: the slack of the coarse check across lost frames (the hull of everything the
      frames written since the last true frame could reach).
    """

    steps: float = 1.0
    timing_s: float = 5e-5
    pass_s: float = 5e-4
    model: float = 0.01
    margin: float = 2.0
    gap: float = 16.0


@quick_init
@dataclass(frozen=True)
class IntegrityView:
    """Counters for GET_STATUS / GET_STATUS_JSON.

    ``implausible``: status frames judged and never taken as the truth (the first frame of a
    link session is not judged: nothing is there to judge it against); ``uncommanded``:
    motions nobody commanded (each one disabled the robot); ``status_age_s``: how old the
    snapshot's status frame is; ``last``: the message of the newest uncommanded motion (or
    None)."""

    implausible: int = 0
    uncommanded: int = 0
    status_age_s: float = 0.0
    last: str | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"implausible": self.implausible, "uncommanded": self.uncommanded,
                "status_age_ms": round(self.status_age_s * 1e3, 1), "last": self.last}


@dataclass(frozen=True, slots=True)
class _Deviation:
    message: str
    #: the joints (0..5) it concerns
    joints: tuple[int, ...]
    #: where the frames written put every joint (steps), when one frame says (the commanded
    #: check); None: only a range is known (the hull)
    expected: tuple[float, ...] | None = None


@dataclass(slots=True)
class _Reply:
    """One status frame as received: when it was read, the parser's dropped-byte count just
    after it, and what the checks made of it."""

    f: StatusFrame
    t: float
    dropped: int
    ok: bool
    #: the oldest frame it can answer (the board answers in order: the oldest one still
    #: unanswered when no reply was lost), or, without that count, the frames written before it
    #: was read (it answers one of the newest of them)
    n: int = 0
    truth: bool = False
    #: the newest frame it can answer: ``n``, or more when replies may have been lost (a lost
    #: reply shifts the count: the next reply answers a newer frame than the one it is counted
    #: for); at most the newest frame written less one for each reply read after it
    hi: int = 0


def _goto(p0: float, pss: float, dt: float, decay: float | None = None) -> float:
    """Where the firmware's P loop ``v = K * (pss - p)`` (``K`` = :data:`~parolkit.robot.
    GOTO_GAIN_PER_S`, clamped to the firmware's speed clamp) takes a joint from ``p0`` in ``dt``
    s (continuous approximation of its loop passes).  ``decay``: ``exp(-K dt)`` when the caller
    has it."""
    e0 = p0 - pss
    lin = abs(e0) - BOARD_SPEED_CLAMP / _K
    if lin <= 0.0 and decay is not None:
        return pss + e0 * decay
    if lin > 0.0:
        tl = lin / BOARD_SPEED_CLAMP
        if dt <= tl:
            return p0 - math.copysign(BOARD_SPEED_CLAMP * dt, e0)
        dt -= tl
        e0 = math.copysign(BOARD_SPEED_CLAMP / _K, e0)
    return pss + e0 * math.exp(-_K * dt)


class BoardProbe:
    """Is the board enabled?  Asked once per link session, before anything else is sent.

    The executor sends :meth:`frame` each tick while :attr:`active`: IDLE (stops whatever a
    previous controller left running), JOG with +-1 step/s on J1, JOG with zero speeds, then
    IDLE while waiting.  The status frame answering the zero JOG carries the speed the board
    set for the first JOG: 1 on an enabled board, 0 on a disabled one (it ignores 123).

    :meth:`observe` sees every status frame.  The answer is *enabled* as soon as any frame
    read after the +-1 JOG was written reports exactly that speed on J1 and 0 elsewhere (a
    disabled board cannot); *disabled* when the two adjacent replies to the two JOG frames
    (``xtr`` 123 twice, read after each was written) end with all speeds 0 and the second
    came at least 1 ms after the first (so the board ran a loop pass in between).  Anything
    else (a lost or damaged reply) repeats the probe, at most ``attempts`` times; then the
    board is taken as disabled (the user must send ENABLE: the safe side).
    """

    def __init__(self, *, attempts: int = 8, wait_ticks: int = 8) -> None:
        # a loaded PC's tty layer delivers replies tens of ms late and in bursts: a lost or
        # unclear answer is asked again (up to ~0.7 s at 100 Hz) before the safe side is taken
        self.attempts = attempts
        self.wait_ticks = wait_ticks
        self.active = False
        #: True enabled, False disabled (see :attr:`reason`), None: not known yet
        self.result: bool | None = None
        self.reason = ""
        self._attempt = 0
        self._i = 0
        self._wait = 0
        self._sign = 1
        #: when each of the probe's three frames was written: (monotonic s, its number or None)
        self._written: list[tuple[float, int | None] | None] = [None, None, None]
        #: the previous frame read: (it, when, its xtr, read after the +-1 JOG was written)
        self._prev: tuple[StatusFrame, float, int, bool] | None = None
        #: a JOG frame other than the probe's two was written after its +-1 JOG in this attempt
        #: (see :meth:`sent`)
        self._jog_after = False

    def start(self) -> None:
        """(Re)start from the first frame (a new link session)."""
        self.active = True
        self.result = None
        self.reason = ""
        self._attempt = 1
        self._restart()

    def cancel(self) -> None:
        """The answer no longer matters (ENABLE, DISABLE or an E-stop decides it); an answer
        already given but not yet taken in by the executor is dropped too (else an ENABLE
        applied in between was undone by a "found disabled" a tick later)."""
        self.active = False
        self.result = None

    def _restart(self) -> None:
        self._i = 0
        self._jog_after = False
        self._wait = 0
        self._written = [None, None, None]
        self._prev = None

    def _sequence(self, k: int) -> tuple[int, tuple[int, ...]]:
        if k == 1:
            return _JOG, (self._sign, 0, 0, 0, 0, 0)
        if k == 2:
            return _JOG, _ZERO6
        return _IDLE, _ZERO6

    def frame(self, status: StatusFrame | None, limits: Sequence[tuple[int, int]]) -> tuple[int, tuple[int, ...]]:
        """(command, speeds) of the probe frame for this tick."""
        if self._i == 1 and status is not None:
            lo, hi = limits[0]
            self._sign = 1 if status.positions[0] < (lo + hi) / 2 else -1
        if self._i < 3:
            out = self._sequence(self._i)
            self._i += 1
            return out
        self._wait += 1
        if self._wait > self.wait_ticks:
            if self._attempt >= self.attempts:
                self._finish(False, "the board did not answer the start-up probe clearly: it is taken as "
                                    "disabled: send ENABLE")
            else:
                self._attempt += 1
                log.info("board probe: no clear answer, asking again (attempt %d)", self._attempt)
                self._restart()
                return self.frame(status, limits)
        return _IDLE, _ZERO6

    def sent(self, frame: CommandFrame, t: float, n: int | None = None) -> None:
        """A frame was written at ``t`` (monotonic s); ``n``: its number (frames written in the
        session), which orders it against the frames read when their times are equal (a board
        on a virtual clock: the frame written and its reply read in the same instant)."""
        if not self.active or self._i == 0:
            return
        k = self._i - 1
        if k <= 2 and self._written[k] is None:
            code, speeds = self._sequence(k)
            if int(frame.command) == code and tuple(frame.speeds) == speeds:
                self._written[k] = (t, n)
            else:  # the guard replaced it (E-stop, ...): this attempt says nothing
                self._i = 3
                self._wait = self.wait_ticks
        elif self._written[1] is not None and int(frame.command) == _JOG:
            # a JOG besides the probe's own two, after its +-1 JOG (the loop's zero-speed stop
            # frames while replies were late, between the two or after them): two replies to
            # such frames look exactly like "disabled" (123 echoed twice, speeds 0; a stop the
            # board took in the same instant as the +-1 JOG leaves no reply showing 1 step/s),
            # so this attempt can no longer say "disabled"
            self._jog_after = True

    @staticmethod
    def _after(written: tuple[float, int | None] | None, t: float, n: int | None) -> bool:
        """Whether a frame read at ``t`` after ``n`` frames were written was read after the
        frame ``written`` (by number when both are known, else by time)."""
        if written is None:
            return False
        wt, wn = written
        return n >= wn if n is not None and wn is not None else t > wt

    def observe(self, f: StatusFrame, t: float, adjacent: bool, n: int | None = None) -> None:
        """A status frame read at ``t``; ``adjacent``: nothing was lost since the previous one;
        ``n``: the number of frames written before it was read (see :meth:`sent`)."""
        if not self.active or self.result is not None:
            return
        tb, tc = self._written[1], self._written[2]
        after_b = self._after(tb, t, n)
        prev, self._prev = self._prev, (f, t, f.xtr, after_b)
        if after_b and tuple(f.speeds) == (self._sign, 0, 0, 0, 0, 0):
            self._finish(True, "")
            return
        if (tc is not None and tb is not None and prev is not None and adjacent and f.xtr == _JOG
                and not self._jog_after
                and prev[2] == _JOG and prev[3] and self._after(tc, t, n) and not any(f.speeds)
                and f.timing >= TIMER_HZ // 1000):
            log.info("board probe: replies echoing 123 twice at rest (%.1f ms and %.1f ms after the "
                     "+-1 JOG was written; board interval %d ticks): disabled", (prev[1] - tb[0]) * 1e3,
                     (t - tb[0]) * 1e3, f.timing)
            self._finish(False, "the board was found disabled: send ENABLE")

    def _finish(self, enabled: bool, reason: str) -> None:
        self.result = enabled
        self.reason = reason
        self.active = False
        log.info("board probe: the board is %s", "enabled" if enabled else "disabled")


class StatusIntegrity:
    """Decides which status frames are the truth and reports motion nobody commanded.

    One owner (the controller core), which calls :meth:`sent` for every frame written and
    :meth:`accept` for every status frame read (with the parser's dropped-byte count),
    :meth:`reset` when a new link session starts, and takes each uncommanded motion found with
    :meth:`take_fault`.

    ``homing_speedup``: how much faster than real time the board homes (1 for a real board; a
    simulated one may be faster: its frames during a homing then fail the link and are not
    shown, and the homing is still seen by its homed bits and speeds).
    """

    def __init__(self, model: RobotModel, rate_hz: float, *, homing_speedup: float = 1.0,
                 probe: BoardProbe | None = None,
                 tolerances: Tolerances | None = None, candidates: int = 3) -> None:
        self.model = model
        self.period = 1.0 / rate_hz
        self.homing_speedup = homing_speedup
        self._pending_fault: str | None = None
        self.probe = probe
        self.tol = tolerances or Tolerances()
        self.candidates = candidates
        self._standby = tuple(int(v) for v in model.standby_steps)
        self._vhome = tuple(max(float(v), float(s), 8050.0) for v, s in zip(model.max_speed_steps_s,
                                                                             HOMING_SEARCH_STEPS_S))
        self.implausible = 0
        self.uncommanded = 0
        self.last_fault: str | None = None
        #: the newest frames written: (number, monotonic s, frame); numbers count from 1
        self._sent: deque[tuple[int, float, CommandFrame]] = deque(maxlen=64)
        #: :meth:`_candidates` by ``n`` since the last frame written (asked several times a reply)
        self._cands: dict[tuple[int, int], tuple[CommandFrame, ...]] = {}
        self._n = 0
        self.reset()

    # ------------------------------------------------------------------ session

    def reset(self) -> None:
        """A new link session: nothing is known about the board's state."""
        self._prev: _Reply | None = None
        #: where the next frames are checked from: the newest true frame, or one that
        #: confirmed motion nobody commanded (see _provisional)
        self._ref: _Reply | None = None
        #: the newest true frame (the one the snapshot shows)
        self._shown: _Reply | None = None
        #: a frame that follows from a true one but shows motion nobody commanded, waiting for
        #: a second frame to confirm it: (that frame, what it shows, frames left to confirm)
        self._suspect: tuple[_Reply, _Deviation, int] | None = None
        self._sent.clear()
        self._cands.clear()
        #: the parser's dropped-byte count at the previous reply, and whether replies may have
        #: been lost since a reply was last matched to the newest frame written
        self._dropped_seen: int | None = None
        self._lost_possible = False
        #: the newest replies read (the evidence a fault's log line shows)
        self._recent: deque[_Reply] = deque(maxlen=8)
        #: the oldest frame the next reply can answer, as the replies' own motion showed it (see
        #: :meth:`_narrow`): a reply counted too old after replies were lost is judged from here
        self._floor = 0
        #: HOME was written (its frame number) and no aborting code since; None: none asked
        self._home_t: int | None = None
        #: frame number of a 101/102/103 that aborted a homing (None: none pending)
        self._abort_n: int | None = None
        #: the homed byte of the truth when HOME was written
        self._home_homed = 0xFF
        #: the board was seen homing since (two frames in a row showed it)
        self._home_seen = False
        #: the board homes without having been asked (reported; until an aborting code)
        self._unasked = False
        #: the homed byte the board is known to report (the truth's, or one reported)
        self._homed_known: int | None = None
        #: no new fault before this many frames were written (the DISABLE of the last one is
        #: on its way: what the board does meanwhile is the same event)
        self._quiet_until = 0

    @property
    def frames_written(self) -> int:
        """Frames written so far (the number of the newest; they count from 1)."""
        return self._n

    @property
    def homing(self) -> bool:
        """A homing may be running: one was asked for (HOME written) and has not been seen
        ending, one nobody asked for is reported, or an aborted one may still be stopping.
        Where the joints are is then not known from the frames written."""
        return self._home_t is not None or self._unasked or self._abort_n is not None

    @property
    def homing_seen(self) -> bool:
        """The board has been seen homing since the last HOME was written."""
        return self._home_seen

    @property
    def ref(self) -> StatusFrame | None:
        """The newest true status frame of this session (the one the snapshot shows)."""
        return self._shown.f if self._shown is not None else None

    def view(self, now: float) -> IntegrityView:
        shown = self._shown
        age = max(0.0, now - shown.t) if shown is not None else 0.0
        return IntegrityView(self.implausible, self.uncommanded, age, self.last_fault)

    # ------------------------------------------------------------------ frames written

    def sent(self, frame: CommandFrame, t: float, n: int | None = None) -> None:
        """The loop wrote ``frame`` at ``t`` (monotonic s); ``n``: its number in the link
        record (:class:`~parolkit.controller.link.LinkHistory`; by default the next one), so
        a reply's ``answers`` means the same frame here and there."""
        self._n = self._n + 1 if n is None else int(n)
        self._sent.append((self._n, t, frame))
        self._cands.clear()
        code = int(frame.command)
        if code == _HOME:
            self._home_t, self._home_seen = self._n, False
            self._abort_n = None  # a new homing: an earlier abort's wait is over
            self._unasked = False  # (and one nobody asked for is now this one)
            self._home_homed = self._ref.f.homed if self._ref is not None else 0xFF
        elif code in _ABORT:
            if self._home_t is not None or self._unasked:
                # 101/102/103 abort a homing, but the board's reply to it (and to the frame
                # after) still shows the homing's last pass: homing until a reply to a later
                # frame shows every joint still (see accept)
                self._abort_n = self._n
            else:
                self._home_t = None
                self._unasked = False
        if self.probe is not None:
            self.probe.sent(frame, t, self._n)

    # ------------------------------------------------------------------ frames read

    @staticmethod
    def _structural(f: StatusFrame) -> bool:
        if (f.io & 0x07) != 0x07 or (f.homed & 0x03) != 0x03:
            return False
        if (f.temperature_error & 0x03) != 0x03 or (f.position_error & 0x03) != 0x03:
            return False
        return all(-BOARD_SPEED_CLAMP <= v <= BOARD_SPEED_CLAMP for v in f.speeds)

    def accept(self, f: StatusFrame, t: float, dropped: int, answers: int | None = None, *,
               newest: int | None = None) -> bool:
        """``f`` read at ``t`` (monotonic s); ``dropped``: the parser's dropped-byte count right
        after ``f`` was parsed; ``answers``: the number of the frame it answers when that is not
        the newest frame written (the board answers in order, so the k-th reply read since the
        replies caught up answers the k-th frame left unanswered, however late and bunched they
        came: :meth:`~parolkit.controller.link.LinkHistory.answered_range`), the oldest it can
        answer when replies may have been lost; ``newest``: then the newest frame it can answer
        (the frame written last less the replies read after it).  It is judged against every
        frame in between.  True when ``f`` is the truth (the snapshot may show it)."""
        n = self._n if answers is None else max(0, min(self._n, answers))
        if self._dropped_seen is not None and dropped != self._dropped_seen:
            self._lost_possible = True  # bytes were dropped: a whole reply may be among them
        self._dropped_seen = dropped
        if newest is not None:
            hi = max(0, min(self._n, newest))
            # the replies' own motion may have shown that the count lags (replies lost): it
            # answers one at or after the floor, never one after ``hi``
            n = max(n, min(self._floor, hi))
            hi = max(n, hi)
        else:
            if n >= self._n:
                self._lost_possible = False  # it answers the newest frame: counted right again
            hi = self._n if self._lost_possible else n
        self._floor = max(self._floor, n + 1)
        rx = _Reply(f, t, dropped, self._structural(f), n, hi=hi)
        self._recent.append(rx)
        prev, self._prev = self._prev, rx
        if prev is not None and newest is not None and prev.hi >= hi:
            # it answered an older frame than this one does (in order)
            prev.hi = max(prev.n, hi - 1)
        # adjacent: the board answered nothing in between (the parser dropped no bytes).  The
        # previous frame may have failed its structural check (a corrupted speed or IO byte):
        # a link from it checks its positions against this frame's own account all the same
        adjacent = prev is not None and rx.ok and prev.dropped == dropped
        if self.probe is not None and rx.ok:
            self.probe.observe(f, t, adjacent, self._n)
        if self._home_t is not None and not self._home_seen and self._n - self._home_t > 1.0 / self.period:
            self._home_t = None  # the board never started the homing asked for (disabled?)
        if self._abort_n is not None and rx.ok and (
                (n > self._abort_n + 1 and not any(f.speeds)) or self._n - self._abort_n > 1.0 / self.period):
            # the aborted homing has stopped (or a second has passed): the joints are where
            # they stopped, unhomed; from here on motion is judged as usual
            self._abort_n = None
            self._home_t = None
            self._unasked = False
        if not rx.ok:
            self.implausible += 1
            return False
        if prev is None:
            # the first frame of the session: nothing to judge it against.  Not the truth (one
            # frame proves nothing) and not implausible either (nothing says it is corrupted):
            # the next frame is checked from it
            return False
        if adjacent:
            fault = self._raw_checks(prev, rx)
            if fault is not None:
                self._fault(fault)
        dt = self._dt(prev, rx) if adjacent else None
        linked = dt is not None and self._link(prev.f, f, dt, prev.n, prev.hi)
        ref = self._ref
        pending = self._suspect
        if pending is not None:
            sus, sdev, left = pending
            if ref is not None and not self._reachable(ref, sus, sdev.joints):
                pending, self._suspect = None, None  # (see _reachable)
        if pending is not None:
            sus, sdev, left = pending
            if linked and prev is sus and self._link_tells(ref, prev, rx, dt, sdev.joints, sdev.expected):
                # the next frame follows from it: the board really went there.  Not the truth
                # yet: nothing commanded says where the joints are, and a frame linked only by
                # the board's own account of a fast motion may carry a corrupted low byte (a
                # racing J3 was shown 5 steps off); the next frame that links to it is
                self._suspect = None
                self._fault(sdev.message)
                if sdev.expected is None:  # (beyond the hull after lost frames: see below)
                    return self._provisional(rx)
                self.implausible += 1
                return False
            if (ref is not None and not (adjacent and prev is sus) and self._outside_hull(ref, rx, sdev.joints)
                    and self._reachable(sus, rx, sdev.joints)):
                # a second frame shows the same joints beyond anything commanded, a reply lost
                # in between (the next frame right after the suspect that does not link to it
                # contradicts it: one of the two is corrupted, and two corrupted bytes beyond the
                # hull, a tick apart, say nothing; the frames after decide), where the board can
                # have gone from the suspect (a frame with a garbage byte lies beyond every hull)
                self._suspect = None
                self._fault(sdev.message)
                self.implausible += 1
                return False
            self._suspect = (sus, sdev, left - 1) if left > 1 else None
            if left <= 1:
                log.info("integrity: not confirmed by the next frames: %s", sdev.message)
        if linked:
            assert dt is not None
            if ref is None:
                return self._truth(rx)  # a new session: two frames agree
            if ref is not prev and prev is not self._suspect_reply():
                gap = self._gap_deviation(ref, prev)
                if gap is not None and self._link_tells(ref, prev, rx, dt, gap.joints):
                    # prev and rx agree: two frames show it.  Over a long interval a third must
                    # too: two replies in a row with the same joint's byte corrupted then link now
                    # and then (50 ms: J1 shown 109 and 131 steps off, at rest both times)
                    # (rx's own timing field may be the corrupted byte that makes it long)
                    if dt <= LONG_LINK_PERIODS * self.period:
                        self._suspect = None
                        self._fault(gap.message)
                        return self._provisional(rx)
                    beyond = self._gap_deviation(ref, rx)
                    if beyond is not None:
                        self._suspect = (rx, beyond, 2)
                        self.implausible += 1
                        return False
                    # rx is back within the hull: the two do not show one excursion, and prev
                    # (a corrupted frame, likely) says nothing about what rx should be: the
                    # next frame is judged from rx
                    self.implausible += 1
                    return False
            tight, dev = self._commanded(prev, rx, dt)
            if dev is None:
                if tight:
                    return self._truth(rx)
                # genuine, and no motion worth reporting, but not within the board's own
                # precision of what was commanded: not shown (the next frame links to it)
                self.implausible += 1
                return False
            # it follows from a true frame, but not from what was commanded: a second frame
            # must show it (a reply with several corrupted bytes may pass the link by chance)
            self._suspect = (rx, dev, 2)
            return False
        if ref is not None and self._at_rest_like(ref.f, f):
            return self._truth(rx)
        self.implausible += 1
        return False

    def _link_tells(self, ref: _Reply | None, a: _Reply, b: _Reply, dt: float | None,
                    joints: Sequence[int], expected: Sequence[float] | None = None) -> bool:
        """Whether ``b``'s link to ``a`` tells ``a``'s ``joints`` from where the commands put
        the board: ``b`` would not also follow from ``a`` with those joints moved to the nearest
        point of the commanded hull (or, inside it, to ``expected``: where the frame written
        put them).  The GO TO law closes 99 % of any gap in 90 ms, and a
        board fed in bursts (a pty on a busy machine) sees that much time between two frames
        now and then: a true frame then follows from any position, a corrupted one included,
        and its link confirms nothing.  (A corrupted frame may still become a suspect so, by
        "following" a true one: the next frames show whether the board was really there, and
        a real excursion found late is a missed stop, the worse error.)"""
        if ref is None or dt is None:
            return True
        hull = self._hull(ref, a)
        if hull is None:
            return True
        pos = list(a.f.positions)
        for j in joints:
            lo, hi = hull[j]
            if math.ceil(lo) > math.floor(hi):
                return True
            pos[j] = min(max(pos[j], math.ceil(lo)), math.floor(hi))
        if pos == list(a.f.positions) and expected is not None:
            # within the hull: would ``b`` also follow from where the frame written put those
            # joints?  (A long interval's link forgives a few steps: 7 steps of a corrupted byte
            # decay to 1.6 in 30 ms, within the link's allowance, and confirmed nothing)
            for j in joints:
                pos[j] = round(expected[j])
        if pos == list(a.f.positions):
            return True
        return not self._link(replace(a.f, positions=tuple(pos)), b.f, dt, a.n, a.hi)

    def _suspect_reply(self) -> _Reply | None:
        return self._suspect[0] if self._suspect is not None else None

    def _idle_codes_only(self, n: int, hi: int | None = None) -> bool:
        cands = self._candidates(n, hi)
        return bool(cands) and all(int(fr.command) not in (_JOG, _GOTO, _HOME) for fr in cands)

    def _raw_checks(self, a: _Reply, b: _Reply) -> str | None:
        """Homing and speeds shown by two adjacent frames, whatever their positions."""
        ref_homed = self._homed_known
        if self._home_t is not None:
            # the same fallen homed byte, or the same speed on a joint, twice in a row: two
            # corrupted bytes do not agree like that
            before = self._home_homed
            fallen = a.f.homed == b.f.homed and (b.f.homed & before) != before
            if fallen or any(v and v == w for v, w in zip(a.f.speeds, b.f.speeds)):
                self._home_seen = True
            return None
        if self._unasked:
            return None
        idle = self._idle_codes_only(a.n, a.hi) and self._idle_codes_only(b.n, b.hi)
        if a.f.xtr == _HOME and not any(int(fr.command) == _HOME for fr in self._candidates(a.n, a.hi)) and (
                (b.f.homed & a.f.homed) != a.f.homed or (idle and any(b.f.speeds))):
            self._unasked = True
            self._homed_known = b.f.homed
            return "the board started homing without a HOME command (corrupted frame?)"
        if ref_homed is not None and a.f.homed == b.f.homed and (b.f.homed & ref_homed) != ref_homed:
            self._unasked = True
            self._homed_known = b.f.homed
            lost = [JOINT_NAMES[j] for j in range(6) if ref_homed & (0x80 >> j) and not b.f.homed & (0x80 >> j)]
            return (f"the board reports {', '.join(lost)} no longer homed without a HOME command "
                    f"(homing nobody asked for, or a power cycle)")
        if idle:
            # the constant speeds of the homing's searches, back-offs and approaches, in two
            # frames in a row while the board was told to idle (an idle frame's speed bytes,
            # even corrupted, make no step: only a homing runs at these)
            moving = [j for j in range(6) if abs(a.f.speeds[j]) in _HOMING_SEGMENT_SPEEDS
                      and abs(b.f.speeds[j]) in _HOMING_SEGMENT_SPEEDS]
            if moving:
                self._unasked = True
                return ("the board is homing without a HOME command (corrupted frame?): "
                        + ", ".join(f"{JOINT_NAMES[j]} at {b.f.speeds[j]} steps/s" for j in moving))
        return None

    def _truth(self, rx: _Reply) -> bool:
        rx.truth = True
        self._ref = self._shown = rx
        self._homed_known = rx.f.homed
        f = rx.f
        if (self._home_t is not None and self._home_seen and f.homed == 0xFF and not any(f.speeds)
                and f.xtr != _HOME and tuple(f.positions) == self._standby):
            self._home_t = None  # the homing asked for is over
        return True

    def _provisional(self, rx: _Reply) -> bool:
        """``rx`` confirmed motion nobody commanded: it is where the next frames are checked
        from, but not shown.  It follows from the frame before by the board's own account
        alone, and during such motion nothing commanded says where the joints are: a corrupted
        low byte of a fast joint passes that (a joint at the speed clamp is not checked by its
        speed at all; seen: J2 shown 3 steps off while J4 and J5 raced).  The first frame that
        matches what was commanded from it is the truth again."""
        self._ref = rx
        self._homed_known = rx.f.homed
        self.implausible += 1
        return False

    @staticmethod
    def _at_rest_like(ref: StatusFrame, f: StatusFrame) -> bool:
        """``f`` shows the board exactly where the last true frame had it, at rest: whatever
        was lost in between, a corrupted frame cannot look like that."""
        return (tuple(f.positions) == tuple(ref.positions) and not any(f.speeds) and not any(ref.speeds)
                and f.homed == ref.homed)

    def _dt(self, a: _Reply, b: _Reply) -> float:
        """Board time between the two frames: ``b.timing``, unwrapped by the longest pause in
        the frames written between the ones they answer (:meth:`_pause`)."""
        dt = b.f.timing / TIMER_HZ
        gap = self._pause(a, b)
        if gap > 0.75 * _TIMING_WRAP_S:
            dt += max(0, round((gap - dt) / _TIMING_WRAP_S)) * _TIMING_WRAP_S
        return dt

    def _pause(self, a: _Reply, b: _Reply) -> float:
        """The longest the board can have waited for a frame between answering ``a`` and
        ``b``: the longest interval between consecutive frames written from the newest one
        ``a`` can answer to the newest one ``b`` can (a timer wrap needs a pause that long;
        the board answers a frame as it arrives).  Not the read times: a reply held back in
        the operating system on a busy machine is read late although the board sent it on
        time, and a wrap added for it makes the GO TO law take any position to the target, so
        a corrupted frame looks linked.  The read times when those frames are no longer
        remembered (or the numbers say nothing)."""
        lo, hi = a.n, b.n
        sent = self._sent
        if hi <= lo or not sent or sent[0][0] > lo or sent[-1][0] < hi:
            return b.t - a.t
        first = sent[0][0]
        if sent[hi - first][0] != hi:  # (numbered one by one in a session: cannot happen)
            return b.t - a.t
        longest = 0.0
        prev_t = sent[lo - first][1]
        for k in range(lo + 1, hi + 1):
            t = sent[k - first][1]
            longest = max(longest, t - prev_t)
            prev_t = t
        return longest

    # ------------------------------------------------------------------ the link check

    def mode(self, f: StatusFrame, n: int | None = None, hi: int | None = None) -> LinkMode:
        """What the board does after ``f`` until the next frame it answers (``n``: frames
        written before ``f`` was read, or the oldest frame it can answer and ``hi`` the newest).
        ``f.xtr`` echoes the command it answered; when that is none of the commands just written
        (a corrupted echo, or a corrupted command the board executed), the newest command
        written counts: a corrupted echo then still links, and a board that ran something else
        does not (its motion shows up as uncommanded)."""
        code = f.xtr
        if n is not None:
            cands = self._candidates(n, hi)
            if cands and all(int(fr.command) != code for fr in cands):
                code = int(cands[-1].command)
        if code == _HOME:
            return LinkMode.HOMING
        if code == _JOG:
            return LinkMode.JOG
        if code == _GOTO:
            return LinkMode.GOTO
        if (self._home_t is not None or self._unasked) and (code not in _ABORT or self._abort_n is not None):
            return LinkMode.HOMING
        return LinkMode.NONE

    def _link(self, a: StatusFrame, b: StatusFrame, dt: float, n: int | None = None,
              hi: int | None = None) -> bool:
        mode = self.mode(a, n, hi)
        if mode is LinkMode.HOMING:
            return self._link_homing(a, b, dt)
        if b.homed != a.homed:
            return False
        if mode is LinkMode.NONE:
            return tuple(b.positions) == tuple(a.positions) and not any(b.speeds)
        pred, allow = self._link_model(mode, a, b, dt)
        return all(abs(p1 - q) <= al for p1, q, al in zip(b.positions, pred, allow))

    def _link_model(self, mode: LinkMode, a: StatusFrame, b: StatusFrame,
                    dt: float) -> tuple[list[float], list[float]]:
        """Where ``b``'s own speeds and timing say the joints should be, coming from ``a``
        under ``mode`` (JOG or GO TO), and the allowance per joint."""
        tol = self.tol
        pred: list[float] = []
        allow: list[float] = []
        if mode is LinkMode.JOG:
            for p0, v in zip(a.positions, b.speeds):
                pred.append(p0 + v * dt)
                allow.append(tol.steps + abs(v) * tol.timing_s if v else 0.0)  # speed 0: not a step
            return pred, allow
        e = math.exp(-_K * dt)
        for p0, p1, v in zip(a.positions, b.positions, b.speeds):
            if abs(v) >= BOARD_SPEED_CLAMP:
                # clamped: the target is unknown; it raced toward it (rare: a corrupted target)
                pred.append(p0 + v * dt if abs(p1 - p0) > BOARD_SPEED_CLAMP * dt or (p1 - p0) * v < 0 else p1)
                allow.append(tol.steps)
                continue
            # p_ss from the reported speed; the last pass stepped after that speed was set
            last = 0.5 * v * tol.pass_s
            q = _goto(p0, p1 + v / _K - last, dt, e)
            pred.append(q)
            allow.append(tol.steps + (1.0 - e) * (abs(last) + 1.0) + tol.model * abs(q - p0)
                         + abs(v) * tol.timing_s)
        return pred, allow

    def _link_homing(self, a: StatusFrame, b: StatusFrame, dt: float) -> bool:
        if a.xtr != _HOME and (a.homed & b.homed) != a.homed:
            return False  # homed bits only rise while homing (they reset when it starts)
        for j, v in enumerate(b.speeds):
            if abs(v) > self._vhome[j] + 1:
                return False
        s = self.homing_speedup
        for j, (p0, p1) in enumerate(zip(a.positions, b.positions)):
            if not a.speeds[j] and not b.speeds[j]:
                # at rest in both frames: it stayed put, or its counter was overwritten (zeroed
                # at a switch, or the standby counts at the end); a corrupted position byte of a
                # joint at rest was within the reach below and showed a false position
                if p1 != p0 and p1 != 0 and p1 != self._standby[j]:
                    return False
                continue
            reach = s * self._vhome[j] * dt + 64
            if abs(p1 - p0) > reach and abs(p1) > reach and p1 != self._standby[j]:
                return False
        return True

    # ------------------------------------------------------------------ the commanded check

    def _candidates(self, n: int, hi: int | None = None) -> tuple[CommandFrame, ...]:
        """The frames one of which a status frame read after frame number ``n`` was written
        answered (the newest few of those), and the ones up to ``hi`` when replies may have been
        lost before it (:attr:`_Reply.hi`)."""
        top = n if hi is None else max(n, hi)
        known = self._cands.get((n, top))
        if known is not None:
            return known
        out: list[CommandFrame] = []
        low = n - self.candidates
        for k, _, fr in reversed(self._sent):  # newest first: a few steps, not the whole deque
            if k <= low:
                break
            if k <= top:
                out.append(fr)
        out.reverse()
        known = self._cands[(n, top)] = tuple(out)
        return known

    def _predict(self, p0: Sequence[int], frame: CommandFrame, dt: float) -> tuple[list[float], list[float]]:
        """Positions ``frame`` takes the joints to from ``p0`` in ``dt`` s, and how far the
        board may differ from that (steps)."""
        tol = self.tol
        code = int(frame.command)
        pred: list[float] = []
        allow: list[float] = []
        if code == _JOG:
            for p, v in zip(p0, frame.speeds):
                vc = max(-BOARD_SPEED_CLAMP, min(BOARD_SPEED_CLAMP, v))
                pred.append(p + vc * dt)
                allow.append(tol.steps + abs(vc) * tol.timing_s if vc else 0.0)
        elif code == _GOTO:
            e = math.exp(-_K * dt)
            for p, tgt, vff in zip(p0, frame.positions, frame.speeds):
                pss = tgt + vff * _FF_LEAD_S
                if pss == p:  # on target, no feed-forward: the P loop asks for speed 0
                    pred.append(float(p))
                    allow.append(0.0)
                    continue
                q = _goto(p, pss, dt, e)
                pred.append(q)
                allow.append(tol.steps + tol.model * abs(q - p)
                             + min(BOARD_SPEED_CLAMP, _K * abs(pss - q)) * tol.timing_s)
        else:  # IDLE, ENABLE, DISABLE, CLEAR_ERROR, unknown: not a step
            pred = [float(p) for p in p0]
            allow = [0.0] * 6
        return pred, allow

    def _commanded(self, a: _Reply, b: _Reply, dt: float) -> tuple[bool, _Deviation | None]:
        """Compare ``b``'s positions with what the frames written could produce from ``a``'s:
        (they match within the board's own precision, the deviation when they are beyond
        it and the margins).  (True, None) when nothing can be compared (a homing asked for,
        no frame written yet).  Every frame ``a`` can answer is tried (the board ran the one it
        answered, or the newest it took in in the same pass, until it answered ``b``)."""
        if self._home_t is not None or self._unasked:
            return True, None  # a homing was asked for (or is reported): positions unknown
        cands = self._candidates(a.n, a.hi)
        if not cands:
            return True, None
        p1s = b.f.positions
        tried = []
        top = max(a.n, a.hi)
        for i in range(len(cands) - 1, -1, -1):  # usually the newest one was answered
            fr = cands[i]
            pred, allow = self._predict(a.f.positions, fr, dt)
            res = [abs(p1 - q) for p1, q in zip(p1s, pred)]
            if all(r <= al for r, al in zip(res, allow)):
                self._narrow(a, b, dt, top - (len(cands) - 1 - i))
                return True, None
            tried.append((fr, pred, allow, res))
        # a corrupted position that slipped through the link checks before and after it is off
        # by at most twice their allowance: the uncommanded check allows that much more (and a
        # margin), so a reply byte can never look like uncommanded motion.  (HOMING here: xtr
        # 100 without a HOME written; a homing that follows is judged by _raw_checks.)
        hide = self._hide(a, b, dt)
        best: tuple[float, CommandFrame, list[float], list[float]] | None = None
        for fr, pred, allow, res in tried:
            loose = [al + h + self.tol.margin for al, h in zip(allow, hide)]
            excess = max(r - al for r, al in zip(res, loose))
            if best is None or excess < best[0]:
                best = (excess, fr, pred, loose)
        assert best is not None
        excess, fr, pred, loose = best
        if excess <= 0.0:
            return False, None
        return False, self._describe(a.f, b.f, fr, pred, loose)

    def _hide(self, a: _Reply, b: _Reply, dt: float) -> list[float]:
        """Per joint, how far a corrupted position that passed the link checks before and after
        it can be off (twice their allowance), for the frames from ``a`` to ``b``."""
        mode = self.mode(a.f, a.n, a.hi)
        if mode is LinkMode.HOMING:
            return [2.0 * (self.homing_speedup * v * dt + 64) for v in self._vhome]
        if mode is LinkMode.NONE:
            return [0.0] * 6
        return [2.0 * al for al in self._link_model(mode, a.f, b.f, dt)[1]]

    def _narrow(self, a: _Reply, b: _Reply, dt: float, k: int) -> None:
        """``b`` follows from ``a`` under frame number ``k`` (and under none of the newer ones
        ``a`` can answer).  When ``a`` may answer several frames (replies lost on the way, a
        frame the board never took in: the count of replies lags behind the frames answered for
        good), the board's motion between the two tells which: the board ran the frame ``a``
        answered (or a newer one it took in in the same pass), and that frame moves the joints
        as ``b`` shows.  A frame from ``a.n`` on that would move them beyond even the uncommanded
        check's margins (where a corrupted byte cannot hide) was not the one: the oldest one
        left is the oldest ``a`` can answer, and ``b`` and the replies after it answer newer
        ones (:attr:`_floor`).  Only ever the oldest is moved on, never past the newest
        (``hi``): a reply is still judged against every frame it can answer."""
        if k <= a.n or dt <= 0.0:
            return
        frames = self._candidates(a.n, k - 1)
        first = k - len(frames)
        hide: list[float] | None = None
        oldest = k
        for i in range(len(frames) - 1, -1, -1):
            number = first + i
            if number < a.n:
                break
            pred, allow = self._predict(a.f.positions, frames[i], dt)
            if hide is None:
                hide = self._hide(a, b, dt)
            if all(abs(p1 - q) <= al + h + self.tol.margin
                   for p1, q, al, h in zip(b.f.positions, pred, allow, hide)):
                oldest = number
        if oldest > a.n:
            a.n = oldest
            # (never past the newest frame ``b`` can answer: that bound is sure)
            b.n = min(max(b.n, oldest + 1), max(b.hi, b.n))
            self._floor = max(self._floor, b.n + 1)

    def _describe(self, a: StatusFrame, b: StatusFrame, fr: CommandFrame, pred: list[float],
                  allow: list[float]) -> _Deviation:
        parts = []
        joints = []
        code = int(fr.command)
        for j in range(6):
            if abs(b.positions[j] - pred[j]) <= allow[j]:
                continue
            joints.append(j)
            moved = b.positions[j] - a.positions[j]
            want = pred[j] - a.positions[j]
            name = JOINT_NAMES[j]
            if code not in (_JOG, _GOTO):
                parts.append(f"{name} moved {moved} steps while idle")
            elif moved == 0:
                parts.append(f"{name} stood still where {want:.0f} steps were commanded (is the board disabled?)")
            else:
                parts.append(f"{name} moved {moved} steps where {want:.0f} were commanded")
        return _Deviation("; ".join(parts), tuple(joints), tuple(pred))

    def _hull(self, ref: _Reply, b: _Reply) -> list[tuple[float, float]] | None:
        """Per joint, the range the frames written since ``ref`` could take it to by the time
        ``b`` was read (the start, every GO TO target, the farthest a JOG could run), or None
        when that cannot be judged (a homing, frames no longer known)."""
        if self._home_t is not None or self._unasked:
            return None
        first = ref.n - self.candidates + 1
        if not self._sent or self._sent[0][0] > first:
            return None  # the frames written since then are no longer all known
        frames = [fr for (k, _, fr) in self._sent if first <= k <= max(b.n, b.hi)]
        if not frames or any(int(fr.command) == _HOME for fr in frames):
            return None
        # how long those frames ran: ticks, or the time it took if ticks came late
        span = max(len(frames) * self.period, b.t - ref.t + self.candidates * self.period)
        out = []
        for j in range(6):
            p0 = ref.f.positions[j]
            lo = hi = float(p0)
            vlo = vhi = 0.0
            for fr in frames:
                code = int(fr.command)
                if code == _JOG:
                    vlo, vhi = min(vlo, fr.speeds[j]), max(vhi, fr.speeds[j])
                elif code == _GOTO:
                    pss = fr.positions[j] + fr.speeds[j] * _FF_LEAD_S
                    lo, hi = min(lo, pss), max(hi, pss)
            slack = self.tol.steps + self.tol.margin + self.tol.gap
            out.append((lo + vlo * span - slack, hi + vhi * span + slack))
        return out

    def _outside_hull(self, ref: _Reply, b: _Reply, joints: Sequence[int]) -> bool:
        hull = self._hull(ref, b)
        if hull is None:
            return False
        return any(not hull[j][0] <= b.f.positions[j] <= hull[j][1] for j in joints)

    def _gap_deviation(self, ref: _Reply, b: _Reply) -> _Deviation | None:
        """``b`` (a frame the next one links to, after frames were lost since ``ref``): its
        positions must lie within the hull of what the frames written since could reach."""
        hull = self._hull(ref, b)
        if hull is None:
            return None
        idle = self._idle_codes_only(b.n, b.hi) and self._idle_codes_only(ref.n, ref.hi)
        parts = []
        joints = []
        for j, (lo, hi) in enumerate(hull):
            p1 = b.f.positions[j]
            if not lo <= p1 <= hi:
                joints.append(j)
                what = "while idle" if idle else "beyond anything commanded"
                parts.append(f"{JOINT_NAMES[j]} moved {p1 - ref.f.positions[j]} steps {what}")
        if joints and not self._reachable(ref, b, joints):
            return None  # no board gets there in that time: corrupted bytes (two alike)
        return _Deviation("; ".join(parts), tuple(joints)) if joints else None

    def _reachable(self, ref: _Reply, b: _Reply, joints: Sequence[int]) -> bool:
        """Whether a board could have taken ``joints`` from where ``ref`` shows them to where
        ``b`` does in the time between the two (at the firmware's speed clamp, the fastest any
        command runs a stepper, plus a tick either side).  A position no board can reach in
        that time is a corrupted byte however many frames show it: two replies in a row with
        the same byte corrupted alike happen (1 % corruption: about once in 10^6 pairs)."""
        span = abs(b.t - ref.t) + 2.0 * self.period
        reach = BOARD_SPEED_CLAMP * span + self.tol.steps + self.tol.margin + self.tol.gap
        return all(abs(b.f.positions[j] - ref.f.positions[j]) <= reach for j in joints)

    # ------------------------------------------------------------------ faults

    def _fault(self, message: str) -> None:
        if self._n < self._quiet_until:
            log.info("uncommanded motion (the same event, DISABLE on its way): %s", message)
            return
        self._quiet_until = self._n + 3
        self.uncommanded += 1
        self.last_fault = message
        self._pending_fault = message
        log.error("uncommanded motion: %s", message)
        log.info("uncommanded motion, the evidence:\n%s", self._evidence())

    def _evidence(self) -> str:
        """The newest replies and the frames written since the oldest of them could answer,
        one per line (positions and speeds in steps), for the log of a fault."""
        lines = []
        ref = self._ref
        if ref is not None:
            lines.append(f"  reference: answers {ref.n} read {ref.t:.4f} positions {ref.f.positions}")
        for r in self._recent:
            lines.append(f"  read {r.t:.4f} answers {r.n}..{max(r.n, r.hi)} dropped {r.dropped} ok {r.ok} "
                         f"truth {r.truth} positions {r.f.positions} speeds {r.f.speeds} timing {r.f.timing} "
                         f"xtr {r.f.xtr}")
        first = min((r.n for r in self._recent), default=self._n) - self.candidates
        for k, t, fr in self._sent:
            if k > first:
                lines.append(f"  wrote {k} at {t:.4f} command {int(fr.command)} positions {fr.positions} "
                             f"speeds {fr.speeds}")
        return "\n".join(lines)

    def take_fault(self) -> str | None:
        """The uncommanded motion found since the last call (its message), once; None: none.
        The controller disables the robot with it."""
        msg, self._pending_fault = self._pending_fault, None
        return msg
