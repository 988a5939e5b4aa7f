"""A wrapper that logs every frame crossing a link, both ways, decoded (``spy+`` URLs).

For owners debugging a board: ``parolkit serve --port 'spy+/dev/ttyACM0?log=frames.log'``
writes one timestamped line per command frame sent and per status frame received, with every
field decoded, and shows bytes that are not a frame in hex.  The format is described in
:mod:`parolkit.transport.framelog` and docs/transport.md.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from typing import TextIO

from parolkit.errors import ParolkitValueError
from parolkit.transport.base import Transport, TransportError
from parolkit.transport.framelog import SpyDirection, SpyLog

__all__ = ["SpyTransport"]


class SpyTransport(Transport):
    """Wraps ``inner`` and logs what crosses it; the bytes themselves pass unchanged.

    * ``log``: a file path (appended to, line-buffered, opened by :meth:`open` and closed by
      :meth:`close`), ``"-"`` for standard error, or an open text stream (never closed here).
    * ``raw``: also write each frame's bytes in hex.

    Each :meth:`open` starts with an ``open`` line and each :meth:`close` ends with the bytes
    of any incomplete frame and a ``close`` line, so a reconnect is visible in the log.
    Failed reads and writes are logged before the error is raised.  ``counters`` says how many
    frames and undecoded bytes went each way.  Writing the log costs the caller's thread one
    line-buffered write per frame.
    """

    def __init__(self, inner: Transport, log: str | os.PathLike[str] | TextIO = "-", *,
                 raw: bool = False) -> None:
        if not isinstance(inner, Transport):
            raise ParolkitValueError(f"inner must be a Transport, got {type(inner).__name__}")
        if isinstance(log, os.PathLike):
            log = os.fspath(log)
        if isinstance(log, str):
            if not log:
                raise ParolkitValueError("log must be a file path or '-' (stderr), got ''")
        elif not (hasattr(log, "write") and hasattr(log, "flush")):
            raise ParolkitValueError(
                f"log must be a file path, '-' or a text stream, got {type(log).__name__}")
        if not isinstance(raw, bool):
            raise ParolkitValueError(f"raw must be a bool, got {raw!r}")
        self.inner = inner
        self.simulated = inner.simulated
        self.virtual_clock = inner.virtual_clock
        self.step_s = inner.step_s
        self.log_target: str | TextIO = log
        self.raw = raw
        self._lock = threading.Lock()
        self._log: SpyLog | None = None
        self._owned_file: TextIO | None = None
        self._frames = {d: 0 for d in SpyDirection}
        self._undecoded = {d: 0 for d in SpyDirection}

    @property
    def description(self) -> str:
        return f"spy+{self.inner.description}"

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def fileno(self) -> int | None:
        return self.inner.fileno()

    @property
    def counters(self) -> dict[str, int]:
        """Frames and undecoded bytes logged so far, both directions, over every open."""
        with self._lock:
            frames, undecoded = dict(self._frames), dict(self._undecoded)
            if self._log is not None:
                for d in SpyDirection:
                    frames[d] += self._log.frames[d]
                    undecoded[d] += self._log.undecoded_bytes[d]
        return {
            "frames_to_board": frames[SpyDirection.TO_BOARD],
            "frames_from_board": frames[SpyDirection.FROM_BOARD],
            "undecoded_to_board": undecoded[SpyDirection.TO_BOARD],
            "undecoded_from_board": undecoded[SpyDirection.FROM_BOARD],
        }

    # ---- the log ------------------------------------------------------------------------------
    def _start_log(self) -> None:
        target = self.log_target
        if target == "-":
            stream: TextIO = sys.stderr
        elif isinstance(target, str):
            try:
                stream = open(target, "a", encoding="utf-8", buffering=1)
            except OSError as exc:
                raise TransportError(f"spy: cannot open the log file {target}: {exc}") from exc
            self._owned_file = stream
        else:
            stream = target
        self._log = SpyLog(stream, raw=self.raw)

    def _end_log(self, text: str) -> None:
        log, self._log = self._log, None
        if log is None:
            return
        mono, wall = time.monotonic(), time.time()
        try:
            log.finish(mono, wall)
            log.event(text, mono, wall)
            log.stream.flush()
        finally:
            for d in SpyDirection:
                self._frames[d] += log.frames[d]
                self._undecoded[d] += log.undecoded_bytes[d]
            file, self._owned_file = self._owned_file, None
            if file is not None:
                file.close()

    def _event(self, text: str) -> None:
        if self._log is not None:
            self._log.event(text, time.monotonic(), time.time())

    # ---- Transport ----------------------------------------------------------------------------
    def open(self) -> None:
        with self._lock:
            self._end_log("reopen")
            self._start_log()
            self._event(f"open {self.description}")
            try:
                self.inner.open()
            except Exception as exc:
                self._end_log(f"open failed: {type(exc).__name__}: {exc}")
                raise

    def close(self) -> None:
        with self._lock:
            try:
                self.inner.close()
            finally:
                self._end_log("close")

    def _check_open(self) -> None:
        if not self.inner.is_open:
            raise TransportError(f"{self.description}: the link is not open (call open())")

    def write(self, data: bytes) -> None:
        self._check_open()
        mono, wall = time.monotonic(), time.time()
        try:
            self.inner.write(data)
        except Exception as exc:
            with self._lock:
                self._event(f"{SpyDirection.TO_BOARD.value} write of {len(data)} bytes failed: "
                            f"{type(exc).__name__}: {exc}")
            raise
        with self._lock:
            if self._log is not None:
                self._log.data(SpyDirection.TO_BOARD, bytes(data), mono, wall)

    def read(self) -> bytes:
        self._check_open()
        try:
            data = self.inner.read()
        except Exception as exc:
            with self._lock:
                self._event(f"{SpyDirection.FROM_BOARD.value} read failed: "
                            f"{type(exc).__name__}: {exc}")
            raise
        if data:
            mono, wall = time.monotonic(), time.time()
            with self._lock:
                if self._log is not None:
                    self._log.data(SpyDirection.FROM_BOARD, data, mono, wall)
        return data
