"""What the server knows about senders (issue 22): the sockets registered for their acks."""

from __future__ import annotations

from parolkit.controller.senders import KnownClients

A, B = ("127.0.0.1", 40001), ("127.0.0.1", 40002)


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
