"""SpyTransport and its frame log: every frame both ways decoded, timestamped, nothing lost."""

from __future__ import annotations

import io
import time
from datetime import datetime
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from parolkit.board import BoardEmulator
from parolkit.errors import ParolkitValueError
from parolkit.protocol import BoardCommand, CommandFrame, StatusFrame, StatusParser
from parolkit.transport import EmulatorTransport, LinkLostError, SpyTransport, TransportError
from parolkit.transport.framelog import SpyDirection, StreamSplitter, format_frame

ENABLE = CommandFrame(command=BoardCommand.ENABLE, positions=(1, -2, 3, -4, 5, -6)).encode()
IDLE = CommandFrame(command=BoardCommand.IDLE).encode()


def spy(log: object, **kw: object) -> SpyTransport:
    return SpyTransport(EmulatorTransport(clock="virtual"), log, **kw)  # type: ignore[arg-type]


def test_the_log_shows_both_directions_decoded_with_wall_and_monotonic_times(tmp_path: Path) -> None:
    path = tmp_path / "frames.log"
    t0 = time.monotonic()
    with spy(str(path)) as t:
        t.write(ENABLE)
        (reply,) = StatusParser().feed(t.read())
    t1 = time.monotonic()
    lines = path.read_text().splitlines()
    assert len(lines) == 4
    opened, sent, received, closed = (line.split(" ", 3) for line in lines)
    assert opened[2:] == ["--", "open spy+emulated board"]
    assert closed[2:] == ["--", "close"]
    assert sent[2] == "PC>BOARD" and received[2] == "BOARD>PC"
    assert sent[3].startswith("CommandFrame positions=1,-2,3,-4,5,-6 ")
    assert " command=ENABLE " in sent[3] and " affected=0b11111111 " in sent[3]
    assert received[3] == format_frame(reply)
    assert " xtr=101 " in received[3]
    for wall, mono, *_ in (opened, sent, received, closed):
        assert datetime.fromisoformat(wall).tzinfo is not None
        assert t0 <= float(mono) <= t1
    assert float(sent[1]) <= float(received[1])
    assert t.counters == {"frames_to_board": 1, "frames_from_board": 1,
                          "undecoded_to_board": 0, "undecoded_from_board": 0}


def test_bytes_that_are_no_frame_are_shown_in_hex_in_stream_order() -> None:
    out = io.StringIO()
    with spy(out) as t:
        t.write(b"\x00\x13\xab" + ENABLE[:10])
        t.write(ENABLE[10:] + b"\x7f")
        assert len(StatusParser().feed(t.read())) == 1
    lines = [line.split(" ", 2)[2] for line in out.getvalue().splitlines()]
    assert lines[1] == "PC>BOARD undecoded 3 bytes: 00 13 ab"
    assert lines[2].startswith("PC>BOARD CommandFrame ") and "command=ENABLE" in lines[2]
    assert lines[3] == "PC>BOARD undecoded 1 bytes: 7f"
    assert lines[4].startswith("BOARD>PC StatusFrame ")
    assert t.counters["undecoded_to_board"] == 4


def test_an_incomplete_frame_is_reported_at_close() -> None:
    out = io.StringIO()
    with spy(out) as t:
        t.write(IDLE[:20])
    lines = out.getvalue().splitlines()
    assert lines[-2].split(" ", 2)[2] == f"PC>BOARD incomplete 20 bytes at close: {IDLE[:20].hex(' ')}"
    assert lines[-1].endswith("-- close")


def test_raw_adds_every_frame_s_bytes_in_hex() -> None:
    out = io.StringIO()
    with spy(out, raw=True) as t:
        t.write(IDLE)
        t.read()
    sent = out.getvalue().splitlines()[1]
    assert sent.endswith(f" raw={IDLE.hex()}")


def test_log_dash_writes_to_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    with spy("-") as t:
        t.write(IDLE)
        t.read()
    err = capsys.readouterr().err
    assert " PC>BOARD CommandFrame " in err and " BOARD>PC StatusFrame " in err


def test_reconnect_appends_close_and_open_to_the_same_file(tmp_path: Path) -> None:
    path = tmp_path / "frames.log"
    path.write_text("earlier session\n")
    t = spy(path)
    t.open()
    t.write(IDLE)
    t.reconnect()
    t.write(IDLE)
    t.close()
    events = [line.split(" ", 3)[3] if " -- " in line else line.split(" ", 3)[2]
              for line in path.read_text().splitlines()[1:]]
    assert path.read_text().startswith("earlier session\n")
    assert events == ["open spy+emulated board", "PC>BOARD", "close", "open spy+emulated board",
                      "PC>BOARD", "close"]
    assert t.counters["frames_to_board"] == 2


def test_a_lost_link_is_logged_before_the_error_is_raised() -> None:
    out = io.StringIO()
    emu = BoardEmulator(clock="virtual")
    t = SpyTransport(EmulatorTransport(emu), out)
    t.open()
    emu.unplug()
    with pytest.raises(LinkLostError):
        t.write(IDLE)
    assert out.getvalue().splitlines()[-1].endswith(
        "-- PC>BOARD write of 56 bytes failed: LinkLostError: emulated board was unplugged")
    with pytest.raises(TransportError, match="not open"):
        t.read()
    t.close()


def test_a_log_file_that_cannot_be_opened_names_the_path_and_leaves_the_link_closed(
        tmp_path: Path) -> None:
    t = spy(tmp_path / "no-such-dir" / "frames.log")
    with pytest.raises(TransportError, match="no-such-dir/frames.log"):
        t.open()
    assert not t.is_open


def test_a_failed_open_is_logged(tmp_path: Path) -> None:
    out = io.StringIO()
    emu = BoardEmulator(clock="virtual")
    emu.unplug()
    t = SpyTransport(EmulatorTransport(emu), out)
    with pytest.raises(TransportError, match="unplugged"):
        t.open()
    assert out.getvalue().splitlines()[-1].endswith(
        "-- open failed: TransportError: cannot open the emulated board: it is unplugged")


@pytest.mark.parametrize("kwargs, name", [
    ({"inner": object()}, "inner"),
    ({"log": ""}, "log"),
    ({"log": 3}, "log"),
    ({"raw": "yes"}, "raw"),
])
def test_spy_checks_its_arguments(kwargs: dict[str, object], name: str) -> None:
    args: dict[str, object] = {"inner": EmulatorTransport(clock="virtual"), "log": "-"}
    args.update(kwargs)
    with pytest.raises(ParolkitValueError, match=name):
        SpyTransport(**args)  # type: ignore[arg-type]


STATUS = StatusFrame(xtr=101, positions=(1, 2, 3, 4, 5, 6)).encode()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.just(STATUS), st.binary(max_size=70),
                          st.just(STATUS[:30]), st.just(STATUS[30:])), max_size=12),
       st.integers(min_value=1, max_value=64))
def test_the_splitter_accounts_for_every_byte_in_order(chunks: list[bytes], cut: int) -> None:
    stream = b"".join(chunks)
    splitter = StreamSplitter(SpyDirection.FROM_BOARD)
    parser = StatusParser()
    pieces = []
    for i in range(0, len(stream), cut):
        pieces += splitter.feed(stream[i:i + cut])
    assert b"".join(p.raw for p in pieces) + splitter.pending() == stream
    frames = [p.frame for p in pieces if p.frame is not None]
    assert frames == parser.feed(stream)  # exactly what the controller's parser accepts
    assert all(p.raw == p.frame.encode() for p in pieces if p.frame is not None)
