"""What every frame carries besides motion: the digital outputs and the SSG-48 gripper's
setpoints.  A value: a command that changes them gives the next one (one owner: the core)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from parolkit.protocol.frames import CommandFrame, IOBits

__all__ = ["Setpoints"]


@dataclass(frozen=True, slots=True)
class Setpoints:
    """OUT1/OUT2 and the gripper's persistent setpoints (position, speed, current, command bits)."""

    outputs: tuple[bool, bool] = (False, False)
    gripper_position: int = 0
    gripper_speed: int = 0
    gripper_current: int = 0
    gripper_command: int = 0

    def with_output(self, port: int, on: bool) -> Setpoints:
        """Output ``port`` (1 or 2) on or off."""
        outs = list(self.outputs)
        outs[port - 1] = on
        return replace(self, outputs=(outs[0], outs[1]))

    def with_gripper(self, *, command: int, position: int | None = None, speed: int | None = None,
                     current: int | None = None) -> Setpoints:
        return replace(self, gripper_command=command,
                       gripper_position=self.gripper_position if position is None else position,
                       gripper_speed=self.gripper_speed if speed is None else speed,
                       gripper_current=self.gripper_current if current is None else current)

    @property
    def io(self) -> int:
        """The frame's IO byte: OUT1 and OUT2."""
        return (int(IOBits.OUT1) if self.outputs[0] else 0) | (int(IOBits.OUT2) if self.outputs[1] else 0)

    def frame(self, positions: Sequence[int], speeds: Sequence[int], command: int,
              gripper_mode: int) -> CommandFrame:
        """A command frame with this motion and these setpoints."""
        return CommandFrame(
            positions=tuple(positions), speeds=tuple(speeds), command=command, io=self.io,
            gripper_position=self.gripper_position, gripper_speed=self.gripper_speed,
            gripper_current=self.gripper_current, gripper_command=self.gripper_command,
            gripper_mode=gripper_mode,
        )
