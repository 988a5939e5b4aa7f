"""Loop statistics: tick period and serial round trip, kept as fixed-bin histograms.

Recording is O(1) per tick (one list increment, no allocation); percentiles are computed from
the histogram on request, over the whole run since the last :meth:`LoopMetrics.reset`.
Bin width 10 us up to 200 ms; anything longer goes to the last bin (and ``max`` is exact).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

__all__ = ["Histogram", "LoopMetrics", "LoopStatsView"]

_BIN_S = 10e-6
_NBINS = 20_000  # 200 ms


class Histogram:
    """Durations in seconds, 10 us bins; exact count, sum and max."""

    __slots__ = ("bins", "count", "total", "max", "min")

    def __init__(self) -> None:
        self.bins = [0] * _NBINS
        self.count = 0
        self.total = 0.0
        self.max = 0.0
        self.min = float("inf")

    def add(self, seconds: float) -> None:
        i = int(seconds / _BIN_S)
        if i >= _NBINS:
            i = _NBINS - 1
        elif i < 0:
            i = 0
        self.bins[i] += 1
        self.count += 1
        self.total += seconds
        if seconds > self.max:
            self.max = seconds
        if seconds < self.min:
            self.min = seconds

    def percentile(self, q: float) -> float:
        """The q-th percentile (0..100) in seconds (bin centre); 0.0 when empty."""
        if self.count == 0:
            return 0.0
        want = max(1, int(round(self.count * q / 100.0 + 0.4999)))
        acc = 0
        for i, c in enumerate(self.bins):
            if c:
                acc += c
                if acc >= want:
                    return min((i + 0.5) * _BIN_S, self.max)
        return self.max

    def percentiles(self, qs: tuple[float, ...]) -> tuple[float, ...]:
        """Several percentiles in one pass over the bins."""
        if self.count == 0:
            return tuple(0.0 for _ in qs)
        wants = [max(1, int(round(self.count * q / 100.0 + 0.4999))) for q in qs]
        out: list[float | None] = [None] * len(qs)
        acc = 0
        for i, c in enumerate(self.bins):
            if c:
                acc += c
                for k, w in enumerate(wants):
                    if out[k] is None and acc >= w:
                        out[k] = min((i + 0.5) * _BIN_S, self.max)
                if all(o is not None for o in out):
                    break
        return tuple(self.max if o is None else o for o in out)


@dataclass(frozen=True)
class LoopStatsView:
    """A copy of the loop statistics (times in ms)."""

    rate_hz: float
    ticks: int
    period_p50_ms: float
    period_p99_ms: float
    period_max_ms: float
    overruns: int
    #: how late ticks started after their deadline (wake-up latency, overruns included)
    late_p50_ms: float
    late_p99_ms: float
    late_max_ms: float
    rtt_p50_ms: float
    rtt_p99_ms: float
    rtt_max_ms: float
    tick_work_p99_ms: float
    tick_work_max_ms: float
    frames_sent: int
    frames_received: int
    bytes_dropped: int
    implausible_frames: int
    link_losses: int
    #: speed streams stopped because replies went missing (before a loss, or instead of one)
    link_holds: int
    #: the longest run of frames the board left unanswered
    unanswered_max: int
    #: the tick thread's scheduling: "fifo:N", "nice:-10" or "normal"
    scheduling: str

    def as_dict(self) -> dict[str, Any]:
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


class LoopMetrics:
    """Mutable statistics owned by the loop thread; :meth:`view` may be called from any thread.

    ``period``: time between successive tick starts; ``lateness``: how long after its deadline
    a tick started; ``rtt``: write of a command frame to the arrival of its status frame, for
    the replies that came within the reply wait (a later one is read by the next tick and
    counted by the core as a frame left unanswered: ``unanswered_max``);
    ``work``: time the tick spent before sleeping.
    An overrun is a tick that started more than one period late (its deadline was skipped).
    """

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self._lock = threading.Lock()
        self._cache: tuple[float, LoopStatsView] | None = None
        self._scheduling = "not started"
        self.reset()

    @property
    def scheduling(self) -> str:
        """The tick thread's scheduling, set once when it starts (not reset: it does not change
        during a run)."""
        return self._scheduling

    @scheduling.setter
    def scheduling(self, value: str) -> None:
        # a view cached before the tick thread started would say "not started" for up to
        # max_age_s after it had (GET_STATUS right after the link came up did)
        with self._lock:
            self._scheduling = value
            self._cache = None

    def reset(self) -> None:
        with self._lock:
            self.period = Histogram()
            self.lateness = Histogram()
            self.rtt = Histogram()
            self.work = Histogram()
            self.ticks = 0
            self.overruns = 0
            self.frames_sent = 0
            self.frames_received = 0
            self.bytes_dropped = 0
            self.implausible_frames = 0
            self.link_losses = 0
            self.link_holds = 0
            self.unanswered_max = 0
            self._cache = None

    def view(self, max_age_s: float = 0.0, now: float | None = None) -> LoopStatsView:
        """Percentiles from the histograms.  ``max_age_s`` > 0 reuses a view that young."""
        import time

        t = time.monotonic() if now is None else now
        cached = self._cache
        if max_age_s > 0 and cached is not None and t - cached[0] <= max_age_s:
            return cached[1]
        with self._lock:
            p50, p99 = self.period.percentiles((50.0, 99.0))
            l50, l99 = self.lateness.percentiles((50.0, 99.0))
            r50, r99 = self.rtt.percentiles((50.0, 99.0))
            (w99,) = self.work.percentiles((99.0,))
            v = LoopStatsView(
                rate_hz=self.rate_hz,
                ticks=self.ticks,
                period_p50_ms=p50 * 1e3,
                period_p99_ms=p99 * 1e3,
                period_max_ms=self.period.max * 1e3,
                overruns=self.overruns,
                late_p50_ms=l50 * 1e3,
                late_p99_ms=l99 * 1e3,
                late_max_ms=self.lateness.max * 1e3,
                rtt_p50_ms=r50 * 1e3,
                rtt_p99_ms=r99 * 1e3,
                rtt_max_ms=self.rtt.max * 1e3,
                tick_work_p99_ms=w99 * 1e3,
                tick_work_max_ms=self.work.max * 1e3,
                frames_sent=self.frames_sent,
                frames_received=self.frames_received,
                bytes_dropped=self.bytes_dropped,
                implausible_frames=self.implausible_frames,
                link_losses=self.link_losses,
                link_holds=self.link_holds,
                unanswered_max=self.unanswered_max,
                scheduling=self.scheduling,
            )
            self._cache = (t, v)  # under the lock: a new scheduling never meets a stale cache
        return v
