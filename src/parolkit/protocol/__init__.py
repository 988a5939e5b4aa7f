"""Wire formats: board frames (codec + stream parser) and controller text commands."""

from parolkit.protocol.frames import (
    BOARD_CRC,
    COMMAND_FRAME_SIZE,
    COMMAND_LEN,
    PC_CRC,
    STATUS_FRAME_SIZE,
    STATUS_LEN,
    TIMER_HZ,
    BoardCommand,
    CommandFrame,
    FrameError,
    GripperCommandBits,
    GripperMode,
    GripperStatus,
    IOBits,
    StatusFrame,
    bits_to_byte,
    byte_to_bits,
)
from parolkit.protocol.stream import CommandParser, FrameParser, ParserStats, StatusParser

__all__ = [
    "BOARD_CRC", "COMMAND_FRAME_SIZE", "COMMAND_LEN", "PC_CRC", "STATUS_FRAME_SIZE", "STATUS_LEN",
    "TIMER_HZ", "BoardCommand", "CommandFrame", "FrameError", "GripperCommandBits", "GripperMode",
    "GripperStatus", "IOBits", "StatusFrame", "bits_to_byte", "byte_to_bits", "CommandParser",
    "FrameParser", "ParserStats", "StatusParser",
]
