"""Bandwidth and CPU of the commander with N idle pages open.

Starts ``parolkit gui --sim --no-browser`` on a free port (its own controller), opens N pages
in headless Chromium (Playwright), waits until they are linked, then for ``--seconds`` counts
the bytes of every websocket frame each page receives (Chrome DevTools Protocol
``Network.webSocketFrameReceived``) and the GUI server process's CPU time (``/proc/<pid>/stat``
utime + stime; the controller child is not counted).  Prints bytes/s per page and the GUI
server's CPU %.  Needs Chromium (scripts/ensure-chromium.sh).

    python bench/gui_bandwidth.py [--pages 3] [--seconds 20] [--src OTHER/src]

``--src`` measures another checkout's ``src`` (e.g. a worktree of an older commit) with the
same script: the reference for the figures in README's performance table.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = os.environ.get("PAROLKIT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--headless=new", "--disable-gpu", "--enable-unsafe-swiftshader",
                 "--use-angle=swiftshader", "--disable-background-networking", "--no-first-run"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def _cpu_s(pid: int) -> float:
    """utime + stime of ``pid``, s."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _start_gui(programs: str, src: Path) -> tuple[subprocess.Popen[bytes], str]:
    port = _free_port()
    env = dict(os.environ, PYTHONPATH=str(src) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "parolkit", "gui", "--sim", "--no-browser", "--http-port",
                             str(port), "--programs-dir", programs], env=env, cwd=REPO,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise SystemExit(f"parolkit gui exited with {proc.returncode}")
        try:
            with urllib.request.urlopen(url, timeout=1):
                return proc, url
        except urllib.error.HTTPError:
            return proc, url
        except OSError:
            time.sleep(0.3)
    proc.kill()
    raise SystemExit("parolkit gui did not answer within 60 s")


def measure(pages: int, seconds: float, src: Path = REPO / "src") -> tuple[list[float], float, float]:
    """(bytes/s of each page, GUI CPU % before any page, GUI CPU % with the pages open)."""
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as programs:
        proc, url = _start_gui(programs, src)
        try:
            time.sleep(3)
            c0, t0 = _cpu_s(proc.pid), time.monotonic()
            time.sleep(min(seconds, 10))
            cpu_idle = 100 * (_cpu_s(proc.pid) - c0) / (time.monotonic() - t0)
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
                counts = [0] * pages
                for i in range(pages):
                    page = browser.new_page(viewport={"width": 1500, "height": 1000})
                    cdp = page.context.new_cdp_session(page)
                    cdp.send("Network.enable")

                    def on_frame(ev: dict, i: int = i) -> None:
                        counts[i] += len(ev["response"]["payloadData"].encode())

                    cdp.on("Network.webSocketFrameReceived", on_frame)
                    page.goto(url)
                    page.get_by_text("LINKED").first.wait_for(timeout=60000)
                # idle means homed and standing still (the simulator homes at start)
                page.locator("[data-testid=state-chip]", has_text="READY").wait_for(timeout=90000)
                time.sleep(3)  # let the pages settle
                start = list(counts)
                c0, t0 = _cpu_s(proc.pid), time.monotonic()
                end_at = t0 + seconds
                while time.monotonic() < end_at:
                    browser.contexts[0].pages[0].wait_for_timeout(200)  # keeps Playwright's events flowing
                dt = time.monotonic() - t0
                cpu = 100 * (_cpu_s(proc.pid) - c0) / dt
                rates = [(counts[i] - start[i]) / dt for i in range(pages)]
                browser.close()
        finally:
            proc.terminate()
            proc.wait(20)
    return rates, cpu_idle, cpu


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pages", type=int, default=3, help="idle pages to open (default 3)")
    ap.add_argument("--seconds", type=float, default=20.0, help="measuring time, s (default 20)")
    ap.add_argument("--src", type=Path, default=REPO / "src",
                    help="the parolkit sources to run (default: this checkout's src)")
    args = ap.parse_args()
    if args.pages < 1 or args.seconds <= 0:
        ap.error("--pages must be >= 1 and --seconds > 0")
    if not (args.src / "parolkit" / "gui").is_dir():
        ap.error(f"--src {args.src}: no parolkit/gui package there")
    print(f"measuring {args.src} with {args.pages} idle page(s) for {args.seconds:g} s")
    rates, cpu_idle, cpu = measure(args.pages, args.seconds, args.src.resolve())
    for i, r in enumerate(rates):
        print(f"page {i + 1}: {r / 1000:.1f} KB/s received over the websocket (idle, linked)")
    print(f"GUI server CPU: {cpu_idle:.1f} % with no page, {cpu:.1f} % with {args.pages} page(s) open "
          f"({os.cpu_count()} cores; 100 % = one core)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
