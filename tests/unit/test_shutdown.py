"""Ctrl-C / SIGTERM handling of the long-running commands (``serve``, ``board-sim``).

Each case runs in a fresh interpreter: signal handlers belong to a process's main thread.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

from parolkit._shutdown import ShutdownRequest


def run_py(code: str, timeout: float = 10.0) -> str:
    res = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                         text=True, timeout=timeout)
    assert res.returncode == 0, res.stderr
    return res.stdout.strip()


def test_wait_returns_the_signal_sent_from_another_thread():
    out = run_py("""
        import os, signal, threading, time
        from parolkit._shutdown import ShutdownRequest
        req = ShutdownRequest().install()
        threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGTERM)).start()
        t = time.monotonic()
        print(req.wait(), round(time.monotonic() - t, 1) < 1.0)
    """)
    assert out == "15 True"


def test_a_signal_arriving_while_the_main_thread_holds_a_lock_never_blocks():
    """The case that hung `parolkit serve`: the handler ran inside Event.wait() while that
    thread held the event's lock, and the old handler's Event.set() waited for it forever."""
    out = run_py("""
        import signal, threading
        from parolkit._shutdown import ShutdownRequest
        req = ShutdownRequest().install()
        ev = threading.Event()
        with ev._cond:  # what Event.wait() holds between two of its bytecodes
            signal.raise_signal(signal.SIGTERM)  # runs the handler right here
            signal.raise_signal(signal.SIGINT)
        print(req.wait(), req.received)
    """)
    assert out == "15 15"  # the first signal counts


def test_a_storm_of_signals_during_wait_ends_it_promptly():
    out = run_py("""
        import os, signal, threading, time
        from parolkit._shutdown import ShutdownRequest
        req = ShutdownRequest().install()
        def storm():
            time.sleep(0.1)
            for _ in range(500):
                os.kill(os.getpid(), signal.SIGTERM)
        threading.Thread(target=storm, daemon=True).start()
        print(req.wait(poll_s=0.01))
    """)
    assert out == "15"


def test_without_a_signal_nothing_is_received():
    assert ShutdownRequest().received is None

