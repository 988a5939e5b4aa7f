"""Cheap live data (issue 15 item 9): an idle page receives <= 10 KB/s and the live charts
get only new samples, yet still draw the last 20 s and follow a jog.

Fails on the code before this change: every 0.5 s both charts were re-sent in full (about
100-160 KB/s per idle page) and the 3D view re-sent the arm 30 times a second standing still.
"""

from __future__ import annotations

import pytest
from tests.browser.helpers import number, settled, wait_linked, wait_ready, wait_until

pytestmark = [pytest.mark.browser]

CHART_POINTS = """(testid) => {
  const host = document.querySelector(`[data-testid=${testid}]`);
  const el = host && getElement(host.id.replace(/^c/, ''));
  if (!el || !el.chart) return null;
  const s = el.chart.getOption().series[0].data;
  return s.length ? [s.length, s[0][0], s[s.length - 1][0], s[s.length - 1][1]] : [0];
}"""


def test_an_idle_page_costs_under_10_kb_per_s_and_the_charts_still_draw(browser, gui_url):
    page = browser.new_page(viewport={"width": 1500, "height": 1000})
    frames: list[int] = []
    cdp = page.context.new_cdp_session(page)
    cdp.send("Network.enable")
    cdp.on("Network.webSocketFrameReceived", lambda ev: frames.append(len(ev["response"]["payloadData"].encode())))
    page.goto(gui_url)
    wait_linked(page)
    wait_ready(page, 60)
    page.wait_for_timeout(2000)
    start, n0 = sum(frames), len(frames)
    t0 = page.evaluate("() => performance.now()")
    page.wait_for_timeout(5000)
    dt = (page.evaluate("() => performance.now()") - t0) / 1000
    rate = (sum(frames) - start) / dt
    assert rate <= 10_000, f"an idle page receives {rate / 1000:.1f} KB/s"
    biggest = max(frames[n0:], default=0)
    assert biggest < 4000, f"a {biggest}-byte frame while idle: a chart re-sent in full?"
    # the charts hold the window pushed piece by piece: many points, the newest at t = 0
    pts = wait_until(lambda: (page.evaluate(CHART_POINTS, "pos-chart") or [0])[0] > 20 and
                     page.evaluate(CHART_POINTS, "pos-chart"), 10, what="points in the position chart", page=page)
    assert pts[2] == 0 and pts[1] < -1.0, pts
    # a jog shows in the chart (the newest J1 value follows the readout)
    page.get_by_test_id("jog-j1+").hover()
    page.mouse.down()
    page.wait_for_timeout(800)
    page.mouse.up()
    j1 = settled(page, "angle-1")
    wait_until(lambda: abs(page.evaluate(CHART_POINTS, "pos-chart")[3] - j1) < 0.05, 10,
               what="the chart's newest J1 at the readout", page=page)
    assert abs(number(page, "angle-1") - j1) < 0.05
    page.close()
