"""The commander for a class: 20 pages (1 teacher, 19 students) and the turn queue handed round.

Starts ``parolkit gui --sim --no-browser`` on a free port with ``gui.teacher_password`` (its own
controller), opens one page per member in headless Chromium (Playwright; each in a browser
context of its own, so each has its own session), logs the teacher and the students in, and
every student asks for a turn.  Then:

* **idle**: for ``--seconds`` the GUI server's CPU time (``/proc/<pid>/stat`` utime + stime; the
  controller child not counted) and the bytes of every websocket frame each page receives
  (Chrome DevTools Protocol ``Network.webSocketFrameReceived``): CPU per idle page and bytes per
  idle page per second;
* **E-STOP from a student page** (before the rounds: a hand-over that never shows ends a run),
  see below;
* **the queue handed round** ``--rounds`` times: the teacher presses "Hand over to <first>"
  (the first row's Hand over: the turn in progress ends, the robot is stopped), the new holder's
  page shows "your turn",
  the previous holder asks for a turn again (to the end of the queue); the time from the press
  to the holder's page (a figure of the whole path: the teacher's page, the server, the
  holder's page on a loaded machine) and the GUI server's CPU during the rounds;
* **E-STOP from a student page**, ``--estops`` times, each from another watching student: the
  bench subscribes to the controller's status every tick (its own client) and counts the control
  frames (the status's ``seq``, the number of its tick; one frame to the board per tick) from the last status
  before the GUI server sent the ESTOP (the time in the commander's log, to the ms) to the first
  status with the E-stop latched: 1 is "on the next frame".  The press-to-latch frames (the
  browser and the websocket included) are printed too.  The teacher enables again between them.

Each page's 3D view draws one frame per 20 s (:data:`SLOW_DRAWING`): the server's side is
unchanged, the machine keeps its cores for the server.  Figures only, no assertion on time:
``make bench`` runs it, a loaded machine changes them.  Needs Chromium
(scripts/ensure-chromium.sh).

    python bench/classroom.py [--students 19] [--rounds 5] [--seconds 20] [--estops 5]
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

from playwright.sync_api import TimeoutError as PlaywrightTimeout

from _measure import machine_line

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = os.environ.get("PAROLKIT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--headless=new", "--disable-gpu", "--enable-unsafe-swiftshader",
                 "--use-angle=swiftshader", "--disable-background-networking", "--no-first-run"]
TEACHER_PASSWORD = "the bench's teacher"
#: generous bounds on waiting for a page (a loaded machine), ms: a bound, not a figure
PAGE_WAIT_MS = 600_000
#: a press whose effect the page has not shown this long is pressed again (it was lost), ms
RETRY_MS = 90_000
#: the pages' own 3D view draws one frame per 20 s (the scene's fps prop in the page, as
#: tests/browser/test_view3d.py sets it): 20 software-rendered WebGL views at their idle 2 fps
#: take cores of the machine that also runs the server; what the server sends and spends is the
#: same (the prop only paces the page's drawing; the server sets it again when the arm moves)
SLOW_DRAWING = """() => {
  const host = document.querySelector('[data-testid=scene]');
  const el = host && typeof mounted_app !== 'undefined' && mounted_app.elements[Number(host.id.slice(1))];
  if (el) el.props.fps = 0.05;
  return !!el;
}"""

CHIP = "document.querySelector('[data-testid=class-chip]')"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def _cpu_s(pid: int) -> float:
    """utime + stime of ``pid``, s."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Gui:
    """``parolkit gui --sim`` with a teacher's password; its log tells the controller's port."""

    def __init__(self, root: Path) -> None:
        cfg = root / "parolkit.toml"
        cfg.write_text(f'[gui]\nteacher_password = "{TEACHER_PASSWORD}"\n')
        self.port = _free_port()
        self.log_path = root / "gui.log"
        env = dict(os.environ, PYTHONPATH=str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
        with open(self.log_path, "wb") as log:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "parolkit", "gui", "--sim", "--no-browser", "--http-port", str(self.port),
                 "--programs-dir", str(root / "programs"), "--config", str(cfg)],
                env=env, cwd=REPO, stdout=log, stderr=subprocess.STDOUT)
        self.url = f"http://127.0.0.1:{self.port}/"
        deadline = time.monotonic() + 90
        while True:
            if self.proc.poll() is not None:
                raise SystemExit(f"parolkit gui exited with {self.proc.returncode}:\n{self.log_path.read_text()}")
            try:
                with urllib.request.urlopen(self.url + "login", timeout=1):
                    break
            except urllib.error.HTTPError:
                break
            except OSError:
                if time.monotonic() > deadline:
                    self.stop()
                    raise SystemExit("parolkit gui did not answer within 90 s") from None
                time.sleep(0.3)
        m = re.search(r"on UDP (\d+), acks on", self.log_path.read_text())
        if m is None:
            self.stop()
            raise SystemExit(f"no controller port in the GUI's log:\n{self.log_path.read_text()}")
        self.controller_port = int(m.group(1))

    def cpu_s(self) -> float:
        return _cpu_s(self.proc.pid)

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()


class Member:
    """One page in a browser context of its own, with its websocket bytes counted."""

    def __init__(self, browser: Any, url: str, name: str) -> None:
        self.name = name
        self.context = browser.new_context(viewport={"width": 1280, "height": 800})
        self.page = self.context.new_page()
        self.bytes = 0
        cdp = self.context.new_cdp_session(self.page)
        cdp.send("Network.enable")
        cdp.on("Network.webSocketFrameReceived", self._frame)
        self.page.set_default_timeout(PAGE_WAIT_MS)
        self.page.goto(url)
        self.page.wait_for_url("**/login?next=*")
        if name == "teacher":
            self.page.get_by_test_id("login-password").fill(TEACHER_PASSWORD)
        else:
            self.page.get_by_test_id("login-name").fill(name)
        self.page.get_by_test_id("login-submit").click()

    def _frame(self, ev: dict[str, Any]) -> None:
        self.bytes += len(ev["response"]["payloadData"].encode())

    def slow_drawing(self) -> None:
        self.page.wait_for_function(SLOW_DRAWING, timeout=PAGE_WAIT_MS, polling=500)

    def wait_chip(self, fragment: str, timeout_ms: int = PAGE_WAIT_MS) -> None:
        self.page.wait_for_function(f"(f) => ({CHIP}?.innerText || '').includes(f)", arg=fragment,
                                    timeout=timeout_ms, polling=50)

    def chip(self) -> str:
        return "".join(str(self.page.evaluate(f"() => {CHIP}?.innerText || ''")).splitlines()[-1:])

    def press_until(self, testid: str, fragment: str, locator: Any = None) -> int:
        """Press ``testid`` (or ``locator``) until this page's chip shows ``fragment``: the
        presses it took.  A press can be lost on a starved machine (the page was reloaded after
        its connection timed out): pressed again after :data:`RETRY_MS`, at most 5 times."""
        target = locator if locator is not None else self.page.get_by_test_id(testid)
        for presses in range(1, 6):
            target.click()
            try:
                self.wait_chip(fragment, RETRY_MS)
                return presses
            except PlaywrightTimeout:
                print(f"    ({self.name}: still {self.chip()!r} {RETRY_MS // 1000} s after pressing {testid}: "
                      "pressed again)", flush=True)
        raise SystemExit(f"{self.name}'s page never showed {fragment!r} (it shows {self.chip()!r})")


class StatusTape:
    """Every status of the controller (every tick) with the wall time it arrived and the
    controller's own time of its tick (the status's ``time``, s since the controller started).

    A status is judged by when its tick ran, not by when it arrived: on a machine that also
    runs 20 pages this process hears the statuses tens of ms late, and by arrival the last
    status before a moment is a few ticks older than the tick that ran then (the first run
    counted 4 frames from the GUI's send to the latch, every time).  The controller's clock
    is put on the wall clock by the status that arrived soonest after its tick (the smallest
    arrival - ``time``): a bound from below on the lag that all the other statuses share."""

    def __init__(self, port: int) -> None:
        from parolkit.client import Robot

        self.robot = Robot("127.0.0.1", port, ack_port=0, timeout=2.0)
        self.lock = threading.Lock()
        self.tape: list[tuple[float, int, bool, float]] = []
        self.sub = self.robot.subscribe(1, callback=self._on)

    def _on(self, st: Any) -> None:
        with self.lock:
            self.tape.append((time.time(), st.seq, st.estop_latched, st.time))  # seq: the tick's number

    def frames(self, since_wall: float) -> int | None:
        """Control frames from the last tick that ran before ``since_wall`` to the first one
        whose status shows the E-stop latched (None: not latched yet)."""
        with self.lock:
            tape = list(self.tape)
        if not tape:
            return None
        offset = min(arrived - t for arrived, _, _, t in tape)  # the controller's clock on the wall clock
        ran = [(t + offset, seq, latched) for _, seq, latched, t in tape]
        before = [r for r in ran if r[0] <= since_wall]
        after = [r for r in ran if r[0] > since_wall and r[2]]
        if not before or not after:
            return None
        return after[0][1] - before[-1][1]

    def close(self) -> None:
        self.sub.close()
        self.robot.close()


def _log_times(teacher: Member, text: str) -> list[float]:
    """Wall times (s since the epoch) of the commander's log lines holding ``text`` (the log
    shows HH:MM:SS.mmm of today)."""
    out = []
    today = datetime.date.today()
    for line in teacher.page.get_by_test_id("log").inner_text().splitlines():
        m = re.match(r"(\d\d):(\d\d):(\d\d)\.(\d{3})\s", line)
        if m and text in line:
            h, mi, s, ms = (int(g) for g in m.groups())
            stamp = datetime.datetime.combine(today, datetime.time(h, mi, s, ms * 1000))
            out.append(stamp.timestamp())
    return out


def _pct(values: list[float], q: float) -> float:
    vs = sorted(values)
    return vs[min(len(vs) - 1, int(round(q / 100 * (len(vs) - 1))))]


def run(students: int, rounds: int, seconds: float, estops: int) -> None:
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp:
        gui = Gui(Path(tmp))
        try:
            time.sleep(3)
            c0, t0 = gui.cpu_s(), time.monotonic()
            time.sleep(min(seconds, 10))
            cpu_none = 100 * (gui.cpu_s() - c0) / (time.monotonic() - t0)
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
                t_open = time.monotonic()
                members = []
                for name in ["teacher", *(f"Student {i + 1:02d}" for i in range(students))]:
                    members.append(Member(browser, gui.url, name))
                    members[-1].wait_chip(" · ")
                    members[-1].slow_drawing()  # before the next page loads
                teacher, pupils = members[0], members[1:]
                for m in members:
                    m.wait_chip(" · ")
                    m.slow_drawing()
                print(f"{len(members)} pages logged in and linked in {time.monotonic() - t_open:.0f} s", flush=True)
                teacher.page.locator("[data-testid=state-chip]", has_text="READY").wait_for()
                for m in pupils:
                    m.page.get_by_test_id("class-action").click()  # Ask for a turn
                teacher.page.wait_for_function(
                    "(n) => document.querySelectorAll('[data-testid=class-queue-item]').length === n",
                    arg=students, timeout=PAGE_WAIT_MS)
                _idle(gui, members, seconds, cpu_none)
                try:
                    # (the E-STOPs first: a hand-over that never shows ends the run)
                    _estops(gui, teacher, pupils, estops)
                    _hand_round(gui, teacher, pupils, rounds)
                except BaseException:
                    _keep_log(gui, teacher)
                    raise
                browser.close()
        finally:
            gui.stop()


def _keep_log(gui: Gui, teacher: Member) -> None:
    """The run failed: what the teacher's page shows, and the GUI server's log kept (the
    temporary folder goes)."""
    kept = Path(tempfile.gettempdir()) / f"classroom-gui-{datetime.datetime.now():%Y%m%d-%H%M%S}.log"
    try:
        queue = teacher.page.eval_on_selector_all("[data-testid=class-queue-item]",
                                                  "els => els.map(e => e.dataset.name)")
        print(f"the teacher's page: {teacher.chip()!r}, the queue {queue}", flush=True)
    except Exception as exc:  # (the page may be what failed)
        print(f"the teacher's page could not be read: {exc}", flush=True)
    kept.write_bytes(gui.log_path.read_bytes())
    print(f"the GUI server's log: {kept}", flush=True)


def _idle(gui: Gui, members: list[Member], seconds: float, cpu_none: float) -> None:
    time.sleep(3)  # let the pages settle
    start = [m.bytes for m in members]
    c0, t0 = gui.cpu_s(), time.monotonic()
    while time.monotonic() < t0 + seconds:
        members[0].page.wait_for_timeout(200)  # keeps Playwright's events flowing
    dt = time.monotonic() - t0
    cpu = 100 * (gui.cpu_s() - c0) / dt
    rates = [(m.bytes - b) / dt for m, b in zip(members, start, strict=True)]
    n = len(members)
    print(f"idle, {n} pages ({n - 1} students in the queue), {dt:.0f} s:")
    print(f"  GUI server CPU {cpu:.1f} % of a core ({cpu_none:.1f} % with no page): "
          f"{(cpu - cpu_none) / n:.2f} % per idle page")
    print(f"  websocket bytes per idle page: {statistics.mean(rates) / 1000:.2f} KB/s mean, "
          f"{min(rates) / 1000:.2f} min, {max(rates) / 1000:.2f} max (teacher {rates[0] / 1000:.2f} KB/s)",
          flush=True)


def _hand_round(gui: Gui, teacher: Member, pupils: list[Member], rounds: int) -> None:
    by_name = {m.name: m for m in pupils}
    latencies: list[float] = []
    holder: Member | None = None
    repeated = 0
    c0, t0 = gui.cpu_s(), time.monotonic()
    first = teacher.page.locator("[data-testid=class-queue-item]").first
    for k in range(rounds * len(pupils)):
        nxt = by_name[str(first.get_attribute("data-name"))]
        t_press = time.monotonic()
        # the first waiting student's Hand over on the teacher's page
        presses = nxt.press_until("class-hand-over", "your turn", first.get_by_test_id("class-hand-over"))
        if presses == 1:
            latencies.append(time.monotonic() - t_press)
        repeated += presses - 1
        if holder is not None:  # the previous holder queues again
            holder.wait_chip("watching")
            repeated += holder.press_until("class-action", "in the queue") - 1
        holder = nxt
        if (k + 1) % len(pupils) == 0:
            print(f"  round {(k + 1) // len(pupils)} done after {time.monotonic() - t0:.0f} s", flush=True)
    dt = time.monotonic() - t0
    cpu = 100 * (gui.cpu_s() - c0) / dt
    teacher.page.get_by_test_id("class-action").click()  # Take back
    teacher.wait_chip("you have the robot")
    ms = [x * 1000 for x in latencies]
    print(f"the queue handed round {rounds} times: {rounds * len(pupils)} hand-overs in {dt:.0f} s, GUI server "
          f"CPU {cpu:.1f} %; {repeated} press(es) repeated after {RETRY_MS // 1000} s without effect (a page reloaded "
          "on a starved machine; those hand-overs are not in the times)")
    print(f"  the teacher's press to 'your turn' on the student's page: p50 {_pct(ms, 50):.0f} ms, "
          f"p95 {_pct(ms, 95):.0f} ms, max {max(ms):.0f} ms")


def _estops(gui: Gui, teacher: Member, pupils: list[Member], estops: int) -> None:
    tape = StatusTape(gui.controller_port)
    sent_frames: list[int] = []
    press_frames: list[int] = []
    try:
        for k in range(estops):
            student = pupils[(k * 7) % len(pupils)]
            time.sleep(0.5)  # a tape before the press
            before = len(_log_times(teacher, "software E-STOP sent"))
            t_press = time.time()
            student.page.get_by_test_id("btn-estop").click()
            teacher.page.wait_for_function(
                "() => (document.querySelector('[data-testid=state-chip]')?.innerText || '').includes('E-STOP')",
                timeout=PAGE_WAIT_MS)
            deadline = time.monotonic() + 30
            while (sent := _log_times(teacher, "software E-STOP sent")) and len(sent) <= before \
                    and time.monotonic() < deadline:
                time.sleep(0.2)
            t_sent = sent[-1] if len(sent) > before else None
            f_press = tape.frames(t_press)
            f_sent = tape.frames(t_sent) if t_sent is not None else None
            if f_press is not None:
                press_frames.append(f_press)
            if f_sent is not None:
                sent_frames.append(f_sent)
            print(f"  E-STOP from {student.name}'s page: latched {f_sent} frame(s) after the GUI server sent it, "
                  f"{f_press} after the press")
            teacher.page.get_by_test_id("btn-enable").click()
            teacher.page.locator("[data-testid=state-chip]", has_text="READY").wait_for()
    finally:
        tape.close()
    if sent_frames:
        print(f"E-STOP from a student page, {len(sent_frames)} presses: frames from the GUI's send to the latch "
              f"{sorted(sent_frames)} (1 = the next frame); from the press {sorted(press_frames)} "
              "(the browser, the websocket and the GUI server included)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--students", type=int, default=19, help="student pages (default 19; one teacher besides)")
    ap.add_argument("--rounds", type=int, default=5, help="times the queue is handed round (default 5)")
    ap.add_argument("--seconds", type=float, default=20.0, help="idle measuring time, s (default 20)")
    ap.add_argument("--estops", type=int, default=5, help="E-STOPs from student pages (default 5)")
    args = ap.parse_args()
    if args.students < 2 or args.rounds < 1 or args.seconds <= 0 or args.estops < 0:
        ap.error("--students must be >= 2, --rounds >= 1, --seconds > 0 and --estops >= 0")
    print(machine_line())
    print(f"1 teacher and {args.students} students, the queue handed round {args.rounds} times")
    run(args.students, args.rounds, args.seconds, args.estops)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
