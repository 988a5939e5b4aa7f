"""Browser-test fixtures: a real ``parolkit gui --sim`` process and a real headless Chromium."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from contextlib import contextmanager
from pathlib import Path

import pytest

from parolkit.client.launch import die_with_parent, stop_process

REPO_ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO_ROOT / "test-artifacts" / "browser"
CHROMIUM = os.environ.get("PAROLKIT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox", "--headless=new", "--disable-gpu", "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader", "--disable-background-networking", "--disable-component-update",
    "--disable-sync", "--no-first-run",
]


#: the 3D view's frame rate of the commanders the browser tests start (``--view-fps``), unless
#: a test gives its own: Chromium draws WebGL on the CPU here (SwiftShader), and at the
#: default 30 fps a page with the arm moving cost about one core of the two (5 fps: 0.3);
#: test_view3d checks the default rate
TEST_VIEW_FPS = 5


def _free_tcp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_gui(args: list[str]) -> tuple[subprocess.Popen, str, Path]:
    """Start ``parolkit gui ARGS --no-browser`` on a free HTTP port of 127.0.0.1 and wait until
    it answers HTTP (any status: a login page redirects); returns (process, URL, log path).
    The view's frame rate is :data:`TEST_VIEW_FPS` unless ARGS has ``--view-fps``."""
    if "--view-fps" not in args:
        args = [*args, "--view-fps", str(TEST_VIEW_FPS)]
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    port = _free_tcp_port()
    log_path = ARTIFACTS / f"gui-{port}.log"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = str(REPO_ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("PYTEST_CURRENT_TEST", None)  # NiceGUI would switch to its own screen-test mode
    with open(log_path, "wb") as log:
        proc = subprocess.Popen([sys.executable, "-m", "parolkit", "gui", *args, "--http-port", str(port),
                                 "--no-browser"], stdout=log, stderr=subprocess.STDOUT, env=env, cwd=REPO_ROOT,
                                preexec_fn=die_with_parent)
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 90
    while True:
        if proc.poll() is not None:
            pytest.fail(f"parolkit gui exited with {proc.returncode}:\n{log_path.read_text(errors='replace')}")
        try:
            # a static file, not a page: a page request builds the whole commander page, over 1 s
            # on a busy machine, and each timed-out try left the server one more page to build
            # (it never caught up within 40 s at a load of 17-27)
            with urllib.request.urlopen(url + "parolkit-static/commander.css", timeout=10):
                break
        except urllib.error.HTTPError:
            break  # it answers
        except OSError:
            pass
        if time.monotonic() > deadline:
            _stop(proc)
            pytest.fail(f"parolkit gui did not serve {url} within 90 s:\n{log_path.read_text(errors='replace')}")
        time.sleep(0.2)
    return proc, url, log_path


@contextmanager
def gui_on_controller(root: Path, controller_args: list[str], gui_args: list[str]):
    """A controller process (``parolkit serve --sim CONTROLLER_ARGS``, its log in ``root``) and
    ``parolkit gui --connect`` to it (``GUI_ARGS``); yields (controller, URL, GUI log path) and
    stops both, the GUI first."""
    from tests.conftest import start_controller

    controller = start_controller(controller_args, log_dir=root)
    try:
        proc, url, log_path = start_gui(["--connect", f"127.0.0.1:{controller.port}", *gui_args])
        try:
            yield controller, url, log_path
        finally:
            _stop(proc)
    finally:
        controller.stop()


def commander_on_controller(root: Path, *gui_args: str):
    """:func:`gui_on_controller` as :func:`controller_gui` has it: the controller with the stream
    watchdog of one the GUI starts itself, the GUI's programs folder ``root/programs``, and
    ``GUI_ARGS`` besides."""
    return gui_on_controller(root, ["--stream-watchdog", "0.15"], ["--programs-dir", str(root / "programs"), *gui_args])


@pytest.fixture(scope="module")
def controller_gui(tmp_path_factory):
    """A controller process (``parolkit serve --sim`` with the stream watchdog of a controller
    the GUI starts itself, docs/gui.md "Jogging") and ``parolkit gui --connect`` to it, its
    programs folder a temporary one; yields {"url", "controller"}: a test can ask the
    controller itself (``controller.query("GET_STATUS")``, a client of its own)."""
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    root = tmp_path_factory.mktemp("controller-gui")
    with commander_on_controller(root) as (controller, url, _):
        yield {"url": url, "controller": controller}


@pytest.fixture(scope="module")
def controller_page(browser, controller_gui):
    """One 1500 x 1000 page on :func:`controller_gui`, linked, the robot homed and idle."""
    from tests.browser.helpers import wait_linked, wait_ready

    pg = browser.new_page(viewport={"width": 1500, "height": 1000})
    pg.goto(controller_gui["url"])
    wait_linked(pg)
    wait_ready(pg, 60)
    yield pg
    pg.close()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Keep each phase's report on the test (``item.pk_failed``) for :func:`_recover_after_failure`."""
    outcome = yield
    if outcome.get_result().failed:
        item.pk_failed = True


@pytest.fixture(autouse=True)
def _recover_after_failure(request):
    """A test on the module's shared :func:`controller_page` that failed half-way (an E-stop
    latched, a program running) would fail every test after it at its first wait for READY:
    after a failure the page is brought back to READY, so the next test fails, or not, on its
    own (CI 2026-11-29: one failure in test_commander_truth took five tests with it)."""
    yield
    if not getattr(request.node, "pk_failed", False) or "controller_page" not in request.fixturenames:
        return
    from tests.browser.helpers import recover, state

    page = request.getfixturevalue("controller_page")
    try:
        if "PROGRAM" in state(page):
            page.get_by_test_id("btn-stop").click()
        recover(page)
    except Exception as exc:  # the page may be gone: the next test says so itself
        print(f"after the failure the page could not be brought back to READY: {exc}")


@pytest.fixture(scope="module")
def gui_url(tmp_path_factory):
    """Start ``parolkit gui --sim --no-browser`` on a free HTTP port (its programs and
    recordings folders temporary ones); yield its URL."""
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    programs = tmp_path_factory.mktemp("programs")
    recordings = tmp_path_factory.mktemp("recordings")
    proc, url, _ = start_gui(["--sim", "--programs-dir", str(programs), "--recordings-dir", str(recordings)])
    yield url
    _stop(proc)


def _stop(proc: subprocess.Popen) -> None:
    """SIGTERM, then SIGKILL if the GUI has not exited 15 s later (its controller child follows
    it either way: die_with_parent)."""
    stop_process(proc, 15)


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"Chromium not found at {CHROMIUM}: run scripts/ensure-chromium.sh (make test does)")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def page(browser, gui_url):
    """One page for the whole module (tests run in file order and build on each other)."""
    pg = browser.new_page(viewport={"width": 1500, "height": 1000})
    pg.console_errors = []  # type: ignore[attr-defined]
    pg.on("console", lambda m: pg.console_errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: pg.console_errors.append(f"pageerror: {e}"))
    pg.goto(gui_url)
    yield pg
    pg.close()


@pytest.fixture(scope="session")
def axe_js() -> str:
    """axe-core's script (from npm: scripts/ensure-axe.sh, run by make test)."""
    from tests.browser.helpers import AXE_JS

    if not AXE_JS.exists():
        pytest.fail(f"axe-core not found at {AXE_JS}: run scripts/ensure-axe.sh (make test does)")
    return AXE_JS.read_text()
