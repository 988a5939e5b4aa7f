"""Start a controller (``parolkit serve``) as a child process that never outlives its parent.

Used by the programs that bring their own controller (``parolkit gui --sim``,
``parolkit run --sim``, ``parolkit replay``); :class:`SimController` is the whole of it for a
one-off run on the simulated board (free ports, wait until homed, stop).  Standard library
only, like the rest of the client: the child is a separate program reached over UDP, never
imported.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from typing import IO

__all__ = ["die_with_parent", "spawn_controller", "free_udp_port", "SimController"]


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


def stop_process(proc: subprocess.Popen[bytes], timeout: float = 10.0) -> int | None:
    """SIGTERM ``proc`` (a controller then stops motion and disables the robot), SIGKILL if it
    has not exited ``timeout`` s later; returns its exit status."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
    return proc.returncode


def free_udp_port() -> int:
    """A UDP port on 127.0.0.1 that nothing is bound to right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


class SimController:
    """``parolkit serve --sim EXTRA_ARGS...`` started for one run on free ports (``port``,
    ``ack_port``), its log in a temporary file (a pipe nobody reads would fill up and block
    it); :meth:`wait_ready` until the simulated board has homed, :meth:`close` stops it.
    ``board``: a ``sim://`` transport URL with options (``--port URL`` instead of ``--sim``),
    e.g. the lockstep board ``sim://?clock=virtual&step=0.01``."""

    def __init__(self, extra_args: Sequence[str] = (), *, board: str | None = None) -> None:
        if board is not None and not board.startswith("sim://"):
            raise ValueError(f"board must be a sim:// transport URL, got {board!r}")
        self.port = free_udp_port()
        self.ack_port = free_udp_port()
        self.log = tempfile.TemporaryFile()
        source = ["--port", board] if board is not None else ["--sim"]
        self.proc = spawn_controller([*source, *extra_args, "--udp-port", str(self.port),
                                      "--ack-port", str(self.ack_port)], stdout=self.log, stderr=subprocess.STDOUT)

    def log_tail(self, lines: int = 15) -> str:
        self.log.seek(0)
        return "\n".join(self.log.read().decode(errors="replace").splitlines()[-lines:])

    def _query(self, text: str, timeout: float) -> str:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.settimeout(timeout)
            sock.sendto(text.encode(), ("127.0.0.1", self.port))
            try:
                return sock.recv(65535).decode(errors="replace")
            except OSError:  # timeout, or ICMP "port unreachable" while it starts
                return ""

    def wait_ready(self, timeout: float = 60.0) -> None:
        """Wait until the controller answers and the simulated board has homed."""
        deadline = time.monotonic() + timeout
        last = "no answer"
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"the simulated controller exited with {self.proc.returncode}:\n"
                                   f"{self.log_tail()}")
            reply = self._query("GET_STATUS", 0.25)
            if reply.startswith("STATUS|"):
                fields = dict(f.partition("=")[::2] for f in reply.split("|")[1:])
                last = f"state {fields.get('STATE')}, homed {fields.get('HOMED')}"
                if fields.get("HOMED") == "1,1,1,1,1,1" and fields.get("STATE") != "HOMING":
                    return
                time.sleep(0.05)
        raise RuntimeError(f"the simulated controller was not ready within {timeout:g} s ({last}); "
                           f"its log:\n{self.log_tail()}")

    def close(self) -> None:
        stop_process(self.proc)
        self.log.close()
