"""A tab of the page's tab bar (NiceGUI) whose text is its name alone.

Quasar draws a tab's icon as a Material Icons ligature: an ``<i>`` whose text is the icon's
name, so the tab's text read "open_with Jog" (copied, read by ``innerText``, shown as words
while the icon font loads).  Here the icon is a glyph the stylesheet draws from the element's
``data-icon`` (``.pk-tab-icon::before`` in ``commander.css``): no text node, hidden from
assistive technology.
"""

from __future__ import annotations

from nicegui import ui

__all__ = ["icon_tab"]


def icon_tab(label: str, icon: str, testid: str) -> ui.tab:
    """A ``ui.tab`` named ``label`` with the Material icon ``icon`` and ``data-testid``."""
    with ui.tab(label).props(f"data-testid={testid}") as tab:
        ui.element("i").classes("q-icon material-icons pk-tab-icon").props(f"aria-hidden=true data-icon={icon}")
    return tab
