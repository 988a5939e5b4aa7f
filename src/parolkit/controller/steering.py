"""The command port's second queue: the kernel steers what may be a stop into a socket of its own.

A flood fills the command socket's receive queue (megabytes of datagrams), and a datagram is
read only after every one that arrived before it: an ESTOP behind 20,000 datagrams/s waited
50-570 ms in that queue when the server thread got too little CPU (two CPU hogs beside the
flood; the tick took it in the tick after it was read).  So the port has two sockets in one
``SO_REUSEPORT`` group, and a classic BPF program attached to the group picks the socket of
each datagram as it arrives (Linux, ``SO_ATTACH_REUSEPORT_CBPF``):

* socket 1, the **safety socket**: a datagram of at most :data:`SAFETY_MAX_BYTES` bytes that
  contains ``STOP`` or ``DISA`` (ESTOP, STOP, DISABLE, with or without an ID) or ``ACK_``
  (ACK_HERE, so that an ACK_HERE and the ID'd STOP after it keep their order), any case.  The
  tick thread reads it every tick (:meth:`UdpServer.read_safety_socket
  <parolkit.controller.server.UdpServer.read_safety_socket>`), so a stop waits behind other
  stops only, never behind the flood;
* socket 0, the command socket: everything else, read by the server thread as before.

The program only sorts; the server classifies what it reads exactly as before (a lookalike
such as ``ESTOPX`` is handed on to the server thread).  Where the kernel refuses (not Linux, no
BPF), the port has one socket and the server reads everything, as before; :func:`open_command_port`
says which.

``SO_REUSEPORT`` would let a second controller join the group (and get nothing, or half the
traffic) instead of failing to bind: the port is first bound once without it, which fails as
before when anything holds it.  (A process of the same user could still join the group
later; it can signal the controller anyway.)
"""

from __future__ import annotations

import ctypes
import socket
import struct

__all__ = ["SAFETY_MAX_BYTES", "MARKERS", "RCVBUF", "SO_RXQ_OVFL", "safety_program", "open_command_port",
           "CommandPort"]

#: datagrams longer than this are never taken for a stop (the server's check too)
SAFETY_MAX_BYTES = 80
#: 4 bytes (lower case) of which one in a datagram sends it to the safety socket
MARKERS = (b"stop", b"disa", b"ack_")
#: the command socket's receive buffer asked for, bytes
RCVBUF = 1 << 21
#: linux/asm-generic/socket.h
SO_ATTACH_REUSEPORT_CBPF = 51
#: the kernel stamps each datagram with its arrival time (both sockets: one receive order)
SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)
#: each datagram read carries the count of datagrams the kernel dropped at that socket (its
#: receive buffer was full) since it was opened: the controller counts what it never saw
SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40)

# classic BPF opcodes (linux/filter.h)
_LD_W_ABS = 0x20   # A = 4 bytes at k (big-endian); past the end: the program returns 0
_LD_W_LEN = 0x80   # A = the datagram's length
_OR_K = 0x44       # A |= k
_JEQ_K = 0x15      # A == k ? jump jt : jump jf
_JGT_K = 0x25      # A > k ? jump jt : jump jf
_RET_K = 0x06      # return k: the index of the socket in the group


def _insn(code: int, jt: int, jf: int, k: int) -> bytes:
    return struct.pack("=HBBI", code, jt, jf, k)


def _lower_mask(marker: bytes) -> int:
    """The OR mask that folds the letters of a 4-byte window to lower case (only where the
    marker has a letter: ``_`` stays)."""
    return int.from_bytes(bytes(0x20 if chr(c).isalpha() else 0 for c in marker), "big")


def safety_program() -> list[bytes]:
    """The steering program: 1 (the safety socket) for a datagram of at most
    :data:`SAFETY_MAX_BYTES` bytes with one of :data:`MARKERS` in it, any case; else 0.

    The payload starts at offset 0 (the kernel skips the UDP header).  Unrolled over every
    offset: a load past the end ends the program with 0, and no marker fits after it."""
    prog = [_insn(_LD_W_LEN, 0, 0, 0), _insn(_JGT_K, 0, 1, SAFETY_MAX_BYTES), _insn(_RET_K, 0, 0, 0)]
    masks = sorted({_lower_mask(m) for m in MARKERS})
    for k in range(SAFETY_MAX_BYTES - 3):
        for mask in masks:
            words = [int.from_bytes(m, "big") for m in MARKERS if _lower_mask(m) == mask]
            prog += [_insn(_LD_W_ABS, 0, 0, k), _insn(_OR_K, 0, 0, mask)]
            for i, word in enumerate(words):
                # a match jumps over the remaining comparisons to "return 1"
                left = len(words) - 1 - i
                prog.append(_insn(_JEQ_K, left, 0, word) if left else _insn(_JEQ_K, 0, 1, word))
            prog.append(_insn(_RET_K, 0, 0, 1))
    prog.append(_insn(_RET_K, 0, 0, 0))
    return prog


def _attach(sock: socket.socket, prog: list[bytes]) -> None:
    code = ctypes.create_string_buffer(b"".join(prog))
    fprog = struct.pack("@HP", len(prog), ctypes.addressof(code))  # struct sock_fprog
    sock.setsockopt(socket.SOL_SOCKET, SO_ATTACH_REUSEPORT_CBPF, fprog)


class CommandPort:
    """The bound command socket, the safety socket (None: the kernel does not steer) and, if
    none, why not."""

    def __init__(self, sock: socket.socket, safety: socket.socket | None, why_not: str = "") -> None:
        self.sock = sock
        self.safety = safety
        self.why_not = why_not

    def close(self) -> None:
        """Close both sockets."""
        for sock in (self.sock, self.safety):
            if sock is not None:
                sock.close()


def _count_drops(sock: socket.socket) -> None:
    """Ask the kernel for its drop count with every datagram (``SO_RXQ_OVFL``); an OS without
    it leaves the count at 0."""
    try:
        sock.setsockopt(socket.SOL_SOCKET, SO_RXQ_OVFL, 1)
    except OSError:
        pass


def open_command_port(host: str, port: int, *, rcvbuf: int = RCVBUF) -> CommandPort:
    """Bind ``(host, port)`` (0: a free port): the command socket and, where the kernel
    steers (see the module docstring), the safety socket beside it.  ``OSError`` when the port
    is taken, as a plain bind."""
    fam = socket.AF_INET6 if ":" in host else socket.AF_INET
    if port:
        probe = socket.socket(fam, socket.SOCK_DGRAM)  # fails as before when anything holds the port
        try:
            probe.bind((host, port))
        finally:
            probe.close()
    reuse = getattr(socket, "SO_REUSEPORT", None)
    sock = socket.socket(fam, socket.SOCK_DGRAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        _count_drops(sock)
        if reuse is not None:
            try:
                sock.setsockopt(socket.SOL_SOCKET, reuse, 1)
            except OSError:
                reuse = None
        sock.bind((host, port))
    except BaseException:
        sock.close()
        raise
    if reuse is None:
        return CommandPort(sock, None, "the OS has no SO_REUSEPORT")
    safety = socket.socket(fam, socket.SOCK_DGRAM)
    try:
        safety.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)  # (a burst of ACK_HEREs)
        safety.setsockopt(socket.SOL_SOCKET, reuse, 1)
        _count_drops(safety)
        safety.bind(sock.getsockname()[:2])
        _attach(sock, safety_program())
        for s in (sock, safety):
            s.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
    except OSError as exc:
        safety.close()
        return CommandPort(sock, None, f"the kernel does not steer datagrams ({exc})")
    safety.setblocking(False)
    return CommandPort(sock, safety)
