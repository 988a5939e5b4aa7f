"""The stop supervisor's frame, its settings, how it judges a silent controller and how the
controller judges it (real supervisor processes; the whole controller is proven in
tests/integration/test_bounded_commitment.py and test_supervisor_loss.py)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import pytest
from tests.conftest import process_exited, wait_until

from parolkit.config import ControllerSettings
from parolkit.controller.supervisor import (
    STOP_COPIES,
    StopSupervisor,
    SupervisorEvent,
    SupervisorEventKind,
    controller_stopped,
    stop_frame,
)
from parolkit.errors import ParolkitValueError
from parolkit.protocol.frames import BoardCommand, CommandFrame, GripperMode


def test_the_stop_frame_disables_with_zero_speeds_and_keeps_outputs_and_gripper_setpoints():
    last = CommandFrame(positions=(1, 2, 3, 4, 5, 6), speeds=(900, -800, 0, 0, 0, 5000), command=BoardCommand.JOG,
                        io=0x20, gripper_position=120, gripper_speed=50, gripper_current=400,
                        gripper_command=0xD0, gripper_mode=GripperMode.CALIBRATE)
    f = CommandFrame.decode(stop_frame(last.encode()))
    assert f.command == BoardCommand.DISABLE and f.speeds == (0,) * 6
    assert f.outputs == (True, False)
    assert (f.gripper_position, f.gripper_speed, f.gripper_current, f.gripper_command) == (120, 50, 400, 0xD0)
    # a one-shot gripper mode is never repeated by the stop frame
    assert f.gripper_mode == GripperMode.OPERATE


def test_the_stop_frame_of_garbage_is_none():
    assert stop_frame(b"\x00" * 56) is None


@pytest.mark.parametrize("bad", [-0.1, 0.05, 61, "0.5", True, float("nan")])
def test_supervisor_stall_must_be_0_or_seconds_in_0_1_to_60(bad):
    with pytest.raises(ParolkitValueError, match=r"controller.supervisor_stall_s must be 0 \(never\) or a number "
                                                 r"of seconds in 0.1..60"):
        ControllerSettings(supervisor_stall_s=bad)


def test_supervisor_stall_is_at_least_ten_loop_periods():
    ControllerSettings(rate_hz=10, supervisor_stall_s=1.0)
    ControllerSettings(rate_hz=10, supervisor_stall_s=0)
    with pytest.raises(ParolkitValueError, match=r"supervisor_stall_s must be 0 \(never\) or a number of seconds in "
                                                 r"1..60 \(at least 0.1 s and 10 loop periods at 10 Hz\), got 0.5"):
        ControllerSettings(rate_hz=10, supervisor_stall_s=0.5)


def test_the_supervisor_runs_one_priority_above_the_tick_thread_or_at_nice_minus_10_when_the_tick_asks_none():
    assert ControllerSettings(realtime_priority=10).supervisor_priority == 11
    assert ControllerSettings(realtime_priority=99).supervisor_priority == 99
    assert ControllerSettings(realtime_priority=0).supervisor_priority == 0


def test_supervisor_switch_must_be_a_bool():
    with pytest.raises(ParolkitValueError, match="controller.supervisor must be"):
        ControllerSettings(supervisor=1)  # type: ignore[arg-type]


def _wait_events(sup: StopSupervisor, kind: SupervisorEventKind, timeout: float = 10.0) -> list[SupervisorEvent]:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        got = [e for e in sup.poll() if e.kind is kind]
        if got:
            return got
        time.sleep(0.005)
    raise AssertionError(f"no {kind} event within {timeout} s")


@pytest.fixture
def port_pipe():
    """A pipe standing for the serial port: (read end, write end); what the supervisor writes
    to the board arrives at the read end."""
    r, w = os.pipe()
    os.set_blocking(r, False)
    yield r, w
    os.close(r)
    os.close(w)


@pytest.fixture
def ready_supervisor(port_pipe):
    """``start(stall_s)``: a stop supervisor process (period 10 ms) that holds the pipe's write
    end as its port and said it is ready; closed after the test."""
    started: list[StopSupervisor] = []

    def start(stall_s: float) -> StopSupervisor:
        sup = StopSupervisor(period_s=0.01, stall_s=stall_s)
        started.append(sup)
        assert sup.start()
        sup.port_opened(port_pipe[1])
        _wait_events(sup, SupervisorEventKind.READY)
        return sup

    yield start
    for sup in started:
        sup.close()


def test_a_running_controller_that_writes_nothing_is_stopped_only_after_the_stall_limit(port_pipe, ready_supervisor):
    """This process (the supervisor's parent: its controller) runs on but sends no frame: the
    supervisor looks after 3 periods, sees it running, and waits for the stall limit."""
    sup = ready_supervisor(0.3)
    jog = CommandFrame(positions=(1, 2, 3, 4, 5, 6), speeds=(0, 0, 0, 0, 0, 900), command=BoardCommand.JOG)
    t0 = time.monotonic()
    sup.sent(jog.encode())
    (ev,) = _wait_events(sup, SupervisorEventKind.STOPPED)
    assert time.monotonic() - t0 >= 0.3
    quiet = int(re.search(r"runs but wrote no frame for (\d+) ms \(limit 300 ms\)", ev.text).group(1))
    assert quiet >= 300, ev.text
    assert ev.text.endswith("the stop supervisor disabled the board")
    assert os.read(port_pipe[0], 1000) == stop_frame(jog.encode()) * STOP_COPIES


def test_a_stopped_process_is_seen_stopped_and_a_running_one_is_not():
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        assert not controller_stopped(child.pid)
        os.kill(child.pid, signal.SIGSTOP)
        wait_until(lambda: controller_stopped(child.pid), 5, interval=0.005, what="SIGSTOP seen in /proc")
        os.kill(child.pid, signal.SIGCONT)
        wait_until(lambda: not controller_stopped(child.pid), 5, interval=0.005, what="SIGCONT seen in /proc")
    finally:
        child.kill()
        child.wait()
    assert not controller_stopped(child.pid)  # gone


@pytest.mark.parametrize("found_by", ["poll", "send"])
def test_a_supervisor_killed_is_reported_lost_once_with_the_signal_and_a_new_one_can_be_started(
        port_pipe, ready_supervisor, found_by):
    """Whether the loop's poll reads its socket's EOF first or the next frame's send fails
    (EPIPE), the loss reads the same."""
    sup = ready_supervisor(0)
    old = sup.pid
    assert old is not None
    os.kill(old, signal.SIGKILL)
    wait_until(lambda: process_exited(old), 5, interval=0.001, what="the supervisor dead, its threads too")
    if found_by == "send":
        sup.sent(b"\x00" * 56)
        assert sup.state == "dead"
    (ev,) = _wait_events(sup, SupervisorEventKind.LOST)
    assert ev.text == f"the stop supervisor (pid {old}) exited (killed by signal 9)"
    assert sup.state == "dead" and sup.poll() == []
    sup.sent(b"\x00" * 56)  # nothing is sent to a lost supervisor, nothing breaks
    assert sup.start()
    sup.port_opened(port_pipe[1])
    _wait_events(sup, SupervisorEventKind.READY)
    assert sup.state == "ready" and sup.pid != old and sup.restarts == 1


def test_after_the_controller_closed_its_supervisor_a_restart_under_way_starts_nothing(ready_supervisor):
    """Shutdown (close) while the loop's restart helper is about to start a new supervisor:
    nothing is started that would outlive the controller, and no loss is reported."""
    sup = ready_supervisor(0)
    old = sup.pid
    sup.close()
    assert not sup.start()
    assert sup.pid == old and sup.state == "off" and sup.poll() == []
