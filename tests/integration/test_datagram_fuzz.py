"""The datagram path under arbitrary bytes, against the real controller process (issue 13):
nothing escapes (the controller keeps answering), every ID'd datagram gets exactly one terminal
ack, and the log stays within its byte budget."""

from __future__ import annotations

import itertools
import json
import socket
import time
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.conftest import start_controller

from parolkit.controller.server import LOG_BUDGET_BYTES_PER_S
from parolkit.protocol.commands import _NAMES, DatagramError, Subscribe, parse_datagram
from parolkit.robot import PAROL6

TERMINAL = {"COMPLETED", "FAILED", "CANCELLED", "INVALID"}


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    cp = start_controller(log_dir=tmp_path_factory.mktemp("fuzz"))
    yield cp
    cp.stop()


def _server(served) -> dict:
    reply = served.query("GET_STATUS_JSON", timeout=2.0)
    assert reply and reply.startswith("STATUS_JSON|"), reply
    return json.loads(reply.split("|", 1)[1])["server"]


#: IDs are never reused, not even across examples: an ID belongs to the socket that sent it
#: (issue 22), and every example sends from a new socket
_IDS = (f"fz{n:06d}" for n in itertools.count())


def _acks_expected(data: bytes) -> int:
    """Terminal acks an ID'd datagram gets: one, except a SUBSCRIBE that has not echoed its
    cookie (answered with COOKIE alone, docs/protocol.md "Status stream")."""
    try:
        return 0 if isinstance(parse_datagram(data, PAROL6).command, Subscribe) else 1
    except DatagramError:
        return 1


_NAME = st.sampled_from(sorted(_NAMES) + ["movejoint", "GET_", "ACK", ""])
_FIELD = st.one_of(st.binary(max_size=12), st.integers().map(lambda v: str(v).encode()),
                   st.sampled_from([b"", b"None", b"nan", b"1e999", b"0" * 5000, "٣".encode(), b"\xff",
                                    b"\x00", b"1,2,3", b"x" * 3000]))
_BODY = st.one_of(
    st.binary(max_size=200),
    st.tuples(_NAME, st.lists(_FIELD, max_size=10)).map(
        lambda t: b"|".join([t[0].encode()] + t[1])),
)


@pytest.mark.slow
@settings(max_examples=4, deadline=None, suppress_health_check=list(HealthCheck))
@given(bodies=st.lists(st.tuples(_BODY, st.booleans()), min_size=150, max_size=300))
def test_arbitrary_datagrams_get_exactly_one_terminal_ack_per_id_and_a_bounded_log(served, bodies):
    log_before = len(served.log().encode())
    received_before = _server(served)["received"]
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.2)
    ctl = (served.host, served.port)
    try:
        sock.sendto(b"ACK_HERE", ctl)
        sent: list[str] = []
        silent: list[str] = []  # ID'd SUBSCRIBEs without a cookie: no ack
        bodies_of: dict[str, bytes] = {}
        t0 = time.monotonic()
        for k, (body, with_id) in enumerate(bodies):
            if with_id:
                cid = next(_IDS)
                data = cid.encode() + b"|" + body
                if _acks_expected(data[:65000]):
                    sent.append(cid)
                    bodies_of[cid] = body
                else:
                    silent.append(cid)
            else:
                data = body
            sock.sendto(data[:65000], ctl)
            if k % 40 == 39:
                time.sleep(0.01)  # stay under the per-source share: this is not the flood test
        sock.sendto(b"STOP", ctl)
        acks: Counter[str] = Counter()
        seen: dict[str, list[str]] = {}

        def drain() -> bool:
            try:
                while True:
                    text = sock.recvfrom(65535)[0].decode("utf-8", "replace")
                    parts = text.split("|", 3)
                    if parts[0] == "ACK" and len(parts) >= 3:
                        seen.setdefault(parts[1], []).append(parts[2])
                        if parts[2] in TERMINAL:
                            acks[parts[1]] += 1
            except TimeoutError:
                pass
            return all(acks[c] >= 1 for c in sent)

        deadline = time.monotonic() + 60
        while not drain():
            if time.monotonic() > deadline:
                missing = [c for c in sent if not acks[c]]
                server = _server(served)
                raise AssertionError(
                    f"no terminal ack within 60 s for {len(missing)} of {len(sent)} IDs; "
                    f"the server received {server['received'] - received_before} of "
                    f"{len(bodies) + 3} datagrams (this query included); server counters {server}; first missing: "
                    + "; ".join(f"{c}: acks {seen.get(c)} body {bodies_of[c][:120]!r}"
                                for c in missing[:5]))
        time.sleep(0.5)
        drain()
        elapsed = time.monotonic() - t0
    finally:
        sock.sendto(b"STOP", ctl)
        sock.close()
    assert not [c for c in sent if acks[c] != 1], {c: seen.get(c) for c in sent if acks[c] != 1}
    assert not [c for c in silent if c in seen], {c: seen[c] for c in silent if c in seen}
    # the controller still answers, and nothing raised out of the datagram path
    assert served.query("PING") == "PONG"
    log = served.log()
    assert "Traceback" not in log, log[-3000:]
    grown = len(log.encode()) - log_before
    assert grown <= LOG_BUDGET_BYTES_PER_S * (elapsed + 2) + 2000, (grown, elapsed)
