"""Shared test fixtures: free ports, test data paths, and a real controller process.

The controller fixture starts ``python -m parolkit serve`` as a real subprocess (never an
in-process stand-in) on free UDP ports, on a pre-homed simulated board unless a test asks for
homing (``homed=False``), and waits until its board link is up.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

import parolkit
from parolkit.client.launch import die_with_parent

REPO_ROOT = Path(__file__).resolve().parent.parent
DATA_DIR = REPO_ROOT / "tests" / "data"
ARTIFACTS_DIR = REPO_ROOT / "test-artifacts"

# every process a test starts keeps its default programs and recordings folders
# ($XDG_DATA_HOME/parolkit/...) out of the user's home: a commander started without
# --programs-dir (test_supervisor_state) wrote into ~/.local/share/parolkit
if "PAROLKIT_TEST_DATA_HOME" not in os.environ:
    import tempfile

    os.environ["PAROLKIT_TEST_DATA_HOME"] = tempfile.mkdtemp(prefix="parolkit-test-data-")
os.environ["XDG_DATA_HOME"] = os.environ["PAROLKIT_TEST_DATA_HOME"]


def wait_until(predicate, timeout: float = 10.0, interval: float = 0.02, what: str = "condition"):
    """Poll ``predicate`` until it returns something true (returned), else fail after ``timeout``
    s. For post-conditions that take a few ticks: a fixed sleep is too short on a loaded machine."""
    deadline = time.monotonic() + timeout
    while True:
        last = predicate()
        if last:
            return last
        if time.monotonic() > deadline:
            raise AssertionError(f"{what} not reached within {timeout:g} s (last: {last!r})")
        time.sleep(interval)


def frames_pass(loop_stats, n: int, timeout: float = 20.0) -> None:
    """Wait until the controller has written ``n`` more frames: its ticks, not the clock (a
    busy machine stretches the wall clock, never the ticks).  ``loop_stats``: its
    GET_LOOP_STATS as a dict (``ControllerProcess.loop_stats`` or the like)."""
    sent = loop_stats()["frames_sent"]
    wait_until(lambda: loop_stats().get("frames_sent", 0) >= sent + n, timeout, what=f"{n} more frames written")


def process_state(pid: int) -> str | None:
    """The state letter of process ``pid`` in /proc (``S`` sleeping, ``T`` stopped, ``Z``
    exited but not yet reaped, ...), None when there is no such process."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def process_exited(pid: int) -> bool:
    """Process ``pid`` has exited with all its threads (not yet reaped): its files are closed.
    (A killed multi-threaded process shows ``Z`` as soon as its main thread is gone, while its
    other threads, which share its open files, may still be exiting on a loaded machine.)"""
    if process_state(pid) != "Z":
        return False
    try:
        return len(os.listdir(f"/proc/{pid}/task")) <= 1
    except OSError:
        return True


def child_pids(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (from /proc; exited ones not yet reaped included)."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
            out.append(int(entry.name))
    return out


def free_udp_port() -> int:
    """A UDP port that was free a moment ago on 127.0.0.1."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def free_tcp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def udp_query(port: int, text: str, timeout: float = 1.0, host: str = "127.0.0.1") -> str | None:
    """Send one datagram and return the first reply (or None on timeout)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.settimeout(timeout)
        s.sendto(text.encode(), (host, port))
        try:
            data, _ = s.recvfrom(65535)
        except TimeoutError:
            return None
        return data.decode(errors="replace")


def run_mypy(directory: Path, files: dict[str, str], *options: str) -> dict[str, dict[int, list[str]]]:
    """mypy ``--strict`` over user code (``files``: file name -> source) written to
    ``directory``, against THIS checkout's ``parolkit`` (site-packages switched off, so an
    installed copy cannot answer instead; errors inside parolkit itself are not reported).
    ``options``: more lines of the ``[mypy]`` section (``disallow_any_expr = True``).
    Returns file name -> line -> the error messages of that line."""
    api = pytest.importorskip("mypy.api")
    for name, source in files.items():
        (directory / name).write_text(source, encoding="utf-8")
    src = Path(parolkit.__file__).resolve().parents[1]
    (directory / "mypy.ini").write_text(
        f"[mypy]\nmypy_path = {src}\nstrict = True\nno_site_packages = True\nfollow_imports = silent\n"
        f"cache_dir = {directory / 'cache'}\n" + "".join(f"{o}\n" for o in options), encoding="utf-8")
    stdout, stderr, _status = api.run(["--config-file", str(directory / "mypy.ini"),
                                       *(str(directory / name) for name in files)])
    assert not stderr, stderr
    errors: dict[str, dict[int, list[str]]] = {name: {} for name in files}
    for line in stdout.splitlines():
        path, _, rest = line.partition(":")
        number, _, message = rest.partition(": error: ")
        name = Path(path).name
        if message and name in errors and number.isdigit():
            errors[name].setdefault(int(number), []).append(message)
    return errors


@dataclass
class ControllerProcess:
    """A running ``parolkit serve`` subprocess."""

    proc: subprocess.Popen
    host: str
    port: int
    ack_port: int
    args: list[str] = field(default_factory=list)
    log_path: Path | None = None

    def query(self, text: str, timeout: float = 1.0) -> str | None:
        return udp_query(self.port, text, timeout, self.host)

    def loop_stats(self) -> dict:
        """GET_LOOP_STATS as a dict (empty when no reply came)."""
        reply = self.query("GET_LOOP_STATS") or ""
        return json.loads(reply.split("|", 1)[1]) if reply.startswith("LOOP_STATS|") else {}

    def log(self) -> str:
        return self.log_path.read_text(errors="replace") if self.log_path else ""

    def stop(self, timeout: float = 10.0) -> int:
        from parolkit.client.launch import stop_process

        code = stop_process(self.proc, timeout)
        assert code is not None
        return code


#: the simulated board of a controller the fixtures start: powered up as if homing had just
#: finished (no 2 s of homing before every test that is not about homing)
PRE_HOMED_BOARD = "sim://?homed=1"


def _board_args(extra: list[str], homed: bool, lockstep: bool) -> list[str]:
    """The board flags ``start_controller`` adds to ``extra``: none when ``extra`` names a link
    (``--port``/``--sim``); else a pre-homed simulated board (``homed``, with ``--no-home``:
    nothing to home) or one that powers up unhomed (the controller homes it at start unless
    ``extra`` says ``--no-home``), in lockstep with the frames when ``lockstep``."""
    if "--port" in extra or "--sim" in extra:
        if lockstep:
            raise ValueError("lockstep=True picks the board: do not also pass --port/--sim")
        return []
    pre_homed = homed and "--no-home" not in extra and "--sim-speedup" not in extra
    if lockstep:
        from parolkit.record.replay import lockstep_board  # numpy & co.: only when needed

        rate = float(extra[extra.index("--rate") + 1]) if "--rate" in extra else 100.0
        board = ["--port", lockstep_board(rate) + ("&homed=1" if pre_homed else "")]
    else:
        board = ["--port", PRE_HOMED_BOARD] if pre_homed else ["--sim"]
    return board + (["--no-home"] if pre_homed else [])


def start_controller(
    extra_args: list[str] | None = None,
    *,
    log_dir: Path | None = None,
    ready_timeout: float = 20.0,
    wait_homed: bool = True,
    homed: bool = True,
    lockstep: bool = False,
) -> ControllerProcess:
    """Start ``parolkit serve`` on free ports and wait until it answers PING and (with
    ``wait_homed``) its board link is up and homed.

    Without ``--port``/``--sim`` in ``extra_args`` the board is simulated: pre-homed unless
    ``homed=False`` (a test about homing: the board powers up unhomed and the controller homes
    it, as ``parolkit serve --sim`` does) or ``--no-home`` is given (an unhomed board);
    ``lockstep=True``: a board in lockstep with the frames (``sim://?clock=virtual&step=...``:
    each frame written runs it exactly one period, and the controller schedules trajectories on
    its ticks), for tests that judge how long something took or how far something moved: in
    ticks, whatever the machine's load did to the wall clock."""
    port, ack_port = free_udp_port(), free_udp_port()
    args = [sys.executable, "-m", "parolkit", "serve", "--udp-port", str(port), "--ack-port", str(ack_port)]
    extra = list(extra_args or [])
    extra += _board_args(extra, homed, lockstep)
    args += extra
    log_dir = log_dir or ARTIFACTS_DIR
    log_dir.mkdir(parents=True, exist_ok=True)
    log_path = log_dir / f"controller-{port}.log"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = str(REPO_ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(
            args, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=REPO_ROOT,
            preexec_fn=die_with_parent,
        )
    cp = ControllerProcess(proc, "127.0.0.1", port, ack_port, args, log_path)
    deadline = time.monotonic() + ready_timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"controller exited with {proc.returncode}:\n{cp.log()}")
        if (cp.query("PING", 0.2) or "").startswith("PONG"):
            break
    else:
        cp.stop()
        raise RuntimeError(f"controller did not answer PING within {ready_timeout} s:\n{cp.log()}")
    if not wait_homed or "--no-home" in (extra_args or []):
        return cp
    while time.monotonic() < deadline:  # homing done (or a pre-homed board's first frames read)
        if proc.poll() is not None:
            raise RuntimeError(f"controller exited with {proc.returncode}:\n{cp.log()}")
        reply = cp.query("GET_STATUS", 0.5) or ""
        if "HOMED=1,1,1,1,1,1" in reply and "STATE=IDLE" in reply and reply.endswith("|SERIAL=1"):
            return cp
        time.sleep(0.02)
    cp.stop()
    raise RuntimeError(f"the board link was not up and homed within {ready_timeout} s:\n{cp.log()}")


@pytest.fixture
def controller_factory(tmp_path):
    """``controller_factory(extra_args)`` starts controllers that are stopped after the test."""
    started: list[ControllerProcess] = []

    def factory(extra_args: list[str] | None = None, **kw) -> ControllerProcess:
        cp = start_controller(extra_args, log_dir=tmp_path, **kw)
        started.append(cp)
        return cp

    yield factory
    for cp in started:
        cp.stop()


@pytest.fixture
def controller(controller_factory) -> ControllerProcess:
    """A controller on a pre-homed simulated board, on free ports."""
    return controller_factory()


# --- the order of the test modules: the longest first. make test runs the modules in parallel
# processes, each module whole in one (--dist loadfile --no-loadscope-reorder: xdist hands them
# out in collection order); a module started last that takes a minute leaves the other process
# idle for that minute. tests/module_seconds.json holds each module's measured time (written by
# scripts/test-durations from a timeline below); a module not in it counts as its folder's
# typical time until the file is next written
MODULE_SECONDS = Path(__file__).with_name("module_seconds.json")
_FOLDER_SECONDS = {"browser": 30.0, "integration": 15.0, "unit": 2.0}


def _module_seconds(nodeid: str, measured: dict[str, float]) -> float:
    module = nodeid.split("::", 1)[0]
    if module in measured:
        return measured[module]
    parts = module.split("/")
    return _FOLDER_SECONDS.get(parts[1] if len(parts) > 2 else "", 2.0)


def _heavy(module: str) -> bool:
    """A browser module: Chromium, a commander and a controller at once, over a core of the
    two while the arm moves; two of them side by side each took about twice as long."""
    return module.startswith("tests/browser/")


def module_order(seconds: dict[str, float], workers: int) -> list[str]:
    """The modules in the order pytest-xdist (``--dist loadfile --no-loadscope-reorder``) is to
    hand them out: as a greedy run of ``workers`` processes would start them, each process when
    free taking the longest module left (longest first: no long module left for the end),
    a browser module only while no other process runs one (if modules of the other kind are
    left)."""
    left = {kind: sorted((m for m in seconds if _heavy(m) == kind), key=lambda m: (-seconds[m], m))
            for kind in (True, False)}
    running: list[tuple[float, bool]] = [(0.0, False)] * max(1, workers)  # (free at, runs a browser module)
    order: list[str] = []
    while left[True] or left[False]:
        i = min(range(len(running)), key=lambda k: running[k][0])
        now = running[i][0]
        busy_heavy = any(heavy and free > now for k, (free, heavy) in enumerate(running) if k != i)
        kind = (not busy_heavy) if left[not busy_heavy] else busy_heavy
        module = left[kind].pop(0)
        order.append(module)
        running[i] = (now + seconds[module], kind)
    return order


def pytest_collection_modifyitems(session, config, items):
    measured = json.loads(MODULE_SECONDS.read_text()) if MODULE_SECONDS.exists() else {}
    modules = {item.nodeid.split("::", 1)[0] for item in items}
    # (the order that counts is the workers' collection: pytest-xdist tells them how many they are)
    workers = os.environ.get("PYTEST_XDIST_WORKER_COUNT") or getattr(config.option, "numprocesses", None) or 1
    rank = {m: k for k, m in enumerate(module_order({m: _module_seconds(m, measured) for m in modules},
                                                    int(workers)))}
    items.sort(key=lambda item: rank[item.nodeid.split("::", 1)[0]])  # stable: a module's own order kept


# --- the run's timeline: PAROLKIT_TEST_TIMELINE=FILE appends one line per test
# ("worker start_s end_s nodeid", wall-clock seconds, setup to teardown) for
# scripts/test-durations and to see when a run's processes were idle; off by default
_TIMELINE = os.environ.get("PAROLKIT_TEST_TIMELINE")


if _TIMELINE:
    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        start = time.time()
        yield
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        with open(_TIMELINE, "a") as f:
            f.write(f"{worker} {start:.3f} {time.time():.3f} {item.nodeid}\n")
