"""``parolkit gui --sim`` as a real process: SIGTERM ends it, and its controller, even while a
page still holds a connection open (no browser needed: a raw socket.io long-poll is enough)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request

from tests.conftest import REPO_ROOT, free_tcp_port, wait_until

from parolkit.client.launch import die_with_parent
from parolkit.gui.cli import GRACEFUL_SHUTDOWN_S, GUI_STREAM_WATCHDOG_S


def _children(pid: int) -> list[int]:
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout
    return [int(p) for p in out.split()]


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_sigterm_stops_the_gui_and_its_controller_while_a_page_holds_a_long_poll(tmp_path):
    port = free_tcp_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO_ROOT / "src"))
    env.pop("PYTEST_CURRENT_TEST", None)  # NiceGUI would switch to its own screen-test mode
    with open(tmp_path / "gui.log", "wb") as log:
        proc = subprocess.Popen([sys.executable, "-m", "parolkit", "gui", "--sim", "--http-port", str(port),
                                 "--no-browser", "--programs-dir", str(tmp_path / "programs")],
                                stdout=log, stderr=subprocess.STDOUT, env=env, cwd=REPO_ROOT,
                                preexec_fn=die_with_parent)
    held = None
    try:
        base = f"http://127.0.0.1:{port}/_nicegui_ws/socket.io/?EIO=4&transport=polling"

        def handshake():
            try:
                with urllib.request.urlopen(base, timeout=2) as r:
                    return r.read().decode()
            except OSError:
                return None

        body = wait_until(handshake, 60, 0.2, what="the commander serving socket.io")
        sid = json.loads(body[1:])["sid"]
        controllers = _children(proc.pid)
        assert len(controllers) == 1, controllers
        with open(f"/proc/{controllers[0]}/cmdline", "rb") as f:
            argv = f.read().decode().split("\0")
        # the GUI's jog cadence needs its 150 ms watchdog (a flag: no temporary config file)
        assert argv[argv.index("--stream-watchdog") + 1] == str(GUI_STREAM_WATCHDOG_S)
        # the second poll is held open by the server until it has something to send (up to
        # its ping interval, 24 s): uvicorn's default shutdown would wait for it
        held = socket.create_connection(("127.0.0.1", port))
        held.sendall(f"GET /_nicegui_ws/socket.io/?EIO=4&transport=polling&sid={sid} HTTP/1.1\r\n"
                     "Host: 127.0.0.1\r\n\r\n".encode())
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(GRACEFUL_SHUTDOWN_S + 10)  # uvicorn's default waits for the poll (24 s)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGUSR1)  # the GUI prints its threads' stacks to its log
            time.sleep(1.0)
            raise AssertionError("the GUI did not exit:\n" + (tmp_path / "gui.log").read_text(errors="replace")) \
                from None
        log = (tmp_path / "gui.log").read_text(errors="replace")
        # uvicorn re-raises the signal once the app has shut down
        assert proc.returncode in (0, -signal.SIGTERM), log
        # the GUI stopped its controller before exiting (SIGTERM: stop motion, DISABLE); had it
        # only died with the GUI (die_with_parent), it would still be shutting down here
        assert not _alive(controllers[0]), "the controller outlived the GUI"
        assert "controller: shutting down" in log, log
    finally:
        if held is not None:
            held.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)
