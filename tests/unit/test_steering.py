"""The command port's safety socket (parolkit.controller.steering): the kernel sorts a datagram
that may be a stop into a queue of its own, and the tick reads it there, so a stop never waits
behind a flood in the command socket's queue.  Real UDP sockets on 127.0.0.1; the controller's
own bind, server and driver on a simulated board in lockstep, ticked by the test."""

from __future__ import annotations

import socket

import pytest
from tests.conftest import free_udp_port

from parolkit.config import load_config
from parolkit.controller.app import Controller
from parolkit.controller.driver import Driver
from parolkit.controller.steering import SAFETY_MAX_BYTES, open_command_port
from parolkit.protocol.frames import BoardCommand
from parolkit.transport import open_transport

#: datagrams sent ahead of the stops: more than a starved server thread reads in a tick, few
#: enough for the smallest receive buffer Linux gives (net.core.rmem_max 208 KiB x 2)
AHEAD = 200
FLOOD = (b"GET_STATUS", b"abcd0001|STREAM|OFF", b"\x00" * 12, b"STO", b"X" * (SAFETY_MAX_BYTES - 3) + b"STOP")
STOPS = (b"abCd1234|ESTOP", b"STOP", b"disable", b"ACK_HERE", b"ESTOPX", b"x" * (SAFETY_MAX_BYTES - 4) + b"stop")


def _read_all(sock: socket.socket) -> list[bytes]:
    sock.setblocking(False)
    out = []
    while True:
        try:
            out.append(sock.recv(65535))
        except BlockingIOError:
            return out


def _ticked_controller(ack_port: int) -> tuple[Controller, Driver]:
    """The controller's own bind, server and driver on a simulated board in lockstep, acks to
    ``ack_port``; no thread started: the test ticks the driver and plays the server thread."""
    cfg = load_config(None).with_overrides(
        {"controller": {"udp_port": free_udp_port(), "ack_port": ack_port, "supervisor": False}})
    ctl = Controller(cfg)
    ctl.bind()
    ctl.assemble_server(ctl.sock)
    board = open_transport(f"sim://?clock=virtual&step={cfg.controller.period_s!r}&homed=1")
    return ctl, ctl.assemble_driver(board, plan_inline=True)


def _close(ctl: Controller, driver: Driver, ack: socket.socket) -> None:
    driver.stop()
    ctl.server.stop()
    for s in (ctl.sock, ctl.safety_sock, ack):
        if s is not None:
            s.close()


@pytest.fixture
def client():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    yield s
    s.close()


def test_the_kernel_puts_what_may_be_a_stop_in_the_safety_socket_ahead_of_the_datagrams_before_it(client):
    port = open_command_port("127.0.0.1", 0, rcvbuf=1 << 21)
    try:
        assert port.safety is not None, port.why_not
        dest = port.sock.getsockname()
        assert port.safety.getsockname() == dest
        for k in range(AHEAD):
            client.sendto(FLOOD[k % len(FLOOD)], dest)
        for text in STOPS:
            client.sendto(text, dest)
        # (on loopback a datagram is in its socket's queue when sendto returns)
        assert _read_all(port.safety) == list(STOPS)
        assert _read_all(port.sock) == [FLOOD[k % len(FLOOD)] for k in range(AHEAD)]
    finally:
        port.sock.close()
        if port.safety is not None:
            port.safety.close()


def test_a_port_in_use_still_fails_to_bind_although_the_controller_shares_it_with_its_safety_socket():
    port = open_command_port("127.0.0.1", 0, rcvbuf=1 << 16)
    number = port.sock.getsockname()[1]
    try:
        with pytest.raises(OSError, match="in use"):
            open_command_port("127.0.0.1", number, rcvbuf=1 << 16)
        plain = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        with pytest.raises(OSError, match="in use"):
            plain.bind(("127.0.0.1", number))
        plain.close()
    finally:
        port.sock.close()
        if port.safety is not None:
            port.safety.close()


def test_the_tick_writes_disable_for_an_estop_behind_a_flood_the_server_thread_has_not_read(client):
    """Issue 23: under two CPU hogs and a 20,000/s flood the server thread read an ESTOP
    50-570 ms after it was sent (it waited behind the flood in the socket's queue), and the
    DISABLE reached the board up to 58 frames late.  Here the server thread never runs at all
    (the worst a starved one can do) and 200 datagrams wait before the ESTOP: the next tick
    still writes DISABLE, and the ESTOP's ID is acked to its sender."""
    ack = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    ack.bind(("127.0.0.1", 0))
    ctl, driver = _ticked_controller(ack.getsockname()[1])
    host, number = ctl.sock.getsockname()[:2]
    try:
        def tick():
            out = driver.tick(driver.tick_count * driver.period)
            driver.tick_count += 1
            ctl._publish(out)
            return out

        for _ in range(40):  # the start-up probe; an enabled, homed, idle robot
            out = tick()
        client.sendto(b"enab0001|ENABLE", (host, number))
        ctl.server.serve_now(*ctl.sock.recvfrom(65535))  # (the server thread's work, once)
        for _ in range(5):
            out = tick()
        assert out.frame is not None and out.frame.command != BoardCommand.DISABLE, out.frame
        for k in range(AHEAD):
            client.sendto(FLOOD[k % len(FLOOD)], (host, number))
        client.sendto(b"estp0001|ESTOP", (host, number))
        out = tick()
        assert out.frame is not None and out.frame.command == BoardCommand.DISABLE, out.frame
        assert ctl.server.steered == 1
        ctl.outbox.send_waiting()
        ack.settimeout(2.0)
        acks = [ack.recv(65535) for _ in range(2)]
        assert any(a.startswith(b"ACK|estp0001|COMPLETED") for a in acks), acks
    finally:
        _close(ctl, driver, ack)


def test_an_ack_here_and_the_id_d_stop_after_it_keep_their_order_through_the_safety_socket(client):
    """ACK_HERE takes effect as it is read, so the acks of an ID'd STOP sent right after it
    reach the socket that asked: both go to the safety socket, one queue, in order; the
    ACK_HERE itself is handed on to the server thread for its own ack."""
    cfg = load_config(None).with_overrides({"controller": {"udp_port": free_udp_port()}})
    ctl = Controller(cfg)
    host, number = ctl.bind()
    ctl.assemble_server(ctl.sock)
    try:
        for text in (b"ACK_HERE", b"stop0001|STOP", b"dis00001|DISABLE"):
            client.sendto(text, (host, number))
        ctl.server.read_safety_socket()  # what the tick does
        me = client.getsockname()
        subs = ctl.inbox.take_safety()
        assert [s.command_id for s in subs] == ["stop0001", "dis00001"]
        for s in subs:
            assert me in s.route, (s.command_id, s.route)
        assert [d for _, d, _ in ctl.server._passed] == [b"ACK_HERE"]
    finally:
        ctl.server.stop()
        for s in (ctl.sock, ctl.safety_sock):
            if s is not None:
                s.close()


def test_a_command_sent_after_ack_here_is_acked_to_the_socket_that_asked_whoever_reads_the_safety_socket(client):
    """``Robot(ack_port=0)`` sends ACK_HERE (to the safety socket) and then MOVEJOINT (to the
    command socket): with only the tick reading the safety socket, the server thread served the
    move before the ACK_HERE was read and its acks went to the ack port alone (the client timed
    out: tests/integration/test_control_lease.py).  The server thread reads the safety socket
    too before it serves what it read; here no tick runs at all."""
    cfg = load_config(None).with_overrides({"controller": {"udp_port": free_udp_port()}})
    ctl = Controller(cfg)
    host, number = ctl.bind()
    ctl.assemble_server(ctl.sock)
    ctl.outbox.start()
    ctl.server.start()
    try:
        client.settimeout(2.0)
        client.sendto(b"ACK_HERE", (host, number))
        client.sendto(b"ping0001|PING", (host, number))
        got = [client.recv(65535) for _ in range(2)]  # PONG and the ack
        assert b"PONG" in got and any(g.startswith(b"ACK|ping0001|COMPLETED") for g in got), got
    finally:
        ctl.server.stop()
        ctl.outbox.stop()
        for s in (ctl.sock, ctl.safety_sock):
            if s is not None:
                s.close()


def test_a_stop_read_by_the_tick_before_the_server_reads_an_earlier_move_still_cancels_that_move(client):
    """MOVEJOINT, then STOP: the STOP goes to the safety socket and the tick may read it before
    the server thread reads the move (test_controller_sim's command-after-STOP test saw the
    move start after the STOP and run).  Receive numbers are the kernel's arrival times on
    both sockets, so the core knows the move came before the STOP and cancels it."""
    ack = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    ack.bind(("127.0.0.1", 0))
    ctl, driver = _ticked_controller(ack.getsockname()[1])
    host, number = ctl.sock.getsockname()[:2]
    acks: list = []
    try:
        def tick():
            out = driver.tick(driver.tick_count * driver.period)
            driver.tick_count += 1
            ctl._publish(out)
            acks.extend((a.command_id, a.status.name) for a in out.acks)

        for _ in range(40):  # the start-up probe; an enabled, homed, idle robot
            tick()
        client.sendto(b"move0001|MOVEJOINT|80|-90|170|0|0|180|2|None", (host, number))
        client.sendto(b"stop0001|STOP", (host, number))
        tick()  # the tick reads the STOP first (the server thread has not run)
        ctl.server._drain()  # now the server thread reads and serves the move
        while ctl.server._turn:
            ctl.server._serve_one()
        for _ in range(5):
            tick()
        move = [s for c, s in acks if c == "move0001"]
        assert "EXECUTING" not in move and move[-1] == "CANCELLED", acks
        assert ("stop0001", "COMPLETED") in acks, acks
    finally:
        _close(ctl, driver, ack)


def test_datagrams_the_kernel_dropped_for_a_full_buffer_are_counted_in_overload(client):
    """A client faster than the server reads fills the socket's receive buffer, and the kernel
    drops the rest before the controller sees them (the 20,000/s flood test lost 1.9 % of its
    datagrams so on a busy CI machine).  Nothing can answer those, but the controller counts
    them, with the kernel's own count, so GET_STATUS's OVERLOAD shows them."""
    ack = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    ack.bind(("127.0.0.1", 0))
    ctl, driver = _ticked_controller(ack.getsockname()[1])
    # the smallest buffer the kernel gives: a few hundred datagrams fill it
    ctl.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1)
    dest = ctl.sock.getsockname()[:2]
    try:
        for _ in range(2000):  # (loopback: each is queued or dropped when sendto returns)
            client.sendto(b"GET_STATUS", dest)
        dropped = _kernel_drops(dest[1])
        assert dropped > 0, "the kernel dropped nothing: the buffer did not fill"
        ctl.server._drain()
        assert ctl.server.read_main + dropped == 2000
        # the kernel stamps its count on the datagrams that arrive after the drops
        assert ctl.server.kernel_dropped == 0
        client.sendto(b"PING", dest)
        ctl.server._drain()
        assert ctl.server.kernel_dropped == dropped
        assert ctl.server.overload_view()["kernel_dropped"] == dropped
        assert ctl.server.overload >= dropped
    finally:
        _close(ctl, driver, ack)


def _kernel_drops(port: int) -> int:
    """The drops column of /proc/net/udp, summed over the sockets bound to ``port``."""
    with open("/proc/net/udp") as f:
        rows = [line.split() for line in f.read().splitlines()[1:]]
    return sum(int(r[-1]) for r in rows if int(r[1].rsplit(":", 1)[1], 16) == port)
