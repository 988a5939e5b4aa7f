"""Serve an emulated board on a pseudo-terminal, so any PAROL6 PC software can open it.

:class:`PtyBoardServer` creates a pty (raw mode, no echo), points a symlink (``link_path``,
e.g. ``/tmp/p6``) at its slave device and moves bytes between the master side and a
:class:`~parolkit.board.BoardEmulator` in a thread.  pyserial opens the link path at
3,000,000 baud like a real ``/dev/ttyACM0``.

Unplug / replug (``emulator.unplug()``): the server closes the pty and removes the symlink, so
the PC side sees EOF / EIO exactly as when a USB cable is pulled; replug creates a NEW pty and
re-points the symlink (like a re-enumerated USB device): the PC must re-open the path.

Frame log (opt-in, ``frame_log_size=N``): :class:`FrameLog` keeps the last N command frames
that arrived on the pty, each with its ``time.monotonic()`` receive time (CLOCK_MONOTONIC,
the same clock in every process on the machine) and its command code, so a test in another
process can tell which frame the board received after a moment it noted itself.  Frames are
recorded as they arrive on the wire, before any injected link fault; the board's behaviour
does not change.

Exchange log (opt-in, ``exchange_log=PATH``): :class:`ExchangeLog` writes one JSON line per
command frame that arrived on the pty (as sent, before any injected fault) and one per frame
the board executed (as executed, after the faults) with the TRUE status frame it answered
(before the faults corrupt it on its way back): what a test needs to tell corrupted replies
from what the board really reported, and corrupted commands from what was sent.
"""

from __future__ import annotations

import json
import os
import select
import threading
import time
import tty
from collections import deque
from pathlib import Path
from typing import IO, Any

from parolkit.board.emulator import BoardEmulator, ClockMode
from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.protocol.frames import COMMAND_LEN, CommandFrame, StatusFrame
from parolkit.protocol.stream import FrameParser
from parolkit.transport.base import LinkLostError

__all__ = ["PtyBoardServer", "PtyServerError", "FrameLog", "ExchangeLog", "CommandRewrite", "FRAME_LOG_MAX",
           "FRAME_QUERY_MAX"]

#: largest frame log a board-sim keeps (frames; 10 minutes at 100 Hz take 60,000)
FRAME_LOG_MAX = 100_000
#: most frames one :meth:`FrameLog.query` returns (keeps a control reply under 64 KiB)
FRAME_QUERY_MAX = 2000
#: offset of the command byte in a 56-byte PC -> board frame (header 4 + payload 36)
_COMMAND_OFFSET = 4 + 36


class PtyServerError(ParolkitError):
    """The pty or its symlink could not be set up (the message says which path and why)."""


def _make_pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)  # raw: no echo, no line discipline, 8 bits
    os.set_blocking(master, False)
    return master, slave, os.ttyname(slave)


def _point_symlink(link: Path, target: str) -> None:
    if link.exists() or link.is_symlink():
        if not link.is_symlink():
            raise PtyServerError(
                f"link path {link} exists and is not a symlink: refusing to replace it")
    tmp = link.with_name(f".{link.name}.{os.getpid()}.tmp")
    try:
        if tmp.is_symlink():
            tmp.unlink()
        os.symlink(target, tmp)
        os.replace(tmp, link)
    except OSError as exc:
        raise PtyServerError(f"cannot create symlink {link} -> {target}: {exc}") from exc


class _RawCommandFrame:
    """Frame type for the log's parser: keeps the 56 bytes instead of decoding every field."""

    @staticmethod
    def decode(raw: bytes) -> bytes:
        return raw


class FrameLog:
    """The last ``size`` command frames received, as ``(seq, t, command)``.

    ``seq`` counts every frame since the log was made (1 = the first), so a gap between two
    queries shows as a jump; ``t`` is ``time.monotonic()`` when the read that completed the
    frame returned (s); ``command`` is the frame's command byte (``BoardCommand`` values:
    101 ENABLE, 102 DISABLE, 156 GO TO, ...).  Frames are found by the board's own rule
    (start bytes, LEN 52, end bytes ``01 02``), so garbage never shows up as a frame.
    Thread-safe: the pty thread feeds it, the control thread queries it.
    """

    def __init__(self, size: int) -> None:
        if isinstance(size, bool) or not isinstance(size, int) or not 1 <= size <= FRAME_LOG_MAX:
            raise ParolkitValueError(f"frame log size must be an integer 1..{FRAME_LOG_MAX}, got {size!r}")
        self.size = size
        self._ring: deque[tuple[int, float, int]] = deque(maxlen=size)
        # FrameParser is typed for the two decoded frame types; this one yields the raw bytes
        # (_RawCommandFrame.decode), which its type parameter cannot express: Any
        self._parser: FrameParser[Any] = FrameParser(_RawCommandFrame, COMMAND_LEN, None)
        self._lock = threading.Lock()
        #: frames recorded since the log was made (the newest frame's ``seq``)
        self.total = 0

    def feed(self, data: bytes, t: float) -> None:
        """Bytes that arrived at ``t`` (``time.monotonic()``): record every frame they complete."""
        with self._lock:
            for raw in self._parser.iter_feed(data):
                self.total += 1
                self._ring.append((self.total, t, raw[_COMMAND_OFFSET]))

    def new_stream(self) -> None:
        """A new pty: forget a partial frame of the old one (recorded frames stay)."""
        with self._lock:
            self._parser.reset()

    def query(self, *, since: float | None = None, after: int | None = None, last: int | None = None,
              limit: int = FRAME_QUERY_MAX) -> dict[str, object]:
        """Frames oldest first: received after time ``since`` (s, monotonic) and after sequence
        number ``after``; with ``last`` only the newest ``last`` of those; at most ``limit``.

        Returns ``{"size", "total", "oldest", "more", "frames": [[seq, t, command], ...]}``:
        ``oldest`` is the oldest ``seq`` still held (frames before it were overwritten) and
        ``more`` says that frames after the last one returned match too (ask again with
        ``after`` = its ``seq``).
        """
        for name, v in (("last", last), ("limit", limit)):
            if v is not None and (isinstance(v, bool) or not isinstance(v, int)
                                  or not 1 <= v <= FRAME_QUERY_MAX):
                raise ParolkitValueError(f"{name} must be an integer 1..{FRAME_QUERY_MAX}, got {v!r}")
        with self._lock:
            frames = list(self._ring)
            total = self.total
        oldest = frames[0][0] if frames else total + 1
        if after is not None:
            frames = [f for f in frames if f[0] > after]
        if since is not None:
            frames = [f for f in frames if f[1] > since]
        if last is not None:
            frames = frames[-last:]
        more = len(frames) > limit
        frames = frames[:limit]
        return {
            "size": self.size,
            "total": total,
            "oldest": oldest,
            "more": more,
            "frames": [[seq, round(t, 6), cmd] for seq, t, cmd in frames],
        }


class ExchangeLog:
    """JSON lines written to ``path`` as things happen (``t``: ``time.monotonic()``, s):

    * ``{"k": "in", "t": T, "n": N, "raw": HEX}``: the Nth command frame that arrived on the
      pty, its 56 bytes as sent (before any injected fault);
    * ``{"k": "ex", "t": T, "n": N, "raw": HEX, "cmd": C, "reply": {...}}``: the Nth frame the
      board executed, its 56 bytes as executed (after the faults: ``raw`` differs from the
      "in" line of the same frame when a fault changed it), and the status frame it answered,
      as the board sent it (before the faults): ``{"p": positions, "v": speeds, "homed",
      "io", "xtr", "timing", "raw": HEX}``;
    * ``{"k": "out", "t": T, "raw": HEX}``: bytes written to the pty (after the faults): what
      the PC read, to tell which replies arrived intact.

    A frame whose bytes were damaged so that the board did not take it has an "in" line and
    no "ex" line.  Thread-safe (the pty thread feeds "in", the board's lock holder "ex")."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        target = Path(path)
        if not target.parent.is_dir():
            raise ParolkitValueError(f"exchange log {target}: directory {target.parent} does not exist")
        try:
            self._file: IO[str] | None = open(target, "w", encoding="utf-8", buffering=1)
        except OSError as exc:
            raise ParolkitValueError(f"cannot write the exchange log {target}: {exc}") from exc
        self.path = target
        self._parser: FrameParser[Any] = FrameParser(_RawCommandFrame, COMMAND_LEN, None)
        self._lock = threading.Lock()
        self.received = 0
        self.executed = 0

    def _write(self, obj: dict[str, object]) -> None:
        f = self._file
        if f is not None:
            f.write(json.dumps(obj, separators=(",", ":")) + "\n")

    def feed(self, data: bytes, t: float) -> None:
        """Bytes that arrived on the pty at ``t``: a line per command frame they complete."""
        with self._lock:
            for raw in self._parser.iter_feed(data):
                self.received += 1
                self._write({"k": "in", "t": round(t, 6), "n": self.received, "raw": raw.hex()})

    def exchange(self, frame: CommandFrame, reply: StatusFrame) -> None:
        """The board executed ``frame`` and answered ``reply`` (an emulator exchange listener)."""
        t = time.monotonic()
        with self._lock:
            self.executed += 1
            self._write({
                "k": "ex", "t": round(t, 6), "n": self.executed, "raw": frame.encode().hex(),
                "cmd": int(frame.command),
                "reply": {"p": list(reply.positions), "v": list(reply.speeds), "homed": reply.homed,
                          "io": reply.io, "xtr": reply.xtr, "timing": reply.timing,
                          "raw": reply.encode().hex()},
            })

    def sent_to_pc(self, data: bytes, t: float) -> None:
        """Bytes the board side wrote to the pty at ``t``."""
        with self._lock:
            self._write({"k": "out", "t": round(t, 6), "raw": data.hex()})

    def new_stream(self) -> None:
        with self._lock:
            self._parser.reset()

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None


class CommandRewrite:
    """A deliberate one-shot link fault: the next command frame whose command byte is
    ``old`` reaches the board with ``new`` instead (e.g. 101 ENABLE -> 100 HOME, the bit flip
    a corrupted byte can make).  Frames are recognised by the board's own rule (start bytes,
    LEN 52, end bytes 01 02); while armed, the tail of a chunk that may be the start of a
    frame is held back until the rest arrives (only then)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._armed: tuple[int, int] | None = None
        self._held = b""
        #: frames rewritten so far
        self.done = 0

    def arm(self, old: int, new: int) -> None:
        for name, v in (("old", old), ("new", new)):
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 255:
                raise ParolkitValueError(f"rewrite: {name} command code must be 0..255, got {v!r}")
        with self._lock:
            self._armed = (old, new)

    @property
    def armed(self) -> bool:
        return self._armed is not None

    def reset(self) -> None:
        """A new pty: forget a held partial frame of the old one (an armed rewrite stays)."""
        with self._lock:
            self._held = b""

    def apply(self, data: bytes) -> bytes:
        """``data`` as the board should get it (possibly with a tail held back)."""
        with self._lock:
            if self._armed is None and not self._held:
                return data
            buf = bytearray(self._held + data)
            self._held = b""
            if self._armed is None:
                return bytes(buf)
            old, new = self._armed
            size = 4 + COMMAND_LEN
            i = 0
            while True:
                i = buf.find(b"\xff\xff\xff" + bytes((COMMAND_LEN,)), i)
                if i < 0:
                    break
                if i + size > len(buf):
                    self._held = bytes(buf[i:])  # the rest of this frame comes later
                    del buf[i:]
                    break
                if buf[i + size - 2:i + size] == b"\x01\x02" and buf[i + _COMMAND_OFFSET] == old:
                    buf[i + _COMMAND_OFFSET] = new
                    self._armed = None
                    self.done += 1
                    break
                i += 1
            return bytes(buf)


class PtyBoardServer:
    """Bridges ``emulator`` to a pty whose slave is symlinked at ``link_path``.

    Use as a context manager or call :meth:`start` / :meth:`stop`.  A real-time emulator's
    loop is started if it is not running.  ``device`` is the current slave path
    (``/dev/pts/N``); ``link_path`` always points at it while plugged.  With
    ``frame_log_size=N`` the last N command frames received are kept in ``frame_log``
    (:class:`FrameLog`; ``None`` without).
    """

    def __init__(self, emulator: BoardEmulator, link_path: str | os.PathLike[str], *,
                 frame_log_size: int = 0, exchange_log: str | os.PathLike[str] | None = None) -> None:
        if not isinstance(emulator, BoardEmulator):
            raise ParolkitValueError(
                f"emulator must be a BoardEmulator, got {type(emulator).__name__}")
        if not isinstance(link_path, (str, os.PathLike)) or not str(link_path):
            raise ParolkitValueError(f"link_path must be a file path, got {link_path!r}")
        self.emulator = emulator
        self.link_path = Path(link_path)
        if not self.link_path.parent.is_dir():
            raise ParolkitValueError(
                f"link_path {self.link_path}: directory {self.link_path.parent} does not exist")
        self._lock = threading.Lock()
        self._master: int | None = None
        self._slave: int | None = None
        self.device: str | None = None
        self._wake_r, self._wake_w = -1, -1
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._want_plugged = emulator.plugged
        self._started_loop = False
        #: bytes moved (monotonic): PC -> board, board -> PC
        self.bytes_in = 0
        self.bytes_out = 0
        #: board output lost because the PC side did not read (pty buffer full)
        self.bytes_discarded = 0
        if isinstance(frame_log_size, bool) or not isinstance(frame_log_size, int) or frame_log_size < 0:
            raise ParolkitValueError(
                f"frame_log_size must be 0 (off) or a number of frames 1..{FRAME_LOG_MAX}, got {frame_log_size!r}")
        #: the received command frames (opt-in), or None
        self.frame_log: FrameLog | None = FrameLog(frame_log_size) if frame_log_size else None
        #: every frame sent and executed, and the true replies (opt-in), or None
        self.exchange_log: ExchangeLog | None = ExchangeLog(exchange_log) if exchange_log is not None else None
        #: one-shot command-byte rewrite (a deliberate link fault, see :meth:`rewrite_next`)
        self.rewrite = CommandRewrite()

    # ---- lifecycle ---------------------------------------------------------------------------
    def start(self) -> PtyBoardServer:
        if self._thread is not None:
            return self
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        if self.emulator.plugged:
            self._open_pty()
        if self.emulator.clock is ClockMode.REALTIME and not self.emulator.running:
            self.emulator.start()
            self._started_loop = True
        self.emulator.add_link_listener(self._on_link)
        if self.exchange_log is not None:
            self.emulator.add_exchange_listener(self.exchange_log.exchange)
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="parolkit-pty-server", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving, close the pty and remove the symlink (idempotent)."""
        if self._thread is None:
            return
        self._stop.set()
        self._wake()
        self._thread.join(timeout=2.0)
        self._thread = None
        self.emulator.remove_link_listener(self._on_link)
        if self.exchange_log is not None:
            self.emulator.remove_exchange_listener(self.exchange_log.exchange)
            self.exchange_log.close()
        self._close_pty()
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass
        self._wake_r = self._wake_w = -1
        if self._started_loop:
            self.emulator.stop()
            self._started_loop = False

    def __enter__(self) -> PtyBoardServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def serve_forever(self, stop: threading.Event) -> None:
        """Start (if needed) and block until ``stop`` is set; then stop."""
        self.start()
        try:
            while not stop.wait(0.2):
                pass
        finally:
            self.stop()

    def rewrite_next(self, old: int, new: int) -> None:
        """The next command frame with command byte ``old`` reaches the board as ``new``
        (after the frame and exchange logs saw it as sent)."""
        self.rewrite.arm(old, new)

    # ---- pty ---------------------------------------------------------------------------------
    def _open_pty(self) -> None:
        master, slave, name = _make_pty()
        try:
            _point_symlink(self.link_path, name)
        except PtyServerError:
            os.close(master)
            os.close(slave)
            raise
        with self._lock:
            self._master, self._slave, self.device = master, slave, name
        if self.frame_log is not None:
            self.frame_log.new_stream()
        if self.exchange_log is not None:
            self.exchange_log.new_stream()
        self.rewrite.reset()

    def _close_pty(self) -> None:
        with self._lock:
            fds = (self._master, self._slave)
            self._master = self._slave = None
            self.device = None
        for fd in fds:
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        try:
            if self.link_path.is_symlink():
                self.link_path.unlink()
        except OSError:
            pass

    def _on_link(self, plugged: bool) -> None:
        self._want_plugged = plugged
        self._wake()

    def _wake(self) -> None:
        if self._wake_w >= 0:
            try:
                os.write(self._wake_w, b"x")
            except OSError:
                pass

    # ---- the bridge ----------------------------------------------------------------------------
    def _run(self) -> None:
        emu = self.emulator
        while not self._stop.is_set():
            # follow unplug / replug
            if not self._want_plugged and self._master is not None:
                self._close_pty()
            elif self._want_plugged and self._master is None:
                try:
                    self._open_pty()
                except PtyServerError:
                    self._stop.wait(0.1)
                    continue
            master = self._master
            due = emu.next_output_due() if master is not None else None
            timeout = 0.1 if due is None else 0.0005
            fds = [self._wake_r] + ([master] if master is not None else [])
            try:
                ready, _, _ = select.select(fds, [], [], timeout)
            except (OSError, ValueError):
                continue  # an fd was closed under us by unplug: loop and re-evaluate
            if self._wake_r in ready:
                try:
                    os.read(self._wake_r, 4096)
                except OSError:
                    pass
            if master is None:
                continue
            try:
                if master in ready:
                    data = os.read(master, 65536)
                    if data:
                        if self.frame_log is not None:
                            self.frame_log.feed(data, time.monotonic())
                        if self.exchange_log is not None:
                            self.exchange_log.feed(data, time.monotonic())
                        self.bytes_in += len(data)
                        data = self.rewrite.apply(data)
                        if data:
                            emu.write(data)
                out = emu.read()
                if out:
                    if self.exchange_log is not None:
                        self.exchange_log.sent_to_pc(out, time.monotonic())
                    self._write_all(master, out)
            except BlockingIOError:
                continue
            except LinkLostError:
                continue  # unplugged meanwhile: the next pass closes the pty
            except OSError:
                # EIO: nobody has the slave open right now (we hold it, so rare); keep serving
                self._stop.wait(0.001)

    def _write_all(self, fd: int, data: bytes) -> None:
        # A PC that never reads fills the pty buffer; like a USB CDC device with a full host
        # buffer, the board's further output is lost (counted), the board never blocks.
        view = memoryview(data)
        while view:
            try:
                n = os.write(fd, view)
            except BlockingIOError:
                if not select.select([], [fd], [], 0.005)[1]:
                    self.bytes_discarded += len(view)
                    return
                continue
            self.bytes_out += n
            view = view[n:]
