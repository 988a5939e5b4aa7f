"""Transports: in-process emulator link, fault-injecting wrapper, factory, argument checks."""

from __future__ import annotations

import time

import pytest

from parolkit.board import BoardEmulator
from parolkit.errors import ParolkitValueError
from parolkit.protocol import BoardCommand, CommandFrame, StatusParser
from parolkit.transport import (
    EmulatorTransport,
    FaultyTransport,
    LinkLostError,
    SerialTransport,
    Transport,
    TransportError,
    open_transport,
)

IDLE = CommandFrame(command=BoardCommand.IDLE).encode()


def roundtrip(t: Transport, data: bytes = IDLE, wait_s: float = 0.0) -> list:
    parser = StatusParser()
    t.write(data)
    if wait_s:
        time.sleep(wait_s)
    return parser.feed(t.read())


def test_emulator_transport_answers_every_frame_with_one_status_frame():
    with EmulatorTransport(clock="virtual") as t:
        assert t.simulated and t.description == "emulated board" and t.is_open
        frames = roundtrip(t, CommandFrame(command=BoardCommand.ENABLE).encode())
        assert len(frames) == 1 and frames[0].xtr == 101
        assert t.read() == b""  # nothing unsolicited


def test_emulator_transport_starts_and_stops_the_realtime_loop():
    t = EmulatorTransport(homing_speedup=10)
    assert not t.emulator.running
    t.open()
    assert t.emulator.running
    t.close()
    assert not t.emulator.running


def test_emulator_transport_uses_a_given_emulator_for_test_control():
    emu = BoardEmulator(clock="virtual")
    with EmulatorTransport(emu) as t:
        assert t.emulator is emu
        emu.set_estop(True)
        assert roundtrip(t)[0].estop_pressed


def test_emulator_transport_unplug_raises_link_lost_and_reopen_after_replug_works():
    with EmulatorTransport(clock="virtual") as t:
        t.emulator.unplug()
        with pytest.raises(LinkLostError):
            t.write(IDLE)
        assert not t.is_open
        with pytest.raises(TransportError, match="unplugged"):
            t.open()
        t.emulator.replug()
        t.open()
        assert len(roundtrip(t)) == 1


def test_emulator_transport_refuses_use_before_open():
    t = EmulatorTransport(clock="virtual")
    with pytest.raises(TransportError, match="not open"):
        t.read()


def test_emulator_transport_rejects_conflicting_arguments():
    with pytest.raises(ParolkitValueError, match="emulator"):
        EmulatorTransport(BoardEmulator(clock="virtual"), homing_speedup=2)
    with pytest.raises(ParolkitValueError, match="emulator"):
        EmulatorTransport("board")  # type: ignore[arg-type]
    with pytest.raises(ParolkitValueError, match="homing_speedup"):
        EmulatorTransport(homing_speedup=-1)


def test_open_transport_none_gives_an_open_emulator_link():
    t = open_transport(None, clock="virtual")
    try:
        assert isinstance(t, EmulatorTransport) and t.is_open
        assert len(roundtrip(t)) == 1
    finally:
        t.close()


def test_open_transport_reports_a_missing_serial_port_by_name():
    with pytest.raises(TransportError, match="/nonexistent/ttyPAROL"):
        open_transport("/nonexistent/ttyPAROL")
    with pytest.raises(ParolkitValueError, match="empty transport URL"):
        open_transport("")


@pytest.mark.parametrize(
    "args, kwargs, field",
    [
        (("",), {}, "port"),
        ((None,), {}, "port"),
        (("/dev/x",), {"baud": 0}, "baud"),
        (("/dev/x",), {"baud": 3e6}, "baud"),
        (("/dev/x",), {"write_timeout_s": 0}, "write_timeout_s"),
    ],
)
def test_serial_transport_checks_its_arguments(args, kwargs, field):
    with pytest.raises(ParolkitValueError, match=field):
        SerialTransport(*args, **kwargs)


def test_serial_transport_refuses_use_before_open():
    t = SerialTransport("/dev/null-parolkit")
    assert not t.is_open and t.description == "/dev/null-parolkit @ 3000000"
    with pytest.raises(TransportError, match="not open"):
        t.write(IDLE)


def test_faulty_transport_dropping_everything_means_no_reply():
    with FaultyTransport(EmulatorTransport(clock="virtual"), drop_rate=1.0, seed=3) as t:
        assert roundtrip(t) == []
        assert t.counters["tx_dropped"] == len(IDLE)
        t.set_faults(drop_rate=0.0)
        assert len(roundtrip(t)) == 1


def test_faulty_transport_corruption_is_caught_by_the_parsers():
    with FaultyTransport(EmulatorTransport(clock="virtual"), corrupt_rate=0.02, seed=11) as t:
        parser = StatusParser()
        good = 0
        for _ in range(200):
            t.write(IDLE)
            good += len(parser.feed(t.read()))
        assert 50 < good < 200
        assert t.counters["tx_corrupted"] + t.counters["rx_corrupted"] > 0
        assert parser.stats.frames_rejected + parser.stats.bytes_dropped > 0


def test_faulty_transport_delay_and_silence():
    with FaultyTransport(EmulatorTransport(clock="virtual"), delay_s=0.05) as t:
        assert roundtrip(t) == []
        parser, frames, t0 = StatusParser(), [], time.monotonic()
        while not frames and time.monotonic() - t0 < 1.0:
            time.sleep(0.01)
            frames = parser.feed(t.read())
        assert len(frames) == 1
        assert time.monotonic() - t0 >= 0.09  # 50 ms out + 50 ms back
        t.set_faults(silent=True)
        assert roundtrip(t) == []


def test_faulty_transport_names_its_inner_link_and_refuses_use_when_closed():
    t = FaultyTransport(EmulatorTransport(clock="virtual"), drop_rate=1.0)
    assert t.description == "faulty+emulated board" and t.simulated
    # every byte would be dropped, so the inner link never sees the call: the wrapper checks
    with pytest.raises(TransportError, match="faulty\\+emulated board: the link is not open"):
        t.write(IDLE)
    with pytest.raises(TransportError, match="not open"):
        t.read()


def test_faulty_transport_checks_its_arguments():
    with pytest.raises(ParolkitValueError, match="inner"):
        FaultyTransport(object())  # type: ignore[arg-type]
    with pytest.raises(ParolkitValueError, match="corrupt_rate"):
        FaultyTransport(EmulatorTransport(clock="virtual"), corrupt_rate=1.5)
    with pytest.raises(ParolkitValueError, match="bogus"):
        FaultyTransport(EmulatorTransport(clock="virtual"), bogus=1)


def test_a_lockstep_board_runs_exactly_one_step_per_frame_whatever_the_wall_clock_does():
    """``sim://?clock=virtual&step=0.01``: each frame written runs the board 10 ms, so the same
    frames give the same replies however long the PC waited between them."""
    jog = CommandFrame(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0)).encode()
    runs = []
    for pause in (0.0, 0.03):
        t = open_transport("sim://?clock=virtual&step=0.01&homed=1")
        try:
            assert t.emulator.time_s == 0.0
            replies = []
            for _ in range(5):
                replies += roundtrip(t, jog, wait_s=pause)
            assert abs(t.emulator.time_s - 0.05) < 1e-9  # 5 frames, 5 steps: no wall-clock time
            runs.append([f.positions[0] for f in replies])
        finally:
            t.close()
    assert runs[0] == runs[1] and runs[0][-1] - runs[0][0] == 40  # 4 steps of 10 ms at 1000 steps/s


@pytest.mark.parametrize("wrapped", ["spy+sim://?log={log}", "faulty+sim://?drop=0", "spy+faulty+sim://?log={log}"])
def test_a_lockstep_board_stays_in_lockstep_inside_spy_and_faulty_wrappers(wrapped, tmp_path):
    """The controller schedules trajectories on its ticks when the link says its board runs one
    step per frame (``step_s``): a wrapper passes its inner board's on, or a spied lockstep
    board would be driven as if it ran on the wall clock."""
    url = wrapped.format(log=tmp_path / "frames.log")
    assert open_transport(url).step_s is None  # a board on its own clock
    t = open_transport(url + "&clock=virtual&step=0.01&homed=1")
    assert t.step_s == 0.01
    jog = CommandFrame(command=BoardCommand.JOG, speeds=(1000, 0, 0, 0, 0, 0)).encode()
    try:
        replies = [f for _ in range(5) for f in roundtrip(t, jog, wait_s=0.02)]
    finally:
        t.close()
    assert replies[-1].positions[0] - replies[0].positions[0] == 40  # 4 frames after the first, 10 ms each


@pytest.mark.parametrize("url, fragment", [
    ("sim://?step=0.01", "step .* needs clock=virtual"),
    ("sim://?clock=virtual&step=0", r"step='0' is not allowed: expected 0.0001..1 s"),
    ("sim://?clock=virtual&step=x", "step='x'"),
])
def test_a_lockstep_board_needs_the_virtual_clock_and_a_step_in_range(url, fragment):
    with pytest.raises((ParolkitValueError, TransportError, ValueError), match=fragment):
        open_transport(url)


class _StallingClock:
    """A monotonic clock that jumps by ``step_s`` at every read: each read is as if the process had
    just been stopped that long (SIGSTOP, a busy machine) between two lines of the write."""

    def __init__(self, step_s: float) -> None:
        self.now = 1000.0
        self.step_s = step_s

    def __call__(self) -> float:
        self.now += self.step_s
        return self.now


@pytest.fixture
def pty_serial():
    import os
    import tty

    master, slave = os.openpty()
    tty.setraw(master)
    t = SerialTransport(os.ttyname(slave), write_timeout_s=0.1)
    t.open()
    try:
        yield t, master
    finally:
        t.close()
        os.close(master)
        os.close(slave)


def test_a_serial_write_that_went_through_is_no_timeout_however_long_the_process_was_stalled(
        pty_serial, monkeypatch):
    # pyserial's own write raises "Write timeout" after a complete os.write when its timer expired
    # meanwhile: a controller stopped for 200 ms reported the board link lost though every byte had
    # gone out.  A write is judged by whether the bytes went, not by the clock.
    import os

    import serial.serialutil

    from parolkit.transport import serial_port

    t, master = pty_serial
    clock = _StallingClock(0.5)
    monkeypatch.setattr(serial.serialutil.Timeout, "TIME", clock)
    monkeypatch.setattr(serial_port, "_clock", clock)
    t.write(IDLE)
    got = b""
    while len(got) < len(IDLE):
        got += os.read(master, 4096)
    assert got == IDLE


def test_a_serial_write_the_other_end_never_takes_times_out_naming_port_and_bytes(pty_serial):
    # nobody reads the pty: the kernel's buffer fills and the rest of the write cannot go out
    t, _master = pty_serial
    big = bytes(range(256)) * 4096  # 1 MiB, far more than a pty buffers
    t0 = time.monotonic()
    with pytest.raises(TransportError, match=r"write timed out after 0\.1 s \(\d+ of 1048576 bytes written\)"):
        t.write(big)
    assert time.monotonic() - t0 < 5.0
    assert t.is_open  # a slow reader is not a lost link: the port stays open
