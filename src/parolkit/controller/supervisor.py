"""The stop supervisor: a small process that stops the board when the controller dies.

The stock firmware has no watchdog: it runs its last command forever, so a controller killed
during a jog (``kill -9``, a crash, the out-of-memory killer) would leave the joints turning.
The supervisor closes that gap.  It is a separate process the controller starts at link-up
(``python -m parolkit.controller.supervisor``); it shares the serial port (the controller hands
it a duplicate of the port's file descriptor over a Unix socket, so no second ``open()`` is
needed, which an exclusively locked port would refuse) and it never reads from the port.  It
asks for SCHED_FIFO one above the tick thread (else nice -10): it must run when the tick
does not.

Messages, controller -> supervisor (one SOCK_SEQPACKET datagram each):

* ``F`` + the 56 bytes of every command frame the controller wrote, as it writes it;
* ``P`` with the port's file descriptor attached (SCM_RIGHTS): the link is (re)opened;
* ``X``: the link is closed or lost (the supervisor drops its descriptor);
* ``Q``: a clean shutdown (the controller sent its own final frame): exit quietly.

Supervisor -> controller (never blocking: a controller that reads nothing cannot hold it up):
``R`` + its scheduling when it is ready; ``A`` after every :data:`HEARTBEAT_FRAMES` frames it
received (alive); ``T`` + a reason when it stopped the board on its own (see below).

When the controller's end of the socket closes without ``Q`` (the kernel closes it the moment
the process dies, whatever killed it), the supervisor writes the stop frame three times (the
first may be swallowed by a frame the controller left half-written) and exits.  The stop frame
is the controller's last frame with every speed zero and the command DISABLE (102): the board
stops dead and ignores motion commands until someone sends ENABLE, exactly what the
controller's own clean shutdown leaves; the outputs (a pneumatic gripper's valve) and the
gripper setpoints stay as they were, so a part held is not dropped.  A controller that never
wrote a frame commanded nothing, and nothing is written for it.

A controller that is alive but writes no frame while the link is up is stopped the same way
(the stop frame, then ``T``; the controller latches the error and reports the robot
disabled when it runs again):

* when its process is *stopped* (``kill -STOP``, Ctrl-Z, a debugger holding a thread: state
  T or t in /proc) and it wrote no frame for :data:`STOPPED_PERIODS` loop periods (30 ms at
  100 Hz): a stopped process is never merely late, so this limit can follow the loop period
  without ever stopping a live controller for nothing;
* when it *runs* (or waits) but wrote no frame for ``stall_s`` (``controller.supervisor_stall_s``,
  1 s; 0 = never): a hung or deadlocked controller.  Under load a live controller's frames come
  late: with two CPU hogs on a loaded 2-core PC, gaps of 100-440 ms between frames were seen
  several times a minute, so a limit this side of 100 ms would stop a working robot.

The limit that no software helps: a pulled USB cable leaves the board running its last
command.

The controller watches its supervisor in turn (:class:`StopSupervisor`): a supervisor that
exited, cannot be reached, answers none of :data:`SILENT_FRAMES_MAX` frames or does not start
is *lost*; the controller stops the motion, latches the error, refuses motion until a new
supervisor is ready, and starts one.
"""

from __future__ import annotations

import argparse
import errno
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

from parolkit.controller.messages import SupervisorEvent, SupervisorEventKind
from parolkit.controller.scheduling import raise_priority
from parolkit.protocol.frames import COMMAND_FRAME_SIZE, BoardCommand, CommandFrame, FrameError

__all__ = ["StopSupervisor", "SupervisorEvent", "SupervisorEventKind", "stop_frame", "controller_stopped", "main",
           "STOP_COPIES", "STOPPED_PERIODS", "HEARTBEAT_FRAMES", "SILENT_FRAMES_MAX", "START_TIMEOUT_S"]

log = logging.getLogger("parolkit.controller")

_ZERO6 = (0, 0, 0, 0, 0, 0)
#: copies of the stop frame written when the controller dies
STOP_COPIES = 3
#: a controller whose process is stopped (state T or t: ``kill -STOP``, Ctrl-Z, a debugger)
#: and that wrote no frame for this many loop periods is frozen: the board is stopped (30 ms
#: at 100 Hz, 12 ms at 250 Hz; a stopped process is never merely late, so no load trips it)
STOPPED_PERIODS = 3
#: the supervisor says it is alive (``A``) after every this many frames it received
HEARTBEAT_FRAMES = 10
#: frames the controller wrote with no word from a ready supervisor after which it counts as
#: lost (stopped, hung): judged by frames written, so the controller's own late ticks never
#: count; a supervisor reads each frame as it comes (1 s at 100 Hz, 0.4 s at 250 Hz)
SILENT_FRAMES_MAX = 100
#: a supervisor not ready this long after its start counts as lost, s (a Python start-up
#: under heavy load takes a second or two)
START_TIMEOUT_S = 10.0


def stop_frame(last: bytes) -> bytes | None:
    """The frame that stops the board after ``last`` (the controller's last frame, encoded):
    the same outputs and gripper setpoints, every speed zero, command DISABLE.  None when
    ``last`` is not a command frame."""
    try:
        f = CommandFrame.decode(last)
    except FrameError:
        return None
    return replace(f, speeds=_ZERO6, command=BoardCommand.DISABLE, gripper_mode=0).encode()


def controller_stopped(pid: int) -> bool:
    """True when a thread of process ``pid`` is stopped (``kill -STOP``, Ctrl-Z, a debugger
    holding it: state T or t in /proc): it writes no frame until someone resumes it.  False
    when it runs, waits, is gone, or /proc cannot tell."""
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return False
    for tid in tasks:
        try:
            with open(f"/proc/{pid}/task/{tid}/stat", "rb") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat.rsplit(b")", 1)[-1].split()
        if fields and fields[0] in (b"T", b"t"):
            return True
    return False


class _Supervisor:
    """The supervisor process's state (see the module docstring)."""

    def __init__(self, sock: socket.socket, controller_pid: int, period_s: float, stall_s: float) -> None:
        self.sock = sock
        self.controller_pid = controller_pid
        self.period_s = period_s
        #: a stopped controller counts as frozen after this much silence, s
        self.stopped_after = STOPPED_PERIODS * period_s if period_s > 0 else 0.0
        self.stall_s = stall_s
        self.port_fd: int | None = None
        self.last: bytes | None = None
        self.last_t = 0.0
        self.tripped = False
        self.frames = 0

    def _write_stop(self) -> bool:
        fd, last = self.port_fd, self.last
        if fd is None or last is None:
            return False
        frame = stop_frame(last)
        if frame is None:
            return False
        try:
            for _ in range(STOP_COPIES):
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

    def _tell(self, msg: bytes) -> bool:
        """Send ``msg`` to the controller without ever blocking (a controller that reads
        nothing must not hold the supervisor up); False when the controller is gone."""
        try:
            self.sock.send(msg, socket.MSG_DONTWAIT)
        except BlockingIOError:
            pass
        except OSError:
            return False
        return True

    def _timeout(self, now: float) -> float | None:
        """How long to wait for the next message before judging the controller's silence
        (None: nothing to judge, no port or no frame yet, or the board already stopped)."""
        if self.port_fd is None or self.last is None or self.tripped:
            return None
        quiet = now - self.last_t
        checks: list[float] = []
        if self.stopped_after > 0:
            # first at the limit, then every period (the controller may be stopped later)
            checks.append(self.stopped_after - quiet if quiet < self.stopped_after else self.period_s)
        if self.stall_s > 0:
            checks.append(self.stall_s - quiet)
        return max(0.0, min(checks)) if checks else None

    def _judge_silence(self, now: float) -> str | None:
        """Why the controller's silence stops the board now, or None."""
        quiet = now - self.last_t
        if 0 < self.stopped_after <= quiet and controller_stopped(self.controller_pid):
            return (f"the controller (pid {self.controller_pid}) is stopped and wrote no frame for "
                    f"{quiet * 1000:.0f} ms (limit {self.stopped_after * 1000:.0f} ms, "
                    f"{STOPPED_PERIODS} periods)")
        if 0 < self.stall_s <= quiet:
            return (f"the controller (pid {self.controller_pid}) runs but wrote no frame for "
                    f"{quiet * 1000:.0f} ms (limit {self.stall_s * 1000:.0f} ms)")
        return None

    def run(self, scheduling: str) -> int:
        if not self._tell(b"R" + scheduling.encode()):
            return self._died()
        while True:
            ready, _, _ = select.select([self.sock], [], [], self._timeout(time.monotonic()))
            if not ready:
                why = self._judge_silence(time.monotonic())
                if why is not None:
                    self.tripped = True
                    ok = self._write_stop()
                    if not self._tell(b"T" + f"{why}: the stop supervisor {'disabled' if ok else 'could not disable'} "
                                             f"the board".encode()):
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
                self.frames += 1
                if self.frames % HEARTBEAT_FRAMES == 0 and not self._tell(b"A"):
                    return self._died()
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
        self._write_stop()
        self._drop_port()
        return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m parolkit.controller.supervisor --fd N --period P [--stall S] [--priority F]``
    (started by the controller, not by hand)."""
    ap = argparse.ArgumentParser(prog="parolkit-supervisor",
                                 description="stops the PAROL6 board when the controller dies")
    ap.add_argument("--fd", type=int, required=True, help="the Unix socket to the controller")
    ap.add_argument("--period", type=float, default=0.0,
                    help=f"the controller's loop period, s: a stopped controller that wrote no frame for "
                         f"{STOPPED_PERIODS} periods is frozen (0 = do not look)")
    ap.add_argument("--stall", type=float, default=0.0,
                    help="stop the board when a running controller wrote no frame for this long, s (0 = never)")
    ap.add_argument("--priority", type=int, default=0,
                    help="SCHED_FIFO priority to ask for (0 = nice -10 only)")
    args = ap.parse_args(argv)
    # a Ctrl-C or SIGTERM aimed at the controller's process group must not take the supervisor
    # down before the controller has stopped the board: it exits when the controller is gone
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    scheduling = raise_priority(args.priority)
    sock = socket.socket(fileno=args.fd)
    return _Supervisor(sock, os.getppid(), max(0.0, args.period), max(0.0, args.stall)).run(scheduling)


class StopSupervisor:
    """The controller's end: starts the supervisor process, feeds it, watches it.

    :meth:`sent` and :meth:`poll` are cheap and never block (the loop thread calls them every
    tick); :meth:`start` starts a process (again, after a loss) and is meant for a helper
    thread once the loop runs.  ``period_s``: the loop period (a stopped controller is frozen
    after :data:`STOPPED_PERIODS` of them; 0 = do not look); ``stall_s``: the limit for a
    running controller that writes nothing (s, 0 = none); ``priority``: the SCHED_FIFO
    priority it asks for (0 = nice -10 only).

    A supervisor is *lost* (:attr:`state` "dead", one LOST event from :meth:`poll`) when its
    socket reports EOF (it exited: the kernel closes the socket whatever killed it), when a
    send to it fails, when it answered none of the last :data:`SILENT_FRAMES_MAX` frames
    written (stopped, hung), when it did not report ready within :data:`START_TIMEOUT_S` or
    when it could not be started.
    """

    def __init__(self, period_s: float = 0.0, stall_s: float = 0.0, priority: int = 0) -> None:
        self.period_s = float(period_s)
        self.stall_s = float(stall_s)
        self.priority = int(priority)
        self._sock: socket.socket | None = None
        self._proc: subprocess.Popen[bytes] | None = None
        self._lock = threading.Lock()
        #: "off" (not started), "starting", "ready", "dead" (lost; see the class docstring)
        self.state = "off"
        #: frames not forwarded because the supervisor's socket was full
        self.frames_skipped = 0
        #: supervisors started after the first (each after a loss)
        self.restarts = 0
        self._started = False
        self._closed = False
        #: the supervisor's scheduling, as it reported it when ready
        self.scheduling = "unknown"
        self._started_at = 0.0
        #: frames written since the supervisor last said anything (see :meth:`poll`)
        self._silent_frames = 0
        #: a loss :meth:`poll` has not reported yet
        self._lost: str | None = None

    @property
    def pid(self) -> int | None:
        """The supervisor process's id (None before the first start)."""
        proc = self._proc
        return proc.pid if proc is not None else None

    def start(self) -> bool:
        """Start a supervisor process; the previous one, if any, is killed and reaped first (a
        stopped one must never wake up and write to the port).  False when it could not be
        started: :meth:`poll` then reports the loss (or after :meth:`close`: a restart that was
        under way when the controller shut down starts nothing)."""
        if self._closed:
            return False
        self._retire()
        parent, child = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            proc = subprocess.Popen(
                [sys.executable, "-m", "parolkit.controller.supervisor", "--fd", str(child.fileno()),
                 "--period", repr(self.period_s), "--stall", repr(self.stall_s), "--priority", str(self.priority)],
                pass_fds=(child.fileno(),), stdin=subprocess.DEVNULL, start_new_session=True)
        except OSError as exc:
            parent.close()
            with self._lock:
                self._proc = None
                self._gone(f"could not be started: {exc}")
            return False
        finally:
            child.close()
        parent.setblocking(False)
        with self._lock:
            if self._closed:  # closed while this one started
                proc.kill()
                proc.wait()
                parent.close()
                return False
            if self._started:
                self.restarts += 1
            self._started = True
            self._sock, self._proc = parent, proc
            self._started_at = time.monotonic()
            self._silent_frames = 0
            self._lost = None
            self.state = "starting"
        return True

    def _retire(self) -> None:
        with self._lock:
            sock, self._sock = self._sock, None
            proc = self._proc
        if sock is not None:
            sock.close()
        if proc is not None and proc.poll() is None:
            proc.kill()
            try:
                proc.wait(1.0)
            except subprocess.TimeoutExpired:
                log.error("the stop supervisor (pid %d) did not exit after SIGKILL", proc.pid)

    def _exit_status(self) -> str:
        """' (killed by signal N)' or ' (exit code N)' of the supervisor that closed its socket
        ('' when unknown): its socket closes a moment before it can be reaped, so it gets that
        moment (at most 2 ms, once per loss)."""
        proc = self._proc
        if proc is None:
            return ""
        try:
            code = proc.wait(0.002)
        except subprocess.TimeoutExpired:
            return ""
        return f" (killed by signal {-code})" if code < 0 else f" (exit code {code})"

    def _gone(self, how: str) -> None:
        """(under the lock) The supervisor is lost (``how``: what happened to it)."""
        self.state = "dead"
        pid = self.pid
        self._lost = f"the stop supervisor{f' (pid {pid})' if pid is not None else ''} {how}"
        log.error("%s: a crash of the controller would leave the board running its last command", self._lost)

    def _send(self, data: bytes, fds: tuple[int, ...] = ()) -> None:
        with self._lock:
            sock = self._sock
            if sock is None or self.state == "dead":
                return
            try:
                if fds:
                    socket.send_fds(sock, [data], list(fds))
                else:
                    sock.send(data)
            except BlockingIOError:
                self.frames_skipped += 1
            except OSError as exc:
                if fds and exc.errno == errno.EBADF:
                    # the port closed while it was being handed over (the link is being lost):
                    # the supervisor is fine, the reconnect hands it the new port
                    log.warning("the port closed before the stop supervisor got it: %s", exc)
                elif exc.errno in (errno.EPIPE, errno.ECONNRESET):  # its end closed: it exited
                    self._gone("exited" + self._exit_status())
                else:
                    self._gone(f"cannot be reached ({exc})")

    def sent(self, frame: bytes) -> None:
        """(loop thread) The controller wrote ``frame`` (56 encoded bytes)."""
        self._send(b"F" + frame)
        self._silent_frames += 1

    def port_opened(self, fd: int | None) -> None:
        """The link is (re)opened on file descriptor ``fd`` (None: a link with no descriptor)."""
        if fd is None:
            self._send(b"X")
        else:
            self._send(b"P", (fd,))

    def port_closed(self) -> None:
        self._send(b"X")

    def poll(self) -> list[SupervisorEvent]:
        """(loop thread) Everything the supervisor said since the last call, and its loss
        (once) when it is gone."""
        events: list[SupervisorEvent] = []
        with self._lock:
            sock = self._sock
            while sock is not None and self.state != "dead":
                try:
                    msg = sock.recv(512)
                except BlockingIOError:
                    break
                except OSError:
                    msg = b""
                if not msg:
                    self._gone("exited" + self._exit_status())
                    break
                self._silent_frames = 0
                kind, text = msg[:1], msg[1:].decode(errors="replace")
                if kind == b"R":
                    self.state = "ready"
                    self.scheduling = text
                    events.append(SupervisorEvent(SupervisorEventKind.READY, text))
                elif kind == b"T":
                    events.append(SupervisorEvent(SupervisorEventKind.STOPPED, text))
            if self.state == "ready" and self._silent_frames > SILENT_FRAMES_MAX:
                self._gone(f"answered none of the last {self._silent_frames} frames (stopped or hung)")
            elif self.state == "starting" and time.monotonic() - self._started_at > START_TIMEOUT_S:
                self._gone(f"was not ready {START_TIMEOUT_S:g} s after its start")
            if self._lost is not None:
                events.append(SupervisorEvent(SupervisorEventKind.LOST, self._lost))
                self._lost = None
        return events

    def close(self, timeout: float = 1.0) -> None:
        """Clean shutdown: the controller has stopped the board itself."""
        self._send(b"Q")
        with self._lock:
            self._closed = True
            sock, self._sock = self._sock, None
            proc = self._proc
            self.state = "off"
        if sock is not None:
            sock.close()
        if proc is not None:
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(1.0)


if __name__ == "__main__":  # pragma: no cover - run as a process
    sys.exit(main())
