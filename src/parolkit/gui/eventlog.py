"""The commander's event log: timestamped entries with a level, newest last, bounded."""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from enum import Enum

__all__ = ["Level", "LogEntry", "EventLog", "level_of_ack"]


class Level(str, Enum):
    """Severity of a log entry; ERROR entries are highlighted."""

    INFO = "info"
    SUCCESS = "success"
    WARNING = "warning"
    ERROR = "error"


@dataclass(frozen=True)
class LogEntry:
    """One log line. ``timestamp`` is a Unix time in seconds."""

    timestamp: float
    level: Level
    text: str

    @property
    def clock(self) -> str:
        """Local wall-clock time with milliseconds, e.g. '14:03:07.125'."""
        lt = time.localtime(self.timestamp)
        return time.strftime("%H:%M:%S", lt) + f".{int(self.timestamp * 1000) % 1000:03d}"

    def format(self) -> str:
        return f"{self.clock}  {self.level.value.upper():7s}  {self.text}"


def level_of_ack(status: str) -> Level:
    """Log level for an ACK status (COMPLETED -> success, FAILED/INVALID -> error, ...)."""
    s = status.upper()
    if s in ("FAILED", "INVALID"):
        return Level.ERROR
    if s == "CANCELLED":
        return Level.WARNING
    if s == "COMPLETED":
        return Level.SUCCESS
    return Level.INFO


class EventLog:
    """A bounded log (oldest entries drop off beyond ``maxlen``); listeners see each new entry."""

    def __init__(self, maxlen: int = 500, clock: Callable[[], float] = time.time) -> None:
        if maxlen < 1:
            raise ValueError(f"maxlen must be >= 1, got {maxlen}")
        self._entries: deque[LogEntry] = deque(maxlen=maxlen)
        self._clock = clock
        self._listeners: list[Callable[[LogEntry], None]] = []
        self.version = 0  # increments on every change, so views can refresh cheaply

    def add(self, text: str, level: Level = Level.INFO) -> LogEntry:
        entry = LogEntry(self._clock(), Level(level), str(text))
        self._entries.append(entry)
        self.version += 1
        for listener in list(self._listeners):
            listener(entry)
        return entry

    def info(self, text: str) -> LogEntry:
        return self.add(text, Level.INFO)

    def error(self, text: str) -> LogEntry:
        return self.add(text, Level.ERROR)

    def subscribe(self, listener: Callable[[LogEntry], None]) -> None:
        self._listeners.append(listener)

    def unsubscribe(self, listener: Callable[[LogEntry], None]) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def clear(self) -> None:
        self._entries.clear()
        self.version += 1

    def __iter__(self) -> Iterator[LogEntry]:
        return iter(list(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def tail(self, n: int) -> list[LogEntry]:
        """The newest ``n`` entries, oldest first."""
        return list(self._entries)[-n:] if n > 0 else []

    def errors(self) -> list[LogEntry]:
        return [e for e in self._entries if e.level is Level.ERROR]
