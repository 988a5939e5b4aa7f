"""The status stream sends every tick's snapshot, in order, even when its thread falls behind.

Real parts: a real UDP socket pair on 127.0.0.1 and real snapshots from the control loop (the
virtual-clock rig of test_controller_core)."""

from __future__ import annotations

import json
import socket

from tests.conftest import wait_until
from tests.unit.test_controller_core import Rig

from parolkit.controller.server import StatusStream


def test_every_ticks_snapshot_reaches_a_subscriber_in_order_even_after_a_stall():
    """200 ticks (2 s) handed over while the stream thread had no chance to run (a loaded machine):
    the stream used to send only the newest snapshot when its thread woke, so a recorder lost
    ticks (issue 16's 0-dropped-ticks figure).  All 200 arrive, in order."""
    rig = Rig()
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    out.bind(("127.0.0.1", 0))
    sub = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sub.bind(("127.0.0.1", 0))
    sub.settimeout(5.0)
    sub.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    stream = StatusStream(out)
    try:
        assert stream.subscribe(sub.getsockname(), 1) is None
        snaps = []
        for _ in range(200):
            rig.tick()
            snaps.append(rig.outputs[-1].snapshot)
        for s in snaps:  # all handed over before the thread runs at all
            stream.notify(s)
        stream.start()
        seqs = []
        while len(seqs) < 200:
            data = sub.recv(65535).decode()
            seqs.append(json.loads(data.split("|", 1)[1])["seq"])
        assert seqs == [s.seq for s in snaps]
        # (the thread counts a datagram after sendto returns: the 200th may arrive first)
        wait_until(lambda: stream.sent == 200, 5.0, what="200 counted as sent")
        assert stream.overflowed == 0
    finally:
        stream.stop()
        out.close()
        sub.close()
        rig.close()


def test_a_stream_queue_that_overflows_counts_what_it_dropped():
    rig = Rig()
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    stream = StatusStream(out)
    try:
        stream.subscribe(("127.0.0.1", 9), 1)
        rig.tick()
        snap = rig.outputs[-1].snapshot
        for _ in range(StatusStream.QUEUE_TICKS + 5):
            stream.notify(snap)
        assert stream.overflowed == 5
    finally:
        out.close()
        rig.close()
