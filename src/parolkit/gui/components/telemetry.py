"""Telemetry (NiceGUI): the readout card (joint angles and speeds, homed bits, TCP pose, IO
and E-stop, error bits, board timing, loop statistics, queue, the event log) and the live
charts of joint positions and speeds.

Units: deg, deg/s, mm, ms.  Every readout value has a fixed width in characters
(``commander.css``): a longer text, such as the E-stop line when E-STOP latches, never moves
or overlaps its neighbours.

With no link to the controller the values are the last ones received: the card says so
("stale", with the age of the last status, ``data-testid=stale``) and the page's main element
gets ``pk-stale`` (the stylesheet dims every value then).  While the board homes the joint
angles and the TCP pose are not shown: the board's counters count from its limit switches until
homing ends (:func:`parolkit.gui.link.joints_known`); the charts leave that stretch out.
"""

from __future__ import annotations

import json
import time
from typing import Any

from nicegui import ui

from parolkit.client.core import RobotStatus
from parolkit.gui.eventlog import EventLog
from parolkit.gui.link import ControllerLink, joints_known
from parolkit.gui.status import POSE_READOUTS, format_angles, format_loop, format_pose, format_speeds
from parolkit.robot import JOINT_NAMES

__all__ = ["Readouts", "LiveCharts", "live_options", "plan_options", "stale_text", "PLOT_WINDOW_S",
           "JOINT_COLOURS", "HOMING_TEXT"]

#: the live charts show the last this many seconds
PLOT_WINDOW_S = 20.0
JOINT_COLOURS = ("#60a5fa", "#f472b6", "#34d399", "#fbbf24", "#a78bfa", "#f87171")


#: what a joint angle reads while the board homes (its counter counts from the limit switch)
HOMING_TEXT = "homing…"


def stale_text(age_s: float | None) -> str:
    """The stale marker: how old the values shown are (``age_s``: since the last status; None:
    no status received yet)."""
    if age_s is None:
        return "stale · no status received yet"
    if age_s < 60:
        return f"stale · last status {age_s:.0f} s ago"
    minutes = int(age_s // 60)
    return f"stale · last status {minutes} min {int(age_s % 60):02d} s ago"


def _fmt_ms(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.2f} ms"


def _html_escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _led(cls: str = "") -> str:
    return f"<span class='pk-led{cls}' aria-hidden='true'></span>"


class Readouts:
    """The readout card and the log; :meth:`update` every 0.1 s."""

    def __init__(self, log: EventLog, link: ControllerLink | None = None) -> None:
        self.log = log
        self.link = link
        self._log_version = -1
        self._offline_shown = False
        self._stale_shown: str | None = None
        self._homing_shown = False
        with ui.card().classes("pk-card w-full p-3 gap-2").props('role=region aria-label="Readouts"'):
            # with no link: the values are the last received, this long ago
            self.stale_label = ui.label("").classes("pk-stale-badge") \
                .props('data-testid=stale role=status aria-live=polite')
            self.stale_label.set_visibility(False)
            with ui.element("div").classes("pk-readouts"):
                with ui.column().classes("gap-1"):
                    ui.label("Joints").classes("pk-title")
                    self.joint_labels: list[ui.label] = []
                    self.speed_labels: list[ui.label] = []
                    self.homed_leds: list[ui.html] = []
                    with ui.element("div").classes("pk-grid pk-grid-joints"):
                        for name in ("", "angle", "speed", "homed"):
                            num = " pk-num" if name in ("angle", "speed") else ""
                            ui.label(name).classes("text-xs pk-muted" + num)
                        for j in range(6):
                            ui.label(JOINT_NAMES[j]).classes("text-slate-300 text-sm")
                            self.joint_labels.append(
                                ui.label("—").classes("pk-val pk-num text-sm").props(f"data-testid=angle-{j + 1}"))
                            self.speed_labels.append(
                                ui.label("—").classes("pk-val pk-num text-xs text-slate-300")
                                .props(f"data-testid=speed-{j + 1}"))
                            self.homed_leds.append(ui.html(_led()).props(f"data-testid=homed-{j + 1}"))
                with ui.column().classes("gap-1"):
                    ui.label("TCP pose").classes("pk-title")
                    self.pose_labels: list[ui.label] = []
                    with ui.element("div").classes("pk-grid pk-grid-pose"):
                        for name, index, letter in POSE_READOUTS:
                            if index < 3:
                                ui.label(name).classes("text-slate-300 text-sm")
                            else:  # an angle also shows the pose's own name of it (MoveCart's A B C)
                                ui.label(f"{name} ({letter})").classes("text-slate-300 text-sm") \
                                    .tooltip(f"{letter}: the turn about {name[1]} in R = Rx(C)·Ry(B)·Rz(A)")
                            self.pose_labels.append(
                                ui.label("—").classes("pk-val pk-num text-sm")
                                .props(f"data-testid=pose-{name.lower()}"))
                with ui.column().classes("gap-1"):
                    ui.label("IO · safety").classes("pk-title")
                    self.io_leds: dict[str, ui.html] = {}
                    with ui.element("div").classes("pk-grid pk-grid-io"):
                        for key, label in (("in1", "IN1"), ("in2", "IN2"), ("out1", "OUT1"), ("out2", "OUT2"),
                                           ("estop", "E-stop")):
                            ui.label(label).classes("text-slate-300 text-sm")
                            self.io_leds[key] = ui.html(f"{_led()} <span class='pk-mono'>—</span>") \
                                .props(f"data-testid=io-{key}")
            self.error_label = ui.label("no errors").classes("text-xs pk-muted pk-errors") \
                .props("data-testid=error-bits")
            with ui.element("div").classes("pk-stats pk-muted pk-mono"):
                self.timing_label = ui.label("board —").classes("pk-timing").props("data-testid=board-timing")
                self.loop_label = ui.label("loop —").props("data-testid=loop-stats")
                self.queue_label = ui.label("queue —").props("data-testid=queue")
            ui.label("Log").classes("pk-title")
            # a scrolling region: focusable so a keyboard can scroll it
            self.log_box = ui.html("").classes("pk-log w-full") \
                .props('data-testid=log role=log aria-label="Event log" tabindex=0')

    def update(self, st: RobotStatus | None, link_up: bool = True) -> None:
        """Show ``st`` (readouts only change on the page when their text changed); with no
        link every LED goes dark, the IO reads "—" and the values left are marked stale."""
        self._show_stale(st is not None and link_up)
        if st is not None and link_up:
            self._offline_shown = False
            self._update_status(st)
        elif not self._offline_shown:
            self._offline_shown = True
            for led in self.homed_leds:
                led.set_content(_led())
            for led in self.io_leds.values():
                led.set_content(f"{_led()} <span class='pk-mono'>—</span>")
        if self.log.version != self._log_version:
            self._log_version = self.log.version
            rows = "".join(f"<div class='{e.level.value}'>{_html_escape(e.format())}</div>"
                           for e in reversed(self.log.tail(80)))
            self.log_box.set_content(rows)

    def _age_s(self) -> float | None:
        """Seconds since the last status (None: none yet, or no link given)."""
        link = self.link
        if link is None or link.status is None:
            return None
        return max(0.0, time.monotonic() - link.status_monotonic)

    def _show_stale(self, live: bool) -> None:
        """The stale marker while not ``live``: the badge with the age of the last status, and
        ``pk-stale`` on the page's main element (the stylesheet dims the values)."""
        text = "" if live else stale_text(self._age_s())
        if text == self._stale_shown:
            return
        was_stale = bool(self._stale_shown)
        self._stale_shown = text
        self.stale_label.set_text(text)
        if bool(text) != was_stale:
            self.stale_label.set_visibility(bool(text))
            main = ui.query(".pk-main")
            if text:
                main.classes(add="pk-stale")
            else:
                main.classes(remove="pk-stale")

    def _update_status(self, st: RobotStatus) -> None:
        known = joints_known(st)
        if known:
            for lbl, v in zip(self.joint_labels, format_angles(st.angles)):
                lbl.set_text(v)
            for lbl, v in zip(self.pose_labels, format_pose(st.pose)):
                lbl.set_text(v)
        elif not self._homing_shown:  # the counters count from the limit switches: no angle
            for lbl in self.joint_labels:
                lbl.set_text(HOMING_TEXT)
            for lbl in self.pose_labels:
                lbl.set_text("—")
        self._homing_shown = not known
        for lbl, v in zip(self.speed_labels, format_speeds(st.speeds_deg_s)):
            lbl.set_text(v)
        for led, h in zip(self.homed_leds, st.homed):
            led.set_content(_led(" on" if h else ""))
        io = st.io
        for key in ("in1", "in2", "out1", "out2"):
            v = getattr(io, key)
            self.io_leds[key].set_content(
                f"{_led(' on' if v else '')} <span class='pk-mono'>{'HIGH' if v else 'LOW'}</span>")
        pressed = io.estop_pressed
        self.io_leds["estop"].set_content(
            f"{_led(' bad' if pressed or st.estop_latched else ' on')} <span class='pk-mono'>"
            f"{'PRESSED' if pressed else 'released'}{' · latched' if st.estop_latched else ''}</span>")
        err = st.errors
        bits = [f"J{j + 1} temp" for j, b in enumerate(err.temperature) if b]
        bits += [f"J{j + 1} pos" for j, b in enumerate(err.position) if b]
        if err.message:
            bits.append(err.message)
        self.error_label.set_text("errors: " + ", ".join(bits) if bits else "no temperature / position errors")
        self.error_label.classes(replace="text-xs pk-errors " + ("text-red-300" if bits else "pk-muted"))
        self.timing_label.set_text(f"board {_fmt_ms(st.board.timing_ms)}")
        self.loop_label.set_text(f"loop {format_loop(st.loop)}")
        cmd = st.command
        progress = "" if cmd is None or cmd.progress is None else f" {cmd.progress * 100:.0f}%"
        cmd_text = "idle" if cmd is None else cmd.name + progress
        self.queue_label.set_text(f"queue {st.queue} · {cmd_text}")


#: spacing of the live chart samples pushed to the page, s (300 points per 20 s window)
SAMPLE_SPACING_S = 1.0 / 15


class LiveCharts:
    """Joint positions and speeds of the last :data:`PLOT_WINDOW_S` s; :meth:`update` every 0.5 s."""

    def __init__(self, link: ControllerLink) -> None:
        self.link = link
        #: time (monotonic s) of the newest sample pushed to the page
        self._sent_t = -1e18
        with ui.card().classes("pk-card w-full p-3 gap-1").props('role=region aria-label="Live charts"'):
            ui.label(f"Live joint positions and speeds (last {PLOT_WINDOW_S:.0f} s)").classes("pk-title")
            with ui.element("div").classes("pk-two"):
                self.pos_chart = ui.echart(live_options("deg")).style("height: 230px") \
                    .props('data-testid=pos-chart role=img aria-label="joint positions, last 20 s"')
                self.speed_chart = ui.echart(live_options("deg/s")).style("height: 230px") \
                    .props('data-testid=speed-chart role=img aria-label="joint speeds, last 20 s"')

    def update(self) -> None:
        """Push only the samples newer than the last push (the page keeps the window:
        ``pkLive`` in commander.js); a new page gets the whole window on its first push."""
        hist = self.link.history
        if not hist:
            return
        rows: list[list[float | None]] = []
        last = self._sent_t
        for s in hist:
            if s.t > last + SAMPLE_SPACING_S - 1e-9:
                if s.homing:  # the counters count from the limit switches: a gap in the lines
                    rows.append([round(s.t, 3), *([None] * 12)])
                else:
                    rows.append([round(s.t, 3), *(round(v, 2) for v in s.angles),
                                 *(round(v, 2) for v in s.speeds)])
                last = s.t
        if not rows:
            return
        self._sent_t = last
        ui.run_javascript(f"window.pkLive && window.pkLive({self.pos_chart.id}, {self.speed_chart.id}, "
                          f"{json.dumps(rows, separators=(',', ':'))}, {PLOT_WINDOW_S})")


def live_options(unit: str) -> dict[str, Any]:
    """ECharts options of a live chart: six joint series against time (s, last window)."""
    return {
        "animation": False,
        "backgroundColor": "transparent",
        "grid": {"left": 52, "right": 14, "top": 30, "bottom": 34},
        "legend": {"textStyle": {"color": "#cbd5e1"}, "top": 0, "left": 44, "itemWidth": 14, "itemGap": 8},
        "tooltip": {"trigger": "axis"},
        "xAxis": {"type": "value", "min": -PLOT_WINDOW_S, "max": 0, "name": "s",
                  "axisLabel": {"color": "#a3b1c9"}, "splitLine": {"show": False}},
        "yAxis": {"type": "value", "name": unit, "nameLocation": "middle", "nameGap": 36, "scale": True,
                  "nameTextStyle": {"color": "#a3b1c9"}, "axisLabel": {"color": "#a3b1c9"},
                  "splitLine": {"lineStyle": {"color": "#1e293b"}}},
        "series": [{"name": JOINT_NAMES[j], "type": "line", "showSymbol": False, "data": [],
                    "lineStyle": {"width": 1.6}, "color": JOINT_COLOURS[j]} for j in range(6)],
    }


def plan_options(unit: str, title: str) -> dict[str, Any]:
    """ECharts options of a planned-trajectory chart (time from the program's start, s)."""
    opts = live_options(unit)
    opts["xAxis"] = {"type": "value", "name": "s", "axisLabel": {"color": "#a3b1c9"}, "splitLine": {"show": False}}
    opts["title"] = {"text": title + " (Check)", "textStyle": {"color": "#a3b1c9", "fontSize": 11},
                     "left": "center", "bottom": 0}
    return opts
