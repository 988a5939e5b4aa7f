"""Issue 26 item 8, the parts below the page: what the board's counters are while it homes
(the emulator as the firmware: they count from the limit switches, so the commander shows no
angles then), the link's first status as the baseline of the implausible-frame count (against a
real UDP socket), the stale marker's words and how an output's buttons show its state."""

from __future__ import annotations

import asyncio
import json
import time

import pytest
from tests.unit.test_client import STATUS_OBJECT, FakeController
from tests.unit.test_gui_logic import STATUS

from parolkit.board import BoardEmulator
from parolkit.board.homing import HOMED_OFFSETS_STEPS, STANDBY_STEPS
from parolkit.client.core import RobotStatus
from parolkit.gui.components.io_panel import output_look
from parolkit.gui.components.telemetry import stale_text
from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.link import ControllerLink, joints_known
from parolkit.protocol import BoardCommand, CommandFrame, StatusParser
from parolkit.robot import PAROL6


def _status(**fields: object) -> RobotStatus:
    return RobotStatus.from_json(dict(STATUS, **fields))


def test_the_joints_are_known_except_while_the_board_homes():
    assert joints_known(_status(state="IDLE"))
    assert joints_known(_status(state="MOVING"))
    assert joints_known(_status(state="ESTOP"))
    assert not joints_known(_status(state="HOMING"))


def test_the_emulator_homes_as_the_firmware_its_counters_count_from_the_switches_while_the_arm_stays():
    """board-firmware.md, "Homing": each counter is zeroed at its switch and the joint moved to
    its offset from there (J2 19588, J4 -10200), then every counter is overwritten with the
    standby counts.  So at the standby pose the counters read J2 +55.1° and J4 -143.4° for a
    while: not where the arm is.  The emulator does the same (it must behave like the
    firmware); the fix is the commander's, which shows no angles while homing."""
    emu = BoardEmulator(clock="virtual", homing_speedup=20)
    parser = StatusParser()

    def send(command: BoardCommand):
        emu.write(CommandFrame(command=command).encode())
        (frame,) = parser.feed(emu.read())
        return frame

    send(BoardCommand.ENABLE)
    emu.advance(0.01)
    send(BoardCommand.HOME)
    pairs = []
    for _ in range(5000):
        emu.advance(0.01)
        frame = send(BoardCommand.IDLE)
        pairs.append((frame.positions, emu.physical_positions))
        if frame.homed == 0xFF:
            break
    assert pairs[-1][0] == STANDBY_STEPS
    # J2 and J4 sat at their offsets from the switch while the arm stood at standby
    for j in (1, 3):
        at_offset = [phys for counted, phys in pairs if counted[j] == HOMED_OFFSETS_STEPS[j]]
        assert at_offset, f"J{j + 1}'s counter never read its offset {HOMED_OFFSETS_STEPS[j]}"
        assert all(phys[j] == STANDBY_STEPS[j] for phys in at_offset)
        counted_deg = HOMED_OFFSETS_STEPS[j] / PAROL6.steps_per_deg[j]
        lo, hi = PAROL6.limits_deg[j]
        assert not lo <= counted_deg <= hi  # read as an angle: outside the joint's limits
    assert HOMED_OFFSETS_STEPS[1] / PAROL6.steps_per_deg[1] == pytest.approx(55.09, abs=0.01)
    assert HOMED_OFFSETS_STEPS[3] / PAROL6.steps_per_deg[3] == pytest.approx(-143.44, abs=0.01)


class _CountingController(FakeController):
    """A fake controller whose statuses carry the integrity counters ``implausible``."""

    implausible = 7

    def _answer(self, text: str, addr) -> None:
        parts = text.split("|")
        if parts[0] == "SUBSCRIBE" and parts[3:4] == [self.COOKIE]:
            port = int(parts[1])
            self.sub_port = port
            for seq in range(3):
                self.send_status(seq)
            return
        super()._answer(text, addr)

    def send_status(self, seq: int) -> None:
        obj = dict(STATUS_OBJECT, seq=seq, integrity={"implausible": self.implausible, "uncommanded": 0,
                                                       "status_age_ms": 1.0, "last": None})
        self.sock.sendto(("STATUS_JSON|" + json.dumps(obj)).encode(), ("127.0.0.1", self.sub_port))


def test_a_connection_takes_the_controllers_earlier_count_as_its_baseline():
    """A commander connecting to a controller that had counted 7 implausible frames logged
    "7 status frame(s) ignored as implausible (corrupted?)" at once, as if they had just come
    (and again at every connection); now the 7 are said once as the controller's history and
    only frames after the connection are warned about."""
    fake = _CountingController()

    async def main() -> list[tuple[Level, str]]:
        events = EventLog()
        link = ControllerLink("127.0.0.1", fake.port, fake.ack_port, every_n_ticks=2, event_log=events)
        await link.start()
        try:
            deadline = time.monotonic() + 5
            while link.status_count < 3:
                assert time.monotonic() < deadline, "no statuses"
                await asyncio.sleep(0.01)
            fake.implausible = 9
            fake.send_status(10)
            while link.status is None or link.status.seq != 10:
                assert time.monotonic() < deadline, "the status after the connection did not come"
                await asyncio.sleep(0.01)
        finally:
            await link.close()
        return [(e.level, e.text) for e in events.tail(50)]

    try:
        lines = asyncio.run(main())
    finally:
        fake.close()
    warnings = [t for lvl, t in lines if "implausible" in t and lvl is Level.WARNING]
    assert warnings == ["board link: 2 status frame(s) ignored as implausible (corrupted?), 9 in all"], lines
    assert (Level.INFO, "board link: the controller has ignored 7 implausible status frame(s) since it "
                        "started (before this commander connected)") in lines


def test_the_stale_marker_says_how_old_the_values_are():
    assert stale_text(None) == "stale · no status received yet"
    assert stale_text(1.4) == "stale · last status 1 s ago"
    assert stale_text(59.2) == "stale · last status 59 s ago"
    assert stale_text(125.0) == "stale · last status 2 min 05 s ago"


def test_an_outputs_buttons_show_the_state_it_is_in():
    assert output_look("HIGH", True) == ("unelevated color=positive", "true")
    assert output_look("LOW", True) == ("outline color=grey-4", "false")
    assert output_look("HIGH", False) == ("outline color=grey-4", "false")
    assert output_look("LOW", False) == ("unelevated color=grey-7", "true")
    assert output_look("HIGH", None)[1] == output_look("LOW", None)[1] == "false"  # not known yet
    with pytest.raises(ValueError, match="HIGH or LOW"):
        output_look("high", True)
