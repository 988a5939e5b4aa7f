"""The shared program document's merge of concurrent edits and its memory of the program shown
last (issue 26 items 2 and 7; gui/program_doc.py, gui/programs.py; no browser).

The page's half (moving its pending changes over others', commander.js ``pkDoc``) is CodeMirror's
``ChangeSet.map``; here the pages are played by hand: a change refused as behind is made again on
the newer text, as the page does.
"""

from __future__ import annotations

import pytest

from parolkit.gui import program_doc
from parolkit.gui.eventlog import EventLog
from parolkit.gui.program_doc import SERVER, Change, EditRefused, ProgramDoc, utf16_len
from parolkit.gui.programs import MAX_PROGRAM_BYTES, ProgramNameError, ProgramsFolder, uploaded_program


def _doc(tmp_path, text: str = "Begin()\nEnd()\n") -> ProgramDoc:
    return ProgramDoc(ProgramsFolder(tmp_path / "programs"), EventLog(), text)


def _insert(doc_text: str, at: int, what: str) -> dict:
    """A page's change inserting ``what`` at UTF-16 offset ``at`` of ``doc_text``."""
    return {"n": utf16_len(doc_text), "c": [[at, at, what]]}


# ---- changes ----

def test_a_change_applies_in_utf16_offsets_as_the_browser_counts():
    text = "a😀b\n"  # the emoji is 2 UTF-16 units
    change = Change.from_wire({"n": 5, "c": [[3, 4, "XY"], [5, 5, "end"]]})
    assert change.apply(text) == "a😀XY\nend"
    assert change.to_wire() == {"n": 5, "c": [[3, 4, "XY"], [5, 5, "end"]]}


def test_a_change_that_splits_a_character_or_does_not_fit_the_text_is_refused():
    with pytest.raises(EditRefused, match="splits a character"):
        Change.from_wire({"n": 4, "c": [[2, 2, "x"]]}).apply("a😀b")
    with pytest.raises(EditRefused, match="text of 9 units, the text has 4"):
        Change.from_wire({"n": 9, "c": []}).apply("a😀b")


@pytest.mark.parametrize("wire, words", [
    ({"n": 3}, "must be"),
    ([1, 2], "must be"),
    ({"n": -1, "c": []}, "integer >= 0"),
    ({"n": True, "c": []}, "integer >= 0"),
    ({"n": 5, "c": "x"}, "must be a list"),
    ({"n": 5, "c": [[0, 1]]}, r"\[start, end, text\]"),
    ({"n": 5, "c": [[0, 1, 2]]}, r"\[start, end, text\]"),
    ({"n": 5, "c": [[2, 1, ""]]}, "out of order"),
    ({"n": 5, "c": [[0, 6, ""]]}, "outside 0..5"),
    ({"n": 5, "c": [[2, 3, ""], [1, 1, "x"]]}, "previous range ends at 3"),
    ({"n": 5, "c": [[0, 0, "a\r\nb"]]}, "line ends"),
])
def test_a_malformed_change_is_refused_naming_what_is_wrong(wire, words):
    with pytest.raises(EditRefused, match=words):
        Change.from_wire(wire)


@pytest.mark.parametrize("old, new", [
    ("abc", "abXc"), ("abc", "ac"), ("", "x"), ("x", ""), ("aaa", "aaaa"), ("a😀c", "a😀😀c"), ("😀", "x😀"),
])
def test_the_servers_change_between_two_texts_is_the_one_range_that_differs(old, new):
    change = Change.between(old, new)
    assert change is not None and len(change.ranges) == 1 and change.apply(old) == new
    assert Change.between(new, new) is None


# ---- pushes: only on the current revision, all or nothing ----

def test_a_push_on_the_current_revision_is_applied_and_kept(tmp_path):
    doc = _doc(tmp_path)
    heard = []
    doc.subscribe(lambda: heard.append(doc.revision))
    me = doc.attach()
    assert doc.push(me, 0, [_insert(doc.text, 8, "Delay(1)\n"), _insert("Begin()\nDelay(1)\nEnd()\n", 0, "# a\n")])
    assert doc.text == "# a\nBegin()\nDelay(1)\nEnd()\n" and doc.revision == 2 and heard == [2]
    assert [(u.editor, u.change.to_wire()) for u in doc.since(0) or []] == [
        (me, {"n": 14, "c": [[8, 8, "Delay(1)\n"]]}), (me, {"n": 23, "c": [[0, 0, "# a\n"]]})]
    assert doc.since(2) == [] and doc.dirty
    assert (tmp_path / "programs" / ".autosave" / "program.rbt").read_text() == doc.text


def test_two_pages_pushing_on_the_same_revision_one_is_behind_and_nothing_is_lost(tmp_path):
    """Both typed on revision 0 at the same moment: the first push is applied, the second is
    refused (nothing of it applied); that page gets the first's update, makes its change again
    on the newer text (what pkDoc's ChangeSet.map does) and pushes at revision 1: both are in."""
    doc = _doc(tmp_path, "A:\nB:\n")
    a, b = doc.attach(), doc.attach()
    base = doc.text
    assert doc.push(a, 0, [_insert(base, 2, "x")])
    assert not doc.push(b, 0, [_insert(base, 5, "y")])
    assert doc.text == "A:x\nB:\n" and doc.revision == 1
    missed = doc.since(0)
    assert missed is not None and [u.editor for u in missed] == [a]
    # page b moves its insertion over a's (at 2, before b's 5): one unit later
    assert doc.push(b, 1, [_insert(doc.text, 6, "y")])
    assert doc.text == "A:x\nB:y\n" and [u.editor for u in doc.since(0) or []] == [a, b]


def test_a_push_with_one_bad_change_applies_none_of_them(tmp_path):
    doc = _doc(tmp_path, "abc")
    me = doc.attach()
    with pytest.raises(EditRefused, match="text of 9 units"):
        doc.push(me, 0, [_insert("abc", 0, "x"), {"n": 9, "c": []}])
    assert doc.text == "abc" and doc.revision == 0


@pytest.mark.parametrize("base, changes, words", [
    (1, [{"n": 3, "c": []}], r"base revision must be an integer in 0..0"),
    (-1, [{"n": 3, "c": []}], "base revision"),
    ("0", [{"n": 3, "c": []}], "base revision"),
    (True, [{"n": 3, "c": []}], "base revision"),
    (0, [], "non-empty list"),
    (0, "x", "non-empty list"),
])
def test_a_push_on_a_revision_the_document_never_had_or_without_changes_is_refused(tmp_path, base, changes, words):
    doc = _doc(tmp_path, "abc")
    with pytest.raises(EditRefused, match=words):
        doc.push(doc.attach(), base, changes)


def test_a_push_that_would_make_the_program_too_long_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(program_doc, "MAX_TEXT_UNITS", 10)
    doc = _doc(tmp_path, "abc")
    with pytest.raises(EditRefused, match="at most 10"):
        doc.push(doc.attach(), 0, [_insert("abc", 3, "12345678")])
    assert doc.text == "abc"


def test_a_page_further_behind_than_the_kept_updates_gets_the_whole_text(tmp_path, monkeypatch):
    monkeypatch.setattr(program_doc, "MAX_HISTORY", 3)
    doc = _doc(tmp_path, "")
    me = doc.attach()
    for i in range(5):
        assert doc.push(me, i, [_insert(doc.text, i, str(i))])
    assert doc.text == "01234" and doc.since(1) is None and doc.since(6) is None
    assert [u.change.to_wire()["c"] for u in doc.since(2) or []] == [[[2, 2, "2"]], [[3, 3, "3"]], [[4, 4, "4"]]]


def test_the_servers_own_changes_are_updates_every_page_follows(tmp_path):
    doc = _doc(tmp_path, "Begin()\r\nEnd()\r\n")
    assert doc.text == "Begin()\nEnd()\n"  # the editor's line ends
    assert doc.edit("Begin()\nDelay(1)\nEnd()\n") and not doc.edit("Begin()\nDelay(1)\nEnd()\n")
    (update,) = doc.since(0) or []
    assert update.editor == SERVER and update.change.apply("Begin()\nEnd()\n") == doc.text
    doc.folder.write("lesson", "MoveJoint(0,0,0,0,0,0)\r\n")
    doc.opened("lesson.rbt", doc.folder.read("lesson")[1])
    assert doc.revision == 2 and doc.text == "MoveJoint(0,0,0,0,0,0)\n" and not doc.dirty


# ---- item 7: the program shown last, after a restart ----

def test_a_restarted_commander_reopens_the_program_shown_last_as_saved(tmp_path):
    folder = ProgramsFolder(tmp_path)
    first = ProgramDoc(folder, EventLog(), "default\n")
    first.edit("Begin()\nDelay(1)\nEnd()\n")
    folder.write("lesson1", first.text)
    first.saved("lesson1.rbt")
    assert (tmp_path / ".autosave" / "last").read_text() == "lesson1.rbt\n"
    again = ProgramDoc(folder, EventLog(), "default\n")
    assert (again.name, again.text, again.dirty) == ("lesson1.rbt", "Begin()\nDelay(1)\nEnd()\n", False)


def test_the_program_shown_last_is_reopened_with_its_unsaved_edits(tmp_path):
    folder = ProgramsFolder(tmp_path)
    folder.write("a", "A\n")
    folder.write("b", "B\n")
    first = ProgramDoc(folder, EventLog(), "default\n")
    first.opened("a.rbt", "A\n")
    first.edit("A edited\n")  # kept for a.rbt
    first.opened("b.rbt", "B\n")  # shown last, no edits
    again = ProgramDoc(folder, EventLog(), "default\n")
    assert (again.name, again.text, again.dirty) == ("b.rbt", "B\n", False)
    again.opened("a.rbt", "A\n")
    assert again.text == "A edited\n" and again.dirty


def test_a_last_program_that_is_gone_or_a_refused_name_falls_back(tmp_path):
    folder = ProgramsFolder(tmp_path)
    folder.remember_last("gone")
    assert folder.last_program() == "gone.rbt"
    assert ProgramDoc(folder, EventLog(), "default\n").text == "default\n"
    (tmp_path / ".autosave" / "last").write_text("../../etc/passwd\n")
    with pytest.raises(ProgramNameError, match="path separator"):
        folder.last_program()
    log = EventLog()
    doc = ProgramDoc(folder, log, "default\n")
    assert doc.text == "default\n" and any("path separator" in e.text for e in log)


@pytest.mark.parametrize("data, words", [
    (b"x" * (MAX_PROGRAM_BYTES + 1), f"at most {MAX_PROGRAM_BYTES} bytes"),
    (b"Begin()\n\xff\xfe\n", "not UTF-8 text"),
    (b"Begin()\x00\n", "control characters"),
    (b"\x1b[31mred\n", "control characters"),
])
def test_an_upload_that_is_not_a_plain_text_program_is_refused(data, words):
    with pytest.raises(ProgramNameError, match=words):
        uploaded_program(data)


def test_an_uploaded_program_is_its_text():
    assert uploaded_program("\ufeffBegin()\r\n\tDelay(1) # é\nEnd()\n".encode()) == "Begin()\r\n\tDelay(1) # é\nEnd()\n"
