"""Exceptions shared by every part of parolkit, and the map of all of them.

Each exception says what went wrong and, where it helps, what to do.  Every parolkit
exception derives from :class:`ParolkitError`; value problems also derive from
:class:`ValueError` so generic code that catches ``ValueError`` keeps working.  The one
exception outside the tree is the standard-library client's, which may not import parolkit.

The whole tree (``tests/unit/test_error_tree.py`` checks that every exception class of the
package is drawn here, under its real base class, and that no two share a name)::

    Exception
    +-- ParolkitError                     parolkit.errors: base of every parolkit error
    |   +-- ParolkitValueError            parolkit.errors: a value is malformed or out of range
    |   |   |                             (also a ValueError; the message names it)
    |   |   +-- JointLimitError           parolkit.errors: a joint position/speed outside its range
    |   |   +-- IKError                   parolkit.kinematics: no IK solution inside the limits
    |   |   +-- FrameError                parolkit.protocol.frames: bytes that are not a board frame
    |   |   +-- DatagramError             parolkit.protocol.commands: a UDP datagram that is not a
    |   |                                 valid command (the controller answers INVALID / ERROR)
    |   |   +-- ClassroomError            parolkit.gui.classroom: a class action refused (why, and
    |   |   |                             what to do instead)
    |   |   +-- GamepadInputError         parolkit.gui.gamepad: a gamepad message the commander cannot take
    |   |   +-- EditRefused               parolkit.gui.program_doc: a page's edit that cannot be applied
    |   |   +-- FolderNameError           parolkit.gui.programs: a file name the commander refuses
    |   |       |                         in one of its folders (names the rule)
    |   |       +-- ProgramNameError      parolkit.gui.programs: a program name or file (outside
    |   |       |                         its programs folder, too large)
    |   |       +-- RecordingNameError    parolkit.gui.recordings: a recording name
    |   |           +-- RecordingNotListed  parolkit.gui.recordings: well formed, but not a
    |   |                                 recording the folder lists (HTTP 404)
    |   +-- PlanningError                 parolkit.motion: a move refused before anything moved
    |   +-- ProgramError                  parolkit.script: an RBTscript program with errors (all of
    |   |                                 them, as ScriptError diagnostics; those are not exceptions)
    |   +-- TransportError                parolkit.transport: a byte link could not be opened or used
    |   |   +-- LinkLostError             parolkit.transport: the link went away while in use
    |   |   +-- TransportURLError         parolkit.transport: a malformed link URL or option (the
    |   |                                 message names the part; also a ParolkitValueError)
    |   +-- PtyServerError                parolkit.board.pty_server: the emulator's pty could not be set up
    |   +-- ControlError                  parolkit.board.control_channel: the board-sim control channel failed
    |   +-- BoardTestError                parolkit.boardtest: a board test action could not complete
    |   +-- TrajectoryRefused             parolkit.ros2.trajectory: a ROS JointTrajectory refused
    |   |                                 before anything was sent (names the point and reason)
    |   +-- GoalRefused                   parolkit.ros2.follow_joint_trajectory: an action goal that
    |   |                                 cannot run (control_msgs' error code and the reason)
    |   +-- WrongPassword                 parolkit.gui.security: a login with a wrong password
    |   +-- RobotError                    parolkit.client.errors: base of the object API's errors
    |       +-- CommandNotCompleted       a command ended without COMPLETED (command_id, command,
    |       |   |                         status, reason: the controller's words)
    |       |   +-- CommandFailed         FAILED: accepted but could not be executed
    |       |   +-- CommandInvalid        INVALID: refused; the reason names the field (also a ValueError)
    |       |   +-- CommandCancelled      CANCELLED: by STOP, E-stop or a lost board link
    |       |   +-- CommandTimeout        no terminal acknowledgement in time (it may still run)
    |       +-- ControllerUnreachable     the controller did not answer
    |       +-- ReplyError                a malformed reply, or an ERROR|... answer
    +-- OSError
        +-- AckPortBusyError              parolkit.client.robot_api: the acknowledgement port is taken
                                          (robot_api is standard library only: not a ParolkitError)

Three private exceptions never leave their module (control flow, not errors):
``parolkit.script.parser._Reject`` (stop building a line whose errors are recorded),
``parolkit.script.interpreter._Stopped`` (the run was stopped) and
``parolkit.script.interpreter._LineFailed`` (a line did not complete: the run ends FAILED).

Where to catch what: a script driving the robot catches :class:`RobotError` (or one of its
subclasses); code calling planning, kinematics or parsing functions directly catches
:class:`ParolkitError` (``ParolkitValueError`` for bad arguments).
"""

from __future__ import annotations

__all__ = ["ParolkitError", "ParolkitValueError", "JointLimitError"]

_JOINT_NAMES = ("J1", "J2", "J3", "J4", "J5", "J6")


class ParolkitError(Exception):
    """Base class of every parolkit error."""


class ParolkitValueError(ParolkitError, ValueError):
    """A value given to a public function is malformed or out of range (the message names it)."""


class JointLimitError(ParolkitValueError):
    """A joint position or speed is outside its allowed range.

    Attributes: ``joint`` (0-based index), ``joint_name`` ("J1".."J6"), ``value``, ``low``,
    ``high``, ``unit`` and, for batches, ``sample`` (row index).
    """

    def __init__(
        self,
        *,
        joint: int,
        value: float,
        low: float,
        high: float,
        unit: str,
        sample: int | None = None,
        what: str = "joints",
    ) -> None:
        self.joint = joint
        self.joint_name = _JOINT_NAMES[joint]
        self.value = value
        self.low = low
        self.high = high
        self.unit = unit
        self.sample = sample
        self.what = what
        side = f"< lower limit {low:g}" if value < low else f"> upper limit {high:g}"
        where = f" (sample {sample})" if sample is not None else ""
        super().__init__(
            f"{what}{where}: {self.joint_name} = {value:g} {unit} is out of range: {side} "
            f"(allowed {low:g} .. {high:g} {unit})"
        )

    def __reduce__(self) -> tuple[object, ...]:
        # keyword-only arguments: rebuilt from them (an error raised in a worker process, e.g.
        # the commander's teach process, reaches the page as itself)
        return (_joint_limit_error, (self.joint, self.value, self.low, self.high, self.unit, self.sample, self.what))


def _joint_limit_error(joint: int, value: float, low: float, high: float, unit: str, sample: int | None,
                       what: str) -> JointLimitError:
    return JointLimitError(joint=joint, value=value, low=low, high=high, unit=unit, sample=sample, what=what)
