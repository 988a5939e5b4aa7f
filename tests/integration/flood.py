"""The flood rig of issue 11: one client floods the controller, a second client sends ESTOPs.

Used by ``tests/integration/test_flood_estop.py`` (which asserts) and ``bench/controller.py``
(which prints figures).  Three parts:

* :func:`flood_main` -- the flooder, run as its own process (``python flood.py send ...``) so
  it shares no GIL with anyone: a fixed, seeded mix of datagrams paced to ``rate`` per second
  from ``start_at`` (a ``time.monotonic()`` value) for ``duration`` s, bounded in count
  (``rate * duration``) and in time; it prints a JSON summary (IDs sent, kinds, rate reached).
* :func:`acks_main` -- the ack recorder, its own process (``python flood.py acks PORT``): binds
  the controller's ack port and keeps every ``ACK|ID|STATUS|details`` it receives, for both
  clients (both send from 127.0.0.1, so the acks of every ID'd command arrive there).
* :class:`SecondClient` -- runs in the caller's process: ESTOP at given moments (re-ENABLE and a
  new MOVEJOINT after each one), PING round trips all the time, every command with an ID; the
  board's frame log (``board-sim --frame-log``) then says how many frames the board received
  between each ESTOP and its first DISABLE frame, or with the controller's ``spy+`` log, how
  many frames the controller wrote in between (:meth:`SecondClient.judge_estops`).

Standard library only (the two processes import nothing from parolkit).
"""

from __future__ import annotations

import json
import math
import random
import socket
import subprocess
import sys
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

HOST = "127.0.0.1"
#: board command code of DISABLE (parolkit.protocol.BoardCommand.DISABLE)
BOARD_DISABLE = 102
#: the board command codes by the names a spy+ log shows (parolkit.protocol.BoardCommand)
BOARD_COMMANDS = {"HOME": 100, "ENABLE": 101, "DISABLE": 102, "CLEAR_ERROR": 103, "JOG": 123, "GOTO": 156,
                  "IDLE": 255}
TERMINAL = ("COMPLETED", "FAILED", "CANCELLED", "INVALID")
THIS_FILE = Path(__file__).resolve()

# ------------------------------------------------------------------------------------ the mix

#: valid immediate commands, queries and garbage, as (kind, share); kinds ending in "_id"
#: carry an ID and need exactly one terminal ack
MIX = (
    ("immediate_id", 0.20),   # ID|STREAM|OFF          -> COMPLETED (or a "busy" FAILED)
    ("immediate", 0.20),      # STREAM|OFF             -> nothing
    ("query_id", 0.08),       # ID|GET_ANGLES ...      -> the reply and a COMPLETED ack
    ("query", 0.22),          # GET_ANGLES / GET_STATUS / PING -> the reply
    ("invalid_id", 0.07),     # ID|MOVEJOINT|1|2 ...   -> INVALID
    ("garbage", 0.23),        # random bytes, malformed text, 3,000-byte and over-long datagrams
)
QUERIES = ("GET_ANGLES", "GET_STATUS", "PING")
INVALID_WITH_ID = ("MOVEJOINT|1|2", "NOPE|1", "STREAM|MAYBE", "GET_ANGLES|x", "JOG|99|1|1|1")
MALFORMED = (b"", b"|||||", b"MOVEJOINT|1|2", b"GET_ANGLES|x", b"JOG|99|1|1|1", b"STREAM|MAYBE",
             b"ESTOPX", b"abcdefg|STOOP", b"\x00" * 12, b"SMOOTH_BLEND|2|||||", b"MOVEPOSE|nan|1")
#: over the protocol's 65,000-byte limit (and under UDP's 65,507)
OVER_LONG = 65_100


def make_datagrams(count: int, seed: int) -> tuple[list[bytes], list[str], list[tuple[int, str]]]:
    """``count`` datagrams of :data:`MIX` (seeded), the kind of each, and (index, ID) of the
    ID'd ones.  IDs are ``f`` + 7 digits (8 characters, not all upper-case, as the protocol
    wants)."""
    rng = random.Random(seed)
    kinds = [k for k, _ in MIX]
    weights = [w for _, w in MIX]
    long_text, over_long = b"A" * 3000, b"B" * OVER_LONG
    out: list[bytes] = []
    ids: list[tuple[int, str]] = []
    chosen = rng.choices(kinds, weights, k=count)
    for n, kind in enumerate(chosen):
        cid = f"f{n:07d}"
        if kind == "immediate_id":
            data = f"{cid}|STREAM|OFF".encode()
        elif kind == "immediate":
            data = b"STREAM|OFF"
        elif kind == "query_id":
            data = f"{cid}|{rng.choice(QUERIES)}".encode()
        elif kind == "query":
            data = rng.choice(QUERIES).encode()
        elif kind == "invalid_id":
            data = f"{cid}|{rng.choice(INVALID_WITH_ID)}".encode()
        else:
            r = rng.random()
            if r < 0.40:  # never UTF-8 (a continuation byte first): no ID can be read from it
                data = bytes([rng.randint(0x80, 0xBF)]) + rng.randbytes(rng.randint(0, 80))
            elif r < 0.85:
                data = rng.choice(MALFORMED)
            elif r < 0.99:
                data = long_text
            else:
                data = over_long
        if kind.endswith("_id"):
            ids.append((n, cid))
        out.append(data)
    return out, chosen, ids


def _big_rcvbuf(sock: socket.socket, size: int = 64 << 20) -> None:
    """As large a receive buffer as allowed (as root beyond rmem_max): a recorder must not drop."""
    try:
        sock.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_RCVBUFFORCE", 33), size)
    except OSError:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size)


def flood_main(argv: list[str]) -> int:
    """``send HOST PORT RATE DURATION START_AT SEED LINGER_S``: flood, count the replies to the
    flood's own socket until none came for 0.5 s (at most LINGER_S after the flood), then print
    a JSON summary."""
    host, port = argv[0], int(argv[1])
    rate, duration, start_at, seed = float(argv[2]), float(argv[3]), float(argv[4]), int(argv[5])
    linger_s = float(argv[6])
    total = int(rate * duration)
    data, kinds, ids = make_datagrams(total, seed)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 22)
    _big_rcvbuf(sock)
    sock.bind((HOST, 0))
    sock.settimeout(0.1)
    addr = (host, port)
    replies: Counter[str] = Counter()
    last_reply = [0.0]
    done = threading.Event()

    def read_replies() -> None:  # recv releases the GIL: the sender keeps its pace
        recv = sock.recv
        while True:
            try:
                d = recv(65535)
            except TimeoutError:
                if done.is_set():
                    return
                continue
            except OSError:
                return
            replies[d[:16].split(b"|", 1)[0].decode("ascii", "replace")] += 1
            last_reply[0] = time.monotonic()
            if done.is_set():
                return  # (replies still coming: the main thread reads the counts next)

    reader = threading.Thread(target=read_replies, daemon=True)
    reader.start()
    failed: set[int] = set()
    errors: Counter[str] = Counter()
    now = time.monotonic()
    if start_at > now:
        time.sleep(start_at - now)
    t0 = time.monotonic()
    end = t0 + duration
    n = 0
    sendto = sock.sendto
    while n < total:
        now = time.monotonic()
        if now >= end:
            break  # behind schedule: stop on time anyway
        due = min(total, int((now - t0) * rate) + 1)
        while n < due:
            try:
                sendto(data[n], addr)
            except OSError as exc:
                failed.add(n)
                errors[type(exc).__name__] += 1
            n += 1
        time.sleep(0.0005)
    t1 = time.monotonic()
    while time.monotonic() - max(t1, last_reply[0]) < 0.5 and time.monotonic() - t1 < linger_s:
        time.sleep(0.05)
    done.set()
    reader.join()  # before the counts are read: the reader adds to them until it returns
    ok = [i for i in range(n) if i not in failed]
    sent_kinds = Counter(kinds[i] for i in ok)
    print(json.dumps({
        "sent": len(ok), "planned": total, "send_errors": dict(errors),
        "first_t": t0, "last_t": t1, "rate": len(ok) / max(1e-9, t1 - t0),
        "kinds": dict(sent_kinds),
        "over_long": sum(1 for i in ok if len(data[i]) > 65_000),
        "queries": sent_kinds["query"] + sent_kinds["query_id"],
        "replies": dict(replies),
        "query_replies": sum(replies[k] for k in ("PONG", "ANGLES", "STATUS")),
        "ids": {cid: kinds[i] for i, cid in ids if i < n and i not in failed},
        "drops": udp_drops(sock.getsockname()[1]),
    }))
    return 0


def acks_main(argv: list[str]) -> int:
    """``acks PORT``: record acks on PORT until stdin says ``stop QUIET_S MAX_S`` (stop once no ack
    came for QUIET_S, or MAX_S after the stop line), then print them as JSON."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    _big_rcvbuf(sock)
    sock.bind((HOST, int(argv[0])))
    sock.settimeout(0.1)
    stop: dict[str, float] = {}

    def read_stdin() -> None:
        for line in sys.stdin:
            words = line.split()
            if words and words[0] == "stop":
                stop["quiet"], stop["until"] = float(words[1]), time.monotonic() + float(words[2])
                return
        stop["quiet"], stop["until"] = 0.0, time.monotonic()

    threading.Thread(target=read_stdin, daemon=True).start()
    print(f"ready {sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)}", flush=True)
    raw: list[bytes] = []
    last = time.monotonic()
    recv = sock.recv
    while True:
        try:
            raw.append(recv(65535))
            last = time.monotonic()
            continue
        except TimeoutError:
            pass
        if stop and (time.monotonic() - last >= stop["quiet"] or time.monotonic() >= stop["until"]):
            break
    acks: dict[str, list[list[str]]] = {}
    other = 0
    for d in raw:
        p = d.decode("utf-8", "replace").split("|", 3)
        if len(p) >= 3 and p[0] == "ACK":
            acks.setdefault(p[1], []).append([p[2], p[3] if len(p) > 3 else ""])
        else:
            other += 1
    print(json.dumps({"datagrams": len(raw), "other": other, "acks": acks,
                      "drops": udp_drops(int(argv[0]))}))
    return 0


# ------------------------------------------------------------------------------------ helpers


def udp_drops(port: int) -> int | None:
    """Datagrams the kernel dropped at the IPv4 UDP sockets bound to ``port`` (a receive buffer
    was full), from ``/proc/net/udp``: all of them (the controller's port has two, the command
    socket and the safety socket); None when none is found."""
    try:
        lines = Path("/proc/net/udp").read_text().splitlines()[1:]
    except OSError:
        return None
    drops = [int(f[-1]) for f in (line.split() for line in lines)
             if len(f) >= 13 and int(f[1].rsplit(":", 1)[1], 16) == port]
    return sum(drops) if drops else None


def pct(xs: list[float], q: float) -> float:
    """The q-th percentile (nearest rank) of ``xs``; inf counts as a value (a lost reply)."""
    if not xs:
        return math.nan
    s = sorted(xs)
    return s[min(len(s) - 1, max(0, math.ceil(len(s) * q / 100.0) - 1))]


def ms(x: float, inf: str = "lost") -> str:
    """``x`` s in ms; ``inf`` names an infinite value (a reply or frame that never came)."""
    if math.isnan(x):
        return "n/a"
    return inf if math.isinf(x) else f"{x * 1e3:.2f} ms"


class Flooder:
    """The flooder process (see :func:`flood_main`)."""

    def __init__(self, port: int, rate: float, duration: float, start_at: float, seed: int,
                 linger_s: float = 5.0) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(THIS_FILE), "send", HOST, str(port), str(rate), str(duration),
             repr(start_at), str(seed), str(linger_s)],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.timeout = max(0.0, start_at - time.monotonic()) + duration + linger_s + 60

    def result(self) -> dict:
        out, err = self.proc.communicate(timeout=self.timeout)
        if self.proc.returncode != 0:
            raise RuntimeError(f"the flooder failed ({self.proc.returncode}): {err}")
        return json.loads(out)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)


class AckRecorder:
    """The ack recorder process on the controller's ack port (see :func:`acks_main`)."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.proc = subprocess.Popen([sys.executable, str(THIS_FILE), "acks", str(port)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        if not line.startswith("ready"):
            raise RuntimeError(f"the ack recorder did not start: {line!r} {self.proc.stderr.read()}")
        self.rcvbuf = int(line.split()[1])

    def finish(self, quiet_s: float, max_s: float) -> dict:
        """Stop once no ack came for ``quiet_s`` (at most ``max_s`` from now); all acks by ID."""
        out, err = self.proc.communicate(f"stop {quiet_s} {max_s}\n", timeout=max_s + 30)
        if self.proc.returncode != 0:
            raise RuntimeError(f"the ack recorder failed ({self.proc.returncode}): {err}")
        return json.loads(out)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)


def send_control(path: str, text: str, timeout_s: float = 2.0) -> str:
    """board-sim's control client (imported when first needed: the two processes above run
    without parolkit)."""
    from parolkit.board.control_channel import send_control as send

    return send(path, text, timeout_s=timeout_s)


# ------------------------------------------------------------------------------------ client 2


@dataclass
class EstopResult:
    """One ESTOP of the second client, judged by the frames: the board's frame log, or with the
    controller's ``spy+`` log, the frames as the controller wrote them (:func:`written_frames`)."""

    t_send: float
    #: command code of the last frame before the send (None: no frame yet)
    before: int | None
    #: frames after the send before the first DISABLE frame (None: none came)
    frames_before: int | None
    #: time from the send to the board's receipt of that DISABLE frame, s (None: none came)
    latency_s: float | None
    #: IDs of the ENABLEs sent since the previous ESTOP (the one that should have armed the board)
    enables: tuple[str, ...] = ()

    @property
    def armed(self) -> bool:
        """The last frame before the send was not DISABLE: the re-ENABLE had been sent, so a
        DISABLE after the send is this ESTOP's."""
        return self.before is not None and self.before != BOARD_DISABLE

    @property
    def ticks(self) -> float:
        """The DISABLE was the N-th frame after the send (inf: none came)."""
        return math.inf if self.frames_before is None else self.frames_before + 1

    def describe(self) -> str:
        if not self.armed:
            return "the last frame before the send was already DISABLE (the re-ENABLE had not been sent)"
        if self.frames_before is None:
            return "no DISABLE frame after the send, or none reached the board"
        return f"DISABLE was frame {self.ticks} after the send, {self.latency_s * 1e3:.1f} ms"


def written_frames(spy_log: Path) -> list[tuple[float, int]]:
    """The frames the controller wrote, from its ``spy+`` log: (monotonic s as ``write`` was
    called, command code), in order."""
    frames = (_spy_frame(line) for line in spy_log.read_text(errors="replace").splitlines())
    return [f for f in frames if f is not None]


def _spy_frame(line: str) -> tuple[float, int] | None:
    """A ``spy+`` log line's frame written: (time, command code); None for other lines."""
    parts = line.split(" ")
    if len(parts) > 3 and parts[2] == "PC>BOARD" and parts[3] == "CommandFrame":
        name = next((p[8:] for p in parts[4:] if p.startswith("command=")), "")
        return float(parts[1]), BOARD_COMMANDS[name] if name in BOARD_COMMANDS else int(name)
    return None


@dataclass
class PhaseResult:
    """What the second client measured in one phase."""

    estops: list[EstopResult] = field(default_factory=list)
    #: (send time, round trip s or inf when no PONG came within the ping timeout)
    pings: list[tuple[float, float]] = field(default_factory=list)
    t0: float = 0.0
    t1: float = 0.0
    #: the IDs the second client sent in this phase
    ids: list[str] = field(default_factory=list)


class SecondClient:
    """The second client: ESTOP at chosen moments, ENABLE and a new MOVEJOINT 0.1 s after each,
    every command with an ID, from one socket; PING round trips all the time from a second
    socket (closed loop, one outstanding; a fresh socket after a PING got no PONG within
    :attr:`PING_TIMEOUT_S`, so its late PONG is never taken for the next one's)."""

    PING_TIMEOUT_S = 1.0
    PING_GAP_S = 0.005
    ENABLE_AFTER_S = 0.1
    #: an ENABLE with no effect on the board's frames after this long is sent again, s
    ENABLE_AGAIN_S = 0.1

    def __init__(self, port: int, control_path: str, *, id_prefix: str = "c",
                 spy_log: Path | None = None) -> None:
        self.addr = (HOST, port)
        self.control_path = control_path
        #: the controller's ``spy+`` log: armed is judged on the frames it wrote (as the ESTOPs
        #: are), read as it grows; None: on the frames the board received
        self.spy_log = spy_log
        self._spy_offset = 0
        self._spy_last: int | None = None
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((HOST, 0))
        self._prefix = id_prefix
        self._n = 0
        self._flip = False
        self._ping_stop = threading.Event()
        self._ping_thread: threading.Thread | None = None
        self._pings: list[tuple[float, float]] = []
        #: every ID this client sent -> its datagram
        self.ids: dict[str, str] = {}

    # ---- commands
    def send(self, text: str) -> tuple[str, float]:
        """Send ``ID|text``; returns the ID and the monotonic send time."""
        self._n += 1
        cid = f"{self._prefix}{self._n:07d}"
        data = f"{cid}|{text}"
        self.ids[cid] = data
        t = time.monotonic()
        self.sock.sendto(data.encode(), self.addr)
        return cid, t

    def move(self) -> None:
        """A slow MOVEJOINT, J1 alternating between 70 and 110 deg in 2 s: the robot is moving
        when the next ESTOP comes."""
        self._flip = not self._flip
        self.send(f"MOVEJOINT|{70 if self._flip else 110}|-90|180|0|0|180|2|None")

    # ---- pings
    def start_pings(self) -> None:
        self._pings = []
        self._ping_stop.clear()
        self._ping_thread = threading.Thread(target=self._ping_loop, name="flood-pings", daemon=True)
        self._ping_thread.start()

    def stop_pings(self) -> list[tuple[float, float]]:
        self._ping_stop.set()
        if self._ping_thread is not None:
            self._ping_thread.join(self.PING_TIMEOUT_S + 2)
        return self._pings

    def _ping_loop(self) -> None:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.settimeout(self.PING_TIMEOUT_S)
        while not self._ping_stop.is_set():
            t = time.monotonic()
            s.sendto(b"PING", self.addr)
            try:
                while not s.recv(65535).startswith(b"PONG"):
                    pass
                self._pings.append((t, time.monotonic() - t))
            except TimeoutError:
                self._pings.append((t, math.inf))
                s.close()
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                s.settimeout(self.PING_TIMEOUT_S)
            self._ping_stop.wait(self.PING_GAP_S)
        s.close()

    # ---- board frames
    def frames(self, since: float) -> list[list]:
        """Every frame the board received after ``since`` (paged through the control socket)."""
        out: list[list] = []
        query = f"frames since={since:.6f}"
        while True:
            reply = send_control(self.control_path, query, timeout_s=5.0)
            if not reply.startswith("ok "):
                raise RuntimeError(f"board-sim frame log: {reply}")
            got = json.loads(reply[3:])
            out += got["frames"]
            if not got["more"] or not got["frames"]:
                return out
            query = f"frames since={since:.6f} after={got['frames'][-1][0]}"

    def _board_armed(self) -> bool:
        """The last frame is not DISABLE: the last one the controller wrote (``spy_log``: what
        the ESTOPs are judged on; the board gets it later, by the pty's worker, 50-2,600 ms
        later beside two CPU hogs under the flood), else the last one the board received."""
        if self.spy_log is not None:
            with open(self.spy_log, "rb") as f:
                f.seek(self._spy_offset)
                data = f.read()
            end = data.rfind(b"\n") + 1
            self._spy_offset += end
            for line in data[:end].decode(errors="replace").splitlines():
                frame = _spy_frame(line)
                if frame is not None:
                    self._spy_last = frame[1]
            return self._spy_last is not None and self._spy_last != BOARD_DISABLE
        reply = send_control(self.control_path, "frames last=1", timeout_s=1.0)
        frames = json.loads(reply[3:])["frames"] if reply.startswith("ok ") else []
        return bool(frames) and frames[-1][2] != BOARD_DISABLE

    # ---- the ESTOP cycles
    def estop_cycles(self, moments: list[float], *,
                     arm_wait_s: float = 0.3) -> list[tuple[float, tuple[str, ...]]]:
        """ENABLE and a move, then ESTOP at each of ``moments`` (monotonic; once the board's last
        frame is not DISABLE, waiting at most ``arm_wait_s`` for that), each followed by ENABLE
        and a new move ``ENABLE_AFTER_S`` later.  Returns each ESTOP's send time with the IDs
        of the ENABLEs sent before it (since the previous ESTOP)."""
        self._board_armed()  # imports the control client before the timed part
        sent = []
        enables = [self.send("ENABLE")[0]]
        self.move()
        for t in moments:
            time.sleep(max(0.0, t - time.monotonic()))
            end = time.monotonic() + arm_wait_s
            again = time.monotonic() + self.ENABLE_AGAIN_S
            while not self._board_armed() and time.monotonic() < end:
                if time.monotonic() >= again:
                    # no effect yet: the kernel may have dropped the ENABLE at the controller's
                    # full buffer (a starved run lost 2 in 3 datagrams there); send it again,
                    # as a client that sees nothing happen would
                    enables.append(self.send("ENABLE")[0])
                    again = time.monotonic() + self.ENABLE_AGAIN_S
                time.sleep(0.005)
            _, t_send = self.send("ESTOP")
            sent.append((t_send, tuple(enables)))
            time.sleep(max(0.0, t_send + self.ENABLE_AFTER_S - time.monotonic()))
            enables = [self.send("ENABLE")[0]]
            self.move()
        return sent

    def judge_estops(self, sent: list[tuple[float, tuple[str, ...]]],
                     spy_log: Path | None = None) -> list[EstopResult]:
        """Count the frames after each send before the first DISABLE: in the board's frame log,
        or with ``spy_log`` (the controller's ``spy+`` log) in the frames as the controller
        wrote them, each DISABLE then also found in the board's log (it arrived).  The latency
        is always the board's receipt.

        A DISABLE that an earlier, late ESTOP caused can be taken for a later one's, which then
        looks faster than it was; the verdict stays right: that earlier ESTOP was itself more
        than a re-ENABLE late (at least 0.35 s), so it fails."""
        board = [(f[1], f[2]) for f in self.frames(min(t for t, _ in sent) - 1.0)] if sent else []
        frames = written_frames(spy_log) if spy_log is not None and sent else board
        results = []
        for t_send, enables in sent:
            before = [f for f in frames if f[0] <= t_send]
            after = [f for f in frames if f[0] > t_send]
            idx = next((i for i, f in enumerate(after) if f[1] == BOARD_DISABLE), None)
            # the board's receipt of the first DISABLE after the send (none: it never arrived)
            t_board = next((t for t, cmd in board if t > t_send and cmd == BOARD_DISABLE), None)
            if t_board is None:
                idx = None
            results.append(EstopResult(t_send, before[-1][1] if before else None, idx,
                                       None if t_board is None else t_board - t_send, enables))
        return results

    def phase(self, start: float, duration: float, estops: int,
              rng: random.Random) -> tuple[PhaseResult, list[tuple[float, tuple[str, ...]]]]:
        """PINGs from ``start`` for ``duration`` s and ``estops`` ESTOP cycles at random moments
        in between; returns the pings and the ESTOP send times (judge them later, once late
        DISABLE frames had their chance)."""
        time.sleep(max(0.0, start - time.monotonic()))
        known = len(self.ids)
        self.start_pings()
        sent = self.estop_cycles(estop_moments(start, duration, estops, rng))
        time.sleep(max(0.0, start + duration - time.monotonic()))
        return PhaseResult(pings=list(self.stop_pings()), t0=start, t1=start + duration,
                           ids=list(self.ids)[known:]), sent

    def close(self) -> None:
        self.stop_pings()
        self.sock.close()


def estop_moments(start: float, duration: float, count: int, rng: random.Random,
                  min_gap_s: float = 0.35) -> list[float]:
    """``count`` random moments in ``[start + 0.3, start + duration - 0.3]``, at least
    ``min_gap_s`` apart: one per equal slot, at a random place in the slot's first part."""
    span = duration - 0.6
    slot = span / count
    jitter = max(0.0, slot - min_gap_s)
    return [start + 0.3 + k * slot + rng.uniform(0.0, jitter) for k in range(count)]


# ------------------------------------------------------------------------------------ acks


@dataclass
class AckCheck:
    """Every ID'd command needs exactly one terminal ack."""

    expected: int
    missing: list[str]
    duplicate: list[str]
    statuses: Counter
    #: terminal FAILED details, counted (e.g. a "busy" refusal)
    failed_details: Counter

    @property
    def ok(self) -> bool:
        return not self.missing and not self.duplicate


def check_acks(ids: list[str], acks: dict[str, list[list[str]]]) -> AckCheck:
    missing, duplicate = [], []
    statuses: Counter = Counter()
    failed: Counter = Counter()
    for cid in ids:
        terminal = [a for a in acks.get(cid, []) if a[0] in TERMINAL]
        if not terminal:
            missing.append(cid)
        elif len(terminal) > 1:
            duplicate.append(cid)
        for st, details in terminal:
            statuses[st] += 1
            if st == "FAILED":
                failed[details[:60]] += 1
    return AckCheck(len(ids), missing, duplicate, statuses, failed)


# ------------------------------------------------------------------------------------ the run


@dataclass
class FloodRun:
    """Everything one run measured: a reference phase without the flood, then the flood."""

    reference: PhaseResult
    flood: PhaseResult
    flooder: dict
    acks: dict
    #: IDs of the second client -> its datagram
    client_ids: dict[str, str]
    #: datagrams the kernel dropped at the controller's socket during the run
    controller_drops: int
    ack_rcvbuf: int
    seed: int
    rate: float

    @property
    def flood_pings(self) -> list[float]:
        """Round trips of the PINGs sent while the flooder was sending."""
        return [r for t, r in self.flood.pings if self.flooder["first_t"] <= t <= self.flooder["last_t"]]

    def client_acks(self, phase: PhaseResult | None = None) -> AckCheck:
        """The second client's IDs (of one phase, or all, including the final STOP)."""
        return check_acks(phase.ids if phase else list(self.client_ids), self.acks["acks"])

    def flooder_acks(self) -> AckCheck:
        return check_acks(list(self.flooder["ids"]), self.acks["acks"])

    def flood_covered_estops(self) -> bool:
        ts = [e.t_send for e in self.flood.estops]
        return bool(ts) and self.flooder["first_t"] <= min(ts) and max(ts) <= self.flooder["last_t"]


def run_flood(ctl_port: int, ack_recorder: AckRecorder, control_path: str, *, rate: float = 20_000,
              duration: float = 10.0, estops: int = 20, reference_s: float = 1.6,
              reference_estops: int = 3, seed: int = 11, settle_quiet_s: float = 3.0,
              settle_max_s: float = 40.0, spy_log: Path | None = None) -> FloodRun:
    """The scenario: a reference phase (the second client alone), then the flood with the second
    client's ESTOP cycles and PINGs; then STOP, wait until the acks settle and judge the ESTOPs
    by the frames (:meth:`SecondClient.judge_estops`: ``spy_log``, the controller's log of
    the frames it wrote, else the board's frame log)."""
    rng = random.Random(seed)
    drops_before = udp_drops(ctl_port) or 0
    client = SecondClient(ctl_port, control_path, spy_log=spy_log)
    flooder = None
    try:
        reference, ref_sent = client.phase(time.monotonic() + 0.2, reference_s, reference_estops, rng)
        start = time.monotonic() + 1.5  # the flooder builds its datagrams meanwhile
        flooder = Flooder(ctl_port, rate, duration, start, seed)
        flood, sent = client.phase(start, duration, estops, rng)
        fl = flooder.result()
        client.send("STOP")  # ends the last move (CANCELLED) with an ack of its own
        acks = ack_recorder.finish(settle_quiet_s, settle_max_s)
        reference.estops = client.judge_estops(ref_sent, spy_log)
        flood.estops = client.judge_estops(sent, spy_log)
    finally:
        if flooder is not None:
            flooder.kill()
        client.close()
    return FloodRun(reference, flood, fl, acks, dict(client.ids),
                    (udp_drops(ctl_port) or 0) - drops_before, ack_recorder.rcvbuf, seed, rate)


def estop_line(name: str, estops: list[EstopResult]) -> str:
    """``name: DISABLE in frame [1, 1, 2, never, -] after the send; ticks p50/p99/max, ms ...``"""
    marks = ["-" if not e.armed else ("never" if e.frames_before is None else str(e.ticks))
             for e in estops]
    armed = [e for e in estops if e.armed]
    ticks = [e.ticks for e in armed] or [math.nan]
    lat = [math.inf if e.latency_s is None else e.latency_s for e in armed] or [math.nan]

    def t(x: float) -> str:
        return "n/a" if math.isnan(x) else ("never" if math.isinf(x) else f"{x:g}")

    before = Counter(e.before for e in estops)
    return (f"  {name}: the DISABLE was frame [{', '.join(marks)}] after the send; ticks p50 "
            f"{t(pct(ticks, 50))} p99 {t(pct(ticks, 99))} max {t(max(ticks))}; ms p50 "
            f"{ms(pct(lat, 50), 'never')} p99 {ms(pct(lat, 99), 'never')} max {ms(max(lat), 'never')}; "
            f"board's last frame "
            f"before the send by command {dict(before)}")


def ping_line(name: str, rtts: list[float]) -> str:
    lost = sum(1 for r in rtts if math.isinf(r))
    return (f"  {name}: p50 {ms(pct(rtts, 50))}, p99 {ms(pct(rtts, 99))}, "
            f"max {ms(max(rtts) if rtts else math.nan)}; {len(rtts)} PINGs, {lost} unanswered "
            f"within {SecondClient.PING_TIMEOUT_S:g} s")


def ack_line(name: str, check: AckCheck, what: dict[str, str]) -> str:
    line = (f"  {name}: {check.expected:,} IDs, {len(check.missing):,} without a terminal ack, "
            f"{len(check.duplicate):,} with more than one; terminal acks {dict(check.statuses)}")
    if check.missing:
        kinds = Counter(what.get(cid, "?") for cid in check.missing)
        line += f"\n    missing by kind {dict(kinds)}; first: " + ", ".join(
            f"{cid} ({what.get(cid, '?')})" for cid in check.missing[:6])
    if check.duplicate:
        line += "\n    more than one: " + ", ".join(check.duplicate[:6])
    if check.failed_details:
        line += f"\n    FAILED details: {dict(check.failed_details.most_common(4))}"
    return line


def report(run: FloodRun) -> list[str]:
    """The run's figures, one line each (the test's failure message, the bench's output)."""
    fl = run.flooder
    q = fl["queries"]
    what = {c: d.split("|")[1] for c, d in run.client_ids.items()}
    return [
        f"flood: {fl['sent']:,} datagrams in {fl['last_t'] - fl['first_t']:.2f} s ({fl['rate']:,.0f}/s, "
        f"target {run.rate:,.0f}/s; {len(fl['ids']):,} with an ID; {fl['over_long']} over-long; "
        f"kinds {fl['kinds']}); sendto errors {fl['send_errors']}; seed {run.seed}",
        f"  replies to the flooder's {q:,} queries: {fl['query_replies']:,} "
        f"({100 * (1 - fl['query_replies'] / max(1, q)):.1f} % "
        f"lost); all replies by kind {fl['replies']}; the flooder's own socket dropped {fl['drops']}",
        f"  kernel drops at the controller's socket: {run.controller_drops:,}; at the ack recorder's: "
        f"{run.acks['drops']} (buffer {run.ack_rcvbuf:,} B; {run.acks['datagrams']:,} acks recorded)",
        "ESTOP -> the first DISABLE frame (frame N after the send, of the frames written with a spy+ "
        "log, else received; ms: its arrival at the board; '-' = the last frame before the send was "
        "DISABLE, 'never' = no DISABLE came; once ESTOPs are late, a later one may see an earlier "
        "one's DISABLE: then N is a lower bound):",
        estop_line("reference, no flood", run.reference.estops),
        estop_line(f"under the flood ({len(run.flood.estops)} ESTOPs)", run.flood.estops),
        "PING round trip of the second client:",
        ping_line("reference, no flood", [r for _, r in run.reference.pings]),
        ping_line("under the flood", run.flood_pings),
        "terminal acks (one per ID'd command expected):",
        ack_line("second client, reference", run.client_acks(run.reference), what),
        ack_line("second client, under the flood (and the final STOP)",
                 check_acks([c for c in run.client_ids if c not in set(run.reference.ids)], run.acks["acks"]),
                 what),
        ack_line("flooder", run.flooder_acks(), fl["ids"]),
    ]


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "send":
        sys.exit(flood_main(sys.argv[2:]))
    if len(sys.argv) >= 2 and sys.argv[1] == "acks":
        sys.exit(acks_main(sys.argv[2:]))
    print("usage: flood.py send HOST PORT RATE DURATION START_AT SEED | flood.py acks PORT",
          file=sys.stderr)
    sys.exit(2)
