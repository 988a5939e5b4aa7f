"""Board-link codec and pty round-trip benchmark.

Prints, as one compact table:

* encode / decode throughput of ``CommandFrame`` / ``StatusFrame`` (frames/s), against a
  naive ``struct``-based encoder/decoder of the same layout measured in the same run;
* stream-parse throughput of ``StatusParser`` on a byte stream cut into 64-byte USB packets,
  against decoding the same frames pre-split (the parser's overhead for hunting/resync);
* the emulated board's own per-frame cost (``BoardEmulator.write`` + ``read``, virtual clock);
* round-trip latency p50/p99 of pyserial <-> ``PtyBoardServer`` (one 56-byte frame out, the
  60-byte reply back), against a raw ``os.write``/``os.read`` echo over a pty (the floor).

Run: ``.venv/bin/python bench/codec.py [--frames N] [--roundtrips N]``.
"""

from __future__ import annotations

import argparse
import os
import select
import statistics
import struct
import sys
import tempfile
import threading
import time
import tty
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from parolkit.board import BoardEmulator, PtyBoardServer
from parolkit.protocol import CommandFrame, StatusFrame, StatusParser

# ---------------------------------------------------------------------------------------------
# the naive reference: struct packing of the same layout (no validation, no value objects)
# ---------------------------------------------------------------------------------------------

def naive_encode_command(pos, spd, cmd, io, gpos, gspd, gcur, gcmd, gmode, gid) -> bytes:
    out = bytearray(b"\xff\xff\xff\x34")
    for v in (*pos, *spd):
        out += struct.pack(">i", v)[1:]
    out += struct.pack(">BBBBhhhBBBB", cmd, 0xFF, io, 0, gpos, gspd, gcur, gcmd,
                       gmode, gid, 228)
    out += b"\x01\x02"
    return bytes(out)


def naive_decode_status(b: bytes) -> tuple:
    p = b[4:]
    vals = []
    for i in range(12):
        raw = int.from_bytes(p[3 * i:3 * i + 3], "big")
        vals.append(raw - 0x1000000 if raw & 0x800000 else raw)
    rest = struct.unpack(">BBBBHBBBhhhBB", p[36:53])
    return (*vals, *rest)


def rate(fn, n: int) -> float:
    t0 = time.perf_counter()
    fn(n)
    return n / (time.perf_counter() - t0)


def bench_codec(n: int) -> list[tuple[str, float, str, float]]:
    pos = (10240, -32000, 57905, 0, 0, 32000)
    spd = (100, -200, 300, 0, 0, 5000)

    def enc(k: int) -> None:
        for _ in range(k):
            CommandFrame(positions=pos, speeds=spd, command=156, io=0x20, gripper_position=100,
                         gripper_speed=50, gripper_current=500, gripper_command=0xD0).encode()

    def enc_ref(k: int) -> None:
        for _ in range(k):
            naive_encode_command(pos, spd, 156, 0x20, 100, 50, 500, 0xD0, 0, 0)

    assert naive_encode_command(pos, spd, 156, 0x20, 100, 50, 500, 0xD0, 0, 0) == CommandFrame(
        positions=pos, speeds=spd, command=156, io=0x20, gripper_position=100, gripper_speed=50,
        gripper_current=500, gripper_command=0xD0).encode()

    status = StatusFrame(positions=pos, speeds=spd, homed=0xFF, timing=7031, xtr=156).encode()

    def dec(k: int) -> None:
        for _ in range(k):
            StatusFrame.decode(status)

    def dec_ref(k: int) -> None:
        for _ in range(k):
            naive_decode_status(status)

    stream = status * n
    packets = [stream[i:i + 64] for i in range(0, len(stream), 64)]

    def parse(k: int) -> None:
        p = StatusParser()
        got = 0
        for pk in packets:
            got += len(p.feed(pk))
        assert got == n

    def presplit(k: int) -> None:
        for i in range(0, len(stream), 60):
            StatusFrame.decode(stream[i:i + 60])

    emu = BoardEmulator(clock="virtual")
    frame = CommandFrame(command=255).encode()

    def board(k: int) -> None:
        for _ in range(k):
            emu.write(frame)
            emu.read()

    rows = []
    r, ref = rate(enc, n), rate(enc_ref, n)
    rows.append(("encode CommandFrame", r, "naive struct encoder", ref))
    r, ref = rate(dec, n), rate(dec_ref, n)
    rows.append(("decode StatusFrame", r, "naive struct decoder", ref))
    r, ref = rate(parse, n), rate(presplit, n)
    rows.append(("StatusParser, 64-byte packets", r, "decode of pre-split frames", ref))
    r = rate(board, n)
    rows.append(("BoardEmulator write+read", r, "encode CommandFrame", rows[0][1]))
    return rows


# ---------------------------------------------------------------------------------------------
# pty round trips
# ---------------------------------------------------------------------------------------------

def _percentiles(xs: list[float]) -> tuple[float, float]:
    xs = sorted(xs)
    return statistics.median(xs), xs[min(len(xs) - 1, int(round(0.99 * (len(xs) - 1))))]


def raw_echo_roundtrips(n: int) -> list[float]:
    """os.write a 56-byte frame into a pty slave; an echo thread answers 60 bytes on the master."""
    master, slave = os.openpty()
    tty.setraw(slave)
    stop = threading.Event()
    reply = b"\x00" * 60

    def echo() -> None:
        while not stop.is_set():
            r, _, _ = select.select([master], [], [], 0.1)
            if r:
                data = os.read(master, 4096)
                if data:
                    os.write(master, reply)

    th = threading.Thread(target=echo, daemon=True)
    th.start()
    out = []
    frame = CommandFrame().encode()
    for _ in range(n):
        t0 = time.perf_counter()
        os.write(slave, frame)
        got = 0
        while got < 60:
            select.select([slave], [], [], 1.0)
            got += len(os.read(slave, 4096))
        out.append(time.perf_counter() - t0)
    stop.set()
    th.join()
    os.close(master)
    os.close(slave)
    return out


def board_roundtrips(n: int) -> list[float]:
    import serial

    emu = BoardEmulator()
    out = []
    with tempfile.TemporaryDirectory() as d, PtyBoardServer(emu, Path(d) / "p6"):
        ser = serial.Serial(str(Path(d) / "p6"), 3_000_000, timeout=1.0)
        parser = StatusParser()
        frame = CommandFrame().encode()
        for _ in range(n):
            t0 = time.perf_counter()
            ser.write(frame)
            while not parser.feed(ser.read(ser.in_waiting or 1)):
                pass
            out.append(time.perf_counter() - t0)
        ser.close()
    return out


def cpu_share(seconds: float, goto: bool) -> float:
    """Process CPU time / wall time while a PC streams frames at 100 Hz to a real-time board."""
    from parolkit.transport import EmulatorTransport

    with EmulatorTransport() as t:
        parser = StatusParser()
        c0, w0 = time.process_time(), time.monotonic()
        next_t = w0
        k = 0
        while next_t - w0 < seconds:
            tgt = int(3000 * ((k % 200) / 100.0 - 1.0)) if goto else 0
            t.write(CommandFrame(command=156 if goto else 255,
                                 positions=(tgt, -tgt, tgt, tgt, -tgt, tgt)).encode())
            parser.feed(t.read())
            k += 1
            next_t += 0.01
            time.sleep(max(0.0, next_t - time.monotonic()))
        return (time.process_time() - c0) / (time.monotonic() - w0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20000, help="frames per throughput figure")
    ap.add_argument("--roundtrips", type=int, default=1000, help="round trips per latency figure")
    args = ap.parse_args()

    print(f"codec throughput ({args.frames} frames each; ratio = parolkit / reference)")
    print(f"{'measure':32s} {'frames/s':>11s}   {'reference':28s} {'frames/s':>11s} {'ratio':>7s}")
    for name, r, ref_name, ref in bench_codec(args.frames):
        print(f"{name:32s} {r:11,.0f}   {ref_name:28s} {ref:11,.0f} {r / ref:7.2f}")

    raw = raw_echo_roundtrips(args.roundtrips)
    brd = board_roundtrips(args.roundtrips)
    r50, r99 = _percentiles(raw)
    b50, b99 = _percentiles(brd)
    print()
    print(f"pty round trip, 56 B out / 60 B back ({args.roundtrips} each; ratio = board / raw echo)")
    print(f"{'path':44s} {'p50 ms':>8s} {'p99 ms':>8s}")
    print(f"{'raw os.write/os.read echo (floor)':44s} {r50 * 1e3:8.3f} {r99 * 1e3:8.3f}")
    print(f"{'pyserial <-> PtyBoardServer + BoardEmulator':44s} {b50 * 1e3:8.3f} {b99 * 1e3:8.3f}")
    print(f"{'ratio':44s} {b50 / r50:8.2f} {b99 / r99:8.2f}")
    print(f"budget at 100 Hz: 10 ms per tick; board p99 uses {b99 / 0.01 * 100:.1f} % of it")
    idle, goto = cpu_share(2.0, False), cpu_share(2.0, True)
    print()
    print("CPU share of one core, PC + real-time emulator in one process, 100 Hz frames, "
          f"{BoardEmulator().pass_hz} Hz board passes")
    print(f"{'IDLE frames':44s} {idle * 100:7.1f} %")
    print(f"{'GO TO frames, all joints moving':44s} {goto * 100:7.1f} %   ratio {goto / idle:5.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
