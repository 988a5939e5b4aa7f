"""``parolkit gui``: start (or connect to) a controller and serve the commander.

    parolkit gui [--sim | --port /dev/ttyACM0 | --connect HOST:PORT] [--http-port 8080]
                 [--host 127.0.0.1] [--programs-dir DIR] [--recordings-dir DIR] [--no-browser]

With ``--sim`` (the default) or ``--port`` a ``parolkit serve`` subprocess is started on
free UDP ports and stopped with the GUI.  ``--connect`` uses a running controller.  The GUI
receives its acks on its own socket (``ACK_HERE``), never on the controller's ack port
(``--ack-port`` only sets that port for a controller the GUI starts).

The web server answers only its own names (``Host`` / ``Origin`` allow-list), asks for
``gui.password`` whenever one is set, and refuses to start beyond loopback without one
(:mod:`parolkit.gui.security`); Open / Save use only the programs folder
(:mod:`parolkit.gui.programs`), Record and the recordings list only the recordings folder
(:mod:`parolkit.gui.recordings`).
"""

from __future__ import annotations

import argparse
import faulthandler
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from parolkit.client.launch import free_udp_port, stop_process

if TYPE_CHECKING:
    from parolkit.client.robot import Robot

__all__ = ["register", "main", "parse_host_port", "start_controller_process"]


def parse_host_port(text: str) -> tuple[str, int]:
    """'HOST:PORT' -> (host, port); raises argparse.ArgumentTypeError naming the problem."""
    host, sep, port = text.rpartition(":")
    if not sep or not host:
        raise argparse.ArgumentTypeError(f"--connect needs HOST:PORT (e.g. 127.0.0.1:5001), got {text!r}")
    try:
        p = int(port)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--connect port must be an integer 1..65535, got {port!r}") from None
    if not 1 <= p <= 65535:
        raise argparse.ArgumentTypeError(f"--connect port must be in 1..65535, got {p}")
    return host, p


def _port(text: str) -> int:
    try:
        p = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"port must be an integer 1..65535, got {text!r}") from None
    if not 1 <= p <= 65535:
        raise argparse.ArgumentTypeError(f"port must be in 1..65535, got {p}")
    return p


def _view_fps(text: str) -> float:
    from parolkit.config import check_view_fps
    from parolkit.errors import ParolkitValueError

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--view-fps must be a number of frames per second, got {text!r}") from None
    try:
        return check_view_fps(value, "--view-fps")
    except ParolkitValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser],
             name: str = "gui") -> argparse.ArgumentParser:
    p = subparsers.add_parser(name, help="start the browser commander",
                              description="Start the PAROL6 browser commander (3D simulator, jog, IO, "
                                          "gripper, RBTscript editor).")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--sim", action="store_true", help="start a controller with the simulated robot (default)")
    src.add_argument("--port", metavar="DEV",
                     help="start a controller on this board link: a serial device (real robot) "
                          "or a transport URL (see docs/transport.md)")
    src.add_argument("--connect", metavar="HOST:PORT", type=parse_host_port, help="use a running controller")
    p.add_argument("--ack-port", type=_port, default=None,
                   help="ack port of a controller the GUI starts (default: a free port); the GUI itself gets its "
                        "acks on its own socket (ACK_HERE), so with --connect this is informational only")
    p.add_argument("--http-port", type=_port, default=None, help="HTTP port of the GUI (default from config: 8080)")
    p.add_argument("--host", default=None,
                   help="address the GUI binds (default 127.0.0.1); anything beyond loopback exposes robot control "
                        "to the network and needs gui.password in the config")
    p.add_argument("--programs-dir", type=Path, default=None, metavar="DIR",
                   help="the only folder Open / Save use (default gui.programs_dir, else "
                        "~/.local/share/parolkit/programs); created if missing")
    p.add_argument("--recordings-dir", type=Path, default=None, metavar="DIR",
                   help="the only folder Record writes and the recordings list reads (default "
                        "gui.recordings_dir, else ~/.local/share/parolkit/recordings); created by the first recording")
    p.add_argument("--view-fps", type=_view_fps, default=None, metavar="HZ",
                   help="the 3D view's frame rate while the arm moves, 1..60 (default gui.view_fps, else 30); "
                        "lower it for browsers that draw without a GPU")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    p.add_argument("--config", type=Path, default=None, help="parolkit.toml to use")
    p.set_defaults(func=main)
    return p


def _answers_ping(robot: Robot) -> bool:
    """True when the controller behind ``robot`` (a client :class:`Robot`) answers PING
    (with its board link up or not)."""
    from parolkit.client.errors import RobotError

    try:
        robot.ping()
    except RobotError:
        return False
    return True


#: Stream watchdog (s) of a controller the GUI starts itself.  The GUI's jog stream is sent
#: from an asyncio loop every 10 ms; on a busy machine its jitter exceeds the controller's
#: 20 ms default and a held jog would stutter.  Release sends STOP at once, so this only
#: bounds how long motion continues if the GUI process itself stalls.
GUI_STREAM_WATCHDOG_S = 0.15
#: On SIGTERM / Ctrl+C, open pages get this long (s) to close before the web server stops anyway.
GRACEFUL_SHUTDOWN_S = 3.0


def start_controller_process(serial_port: str | None, udp_port: int, ack_port: int,
                             config: Path | None = None, ready_timeout: float = 20.0) -> subprocess.Popen[bytes]:
    """Start ``parolkit serve`` and wait until it answers PING; raises RuntimeError otherwise.

    Its stream watchdog is :data:`GUI_STREAM_WATCHDOG_S` (the flag wins over ``config``): the
    GUI's jog cadence for a controller of its own is made for it."""
    from parolkit.client.launch import spawn_controller
    from parolkit.client.robot import Robot

    args = ["--udp-port", str(udp_port), "--ack-port", str(ack_port)]
    args += ["--port", serial_port] if serial_port else ["--sim"]
    args += ["--stream-watchdog", str(GUI_STREAM_WATCHDOG_S)]
    if config is not None:
        args += ["--config", str(config)]
    proc = spawn_controller(args)
    deadline = time.monotonic() + ready_timeout
    with Robot("127.0.0.1", udp_port, ack_port=0, timeout=0.2) as robot:
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                stop_controller_process(proc)
                raise RuntimeError(f"the controller exited with code {proc.returncode} (command: {' '.join(args)})")
            if _answers_ping(robot):
                return proc
    stop_controller_process(proc)
    raise RuntimeError(f"the controller did not answer PING within {ready_timeout:g} s")


def stop_controller_process(proc: subprocess.Popen[bytes]) -> None:
    """Terminate a controller started by :func:`start_controller_process` (SIGTERM: it stops
    motion and disables the robot), SIGKILL if it has not exited 10 s later."""
    stop_process(proc)


def main(args: argparse.Namespace) -> int:
    from parolkit.config import load_config

    try:
        cfg = load_config(args.config)
    except (OSError, ValueError) as exc:
        print(f"parolkit gui: {exc}", file=sys.stderr)
        return 2
    from parolkit.gui.programs import ProgramsFolder, default_programs_dir
    from parolkit.gui.recordings import RecordingsFolder, default_recordings_dir
    from parolkit.gui.security import AccessPolicy, LoginGate, is_loopback_bind

    http_port = args.http_port or cfg.gui.http_port
    host = args.host or cfg.gui.host
    password = cfg.gui.password
    teacher_password = cfg.gui.teacher_password  # a class: only the teacher's grant moves the robot
    if not is_loopback_bind(host):
        if password is None and teacher_password is None:
            print(f"parolkit gui: refusing to bind {host}: beyond loopback anyone who can reach this address "
                  "could move the robot; set a login password (gui.password, 8..256 characters; or "
                  "gui.teacher_password for a class, where only the teacher's grant moves it) in the config "
                  f"({cfg.source or 'parolkit.toml'}), or bind 127.0.0.1 and use an SSH tunnel",
                  file=sys.stderr)
            return 2
        print(f"WARNING: the commander binds {host}: the login password is all that stands between the network "
              "and the robot, and plain HTTP sends it unencrypted (use a TLS proxy or an SSH tunnel).",
              file=sys.stderr)
    programs = ProgramsFolder(args.programs_dir or cfg.gui.programs_dir or default_programs_dir())
    try:
        programs.create()
    except OSError as exc:
        print(f"parolkit gui: cannot create the programs folder {programs.root}: {exc}", file=sys.stderr)
        return 2
    recordings = RecordingsFolder(args.recordings_dir or cfg.gui.recordings_dir or default_recordings_dir())
    policy = AccessPolicy.for_bind(host, cfg.gui.allowed_hosts)

    from parolkit.gui.own_controller import OwnController

    own_ctl: OwnController | None = None
    if args.connect:
        ctl_host, ctl_port = args.connect
        ack_port = args.ack_port or 5002
        mode = f"controller {ctl_host}:{ctl_port}"
    else:
        ctl_host, ctl_port = "127.0.0.1", free_udp_port()
        ack_port = args.ack_port or free_udp_port()
        serial_port = args.port
        mode = f"REAL · {serial_port}" if serial_port else "SIMULATOR"
        print(f"starting controller ({'serial ' + serial_port if serial_port else 'simulated robot'}) "
              f"on UDP {ctl_port}, acks on {ack_port}", file=sys.stderr)
        own_ctl = OwnController(
            lambda: start_controller_process(serial_port, ctl_port, ack_port, args.config), stop_controller_process)
        try:
            own_ctl.start()
        except (RuntimeError, OSError) as exc:
            print(f"parolkit gui: {exc}", file=sys.stderr)
            return 1

    from nicegui import app, core, ui

    from parolkit.gui.app import build_app
    from parolkit.gui.class_service import ClassService
    from parolkit.gui.classroom import Classroom, turn_limit_s
    from parolkit.gui.commander import Commander
    from parolkit.gui.link import ControllerLink
    from parolkit.gui.security import SecurityMiddleware

    classroom = Classroom(turn_limit_s(cfg.gui.turn_minutes)) if teacher_password is not None else None
    login_gate = (LoginGate(password, teacher_password=teacher_password, classroom=classroom)
                  if password is not None or teacher_password is not None else None)
    link = ControllerLink(ctl_host, ctl_port, ack_port, every_n_ticks=2)  # 50 Hz status for a 30 fps view
    # our own controller has a 150 ms stream watchdog: 20 Hz jog updates are plenty; a
    # controller we connect to has its own (20 ms by default): send every control tick
    own = own_ctl is not None
    commander = Commander(link, mode_label=mode, programs=programs, recordings=recordings,
                          jog_repeat_s=0.05 if own else 0.01, cart_jog_repeat_s=0.1 if own else 0.01,
                          secret=cfg.controller.secret,
                          login=login_gate is not None, own_controller=own_ctl,
                          view_fps=args.view_fps or cfg.gui.view_fps)
    if classroom is not None:
        commander.classroom = ClassService(classroom, commander)
    root = build_app(commander)
    # every request and websocket: Host, Origin, login (gui/security.py); socket.io checks the
    # Origin of its handshakes against the same list (it would otherwise accept any)
    app.add_middleware(SecurityMiddleware, policy=policy, login=login_gate)
    core.sio.eio.cors_allowed_origins = policy.origin_allowed
    if hasattr(signal, "SIGUSR1"):  # `kill -USR1 PID` prints every thread's stack to stderr
        faulthandler.register(signal.SIGUSR1, all_threads=True)
    if own_ctl is not None:
        # uvicorn ends the process by re-raising SIGTERM / SIGINT after the app's shutdown
        # handlers, so the ``finally`` below is not reached then: stop the controller here
        # (after build_app's handler closed the link)
        app.on_shutdown(own_ctl.stop)
    print(f"parolkit commander on http://{host}:{http_port}/ (programs folder {programs.root}; recordings folder "
          f"{recordings.root}; answers the "
          f"names {', '.join(sorted(policy.allowed))}{'; login required' if login_gate else ''}"
          f"{'; a class: teacher and students' if classroom else ''})",
          file=sys.stderr, flush=True)
    try:
        ui.run(root, host=host, port=http_port, title="parolkit commander", reload=False,
               show=not args.no_browser, show_welcome_message=False, dark=True, favicon="🦾",
               language="en-US",  # <html lang="en-US">: screen readers pick the right voice
               reconnect_timeout=30.0,
               # SIGTERM / Ctrl+C: give open pages this long to close, then stop anyway (by
               # default uvicorn waits for every connection, forever if a browser froze)
               timeout_graceful_shutdown=GRACEFUL_SHUTDOWN_S)
    finally:
        if own_ctl is not None:
            own_ctl.stop()
    return 0
