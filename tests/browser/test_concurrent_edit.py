"""Nothing typed is lost (issue 26 item 2): two tabs typing in the one program at the same time.

Two pages (two browser contexts: two students' browsers) type 16 characters each at 8 keys/s
(``keyboard.type`` with a 125 ms delay), started at the same moment, into the one program the
GUI server keeps.  Every character each page accepted must be in the final text, in the order
it was typed, in both tabs and in the server's copy (its autosave file, written at every
change).  Before the change one tab's 16 characters were lost: each edit replaced the server's
whole text with that tab's, and the other tab's editor was overwritten with it.

Real Chromium (async Playwright: two pages typing at once), a real ``parolkit gui --sim``.
"""

from __future__ import annotations

import asyncio
import time
from collections import Counter
from pathlib import Path

import pytest
from tests.browser.conftest import CHROMIUM, CHROMIUM_ARGS, _stop, start_gui

#: what each tab types: 16 characters no other tab types, 8 keys/s
TYPED_A = "abcdfghijkmnuvxz"  # (letters: jog keys are ignored in the editor, they type)
TYPED_B = "0123456789ABCDEF"
KEY_DELAY_MS = 125
START = "Begin()\n# tab a:\n# tab b:\nEnd()\n"
#: generous: the machine is shared (the typing itself takes 2 s)
DEADLINE_S = 30.0


@pytest.fixture(scope="module")
def gui(tmp_path_factory):
    pytest.importorskip("parolkit.controller.cli", reason="the controller (parolkit serve) is not in this build")
    programs = tmp_path_factory.mktemp("programs")
    proc, url, _ = start_gui(["--sim", "--programs-dir", str(programs)])
    yield {"url": url, "programs": programs}
    _stop(proc)


_EDITOR_TEXT = "() => window.pkEditorText ? window.pkEditorText() : null"


async def _open(browser, url: str):
    context = await browser.new_context(viewport={"width": 1400, "height": 1000})
    page = await context.new_page()
    page.errors = []
    page.on("pageerror", lambda e: page.errors.append(str(e)))
    page.on("console", lambda m: page.errors.append(m.text) if m.type == "error" else None)
    await page.goto(url)
    await page.get_by_test_id("tab-program").click()
    await page.locator("[data-testid=editor] .cm-content[contenteditable=true]").wait_for(timeout=DEADLINE_S * 1000)
    return page


async def _wait(what: str, predicate, timeout: float = DEADLINE_S):
    deadline = time.monotonic() + timeout
    last = None
    while time.monotonic() < deadline:
        last = await predicate()
        if last:
            return last
        await asyncio.sleep(0.1)
    raise AssertionError(f"timed out after {timeout} s waiting for {what} (last {last!r})")


async def _texts(pages) -> list[str | None]:
    return [await p.evaluate(_EDITOR_TEXT) for p in pages]


async def _replace_all(page, text: str) -> None:
    await page.locator("[data-testid=editor] .cm-content").click()
    await page.keyboard.press("Control+A")
    await page.keyboard.press("Delete")
    await page.keyboard.insert_text(text)


async def _cursor_at_end_of_line(page, line: int) -> None:
    await page.locator("[data-testid=editor] .cm-line").nth(line - 1).click()
    await page.keyboard.press("End")


def _autosave(programs: Path) -> str | None:
    kept = programs / ".autosave" / "program.rbt"
    return kept.read_text() if kept.is_file() else None


async def _converged(pages, programs: Path) -> str:
    """Both tabs and the server's copy hold the same text; returns it."""
    async def same():
        texts = await _texts(pages)
        server = _autosave(programs)
        return texts[0] if texts[0] is not None and texts[0] == texts[1] == server else None
    return await _wait("both tabs and the server to hold the same text", same)


def _subsequence(typed: str, text: str) -> bool:
    it = iter(text)
    return all(c in it for c in typed)


#: a slow network, each way, for the page that has one (its pushes always cross the other's)
SLOW_MS = 300
#: delays the page's program-document messages both ways, in order (wraps commander.js's pkDoc)
_SLOW_NETWORK = """(ms) => {
    const send = window.emitEvent;
    window.emitEvent = (name, ...args) => {
        if (name === "pk_doc") setTimeout(() => send(name, ...args), ms); else send(name, ...args);
    };
    const receive = window.pkDoc.receive;
    window.pkDoc.receive = (msg) => { setTimeout(() => receive(msg), ms); };
}"""


async def _two_tabs_typing(url: str, programs: Path, same_line: bool, slow_b: bool = False) -> dict:
    """Two tabs type at once; returns the final text, each tab's text right after its typing
    (what it accepted), each tab's pkDoc state and the pages' errors."""
    from playwright.async_api import async_playwright

    async with async_playwright() as p:
        browser = await p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            a, b = await _open(browser, url), await _open(browser, url)
            await _replace_all(a, START)
            await _wait("the start text in both tabs", lambda: _all_equal(a, b, START))
            if slow_b:
                await b.evaluate(_SLOW_NETWORK, SLOW_MS)
            await _cursor_at_end_of_line(a, 2)
            await _cursor_at_end_of_line(b, 2 if same_line else 3)

            async def typing(page, chars):
                await page.keyboard.type(chars, delay=KEY_DELAY_MS)
                return await page.evaluate(_EDITOR_TEXT)

            # both start at the same moment and type at 8 keys/s
            accepted = await asyncio.gather(typing(a, TYPED_A), typing(b, TYPED_B))
            final = await _converged([a, b], programs)
            for pg in (a, b):  # every change confirmed by the server (the slow tab hears it late)
                await asyncio.wait_for(pg.evaluate("() => window.pkDoc.flush()"), DEADLINE_S)
            states = [await pg.evaluate("() => window.pkDoc.state()") for pg in (a, b)]
            return {"final": final, "accepted": accepted, "states": states, "errors": a.errors + b.errors}
        finally:
            await browser.close()


async def _all_equal(a, b, want: str) -> bool:
    return await _texts([a, b]) == [want, want]


def _accepted_everything(run: dict) -> None:
    """Each tab showed all it typed, in order, right after typing (its editor accepted every key)."""
    for typed, shown in zip((TYPED_A, TYPED_B), run["accepted"], strict=True):
        assert shown is not None and _subsequence(typed, shown), (typed, shown)
    assert all(s["pending"] == 0 and not s["pushing"] for s in run["states"]), run["states"]
    assert not run["errors"], run["errors"]


def test_two_tabs_typing_in_different_lines_lose_nothing(gui):
    run = asyncio.run(_two_tabs_typing(gui["url"], gui["programs"], same_line=False))
    _accepted_everything(run)
    assert run["final"] == f"Begin()\n# tab a:{TYPED_A}\n# tab b:{TYPED_B}\nEnd()\n", run["final"]


def test_two_tabs_typing_at_the_same_place_over_a_slow_network_lose_nothing(gui):
    """Both cursors at the end of the same line, one tab's messages 300 ms late each way: its
    pushes cross the other tab's (refused, merged and pushed again).  The characters
    interleave; none is lost and each tab's are in the order it typed them."""
    run = asyncio.run(_two_tabs_typing(gui["url"], gui["programs"], same_line=True, slow_b=True))
    _accepted_everything(run)
    final = run["final"]
    lines = final.split("\n")
    assert lines[0] == "Begin()" and lines[2:] == ["# tab b:", "End()", ""], final
    typed = lines[1].removeprefix("# tab a:")
    assert Counter(typed) == Counter(TYPED_A + TYPED_B), final
    assert _subsequence(TYPED_A, typed) and _subsequence(TYPED_B, typed), final
    # the merge did happen: the slow tab's pushes were refused and others' changes merged into its own
    slow = run["states"][1]
    assert slow["refused"] > 0 and slow["merged"] > 0, run["states"]
