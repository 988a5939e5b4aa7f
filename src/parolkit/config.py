"""One configuration object for the whole stack, loaded from one TOML file.

Precedence: built-in defaults < TOML file < CLI flags (passed as ``overrides``).

Example ``parolkit.toml``::

    [robot]
    max_speed_steps_s = [15000, 25000, 32000, 10000, 10000, 27000]
    accel_factor = 3.0        # acceleration limit = 3 x max speed per s (or max_accel_steps_s2)

    [controller]
    rate_hz = 250
    udp_port = 5001

    [serial]
    port = "/dev/ttyACM0"

    [gui]
    http_port = 8080
    programs_dir = "~/parol-programs"
    recordings_dir = "~/parol-recordings"

    [ros2]                # `parolkit ros2` (docs/ros2.md)
    domain = 0
    namespace = "parol6"

    [tools.pen]           # a user tool: pose of the TCP in the flange frame, mm / deg
    pose = [0, 0, 120, 0, 0, 0]
    shape = { kind = "capsule", radius = 8 }   # optional: its body, flange -> TCP (mm)

    [[zones]]             # keep-out zones, base frame, mm / deg (docs/collision.md)
    name = "monitor"
    kind = "box"          # or "plane", "cylinder"
    center = [300, -250, 200]
    size = [400, 60, 300]
    margin = 10

    [[zones]]             # the table plane (z = 0) is on by default: off, or redefined by name
    name = "table"
    enabled = false

Unknown sections or keys are an error that names them (a typo never silently does nothing);
so is a value outside its range (every key, its default and its range: docs/config.md).

Importing this module is cheap (standard library only): the robot model, and with it numpy,
is loaded when a :class:`Config` is first built, so a program can find and read its config
file (:func:`find_config_file`) before paying for numpy.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from parolkit.errors import ParolkitValueError

if TYPE_CHECKING:  # importing this module stays numpy-free; the model loads with Config()
    from parolkit.collision.shapes import ToolShape, Zone
    from parolkit.robot import RobotModel
    from parolkit.transport.url import TransportURL

__all__ = [
    "ControllerSettings",
    "SerialSettings",
    "GuiSettings",
    "ToolSettings",
    "Ros2Settings",
    "ServoSettings",
    "Config",
    "default_zones",
    "load_config",
    "DEFAULT_CONFIG_PATHS",
    "find_config_file",
]

#: the 3D view's frame rate while something in it changes (gui.view_fps), Hz
DEFAULT_VIEW_FPS = 30.0

#: ``controller.supervisor_stall_s`` (when not 0) is at least this many loop periods: a
#: shorter limit would stop a live controller at its first late frames
SUPERVISOR_STALL_MIN_PERIODS = 10

#: Searched in order when no path is given; the first that exists is used.
DEFAULT_CONFIG_PATHS = (Path("parolkit.toml"), Path.home() / ".config" / "parolkit" / "parolkit.toml")


@dataclass(frozen=True)
class ControllerSettings:
    """The headless controller (``parolkit serve``)."""

    #: control loop rate, Hz (one command frame per tick)
    rate_hz: float = 100.0
    #: address the UDP server binds; anything but loopback prints a warning
    bind: str = "127.0.0.1"
    #: UDP command port
    udp_port: int = 5001
    #: UDP port acknowledgements are sent to (on the sender's address)
    ack_port: int = 5002
    #: maximum queued motion commands; more are refused with a FAILED ack
    queue_size: int = 256
    #: home automatically at start-up when the board is simulated
    home_on_start: bool = True
    #: frames the board left unanswered in a row that count as a lost link: motion is
    #: cancelled, the error latched, reconnects tried (one frame is written per tick; the
    #: controller's own late ticks never count: a reply read late still answers its frame).
    #: The board is already stopped by then (``link_hold_frames``); this only decides when to
    #: give up, so it leaves room for replies the OS delivers late under load (a loaded Linux
    #: PC's tty layer delayed replies by 20-300 ms)
    link_timeout_ticks: int = 50
    #: frames left unanswered in a row after which running motion is paused: the board gets
    #: stop frames (zero-speed 123, or the last 156 target with zero feed-forward) until a
    #: reply comes back (the motion then goes on) or the link is lost; at most
    #: ``link_timeout_ticks``
    link_hold_frames: int = 2
    #: SCHED_FIFO priority asked for the tick thread (1..99); 0 = do not ask.  Where the OS
    #: refuses it the thread asks for nice -10, else it runs at normal priority (GET_STATUS
    #: ``SCHED=`` says which)
    realtime_priority: int = 10
    #: streaming jog watchdog: motion stops when no update arrived for this long, s
    stream_watchdog_s: float = 0.02
    #: time scale of the simulated board's homing (1 = real time)
    sim_homing_speedup: float = 20.0
    #: the control lease lapses after this much silence from its holder with the robot idle, s
    lease_timeout_s: float = 10.0
    #: shared secret for taking control (CONTROL|TAKE|secret); None = no secret (loopback use).
    #: Set one when the controller is bound beyond loopback.
    secret: str | None = None
    #: run the stop supervisor on a serial link: a small process that writes a DISABLE frame
    #: the moment this controller dies (the board firmware has no watchdog)
    supervisor: bool = True
    #: the supervisor also stops the board when the controller runs but wrote no frame for
    #: this long (hung, deadlocked), s: 0 = never, else 0.1..60 and at least
    #: ``SUPERVISOR_STALL_MIN_PERIODS`` loop periods.  A *stopped* controller (``kill -STOP``,
    #: a debugger) is stopped after 3 loop periods whatever this says (30 ms at 100 Hz; see
    #: parolkit.controller.supervisor); a running one only after this limit, as under load a
    #: live controller's frames come late (gaps of 100-440 ms seen with two CPU hogs)
    supervisor_stall_s: float = 1.0
    #: before homing, one jog press moves a joint at most this far, deg (the limits are unknown)
    unhomed_jog_travel_deg: float = 20.0

    def __post_init__(self) -> None:
        _positive(self.rate_hz, "controller.rate_hz", hi=1000.0)
        _port(self.udp_port, "controller.udp_port")
        _port(self.ack_port, "controller.ack_port")
        _int_range(self.queue_size, "controller.queue_size", 1, 100_000)
        _int_range(self.link_timeout_ticks, "controller.link_timeout_ticks", 1, 1000)
        _int_range(self.link_hold_frames, "controller.link_hold_frames", 1, 1000)
        if self.link_hold_frames > self.link_timeout_ticks:
            raise ParolkitValueError(
                f"controller.link_hold_frames ({self.link_hold_frames}) must not exceed "
                f"controller.link_timeout_ticks ({self.link_timeout_ticks}): a speed stream is "
                f"stopped before the link is declared lost, not after")
        _int_range(self.realtime_priority, "controller.realtime_priority", 0, 99)
        _positive(self.stream_watchdog_s, "controller.stream_watchdog_s", hi=10.0)
        _positive(self.sim_homing_speedup, "controller.sim_homing_speedup", hi=10_000.0)
        _positive(self.unhomed_jog_travel_deg, "controller.unhomed_jog_travel_deg", hi=360.0)
        if not isinstance(self.bind, str) or not self.bind:
            raise ParolkitValueError("controller.bind must be a host address string")
        if not isinstance(self.home_on_start, bool):
            raise ParolkitValueError("controller.home_on_start must be true or false")
        _positive(self.lease_timeout_s, "controller.lease_timeout_s", hi=86_400.0)
        if self.secret is not None and (not isinstance(self.secret, str) or not 8 <= len(self.secret) <= 128
                                        or not self.secret.isascii() or not self.secret.isprintable()
                                        or "|" in self.secret or " " in self.secret):
            raise ParolkitValueError(
                "controller.secret must be 8..128 printable ASCII characters without '|' or spaces")
        if not isinstance(self.supervisor, bool):
            raise ParolkitValueError("controller.supervisor must be true or false")
        lo = max(0.1, SUPERVISOR_STALL_MIN_PERIODS / self.rate_hz)
        if isinstance(self.supervisor_stall_s, bool) or not isinstance(self.supervisor_stall_s, (int, float)) \
                or not (self.supervisor_stall_s == 0 or lo <= self.supervisor_stall_s <= 60.0):
            raise ParolkitValueError(
                f"controller.supervisor_stall_s must be 0 (never) or a number of seconds in {lo:g}..60 "
                f"(at least 0.1 s and {SUPERVISOR_STALL_MIN_PERIODS} loop periods at {self.rate_hz:g} Hz), "
                f"got {self.supervisor_stall_s!r}")

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def supervisor_priority(self) -> int:
        """The SCHED_FIFO priority the stop supervisor asks for: one above the tick thread's
        (it must run when the tick does not), 0 (nice -10 only) when the tick asks for none."""
        return min(self.realtime_priority + 1, 99) if self.realtime_priority else 0


@dataclass(frozen=True)
class SerialSettings:
    """The board link.

    ``port``: None means the in-process simulated board; otherwise a transport URL
    (docs/transport.md): a device path (``/dev/ttyACM0``, ``COM3``), ``sim://?speedup=20``,
    ``serial:///dev/ttyACM0?baud=3000000``, ``spy+/dev/ttyACM0?log=frames.log``,
    ``faulty+sim://?drop=0.01``.  It is checked here (schemes, options, values) so a typo is
    reported at start-up.  ``baud`` applies when the URL names a serial link and sets no baud.
    """

    port: str | None = None
    baud: int = 3_000_000

    def __post_init__(self) -> None:
        if self.port is not None:
            if not isinstance(self.port, str) or not self.port.strip():
                raise ParolkitValueError(
                    "serial.port must be a device path such as /dev/ttyACM0 or a transport URL "
                    f"such as sim:// (see docs/transport.md), got {self.port!r}")
            self._parsed_port()
        _int_range(self.baud, "serial.baud", 1200, 12_000_000)

    def _parsed_port(self) -> TransportURL:
        from parolkit.transport.url import TransportURLError, parse_transport_url

        try:
            return parse_transport_url(self.port or "sim://")
        except TransportURLError as exc:
            raise ParolkitValueError(f"serial.port: {exc}") from None

    @property
    def simulated(self) -> bool:
        """True when the link is the in-process emulated board (no port, or a ``sim://`` URL)."""
        return self.port is None or self._parsed_port().simulated


#: a host name (RFC 1123 labels) for gui.allowed_hosts
_LABEL = r"[a-z0-9](?:[a-z0-9-]{0,61}[a-z0-9])?"
_HOST_NAME = re.compile(rf"^(?=.{{1,253}}$){_LABEL}(?:\.{_LABEL})*$", re.IGNORECASE)


@dataclass(frozen=True)
class GuiSettings:
    """The web commander (``parolkit gui``, docs/gui.md)."""

    http_port: int = 8080
    #: address the commander binds; beyond loopback it needs ``password``
    host: str = "127.0.0.1"
    open_browser: bool = True
    #: the only folder the commander's Open / Save read and write (names only, ``.rbt``);
    #: None = ``$XDG_DATA_HOME/parolkit/programs`` (``~/.local/share/parolkit/programs``).
    #: ``~`` is expanded; a relative path is taken from the current directory.
    programs_dir: str | None = None
    #: the only folder the commander's Record writes and its recordings list reads, downloads,
    #: deletes and teaches from (names only, ``.mcap``); None = ``recordings`` beside the
    #: default programs folder (``$XDG_DATA_HOME/parolkit/recordings``, i.e.
    #: ``~/.local/share/parolkit/recordings``).  Created when the first recording starts.
    recordings_dir: str | None = None
    #: host names or addresses the browser may use to reach the commander, besides
    #: localhost, 127.0.0.1, ::1 and the bound address (the ``Host`` and ``Origin`` allow-list)
    allowed_hosts: tuple[str, ...] = ()
    #: login password (8..256 printable characters); required when ``host`` is beyond loopback,
    #: and when set every page asks for it
    password: str | None = None
    #: a class (docs/gui.md "A class: teacher, students and turns"): the teacher's password
    #: (8..256 printable characters, not the same as ``password``); when set, the login asks a
    #: student's name or this password, and only the teacher or the student the teacher handed
    #: the robot to may move it.  None: no roles (everyone who logs in may press everything)
    teacher_password: str | None = None
    #: a student's turn ends after this many minutes (TURN_MINUTES_RANGE) and the robot is
    #: stopped; 0: no limit (the teacher can set one on the page)
    turn_minutes: float = 0.0
    #: the 3D view's frame rate while the arm or the view changes (VIEW_FPS_RANGE), Hz: its
    #: updates and its drawing.  A browser without a GPU draws in software (SwiftShader: one
    #: core of a school PC at 30 fps); 10 keeps 20 such pages of a class smooth enough
    view_fps: float = DEFAULT_VIEW_FPS

    def __post_init__(self) -> None:
        _port(self.http_port, "gui.http_port")
        check_view_fps(self.view_fps, "gui.view_fps")
        if not isinstance(self.host, str) or not self.host.strip():
            raise ParolkitValueError(f"gui.host must be a host name or address, got {self.host!r}")
        if not isinstance(self.open_browser, bool):
            raise ParolkitValueError("gui.open_browser must be true or false")
        _folder(self.programs_dir, "gui.programs_dir", "~/parol-programs")
        _folder(self.recordings_dir, "gui.recordings_dir", "~/parol-recordings")
        hosts = self.allowed_hosts
        if isinstance(hosts, str) or not isinstance(hosts, (list, tuple)):
            raise ParolkitValueError(
                f"gui.allowed_hosts must be a list of host names or addresses, such as [\"robot-pc.local\"], "
                f"got {hosts!r}")
        for h in hosts:
            _allowed_host(h)
        object.__setattr__(self, "allowed_hosts", tuple(h.lower().strip("[]") for h in hosts))
        pw = self.password
        if pw is not None and (not isinstance(pw, str) or not 8 <= len(pw) <= 256 or not pw.isprintable()):
            raise ParolkitValueError("gui.password must be 8..256 printable characters"
                                     + ("" if isinstance(pw, str) else f", got a {type(pw).__name__}"))
        _password(self.teacher_password, "gui.teacher_password")
        if self.teacher_password is not None and self.teacher_password == pw:
            raise ParolkitValueError("gui.teacher_password must differ from gui.password (students may know "
                                     "the class password; the teacher's must be the teacher's alone)")
        turn = self.turn_minutes
        lo, hi = TURN_MINUTES_RANGE
        if isinstance(turn, bool) or not isinstance(turn, (int, float)) or not math.isfinite(turn) \
                or not (turn == 0 or lo <= turn <= hi):
            raise ParolkitValueError(f"gui.turn_minutes must be 0 (no limit) or a number of minutes in "
                                     f"[{lo:g}, {hi:g}], got {turn!r}")

    def __repr__(self) -> str:  # never show the password (config objects end up in logs)
        secret = ("password", "teacher_password")
        fields = ", ".join(f"{f.name}={'***' if f.name in secret and getattr(self, f.name) else value!r}"
                           for f in dataclasses.fields(self) for value in (getattr(self, f.name),))
        return f"GuiSettings({fields})"


#: a student's turn (gui.turn_minutes, and the limit the teacher sets on the page), minutes
TURN_MINUTES_RANGE = (0.1, 240.0)
#: the 3D view's frame rate (gui.view_fps, ``parolkit gui --view-fps``), Hz
VIEW_FPS_RANGE = (1.0, 60.0)


def check_view_fps(value: object, where: str) -> float:
    """``value`` as the 3D view's frame rate, or ParolkitValueError naming ``where`` and the range."""
    lo, hi = VIEW_FPS_RANGE
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not lo <= value <= hi:
        raise ParolkitValueError(f"{where} must be a frame rate in [{lo:g}, {hi:g}] (frames per second), "
                                 f"got {value!r}")
    return float(value)


def _password(pw: object, name: str) -> None:
    """A login password (gui.teacher_password): None or 8..256 printable characters."""
    if pw is not None and (not isinstance(pw, str) or not 8 <= len(pw) <= 256 or not pw.isprintable()):
        raise ParolkitValueError(f"{name} must be 8..256 printable characters"
                                 + ("" if isinstance(pw, str) else f", got a {type(pw).__name__}"))


def _folder(v: object, name: str, example: str) -> None:
    """A folder setting (gui.programs_dir, gui.recordings_dir): None or a non-empty path."""
    if v is not None and (not isinstance(v, str) or not v.strip() or "\0" in v):
        raise ParolkitValueError(f"{name} must be a folder path such as \"{example}\", got {v!r}")


def _allowed_host(h: object) -> None:
    """One entry of gui.allowed_hosts: a host name or an IP address (IPv6 with or without
    brackets), no scheme, port or path."""
    if isinstance(h, str):
        bare = h[1:-1] if h.startswith("[") and h.endswith("]") else h
        try:
            ipaddress.ip_address(bare)
            return
        except ValueError:
            if _HOST_NAME.match(bare):
                return
    raise ParolkitValueError(
        f"gui.allowed_hosts: {h!r} is not a host name or an IP address (write the name only, such as "
        "\"robot-pc.local\" or \"192.168.1.20\": no http://, port or path)")


_ROS_NAMESPACE = re.compile(r"(/?[A-Za-z][A-Za-z0-9_]*)*/?")


@dataclass(frozen=True)
class Ros2Settings:
    """``parolkit ros2`` (docs/ros2.md): DDS domain, ROS namespace, publishing rates."""

    #: ROS_DOMAIN_ID, 0..232
    domain: int = 0
    #: ROS namespace of the topics ("" = none; e.g. "parol6" -> /parol6/joint_states)
    namespace: str = ""
    #: publish /joint_states and /tf every n-th control tick (1 = the controller's status rate)
    joint_states_every_n: int = 1
    #: publish parolkit/status every n-th published joint state
    status_every_n: int = 10
    #: a trajectory's first point at time_from_start 0 (the start, as MoveIt sends it) may be this
    #: far from the current position on every joint, rad (MoveIt's own start tolerance: 0.01)
    start_tolerance_rad: float = 0.01
    #: joint angles on the ROS side: "parolkit" (parolkit's own) or "community" (the community
    #: PAROL6 URDF's zeros and signs, parolkit.ros2.convention)
    joint_convention: str = "parolkit"

    def __post_init__(self) -> None:
        _int_range(self.domain, "ros2.domain", 0, 232)
        if not isinstance(self.namespace, str) or not _ROS_NAMESPACE.fullmatch(self.namespace):
            raise ParolkitValueError(
                f"ros2.namespace must be a ROS name such as \"parol6\" or \"lab/arm1\" (letters, digits, _ and /, "
                f"each part starting with a letter), got {self.namespace!r}")
        _int_range(self.joint_states_every_n, "ros2.joint_states_every_n", 1, 1000)
        _int_range(self.status_every_n, "ros2.status_every_n", 1, 100000)
        _positive(self.start_tolerance_rad, "ros2.start_tolerance_rad", hi=0.1)
        from parolkit.ros2.convention import CONVENTIONS

        if self.joint_convention not in CONVENTIONS:
            raise ParolkitValueError(f"ros2.joint_convention must be one of {sorted(CONVENTIONS)}, "
                                     f"got {self.joint_convention!r}")


@dataclass(frozen=True)
class ServoSettings:
    """Servo streaming (SERVOJ / SERVOL): the latest target wins, an online jerk-limited
    generator moves toward it."""

    #: with no new target for this long the arm makes a controlled stop and the stream ends, s
    timeout_s: float = 0.05

    def __post_init__(self) -> None:
        _positive(self.timeout_s, "servo.timeout_s", hi=10.0)


@dataclass(frozen=True)
class ToolSettings:
    """A user tool: the TCP pose in the flange frame, [x, y, z mm, A, B, C deg], and
    optionally its body for the collision checks (:class:`parolkit.collision.ToolShape`, a
    capsule; ``[tools.NAME] shape = { kind = "capsule", radius = R }``, by default from the
    flange to the TCP)."""

    name: str
    pose: tuple[float, ...]
    shape: ToolShape | None = None

    def __post_init__(self) -> None:
        if len(self.pose) != 6 or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in self.pose
        ):
            raise ParolkitValueError(f"tools.{self.name}.pose must be 6 finite numbers (mm, deg)")
        from parolkit.robot import MAX_TOOL_OFFSET_MM

        for i, v in enumerate(self.pose):
            hi, unit = (MAX_TOOL_OFFSET_MM, "mm") if i < 3 else (360.0, "deg")
            axis = ("x", "y", "z", "A", "B", "C")[i]
            if not -hi <= v <= hi:
                raise ParolkitValueError(f"tools.{self.name}.pose: {axis} = {v:g} {unit} is out of range "
                                         f"[{-hi:g}, {hi:g}] {unit}")
        object.__setattr__(self, "pose", tuple(float(v) for v in self.pose))
        if self.shape is not None:
            from parolkit.collision.shapes import ToolShape

            if not isinstance(self.shape, ToolShape) or self.shape.name != self.name:
                raise ParolkitValueError(f"tools.{self.name}.shape must be a ToolShape named {self.name!r}, "
                                         f"got {self.shape!r}")


def default_zones() -> tuple[Zone, ...]:
    """The zones in force without a config: the table plane under the base
    (:data:`parolkit.collision.TABLE_ZONE`)."""
    from parolkit.collision.shapes import TABLE_ZONE

    return (TABLE_ZONE,)


def _stock_robot() -> RobotModel:
    from parolkit.robot import PAROL6

    return PAROL6


def find_config_file(path: str | Path | None = None) -> Path | None:
    """The config file to use: ``path`` (must exist) or the first of
    :data:`DEFAULT_CONFIG_PATHS` that exists, or None."""
    if path is not None:
        file = Path(path)
        if file.is_dir():
            raise ParolkitValueError(f"config file {file} is a folder, not a TOML file")
        if not file.is_file():
            raise ParolkitValueError(f"config file {file} does not exist")
        return file
    return next((p for p in DEFAULT_CONFIG_PATHS if p.is_file()), None)


@dataclass(frozen=True)
class Config:
    """Everything configurable, in one object."""

    robot: RobotModel = field(default_factory=_stock_robot)
    controller: ControllerSettings = field(default_factory=ControllerSettings)
    serial: SerialSettings = field(default_factory=SerialSettings)
    gui: GuiSettings = field(default_factory=GuiSettings)
    ros2: Ros2Settings = field(default_factory=Ros2Settings)
    servo: ServoSettings = field(default_factory=ServoSettings)
    tools: tuple[ToolSettings, ...] = ()
    #: keep-out zones in force (enabled ones only), base frame: ``[[zones]]``; the table plane
    #: under the base by default (docs/collision.md)
    zones: tuple[Zone, ...] = field(default_factory=default_zones)
    source: str | None = None

    def __post_init__(self) -> None:
        if self.serial.port is None:
            return
        base = self.serial._parsed_port().base
        step = base.options.get("step")
        if base.scheme.name != "sim" or step is None:
            return
        if base.options.get("clock") != "virtual":
            raise ParolkitValueError(
                f"serial.port {self.serial.port!r}: step (simulated seconds per frame) needs "
                "clock=virtual: a real-time board follows the wall clock, not the frames")
        rate = self.controller.rate_hz
        if abs(float(step) * rate - 1.0) > 1e-6:  # type: ignore[arg-type]
            raise ParolkitValueError(
                f"serial.port {self.serial.port!r}: step must be the control period, "
                f"1/{rate:g} Hz = {1.0 / rate:g} s, got {step!r}")

    def with_overrides(self, overrides: Mapping[str, Mapping[str, Any]]) -> Config:
        """Apply ``{"controller": {"rate_hz": 250}, ...}``; ``None`` values are ignored."""
        return _apply(self, overrides, origin="command line")


def _positive(v: object, name: str, hi: float) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v <= hi:
        raise ParolkitValueError(f"{name} must be a number in (0, {hi:g}], got {v!r}")


def _int_range(v: object, name: str, lo: int, hi: int) -> None:
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise ParolkitValueError(f"{name} must be an integer in {lo}..{hi}, got {v!r}")


def _port(v: object, name: str) -> None:
    _int_range(v, name, 1, 65535)


_SECTIONS = {"controller": ControllerSettings, "serial": SerialSettings, "gui": GuiSettings,
             "ros2": Ros2Settings, "servo": ServoSettings}


def _robot_fields() -> set[str]:
    from parolkit.robot import RobotModel

    return {f.name for f in dataclasses.fields(RobotModel)} - {"dh"}


def _apply(cfg: Config, data: Mapping[str, Any], origin: str) -> Config:
    if not isinstance(data, Mapping):
        raise ParolkitValueError(f"{origin}: configuration must be a table")
    changes: dict[str, Any] = {}
    for section, values in data.items():
        if section == "tools":
            if not isinstance(values, Mapping):
                raise ParolkitValueError(f"{origin}: [tools] must be a table of tables")
            tools = {t.name: t for t in cfg.tools}
            for name, spec in values.items():
                if not isinstance(spec, Mapping) or "pose" not in spec or not set(spec) <= {"pose", "shape"}:
                    got = f", got {', '.join(sorted(spec))}" if isinstance(spec, Mapping) else ""
                    raise ParolkitValueError(f"{origin}: tools.{name} needs exactly one key: pose "
                                             f"(and may have a shape){got}")
                if not isinstance(spec["pose"], (list, tuple)):
                    raise ParolkitValueError(f"{origin}: tools.{name}.pose must be 6 finite numbers (mm, deg), "
                                             f"got {spec['pose']!r}")
                try:
                    tool = ToolSettings(name=name, pose=tuple(spec["pose"]))
                    if "shape" in spec:
                        from parolkit.collision.shapes import tool_shape_from_mapping

                        shape = tool_shape_from_mapping(name, spec["shape"], tool.pose[:3])
                        tool = dataclasses.replace(tool, shape=shape)
                    tools[name] = tool
                except ParolkitValueError as exc:
                    raise ParolkitValueError(f"{origin}: {exc}") from None
            changes["tools"] = tuple(tools.values())
            continue
        if section == "zones":
            changes["zones"] = _zones(cfg.zones, values, origin)
            continue
        if section == "robot":
            target, allowed = cfg.robot, _robot_fields()
        elif section in _SECTIONS:
            target, allowed = getattr(cfg, section), {f.name for f in dataclasses.fields(_SECTIONS[section])}
        else:
            raise ParolkitValueError(
                f"{origin}: unknown section [{section}] (known: robot, controller, serial, gui, ros2, servo, tools, "
                f"zones)"
            )
        if not isinstance(values, Mapping):
            raise ParolkitValueError(f"{origin}: [{section}] must be a table")
        upd = {}
        for key, value in values.items():
            if key not in allowed:
                raise ParolkitValueError(
                    f"{origin}: unknown key {section}.{key} (known: {', '.join(sorted(allowed))})"
                )
            if value is None:
                continue
            if section == "robot" and isinstance(value, list):
                value = tuple(tuple(v) if isinstance(v, list) else v for v in value)
            upd[key] = value
        if upd:
            try:
                changes[section] = dataclasses.replace(target, **upd)
            except (TypeError, ValueError) as exc:
                raise ParolkitValueError(f"{origin}: [{section}]: {exc}") from None
    return dataclasses.replace(cfg, **changes)


def _zones(current: tuple[Zone, ...], entries: object, origin: str) -> tuple[Zone, ...]:
    """``[[zones]]``: each table defines a zone; one with the name of a zone already in force
    (the default table, or one from the file under command-line overrides) replaces it; one
    with only ``name`` and ``enabled = false`` switches that zone off."""
    from parolkit.collision.shapes import zone_from_mapping

    if not isinstance(entries, (list, tuple)):
        raise ParolkitValueError(f"{origin}: zones must be a list of tables: write each zone as [[zones]] "
                                 f"(name = ..., kind = ...), got {entries!r}")
    zones = {z.name: z for z in current}
    seen: set[str] = set()
    for k, spec in enumerate(entries, start=1):
        where = f"{origin}: [[zones]] #{k}"
        try:
            if isinstance(spec, Mapping) and set(spec) <= {"name", "enabled"} and "enabled" in spec:
                name = spec.get("name")
                if spec["enabled"] is not False:
                    raise ParolkitValueError(f"zones.{name}: a zone needs kind and its shape's keys "
                                             f"(only enabled = false may stand alone, to switch a zone off)")
                if name not in zones:
                    known = ", ".join(repr(n) for n in zones) or "none"
                    raise ParolkitValueError(f"zones.{name}: enabled = false names no zone in force (known: {known})")
                zone = None
            else:
                zone = zone_from_mapping(spec, where)
                name = zone.name
        except ParolkitValueError as exc:
            msg = str(exc)
            raise ParolkitValueError(msg if msg.startswith(origin) else f"{origin}: {msg}") from None
        if name in seen:
            raise ParolkitValueError(f"{origin}: zones.{name}: two [[zones]] tables have this name "
                                     f"(#{k} is the second)")
        seen.add(str(name))
        if zone is None or not zone.enabled:
            zones.pop(str(name), None)
        else:
            zones[zone.name] = zone
    return tuple(zones.values())


def load_config(
    path: str | Path | None = None,
    overrides: Mapping[str, Mapping[str, Any]] | None = None,
    *,
    search_default_paths: bool = True,
) -> Config:
    """Defaults, then the TOML file (``path`` or the first of :data:`DEFAULT_CONFIG_PATHS`
    that exists), then ``overrides`` (CLI flags)."""
    cfg = Config()
    file = find_config_file(path) if (path is not None or search_default_paths) else None
    if file is not None:
        try:
            data = tomllib.loads(file.read_bytes().decode("utf-8"))
        except OSError as exc:
            raise ParolkitValueError(f"config file {file} cannot be read: {exc.strerror}") from None
        except UnicodeDecodeError as exc:
            raise ParolkitValueError(f"{file}: not a TOML file: byte 0x{exc.object[exc.start]:02X} at "
                                     f"position {exc.start} is not UTF-8 text") from None
        except tomllib.TOMLDecodeError as exc:
            raise ParolkitValueError(f"{file}: not valid TOML: {exc}") from None
        cfg = dataclasses.replace(_apply(cfg, data, origin=str(file)), source=str(file))
    if overrides:
        cfg = cfg.with_overrides(overrides)
    return cfg
