"""The emulated PAROL6 control board (stock firmware semantics at the byte level).

Control API in one page::

    from parolkit.board import BoardEmulator, LinkFaults, PtyBoardServer

    emu = BoardEmulator(clock="virtual", homing_speedup=50)   # or clock="realtime" (default)
    emu.write(CommandFrame(command=BoardCommand.HOME).encode())   # bytes from the PC
    reply = emu.read()                          # 60-byte status frames the board sent
    emu.advance(0.01)                           # virtual clock: run the board loop 10 ms
    emu.process_frame(frame) -> StatusFrame     # decoded path (no link faults)
    emu.status_frame() -> StatusFrame           # what it would report now

    emu.positions / physical_positions / speeds / homed / enabled / homing_active
    emu.outputs (OUT1, OUT2) / inputs / estop_pressed / gripper (GripperState) / stats
    emu.set_estop(True)          # IO bit 0x08 reads 0; the firmware does nothing else
    emu.set_input(1, True)       # IN1 / IN2
    emu.place_object(30.0)       # a 30 mm object between the SSG-48 jaws (None removes)
    emu.inject_errors(temperature=["J3"], position=[1])   # opt-in error bits
    emu.set_faults(drop_rate=0.01, corrupt_rate=0.01, delay_s=0.0, silent=False,
                   direction="both")                      # opt-in link faults
    emu.unplug() / emu.replug()  # link disappears (LinkLostError in-process; pty closed)
    emu.start() / emu.stop()     # real-time clock: background loop thread

Real-time use: ``EmulatorTransport()`` (in :mod:`parolkit.transport`) starts the loop; a
serial device for external software: ``PtyBoardServer(emu, "/tmp/p6")`` or
``parolkit board-sim --link /tmp/p6``.  See ``docs/board-emulator.md``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from parolkit.board.emulator import BoardEmulator, ClockMode, Direction, EmulatorStats
from parolkit.board.faults import ByteFaultInjector, LinkFaults
from parolkit.board.gripper import GripperState, SSG48Gripper, jaw_rate_units_s
from parolkit.board.homing import (
    J5_OFFSET_PNEUMATIC,
    J5_OFFSET_SSG48,
    SWITCH_POSITIONS_STEPS,
    HomingPhase,
)

if TYPE_CHECKING:  # the real name for type checkers; at run time __getattr__ loads it lazily
    from parolkit.board.pty_server import PtyBoardServer

__all__ = [
    "BoardEmulator", "ClockMode", "Direction", "EmulatorStats", "ByteFaultInjector",
    "LinkFaults", "GripperState", "SSG48Gripper", "jaw_rate_units_s", "J5_OFFSET_PNEUMATIC",
    "J5_OFFSET_SSG48", "SWITCH_POSITIONS_STEPS", "HomingPhase", "PtyBoardServer",
]


def __getattr__(name: str) -> object:
    if name == "PtyBoardServer":
        from parolkit.board.pty_server import PtyBoardServer

        return PtyBoardServer
    raise AttributeError(f"module 'parolkit.board' has no attribute {name!r}")
