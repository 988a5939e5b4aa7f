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
import socket
import sys
import threading

from parolkit._shutdown import ShutdownRequest
from parolkit.controller.steering import CommandPort, open_command_port

__all__ = ["register", "run", "build_overrides"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser],
             name: str = "serve") -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        name, help="run the headless controller (UDP server + fixed-rate loop)",
        description="The PAROL6 headless controller: UDP text commands in, board frames out.",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--sim", action="store_true", help="in-process simulated board (default without --port)")
    src.add_argument("--port", metavar="DEV",
                     help="the board link: a serial device (/dev/ttyACM0, a board-sim pty) or a "
                          "transport URL (sim://, 'spy+/dev/ttyACM0?log=frames.log', "
                          "'faulty+sim://?drop=0.01'; see docs/transport.md)")
    p.add_argument("--no-home", action="store_true", help="do not home the simulated board at start-up")
    p.add_argument("--rate", type=float, metavar="HZ", help="control loop rate in Hz (default 100)")
    p.add_argument("--bind", metavar="ADDR", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--udp-port", type=int, metavar="N", help="UDP command port (default 5001)")
    p.add_argument("--ack-port", type=int, metavar="N", help="UDP port acks are sent to (default 5002)")
    p.add_argument("--config", metavar="FILE", help="TOML configuration file")
    p.add_argument("--sim-speedup", type=float, metavar="X", help="homing time scale of the simulated board")
    p.add_argument("--stream-watchdog", type=float, metavar="S",
                   help="stop a streamed jog this long after its last update, s (default 0.02)")
    p.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"],
                   help="log level (default INFO)")
    p.set_defaults(func=run)
    return p


def build_overrides(args: argparse.Namespace) -> dict[str, dict[str, object]]:
    """CLI flags as a config override table (None = not given)."""
    ctl: dict[str, object] = {
        "rate_hz": args.rate,
        "bind": args.bind,
        "udp_port": args.udp_port,
        "ack_port": args.ack_port,
        "sim_homing_speedup": args.sim_speedup,
        "stream_watchdog_s": args.stream_watchdog,
    }
    if args.no_home:
        ctl["home_on_start"] = False
    out: dict[str, dict[str, object]] = {"controller": ctl}
    if args.port:
        out["serial"] = {"port": args.port}
    return out


def _early_address(args: argparse.Namespace) -> tuple[str | None, int]:
    """(bind, udp_port) from the flags and the TOML file, read without the config module.

    Returns ``(None, 0)`` when the file cannot be read here (the full loader then reports it).
    """
    from parolkit.config import find_config_file  # light: no numpy until a Config is built

    bind, port = "127.0.0.1", 5001
    try:
        path = find_config_file(args.config)
    except ValueError:
        return None, 0
    if path is not None:
        try:
            import tomllib

            ctl = tomllib.loads(path.read_text(encoding="utf-8")).get("controller", {})
            bind = ctl.get("bind", bind)
            port = ctl.get("udp_port", port)
        except Exception:
            return None, 0
    if args.bind:
        bind = args.bind
    if args.udp_port is not None:
        port = args.udp_port
    if not isinstance(bind, str) or isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        return None, 0
    return bind, port


class EarlyPong(threading.Thread):
    """Answers PING with ``PONG`` while the rest of the controller is still loading.

    Only a datagram that is exactly ``PING`` is taken off the socket (peeked first); anything
    else stays queued in the socket for the real server, which takes over the same socket.
    """

    def __init__(self, port: CommandPort) -> None:
        super().__init__(name="parolkit-early-pong", daemon=True)
        self.port = port
        self.sock = port.sock
        self._done = threading.Event()

    def run(self) -> None:
        self.sock.settimeout(0.02)
        while not self._done.is_set():
            try:
                data, addr = self.sock.recvfrom(64, socket.MSG_PEEK)
            except (TimeoutError, BlockingIOError):
                continue
            except OSError:
                return
            if data.strip() == b"PING":
                try:
                    self.sock.recvfrom(64)
                    self.sock.sendto(b"PONG", addr)
                except OSError:
                    pass
            else:
                self._done.wait(0.005)  # a command waits in the socket for the real server

    def stop(self) -> None:
        self._done.set()
        self.join(1.0)

    def close(self) -> None:
        """Close the port's sockets (the controller did not take them over)."""
        self.port.close()


def run(args: argparse.Namespace) -> int:
    logging.basicConfig(
        level=getattr(logging, args.log_level), stream=sys.stderr,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    log = logging.getLogger("parolkit.controller")
    # a short GIL switch interval keeps the tick on time while other threads compute, and lets
    # the server thread answer a datagram without waiting out another thread's slice
    # (bench/controller.py, 100 Hz: query p99 0.67-0.86 ms at 0.1 ms, 1.24-1.29 ms at 0.5 ms)
    sys.setswitchinterval(0.0001)
    shutdown = ShutdownRequest().install()
    # Listen (and answer PING) before the heavy imports: numpy alone can take most of the
    # 1.5 s start-up budget on a busy machine.
    bind, udp_port = _early_address(args)
    port = None
    if bind is not None:
        try:
            port = open_command_port(bind, udp_port)
        except OSError as exc:
            print(f"parolkit serve: cannot listen on {bind}:{udp_port}: {exc}", file=sys.stderr)
            return 2
    early = EarlyPong(port) if port is not None else None
    if early is not None:
        early.start()

    from parolkit.config import load_config
    from parolkit.errors import ParolkitError

    try:
        cfg = load_config(args.config, build_overrides(args))
    except ParolkitError as exc:
        print(f"parolkit serve: {exc}", file=sys.stderr)
        if early is not None:
            early.stop()
            early.close()
        return 2
    if args.sim and cfg.serial.port is not None:
        import dataclasses

        cfg = dataclasses.replace(cfg, serial=dataclasses.replace(cfg.serial, port=None))
    cs = cfg.controller
    if early is None or (bind, udp_port) != (cs.bind, cs.udp_port):
        if early is not None:
            early.stop()
            early.close()
        try:
            port = open_command_port(cs.bind, cs.udp_port)
        except OSError as exc:
            print(f"parolkit serve: cannot listen on {cs.bind}:{cs.udp_port}: {exc}", file=sys.stderr)
            return 2
        early = EarlyPong(port)
        early.start()
    from parolkit.controller.app import Controller

    ctl = Controller(cfg)
    early.stop()
    host, number = ctl.bind(early.port)
    try:
        ctl.start()
    except ParolkitError as exc:
        print(f"parolkit serve: {exc}", file=sys.stderr)
        ctl.stop()
        return 2
    print(f"parolkit controller listening on udp://{host}:{number} (board: {ctl.board_description}, "
          f"{ctl.rate_hz:g} Hz, acks to port {cfg.controller.ack_port})", flush=True)
    try:
        shutdown.wait()
    finally:
        log.info("shutting down: stopping motion, disabling the robot, closing the port")
        ctl.stop()
    return 0


def main(argv: list[str] | None = None) -> int:
    """``headless-commander [flags]``: the same as ``parolkit serve [flags]``."""
    from parolkit.cli import main as parolkit_main

    return parolkit_main(["serve", *(sys.argv[1:] if argv is None else argv)])
