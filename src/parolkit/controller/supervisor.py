"""The stop supervisor: a small process that stops the board when the controller dies.

The stock firmware has no watchdog: it runs its last command forever, so a controller killed
during a jog (``kill -9``, a crash, the out-of-memory killer) would leave the joints turning.
The supervisor closes that gap.  It is a separate process the controller starts at link-up
(``python -m parolkit.controller.supervisor``); it shares the serial port (the controller hands
it a duplicate of the port's file descriptor over a Unix socket, so no second ``open()`` is
needed, which an exclusively locked port would refuse) and it never reads from the port.

Messages, controller -> supervisor (one SOCK_SEQPACKET datagram each):

* ``F`` + the 56 bytes of every command frame the controller wrote, as it writes it;
* ``P`` with the port's file descriptor attached (SCM_RIGHTS): the link is (re)opened;
* ``X``: the link is closed or lost (the supervisor drops its descriptor);
* ``Q``: a clean shutdown (the controller sent its own final frame): exit quietly.

Supervisor -> controller: ``R`` when it is ready; ``T`` + a reason when it stopped the board
on its own (the controller sent no frame for ``stall_s``).

When the controller's end of the socket closes without ``Q`` (the kernel closes it the moment
the process dies, whatever killed it), the supervisor writes the stop frame three times (the
first may be swallowed by a frame the controller left half-written) and exits.  The stop frame
is the controller's last frame with every speed zero and the command DISABLE (102): the board
stops dead and ignores motion commands until someone sends ENABLE, exactly what the
controller's own clean shutdown leaves; the outputs (a pneumatic gripper's valve) and the
gripper setpoints stay as they were, so a part held is not dropped.  A controller that never
wrote a frame commanded nothing, and nothing is written for it.

``stall_s`` > 0 also stops the board when the controller is alive but sends no frame for that
long while the link is up (a frozen process, SIGSTOP, a debugger): then the supervisor writes
the stop frame once and tells the controller, which latches an error and reports the robot
disabled.  The limit that no software helps: a pulled USB cable leaves the board running its
last command.
"""

from __future__ import annotations

import argparse
import logging
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import replace

from parolkit.protocol.frames import COMMAND_FRAME_SIZE, BoardCommand, CommandFrame, FrameError

__all__ = ["StopSupervisor", "stop_frame", "main"]

log = logging.getLogger("parolkit.controller")

_ZERO6 = (0, 0, 0, 0, 0, 0)
#: copies of the stop frame written when the controller dies
STOP_COPIES = 3


def stop_frame(last: bytes) -> bytes | None:
    """The frame that stops the board after ``last`` (the controller's last frame, encoded):
    the same outputs and gripper setpoints, every speed zero, command DISABLE.  None when
    ``last`` is not a command frame."""
    try:
        f = CommandFrame.decode(last)
    except FrameError:
        return None
    return replace(f, speeds=_ZERO6, command=BoardCommand.DISABLE, gripper_mode=0).encode()


class _Supervisor:
    """The supervisor process's state (see the module docstring)."""

    def __init__(self, sock: socket.socket, stall_s: float) -> None:
        self.sock = sock
        self.stall_s = stall_s
        self.port_fd: int | None = None
        self.last: bytes | None = None
        self.last_t = 0.0
        self.tripped = False

    def _write_stop(self, copies: int) -> bool:
        fd, last = self.port_fd, self.last
        if fd is None or last is None:
            return False
        frame = stop_frame(last)
        if frame is None:
            return False
        try:
            for _ in range(copies):
                os.write(fd, frame)
            return True
        except OSError:
            return False

    def _drop_port(self) -> None:
        if self.port_fd is not None:
            try:
                os.close(self.port_fd)
            except OSError:
                pass
            self.port_fd = None

    def run(self) -> int:
        try:
            self.sock.send(b"R")
        except OSError:
            return self._died()
        while True:
            timeout = None
            if self.stall_s > 0 and self.port_fd is not None and self.last is not None and not self.tripped:
                timeout = max(0.0, self.last_t + self.stall_s - time.monotonic())
            ready, _, _ = select.select([self.sock], [], [], timeout)
            if not ready:
                self.tripped = True
                quiet = time.monotonic() - self.last_t
                ok = self._write_stop(1)
                try:
                    self.sock.send(b"T" + (f"no frame from the controller for {quiet * 1000:.0f} ms "
                                           f"(limit {self.stall_s * 1000:.0f} ms): the supervisor "
                                           f"{'disabled' if ok else 'could not disable'} the board").encode())
                except OSError:
                    return self._died()
                continue
            try:
                msg, fds, _, _ = socket.recv_fds(self.sock, 256, 2)
            except OSError:
                return self._died()
            if not msg and not fds:
                return self._died()
            kind = msg[:1]
            if kind == b"F" and len(msg) == 1 + COMMAND_FRAME_SIZE:
                self.last = bytes(msg[1:])
                self.last_t = time.monotonic()
                self.tripped = False
            elif kind == b"P" and fds:
                self._drop_port()
                self.port_fd = fds[0]
                for extra in fds[1:]:
                    os.close(extra)
                self.last_t = time.monotonic()
            elif kind == b"X":
                self._drop_port()
            elif kind == b"Q":
                self._drop_port()
                return 0
            else:
                for fd in fds:
                    os.close(fd)

    def _died(self) -> int:
        """The controller is gone without a clean shutdown: stop the board."""
        self._write_stop(STOP_COPIES)
        self._drop_port()
        return 0


def _raise_priority() -> None:
    try:
        os.setpriority(os.PRIO_PROCESS, 0, -10)
    except (AttributeError, OSError):
        pass


def main(argv: list[str] | None = None) -> int:
    """``python -m parolkit.controller.supervisor --fd N [--stall S]`` (started by the
    controller, not by hand)."""
    ap = argparse.ArgumentParser(prog="parolkit-supervisor",
                                 description="stops the PAROL6 board when the controller dies")
    ap.add_argument("--fd", type=int, required=True, help="the Unix socket to the controller")
    ap.add_argument("--stall", type=float, default=0.0,
                    help="stop the board when no frame came for this long, s (0 = only on death)")
    args = ap.parse_args(argv)
    # a Ctrl-C or SIGTERM aimed at the controller's process group must not take the supervisor
    # down before the controller has stopped the board: it exits when the controller is gone
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _raise_priority()
    sock = socket.socket(fileno=args.fd)
    return _Supervisor(sock, max(0.0, args.stall)).run()


class StopSupervisor:
    """The controller's end: starts the supervisor process and feeds it.

    Every method is cheap and never blocks (the loop thread calls :meth:`sent` every tick);
    if the supervisor died, :attr:`state` says so and the calls do nothing.
    """

    def __init__(self, stall_s: float = 0.0) -> None:
        self.stall_s = float(stall_s)
        self._sock: socket.socket | None = None
        self._proc: subprocess.Popen[bytes] | None = None
        self._lock = threading.Lock()
        #: "off" (not started), "starting", "ready", "dead" (it exited or its socket broke)
        self.state = "off"
        #: frames not forwarded because the supervisor's socket was full
        self.frames_skipped = 0

    def start(self) -> None:
        parent, child = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-m", "parolkit.controller.supervisor", "--fd", str(child.fileno()),
                 "--stall", repr(self.stall_s)],
                pass_fds=(child.fileno(),), stdin=subprocess.DEVNULL, start_new_session=True)
        except OSError:
            parent.close()
            raise
        finally:
            child.close()
        parent.setblocking(False)
        self._sock = parent
        self.state = "starting"

    def _send(self, data: bytes, fds: tuple[int, ...] = ()) -> None:
        sock = self._sock
        if sock is None or self.state == "dead":
            return
        try:
            with self._lock:
                if fds:
                    socket.send_fds(sock, [data], list(fds))
                else:
                    sock.send(data)
        except BlockingIOError:
            self.frames_skipped += 1
        except OSError as exc:
            self.state = "dead"
            log.error("the stop supervisor is gone (%s): a crash of the controller would leave the "
                      "board running its last command", exc)

    def sent(self, frame: bytes) -> None:
        """(loop thread) The controller wrote ``frame`` (56 encoded bytes)."""
        self._send(b"F" + frame)

    def port_opened(self, fd: int | None) -> None:
        """The link is (re)opened on file descriptor ``fd`` (None: a link with no descriptor)."""
        if fd is None:
            self._send(b"X")
        else:
            self._send(b"P", (fd,))

    def port_closed(self) -> None:
        self._send(b"X")

    def poll(self) -> str | None:
        """(loop thread) A message from the supervisor: the reason it stopped the board on its
        own, or None.  Also notes when it became ready or died."""
        sock = self._sock
        if sock is None or self.state == "dead":
            return None
        try:
            msg = sock.recv(512)
        except BlockingIOError:
            return None
        except OSError:
            msg = b""
        if not msg:
            self.state = "dead"
            log.error("the stop supervisor exited: a crash of the controller would leave the board "
                      "running its last command")
            return None
        if msg[:1] == b"R":
            self.state = "ready"
            return None
        if msg[:1] == b"T":
            return msg[1:].decode(errors="replace")
        return None

    def close(self, timeout: float = 1.0) -> None:
        """Clean shutdown: the controller has stopped the board itself."""
        self._send(b"Q")
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()
        proc = self._proc
        if proc is not None:
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(1.0)
        self.state = "off"


if __name__ == "__main__":  # pragma: no cover - run as a process
    sys.exit(main())
