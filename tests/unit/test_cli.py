"""The `parolkit` command dispatcher."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from parolkit.cli import SUBCOMMANDS, main


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "parolkit", *args], capture_output=True, text=True, timeout=60
    )


def test_help_lists_every_sub_command():
    out = run("--help")
    assert out.returncode == 0
    for name in SUBCOMMANDS:
        assert name in out.stdout


def test_unknown_sub_command_is_an_error_listing_the_choices():
    out = run("frobnicate")
    assert out.returncode == 2
    assert "invalid choice: 'frobnicate'" in out.stderr and "serve" in out.stderr


def test_no_arguments_prints_help_and_fails(capsys):
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().out


def test_version():
    out = run("--version")
    assert out.returncode == 0 and out.stdout.startswith("parolkit ")


# ------------------------------------------------------------- bad files: one line, never a traceback

def _recording(path, ticks: int = 100, chunk_every: int = 25):
    """A recording of ``ticks`` status messages in chunks of ``chunk_every`` (the record tests'
    writer); returns the chunks' (start offset, length) in the file."""
    import numpy as np
    from mcap.reader import make_reader
    from tests.unit.test_record import _status, _write

    _write(path, [_status(i, np.array([10240, -32000, 57905, 0, 0, 32000]) + i) for i in range(ticks)],
           flush_every=chunk_every)
    with open(path, "rb") as f:
        return [(c.chunk_start_offset, c.chunk_length) for c in make_reader(f).get_summary().chunk_indexes]


def _damaged(src, dst, chunk) -> None:
    """``src`` with 16 bytes in the middle of chunk (offset, length) flipped."""
    data = bytearray(src.read_bytes())
    middle = chunk[0] + chunk[1] // 2
    data[middle:middle + 16] = bytes(b ^ 0x5A for b in data[middle:middle + 16])
    dst.write_bytes(bytes(data))


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    """name -> path of every kind of bad input a tool may be given."""
    d = tmp_path_factory.mktemp("bad")
    good = d / "good.mcap"
    chunks = _recording(good)
    files = {
        "missing": d / "missing.file",
        "empty": d / "empty.file",
        "folder": d / "folder.file",
        "not-utf8": d / "latin1.file",
        "garbage": d / "garbage.file",
        "program": d / "program.rbt",
        "toml": d / "config.toml",
        "too-fast-config": d / "fast.toml",
        "mcap": good,
        "mcap-first-chunk-damaged": d / "first-chunk-damaged.mcap",
        "mcap-third-chunk-damaged": d / "third-chunk-damaged.mcap",
        "mcap-truncated": d / "truncated.mcap",
        "mcap-without-status": d / "no-status.mcap",
    }
    files["empty"].write_bytes(b"")
    files["folder"].mkdir()
    files["not-utf8"].write_bytes("[robot] # caf\u00e9 in Latin-1\nBegin()\n".encode("latin-1"))
    files["garbage"].write_bytes(bytes(range(256)) * 8)
    files["program"].write_text("Begin()\nMoveJoint(90, -90, 180, 0, 0, 180)\nEnd()\n")
    files["toml"].write_text("[controller]\nrate_hz = 100\n")
    files["too-fast-config"].write_text("[robot]\nmax_speed_steps_s = [1e12, 18000, 20000, 22000, 22000, 22000]\n")
    _damaged(good, files["mcap-first-chunk-damaged"], chunks[0])
    _damaged(good, files["mcap-third-chunk-damaged"], chunks[2])
    files["mcap-truncated"].write_bytes(good.read_bytes()[:chunks[2][0] + chunks[2][1] // 2])
    from parolkit.record.writer import RecordingWriter

    w = RecordingWriter(files["mcap-without-status"])
    w.write_ros("/other/topic", "std_msgs/msg/String", {"data": "x"}, 1, 1)
    w.close()
    return files


#: (kind of input, bad file, what a line of the output must say besides the file's name)
_RECORDING_CASES = [
    ("missing", "no such recording"),
    ("empty", "the file is empty, not a recording"),
    ("folder", "is a folder, not a recording"),
    ("not-utf8", "not an MCAP recording"),
    ("garbage", "not an MCAP recording"),
    ("toml", "not an MCAP recording"),
    ("mcap-without-status", "no /parolkit/status messages"),
    ("mcap-first-chunk-damaged", "no /parolkit/status messages (the file ends early or is damaged: "),
]
_CONFIG_CASES = [
    ("missing", "does not exist"),
    ("folder", "is a folder, not a TOML file"),
    ("not-utf8", "not a TOML file: byte 0xE9 at position 13 is not UTF-8 text"),
    ("garbage", "not a TOML file: byte 0x80 at position 128 is not UTF-8 text"),
    ("mcap", "not a TOML file: byte 0x89 at position 0 is not UTF-8 text"),
    ("program", "not valid TOML"),
    ("too-fast-config", "max_speed_steps_s: J1 = 1e+12 steps/s is out of range (0, 50000]"),
]
_PROGRAM_CASES = [
    ("missing", "No such file or directory"),
    ("empty", "the program has no commands"),
    ("folder", "Is a directory"),
    ("not-utf8", "not UTF-8"),
    ("garbage", "not UTF-8"),
    ("mcap", "not UTF-8"),
]


def _free_port() -> str:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return str(s.getsockname()[1])


def _commands_reading(kind: str, path: str, tmp: str) -> list[list[str]]:
    """Every sub-command that reads a file of ``kind`` (recording, config, program), given
    ``path``; ports are free ones, so a command that wrongly accepted the file cannot take a
    fixed one (the test's timeout ends it)."""
    if kind == "recording":
        return [["plot", path, "-o", f"{tmp}/plot.png"], ["export", "--csv", path, "-o", f"{tmp}/out.csv"],
                ["teach", path, "-o", f"{tmp}/taught.rbt"], ["replay", path]]
    if kind == "config":
        return [["serve", "--config", path, "--udp-port", _free_port(), "--ack-port", _free_port()],
                ["gui", "--no-browser", "--config", path, "--http-port", _free_port(),
                 "--connect", f"127.0.0.1:{_free_port()}"],
                ["run", "--dry-run", "--config", path, str(EXAMPLE)], ["check", "--config", path, str(EXAMPLE)],
                ["urdf", "--config", path, "-o", f"{tmp}/robot.urdf"],
                ["ros2", "--config", path, "--connect", f"127.0.0.1:{_free_port()}"]]
    return [["run", "--dry-run", path], ["check", path], ["fmt", "--check", path]]


EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "simple_joint_move.rbt"


def _refused_in_one_line(what: str, path: str, says: str, tmp: str) -> None:
    """Every command reading a ``what`` given ``path`` (real processes, three at a time) exits
    non-zero with a line naming the file and saying ``says``, and prints no traceback."""
    from concurrent.futures import ThreadPoolExecutor

    def one(argv: list[str]) -> str | None:
        try:
            out = subprocess.run([sys.executable, "-m", "parolkit", *argv], capture_output=True, text=True,
                                 timeout=60)
        except subprocess.TimeoutExpired:
            return f"parolkit {' '.join(argv)}: still running after 60 s (the file was accepted)"
        text = out.stdout + out.stderr
        if "Traceback" in text or out.returncode == 0:
            return f"parolkit {' '.join(argv)}: exit {out.returncode}: {text[-2000:]}"
        if not any(Path(path).name in line and says in line for line in text.splitlines()):
            return f"parolkit {' '.join(argv)}: no line names the file and says {says!r}: {text[-2000:]}"
        return None

    with ThreadPoolExecutor(max_workers=3) as pool:
        problems = [p for p in pool.map(one, _commands_reading(what, path, tmp)) if p]
    assert not problems, "\n".join(problems)


@pytest.mark.slow
@pytest.mark.parametrize("kind, says", _RECORDING_CASES, ids=[k for k, _ in _RECORDING_CASES])
def test_tools_reading_a_recording_refuse_a_bad_one_in_one_line(bad_files, tmp_path, kind, says):
    _refused_in_one_line("recording", str(bad_files[kind]), says, str(tmp_path))


@pytest.mark.slow
@pytest.mark.parametrize("kind, says", _CONFIG_CASES, ids=[k for k, _ in _CONFIG_CASES])
def test_every_command_reading_a_config_refuses_a_bad_one_in_one_line(bad_files, tmp_path, kind, says):
    _refused_in_one_line("config", str(bad_files[kind]), says, str(tmp_path))


@pytest.mark.slow
@pytest.mark.parametrize("kind, says", _PROGRAM_CASES, ids=[k for k, _ in _PROGRAM_CASES])
def test_every_command_reading_a_program_refuses_a_bad_one_in_one_line(bad_files, tmp_path, kind, says):
    _refused_in_one_line("program", str(bad_files[kind]), says, str(tmp_path))


@pytest.mark.parametrize("kind", ["mcap-third-chunk-damaged", "mcap-truncated"])
def test_a_recording_damaged_after_its_start_is_used_up_to_the_damage_and_says_so(bad_files, tmp_path, kind):
    path = str(bad_files[kind])
    out = subprocess.run([sys.executable, "-m", "parolkit", "export", "--csv", path, "-o", str(tmp_path / "x.csv")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    (warning,) = out.stderr.splitlines()
    assert warning.startswith(f"parolkit export: warning: {path}: the recording ends early or is damaged at byte ")
    assert warning.endswith("only the 50 ticks before it are used")
    assert "(50 rows)" in out.stdout


@pytest.mark.parametrize("argv, says", [
    (["plot", "{good}", "-o", "{tmp}/plot.mcap"], "plot.mcap: cannot write a plot as '.mcap'"),
    (["plot", "{good}", "-o", "{tmp}/no/folder/plot.png"], "plot.png: No such file or directory"),
    (["export", "--csv", "{good}", "-o", "{tmp}"], ": Is a directory"),
    (["teach", "{good}", "-o", "{tmp}/no/folder/p.rbt"], "p.rbt: No such file or directory"),
    (["urdf", "-o", "{tmp}/no/folder/robot.urdf"], "robot.urdf: No such file or directory"),
    (["plan", "movejoint", "90", "-90", "180", "0", "0", "170", "--csv", "{tmp}/no/folder/x.csv"],
     "x.csv: No such file or directory"),
    (["run", "--dry-run", str(EXAMPLE), "--plot", "{tmp}/no/folder/x.png"], "x.png: No such file or directory"),
    (["record", "-o", "{tmp}/no/folder/x.mcap", "--duration", "1"], "x.mcap: No such file or directory"),
])
def test_an_output_file_that_cannot_be_written_is_refused_in_one_line(bad_files, tmp_path, argv, says):
    argv = [a.format(good=bad_files["mcap"], tmp=tmp_path) for a in argv]
    out = subprocess.run([sys.executable, "-m", "parolkit", *argv], capture_output=True, text=True, timeout=60)
    assert "Traceback" not in out.stderr and out.returncode != 0, (argv, out.stderr)
    assert f"parolkit {argv[0]}: " in out.stderr and says in out.stderr, (argv, out.stderr)
