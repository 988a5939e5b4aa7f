"""``parolkit board-sim``: an emulated PAROL6 board on a pseudo-terminal.

Serve::

    parolkit board-sim --link /tmp/p6 [--speedup N] [--estop-pressed] [--in1 0|1] [--in2 0|1]
                       [--gripper-object WIDTH_MM] [--control PATH] [--start-homed]
                       [--frame-log SIZE] [--exchange-log PATH]

Control a running one (the control socket defaults to ``LINK.ctl``)::

    parolkit board-sim --link /tmp/p6 --ctl "estop 1"
    parolkit board-sim --link /tmp/p6 --ctl status
    parolkit board-sim --link /tmp/p6 --ctl "frames last=5"     # needs --frame-log
"""

from __future__ import annotations

import argparse
import sys

from parolkit._shutdown import ShutdownRequest

__all__ = ["register", "run"]


def _bit(text: str) -> bool:
    if text in ("0", "1"):
        return text == "1"
    raise argparse.ArgumentTypeError(f"must be 0 or 1, got {text!r}")


def _speedup(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number in 1..1000, got {text!r}") from None
    if not 1.0 <= v <= 1000.0:
        raise argparse.ArgumentTypeError(f"must be in 1..1000, got {text}")
    return v


def _width(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a width in mm (0 < w < 48), got {text!r}") from None
    if not 0.0 < v < 48.0:
        raise argparse.ArgumentTypeError(f"must be 0 < width < 48 mm, got {text}")
    return v


def _frame_log_size(text: str) -> int:
    from parolkit.board.pty_server import FRAME_LOG_MAX

    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of frames 1..{FRAME_LOG_MAX}, got {text!r}") from None
    if not 1 <= v <= FRAME_LOG_MAX:
        raise argparse.ArgumentTypeError(f"must be 1..{FRAME_LOG_MAX} frames, got {text}")
    return v


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser], name: str) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        name,
        help="emulate a PAROL6 control board on a pseudo-terminal",
        description="Emulate a PAROL6 control board (stock firmware behaviour) on a pty whose "
        "path is --link; open it with pyserial at 3000000 baud like /dev/ttyACM0. "
        "With --ctl, send one control command to a running board-sim instead.",
    )
    p.add_argument("--link", required=True, metavar="PATH",
                   help="symlink to create, pointing at the pty (e.g. /tmp/p6)")
    p.add_argument("--speedup", type=_speedup, default=1.0, metavar="N",
                   help="homing time scale, 1..1000 (default 1 = real time, tens of seconds)")
    p.add_argument("--estop-pressed", action="store_true", help="start with the E-stop pressed")
    p.add_argument("--in1", type=_bit, default=False, metavar="0|1", help="initial IN1")
    p.add_argument("--in2", type=_bit, default=False, metavar="0|1", help="initial IN2")
    p.add_argument("--gripper-object", type=_width, default=None, metavar="WIDTH",
                   help="an object WIDTH mm wide sits between the gripper jaws")
    p.add_argument("--start-homed", action="store_true",
                   help="power up already homed (not stock; saves the homing run)")
    p.add_argument("--frame-log", type=_frame_log_size, default=0, metavar="SIZE",
                   help="keep the last SIZE command frames received, with their time.monotonic() "
                   "receive times, for the control command 'frames' (off by default)")
    p.add_argument("--exchange-log", metavar="PATH", default=None,
                   help="write one JSON line per command frame received (as sent) and per frame "
                   "executed (as executed, after injected faults) with the true status frame it "
                   "answered (before faults) to PATH (off by default; see docs/board-emulator.md)")
    p.add_argument("--control", metavar="PATH", default=None,
                   help="control socket path (default: LINK.ctl)")
    p.add_argument("--ctl", metavar="COMMAND", default=None,
                   help="send COMMAND to a running board-sim and print the reply "
                   "(estop 1, in1 1, object 30, unplug, replug, errors temp J3, faults ..., rewrite 101 100, status)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    from parolkit.board.control_channel import ControlError, ControlServer, send_control

    control_path = args.control or f"{args.link}.ctl"
    if args.ctl is not None:
        try:
            reply = send_control(control_path, args.ctl)
        except ControlError as exc:
            print(f"board-sim: {exc}", file=sys.stderr)
            return 1
        print(reply)
        return 0 if reply.startswith("ok") else 1

    from parolkit.board.emulator import BoardEmulator
    from parolkit.board.pty_server import PtyBoardServer, PtyServerError
    from parolkit.errors import ParolkitError

    try:
        emu = BoardEmulator(homing_speedup=args.speedup, estop_pressed=args.estop_pressed,
                            in1=args.in1, in2=args.in2, start_homed=args.start_homed)
        if args.gripper_object is not None:
            emu.place_object(args.gripper_object)
        server = PtyBoardServer(emu, args.link, frame_log_size=args.frame_log,
                                exchange_log=args.exchange_log)
        control = ControlServer(emu, control_path, frame_log=server.frame_log, rewrite=server.rewrite)
    except ParolkitError as exc:
        print(f"board-sim: {exc}", file=sys.stderr)
        return 2

    shutdown = ShutdownRequest().install()
    try:
        control.start()  # before the pty: once the link path exists, the control socket works
        server.start()
    except (PtyServerError, ControlError) as exc:
        control.stop()
        server.stop()
        print(f"board-sim: {exc}", file=sys.stderr)
        return 2
    print(f"board-sim: PAROL6 board on {args.link} -> {server.device} "
          f"(control: {control_path}; homing speedup {args.speedup:g})", flush=True)
    try:
        shutdown.wait()
    finally:
        control.stop()
        server.stop()
        emu.stop()
    print("board-sim: stopped", flush=True)
    return 0
