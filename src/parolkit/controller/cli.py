"""``parolkit serve`` (also installed as ``headless-commander``).

Flags override the TOML config (defaults < TOML < flags)::

    parolkit serve [--sim | --port DEV] [--no-home] [--rate HZ] [--bind ADDR]
                   [--udp-port N] [--ack-port N] [--config FILE] [--sim-speedup X]
                   [--log-level LEVEL]

Prints ``parolkit controller listening on udp://HOST:PORT (board: ...)`` once it answers.
Ctrl-C / SIGTERM: motion stopped, a DISABLE frame sent, the port closed, exit code 0.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading

__all__ = ["register", "run", "build_overrides"]


def register(subparsers, name: str = "serve") -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        name, help="run the headless controller (UDP server + fixed-rate loop)",
        description="The PAROL6 headless controller: UDP text commands in, board frames out.",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--sim", action="store_true", help="in-process simulated board (default without --port)")
    src.add_argument("--port", metavar="DEV", help="serial device of the board, e.g. /dev/ttyACM0 or a board-sim pty")
    p.add_argument("--no-home", action="store_true", help="do not home the simulated board at start-up")
    p.add_argument("--rate", type=float, metavar="HZ", help="control loop rate in Hz (default 100)")
    p.add_argument("--bind", metavar="ADDR", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--udp-port", type=int, metavar="N", help="UDP command port (default 5001)")
    p.add_argument("--ack-port", type=int, metavar="N", help="UDP port acks are sent to (default 5002)")
    p.add_argument("--config", metavar="FILE", help="TOML configuration file")
    p.add_argument("--sim-speedup", type=float, metavar="X", help="homing time scale of the simulated board")
    p.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"],
                   help="log level (default INFO)")
    p.set_defaults(func=run)
    return p


def build_overrides(args: argparse.Namespace) -> dict:
    """CLI flags as a config override table (None = not given)."""
    ctl = {
        "rate_hz": args.rate,
        "bind": args.bind,
        "udp_port": args.udp_port,
        "ack_port": args.ack_port,
        "sim_homing_speedup": args.sim_speedup,
    }
    if args.no_home:
        ctl["home_on_start"] = False
    out: dict = {"controller": ctl}
    if args.port:
        out["serial"] = {"port": args.port}
    return out


def run(args: argparse.Namespace) -> int:
    logging.basicConfig(
        level=getattr(logging, args.log_level), stream=sys.stderr,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    log = logging.getLogger("parolkit.controller")
    # a short GIL switch interval keeps the tick on time while other threads compute
    sys.setswitchinterval(0.0005)
    from parolkit.config import load_config
    from parolkit.errors import ParolkitError

    try:
        cfg = load_config(args.config, build_overrides(args))
    except ParolkitError as exc:
        print(f"parolkit serve: {exc}", file=sys.stderr)
        return 2
    if args.sim and cfg.serial.port is not None:
        import dataclasses

        cfg = dataclasses.replace(cfg, serial=dataclasses.replace(cfg.serial, port=None))
    from parolkit.controller.app import Controller

    ctl = Controller(cfg)
    stop = threading.Event()

    def on_signal(signum, frame):  # noqa: ARG001
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    try:
        host, port = ctl.bind()
    except OSError as exc:
        print(f"parolkit serve: cannot listen on {cfg.controller.bind}:{cfg.controller.udp_port}: {exc}",
              file=sys.stderr)
        return 2
    try:
        ctl.start()
    except ParolkitError as exc:
        print(f"parolkit serve: {exc}", file=sys.stderr)
        ctl.stop()
        return 2
    print(f"parolkit controller listening on udp://{host}:{port} (board: {ctl.board_description}, "
          f"{ctl.rate_hz:g} Hz, acks to port {cfg.controller.ack_port})", flush=True)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        log.info("shutting down: stopping motion, disabling the robot, closing the port")
        ctl.stop()
    return 0


def main(argv: list[str] | None = None) -> int:
    """``headless-commander [flags]``: the same as ``parolkit serve [flags]``."""
    from parolkit.cli import main as parolkit_main

    return parolkit_main(["serve", *(sys.argv[1:] if argv is None else argv)])
