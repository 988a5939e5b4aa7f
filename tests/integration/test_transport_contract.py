"""One contract, every transport: the same test class runs on each kind of board link.

As python-can's back-to-back tests run one suite on every bus, :class:`TestTransportContract`
runs on every URL in :data:`KINDS`: the in-process emulator (both clocks), the emulator served
on a real pseudo-terminal and opened with pyserial (``serial://`` and a plain path), and the
wrappers (``faulty+`` with zero fault rates, ``spy+``, nested) around both.  Real parts only:
the real emulator, a real pty, real pyserial, real log files.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from parolkit.board import BoardEmulator, PtyBoardServer
from parolkit.protocol import BoardCommand, CommandFrame, StatusFrame, StatusParser
from parolkit.transport import (
    Transport,
    TransportError,
    parse_transport_url,
    transport_for_url,
)

#: id -> URL template; {pty} is the board's pty link, {log} a spy log file in tmp_path
KINDS = {
    "sim": "sim://",
    "sim-virtual-clock": "sim://?clock=virtual",
    "serial-url-pty": "serial://{pty}",
    "device-path-pty": "{pty}",
    "faulty-sim": "faulty+sim://?drop=0&flip=0&delay=0&seed=1",
    "faulty-pty": "faulty+serial://{pty}?drop=0&flip=0",
    "spy-sim": "spy+sim://?log={log}",
    "spy-pty": "spy+{pty}?log={log}&raw=1",
    "spy-faulty-sim": "spy+faulty+sim://?log={log}&drop=0",
}

ENABLE = CommandFrame(command=BoardCommand.ENABLE).encode()
IDLE = CommandFrame(command=BoardCommand.IDLE).encode()


def collect(t: Transport, parser: StatusParser, count: int, timeout_s: float = 3.0) -> list[StatusFrame]:
    """Read until ``count`` status frames arrived (or ``timeout_s`` passed)."""
    frames: list[StatusFrame] = []
    deadline = time.monotonic() + timeout_s
    while len(frames) < count and time.monotonic() < deadline:
        frames += parser.feed(t.read())
        if len(frames) < count:
            time.sleep(0.001)
    return frames


@pytest.fixture
def pty_link(tmp_path: Path) -> Iterator[Path]:
    """An emulated board served on a real pty; yields the symlink pyserial opens."""
    link = tmp_path / "p6"
    with PtyBoardServer(BoardEmulator(), link):
        yield link


@pytest.fixture(params=sorted(KINDS), ids=sorted(KINDS))
def url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    template = KINDS[request.param]
    pty = ""
    if "{pty}" in template:
        pty = str(request.getfixturevalue("pty_link"))
    return template.format(pty=pty, log=tmp_path / "spy.log")


@pytest.fixture
def make(url: str) -> Iterator[Callable[[], Transport]]:
    """Builds (unopened) links for ``url``; every link built is closed after the test."""
    made: list[Transport] = []

    def build() -> Transport:
        t = transport_for_url(url)
        made.append(t)
        return t

    yield build
    for t in made:
        t.close()


class TestTransportContract:
    """What the controller may rely on, whatever the link is."""

    def test_a_new_link_is_closed_and_open_opens_it(self, make: Callable[[], Transport]) -> None:
        t = make()
        assert not t.is_open
        t.open()
        assert t.is_open

    def test_read_returns_empty_bytes_without_blocking_when_nothing_arrived(
            self, make: Callable[[], Transport]) -> None:
        t = make()
        t.open()
        t0 = time.monotonic()
        for _ in range(20):
            data = t.read()
            assert data == b"" and isinstance(data, bytes)
        assert time.monotonic() - t0 < 0.5  # 20 reads, none waited for data

    def test_a_command_frame_gets_one_status_frame_back(self, make: Callable[[], Transport]) -> None:
        t = make()
        t.open()
        parser = StatusParser()
        t.write(ENABLE)
        frames = collect(t, parser, 1)
        assert len(frames) == 1
        assert frames[0].xtr == BoardCommand.ENABLE  # the board echoes the command it ran
        time.sleep(0.05)
        assert parser.feed(t.read()) == []  # one frame in, exactly one frame out
        assert parser.stats.bytes_dropped == 0 and parser.stats.frames_rejected == 0

    def test_frames_written_back_to_back_are_each_answered_in_order(
            self, make: Callable[[], Transport]) -> None:
        t = make()
        t.open()
        sent = [BoardCommand.ENABLE if i % 2 else BoardCommand.IDLE for i in range(20)]
        t.write(b"".join(CommandFrame(command=c).encode() for c in sent))
        frames = collect(t, StatusParser(), len(sent))
        assert [f.xtr for f in frames] == [int(c) for c in sent]

    def test_close_closes_and_closing_twice_is_harmless(self, make: Callable[[], Transport]) -> None:
        t = make()
        t.open()
        t.close()
        assert not t.is_open
        t.close()
        assert not t.is_open

    def test_write_and_read_after_close_raise_transport_error(
            self, make: Callable[[], Transport]) -> None:
        t = make()
        t.open()
        t.close()
        with pytest.raises(TransportError):
            t.write(IDLE)
        with pytest.raises(TransportError):
            t.read()

    def test_the_context_manager_opens_and_closes(self, make: Callable[[], Transport]) -> None:
        t = make()
        with t as entered:
            assert entered is t and t.is_open
            t.write(ENABLE)
            assert len(collect(t, StatusParser(), 1)) == 1
        assert not t.is_open

    def test_reconnect_gives_a_working_link_and_reopen_after_close_too(
            self, make: Callable[[], Transport]) -> None:
        t = make()
        t.open()
        t.reconnect()
        assert t.is_open
        t.write(ENABLE)
        assert len(collect(t, StatusParser(), 1)) == 1
        t.close()
        t.open()
        t.write(IDLE)
        assert [f.xtr for f in collect(t, StatusParser(), 1)] == [BoardCommand.IDLE]

    def test_description_names_every_layer_and_simulated_follows_the_url(
            self, make: Callable[[], Transport], url: str) -> None:
        t = make()
        parsed = parse_transport_url(url)
        prefix = "".join(f"{w.scheme.name}+" for w in parsed.wrappers)
        assert t.description.startswith(prefix)
        base = t.description[len(prefix):]
        if parsed.simulated:
            assert base == "emulated board"
        else:
            assert parsed.device is not None and base.startswith(parsed.device)
        assert t.simulated is parsed.simulated


def test_spy_on_a_real_pty_logs_both_directions_decoded(pty_link: Path, tmp_path: Path) -> None:
    log = tmp_path / "frames.log"
    with transport_for_url(f"spy+{pty_link}?log={log}") as t:
        t.write(ENABLE)
        assert len(collect(t, StatusParser(), 1)) == 1
    lines = log.read_text().splitlines()
    assert lines[0].endswith(f"-- open spy+{pty_link} @ 3000000")
    assert " PC>BOARD CommandFrame " in lines[1] and " command=ENABLE " in lines[1]
    assert " BOARD>PC StatusFrame " in lines[2] and " xtr=101 " in lines[2]
    assert lines[3].endswith("-- close") and len(lines) == 4
