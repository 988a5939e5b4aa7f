"""Helpers of the classroom-screen and defect tests (issue 26 items 6 and 8): the controller's
own word on its joints, outputs and state (``GET_STATUS_JSON``, a client of its own), colour
contrast as WCAG computes it, and boxes of the page's elements."""

from __future__ import annotations

import json
import re

from tests.browser.helpers import wait_until

#: the jog buttons' test ids, joints then Cartesian axes
JOG_BUTTONS = [f"jog-j{j}{s}" for j in range(1, 7) for s in "-+"] + \
    [f"jog-{a}{s}" for a in ("x", "y", "z", "rx", "ry", "rz") for s in "-+"]


def controller_status(controller) -> dict:
    """The controller's status object (``GET_STATUS_JSON``), asked until it answers."""
    def ask():
        reply = controller.query("GET_STATUS_JSON", 0.5) or ""
        return json.loads(reply.split("|", 1)[1]) if reply.startswith("STATUS_JSON|") else None
    return wait_until(ask, 15, what="the controller's GET_STATUS_JSON")


def controller_at_rest(controller, timeout: float = 60.0) -> dict:
    """The controller's status once it is idle with nothing running or queued."""
    def rest():
        st = controller_status(controller)
        busy = st["state"] != "IDLE" or st.get("command") or st.get("queue") or any(st["speeds"])
        return None if busy else st
    return wait_until(rest, timeout, interval=0.1, what="the controller at rest")


def luminance(rgb) -> float:
    def lin(c: float) -> float:
        c /= 255.0
        return c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4
    r, g, b = (lin(float(v)) for v in rgb[:3])
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def contrast(a, b) -> float:
    """WCAG contrast ratio of two sRGB colours (0..255 components)."""
    la, lb = luminance(a), luminance(b)
    return (max(la, lb) + 0.05) / (min(la, lb) + 0.05)


def parse_rgb(css: str) -> tuple[float, float, float, float]:
    """``rgb(r, g, b)`` / ``rgba(r, g, b, a)`` -> (r, g, b, a)."""
    nums = [float(v) for v in re.findall(r"[\d.]+", css)]
    assert len(nums) in (3, 4), css
    return (nums[0], nums[1], nums[2], nums[3] if len(nums) == 4 else 1.0)


#: the colour a text is drawn on: the element's and its ancestors' background colours composited
#: (the nearest opaque one at the bottom), in the page
EFFECTIVE_BACKGROUND = """(el) => {
    const layers = [];
    for (let e = el; e; e = e.parentElement) {
        const c = getComputedStyle(e).backgroundColor;
        const m = c.match(/[\\d.]+/g);
        if (!m) continue;
        const a = m.length === 4 ? Number(m[3]) : 1;
        if (a > 0) layers.push([Number(m[0]), Number(m[1]), Number(m[2]), a]);
        if (a >= 1) break;
    }
    let rgb = [255, 255, 255];
    for (const [r, g, b, a] of layers.reverse()) {
        rgb = [r * a + rgb[0] * (1 - a), g * a + rgb[1] * (1 - a), b * a + rgb[2] * (1 - a)];
    }
    return rgb;
}"""


def text_contrast(locator) -> float:
    """Contrast of ``locator``'s text colour against what it is drawn on."""
    fg = parse_rgb(locator.evaluate("(e) => getComputedStyle(e).color"))
    bg = locator.evaluate(EFFECTIVE_BACKGROUND)
    assert fg[3] >= 0.99, f"translucent text colour {fg}"
    return contrast(fg, bg)


def in_viewport(page, b: dict) -> bool:
    vw, vh = page.evaluate("() => [window.innerWidth, window.innerHeight]")
    return b["x"] >= -0.5 and b["y"] >= -0.5 and b["x"] + b["width"] <= vw + 0.5 and b["y"] + b["height"] <= vh + 0.5
