"""``parolkit board-test``: exercise one PAROL6 board function at a time.

Talks to the BOARD directly (a real board on ``--port /dev/ttyACM0``, a ``board-sim`` pty, or
the in-process emulator with ``--sim``), not through the controller.  Every action streams
command frames at ``--rate`` Hz (100 by default) with idle frames before and after it, and
prints what the board answered::

    parolkit board-test --sim jog --joint 3 --speed 1000 --seconds 2
    parolkit board-test --port /dev/ttyACM0 out 1 on
    parolkit board-test --port 'spy+/dev/ttyACM0?log=-' monitor   # every frame, decoded
    parolkit board-test --sim --speedup 50 home
    parolkit board-test --sim gripper calibrate
    parolkit board-test --sim gripper move 200 100 400
    parolkit board-test --sim monitor --seconds 5
    parolkit board-test --sim                 # interactive menu

Units: joint positions in board steps (and degrees), speeds in steps/s (and deg/s), the
board's ``timing`` field in ticks of 1/703125 s and in ms.

Safety: the board enforces nothing, so this tool refuses to jog or home while the hardware
E-stop is pressed and stops a jog at once (zero speed, then DISABLE) when it is pressed
during the move.  Jog speeds are limited to the joint's maximum speed.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, TextIO

from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.protocol.frames import (
    TIMER_HZ,
    BoardCommand,
    CommandFrame,
    GripperCommandBits,
    GripperMode,
    IOBits,
    StatusFrame,
)
from parolkit.protocol.stream import StatusParser
from parolkit.robot import JOINT_NAMES, PAROL6, RobotModel

if TYPE_CHECKING:  # pragma: no cover
    from parolkit.transport.base import Transport

__all__ = ["BoardTester", "BoardTestError", "format_status", "register", "main", "run_action"]

#: Gripper command byte used for moves: activate | move | release-direction (0xD0).
#: how long the tool waits for the board's first reply before it says the board is not there (s):
#: a busy PC's tty layer has held a reply back over a second (two CPU hogs beside the test suite)
FIRST_REPLY_S = 3.0
GRIPPER_MOVE_BITS = GripperCommandBits.ACTIVATE | GripperCommandBits.MOVE | GripperCommandBits.RELEASE_DIR


class BoardTestError(ParolkitError):
    """An action could not be completed (no answer from the board, E-stop, timeout)."""


def _ms(ticks: int) -> float:
    return ticks * 1000.0 / TIMER_HZ


def format_status(frame: StatusFrame | None, model: RobotModel = PAROL6, *,
                  missed: int = 0, sent: int = 0) -> str:
    """A multi-line view of every telemetry field of one status frame."""
    if frame is None:
        return "no status frame received from the board yet"
    spd = [float(x) for x in model.steps_per_deg]
    homed = frame.homed_joints
    temp = [bool(frame.temperature_error & (0x80 >> i)) for i in range(6)]
    perr = [bool(frame.position_error & (0x80 >> i)) for i in range(6)]
    lines = [
        "joint   pos[steps]    pos[deg]  speed[steps/s]  speed[deg/s]  homed  temp_err  pos_err",
    ]
    for i in range(6):
        lines.append(
            f"{JOINT_NAMES[i]:<5} {frame.positions[i]:>12d} {frame.positions[i] / spd[i]:>11.3f} "
            f"{frame.speeds[i]:>15d} {frame.speeds[i] / spd[i]:>13.3f}  {'yes' if homed[i] else 'no':>5}"
            f"  {'ERR' if temp[i] else 'ok':>8}  {'ERR' if perr[i] else 'ok':>7}")
    in1, in2 = frame.inputs
    out1, out2 = frame.outputs
    lines.append(
        f"bytes: homed=0x{frame.homed:02X} io=0x{frame.io:02X} temp_err=0x{frame.temperature_error:02X} "
        f"pos_err=0x{frame.position_error:02X}   all homed: {'yes' if frame.all_homed else 'no'}")
    lines.append(
        f"IO: IN1={int(in1)} IN2={int(in2)} OUT1={int(out1)} OUT2={int(out2)} "
        f"ESTOP={'PRESSED' if frame.estop_pressed else 'released'}")
    lines.append(
        f"timing: {frame.timing} ticks = {_ms(frame.timing):.3f} ms   timeout_error={frame.timeout_error}"
        f"   xtr={frame.xtr} (last command echoed)")
    g = frame.gripper
    code = ("moving", "object (closing)", "object (opening)", "at position")[g.object_code]
    lines.append(
        f"gripper: id={frame.gripper_id} position={frame.gripper_position} speed={frame.gripper_speed} "
        f"current={frame.gripper_current} mA status=0x{frame.gripper_status:02X} "
        f"object_detection={frame.object_detection}")
    lines.append(
        f"  activated={g.activated} calibrated={g.calibrated} action={g.action} object={code} "
        f"error={g.estop_error} temp_error={g.temperature_error} timeout_error={g.timeout_error}")
    if sent:
        lines.append(f"link: {sent} frames sent, {missed} without a reply")
    return "\n".join(lines)


@dataclass
class _Outputs:
    out1: bool = False
    out2: bool = False

    def byte(self) -> int:
        return (IOBits.OUT1 if self.out1 else 0) | (IOBits.OUT2 if self.out2 else 0)


class BoardTester:
    """Streams command frames to one board and keeps its latest status.

    ``transport``: an open :class:`parolkit.transport.Transport`; ``rate_hz``: frame rate
    (1..1000); ``out``: where reports go (default: the current ``sys.stdout``).  Sticky PC-side
    state (outputs, gripper setpoints) is sent in every frame, as the original software does.
    """

    def __init__(self, transport: Transport, rate_hz: float = 100.0, out: TextIO | None = None,
                 model: RobotModel = PAROL6) -> None:
        if isinstance(rate_hz, bool) or not isinstance(rate_hz, (int, float)) or not 1 <= rate_hz <= 1000:
            raise ParolkitValueError(f"rate must be in 1..1000 Hz, got {rate_hz!r}")
        self.transport = transport
        self.period = 1.0 / float(rate_hz)
        self.out = out if out is not None else sys.stdout
        self.model = model
        self.parser = StatusParser()
        self.status: StatusFrame | None = None
        self.outputs = _Outputs()
        self.gripper = (0, 0, 100, 0)  # position, speed, current, command bits
        self.sent = 0
        self.missed = 0
        self._next = time.monotonic()

    # ---- frames ----
    def tick(self, command: int = BoardCommand.IDLE, *, speeds: Sequence[int] = (0,) * 6,
             positions: Sequence[int] | None = None,
             gripper_mode: int = GripperMode.OPERATE) -> StatusFrame | None:
        """Send one frame, wait (until the end of this tick) for the reply, keep the rate."""
        if positions is None:
            positions = self.status.positions if self.status is not None else (0,) * 6
        gpos, gspd, gcur, gbits = self.gripper
        frame = CommandFrame(positions=tuple(positions), speeds=tuple(int(s) for s in speeds),
                             command=int(command), io=self.outputs.byte(), gripper_position=gpos,
                             gripper_speed=gspd, gripper_current=gcur, gripper_command=gbits,
                             gripper_mode=int(gripper_mode))
        now = time.monotonic()
        if self._next < now - self.period:  # we fell behind (or were idle): restart the grid
            self._next = now
        self.transport.write(frame.encode())
        self.sent += 1
        deadline = self._next + self.period
        got = None
        while True:
            frames = self.parser.feed(self.transport.read())
            if frames:
                got = frames[-1]
                self.status = got
                break
            if time.monotonic() >= deadline:
                break
            time.sleep(0.0005)
        if got is None:
            self.missed += 1
        self._next = deadline
        delay = self._next - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        return got

    def idle(self, seconds: float) -> StatusFrame | None:
        """Idle frames (255) for ``seconds``; returns the latest status."""
        for _ in range(max(1, round(seconds / self.period))):
            self.tick()
        return self.status

    def require_status(self) -> StatusFrame:
        """The latest status; without one yet, idle frames until the board answers, for at most
        :data:`FIRST_REPLY_S` (a board answers within a frame, but a loaded PC's tty layer may
        hold its first replies back a second)."""
        for _ in range(max(1, round(FIRST_REPLY_S / self.period))):
            if self.status is not None:
                break
            self.tick()
        if self.status is None:
            raise BoardTestError(
                f"the board did not answer {self.sent} frames on {self.transport.description}: "
                "check the cable/port, that the board is powered, and the baud rate")
        return self.status

    def print(self, text: str = "") -> None:
        print(text, file=self.out, flush=True)

    def show(self) -> None:
        self.print(format_status(self.status, self.model, missed=self.missed, sent=self.sent))

    # ---- actions ----
    def jog(self, joint: int, speed_steps_s: int, seconds: float) -> StatusFrame:
        """Run ``joint`` (1..6) at ``speed_steps_s`` (signed) for ``seconds`` with command 123."""
        j = _check_int(joint, "joint", 1, 6) - 1
        limit = int(self.model.max_speed_steps_s[j])
        spd = _check_int(speed_steps_s, "speed (steps/s)", -limit, limit)
        secs = _check_float(seconds, "seconds", 0.01, 60.0)
        st = self.require_status()
        if st.estop_pressed:
            raise BoardTestError("E-stop is pressed: release it before jogging")
        self.idle(0.1)
        start = self.require_status().positions[j]
        speeds = [0] * 6
        speeds[j] = spd
        self.print(f"jog {JOINT_NAMES[j]} at {spd} steps/s "
                   f"({spd / float(self.model.steps_per_deg[j]):.2f} deg/s) for {secs:g} s")
        stopped_by_estop = False
        t_end = time.monotonic() + secs  # wall time: late ticks must not stretch the jog
        while True:
            f = self.tick(BoardCommand.JOG, speeds=speeds)
            if f is not None and f.estop_pressed:
                stopped_by_estop = True
                break
            if time.monotonic() >= t_end - 0.5 * self.period:
                break
        for _ in range(3):  # a speed-only stream always ends with zero speed
            self.tick(BoardCommand.JOG, speeds=(0,) * 6)
        if stopped_by_estop:
            self.tick(BoardCommand.DISABLE)
            self.idle(0.1)
            raise BoardTestError(f"E-stop pressed during the jog of {JOINT_NAMES[j]}: stopped and "
                                 "sent DISABLE; release it and run 'enable'")
        end = self.idle(0.2) or self.require_status()
        moved = end.positions[j] - start
        self.print(f"{JOINT_NAMES[j]}: {start} -> {end.positions[j]} steps "
                   f"(moved {moved} steps = {moved / float(self.model.steps_per_deg[j]):.3f} deg)")
        return end

    def set_output(self, number: int, on: bool) -> StatusFrame:
        """Drive OUT1/OUT2 and read back the board's IO byte."""
        n = _check_int(number, "output", 1, 2)
        if n == 1:
            self.outputs.out1 = bool(on)
        else:
            self.outputs.out2 = bool(on)
        st = self.idle(0.1) or self.require_status()
        actual = st.outputs[n - 1]
        self.print(f"OUT{n} set {'ON' if on else 'OFF'}; board reports OUT{n}={int(actual)} "
                   f"(io byte 0x{st.io:02X})")
        if actual != bool(on):
            raise BoardTestError(f"the board reports OUT{n}={int(actual)}, expected {int(bool(on))}")
        return st

    def read_inputs(self) -> StatusFrame:
        """Report IN1, IN2 and the E-stop input."""
        st = self.idle(0.05) or self.require_status()
        in1, in2 = st.inputs
        self.print(f"IN1={int(in1)} IN2={int(in2)} ESTOP={'PRESSED' if st.estop_pressed else 'released'} "
                   f"(io byte 0x{st.io:02X})")
        return st

    def single(self, command: BoardCommand, label: str, settle_s: float = 0.2) -> StatusFrame:
        """Send ``command`` in one frame, then idle frames; report homed bits and xtr."""
        self.require_status()
        self.tick(command)
        st = self.idle(settle_s) or self.require_status()
        self.print(f"{label}: sent {int(command)}; board echoed xtr={st.xtr}, homed=0x{st.homed:02X}, "
                   f"ESTOP={'PRESSED' if st.estop_pressed else 'released'}")
        return st

    def home(self, timeout_s: float = 120.0) -> StatusFrame:
        """Command 100 once, then idle frames until every homed bit is set."""
        t = _check_float(timeout_s, "timeout", 0.1, 3600.0)
        st = self.require_status()
        if st.estop_pressed:
            raise BoardTestError("E-stop is pressed: release it before homing")
        self.print("homing: sent 100, then idle frames")
        self.tick(BoardCommand.HOME)
        start = time.monotonic()
        last_bits = -1
        while time.monotonic() - start < t:
            f = self.tick()
            if f is None:
                continue
            if f.homed != last_bits:
                last_bits = f.homed
                flags = " ".join(f"{JOINT_NAMES[i]}={'1' if b else '0'}"
                                 for i, b in enumerate(f.homed_joints))
                self.print(f"  t={time.monotonic() - start:6.2f} s homed: {flags}")
            if f.all_homed:
                self.print(f"homed in {time.monotonic() - start:.2f} s; positions {list(f.positions)} steps")
                return f
        raise BoardTestError(f"not homed within {t:g} s (homed byte 0x{self.require_status().homed:02X})")

    def gripper_calibrate(self, seconds: float = 2.0) -> StatusFrame:
        """Gripper mode 1 in exactly one frame, then idle frames for ``seconds``."""
        secs = _check_float(seconds, "seconds", 0.05, 60.0)
        self.require_status()
        self.gripper = (self.gripper[0], self.gripper[1], self.gripper[2], int(GripperCommandBits.ACTIVATE))
        self.tick(gripper_mode=GripperMode.CALIBRATE)
        st = self.idle(secs) or self.require_status()
        self.print(f"gripper calibrate: status=0x{st.gripper_status:02X} calibrated={st.gripper.calibrated} "
                   f"activated={st.gripper.activated} position={st.gripper_position}")
        return st

    def gripper_clear(self) -> StatusFrame:
        """Gripper mode 2 (clear error) in exactly one frame."""
        self.require_status()
        self.tick(gripper_mode=GripperMode.CLEAR_ERROR)
        st = self.idle(0.2) or self.require_status()
        self.print(f"gripper clear error: status=0x{st.gripper_status:02X} error={st.gripper.estop_error}")
        return st

    def gripper_move(self, position: int, speed: int, current: int, seconds: float = 2.0) -> StatusFrame:
        """Move the SSG-48 to ``position`` 0..255 at ``speed`` 0..255 with ``current`` 0..1300 mA."""
        pos = _check_int(position, "position", 0, 255)
        spd = _check_int(speed, "speed", 0, 255)
        cur = _check_int(current, "current (mA)", 0, 1300)
        secs = _check_float(seconds, "seconds", 0.05, 60.0)
        self.require_status()
        self.gripper = (pos, spd, cur, int(GRIPPER_MOVE_BITS))
        self.print(f"gripper move to {pos} at speed {spd}, {cur} mA")
        st = self.idle(secs) or self.require_status()
        g = st.gripper
        code = ("moving", "object found (closing)", "object found (opening)", "at position")[g.object_code]
        self.print(f"gripper: position={st.gripper_position} current={st.gripper_current} mA "
                   f"status=0x{st.gripper_status:02X} ({code}; calibrated={g.calibrated})")
        if not g.calibrated:
            self.print("note: the gripper is not calibrated, so it ignores moves: run 'gripper calibrate' first")
        return st

    def gripper_status(self) -> StatusFrame:
        st = self.idle(0.05) or self.require_status()
        g = st.gripper
        self.print(f"gripper: id={st.gripper_id} position={st.gripper_position} speed={st.gripper_speed} "
                   f"current={st.gripper_current} mA status=0x{st.gripper_status:02X} "
                   f"activated={g.activated} calibrated={g.calibrated} object_code={g.object_code} "
                   f"error={g.estop_error} object_detection={st.object_detection}")
        return st

    def monitor(self, seconds: float | None, refresh_s: float = 0.1,
                live: bool | None = None) -> StatusFrame | None:
        """Idle frames and a live view of every telemetry field (``seconds=None``: until Ctrl-C).

        On a terminal the view redraws in place every ``refresh_s``; otherwise a block is
        printed every second (and at the end).
        """
        live = self.out.isatty() if live is None else live
        every = refresh_s if live else max(1.0, refresh_s)
        start = time.monotonic()
        last = 0.0
        try:
            while seconds is None or time.monotonic() - start < seconds:
                self.tick()
                now = time.monotonic()
                if now - last >= every:
                    last = now
                    block = format_status(self.status, self.model, missed=self.missed, sent=self.sent)
                    if live:
                        self.out.write("\x1b[H\x1b[J" + block + "\n")
                        self.out.flush()
                    else:
                        self.print(f"--- t={now - start:.1f} s")
                        self.print(block)
        except KeyboardInterrupt:
            pass
        self.print("--- final")
        self.show()
        return self.status


def _check_int(value: object, name: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ParolkitValueError(f"{name} must be an integer in {low}..{high}, got {value!r}")
    if not low <= value <= high:
        raise ParolkitValueError(f"{name} must be in {low}..{high}, got {value}")
    return value


def _check_float(value: object, name: str, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value:
        raise ParolkitValueError(f"{name} must be a number in {low:g}..{high:g}, got {value!r}")
    if not low <= value <= high:
        raise ParolkitValueError(f"{name} must be in {low:g}..{high:g} s, got {value:g}")
    return float(value)


# =============================================================================================
# command line
# =============================================================================================


def _on_off(text: str) -> bool:
    t = text.strip().lower()
    if t in ("on", "1", "high", "true"):
        return True
    if t in ("off", "0", "low", "false"):
        return False
    raise argparse.ArgumentTypeError(f"state must be on|off (or 1|0, high|low), got {text!r}")


def _add_actions(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION")
    p = sub.add_parser("jog", help="run one joint at a speed (command 123)")
    p.add_argument("--joint", type=int, required=True, help="joint 1..6")
    p.add_argument("--speed", type=int, required=True, help="steps/s, signed (direction)")
    p.add_argument("--seconds", type=float, default=1.0, help="duration, s (default 1)")
    p = sub.add_parser("out", help="set OUT1/OUT2")
    p.add_argument("number", type=int, choices=(1, 2))
    p.add_argument("state", type=_on_off, help="on|off")
    sub.add_parser("inputs", help="read IN1, IN2 and the E-stop input")
    p = sub.add_parser("home", help="run the board's homing sequence (command 100)")
    p.add_argument("--timeout", type=float, default=120.0, help="s (default 120)")
    sub.add_parser("enable", help="command 101")
    sub.add_parser("disable", help="command 102")
    sub.add_parser("clear-error", help="command 103")
    p = sub.add_parser("gripper", help="SSG-48 gripper: calibrate | move POS SPEED CURRENT | status | clear")
    gsub = p.add_subparsers(dest="gripper_action", metavar="GRIPPER_ACTION")
    g = gsub.add_parser("calibrate", help="calibrate and activate (mode 1, one frame)")
    g.add_argument("--seconds", type=float, default=2.0)
    g = gsub.add_parser("move", help="move to POS (0..255) at SPEED (0..255) with CURRENT (0..1300 mA)")
    g.add_argument("position", type=int)
    g.add_argument("speed", type=int)
    g.add_argument("current", type=int)
    g.add_argument("--seconds", type=float, default=2.0)
    gsub.add_parser("status", help="print the gripper fields")
    gsub.add_parser("clear", help="clear a gripper error (mode 2, one frame)")
    p = sub.add_parser("monitor", help="live view of every telemetry field")
    p.add_argument("--seconds", type=float, default=None, help="s (default: until Ctrl-C)")
    p.add_argument("--refresh", type=float, default=0.1, help="redraw period on a terminal, s")
    sub.add_parser("status", help="print one full status snapshot")


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser],
             name: str = "board-test") -> argparse.ArgumentParser:
    """Add ``parolkit board-test`` to the dispatcher."""
    parser = subparsers.add_parser(
        name, help="exercise one board function at a time",
        description="Exercise one PAROL6 board function at a time, talking to the board directly "
                    "(not through the controller). Without an ACTION: interactive menu.")
    link = parser.add_mutually_exclusive_group()
    link.add_argument("--port", help="the board link: a serial device (/dev/ttyACM0, a board-sim pty) "
                                     "or a transport URL (sim://, 'spy+/dev/ttyACM0?log=-', "
                                     "'faulty+sim://?drop=0.01'; see docs/transport.md)")
    link.add_argument("--sim", action="store_true", help="use the in-process emulated board (default)")
    parser.add_argument("--speedup", type=float, default=None,
                        help="simulated board only: homing time scale 1..1000 (default 1 = real time)")
    parser.add_argument("--baud", type=int, default=None,
                        help="serial link only: baud (default 3000000)")
    parser.add_argument("--rate", type=float, default=100.0, help="frame rate, Hz (default 100)")
    _add_actions(parser)
    parser.set_defaults(func=main)
    return parser


def run_action(tester: BoardTester, args: argparse.Namespace) -> None:
    """Run the action selected in ``args`` (raises BoardTestError/ParolkitValueError)."""
    a = args.action
    if a == "jog":
        tester.jog(args.joint, args.speed, args.seconds)
    elif a == "out":
        tester.set_output(args.number, args.state)
    elif a == "inputs":
        tester.read_inputs()
    elif a == "home":
        tester.home(args.timeout)
    elif a == "enable":
        tester.single(BoardCommand.ENABLE, "enable")
    elif a == "disable":
        tester.single(BoardCommand.DISABLE, "disable")
    elif a == "clear-error":
        tester.single(BoardCommand.CLEAR_ERROR, "clear error")
    elif a == "gripper":
        ga = args.gripper_action
        if ga == "calibrate":
            tester.gripper_calibrate(args.seconds)
        elif ga == "move":
            tester.gripper_move(args.position, args.speed, args.current, args.seconds)
        elif ga == "clear":
            tester.gripper_clear()
        else:
            tester.gripper_status()
    elif a == "monitor":
        tester.monitor(args.seconds, args.refresh)
    elif a == "status":
        tester.idle(0.05)
        tester.show()
    else:
        raise ParolkitValueError(f"unknown action {a!r}")


MENU = """\
board test: type an action (same syntax as the command line), e.g.
  jog --joint 3 --speed 1000 --seconds 2     out 1 on        inputs
  home                                       enable          disable        clear-error
  gripper calibrate    gripper move 200 100 400    gripper status    gripper clear
  monitor --seconds 5                        status          help           quit"""


def interactive(tester: BoardTester, read_line: Callable[[str], str] = input) -> int:
    """The menu loop: read an action per line until ``quit`` (or end of input)."""
    parser = argparse.ArgumentParser(prog="", add_help=False, exit_on_error=False)
    _add_actions(parser)
    tester.print(MENU)
    while True:
        try:
            line = read_line("board-test> ")
        except EOFError:
            return 0
        words = shlex.split(line)
        if not words:
            continue
        if words[0] in ("quit", "exit", "q"):
            return 0
        if words[0] in ("help", "?", "menu"):
            tester.print(MENU)
            continue
        try:
            args = parser.parse_args(words)
        except (argparse.ArgumentError, SystemExit) as exc:
            tester.print(f"error: {exc}" if isinstance(exc, argparse.ArgumentError)
                         else "error: see 'help'")
            continue
        if args.action is None:
            tester.print("error: unknown action; type 'help'")
            continue
        try:
            run_action(tester, args)
        except (ParolkitError, ValueError) as exc:
            tester.print(f"error: {exc}")


def main(args: argparse.Namespace) -> int:
    """Entry point of ``parolkit board-test``; returns the exit code."""
    from parolkit.transport import TransportError, open_transport, parse_transport_url

    try:
        url = parse_transport_url(args.port or "sim://")
        if args.speedup is not None and not url.simulated:
            print("board-test: --speedup applies to the simulated board (--sim) only; a real board "
                  "homes at its own pace", file=sys.stderr)
            return 2
        # flags given on the command line override the URL's options
        transport = open_transport(url, speedup=args.speedup, baud=args.baud)
    except (TransportError, ParolkitValueError) as exc:
        print(f"board-test: {exc}", file=sys.stderr)
        return 2
    try:
        tester = BoardTester(transport, rate_hz=args.rate)
        tester.print(f"board-test on {transport.description} at {args.rate:g} Hz")
        if args.action is None:
            tester.require_status()
            return interactive(tester)
        run_action(tester, args)
        return 0
    except ParolkitValueError as exc:
        print(f"board-test: {exc}", file=sys.stderr)
        return 2
    except (BoardTestError, TransportError) as exc:
        print(f"board-test: {exc}", file=sys.stderr)
        return 1
    finally:
        transport.close()  # every action already ended with idle frames
