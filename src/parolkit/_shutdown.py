"""Wait for Ctrl-C / SIGTERM in a long-running command (``serve``, ``board-sim``) safely.

A Python signal handler runs in the main thread between two bytecodes, wherever that thread
is, including inside ``threading.Event.wait()`` while it holds the event's internal lock.
A handler that calls ``Event.set()`` then waits for that same lock forever: a controller
stuck that way ignored every further SIGTERM (seen in a test run: a `parolkit serve` left
running after its GUI had gone).  So the handler here only records the signal (no lock, no
I/O) and the main thread polls for it with ``time.sleep``.
"""

from __future__ import annotations

import signal
import time

__all__ = ["ShutdownRequest"]


class ShutdownRequest:
    """Install handlers for SIGINT and SIGTERM; :meth:`wait` returns once one arrived."""

    def __init__(self) -> None:
        #: the first signal number received, or None
        self.received: int | None = None

    def install(self) -> ShutdownRequest:
        """Handle SIGINT and SIGTERM (main thread only, as ``signal.signal`` requires)."""
        signal.signal(signal.SIGTERM, self._on_signal)
        signal.signal(signal.SIGINT, self._on_signal)
        return self

    def _on_signal(self, signum: int, _frame: object) -> None:
        if self.received is None:  # an attribute store: takes no lock, cannot block
            self.received = signum

    def wait(self, poll_s: float = 0.1) -> int:
        """Block until a signal arrived (checked every ``poll_s`` s); return its number."""
        while self.received is None:
            time.sleep(poll_s)
        return self.received
