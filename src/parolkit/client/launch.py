"""Start a controller (``parolkit serve``) as a child process that never outlives its parent.

Used by the programs that bring their own controller (``parolkit gui --sim``,
``parolkit run --sim``).  Standard library only, like the rest of the client: the child is a
separate program reached over UDP, never imported.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from typing import IO

__all__ = ["die_with_parent", "spawn_controller"]


def die_with_parent() -> None:
    """``preexec_fn`` for child processes: on Linux the child gets SIGTERM when the parent
    dies (PR_SET_PDEATHSIG), so a killed GUI or script never leaves a controller running.
    Elsewhere it does nothing (the parent's normal shutdown still stops the child)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes
        import signal

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # the parent died before the prctl: nobody will signal us
        os._exit(1)


def spawn_controller(serve_args: Sequence[str], *, stdout: IO[bytes] | int | None = None,
                     stderr: IO[bytes] | int | None = None) -> subprocess.Popen[bytes]:
    """Run ``python -m parolkit serve SERVE_ARGS...`` tied to this process's lifetime."""
    cmd = [sys.executable, "-m", "parolkit", "serve", *serve_args]
    return subprocess.Popen(cmd, stdout=stdout, stderr=stderr, preexec_fn=die_with_parent,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
