"""What the server knows about senders (issue 22): registered sockets, command-ID owners and
return-address cookies; and the server's datagram paths that must not let another sender's ID
through (the busy refusal of a flooded lane, the safety lane, invalid datagrams).

The records are tested as values; the server paths on a real UdpServer with real sockets
(no thread: the test calls the server's read and serve steps itself, as
test_controller_core's ACK_HERE test does)."""

from __future__ import annotations

import socket

import pytest
from tests.unit.test_controller_core import _Answers

from parolkit.controller.inbox import CommandInbox
from parolkit.controller.senders import (
    COOKIE_CHARS,
    CommandIds,
    KnownClients,
    ReturnCookies,
)
from parolkit.controller.server import Outbox, StatusStream, UdpServer
from parolkit.robot import PAROL6

A, B = ("127.0.0.1", 40001), ("127.0.0.1", 40002)


# ------------------------------------------------------------------ command IDs


def test_an_id_belongs_to_its_sender_while_live_and_while_recent():
    ids = CommandIds(recent=8)
    assert ids.claim("aaaa0001", A) is None
    assert ids.claim("aaaa0001", A) is None  # its own sender may repeat it
    assert ids.claim("aaaa0001", B) == A
    assert ids.has_live(A) and not ids.has_live(B)
    ids.ended("aaaa0001")
    assert not ids.has_live(A)
    assert ids.claim("aaaa0001", B) == A  # recent: still A's
    for i in range(8):  # eight newer IDs end: it drops out of the bounded window
        ids.claim(f"bbbb{i:04d}", B)
        ids.ended(f"bbbb{i:04d}")
    assert ids.claim("aaaa0001", B) is None
    assert ids.refused == 2


def test_a_flood_of_new_ids_never_forgets_a_live_one():
    ids = CommandIds(recent=16)
    ids.claim("live0001", A)
    for i in range(10_000):
        cid = f"f{i:07d}"
        assert ids.claim(cid, B) is None
        ids.ended(cid)
    assert ids.claim("live0001", B) == A
    assert ids.live == 1


# ------------------------------------------------------------------ registered sockets


def test_a_full_table_refuses_newcomers_and_never_pushes_out_a_pinned_socket():
    known = KnownClients(capacity=3, idle_s=10.0)
    socks = [("127.0.0.1", p) for p in (5001, 5002, 5003)]
    for s in socks:
        assert known.admit(s, 0.0, lambda a: False) is None
    refusal = known.admit(B, 5.0, lambda a: False)
    assert refusal is not None and "controller busy: 3 client sockets" in refusal and B not in known
    known.heard(socks[0], 6.0)  # the first one spoke: the second is now the longest silent
    pinned = {socks[1]}  # say, the lease holder
    assert known.admit(B, 20.0, lambda a: a in pinned) is None
    assert B in known and socks[1] in known and socks[2] not in known and socks[0] in known
    assert known.admit(A, 20.0, lambda a: True) is not None  # all pinned: nobody gives way
    assert len(known) == 3


# ------------------------------------------------------------------ cookies


def test_a_cookie_proves_one_address_for_one_to_two_periods():
    cookies = ReturnCookies(period_s=30.0)
    c = cookies.issue(A, 100.0)
    assert len(c) == COOKIE_CHARS and "|" not in c
    assert cookies.valid(A, c, 100.0) and cookies.valid(A, c, 119.9)  # same period, next one
    assert not cookies.valid(A, c, 150.0)  # two periods later
    assert not cookies.valid(B, c, 100.0)  # another port
    assert not cookies.valid(("127.0.0.2", A[1]), c, 100.0)  # another host
    assert not cookies.valid(A, None, 100.0) and not cookies.valid(A, c + "x", 100.0)
    assert not ReturnCookies().valid(A, ReturnCookies().issue(A, 100.0), 100.0)  # a key per process


# ------------------------------------------------------------------ the server's paths


@pytest.fixture
def rig():
    """A UdpServer on a real socket (not started), an ack-port listener and two client sockets."""
    socks = []

    def sock() -> socket.socket:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", 0))
        s.settimeout(1.0)
        socks.append(s)
        return s

    srv, acks, owner, other = sock(), sock(), sock(), sock()
    inbox = CommandInbox()
    server = UdpServer(srv, model=PAROL6, inbox=inbox, outbox=Outbox(srv), stream=StatusStream(srv),
                       answerer=_Answers(), ack_port=acks.getsockname()[1], max_waiting_per_source=4)
    yield server, inbox, acks, owner, other
    for s in socks:
        s.close()


def _nothing_on(s: socket.socket) -> bool:
    s.setblocking(False)
    try:
        s.recv(65535)
    except BlockingIOError:
        return True
    return False


def test_another_senders_id_gets_no_ack_from_a_flooded_lane_nor_from_an_invalid_datagram(rig):
    """Shedding (a source's lane full) acks "busy" to the datagram's ID, and an invalid
    datagram acks INVALID: with another sender's live ID both went to the owner's ack port."""
    server, inbox, acks, owner, other = rig
    cid = "own00001"
    server.handle(f"{cid}|DELAY|5".encode(), owner.getsockname())  # live, waiting for the loop
    assert [s.command_id for s in inbox.take()] == [cid]
    them = other.getsockname()
    for _ in range(10):  # four wait in the lane, six are shed
        server._take_in(f"{cid}|PING".encode(), them)
    server._take_in(f"{cid}|".encode() + b"\xff", them)  # shed too
    while server._turn:  # serve what waits
        src = server._turn.popleft()
        for seq, data in server._lanes.pop(src):
            server.handle(data, src, seq)
    server.handle(f"{cid}|".encode() + b"\xff", them)
    replies = [other.recv(65535).decode() for _ in range(12)]
    assert all(r.startswith("ERROR|") and f"command ID {cid} belongs to another client" in r for r in replies)
    assert server.shed == 7 and server.ids.refused == 12
    assert _nothing_on(acks) and _nothing_on(other)


def test_a_stop_with_another_senders_id_still_stops_but_acks_nobody(rig):
    server, inbox, acks, owner, other = rig
    cid = "own00002"
    server.handle(f"{cid}|DELAY|5".encode(), owner.getsockname())
    server._take_in(f"{cid}|STOP".encode(), other.getsockname())
    (stop,) = inbox.take_safety()
    assert stop.command.name == "STOP" and stop.command_id is None and stop.route is None
    reply = other.recv(65535).decode()
    assert reply.startswith("ERROR|STOP applied, but its ID was not used: command ID own00002 belongs")
    assert _nothing_on(acks)
