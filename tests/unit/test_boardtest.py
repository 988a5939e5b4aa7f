"""board-test tool: the telemetry view, argument checks and the menu parser (no board needed
except where a real in-process emulator answers)."""

from __future__ import annotations

import io

import pytest

from parolkit.boardtest import BoardTester, format_status, interactive
from parolkit.errors import ParolkitValueError
from parolkit.protocol.frames import StatusFrame


def test_format_status_shows_every_telemetry_field_with_units():
    frame = StatusFrame(positions=(10240, -32000, 57905, 0, 0, 32000), speeds=(0, 355, 0, 0, 0, -178),
                        homed=0xFF, io=0xA8, temperature_error=0x43, position_error=0x03,
                        timing=7031, timeout_error=100, xtr=156, gripper_id=3, gripper_position=120,
                        gripper_speed=1, gripper_current=450, gripper_status=0xB1, object_detection=1)
    text = format_status(frame, missed=2, sent=100)
    lines = text.splitlines()
    j1 = next(ln for ln in lines if ln.startswith("J1"))
    assert "10240" in j1 and "90.000" in j1 and "yes" in j1
    j2 = next(ln for ln in lines if ln.startswith("J2"))
    assert "-90.000" in j2 and "355" in j2 and "0.998" in j2  # 355 steps/s = 0.998 deg/s on J2
    assert "ERR" in next(ln for ln in lines if ln.startswith("J2"))  # temperature bit of J2 (0x40)
    assert "IN1=1 IN2=0 OUT1=1 OUT2=0 ESTOP=released" in text
    assert "timing: 7031 ticks = 10.000 ms" in text and "xtr=156" in text
    assert "position=120" in text and "current=450 mA" in text and "status=0xB1" in text
    assert "calibrated=True" in text and "object=at position" in text
    assert "100 frames sent, 2 without a reply" in text
    assert "ESTOP=PRESSED" in format_status(StatusFrame(io=0x07))


class _DeadLink:
    """A transport whose board never answers."""

    description = "nowhere"
    is_open = True

    def __init__(self):
        self.written = 0

    def write(self, data: bytes) -> None:
        self.written += 1

    def read(self) -> bytes:
        return b""

    def close(self) -> None:
        pass


def test_an_unanswering_board_is_reported_not_waited_for_forever():
    from parolkit.boardtest import FIRST_REPLY_S, BoardTestError

    t = BoardTester(_DeadLink(), rate_hz=200, out=io.StringIO())
    with pytest.raises(BoardTestError, match=r"did not answer \d+ frames"):
        t.read_inputs()
    # it waited FIRST_REPLY_S for a first reply (at 200 Hz), and no longer
    assert t.missed == t.sent and round(FIRST_REPLY_S * 200) <= t.sent <= round(FIRST_REPLY_S * 200) + 20


class _LateLink(_DeadLink):
    """A board whose first replies a loaded PC's tty layer held back: nothing comes until the
    ``late``-th frame was written, then one status a frame."""

    def __init__(self, late: int):
        super().__init__()
        self.late = late

    def read(self) -> bytes:
        if self.written < self.late:
            return b""
        return StatusFrame(io=0x2C, homed=0xFF).encode()


def test_a_board_whose_first_replies_come_late_is_waited_for():
    """Failed before: the tool gave up after 0.1 s (20 frames at 200 Hz) without a reply, so a
    board-sim that a loaded machine had not scheduled yet was reported as not there."""
    t = BoardTester(_LateLink(60), rate_hz=200, out=io.StringIO())
    t.read_inputs()
    assert t.status is not None and t.sent == 60 and t.missed == 59


@pytest.mark.parametrize("call,needle", [
    (lambda t: t.jog(7, 100, 1), "joint must be in 1..6"),
    (lambda t: t.jog(1, 7000, 1), "speed (steps/s) must be in -6500..6500"),
    (lambda t: t.jog(1, 100, 0), "seconds must be in 0.01..60"),
    (lambda t: t.set_output(3, True), "output must be in 1..2"),
    (lambda t: t.gripper_move(256, 10, 500), "position must be in 0..255"),
    (lambda t: t.gripper_move(10, 10, 1301), "current (mA) must be in 0..1300"),
])
def test_bad_action_arguments_name_the_field_and_range_and_send_nothing(call, needle):
    link = _DeadLink()
    t = BoardTester(link, out=io.StringIO())
    with pytest.raises(ParolkitValueError) as info:
        call(t)
    assert needle in str(info.value)
    assert link.written == 0


def test_the_rate_is_checked():
    with pytest.raises(ParolkitValueError, match="rate must be in 1..1000 Hz"):
        BoardTester(_DeadLink(), rate_hz=0)


def test_the_menu_reports_bad_lines_and_keeps_going():
    out = io.StringIO()
    t = BoardTester(_DeadLink(), out=out)
    lines = iter(["", "frobnicate", "jog --joint 9 --speed 1", "help", "quit"])
    assert interactive(t, lambda prompt: next(lines)) == 0
    text = out.getvalue()
    assert "invalid choice: 'frobnicate'" in text
    assert "error: joint must be in 1..6, got 9" in text
    assert text.count("board test: type an action") == 2
