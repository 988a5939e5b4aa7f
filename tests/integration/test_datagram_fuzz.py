"""The datagram path under arbitrary bytes, against the real controller process (issue 13):
nothing escapes (the controller keeps answering), every ID'd datagram gets exactly one terminal
ack, and the log stays within its byte budget.  Padding (NUL, tabs, line ends, foreign spaces)
and look-alike digits are refused by both parsers, the controller's and RBTscript's, and
nothing moves (issue 22)."""

from __future__ import annotations

import itertools
import json
import socket
import time
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.conftest import start_controller, wait_until

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


# ------------------------------------------------- padding and look-alike digits (issue 22)

#: Characters a datagram or a number was padded with, none of them protocol text: Python's
#: strip() and float() quietly dropped most of them ("\x00JOG|0|20|0.2|None" moved the arm)
_PADDING = ["\x00", "\t", "\n", "\r", "\x0b", "\x0c", "\x1c", "\x1f", "\x7f", "\x85", "\xa0", "\u2003",
            "\u3000", "\u200b"]
#: What RBTscript itself calls whitespace (spaces, tab, form feed, CR, BOM) or a line break: not padding there
_SCRIPT_WHITESPACE = "\t\x0c\r\n\ufeff"
#: The digit zero of other scripts (Unicode category Nd: float() reads every one of them)
_ZEROS = [0x0660, 0x06F0, 0x0966, 0x09E6, 0x0E50, 0x1040, 0xFF10, 0x1D7CE, 0x1D7D8, 0x1D7E2, 0x1D7EC, 0x1D7F6]

#: Valid commands: the datagram's fields, the indexes of its number fields, and the same command
#: as an RBTscript line (its numbers in order as {}), or None
_BASES = [
    (["JOG", "0", "20", "0.2", "None"], [1, 2, 3], None),
    (["MOVEJOINT", "80", "-80", "170", "0", "10", "170", "2", "None"], [1, 2, 3, 4, 5, 6, 7],
     "MoveJoint({}, {}, {}, {}, {}, {}, t={})"),
    (["DELAY", "0.5"], [1], "Delay({})"),
]


def _look_alike(number: str, zero: int) -> str:
    return "".join(chr(zero + int(c)) if c.isdigit() else c for c in number)


def _bad_commands() -> list[tuple[str, str | None]]:
    """(datagram, RBTscript line or None) pairs, each one padded or holding look-alike digits:
    padding at either end and on either side of every number field; each number field with
    the digits of each other script."""
    out: list[tuple[str, str | None]] = []
    for fields, numbers, line in _BASES:
        def add(i: int | None, value: str = "", ends: tuple[str, str] = ("", ""),
                fields: list[str] = fields, numbers: list[int] = numbers, line: str | None = line) -> None:
            mutated = [value if k == i else f for k, f in enumerate(fields)]
            text = line.format(*(mutated[k] for k in numbers)) if line else None
            out.append((ends[0] + "|".join(mutated) + ends[1], ends[0] + text + ends[1] if text else None))

        for pad in _PADDING:
            add(None, ends=(pad, ""))
            add(None, ends=("", pad))
            for i in numbers:
                add(i, pad + fields[i])
                add(i, fields[i] + pad)
        for zero in _ZEROS:
            for i in numbers:
                add(i, _look_alike(fields[i], zero))
    return out


def test_padded_and_look_alike_programs_are_refused_by_the_script_parser():
    from parolkit.script.parser import parse

    lines = [line for _, line in _bad_commands() if line is not None]
    lines = [line for line in lines if not set(line) & set(_SCRIPT_WHITESPACE)]
    assert len(lines) > 150
    accepted = [line for line in lines if parse(f"Begin()\n{line}\nEnd()").ok]
    assert accepted == [], f"{len(accepted)} of {len(lines)} accepted: {accepted[:5]!r}"
    # the same lines without the padding or the look-alike digits are programs
    for fields, numbers, line in _BASES:
        if line is not None:
            assert parse(f"Begin()\n{line.format(*(fields[k] for k in numbers))}\nEnd()").ok


def test_padded_and_look_alike_datagrams_are_refused_by_the_controller_and_nothing_moves(served):
    cases = [datagram for datagram, _ in _bad_commands()]
    assert len(cases) > 300
    before = _server(served)
    angles = served.query("GET_ANGLES", timeout=2.0)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.05)
    ctl = (served.host, served.port)
    seen: dict[str, list[str]] = {}
    sent: list[str] = []
    def drain() -> bool:
        try:
            while True:
                parts = sock.recvfrom(65535)[0].decode("utf-8", "replace").split("|", 3)
                if parts[0] == "ACK" and len(parts) >= 3 and parts[1].startswith("pd"):
                    seen.setdefault(parts[1], []).append(f"{parts[2]}|{parts[3] if len(parts) > 3 else ''}")
        except TimeoutError:
            pass
        return all(seen.get(c) for c in sent)

    try:
        sock.sendto(b"ACK_HERE", ctl)
        for k, text in enumerate(cases):
            cid = f"pd{k:06d}"
            sent.append(cid)
            sock.sendto(text.encode(), ctl)                 # without an ID
            sock.sendto(f"{cid}|{text}".encode(), ctl)      # and with one
            if k % 20 == 19:
                drain()  # paced: this is not the flood test
        try:
            wait_until(drain, timeout=60, what="an ack for every padded / look-alike datagram")
        except AssertionError:
            missing = [c for c in sent if not seen.get(c)]
            raise AssertionError(f"no ack for {len(missing)} of {len(sent)}: "
                                 + "; ".join(repr(cases[int(c[2:])]) for c in missing[:8])
                                 + f"; server {_server(served)}") from None
        time.sleep(0.3)
        drain()
        # a busy controller (a loaded machine: 256 of this client's datagrams waiting) refuses
        # with "busy" before it reads a datagram: those are sent again, one at a time, as a
        # client told to slow down would, until the controller has read each one
        for _ in range(20):
            busy = [c for c in sent if seen.get(c) and all("controller busy" in a for a in seen[c])]
            if not busy:
                break
            for c in busy:
                del seen[c]
                sock.sendto(f"{c}|{cases[int(c[2:])]}".encode(), ctl)
                wait_until(lambda c=c: drain() or bool(seen.get(c)), timeout=10, what=f"an ack for {c} sent again")
    finally:
        sock.close()
    not_invalid = {c: seen[c] for c in sent if len(seen[c]) != 1 or not seen[c][0].startswith("INVALID|")}
    assert not not_invalid, f"{len(not_invalid)} of {len(sent)} not refused: " + "; ".join(
        f"{cases[int(c[2:])]!r}: {acks}" for c, acks in list(not_invalid.items())[:5])
    for c in sent:  # the refusal names the problem
        details = seen[c][0]
        assert "control character" in details or "not ASCII" in details, (cases[int(c[2:])], details)
    after = _server(served)
    assert after["invalid"] - before["invalid"] == 2 * len(cases), (before, after)
    assert after["shed"] == before["shed"]
    assert served.query("GET_ANGLES", timeout=2.0) == angles  # nothing moved
    assert "Traceback" not in served.log()
