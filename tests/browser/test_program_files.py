"""Program files (issue 26 item 7): upload and download ``.rbt`` files in the Program tab's
file row, and a restarted commander reopens the program shown last.

An upload goes through the programs folder's rules (name, 1 MB, plain text) and is refused with
a message that says which; a download is the saved file as an attachment
(``/parolkit-programs/<name>``, nothing outside the folder).  Before the change there was no
upload or download, and after a restart the page showed the default example marked "unsaved
edits" instead of the program saved last.

Real Chromium, a real ``parolkit gui --sim`` restarted by the test.
"""

from __future__ import annotations

import urllib.error
import urllib.request

import pytest
from tests.browser.conftest import _stop, start_gui
from tests.browser.helpers import text, wait_until

LESSON = "Begin()\n# uploaded lesson\nDelay(0.5)\nEnd()\n"
UPLOAD_INPUT = "[data-testid=prog-upload-box] input[type=file]"


@pytest.fixture(scope="module")
def programs_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("programs")


@pytest.fixture(scope="module")
def gui(programs_dir):
    """A ``parolkit gui --sim`` on ``programs_dir``; ``gui["restart"]()`` restarts the process."""
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    state = {}

    def start():
        state["proc"], state["url"], _ = start_gui(["--sim", "--programs-dir", str(programs_dir)])

    def restart():
        _stop(state["proc"])
        start()

    start()
    state["restart"] = restart
    yield state
    _stop(state["proc"])


def _open(browser, url):
    pg = browser.new_page(viewport={"width": 1500, "height": 1000}, accept_downloads=True)
    pg.errors = []
    pg.on("pageerror", lambda e: pg.errors.append(str(e)))
    pg.goto(url)
    pg.get_by_test_id("tab-program").click()
    pg.locator("[data-testid=editor] .cm-content").wait_for()
    return pg


def _editor_text(pg) -> str | None:
    return pg.evaluate("() => window.pkEditorText ? window.pkEditorText() : null")


def _status(pg) -> str:
    return text(pg, "file-status")


def test_an_uploaded_program_is_written_into_the_folder_and_opened(browser, gui, programs_dir, tmp_path):
    source = tmp_path / "lesson2.rbt"
    source.write_text(LESSON)
    pg = _open(browser, gui["url"])
    with pg.expect_file_chooser() as chooser:  # the row's Upload button opens the browser's chooser
        pg.get_by_test_id("prog-upload").click()
    chooser.value.set_files(str(source))
    wait_until(lambda: _editor_text(pg) == LESSON, 20, what="the uploaded program in the editor", page=pg)
    assert (programs_dir / "lesson2.rbt").read_text() == LESSON
    wait_until(lambda: pg.get_by_test_id("prog-name").input_value() == "lesson2.rbt"
               and text(pg, "doc-state") == "lesson2.rbt: saved", 10, what="named and saved", page=pg)
    assert "uploaded lesson2.rbt" in _status(pg)
    assert not pg.errors, pg.errors
    pg.close()


@pytest.mark.parametrize("name, data, words", [
    ("my prog!.rbt", b"Begin()\nEnd()\n", "contains '!'"),
    ("notes.txt", b"Begin()\nEnd()\n", "only .rbt files are programs"),
    ("binary.rbt", b"Begin()\x00\x01\nEnd()\n", "control characters"),
    ("latin1.rbt", "# caf\u00e9\n".encode("latin-1"), "not UTF-8 text"),
    ("lesson2.rbt", b"Begin()\n# another program\nEnd()\n", "a different program named lesson2.rbt"),
    ("huge.rbt", b"# " + b"x" * 1_000_000 + b"\n", "over 1000000 bytes"),
])
def test_an_upload_the_folder_refuses_is_refused_with_the_rule(browser, gui, programs_dir, name, data, words):
    pg = _open(browser, gui["url"])
    before = sorted(p.name for p in programs_dir.iterdir())
    shown = _editor_text(pg)
    pg.locator(UPLOAD_INPUT).set_input_files({"name": name, "mimeType": "text/plain", "buffer": data})
    wait_until(lambda: "upload refused" in _status(pg), 20, what="the refusal in the file row", page=pg)
    assert words in _status(pg), _status(pg)
    notice = pg.locator(".q-notification").filter(has_text="upload refused")
    wait_until(lambda: notice.count() >= 1, 10, what="the refusal as a notification", page=pg)
    assert sorted(p.name for p in programs_dir.iterdir()) == before  # nothing written
    assert (programs_dir / "lesson2.rbt").read_text() == LESSON  # the program of that name kept
    assert _editor_text(pg) == shown
    pg.close()


def test_download_serves_the_saved_file_as_an_attachment(browser, gui, programs_dir):
    pg = _open(browser, gui["url"])
    pg.get_by_test_id("prog-name").fill("lesson2")
    with pg.expect_download() as download:
        pg.get_by_test_id("prog-download").click()
    assert download.value.suggested_filename == "lesson2.rbt"
    assert open(download.value.path()).read() == LESSON
    # the route itself: the folder's name rules (400) and only listed programs (404)
    with urllib.request.urlopen(gui["url"] + "parolkit-programs/lesson2.rbt", timeout=20) as reply:
        assert reply.headers["content-disposition"].startswith("attachment")
        assert reply.read().decode() == LESSON
    for path, code in (("parolkit-programs/..%2F..%2Fetc%2Fpasswd", 400), ("parolkit-programs/a%2Fb.rbt", 400),
                       ("parolkit-programs/missing.rbt", 404)):
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(gui["url"] + path, timeout=20)
        assert refused.value.code == code, path
    # a name with nothing saved under it is said in the row, nothing is downloaded
    pg.get_by_test_id("prog-name").fill("never saved")
    pg.get_by_test_id("prog-download").click()
    wait_until(lambda: "cannot download" in _status(pg) and "Save it first" in _status(pg), 10,
               what="the missing program said", page=pg)
    pg.close()


def test_a_restarted_commander_reopens_the_program_shown_last(browser, gui, programs_dir):
    """Saved last, then the GUI process restarted: the page shows the same name, text and
    "saved" (before: the default example, "unsaved edits")."""
    program = "Begin()\n# lesson three\nDelay(0.2)\nEnd()\n"
    pg = _open(browser, gui["url"])
    content = pg.locator("[data-testid=editor] .cm-content")
    content.click()
    pg.keyboard.press("Control+A")
    pg.keyboard.press("Delete")
    pg.keyboard.insert_text(program)
    pg.get_by_test_id("prog-name").fill("lesson3")
    pg.get_by_test_id("prog-save").click()
    wait_until(lambda: (programs_dir / "lesson3.rbt").is_file()
               and (programs_dir / "lesson3.rbt").read_text() == program, 20, what="saved", page=pg)
    wait_until(lambda: text(pg, "doc-state") == "lesson3.rbt: saved", 10, what="marked saved", page=pg)
    pg.close()
    gui["restart"]()
    again = _open(browser, gui["url"])
    wait_until(lambda: _editor_text(again) == program, 20, what="the same program after the restart", page=again)
    assert again.get_by_test_id("prog-name").input_value() == "lesson3.rbt"
    assert text(again, "doc-state") == "lesson3.rbt: saved"
    again.close()
