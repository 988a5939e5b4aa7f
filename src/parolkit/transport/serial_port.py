"""A real serial link (USB CDC board or the emulator's pseudo-terminal) over pyserial."""

from __future__ import annotations

import errno
import math
import os
import select
import time

from parolkit.errors import ParolkitValueError
from parolkit.transport.base import LinkLostError, Transport, TransportError

__all__ = ["SerialTransport", "DEFAULT_BAUD"]

#: The PAROL6 board's nominal baud rate (over USB CDC the value is nominal).
DEFAULT_BAUD = 3_000_000

#: The clock a write's deadline is read from (a test replaces it to stall the process in between).
_clock = time.monotonic

_RETRY_ERRNOS = (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR)


class SerialTransport(Transport):
    """pyserial link: ``SerialTransport("/dev/ttyACM0")`` or the path of ``parolkit board-sim``.

    * :meth:`read` never blocks (pyserial ``timeout=0``) and returns ``b""`` when nothing came.
    * :meth:`write` gives up when bytes are still left after ``write_timeout_s`` seconds
      (``TransportError``); a write that went through is never a timeout, however long the process
      was stalled meanwhile.
    * A vanished device (cable pulled, pty closed: read returns EOF / EIO) raises
      :class:`LinkLostError`; the port is then closed and :meth:`open` reconnects.
    """

    def __init__(self, port: str, baud: int = DEFAULT_BAUD, *, write_timeout_s: float = 0.1,
                 exclusive: bool = True) -> None:
        if not isinstance(port, str) or not port:
            raise ParolkitValueError(f"port must be a non-empty device path, got {port!r}")
        if isinstance(baud, bool) or not isinstance(baud, int) or not 300 <= baud <= 12_000_000:
            raise ParolkitValueError(f"baud must be an integer in 300..12000000, got {baud!r}")
        if isinstance(write_timeout_s, bool) or not isinstance(write_timeout_s, (int, float)) \
                or math.isnan(write_timeout_s) or not 0.001 <= write_timeout_s <= 10.0:
            raise ParolkitValueError(
                f"write_timeout_s must be a number in 0.001..10 s, got {write_timeout_s!r}")
        self.port = port
        self.baud = baud
        self.write_timeout_s = float(write_timeout_s)
        self.exclusive = bool(exclusive)
        self._ser = None  # serial.Serial | None

    @property
    def description(self) -> str:
        return f"{self.port} @ {self.baud}"

    @property
    def is_open(self) -> bool:
        return self._ser is not None and self._ser.is_open

    def open(self) -> None:
        import serial  # pyserial

        self.close()
        try:
            ser = serial.Serial()
            ser.port = self.port
            ser.baudrate = self.baud
            ser.timeout = 0
            ser.write_timeout = self.write_timeout_s
            ser.exclusive = self.exclusive
            ser.open()
        except (serial.SerialException, OSError, ValueError) as exc:
            raise TransportError(f"cannot open serial port {self.port} at {self.baud} baud: {exc}") from exc
        self._ser = ser

    def fileno(self) -> int | None:
        ser = self._ser
        fd = getattr(ser, "fd", None) if ser is not None and ser.is_open else None
        return fd if isinstance(fd, int) else None

    def close(self) -> None:
        ser, self._ser = self._ser, None
        if ser is not None:
            try:
                ser.close()
            except Exception:
                pass

    def _lost(self, exc: BaseException) -> LinkLostError:
        self.close()
        return LinkLostError(f"serial link {self.port} lost: {exc}")

    def write(self, data: bytes) -> None:
        import serial

        ser = self._ser
        if ser is None:
            raise TransportError(f"serial port {self.port} is not open (call open())")
        fd = self.fileno()
        if fd is None:  # not a POSIX port (Windows): pyserial's own write and timeout
            try:
                n = ser.write(data)
                if n is not None and n != len(data):
                    raise TransportError(f"serial port {self.port}: wrote {n} of {len(data)} bytes")
            except serial.SerialTimeoutException as exc:
                raise TransportError(
                    f"serial port {self.port}: write timed out after {self.write_timeout_s} s") from exc
            except (serial.SerialException, OSError) as exc:
                raise self._lost(exc) from exc
            return
        self._write_fd(fd, data)

    def _write_fd(self, fd: int, data: bytes) -> None:
        """Write all of ``data`` to the non-blocking descriptor, waiting at most ``write_timeout_s``.

        Unlike pyserial's POSIX write (which raises "Write timeout" after a complete ``os.write``
        when its timer ran out meanwhile), the deadline only matters while bytes are still left: a
        process stalled mid-write (stopped, descheduled on a busy machine) always gets one more try,
        and a write that went through is never reported as timed out.
        """
        view = memoryview(data)
        sent = 0
        deadline = _clock() + self.write_timeout_s
        while True:
            try:
                sent += os.write(fd, view[sent:])
            except OSError as exc:
                if exc.errno not in _RETRY_ERRNOS:
                    raise self._lost(exc) from exc
            if sent >= len(data):
                return
            left = deadline - _clock()
            if left <= 0:
                raise TransportError(
                    f"serial port {self.port}: write timed out after {self.write_timeout_s} s "
                    f"({sent} of {len(data)} bytes written)")
            try:
                select.select([], [fd], [], left)
            except OSError as exc:  # EINTR is retried by Python itself (PEP 475)
                raise self._lost(exc) from exc

    def read(self) -> bytes:
        import serial

        ser = self._ser
        if ser is None:
            raise TransportError(f"serial port {self.port} is not open (call open())")
        try:
            return bytes(ser.read(65536))
        except (serial.SerialException, OSError) as exc:
            raise self._lost(exc) from exc
