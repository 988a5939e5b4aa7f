"""A house you can read (issue 15 item 13): the commander's stylesheet and keyboard script are
static files of the package, served by the GUI and applied by the page; the page class is
split into component modules.
"""

from __future__ import annotations

import re
import urllib.request
from pathlib import Path

import pytest
from tests.browser.helpers import wait_linked

import parolkit.gui

pytestmark = [pytest.mark.browser]

GUI = Path(parolkit.gui.__file__).resolve().parent
STATIC_DIR = GUI / "static"  # parolkit.gui.app.STATIC_DIR, without importing NiceGUI here
STATIC_URL = "/parolkit-static"  # parolkit.gui.app.STATIC_URL
COMPONENTS = ("header", "view3d", "jog_panel", "io_panel", "program_panel", "telemetry", "help_dialog",
              "speed_override")


def test_the_page_is_split_into_component_modules_without_css_or_js_in_python():
    """Failed on the old code: gui/app.py was 1028 lines with a 630-line page class and its
    CSS and JavaScript as Python strings; there were no component modules."""
    for name in COMPONENTS:
        assert (GUI / "components" / f"{name}.py").is_file(), f"component module {name} is missing"
    app_lines = (GUI / "app.py").read_text().splitlines()
    assert len(app_lines) < 250, f"gui/app.py has {len(app_lines)} lines"
    for path in [GUI / "app.py", *sorted((GUI / "components").glob("*.py"))]:
        source = path.read_text()
        assert "<style" not in source and "addEventListener" not in source, f"CSS / JS inside {path.name}"
    assert (STATIC_DIR / "commander.css").is_file() and (STATIC_DIR / "commander.js").is_file()


def test_css_and_js_are_served_as_static_files_and_applied(page):
    """Failed on the old code: the page carried an inline <style> and <script>; no static file
    was linked or served."""
    wait_linked(page)
    hrefs = page.evaluate("""() => [...document.querySelectorAll('link[rel=stylesheet], script[src]')]
        .map(e => e.getAttribute('href') || e.getAttribute('src'))""")
    ours = [h for h in hrefs if h.startswith(STATIC_URL + "/")]
    assert {re.sub(r"\?.*", "", h).rsplit("/", 1)[1] for h in ours} == {"commander.css", "commander.js",
                                                                       "gamepad.js"}, hrefs
    inline = page.evaluate("() => [...document.querySelectorAll('style')].map(s => s.textContent).join('\\n')")
    assert ".pk-card" not in inline, "the commander's CSS is still inline"
    base = page.url.rstrip("/")
    for href in ours:
        name = re.sub(r"\?.*", "", href).rsplit("/", 1)[1]
        with urllib.request.urlopen(base + href, timeout=10) as resp:
            body = resp.read()
            ctype = resp.headers.get("content-type", "")
        assert body == (STATIC_DIR / name).read_bytes(), f"{href} is not the package's {name}"
        assert ("css" in ctype) if name.endswith(".css") else ("javascript" in ctype), ctype
    # the stylesheet is applied (a card's background is the file's --pk-card colour) and the
    # script runs (Space on a focused button is taken by it: the default is prevented)
    bg = page.evaluate("() => getComputedStyle(document.querySelector('.pk-card')).backgroundColor")
    assert bg == "rgb(17, 26, 46)", bg
    prevented = page.evaluate("""() => { const b = document.querySelector('[data-testid=help-button]');
        b.focus(); const e = new KeyboardEvent('keyup', {key: ' ', bubbles: true, cancelable: true});
        b.dispatchEvent(e); b.blur(); return e.defaultPrevented; }""")
    assert prevented, "commander.js did not take Space"
