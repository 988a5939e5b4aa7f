"""Wiring: one :class:`Controller` = transport + executor + guard + loop + UDP server.

Start-up order keeps the first PONG fast: bind the UDP socket and start answering first
(PING works before the board link is up), then open the board link and start the loop; the
motion/kinematics imports happen in the planner thread, off the start-up path.
"""

from __future__ import annotations

import ipaddress
import logging
import socket
import sys
import threading
import time
from typing import Sequence

from parolkit.config import Config
from parolkit.controller.executor import Executor
from parolkit.controller.guard import SafetyGuard
from parolkit.controller.jobs import Job
from parolkit.controller.loop import ControlLoop
from parolkit.controller.server import Outbox, StatusStream, UdpServer
from parolkit.controller.state import BoardInfo, CommandInfo, RobotState, Snapshot
from parolkit.protocol import commands as C
from parolkit.protocol.commands import AckStatus, dumps, format_ack
from parolkit.protocol.frames import StatusFrame

__all__ = ["Controller", "is_loopback"]

log = logging.getLogger("parolkit.controller")


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and ``localhost``."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Controller:
    """The headless controller.  ``start()``, then ``stop()`` (or use as a context manager).

    ``transport``: an open :class:`~parolkit.transport.base.Transport`; None opens the one
    the config names (``serial.port``; None = the in-process emulator).
    """

    def __init__(self, config: Config, *, transport=None, home_on_start: bool | None = None) -> None:
        self.config = config
        cs = config.controller
        self.rate_hz = float(cs.rate_hz)
        self._transport = transport
        self.home_on_start = cs.home_on_start if home_on_start is None else home_on_start
        self.tool_name = "default"
        self._tool_obj: object | None = None
        self._kin = None
        self.started_at = time.monotonic()
        self.sock: socket.socket | None = None
        self.outbox: Outbox
        self.executor: Executor
        self.loop: ControlLoop | None = None
        self.server: UdpServer
        self.stream: StatusStream
        self._snapshot: Snapshot | None = None
        self._publish_lock = threading.Lock()
        self._tick_holds_acks = False  # the loop thread owns it (stop() only after the loop ended)
        self._stopped = threading.Event()
        self.board_description = "emulated board" if config.serial.simulated else str(config.serial.port)

    # ------------------------------------------------------------------ lifecycle

    def bind(self, sock: socket.socket | None = None) -> tuple[str, int]:
        """Bind the command socket (or adopt ``sock``, already bound); returns (host, port)."""
        cs = self.config.controller
        if sock is not None:
            self.sock = sock
        else:
            fam = socket.AF_INET6 if ":" in cs.bind else socket.AF_INET
            self.sock = socket.socket(fam, socket.SOCK_DGRAM)
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
            self.sock.bind((cs.bind, cs.udp_port))
        if not is_loopback(cs.bind):
            log.warning(
                "binding %s: the controller is reachable from the network and has no "
                "authentication; anyone who can send UDP to it can move the robot", cs.bind)
            print(f"WARNING: listening on {cs.bind}, not loopback: anyone on the network can move the robot",
                  file=sys.stderr, flush=True)
        return self.sock.getsockname()[:2]

    def start(self) -> None:
        cs = self.config.controller
        if self.sock is None:
            self.bind()
        assert self.sock is not None
        self.outbox = Outbox(self.sock)
        self.executor = Executor(
            model=self.config.robot, rate_hz=self.rate_hz, queue_size=cs.queue_size,
            watchdog_s=cs.stream_watchdog_s, send_ack=self._send_ack, tool_provider=self.tool,
            homing_timeout_s=max(10.0, 180.0 / (cs.sim_homing_speedup if self.config.serial.simulated else 1.0)),
        )
        self.stream = StatusStream(self.sock, self)
        self.server = UdpServer(self, self.sock, cs.ack_port)
        self.outbox.start()
        self.server.start()  # PING answers from here on (SERIAL=0 until the link is up)
        self.stream.start()
        transport = self._transport
        if transport is None:
            from parolkit.transport import open_transport

            if self.config.serial.simulated:
                transport = open_transport(None, homing_speedup=cs.sim_homing_speedup)
            else:
                transport = open_transport(self.config.serial.port, baud=self.config.serial.baud)
        elif not transport.is_open:
            transport.open()
        self.board_description = transport.description
        guard = SafetyGuard(self.config.robot, self.rate_hz)
        self.loop = ControlLoop(
            transport=transport, executor=self.executor, guard=guard, rate_hz=self.rate_hz,
            link_timeout_ticks=cs.link_timeout_ticks, on_tick=self._on_tick,
        )
        self.executor.start()
        self.loop.start()
        threading.Thread(target=self._warm_up, name="parolkit-warmup", daemon=True).start()
        if self.home_on_start and getattr(transport, "simulated", False):
            self.executor.submit(self.executor.new_job(C.Home(), None, None))

    def stop(self) -> None:
        """Stop motion, send a DISABLE frame, close the port, stop the threads."""
        if self._stopped.is_set():
            return
        self._stopped.set()
        if self.loop is not None:
            self.loop.stop()
        self.executor.stop()
        self.server.stop()
        self.stream.stop()
        self._release_tick_acks()  # acks of a tick that ended without publishing (loop stopped)
        self.outbox.flush(0.5)
        self.outbox.stop()
        if self.sock is not None:
            self.sock.close()

    def __enter__(self) -> "Controller":
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ tools / kinematics

    def _kinematics(self):
        if self._kin is None:
            import importlib

            fk = importlib.import_module("parolkit.kinematics.fk")
            tools = importlib.import_module("parolkit.kinematics.tools")
            self._kin = (fk, tools)
        return self._kin

    def _warm_up(self) -> None:
        """Import kinematics and compute one pose off the start-up path."""
        try:
            self._pose_provider(self.config.robot.standby_deg, self.tool_name)
        except Exception as exc:
            log.warning("kinematics warm-up failed: %s", exc)

    def tool(self) -> object:
        """The current tool object (kinematics), resolved lazily."""
        if self._tool_obj is None:
            _, tools = self._kinematics()
            self._tool_obj = tools.get_tool(self.tool_name, self.config)
        return self._tool_obj

    def _pose_provider(self, angles: Sequence[float], tool_name: str):
        fk, tools = self._kinematics()
        tool = tools.get_tool(tool_name, self.config)
        m = fk.fk_matrix(list(angles), tool)
        pose = fk.fk(list(angles), tool)
        return tuple(float(v) for v in pose), tuple(float(v) for v in m.ravel())

    # ------------------------------------------------------------------ acks

    def _send_ack(self, job: Job, status: AckStatus, details: str) -> None:
        if status.terminal or status is AckStatus.EXECUTING:
            log.debug("job %d %s (%s): %s %s", job.seq, job.name, job.command_id, status.value, details)
        if job.command_id is None or job.ack_addr is None:
            if status in (AckStatus.FAILED,) and job.command_id is None:
                log.warning("%s failed: %s", job.name, details)
            return
        if not self._tick_holds_acks and self.loop is not None and self.loop.in_loop_thread():
            # an ack from the tick waits for the snapshot that _on_tick publishes at its end
            self.outbox.hold()
            self._tick_holds_acks = True
        self.outbox.put(format_ack(job.command_id, status, details), job.ack_addr)

    # ------------------------------------------------------------------ snapshot

    def _state(self, ex: Executor, loop: ControlLoop) -> RobotState:
        if not loop.link_up or loop.status is None:
            return RobotState.DISCONNECTED
        if ex.estop_latched or ex.estop_pressed:
            return RobotState.ESTOP
        if not ex.enabled:
            return RobotState.DISABLED
        a = ex.active
        if a is not None:
            if isinstance(a.command, C.Home):
                return RobotState.HOMING
            if a.command.is_motion:
                return RobotState.MOVING
        if ex.error:
            return RobotState.ERROR
        return RobotState.IDLE

    def _on_tick(self, loop: ControlLoop) -> None:
        try:
            self.publish()
        finally:
            self._release_tick_acks()
        self.stream.notify(loop.tick_count)

    def _release_tick_acks(self) -> None:
        if self._tick_holds_acks:
            self._tick_holds_acks = False
            self.outbox.release()

    def publish(self) -> None:
        """Build the status snapshot queries answer from. Called after every tick and after a
        datagram changed the executor; built under a lock, so the last one published has seen
        every change made before it was built."""
        loop = self.loop
        if loop is None:
            return
        with self._publish_lock:
            ex = self.executor
            a = ex.active
            act = ex.activity
            info = CommandInfo(a.command_id, a.name, act.progress if act else 0.0) if a is not None else None
            self._snapshot = Snapshot(
                seq=loop.tick_count, time=time.monotonic() - loop.start_time, state=self._state(ex, loop),
                enabled=ex.enabled, estop_pressed=ex.estop_pressed, estop_latched=ex.estop_latched,
                status=loop.status or loop.last_status,
                board=BoardInfo(loop.link_up and loop.status is not None,
                                bool(getattr(loop.transport, "simulated", False)), loop.transport.description),
                error=ex.error, command=info, queue=len(ex.queue), stream_mode=ex.stream_mode,
                tool=self.tool_name, plan_seq=ex.plan_seq, outputs=(ex.outputs[0], ex.outputs[1]),
                steps_per_deg=self._spd, pose_provider=self._pose_provider, loop_view=self._loop_dict,
            )

    @property
    def _spd(self) -> tuple[float, ...]:
        v = getattr(self, "_spd_cache", None)
        if v is None:
            v = tuple(float(x) for x in self.config.robot.steps_per_deg)
            self._spd_cache = v
        return v

    def _loop_dict(self) -> dict:
        if self.loop is None:
            return {}
        return self.loop.stats.view(max_age_s=0.25).as_dict()

    @property
    def snapshot(self) -> Snapshot:
        s = self._snapshot
        if s is None:
            # before the first tick: a neutral snapshot (link down)
            s = Snapshot(
                seq=0, time=0.0, state=RobotState.DISCONNECTED, enabled=True, estop_pressed=False,
                estop_latched=False, status=StatusFrame(), board=BoardInfo(False, self.config.serial.simulated,
                                                                           self.board_description),
                error=None, command=None, queue=0, stream_mode=False, tool=self.tool_name, plan_seq=0,
                outputs=(False, False), steps_per_deg=self._spd, pose_provider=self._pose_provider,
                loop_view=self._loop_dict,
            )
        return s

    # ------------------------------------------------------------------ queries

    def answer_query(self, name: str) -> str:
        s = self.snapshot
        if name == "PING":
            return s.reply_ping()
        if name == "GET_ANGLES":
            return s.reply_angles()
        if name == "GET_POSE":
            return s.reply_pose()
        if name == "GET_IO":
            return s.reply_io()
        if name == "GET_GRIPPER":
            return s.reply_gripper()
        if name == "GET_SPEEDS":
            return s.reply_speeds()
        if name == "GET_STATUS":
            return s.reply_status()
        if name == "GET_STATUS_JSON":
            return s.reply_status_json()
        if name == "GET_LOOP_STATS":
            extra = self._loop_dict()
            extra["guard_replaced_frames"] = self.loop.guard.replaced_frames if self.loop else 0
            extra["guard_violations"] = self.loop.guard.violations if self.loop else 0
            extra["planned"] = self.executor.planned_count
            extra["plan_time_total_s"] = round(self.executor.plan_time_s, 4)
            extra["datagrams_received"] = self.server.received
            extra["datagrams_invalid"] = self.server.invalid
            extra["uptime_s"] = round(time.monotonic() - self.started_at, 3)
            return "LOOP_STATS|" + dumps(extra)
        if name == "GET_PLAN":
            try:
                tool = self.tool()
            except Exception:
                tool = None
            return "PLAN|" + dumps(self.executor.plan_view(tool))
        if name == "GET_TOOL":
            try:
                pose = self.tool().pose  # type: ignore[attr-defined]
                return f"TOOL|{self.tool_name}|" + C.format_floats(pose)
            except Exception as exc:
                return C.format_error(f"GET_TOOL: {exc}")
        if name == "GET_QUEUE":
            return "QUEUE|" + dumps(self.executor.queue_view())
        return C.format_error(f"unknown query {name}")

    # ------------------------------------------------------------------ immediate commands

    def immediate(self, cmd: C.Command, addr: tuple[str, int]) -> tuple[AckStatus, str]:
        """Apply an immediate command; returns the ack status and details for its ID."""
        ex = self.executor
        # wait for the loop to apply them (a few ticks at most) so the ack means "done"
        wait_s = max(0.5, 10.0 / self.config.controller.rate_hz)

        def apply(action, ok_details: str) -> tuple[AckStatus, str]:
            if ex.post_and_wait(action, wait_s):
                return AckStatus.COMPLETED, ok_details
            return AckStatus.FAILED, (
                f"the control loop did not confirm {cmd.name} within {wait_s:g} s "
                "(it is still applied at the next tick)")

        if isinstance(cmd, C.Stop):
            return apply(ex.do_stop, "stopped")
        if isinstance(cmd, C.EStop):
            return apply(lambda: ex.do_estop("software E-stop (ESTOP command)"),
                         "E-stop latched: send ENABLE to release")
        if isinstance(cmd, C.Enable):
            if self.snapshot.estop_pressed or ex.estop_pressed:
                return AckStatus.FAILED, "hardware E-stop is still pressed: release it first"
            return apply(ex.do_enable, "enabled")
        if isinstance(cmd, C.Disable):
            return apply(ex.do_disable, "disabled")
        if isinstance(cmd, C.ClearError):
            return apply(ex.do_clear_error, "error cleared")
        if isinstance(cmd, C.StreamMode):
            return apply(lambda: ex.set_stream_mode(cmd.on), f"stream mode {'on' if cmd.on else 'off'}")
        if isinstance(cmd, C.SetPort):
            if self.loop is None:
                return AckStatus.FAILED, "the board link is not running"
            if ex.active is not None or ex.queue:
                return AckStatus.FAILED, "robot is busy: STOP before switching the port"
            loop, port = self.loop, cmd.port
            ex.post(lambda: loop.request_port(port))
            return AckStatus.COMPLETED, f"switching to {cmd.port}"
        if isinstance(cmd, C.SetTool):
            try:
                _, tools = self._kinematics()
                obj = tools.get_tool(cmd.tool, self.config)
            except Exception as exc:
                return AckStatus.INVALID, f"SET_TOOL: {exc}"
            if ex.active is not None or ex.queue:
                return AckStatus.FAILED, "robot is busy: the tool can change only when idle"
            self.tool_name, self._tool_obj = cmd.tool, obj
            return AckStatus.COMPLETED, f"tool {cmd.tool}"
        if isinstance(cmd, C.Subscribe):
            err = self.stream.subscribe((addr[0], cmd.port), cmd.every_n_ticks)
            return (AckStatus.FAILED, err) if err else (AckStatus.COMPLETED, "subscribed")
        if isinstance(cmd, C.Unsubscribe):
            self.stream.unsubscribe((addr[0], cmd.port))
            return AckStatus.COMPLETED, "unsubscribed"
        return AckStatus.INVALID, f"{cmd.name} is not an immediate command"
