"""Control channel of a running ``parolkit board-sim``: text commands over a Unix datagram socket.

One command per datagram; the reply is one datagram starting with ``ok`` or ``error:``.

==============================  ============================================================
command                         effect
==============================  ============================================================
``estop 1`` / ``estop 0``       press / release the E-stop (IO bit 0x08 reads 0 / 1)
``in1 1`` / ``in2 0``           set digital input IN1 / IN2
``object 30`` / ``object none`` place a 30 mm object between the gripper jaws / remove it
``unplug`` / ``replug``         the link disappears (pty closed, symlink removed) / returns
``errors temp J3 J4``           report temperature-error bits for J3 and J4 (opt-in)
``errors pos J1``               report position-error bits for J1
``errors clear``                back to the stock constant error bytes
``faults drop=0.01 corrupt=0.01 delay=0.05 silent=0 dir=both``   link faults (any subset)
``faults clear``                perfect link again
``powercycle``                  counters 0, homed 0x03, enabled (joints stay where they are)
``rewrite 101 100``             the next command frame with code 101 reaches the board as 100
                                (a one-shot link fault: ENABLE turned into HOME)
``status``                      ``ok {json}`` with positions, homed, IO, gripper, faults ...
``frames since=T after=N``      ``ok {json}`` the command frames received after monotonic
``frames last=N limit=N``       time T / sequence number N (the newest N, at most N); needs
                                the frame log (``board-sim --frame-log SIZE``)
``help``                        the list of commands
==============================  ============================================================
"""

from __future__ import annotations

import json
import math
import os
import socket
import threading
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict

from parolkit.board.emulator import BoardEmulator
from parolkit.board.faults import faults_from_options
from parolkit.errors import ParolkitError, ParolkitValueError

if TYPE_CHECKING:  # pragma: no cover
    from parolkit.board.pty_server import CommandRewrite, FrameLog

__all__ = ["execute_control", "ControlServer", "send_control", "ControlError", "CONTROL_HELP"]

CONTROL_HELP = (
    "estop 0|1; in1 0|1; in2 0|1; object WIDTH_MM|none; unplug; replug; "
    "errors temp|pos J1..J6 ...; errors clear; "
    "faults [drop=P] [corrupt=P] [delay=S] [silent=0|1] [dir=to_board|from_board|both]; "
    "faults clear; powercycle; rewrite OLD_CODE NEW_CODE; status; "
    "frames [since=MONOTONIC_S] [after=SEQ] [last=N] [limit=N] (with --frame-log); help"
)


class ControlError(ParolkitError):
    """The control channel could not be reached or answered with an error."""


def _flag(word: str, what: str) -> bool:
    if word in ("1", "on", "true", "pressed"):
        return True
    if word in ("0", "off", "false", "released"):
        return False
    raise ParolkitValueError(f"{what}: expected 0 or 1, got {word!r}")


def execute_control(emu: BoardEmulator, text: str, *, frame_log: FrameLog | None = None,
                    rewrite: CommandRewrite | None = None) -> str:
    """Run one control command on ``emu``; returns the reply text (never raises for bad input).

    ``frame_log`` (the pty server's :class:`~parolkit.board.pty_server.FrameLog`) answers
    ``frames``; without it ``frames`` replies with an error saying how to switch it on.
    ``rewrite`` (the pty server's one-shot command rewrite) serves ``rewrite``.
    """
    words = text.strip().split()
    if not words:
        return "error: empty command (try 'help')"
    cmd, args = words[0].lower(), words[1:]
    try:
        if cmd == "help":
            return "ok " + CONTROL_HELP
        if cmd == "status":
            return "ok " + json.dumps(emu.describe())
        if cmd == "frames":
            return _frames(frame_log, args)
        if cmd == "rewrite":
            if rewrite is None:
                return "error: 'rewrite' needs the pty server (board-sim)"
            if len(args) != 2 or not all(a.isdigit() for a in args):
                return "error: usage: rewrite OLD_CODE NEW_CODE (decimal command codes, e.g. rewrite 101 100)"
            rewrite.arm(int(args[0]), int(args[1]))
            return "ok"
        if cmd in ("estop", "in1", "in2"):
            if len(args) != 1:
                return f"error: '{cmd}' needs one argument 0 or 1"
            value = _flag(args[0].lower(), cmd)
            if cmd == "estop":
                emu.set_estop(value)
            else:
                emu.set_input(int(cmd[2]), value)
            return "ok"
        if cmd == "object":
            if len(args) != 1:
                return "error: 'object' needs one argument: width in mm, or 'none'"
            if args[0].lower() in ("none", "off", "remove"):
                emu.place_object(None)
                return "ok"
            try:
                width = float(args[0])
            except ValueError:
                return f"error: object width must be a number of mm, got {args[0]!r}"
            emu.place_object(width)
            return "ok"
        if cmd in ("unplug", "replug", "powercycle"):
            if args:
                return f"error: '{cmd}' takes no arguments"
            {"unplug": emu.unplug, "replug": emu.replug, "powercycle": emu.power_cycle}[cmd]()
            return "ok"
        if cmd == "errors":
            if args == ["clear"]:
                emu.clear_errors()
                return "ok"
            if len(args) < 1 or args[0].lower() not in ("temp", "temperature", "pos", "position"):
                return "error: usage: errors temp|pos J1..J6 ... | errors clear"
            temp, pos = emu.error_injection
            joints = [a.upper() for a in args[1:]]
            from parolkit.board.emulator import _joint_mask  # one parser for joint names

            mask = _joint_mask(joints, "errors")
            if args[0].lower().startswith("temp"):
                temp = mask
            else:
                pos = mask
            emu.inject_errors(temperature=_mask_to_joints(temp), position=_mask_to_joints(pos))
            return "ok"
        if cmd == "faults":
            if args == ["clear"]:
                emu.clear_faults()
                return "ok"
            kw: dict[str, object] = {}
            direction = "both"
            names = {"drop": "drop_rate", "corrupt": "corrupt_rate", "delay": "delay_s"}
            for a in args:
                key, sep, val = a.partition("=")
                if not sep:
                    return f"error: faults arguments are key=value, got {a!r}"
                key = key.lower()
                if key in names:
                    try:
                        kw[names[key]] = float(val)
                    except ValueError:
                        return f"error: faults {key} must be a number, got {val!r}"
                elif key == "silent":
                    kw["silent"] = _flag(val.lower(), "faults silent")
                elif key == "dir":
                    direction = val
                else:
                    return f"error: unknown faults key {key!r} (drop, corrupt, delay, silent, dir)"
            emu.set_faults(faults_from_options(kw), direction=direction)
            return "ok"
    except ParolkitError as exc:
        return f"error: {exc}"
    return f"error: unknown command {cmd!r} (try 'help')"


class _FrameQuery(TypedDict, total=False):
    """The keywords of :meth:`FrameLog.query` a ``frames`` command gave."""

    since: float
    after: int
    last: int
    limit: int


def _frames(frame_log: FrameLog | None, args: list[str]) -> str:
    if frame_log is None:
        return "error: the frame log is off (start board-sim with --frame-log SIZE)"
    kw: _FrameQuery = {}
    for a in args:
        key, sep, val = a.partition("=")
        key = key.lower()
        if not sep or key not in ("since", "after", "last", "limit"):
            return f"error: frames arguments are since=S, after=SEQ, last=N, limit=N; got {a!r}"
        if key == "since":
            try:
                t = float(val)
            except ValueError:
                t = math.nan
            if not math.isfinite(t):
                return f"error: frames since must be a time.monotonic() value in s, got {val!r}"
            kw["since"] = t
        else:
            try:
                n = int(val)
            except ValueError:
                return f"error: frames {key} must be an integer, got {val!r}"
            if key == "after" and n < 0:
                return f"error: frames after must be a sequence number >= 0, got {n}"
            if key == "after":
                kw["after"] = n
            elif key == "last":
                kw["last"] = n
            else:
                kw["limit"] = n
    return "ok " + json.dumps(frame_log.query(**kw), separators=(",", ":"))


def _mask_to_joints(mask: int) -> list[int]:
    return [i + 1 for i in range(6) if mask & (0x80 >> i)]


class ControlServer:
    """Serves :func:`execute_control` on a Unix datagram socket at ``path`` (in a thread);
    ``frame_log`` answers the ``frames`` command (see :func:`execute_control`)."""

    def __init__(self, emulator: BoardEmulator, path: str | os.PathLike[str], *,
                 frame_log: FrameLog | None = None, rewrite: CommandRewrite | None = None) -> None:
        if not isinstance(emulator, BoardEmulator):
            raise ParolkitValueError(
                f"emulator must be a BoardEmulator, got {type(emulator).__name__}")
        self.emulator = emulator
        self.frame_log = frame_log
        self.rewrite = rewrite
        self.path = Path(path)
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    def start(self) -> ControlServer:
        if self.path.exists() or self.path.is_symlink():
            if not self.path.is_socket():
                raise ControlError(f"control path {self.path} exists and is not a socket")
            try:
                send_control(self.path, "help", timeout_s=0.3)
            except ControlError:
                self.path.unlink()  # a stale socket from a crashed run
            else:
                raise ControlError(f"another board-sim already answers on {self.path}")
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        try:
            sock.bind(str(self.path))
        except OSError as exc:
            sock.close()
            raise ControlError(f"cannot bind control socket {self.path}: {exc}") from exc
        sock.settimeout(0.2)
        self._sock = sock
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="parolkit-board-ctl", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        sock = self._sock
        assert sock is not None
        while not self._stop.is_set():
            try:
                data, addr = sock.recvfrom(4096)
            except TimeoutError:
                continue
            except OSError:
                break
            reply = execute_control(self.emulator, data.decode("utf-8", errors="replace"),
                                    frame_log=self.frame_log, rewrite=self.rewrite)
            if addr:
                try:
                    sock.sendto(reply.encode(), addr)
                except OSError:
                    pass  # the asker went away

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        try:
            if self.path.is_socket():
                self.path.unlink()
        except OSError:
            pass

    def __enter__(self) -> ControlServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def send_control(path: str | os.PathLike[str], text: str, *, timeout_s: float = 2.0) -> str:
    """Send one command to a running board-sim's control socket; returns its reply text.

    Raises :class:`ControlError` when nobody listens at ``path`` or no reply came in time.
    """
    if not isinstance(text, str) or not text.strip():
        raise ParolkitValueError(f"text must be a non-empty command string, got {text!r}")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    try:
        sock.bind("")  # Linux autobind: an abstract address the server can answer to
        sock.settimeout(timeout_s)
        try:
            sock.sendto(text.encode(), str(path))
        except OSError as exc:
            raise ControlError(f"no board-sim control socket at {path}: {exc}") from exc
        try:
            data, _ = sock.recvfrom(65536)
        except TimeoutError:
            raise ControlError(f"no reply from the control socket {path} within {timeout_s} s") from None
        return data.decode("utf-8", errors="replace")
    finally:
        sock.close()
