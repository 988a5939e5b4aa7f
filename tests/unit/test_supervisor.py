"""The stop supervisor's frame and its settings (the process itself is proven in
tests/integration/test_bounded_commitment.py)."""

from __future__ import annotations

import pytest

from parolkit.config import ControllerSettings
from parolkit.controller.supervisor import stop_frame
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


@pytest.mark.parametrize("bad", [-0.1, 61, "0.5", True, float("nan")])
def test_supervisor_stall_must_be_seconds_in_0_to_60(bad):
    with pytest.raises(ParolkitValueError, match="supervisor_stall_s"):
        ControllerSettings(supervisor_stall_s=bad)


def test_supervisor_switch_must_be_a_bool():
    with pytest.raises(ParolkitValueError, match="controller.supervisor must be"):
        ControllerSettings(supervisor=1)  # type: ignore[arg-type]
