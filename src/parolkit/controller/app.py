"""Wiring: one :class:`Controller` = the core, its driver (transport, supervisor, planner) and
the UDP server.

Data flows one way: the server hands parsed commands to the tick through a
:class:`~parolkit.controller.inbox.CommandInbox`; the driver returns each tick's
:class:`~parolkit.controller.core.TickOutput`, which :meth:`Controller._publish` stores (the
snapshot) before it sends the acks.  The server reads the latest snapshot; it never waits for
a tick and never calls into the core.

Start-up order keeps the first PONG fast: bind the UDP socket and start answering first
(PING works before the board link is up), then open the board link and start the tick; the
motion/kinematics imports happen in the planner, off the start-up path.
"""

from __future__ import annotations

import logging
import socket
import sys
import threading
import time
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import Any

from parolkit.config import Config
from parolkit.controller.core import ControllerCore, TickOutput
from parolkit.controller.driver import Driver
from parolkit.controller.inbox import CommandInbox
from parolkit.controller.lease import ControlLease, is_loopback
from parolkit.controller.messages import Submission
from parolkit.controller.planning import PlanRequest, needs_plan
from parolkit.controller.server import Outbox, StatusStream, UdpServer
from parolkit.controller.snapshot import SNAPSHOT_QUERIES, BoardInfo, RobotState, Snapshot
from parolkit.controller.steering import CommandPort, open_command_port
from parolkit.controller.supervisor import StopSupervisor
from parolkit.protocol import commands as C
from parolkit.protocol.commands import dumps
from parolkit.protocol.frames import StatusFrame
from parolkit.transport.base import Transport
from parolkit.transport.url import parse_transport_url

__all__ = ["Controller", "is_loopback"]

log = logging.getLogger("parolkit.controller")


class Controller:
    """The headless controller.  ``start()``, then ``stop()`` (or use as a context manager).

    ``transport``: an open :class:`~parolkit.transport.base.Transport`; None opens the one
    the config names (``serial.port``; None = the in-process emulator).
    """

    def __init__(self, config: Config, *, transport: Transport | None = None,
                 home_on_start: bool | None = None) -> None:
        self.config = config
        cs = config.controller
        self.rate_hz = float(cs.rate_hz)
        self._transport = transport
        self.home_on_start = cs.home_on_start if home_on_start is None else home_on_start
        self._kin: tuple[ModuleType, ModuleType] | None = None
        self.started_at = time.monotonic()
        self.sock: socket.socket | None = None
        #: the command port's safety socket (:mod:`parolkit.controller.steering`), None: none
        self.safety_sock: socket.socket | None = None
        self.outbox: Outbox
        self.core: ControllerCore
        self.loop: Driver | None = None
        #: keys of the plans the server asks for ahead of the tick (negative: a job's own plan
        #: is keyed by its number)
        self._ahead_keys = 0
        self._ahead_lock = threading.Lock()
        self.server: UdpServer
        self.stream: StatusStream
        self._snapshot: Snapshot | None = None
        self.inbox = CommandInbox()
        self._stopped = threading.Event()
        #: the board link's URL (``serial.port``; ``sim://`` without one), with the config's
        #: baud rate and simulated homing speed-up as defaults the URL may override
        self.link_url = parse_transport_url(config.serial.port or "sim://").with_options(
            defaults={"baud": config.serial.baud, "speedup": cs.sim_homing_speedup})
        self.board_description = "emulated board" if self.link_url.simulated else str(config.serial.port)

    # ------------------------------------------------------------------ lifecycle

    def bind(self, port: CommandPort | None = None) -> tuple[str, int]:
        """Bind the command port (or adopt ``port``, already bound); returns (host, port)."""
        cs = self.config.controller
        if port is None:
            port = open_command_port(cs.bind, cs.udp_port)
        self.sock, self.safety_sock = port.sock, port.safety
        if port.safety is None:
            log.warning("no safety socket: %s; a stop waits behind every datagram before it", port.why_not)
        if not is_loopback(cs.bind):
            log.warning(
                "binding %s: the controller is reachable from the network and has no "
                "authentication; anyone who can send UDP to it can move the robot", cs.bind)
            print(f"WARNING: listening on {cs.bind}, not loopback: anyone on the network can move the robot",
                  file=sys.stderr, flush=True)
        host, number = self.sock.getsockname()[:2]
        return str(host), int(number)

    def start(self) -> None:
        if self.sock is None:
            self.bind()
        assert self.sock is not None
        self.assemble_server(self.sock)
        self.outbox.start()
        self.server.start()  # PING answers from here on (GET_STATUS: SERIAL=0 until the link is up)
        self.stream.start()
        transport = self._transport
        if transport is None:
            from parolkit.transport import open_transport

            transport = open_transport(self.link_url)
        elif not transport.is_open:
            transport.open()
        loop = self.assemble_driver(transport)
        loop.start()
        threading.Thread(target=self._warm_up, name="parolkit-warmup", daemon=True).start()
        self.home_if_simulated(transport)

    def assemble_server(self, sock: socket.socket) -> None:
        """Build the core, the outbox, the status stream and the UDP server on ``sock``; no
        thread started (:meth:`start` starts them; an in-process driver such as
        :class:`~parolkit.controller.fastforward.InProcessController` calls them itself)."""
        cs = self.config.controller
        safety = self.safety_sock if sock is self.sock else None  # (bound by :meth:`bind`)
        self.sock = sock
        self.outbox = Outbox(sock)
        self.core = ControllerCore(
            model=self.config.robot, rate_hz=self.rate_hz, queue_size=cs.queue_size,
            watchdog_s=cs.stream_watchdog_s, link_timeout_ticks=cs.link_timeout_ticks,
            link_hold_frames=cs.link_hold_frames, homing_timeout_s=max(10.0, 180.0 / self._homing_speedup()),
            homing_speedup=self._homing_speedup(), unhomed_jog_travel_deg=cs.unhomed_jog_travel_deg,
            pose_provider=self._pose_provider, config=self.config,
            servo_timeout_s=self.config.servo.timeout_s,
        )
        self.stream = StatusStream(sock)
        self.server = UdpServer(sock, model=self.config.robot, inbox=self.inbox, outbox=self.outbox,
                                stream=self.stream, answerer=self, ack_port=cs.ack_port,
                                lease=ControlLease(cs.lease_timeout_s, cs.secret), safety_sock=safety)

    def assemble_driver(self, transport: Transport, *, plan_inline: bool = False) -> Driver:
        """The driver around the open ``transport`` (not started).  ``plan_inline``: plans are
        made in the tick that asks (no planner thread, no stop supervisor: fast-forward)."""
        cs = self.config.controller
        self.board_description = transport.description
        self.loop = Driver(
            self.core, transport, realtime_priority=cs.realtime_priority, inbox=self.inbox, publish=self._publish,
            supervisor=(StopSupervisor(cs.period_s, cs.supervisor_stall_s, priority=cs.supervisor_priority)
                        if cs.supervisor and not plan_inline else None),
            server_view=self.server.overload_view, plan_inline=plan_inline,
            safety_intake=self.server.read_safety_socket,
        )
        return self.loop

    def home_if_simulated(self, transport: Transport) -> None:
        """A simulated board homes first when the config says so (a HOME in the inbox)."""
        if self.home_on_start and getattr(transport, "simulated", False):
            self.inbox.put(Submission(C.Home(), None, None, ("controller", 0)))

    def _homing_speedup(self) -> float:
        """How much faster than the real board the simulated board homes (1 for a real one)."""
        url = self.link_url
        return float(url.get("speedup", 1.0) or 1.0) if url.simulated else 1.0  # type: ignore[arg-type]

    def stop(self) -> None:
        """Stop motion, send a DISABLE frame, close the port, stop the threads."""
        if self._stopped.is_set():
            return
        self._stopped.set()
        if self.loop is not None:
            self.loop.stop()
        self.server.stop()
        self.stream.stop()
        if self.loop is not None:
            self.outbox.send_acks(self.loop.take_acks())  # the shutdown's CANCELLED acks
        self.outbox.flush(0.5)
        self.outbox.stop()
        for sock in (self.sock, self.safety_sock):
            if sock is not None:
                sock.close()

    def __enter__(self) -> Controller:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ tools / kinematics

    def _kinematics(self) -> tuple[ModuleType, ModuleType]:
        if self._kin is None:
            import importlib

            fk = importlib.import_module("parolkit.kinematics.fk")
            tools = importlib.import_module("parolkit.kinematics.tools")
            self._kin = (fk, tools)
        return self._kin

    def _warm_up(self) -> None:
        """Import kinematics and compute one pose off the start-up path."""
        try:
            self._pose_provider(self.config.robot.standby_deg, self.snapshot.tool)
        except Exception as exc:
            log.warning("kinematics warm-up failed: %s", exc)

    def tool(self) -> object:
        """The current tool object (kinematics), resolved by name (the snapshot's)."""
        return self.resolve_tool(self.snapshot.tool)

    def resolve_tool(self, name: str) -> object:
        """The kinematics tool called ``name`` (config ``[tools.NAME]`` or built in)."""
        _, tools = self._kinematics()
        return tools.get_tool(name, self.config)

    def plan_ahead(self, command: C.Command) -> int | None:
        """(server thread) Start planning a motion command that reaches an idle robot now, from
        the latest snapshot (the measured joints, the tool), so the move can start at the tick
        that takes the command in; the key of that plan, or None when the robot is not idle
        (the core plans it as usual).  The core uses the plan only if the robot and the tool
        are still where it assumed."""
        s = self.snapshot
        loop = self.loop
        if (loop is None or not needs_plan(command) or s.stream_mode or s.command is not None or s.queue
                or not all(s.homed) or not s.enabled or s.estop_latched or not s.board.connected):
            return None
        try:
            tool = self.resolve_tool(s.tool)
        except Exception:
            return None
        with self._ahead_lock:
            self._ahead_keys -= 1
            key = self._ahead_keys
        loop.plan_ahead(PlanRequest(key, command, tuple(s.angles_deg), s.tool, tool, self.rate_hz,
                                    self.config.robot, world=s.collision.world, speed_pct=s.speed_pct))
        return key

    def _pose_provider(self, angles: Sequence[float], tool_name: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        fk, tools = self._kinematics()
        tool = tools.get_tool(tool_name, self.config)
        m = fk.fk_matrix(list(angles), tool)
        pose = fk.fk(list(angles), tool)
        return tuple(float(v) for v in pose), tuple(float(v) for v in m.ravel())

    # ------------------------------------------------------------------ publication

    def _publish(self, out: TickOutput) -> None:
        """(loop thread) The tick's snapshot first, then its acks: a client that reads the
        status after an ack always sees what the ack reported."""
        # (None: a tick without one, which the driver builds when it is first read)
        self._snapshot = out.snapshot
        if out.acks:
            self.outbox.send_acks(out.acks)
            self.server.commands_ended(out.acks)
        if self.stream.subscribed:
            self.stream.notify(self.snapshot)

    @property
    def _spd(self) -> tuple[float, ...]:
        v = getattr(self, "_spd_cache", None)
        if v is None:
            v = tuple(float(x) for x in self.config.robot.steps_per_deg)
            self._spd_cache = v
        return v

    def _loop_dict(self) -> Mapping[str, Any]:
        if self.loop is None:
            return {}
        return self.loop.loop_view()

    @property
    def snapshot(self) -> Snapshot:
        s = self._snapshot
        if s is None and self.loop is not None:
            s = self.loop.snapshot_now()  # (built once, kept by the driver until its next tick)
        if s is None:
            # before the first tick: a neutral snapshot (link down)
            s = Snapshot(
                seq=0, time=0.0, state=RobotState.DISCONNECTED, enabled=True, estop_pressed=False,
                estop_latched=False, status=StatusFrame(), board=BoardInfo(False, self.link_url.simulated,
                                                                           self.board_description),
                error=None, command=None, queue=0, stream_mode=False, tool="default", plan_seq=0,
                outputs=(False, False), steps_per_deg=self._spd, pose_provider=self._pose_provider,
                loop=self._loop_dict(),
            )
        return s

    # ------------------------------------------------------------------ queries

    def busy(self) -> bool:
        s = self.snapshot
        return s.command is not None or s.queue > 0

    def answer_query(self, name: str, viewer: str | None = None) -> str:
        if name in SNAPSHOT_QUERIES:
            return self.snapshot.reply(name)
        s = self.snapshot
        if name == "GET_LOOP_STATS":
            return s.reply_loop_stats({"datagrams_received": self.server.received,
                                       "datagrams_invalid": self.server.invalid,
                                       "uptime_s": round(time.monotonic() - self.started_at, 3)})
        if name == "GET_PLAN":
            try:
                tool = self.resolve_tool(s.tool)
            except Exception:
                tool = None
            return "PLAN|" + dumps(s.plan.as_dict(tool))
        if name == "GET_TOOL":
            try:
                pose = self.resolve_tool(s.tool).pose  # type: ignore[attr-defined]
                return f"TOOL|{s.tool}|" + C.format_floats(pose)
            except Exception as exc:
                return C.format_error(f"GET_TOOL: {exc}")
        if name == "GET_QUEUE":
            return s.reply_queue(viewer)
        return C.format_error(f"unknown query {name}")
