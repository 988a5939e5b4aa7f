"""Stream parser: arbitrary chunking, resynchronisation, and no false frame ever accepted."""

from __future__ import annotations

import random

from hypothesis import given, settings
from hypothesis import strategies as st

from parolkit.protocol import CommandFrame, CommandParser, StatusFrame, StatusParser

POS = st.lists(st.integers(-(1 << 23), (1 << 23) - 1), min_size=6, max_size=6)


def status_frames(n: int, seed: int) -> list[StatusFrame]:
    rnd = random.Random(seed)
    return [
        StatusFrame(
            positions=[rnd.randint(-(1 << 23), (1 << 23) - 1) for _ in range(6)],
            speeds=[rnd.randint(-50000, 50000) for _ in range(6)],
            homed=rnd.choice([0x03, 0xFF, 0x83]),
            io=rnd.randint(0, 255),
            timing=rnd.randint(0, 65535),
            xtr=rnd.choice([255, 156, 123, 100]),
            gripper_position=rnd.randint(0, 255),
            gripper_current=rnd.randint(-2000, 2000),
            gripper_status=rnd.randint(0, 255),
        )
        for _ in range(n)
    ]


def test_whole_frames_in_one_chunk():
    frames = status_frames(10, 1)
    p = StatusParser()
    assert p.feed(b"".join(f.encode() for f in frames)) == frames
    assert p.stats.frames_ok == 10 and p.stats.bytes_dropped == 0 and p.pending == 0


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 10_000), st.lists(st.integers(1, 70), min_size=1, max_size=40))
def test_any_chunking_yields_the_same_frames(seed, cuts):
    frames = status_frames(5, seed)
    data = b"".join(f.encode() for f in frames)
    p = StatusParser()
    out, i, k = [], 0, 0
    while i < len(data):
        n = cuts[k % len(cuts)]
        out += p.feed(data[i : i + n])
        i += n
        k += 1
    assert out == frames


def test_garbage_before_between_and_after_is_dropped_and_counted():
    frames = status_frames(3, 2)
    junk = b"\x00\xff\xff\x12\xff\xff\xff\x10garbage"
    data = junk + frames[0].encode() + junk + frames[1].encode() + frames[2].encode() + b"\xff\xff"
    p = StatusParser()
    assert p.feed(data) == frames
    assert p.stats.bytes_dropped == 2 * len(junk)
    assert p.stats.bad_len >= 2
    assert p.pending == 2  # a trailing FF FF may start the next frame


def test_frame_hidden_behind_a_truncated_one_is_found():
    a, b = status_frames(2, 3)
    data = a.encode()[:30] + b.encode()  # a lost its tail
    p = StatusParser()
    assert p.feed(data) == [b]
    assert p.stats.frames_rejected >= 1


def test_wrong_end_bytes_and_wrong_len_are_rejected():
    good = StatusFrame().encode()
    p = StatusParser()
    assert p.feed(good[:-1] + b"\x03") == []
    assert p.stats.bad_end == 1
    assert p.feed(good[:3] + b"\x34" + good[4:]) == []
    assert p.feed(good) == [StatusFrame()]


def test_wrong_constant_crc_is_rejected_unless_disabled():
    odd = StatusFrame(crc=7).encode()
    assert StatusParser().feed(odd) == []
    assert StatusParser(check_crc=False).feed(odd) == [StatusFrame(crc=7)]


def test_command_parser_reads_pc_frames_and_ignores_status_frames():
    c = CommandFrame(positions=[1, 2, 3, 4, 5, 6], command=156)
    p = CommandParser()
    assert p.feed(StatusFrame().encode() + c.encode()) == [c]
    assert p.stats.bad_len == 1


def test_garbage_never_grows_the_buffer():
    p = StatusParser()
    rnd = random.Random(5)
    for _ in range(200):
        p.feed(bytes(rnd.choice(b"\x00\x01\x02\x38\x10\x42") for _ in range(500)))
        assert p.pending <= 2
    assert p.stats.frames_ok == 0


def test_feed_refuses_non_bytes():
    import pytest

    with pytest.raises(TypeError, match="needs bytes"):
        StatusParser().feed("text")  # type: ignore[arg-type]


@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 1_000_000),
    n=st.integers(1, 25),
    ops=st.lists(
        st.tuples(st.sampled_from(["drop", "insert", "flip", "dup", "truncate"]), st.floats(0, 1), st.integers(0, 255)),
        max_size=30,
    ),
    chunk=st.integers(1, 128),
)
def test_fuzz_damaged_streams_never_yield_a_false_frame(seed, n, ops, chunk):
    """Split and damage a stream of frames at random. Every frame the parser accepts must be
    well-formed (exact size, LEN, CRC and end bytes re-checked by the strict decoder), and a
    frame that came out of a stream that only LOST bytes (the serial failure mode) must be
    byte-identical to one that was sent: the tail of one frame and the head of the next never
    assemble into a new frame.  Limits of any checksum-less link, documented in
    parolkit.protocol.stream: bytes changed in place inside a payload are undetectable, and so
    is a loss of exactly one whole frame's worth of bytes straddling a boundary; the test
    therefore keeps the total loss below one frame (60 bytes)."""
    frames = status_frames(n, seed)
    data = bytearray(b"".join(f.encode() for f in frames))
    loss_only = True
    lost = 0
    for op, where, byte in ops:
        if not data:
            break
        i = int(where * (len(data) - 1))
        if op in ("drop", "truncate"):
            n_lost = min(1 if op == "drop" else 20, 59 - lost)
            del data[i : i + n_lost]
            lost += n_lost
        else:
            loss_only = False
            if op == "insert":
                data.insert(i, byte)
            elif op == "dup":
                data[i:i] = data[i : i + 5]
            else:
                data[i] ^= byte or 1
    p = StatusParser()
    out = []
    for k in range(0, len(data), chunk):
        out += p.feed(bytes(data[k : k + chunk]))
    sent = {f.encode() for f in frames}
    for f in out:
        raw = f.encode()
        assert StatusFrame.decode(raw, check_crc=True) == f
        if loss_only:
            assert raw in sent
    assert p.stats.frames_ok == len(out)
    if not ops:
        assert out == frames


def test_garbage_inserted_between_frames_never_hides_or_invents_a_frame():
    rnd = random.Random(11)
    frames = status_frames(40, 12)
    stream = bytearray()
    for f in frames:
        stream += bytes(rnd.randint(0, 255) for _ in range(rnd.randint(0, 80)))
        stream += f.encode()
    p = StatusParser()
    out = []
    for k in range(0, len(stream), 17):
        out += p.feed(bytes(stream[k : k + 17]))
    assert out == frames
