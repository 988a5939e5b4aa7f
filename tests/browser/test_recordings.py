"""The Record tab (issue 16 item 2, and teach from a recording in the GUI), in a real headless
Chromium against a real controller, with real files.

One controller process (``parolkit serve --sim``) and one ``parolkit gui --connect`` to it
whose programs and recordings folders are temporary ones the tests look into.  The robot is
moved by a client of the test's own (another client of the controller: the recorder is an
observer and records whatever moves).  How long to record is judged by the ticks the page
says the recording holds (the status stream's), never by sleeping.  The tests run in file
order and build on each other: record, download, teach, nothing to teach, delete, refusals.
"""

from __future__ import annotations

import http.client
import os
import re
import time
import urllib.parse

import numpy as np
import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeoutError
from tests.browser.conftest import gui_on_controller
from tests.browser.helpers import axe_report, axe_violations, text, wait_linked, wait_ready, wait_until

from parolkit.client import Robot
from parolkit.record.reader import load_recording
from parolkit.record.writer import RecordingWriter
from parolkit.robot import PAROL6

pytestmark = [pytest.mark.browser, pytest.mark.slow]

#: the move recorded (deg) and its duration (s): J1 swings 12 deg from standby (90)
TARGET = [102, -90, 180, 0, 0, 180]
MOVE_S = 1.5


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    root = tmp_path_factory.mktemp("recordings")
    programs, recordings = root / "programs", root / "recordings"
    with gui_on_controller(root, ["--stream-watchdog", "0.15"],
                           ["--programs-dir", str(programs), "--recordings-dir", str(recordings)]) as (
            controller, url, log_path):
        yield {"url": url, "controller": controller, "programs": programs, "recordings": recordings,
               "root": root, "log": log_path}


@pytest.fixture(scope="module")
def rpage(browser, setup):
    pg = browser.new_page(viewport={"width": 1500, "height": 1000}, accept_downloads=True)
    pg.goto(setup["url"])
    wait_linked(pg)
    wait_ready(pg, 60)
    pg.get_by_test_id("tab-record").click()
    pg.get_by_test_id("rec-toggle").wait_for()
    yield pg
    pg.close()


def _ticks(page, timeout: float = 30_000) -> int:
    """Statuses the running recording holds, as the page shows them (0 when not recording);
    ``timeout`` (ms) for the Record tab to be in the page."""
    shown = page.get_by_test_id("rec-status").inner_text(timeout=timeout)
    m = re.search(r"(\d+) ticks", shown)
    return int(m.group(1)) if m and "REC" in shown else 0


def _taught(page, program: str) -> bool:
    """``program`` was taught: the Record tab's status says so, or the page has already gone on
    to open it in the Program tab (which takes the Record tab out of the page, at any moment
    between two reads) and the editor holds it."""
    try:
        if page.get_by_test_id("teach-status").count():
            return f"taught {program}" in page.get_by_test_id("teach-status").inner_text(timeout=2000)
        return page.get_by_test_id("prog-name").input_value(timeout=2000) == program
    except PlaywrightTimeoutError:
        return False


def _start(page) -> str:
    """Press Record (on the Record tab); returns the name of the file being recorded."""
    page.get_by_test_id("tab-record").click()
    page.get_by_test_id("rec-toggle").click()
    wait_until(lambda: "REC" in text(page, "rec-status"), 15, what="recording", page=page)
    m = re.search(r"(rec-[\w.-]+\.mcap)", text(page, "rec-status"))
    assert m, text(page, "rec-status")
    return m.group(1)


def _stop(page, name: str) -> None:
    page.get_by_test_id("rec-toggle").click()
    wait_until(lambda: f"saved {name}" in text(page, "rec-status"), 20, what="the recording saved", page=page)
    wait_until(lambda: page.locator(f"[data-testid=rec-item][data-name='{name}']").count() == 1, 15,
               what=f"{name} in the list", page=page)


def _item(page, name: str):
    return page.locator(f"[data-testid=rec-item][data-name='{name}']")


def _move(setup, target: list[float], duration: float) -> None:
    with Robot("127.0.0.1", setup["controller"].port, ack_port=0, timeout=5.0) as robot:
        robot.take_control(force=True)
        try:
            robot.move_joints(target, duration=duration, timeout=30)
        finally:
            robot.release_control()


def _last_j1(program: str) -> float:
    """J1 of the program's last MoveJoint (deg)."""
    found = re.findall(r"^MoveJoint\(([-\d.]+),", program, re.M)
    assert found, program
    return float(found[-1])


def test_record_while_the_robot_moves_lists_the_recording(rpage, setup):
    page = rpage
    assert page.get_by_test_id("rec-toggle").get_attribute("aria-label") == "Record"
    name = _start(page)
    setup["moved"] = name
    assert page.get_by_test_id("rec-toggle").get_attribute("aria-label") == "Stop recording"
    page.get_by_test_id("tab-jog").click()  # recording goes on whatever tab is open; the header says so
    wait_until(lambda: re.search(r"REC \d+:\d\d", text(page, "rec-chip")), 10, what="the REC chip",
               page=page)
    page.get_by_test_id("tab-record").click()
    # the file being written is not listed (nor served) until it is closed
    assert _item(page, name).count() == 0
    wait_until(lambda: _ticks(page) >= 30, 20, what="30 ticks at rest before the move", page=page)
    _move(setup, TARGET, MOVE_S)
    after = _ticks(page)
    wait_until(lambda: _ticks(page) >= after + 40, 20, what="40 ticks at rest after the move", page=page)
    status = text(page, "rec-status")
    assert re.search(r"\d+:\d\d\.\d", status) and re.search(r"\d+(\.\d+)? (B|kB|MB)", status), status
    _stop(page, name)
    wait_until(lambda: not page.get_by_test_id("rec-chip").is_visible(), 10, what="the REC chip gone", page=page)
    path = setup["recordings"] / name
    assert path.is_file() and path.stat().st_size > 0
    row = _item(page, name)
    assert re.search(r"[1-9][\d.]* (B|kB|MB)", row.get_by_test_id("rec-size").inner_text())
    m = re.search(r"([\d.]+) s · (\d+) ticks", row.get_by_test_id("rec-duration").inner_text())
    assert m and int(m.group(2)) >= after + 40, row.inner_text()
    assert re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d", row.get_by_test_id("rec-date").inner_text().strip())


def test_a_recording_downloads_through_the_browser_and_reads_back(rpage, setup):
    page = rpage
    name = setup["moved"]
    with page.expect_download(timeout=20000) as info:
        _item(page, name).get_by_test_id("rec-download").click()
    download = info.value
    assert download.suggested_filename == name
    target = setup["root"] / "downloaded" / name
    target.parent.mkdir()
    download.save_as(target)
    assert target.read_bytes() == (setup["recordings"] / name).read_bytes()
    rec = load_recording(target)
    assert rec.complete and len(rec) > 70
    # the recording holds the move: J1 from standby (90) to 102 deg, at rest at both ends
    j1 = rec.angles_deg[:, 0]
    assert abs(j1[0] - 90.0) < 0.5 and abs(j1[-1] - TARGET[0]) < 0.5, (j1[0], j1[-1])
    assert np.all(np.diff(rec.ticks) > 0)


def test_teach_from_a_recording_saves_the_program_and_opens_it(rpage, setup):
    page = rpage
    name = setup["moved"]
    program = name.removesuffix(".mcap") + ".rbt"
    _item(page, name).get_by_test_id("rec-teach").click()
    wait_until(lambda: _taught(page, program), 60, what="the program taught", page=page)
    path = setup["programs"] / program
    assert path.is_file()
    saved = path.read_text()
    # the fit is the program's first line: the editor shows how close it follows the recording
    assert saved.startswith(f"# taught from {name}: ") and "mm TCP" in saved.splitlines()[0], saved
    assert saved.splitlines()[1] == "Begin()" and "End()" in saved, saved
    assert abs(_last_j1(saved) - TARGET[0]) < 0.1, saved
    # opened in the editor: the Program tab shows it under its name
    wait_until(lambda: page.get_by_test_id("prog-name").is_visible(), 15, what="the Program tab", page=page)
    wait_until(lambda: page.get_by_test_id("prog-name").input_value() == program, 15,
               what="the program's name in the file row", page=page)
    lines = page.evaluate("() => [...document.querySelectorAll('[data-testid=editor] .cm-line')].map(e => e.innerText)")
    assert abs(_last_j1("\n".join(lines)) - TARGET[0]) < 0.1, lines
    assert lines[0].startswith(f"# taught from {name}: "), lines
    # the Record tab's status says how close the fit follows the recording
    page.get_by_test_id("tab-record").click()
    status = text(page, "teach-status")
    assert re.search(r"deviation along the path [\d.]+ mm TCP, [\d.]+ deg joint", status), status
    assert f"taught {program}" in status
    # taught again: a new program, never over the first one
    _item(page, name).get_by_test_id("rec-teach").click()
    second = name.removesuffix(".mcap") + "-2.rbt"
    wait_until(lambda: _taught(page, second), 60, what="taught again", page=page)
    assert path.read_text() == saved and (setup["programs"] / second).is_file()
    page.get_by_test_id("tab-record").click()


def test_teach_from_a_recording_without_motion_says_so(rpage, setup):
    page = rpage
    name = _start(page)
    setup["still"] = name
    wait_until(lambda: _ticks(page) >= 40, 20, what="40 ticks at rest", page=page)
    _stop(page, name)
    before = set(os.listdir(setup["programs"]))
    _item(page, name).get_by_test_id("rec-teach").click()
    wait_until(lambda: "nothing taught" in text(page, "teach-status"), 60, what="the refusal", page=page)
    assert "does not move" in text(page, "teach-status"), text(page, "teach-status")
    assert set(os.listdir(setup["programs"])) == before  # no program written
    # the page lives on: the link is up and the other recording can still be taught
    wait_linked(page)
    assert _item(page, setup["moved"]).get_by_test_id("rec-teach").is_enabled()


def test_delete_asks_first_and_removes_only_that_recording(rpage, setup):
    page = rpage
    name = setup["still"]
    names = [n for n in page.evaluate(
        "() => [...document.querySelectorAll('[data-testid=rec-item]')].map(e => e.dataset.name)")]
    assert names.index(name) < names.index(setup["moved"]), names  # newest first
    _item(page, name).get_by_test_id("rec-delete").click()
    page.get_by_test_id("rec-delete-cancel").click()
    page.wait_for_timeout(500)
    assert (setup["recordings"] / name).is_file() and _item(page, name).count() == 1
    _item(page, name).get_by_test_id("rec-delete").click()
    page.get_by_test_id("rec-delete-confirm").click()
    wait_until(lambda: _item(page, name).count() == 0, 15, what="the row gone", page=page)
    assert not (setup["recordings"] / name).exists()
    assert (setup["recordings"] / setup["moved"]).is_file()


def test_the_record_tab_with_its_list_and_the_delete_dialog_passes_axe(rpage, setup, axe_js):
    """The list's links and buttons are named after their recording, the colours keep 4.5:1
    (test_accessibility checks the tab with an empty list)."""
    page = rpage
    page.get_by_test_id("tab-record").click()
    row = _item(page, setup["moved"])
    assert row.get_by_test_id("rec-download").get_attribute("aria-label") == f"Download {setup['moved']}"
    page.wait_for_timeout(500)
    found = {"list": axe_violations(page, axe_js)}
    row.get_by_test_id("rec-delete").click()
    page.get_by_test_id("rec-delete-cancel").wait_for()
    page.wait_for_timeout(400)  # the dialog's fade-in
    found["delete dialog"] = axe_violations(page, axe_js)
    page.get_by_test_id("rec-delete-cancel").click()
    bad = {k: v for k, v in found.items() if v}
    assert not bad, "axe-core violations:\n" + "\n".join(f"== {k}\n{axe_report(v)}" for k, v in bad.items())


def _demonstration(path, seconds: float, rate_hz: int = 100) -> None:
    """A recording of ``seconds`` at ``rate_hz`` as the recorder writes its status topic: J1
    swings 10 deg out and back in 2 s moves with 2 s pauses (its teach fit takes about 1 s per
    40 s of recording: every recorded sample is compared with its motion's planned path)."""
    spd = PAROL6.steps_per_deg
    writer = RecordingWriter(path)
    n = int(seconds * rate_hz)
    for k in range(n):
        t = k / rate_hz
        phase, leg = t % 4.0, int(t // 4.0)
        s = (1 - np.cos(np.pi * min(phase, 2.0) / 2.0)) / 2  # 0 -> 1 in the move, 1 in the pause
        j1 = 90.0 + 10.0 * (s if leg % 2 == 0 else 1 - s)
        q = [j1, *PAROL6.standby_deg[1:]]
        status = {"seq": k, "time": t, "steps": [int(round(a * spd[i])) for i, a in enumerate(q)], "angles": q,
                  "speeds_deg_s": [0.0] * 6, "pose": [0.0] * 6, "loop": {"rate_hz": rate_hz}, "io": {},
                  "gripper": {}}
        writer.write_status(status, int(t * 1e9), k)
    writer.close({"duration_s": seconds, "statuses": n})


def test_a_long_teach_leaves_the_page_live(rpage, setup):
    """The fit runs off the commander's event loop: while a long recording is being taught the
    page keeps showing the running recording's ticks go up (the page's timers are served)."""
    page = rpage
    long_demo = "long demo.mcap"
    setup["recordings"].mkdir(exist_ok=True)
    # written beside the folder, then moved in whole (the list polls the folder: a file still
    # being written shows as "not closed", as a killed recorder's does)
    staging = setup["recordings"].parent / "staging.mcap"
    _demonstration(staging, 300.0)  # its fit takes seconds (5 min of motion)
    os.replace(staging, setup["recordings"] / long_demo)
    wait_until(lambda: "30000 ticks" in (_item(page, long_demo).get_by_test_id("rec-duration").inner_text()
                                         if _item(page, long_demo).count() == 1 else ""),
               15, what="the copied-in recording listed with its ticks", page=page)
    name = _start(page)
    wait_until(lambda: _ticks(page) >= 10, 20, what="the recording running", page=page)
    _item(page, long_demo).get_by_test_id("rec-teach").click()
    polls: list[tuple[float, int]] = []  # (time, ticks shown) while the page says "teaching"

    def taught() -> bool:
        # the ticks the page shows while it says "teaching" (the Record tab may be gone at any
        # read: the taught program opens in the Program tab)
        try:
            status = page.get_by_test_id("teach-status")
            if status.count() and "teaching from" in status.inner_text(timeout=2000):
                polls.append((time.monotonic(), _ticks(page, timeout=2000)))
        except PlaywrightTimeoutError:
            pass
        return _taught(page, "long demo.rbt")

    wait_until(taught, 180, interval=0.1, what="the long recording taught", page=page)
    # a fit on the event loop freezes the shown ticks for all of it (seconds here); off the
    # loop the page's timers keep showing them go up.  Judged by the updates the page showed
    # during the fit, not by how long it stood still between them (a loaded machine stalls a
    # browser for a while whatever the commander does)
    span = polls[-1][0] - polls[0][0] if polls else 0.0
    assert span >= 1.0, f"the fit took {span:.1f} s: too short to show anything"
    updates = sum(1 for (_, a), (_, b) in zip(polls, polls[1:]) if b > a)
    assert updates >= 5, f"the page showed {updates} tick updates during the {span:.1f} s fit: {polls}"
    page.get_by_test_id("tab-record").click()  # (the taught program opened in the Program tab)
    assert re.search(r"taught long demo.rbt: 75 moves, 74 delays", text(page, "teach-status")), \
        text(page, "teach-status")
    _stop(page, name)


def _get(url: str, raw_path: str) -> tuple[int, bytes]:
    """GET ``raw_path`` exactly as given (no client-side normalisation of '..')."""
    parts = urllib.parse.urlsplit(url)
    conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=10)
    try:
        conn.putrequest("GET", raw_path, skip_accept_encoding=True)
        conn.endheaders()
        resp = conn.getresponse()
        return resp.status, resp.read()
    finally:
        conn.close()


def test_a_download_of_anything_but_a_listed_recording_is_refused(setup):
    folder = setup["recordings"]
    secret = setup["root"] / "secret.mcap"
    secret.write_bytes(b"SECRET outside the recordings folder")
    os.symlink(secret, folder / "link.mcap")  # a link in the folder pointing out of it
    (folder / "notes.txt").write_bytes(b"SECRET not a recording")
    url = setup["url"]
    status, body = _get(url, f"/parolkit-recordings/{setup['moved']}")
    assert status == 200 and body == (folder / setup["moved"]).read_bytes()
    for raw in ("/parolkit-recordings/../x", "/parolkit-recordings/..%2Fx", "/parolkit-recordings/%2E%2E",
                "/parolkit-recordings/..", "/parolkit-recordings/..%2F..%2Fsecret.mcap",
                "/parolkit-recordings/%2Fetc%2Fpasswd", "/parolkit-recordings/link.mcap",
                "/parolkit-recordings/notes.txt", "/parolkit-recordings/nothere.mcap",
                "/parolkit-recordings/.hidden.mcap"):
        status, body = _get(url, raw)
        assert 400 <= status < 500, (raw, status, body[:200])
        assert b"SECRET" not in body and b"root:" not in body, raw
    status, body = _get(url, "/parolkit-recordings/../x")
    assert status == 400 and b"contains a path separator" in body, body
    status, body = _get(url, "/parolkit-recordings/%2E%2E")
    assert status == 400 and b"contains '..'" in body, body
    status, body = _get(url, "/parolkit-recordings/link.mcap")
    assert status == 400 and b"outside the recordings folder" in body, body
    status, body = _get(url, "/parolkit-recordings/nothere.mcap")
    assert status == 404 and b"no recording" in body, body
