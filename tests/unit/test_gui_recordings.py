"""The commander's recordings folder (parolkit.gui.recordings), without a browser: names follow
the programs folder's rules, only listed recordings are served, deleted or taught from, the
list is newest first with each recording's summary, and teaching never overwrites a program."""

from __future__ import annotations

import os
from datetime import datetime

import pytest

from parolkit.config import GuiSettings, load_config
from parolkit.errors import ParolkitValueError
from parolkit.gui.programs import ProgramNameError, ProgramsFolder
from parolkit.gui.recordings import (
    RecordingNameError,
    RecordingNotListed,
    RecordingsFolder,
    default_recordings_dir,
    free_program_name,
    recording_name,
    size_text,
    teach_recording,
)
from parolkit.record import messages
from parolkit.record.writer import RecordingWriter


def _mcap(path, summary=None) -> None:
    """A small valid MCAP file (closed with ``summary`` as its parolkit.recording metadata)."""
    w = RecordingWriter(path)
    w.write_ros("/parolkit/commands", "parolkit_msgs/msg/CommandEvent",
                messages.command_event({"source": "test", "tick": None}, 1), 1, 1)
    w.close(summary)


@pytest.mark.parametrize("text, expected", [("run1", "run1.mcap"), ("run1.mcap", "run1.mcap"),
                                            ("  demo take 2 ", "demo take 2.mcap")])
def test_recording_names_get_the_mcap_extension(text, expected):
    assert recording_name(text) == expected


@pytest.mark.parametrize("text, rule", [
    ("../x", "contains a path separator"),
    ("..", "contains '..'"),
    ("/etc/passwd", "is an absolute path"),
    (".hidden", "starts with '.'"),
    ("a;b", "contains ';'"),
    ("", "no recording name given"),
])
def test_refused_recording_names_name_the_rule_of_the_programs_folder(text, rule):
    with pytest.raises(RecordingNameError, match=rule) as info:
        recording_name(text)
    assert "a recording is named by letters, digits, spaces" in str(info.value) or not text
    # the same rule as programs: one check, two folders
    with pytest.raises(ProgramNameError, match=rule.replace("recording", "program")):
        ProgramsFolder("/nonexistent").path(text)


def test_only_listed_recordings_are_reachable(tmp_path):
    folder = RecordingsFolder(tmp_path / "rec")
    assert folder.names() == [] and folder.entries() == []  # missing folder: empty, not created
    assert not folder.root.exists()
    folder.create()
    _mcap(folder.root / "a.mcap")
    (folder.root / "notes.txt").write_text("not a recording")
    (tmp_path / "secret.mcap").write_text("outside")
    os.symlink(tmp_path / "secret.mcap", folder.root / "link.mcap")
    os.mkdir(folder.root / "dir.mcap")
    assert folder.names() == ["a.mcap"]
    assert folder.listed("a") == (folder.root / "a.mcap").resolve()
    with pytest.raises(RecordingNotListed, match="no recording 'notes.txt.mcap'"):
        folder.listed("notes.txt")
    with pytest.raises(RecordingNameError, match="outside the recordings folder"):
        folder.listed("link.mcap")
    with pytest.raises(RecordingNameError, match="not a regular file"):
        folder.listed("dir.mcap")
    with pytest.raises(RecordingNameError, match="path separator"):
        folder.delete("../secret.mcap")
    assert (tmp_path / "secret.mcap").read_text() == "outside"
    folder.delete("a")
    assert folder.names() == []


def test_the_list_is_newest_first_with_the_summary_of_closed_recordings(tmp_path):
    folder = RecordingsFolder(tmp_path)
    _mcap(tmp_path / "old.mcap", {"duration_s": 2.5, "statuses": 250})
    _mcap(tmp_path / "new.mcap", {"duration_s": 1.0, "statuses": 100})
    (tmp_path / "cut.mcap").write_bytes((tmp_path / "new.mcap").read_bytes()[:40])  # a killed recorder
    os.utime(tmp_path / "old.mcap", (1_000_000, 1_000_000))
    os.utime(tmp_path / "cut.mcap", (2_000_000, 2_000_000))
    rows = folder.entries()
    assert [r.name for r in rows] == ["new.mcap", "cut.mcap", "old.mcap"]
    assert (rows[0].duration_s, rows[0].ticks) == (1.0, 100)
    assert (rows[1].duration_s, rows[1].ticks) == (None, None)
    assert rows[2].size == (tmp_path / "old.mcap").stat().st_size
    assert [r.name for r in folder.entries(exclude="new.mcap")] == ["cut.mcap", "old.mcap"]


def test_a_new_recording_never_takes_an_existing_name(tmp_path):
    folder = RecordingsFolder(tmp_path)
    when = datetime(2026, 11, 24, 20, 15, 30)
    first = folder.new_path(when)
    assert first.name == "rec-20261124-201530.mcap"
    first.write_bytes(b"")
    assert folder.new_path(when).name == "rec-20261124-201530-2.mcap"


def test_teaching_never_overwrites_a_program(tmp_path):
    programs = ProgramsFolder(tmp_path / "p")
    assert free_program_name(programs, "rec-1") == "rec-1.rbt"
    programs.write("rec-1", "Begin()\n")
    programs.write("rec-1-2", "Begin()\n")
    assert free_program_name(programs, "rec-1") == "rec-1-3.rbt"
    assert len(free_program_name(programs, "x" * 96)) <= 100


def test_teach_refuses_an_unlisted_name_and_a_recording_without_status(tmp_path):
    recordings, programs = RecordingsFolder(tmp_path / "r"), ProgramsFolder(tmp_path / "p")
    recordings.create()
    with pytest.raises(RecordingNameError):
        teach_recording(recordings, programs, "../../etc/passwd")
    _mcap(recordings.root / "empty.mcap")
    with pytest.raises(ParolkitValueError, match="no /parolkit/status messages"):
        teach_recording(recordings, programs, "empty.mcap")
    assert programs.names() == []


def test_a_program_taught_from_a_recording_that_ends_early_says_so_in_its_header(tmp_path):
    from mcap.reader import make_reader
    from tests.unit.test_record import _planned_recording, _write

    from parolkit.moves import JointMove

    recordings, programs = RecordingsFolder(tmp_path / "r"), ProgramsFolder(tmp_path / "p")
    recordings.create()
    planned, statuses = _planned_recording(tmp_path, [JointMove((80, -80, 170, 0, 10, 170), 1.5)])
    whole = recordings.root / "whole.mcap"
    _write(whole, statuses, flush_every=20)
    with open(whole, "rb") as f:
        last = make_reader(f).get_summary().chunk_indexes[-1]
    (recordings.root / "cut.mcap").write_bytes(whole.read_bytes()[:last.chunk_start_offset + 10])
    taught = teach_recording(recordings, programs, "cut.mcap")
    header = taught.text.splitlines()[1]
    assert header.startswith("# warning: cut.mcap: the recording ends early or is damaged at byte ")
    assert header.endswith(f"only the {len(statuses) - len(statuses) % 20} ticks before it are used")
    assert "MoveJoint(79.9980,-79.9988,170.0005,0.0000,9.9984,169.9988,t=1.50)" in taught.text
    assert "# warning" not in teach_recording(recordings, programs, "whole.mcap").text


def test_size_text():
    assert [size_text(n) for n in (812, 12_345, 4_560_000)] == ["812 B", "12.3 kB", "4.56 MB"]


def test_recordings_dir_config_and_default(tmp_path, monkeypatch):
    f = tmp_path / "parolkit.toml"
    f.write_text('[gui]\nrecordings_dir = "~/parol-recordings"\n')
    assert load_config(f).gui.recordings_dir == "~/parol-recordings"
    assert GuiSettings().recordings_dir is None
    f.write_text('[gui]\nrecordings_dir = ""\n')
    with pytest.raises(ParolkitValueError, match="gui.recordings_dir must be a folder path"):
        load_config(f)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    assert default_recordings_dir() == tmp_path / "parolkit" / "recordings"  # beside the programs folder


def test_the_teach_process_fits_as_the_thread_does_says_what_failed_and_survives_being_killed(tmp_path):
    """The commander's fits run in a process of their own (a fit in a thread would hold the
    interpreter lock the page's event loop needs): the same program as a fit in this process,
    the fit's own error (not a pickling one) for a recording without status, and a killed
    process is replaced at the next fit."""
    import signal
    from concurrent.futures.process import BrokenProcessPool

    from tests.unit.test_record import _planned_recording, _write

    from parolkit.gui.recordings import TeachProcess
    from parolkit.moves import JointMove

    recordings, programs = RecordingsFolder(tmp_path / "r"), ProgramsFolder(tmp_path / "p")
    recordings.create()
    _, statuses = _planned_recording(tmp_path, [JointMove((80, -80, 170, 0, 10, 170), 1.5)])
    _write(recordings.root / "demo.mcap", statuses)
    _mcap(recordings.root / "empty.mcap")
    here = teach_recording(recordings, programs, "demo.mcap")
    proc = TeachProcess()
    try:
        there = teach_recording(recordings, programs, "demo.mcap", fit=proc.fit)
        assert there.text == here.text and there.path.name == "demo-2.rbt"
        with pytest.raises(ParolkitValueError, match="no /parolkit/status messages"):
            teach_recording(recordings, programs, "empty.mcap", fit=proc.fit)
        pool = proc._pool
        assert pool is not None
        for pid in list(pool._processes):  # the process dies (killed, out of memory ...)
            os.kill(pid, signal.SIGKILL)
        with pytest.raises(BrokenProcessPool):
            teach_recording(recordings, programs, "demo.mcap", fit=proc.fit)
        again = teach_recording(recordings, programs, "demo.mcap", fit=proc.fit)
        assert again.text == here.text
    finally:
        proc.close()
    assert proc._pool is None
