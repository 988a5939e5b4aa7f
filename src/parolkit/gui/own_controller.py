"""The controller process a ``parolkit gui`` started itself (``--sim`` or ``--port``), so that
the page can restart it when it died (no NiceGUI here)."""

from __future__ import annotations

import subprocess
import threading
from collections.abc import Callable

__all__ = ["OwnController"]


class OwnController:
    """A controller process of this GUI: same serial port / simulator, UDP and ack ports on
    every (re)start, so the link's status subscription finds it again by itself."""

    def __init__(self, start: Callable[[], subprocess.Popen[bytes]],
                 stop: Callable[[subprocess.Popen[bytes]], None]) -> None:
        """``start()`` starts the process and returns once it answers PING (raises
        RuntimeError / OSError otherwise); ``stop(proc)`` ends it."""
        self._start, self._stop = start, stop
        self._lock = threading.Lock()
        self.proc: subprocess.Popen[bytes] | None = None
        self.restarting = False

    def start(self) -> None:
        with self._lock:
            self.proc = self._start()

    @property
    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    @property
    def exit_code(self) -> int | None:
        return None if self.proc is None else self.proc.poll()

    def restart(self) -> None:
        """Stop the process if it still runs, then start it again (blocks until it answers
        PING, up to 20 s); raises RuntimeError / OSError when it does not come up."""
        with self._lock:
            self.restarting = True
            try:
                if self.proc is not None:
                    self._stop(self.proc)
                self.proc = self._start()
            finally:
                self.restarting = False

    def stop(self) -> None:
        with self._lock:
            if self.proc is not None:
                self._stop(self.proc)
