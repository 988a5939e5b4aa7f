"""The commander's shared program document and its autosave place (no browser)."""

from __future__ import annotations

import os

import pytest

from parolkit.gui.eventlog import EventLog
from parolkit.gui.program_doc import ProgramDoc
from parolkit.gui.programs import ProgramNameError, ProgramsFolder


def test_edits_are_kept_in_the_folders_autosave_place_until_saved(tmp_path):
    folder = ProgramsFolder(tmp_path / "programs")
    doc = ProgramDoc(folder, EventLog(), "Begin()\n")
    assert doc.edit("Begin()\nDelay(1)\n")
    kept = tmp_path / "programs" / ".autosave" / "program.rbt"
    assert kept.read_text() == "Begin()\nDelay(1)\n" and doc.dirty
    assert not doc.edit("Begin()\nDelay(1)\n")  # same text: nothing new
    doc.saved("demo.rbt")
    assert not kept.exists() and not doc.dirty
    assert folder.names() == []  # the autosave place is not a program (the file itself is written by Save)


def test_a_new_document_restores_the_last_kept_edits(tmp_path):
    folder = ProgramsFolder(tmp_path)
    folder.write("demo", "Begin()\n")
    first = ProgramDoc(folder, EventLog(), "default\n")
    first.opened("demo.rbt", "Begin()\n")
    first.edit("Begin()\n# unsaved\n")
    again = ProgramDoc(folder, EventLog(), "default\n")
    assert (again.name, again.text, again.saved_text) == ("demo.rbt", "Begin()\n# unsaved\n", "Begin()\n")
    assert again.dirty


def test_opening_a_file_with_kept_edits_shows_the_edits(tmp_path):
    folder = ProgramsFolder(tmp_path)
    folder.write_autosave("demo", "edited\n")
    doc = ProgramDoc(folder, EventLog(), "default\n")
    doc.opened("demo.rbt", "on disk\n")
    assert doc.text == "edited\n" and doc.saved_text == "on disk\n"


@pytest.mark.parametrize("name", ["../evil", "/etc/passwd", "a/b", ".hidden"])
def test_autosave_names_follow_the_program_name_rules(tmp_path, name):
    with pytest.raises(ProgramNameError):
        ProgramsFolder(tmp_path).write_autosave(name, "x")


def test_an_autosave_link_pointing_outside_the_folder_is_refused(tmp_path):
    folder = ProgramsFolder(tmp_path / "programs")
    (tmp_path / "programs" / ".autosave").mkdir(parents=True)
    os.symlink(tmp_path / "elsewhere.rbt", tmp_path / "programs" / ".autosave" / "x.rbt")
    with pytest.raises(ProgramNameError, match="outside"):
        folder.write_autosave("x", "data")


def test_an_autosave_folder_that_is_a_link_elsewhere_is_refused(tmp_path):
    (tmp_path / "programs").mkdir()
    (tmp_path / "other").mkdir()
    os.symlink(tmp_path / "other", tmp_path / "programs" / ".autosave")
    with pytest.raises(ProgramNameError, match="outside the programs folder"):
        ProgramsFolder(tmp_path / "programs").write_autosave("x", "data")


def test_completion_covers_every_command_of_the_parsers_table_and_its_inserts_parse():
    from parolkit.gui.completion import COMPLETIONS
    from parolkit.script import parse
    from parolkit.script.parser import COMMAND_NAMES

    calls = {c.label: c.insert for c in COMPLETIONS if c.call}
    assert set(calls) == set(COMMAND_NAMES)
    # the argument-free inserts are whole, valid commands
    assert parse("Begin()\n" + calls["Delay"] + "\n" + calls["Output"] + "\nEnd()\n").ok


def test_completion_offers_every_option_of_the_move_commands():
    from parolkit.gui.completion import COMPLETIONS
    from parolkit.script import parse

    words = {c.label for c in COMPLETIONS if not c.call}
    assert {"t=", "v=", "a=", "r="} <= words
    for key in ("t=", "v=", "a=", "r="):  # each one is an option the parser takes on a move
        assert parse(f"MoveJoint(90, -90, 180, 0, 0, 180, {key}5)").ok, key
