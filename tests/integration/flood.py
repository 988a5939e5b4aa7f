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
  between each ESTOP and its first DISABLE frame.

Standard library only (the two processes import nothing from parolkit).
"""

from __future__ import annotations

import json
import math
import os
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


def flood_main(argv: list[str]) -> int:
    """``send HOST PORT RATE DURATION START_AT SEED``: flood, then print a JSON summary."""
    host, port = argv[0], int(argv[1])
    rate, duration, start_at, seed = float(argv[2]), float(argv[3]), float(argv[4]), int(argv[5])
    total = int(rate * duration)
    data, kinds, ids = make_datagrams(total, seed)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 22)
    addr = (host, port)
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
    ok = [i for i in range(n) if i not in failed]
    print(json.dumps({
        "sent": len(ok), "planned": total, "send_errors": dict(errors),
        "first_t": t0, "last_t": t1, "rate": len(ok) / max(1e-9, t1 - t0),
        "kinds": dict(Counter(kinds[i] for i in ok)),
        "over_long": sum(1 for i in ok if len(data[i]) > 65_000),
        "ids": {cid: kinds[i] for i, cid in ids if i < n and i not in failed},
    }))
    return 0


def acks_main(argv: list[str]) -> int:
    """``acks PORT``: record acks on PORT until stdin says ``stop QUIET_S MAX_S`` (stop once no ack
    came for QUIET_S, or MAX_S after the stop line), then print them as JSON."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:  # as root the buffer may exceed rmem_max: the recorder must never drop an ack
        sock.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_RCVBUFFORCE", 33), 64 << 20)
    except OSError:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 << 20)
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
        except socket.timeout:
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
    """Datagrams the kernel dropped at the IPv4 UDP socket bound to ``port`` (its receive buffer
    was full), from ``/proc/net/udp``; None when not found."""
    try:
        lines = Path("/proc/net/udp").read_text().splitlines()[1:]
    except OSError:
        return None
    for line in lines:
        f = line.split()
        if len(f) >= 13 and int(f[1].rsplit(":", 1)[1], 16) == port:
            return int(f[-1])
    return None


def pct(xs: list[float], q: float) -> float:
    """The q-th percentile (nearest rank) of ``xs``; inf counts as a value (a lost reply)."""
    if not xs:
        return math.nan
    s = sorted(xs)
    return s[min(len(s) - 1, max(0, math.ceil(len(s) * q / 100.0) - 1))]


def ms(x: float) -> str:
    if math.isnan(x):
        return "n/a"
    return "lost" if math.isinf(x) else f"{x * 1e3:.2f} ms"


class Flooder:
    """The flooder process (see :func:`flood_main`)."""

    def __init__(self, port: int, rate: float, duration: float, start_at: float, seed: int) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(THIS_FILE), "send", HOST, str(port), str(rate), str(duration),
             repr(start_at), str(seed)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.timeout = max(0.0, start_at - time.monotonic()) + duration + 60

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


# ------------------------------------------------------------------------------------ client 2


@dataclass
class EstopResult:
    """One ESTOP of the second client, judged by the board's frame log."""

    t_send: float
    #: the board's last frame before the send was not DISABLE (the re-ENABLE had reached it)
    armed: bool
    #: frames the board received after the send before the first DISABLE frame (None: none came)
    frames_before: int | None
    #: time from the send to the board's receipt of that DISABLE frame, s (None: none came)
    latency_s: float | None

    def describe(self) -> str:
        if not self.armed:
            return "board already disabled at the send (the re-ENABLE had not reached it)"
        if self.frames_before is None:
            return "no DISABLE frame at all"
        return f"{self.frames_before} frames, {self.latency_s * 1e3:.1f} ms"


@dataclass
class PhaseResult:
    """What the second client measured in one phase."""

    estops: list[EstopResult] = field(default_factory=list)
    #: (send time, round trip s or inf when no PONG came within the ping timeout)
    pings: list[tuple[float, float]] = field(default_factory=list)
    #: every ID the second client sent -> the datagram
    ids: dict[str, str] = field(default_factory=dict)

    def ping_rtts(self, t0: float = -math.inf, t1: float = math.inf) -> list[float]:
        return [rtt for t, rtt in self.pings if t0 <= t <= t1]


class SecondClient:
    """The second client: ESTOP at chosen moments, ENABLE and a new MOVEJOINT 0.1 s after each,
    PING round trips all the time (closed loop, one outstanding, a fresh socket after a loss so
    a late PONG is never taken for the next one's)."""

    PING_TIMEOUT_S = 1.0
    PING_GAP_S = 0.005
    ENABLE_AFTER_S = 0.1

    def __init__(self, port: int, control_path: str, *, id_prefix: str = "c") -> None:
        self.addr = (HOST, port)
        self.control_path = control_path
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((HOST, 0))
        self._prefix = id_prefix
        self._n = 0
        self._flip = False
        self._ping_stop = threading.Event()
        self._ping_thread: threading.Thread | None = None
        self.result = PhaseResult()

    # ---- commands
    def send(self, text: str) -> tuple[str, float]:
        """Send ``ID|text``; returns the ID and the monotonic send time."""
        self._n += 1
        cid = f"{self._prefix}{self._n:07d}"
        data = f"{cid}|{text}"
        self.result.ids[cid] = data
        t = time.monotonic()
        self.sock.sendto(data.encode(), self.addr)
        return cid, t

    def move(self) -> None:
        """A slow MOVEJOINT, J1 alternating between 70 and 110 deg (2 s): the robot moves when
        the next ESTOP comes."""
        self._flip = not self._flip
        self.send(f"MOVEJOINT|{70 if self._flip else 110}|-90|180|0|0|180|2|None")

    # ---- pings
    def start_pings(self) -> None:
        self._ping_stop.clear()
        self._ping_thread = threading.Thread(target=self._pings, name="flood-pings", daemon=True)
        self._ping_thread.start()

    def stop_pings(self) -> None:
        self._ping_stop.set()
        if self._ping_thread is not None:
            self._ping_thread.join(self.PING_TIMEOUT_S + 2)

    def _pings(self) -> None:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.settimeout(self.PING_TIMEOUT_S)
        while not self._ping_stop.is_set():
            t = time.monotonic()
            s.sendto(b"PING", self.addr)
            try:
                while not s.recv(65535).startswith(b"PONG"):
                    pass
                self.result.pings.append((t, time.monotonic() - t))
            except socket.timeout:
                self.result.pings.append((t, math.inf))
                s.close()  # its late PONG must not be taken for the next ping's
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                s.settimeout(self.PING_TIMEOUT_S)
            self._ping_stop.wait(self.PING_GAP_S)
        s.close()

    # ---- board frames
    def frames(self, since: float) -> list[list]:
        """Every frame the board received after ``since`` (paged through the control socket)."""
        sys_path_src = str(THIS_FILE.parents[2] / "src")
        if sys_path_src not in sys.path:
            sys.path.insert(0, sys_path_src)
        from parolkit.board.control import send_control

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
        from parolkit.board.control import send_control

        reply = send_control(self.control_path, "frames last=1", timeout_s=1.0)
        frames = json.loads(reply[3:])["frames"] if reply.startswith("ok ") else []
        return bool(frames) and frames[-1][2] != BOARD_DISABLE

    # ---- the ESTOP cycles
    def estop_cycles(self, moments: list[float], *, arm_wait_s: float = 0.3) -> list[float]:
        """ESTOP at each of ``moments`` (monotonic; once the board's last frame is not DISABLE,
        waiting at most ``arm_wait_s`` for that), then ENABLE and a new move. Returns send times."""
        self.frames(time.monotonic())  # imports the control client before the timed part
        sent = []
        self.send("ENABLE")
        self.move()
        for t in moments:
            time.sleep(max(0.0, t - time.monotonic()))
            end = time.monotonic() + arm_wait_s
            while not self._board_armed() and time.monotonic() < end:
                time.sleep(0.005)
            _, t_send = self.send("ESTOP")
            sent.append(t_send)
            time.sleep(max(0.0, t_send + self.ENABLE_AFTER_S - time.monotonic()))
            self.send("ENABLE")
            self.move()
        return sent

    def judge_estops(self, sent: list[float]) -> list[EstopResult]:
        """Count, in the board's frame log, the frames after each send before the first DISABLE."""
        frames = self.frames(min(sent) - 1.0) if sent else []
        results = []
        for t_send in sent:
            before = [f for f in frames if f[1] <= t_send]
            after = [f for f in frames if f[1] > t_send]
            armed = bool(before) and before[-1][2] != BOARD_DISABLE
            idx = next((i for i, f in enumerate(after) if f[2] == BOARD_DISABLE), None)
            results.append(EstopResult(
                t_send, armed, idx, None if idx is None else after[idx][1] - t_send))
        self.result.estops += results
        return results

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


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "send":
        sys.exit(flood_main(sys.argv[2:]))
    if len(sys.argv) >= 2 and sys.argv[1] == "acks":
        sys.exit(acks_main(sys.argv[2:]))
    print("usage: flood.py send HOST PORT RATE DURATION START_AT SEED | flood.py acks PORT",
          file=sys.stderr)
    sys.exit(2)
