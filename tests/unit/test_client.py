"""Client datagrams, replies and errors against a REAL UDP socket standing in for the controller.

``FakeController`` binds 127.0.0.1:0, records every datagram that arrives, answers queries
the way docs/protocol.md specifies and sends acks to (sender address, ack_port) with a script
of statuses chosen per command name, and also to the sender itself once it sent the (ext)
``ACK_HERE`` (unless that is the ack port, as the controller does).  Fast checks; the real controller is exercised in
tests/integration/test_client_*.py.
"""

from __future__ import annotations

import asyncio
import json
import random
import socket
import threading
import time
import uuid

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.conftest import free_udp_port

from parolkit.client import robot_api
from parolkit.client.async_robot import AsyncRobot
from parolkit.client.core import AckStatus, CommandResult, Pose, RobotStatus, result_or_raise
from parolkit.client.errors import (
    CommandCancelled,
    CommandFailed,
    CommandInvalid,
    CommandTimeout,
    ControllerUnreachable,
    ReplyError,
    RobotError,
)
from parolkit.client.robot import Robot
from parolkit.errors import ParolkitValueError

#: the 4x4 pose the fake reports (metres): the standby pose of the default tool
STANDBY_MATRIX = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.26257, 1.0, 0.0, 0.0, 0.28875, 0, 0, 0, 1]

STATUS_OBJECT = {
    "seq": 1234, "time": 12.34, "state": "IDLE", "enabled": True,
    "homed": [True] * 6, "all_homed": True, "estop_pressed": False, "estop_latched": False,
    "angles": [90, -90, 180, 0, 0, 180], "pose": [0, 262.57, 288.75, -90, 0, -90],
    "speeds": [0, 0, 0, 0, 0, 0], "speeds_deg_s": [0, 0, 0, 0, 0, 0],
    "io": {"in1": 1, "in2": 0, "out1": 0, "out2": 1, "estop": 1},
    "gripper": {"id": 0, "position": 42, "speed": 1, "current": 300, "status": 0xB1,
                "object_detection": 1, "activated": True, "calibrated": True, "object_code": 3,
                "object_detected": False, "error": False},
    "errors": {"temperature": [False] * 6, "position": [False] * 6, "timeout_error": 100,
               "message": None},
    "board": {"connected": True, "simulated": True, "port": "emulated board",
              "timing_ticks": 7031, "timing_ms": 10.0, "xtr": 255},
    "loop": {"rate_hz": 100.0, "ticks": 5000, "period_p50_ms": 10.0, "period_p99_ms": 10.4,
             "period_max_ms": 12.1, "overruns": 0, "rtt_p50_ms": 0.2, "rtt_p99_ms": 0.6,
             "frames_sent": 5000, "frames_received": 4999, "bytes_dropped": 0},
    "command": {"id": "1a2b3c4d", "name": "MOVEJOINT", "progress": 0.42},
    "queue": 2, "stream_mode": False, "tool": "default", "plan_seq": 7,
}


class FakeController:
    """A real UDP socket that answers like the controller (see module docstring).

    ``acks[name]``: list of (status, details) sent for a command ``name`` (default
    QUEUED, EXECUTING, COMPLETED); ``delay_s`` between acks; ``speeds`` reported.
    """

    #: the cookie a SUBSCRIBE must echo before statuses are sent (as the controller's)
    COOKIE = "fAkE-c0k"

    def __init__(self, ack_port: int | None = None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.ack_port = ack_port if ack_port is not None else free_udp_port()
        self.received: list[str] = []
        self.acks: dict[str, list[tuple[str, str]]] = {}
        self.delay_s = 0.0
        self.speeds = [0, 0, 0, 0, 0, 0]
        self.silent = False
        self.query_error: str | None = None
        #: request name -> the reply sent instead of the usual one (e.g. a malformed one)
        self.replies: dict[str, str] = {}
        self.ack_here: set = set()
        self.honour_ack_here = True  # False: a controller that acks only its ack port
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        self.sock.settimeout(0.1)
        while not self._stop:
            try:
                data, addr = self.sock.recvfrom(65535)
            except TimeoutError:
                continue
            except OSError:
                return
            text = data.decode()
            self.received.append(text)
            if not self.silent:
                self._answer(text, addr)

    def _answer(self, text: str, addr) -> None:
        parts = text.split("|")
        cid = None
        if len(parts[0]) == 8 and not parts[0].isupper():
            cid, parts = parts[0], parts[1:]
        name = parts[0].upper()
        replies = {
            "GET_ANGLES": "ANGLES|90.0000,-90.0000,180.0007,0.0000,0.0000,180.0000",
            "GET_POSE": "POSE|" + ",".join(f"{v:.6f}" for v in STANDBY_MATRIX),
            "GET_IO": "IO|1,0,1,0,1",
            "GET_GRIPPER": "GRIPPER|0,100,1,200,177,1",
            "GET_SPEEDS": "SPEEDS|" + ",".join(str(s) for s in self.speeds),
            "PING": "PONG",
            "GET_STATUS": "STATUS|POSE=" + ",".join(f"{v:.6f}" for v in STANDBY_MATRIX)
                          + "|ANGLES=90,-90,180,0,0,180|SPEEDS=" + ",".join(str(s) for s in self.speeds)
                          + "|IO=0,0,0,0,0|GRIPPER=0,0,1,0,0,1|STATE=IDLE|HOMED=1,1,1,1,1,1"
                          + "|ESTOP=1|QUEUE=0|CMD=None|ERROR=None|SERIAL=1",
            "GET_STATUS_JSON": "STATUS_JSON|" + json.dumps(STATUS_OBJECT),
            "GET_LOOP_STATS": "LOOP_STATS|" + json.dumps(STATUS_OBJECT["loop"]),
            "GET_QUEUE": 'QUEUE|{"active": {"id": "1a2b3c4d", "name": "MOVEJOINT", "progress": 0.5},'
                         ' "queued": [{"id": "5e6f7a8b", "name": "DELAY"}]}',
            "GET_PLAN": 'PLAN|{"seq": 3, "command": "MOVECART", "target_angles": [1, 2, 3, 4, 5, 6],'
                        ' "tcp_path": [[0, 250, 200], [1, 250, 200]]}',
            "GET_TOOL": "TOOL|default|-45.25,0,62.8,0,0,0",
            "GET_CONTROL": 'CONTROL|{"holder": "127.0.0.1:40112", "held_s": 12.5, "idle_s": 0.3, '
                           '"timeout_s": 10, "secret_required": false, "refused": 2, "taken_over": 0}',
        }
        replies.update(self.replies)
        if name in replies:
            reply = f"ERROR|{self.query_error}" if self.query_error else replies[name]
            self.sock.sendto(reply.encode(), addr)
            return
        if name == "ACK_HERE" and cid is None:
            self.ack_here.add(addr)
            return
        if name == "SUBSCRIBE":
            port = int(parts[1])
            if parts[3:4] != [self.COOKIE]:  # the stream starts once the socket echoed its cookie
                self.sock.sendto(f"COOKIE|{self.COOKIE}".encode(), addr)
                return
            for seq in range(3):
                obj = dict(STATUS_OBJECT, seq=seq)
                self.sock.sendto(("STATUS_JSON|" + json.dumps(obj)).encode(), ("127.0.0.1", port))
            return
        if cid is None:
            return
        script = self.acks.get(name, [("QUEUED", "Position 1 in queue"), ("EXECUTING", ""),
                                      ("COMPLETED", "")])

        also = addr if (self.honour_ack_here and addr in self.ack_here
                        and addr[1] != self.ack_port) else None

        def send() -> None:
            for status, details in script:
                if self.delay_s:
                    time.sleep(self.delay_s)
                self.sock.sendto(f"ACK|{cid}|{status}|{details}".encode(), (addr[0], self.ack_port))
                if also is not None:
                    self.sock.sendto(f"ACK|{cid}|{status}|{details}".encode(), also)

        threading.Thread(target=send, daemon=True).start()

    def ack(self, cmd_id: str, status: str, details: str = "") -> None:
        """Send one ack by hand (for tests that must act between two acks)."""
        self.sock.sendto(f"ACK|{cmd_id}|{status}|{details}".encode(), ("127.0.0.1", self.ack_port))

    def wait_for(self, prefix: str, timeout: float = 2.0) -> list[str]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            hits = [t for t in self.received if prefix in t]
            if hits:
                return hits
            time.sleep(0.005)
        return []

    def received_so_far(self) -> list[str]:
        """Every datagram that reached this controller before now: a marker datagram sent now
        is received after them (loopback delivers to the socket in the order sent) and, once it
        is in, what came before it is all there was; without waiting on the clock."""
        marker = f"MARKER-{uuid.uuid4().hex}"
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(marker.encode(), ("127.0.0.1", self.port))
        assert self.wait_for(marker), "the marker datagram did not arrive"
        got = list(self.received)
        return got[:got.index(marker)]

    def close(self) -> None:
        self._stop = True
        self.silent = True
        self.sock.sendto(b"", ("127.0.0.1", self.port))  # wake the thread now
        self._thread.join(1.0)
        self.sock.close()


@pytest.fixture
def fake():
    f = FakeController()
    yield f
    f.close()


@pytest.fixture
def api(fake):
    """robot_api pointed at the fake (restored afterwards)."""
    before = (robot_api.SERVER_IP, robot_api.SERVER_PORT, robot_api.ACK_PORT, robot_api.QUERY_TIMEOUT)
    robot_api.configure(host="127.0.0.1", port=fake.port, ack_port=fake.ack_port)
    robot_api.QUERY_TIMEOUT = 1.0
    yield robot_api
    robot_api.configure(host=before[0], port=before[1], ack_port=before[2])
    robot_api.QUERY_TIMEOUT = before[3]


@pytest.fixture
def robot(fake):
    r = Robot(port=fake.port, ack_port=fake.ack_port, timeout=1.0)
    yield r
    r.close()


# ============================================================================================
# datagram formats (builders) checked against the controller's own parser
# ============================================================================================

BUILDS = [
    (lambda: robot_api.build_move_joint([90, -90, 160, 12, 12, 180], duration=5.5), "MoveJoint"),
    (lambda: robot_api.build_move_joint([90, -90, 160, 12, 12, 180], speed_percentage=50,
                                        accel_percentage=30, profile="trap", tracking="speed"), "MoveJoint"),
    (lambda: robot_api.build_move_pose([7, 250, 200, -100, 0, -90], duration=5.5), "MovePose"),
    (lambda: robot_api.build_move_cart([7, 250, 150, -100, 0, -90], speed_percentage=50), "MoveCart"),
    (lambda: robot_api.build_move_cart([7, 250, 150, -100, 0, -90], speed_percentage=50, blend=10), "MoveCart"),
    (lambda: robot_api.build_move_joint([90, -90, 160, 12, 12, 180], speed_percentage=50, accel_percentage=30,
                                        profile="trap", tracking="speed", blend=5.5), "MoveJoint"),
    (lambda: robot_api.build_move_pose([7, 250, 200, -100, 0, -90], duration=2, blend=100), "MovePose"),
    (lambda: robot_api.build_move_cart_rel_trf([-80, 0, 0, 0, 0, 0], duration=2, profile="poly"),
     "MoveCartRelTRF"),
    (lambda: robot_api.build_jog(3, 50, duration=1.0), "Jog"),
    (lambda: robot_api.build_jog(9, 50, distance_deg=10), "Jog"),
    (lambda: robot_api.build_multijog([0, 8], [10, 20], 1.5), "MultiJog"),
    (lambda: robot_api.build_cartjog("trf", "rz+", 30, 1), "CartJogCommand"),
    (lambda: robot_api.build_pneumatic_gripper("open", 1), "PneumaticGripper"),
    (lambda: robot_api.build_electric_gripper("calibrate"), "ElectricGripper"),
    (lambda: robot_api.build_electric_gripper("move", 100, 150, 200), "ElectricGripper"),
    (lambda: robot_api.build_electric_gripper("clear_error"), "ElectricGripper"),
    (lambda: robot_api.build_delay(0.2), "Delay"),
    (lambda: robot_api.build_home(), "Home"),
    (lambda: robot_api.build_speed_joint([1, 2, 3, 4, 5, 6], 1), "SpeedJoint"),
    (lambda: robot_api.build_move_joint_path([[90, -90, 180, 0, 0, 180], [95.5, -90, 180, 0, 0, 180]], [1, 2.5]),
     "MoveJointPath"),
    (lambda: robot_api.build_move_joint_path([[90, -90, 180, 0, 0, 180], [95.5, -90, 180, 0, 0, 180]], [1, 2.5],
                                             [[3, 0, 0, 0, 0, 0], [0] * 6]), "MoveJointPath"),
    (lambda: robot_api.build_wait_input(1, 1, 2.5), "WaitInput"),
    (lambda: robot_api.build_smooth_circle([0, 250, 200], 30, "XY", "WRF", None, 4), "SmoothCircle"),
    (lambda: robot_api.build_smooth_arc_center([10, 250, 200, -90, 0, -90], [0, 250, 200],
                                               speed_percentage=40, clockwise=True), "SmoothArcCenter"),
    (lambda: robot_api.build_smooth_arc_param([10, 250, 200, -90, 0, -90], 20, 90, "TRF",
                                              [0, 250, 200, -90, 0, -90], 3), "SmoothArcParam"),
    (lambda: robot_api.build_smooth_spline([[0, 250, 200, -90, 0, -90], [10, 250, 210, -90, 0, -90]],
                                           duration=3), "SmoothSpline"),
    (lambda: robot_api.build_smooth_helix([0, 250, 200], 20, 5, -20, duration=5), "SmoothHelix"),
    (lambda: robot_api.build_smooth_blend([
        {"type": "LINE", "end": [1, 2, 3, 4, 5, 6]},
        {"type": "CIRCLE", "center": [0, 250, 200], "radius": 10, "plane": "XZ", "clockwise": True},
        {"type": "ARC", "end": [1, 2, 3, 4, 5, 6], "center": [0, 0, 0]},
        {"type": "SPLINE", "waypoints": [[1, 2, 3, 4, 5, 6], [1, 2, 3, 4, 5, 7]]}]), "SmoothBlend"),
    (lambda: robot_api.build_smooth_blend([{"type": "LINE", "end": [1, 2, 3, 4, 5, 6]}],
                                          speed_percentage=30), "SmoothBlend"),
    (lambda: robot_api.build_stream(True), "StreamMode"),
    (lambda: robot_api.build_set_tool("flange"), "SetTool"),
    (lambda: robot_api.build_subscribe(5000, 2), "Subscribe"),
    (lambda: robot_api.build_unsubscribe(5000), "Unsubscribe"),
]


@pytest.mark.parametrize("build,kind", BUILDS, ids=[k for _, k in BUILDS])
def test_every_datagram_builder_output_is_accepted_by_the_controller_parser(build, kind):
    from parolkit.protocol.commands import parse_datagram

    parsed = parse_datagram(("abcd1234|" + build()).encode())
    assert type(parsed.command).__name__ == kind
    assert parsed.command_id == "abcd1234"


def test_move_joint_datagram_keeps_the_original_field_order_and_the_values():
    from parolkit.protocol.commands import parse_datagram

    text = robot_api.build_move_joint([90, -90, 160, 12, 12, 180.25], duration=5.5)
    assert text == "MOVEJOINT|90|-90|160|12|12|180.25|5.5|None"
    cmd = parse_datagram(text.encode()).command
    assert tuple(cmd.move.target_deg) == (90, -90, 160, 12, 12, 180.25)


def test_move_joint_path_datagram_is_each_point_s_time_angles_and_velocities_in_order():
    from parolkit.protocol.commands import parse_datagram

    points = [[90, -90, 180, 0, 0, 180], [95.5, -90, 180, 0, 0, 180.25]]
    assert robot_api.build_move_joint_path(points, [1, 2.5]) == \
        "MOVEJOINTPATH|2|1|90|-90|180|0|0|180|2.5|95.5|-90|180|0|0|180.25"
    text = robot_api.build_move_joint_path(points, [1, 2.5], [[3, 0, 0, 0, 0, -1.5], [0] * 6])
    assert text == "MOVEJOINTPATH|2|1|90|-90|180|0|0|180|3|0|0|0|0|-1.5|2.5|95.5|-90|180|0|0|180.25|0|0|0|0|0|0"
    move = parse_datagram(text.encode()).command.move
    assert move.points_deg == tuple(tuple(p) for p in points) and move.times_s == (1, 2.5)


@pytest.mark.parametrize("call,needle", [
    (lambda: robot_api.build_move_joint_path([], []), "points must hold 1..200 points, got 0"),
    (lambda: robot_api.build_move_joint_path([[0] * 6] * 201, [1] * 201), "points must hold 1..200 points, got 201"),
    (lambda: robot_api.build_move_joint_path("abc", [1]), "points must be a list of joint positions"),
    (lambda: robot_api.build_move_joint_path([[0] * 5], [1]), "points[0] must have 6 values (J1..J6 in deg), got 5"),
    (lambda: robot_api.build_move_joint_path([[0] * 6], [1, 2]), "times must have one entry per point (1), got 2"),
    (lambda: robot_api.build_move_joint_path([[0] * 6], [0]), "times[0] must be > 0 s, got 0"),
    (lambda: robot_api.build_move_joint_path([[0] * 6] * 2, [2, 1]),
     "times[1] = 1 s must be greater than times[0] = 2 s (times strictly increasing)"),
    (lambda: robot_api.build_move_joint_path([[0] * 6], [1], [[0] * 6] * 2),
     "velocities must have one entry per point (1), got 2"),
    (lambda: robot_api.build_move_joint_path([[0] * 6], [1], [[0, float("nan"), 0, 0, 0, 0]]),
     "velocities[0][1] must be a finite number"),
    (lambda: robot_api.build_move_joint_path([[0] * 6], [1], [[0, 0, 0, 0, 2, 0]]),
     "velocities[0][4] must be 0 (the path ends at rest on its last point), got 2"),
])
def test_move_joint_path_arguments_are_checked_naming_the_argument(call, needle):
    with pytest.raises(ValueError) as info:
        call()
    assert needle in str(info.value)


def test_extension_fields_are_only_appended_when_given():
    assert robot_api.build_move_cart([1, 2, 3, 4, 5, 6], speed_percentage=50) == \
        "MOVECART|1|2|3|4|5|6|NONE|50.0"
    assert robot_api.build_move_cart([1, 2, 3, 4, 5, 6], speed_percentage=50, blend=0) == \
        "MOVECART|1|2|3|4|5|6|NONE|50.0"  # 0: no blending
    assert robot_api.build_move_cart([1, 2, 3, 4, 5, 6], duration=2, tracking="speed") == \
        "MOVECART|1|2|3|4|5|6|2|NONE|None|speed"
    assert robot_api.build_move_joint([0] * 6, duration=1, accel_percentage=40) == \
        "MOVEJOINT|0|0|0|0|0|0|1|None|40|None|None"


@pytest.mark.parametrize("call,needle", [
    (lambda: robot_api.move_robot_joints([1, 2, 3], duration=1), "angles must have 6 values"),
    (lambda: robot_api.move_robot_joints([0] * 6), "either duration"),
    (lambda: robot_api.move_robot_joints([0] * 6, duration=1, speed_percentage=5), "not both"),
    (lambda: robot_api.move_robot_joints([0] * 6, speed_percentage=150), "speed_percentage must be in 0..100"),
    (lambda: robot_api.move_robot_joints([0] * 6, duration=-0.5), "duration must be > 0"),
    (lambda: robot_api.move_robot_joints([0] * 6, duration=0), "got neither"),  # 0 = not given
    (lambda: robot_api.move_robot_joints([0, 0, float("nan"), 0, 0, 0], duration=1), "angles[2] must be a finite"),
    (lambda: robot_api.move_robot_pose([0] * 6, duration=-1), "duration must be > 0"),
    (lambda: robot_api.move_robot_cartesian([0] * 5, speed_percentage=50), "pose must have 6 values"),
    (lambda: robot_api.move_robot_cartesian([0] * 6, speed_percentage=50, blend=200),
     "blend must be in 0..100 mm, got 200"),
    (lambda: robot_api.move_robot_cartesian([0] * 6, speed_percentage=50, blend=-1), "blend must be in 0..100 mm"),
    (lambda: robot_api.move_robot_joints([0] * 6, duration=1, blend=100.5), "blend must be in 0..100 deg, got 100.5"),
    (lambda: robot_api.move_robot_joints([0] * 6, duration=1, blend="abc"), "blend must be a number, got 'abc'"),
    (lambda: robot_api.move_robot_pose([0] * 6, duration=1, blend=float("nan")), "blend must be a finite number"),
    (lambda: robot_api.move_robot_pose([0] * 6, duration=1, blend=True), "blend must be a number, got True"),
    (lambda: robot_api.jog_robot_joint(12, 50, duration=1), "joint_index must be in 0..11"),
    (lambda: robot_api.jog_robot_joint(1, 50), "duration"),
    (lambda: robot_api.jog_multiple_joints([0, 6], [10, 10], 1), "J1 is given in both directions"),
    (lambda: robot_api.jog_multiple_joints([0, 1], [10], 1), "same length"),
    (lambda: robot_api.jog_cartesian("XRF", "X+", 50, 1), "frame must be one of WRF, TRF"),
    (lambda: robot_api.jog_cartesian("WRF", "Q+", 50, 1), "axis must be one of"),
    (lambda: robot_api.control_pneumatic_gripper("squeeze", 1), "action must be one of open, close"),
    (lambda: robot_api.control_pneumatic_gripper("open", 3), "port must be in 1..2"),
    (lambda: robot_api.control_electric_gripper("move", position=256), "position must be in 0..255"),
    (lambda: robot_api.control_electric_gripper("move", speed=-1), "speed must be in 0..255"),
    (lambda: robot_api.control_electric_gripper("move", current=1301), "current must be in 0..1300"),
    (lambda: robot_api.control_electric_gripper("move", current=-1), "current must be in 0..1300"),
    (lambda: robot_api.delay_robot(0), "duration must be > 0"),
    (lambda: robot_api.smooth_circle([0, 0], 10, duration=1), "center must have 3 values"),
    (lambda: robot_api.smooth_circle([0, 0, 0], 0, duration=1), "radius must be > 0"),
    (lambda: robot_api.smooth_circle([0, 0, 0], 10, plane="XW", duration=1), "plane must be one of XY, XZ, YZ"),
    (lambda: robot_api.smooth_spline([[0] * 6], duration=1), "at least 2 poses"),
    (lambda: robot_api.smooth_blend([{"type": "WIGGLE"}]), "segments[0]['type'] must be one of"),
    (lambda: robot_api.smooth_blend([{"type": "LINE"}]), "needs the key 'end'"),
])
def test_bad_arguments_raise_a_precise_value_error_before_anything_is_sent(api, fake, call, needle):
    with pytest.raises(ValueError) as info:
        call()
    assert needle in str(info.value)
    assert fake.received_so_far() == []


def test_configure_validates_and_reports_the_settings():
    before = robot_api.configure()
    try:
        with pytest.raises(ValueError, match="port must be in 1..65535"):
            robot_api.configure(port=70000)
        with pytest.raises(ValueError, match="host must be"):
            robot_api.configure(host="")
        assert robot_api.configure(port=5001)["port"] == 5001
    finally:
        robot_api.configure(**before)


# ============================================================================================
# robot_api round trips
# ============================================================================================


def test_fire_and_forget_sends_exactly_the_original_datagram(api, fake):
    msg = api.move_robot_joints([90, -90, 160, 12, 12, 180], duration=5.5)
    assert msg.startswith("Successfully sent command")
    assert fake.wait_for("MOVEJOINT") == ["MOVEJOINT|90|-90|160|12|12|180|5.5|None"]


def test_wait_for_ack_returns_the_terminal_status_with_the_command_id(api, fake):
    result = api.home_robot(wait_for_ack=True, timeout=2.0)
    assert result["status"] == "COMPLETED" and result["completed"] is True
    sent = fake.wait_for("|HOME")[0]
    assert sent == f"{result['command_id']}|HOME"
    assert len(result["command_id"]) == 8


def test_wait_for_ack_failed_carries_the_controller_reason(api, fake):
    fake.acks["MOVEPOSE"] = [("QUEUED", "Position 1 in queue"), ("FAILED", "IK failed: out of reach")]
    result = api.move_robot_pose([500, 0, 0, 0, 0, 0], duration=1, wait_for_ack=True)
    assert result["status"] == "FAILED"
    assert result["details"] == "IK failed: out of reach"


def test_wait_for_ack_without_a_terminal_ack_reports_timeout(api, fake):
    fake.acks["DELAY"] = [("QUEUED", "Position 1 in queue"), ("EXECUTING", "")]
    t0 = time.monotonic()
    result = api.delay_robot(5, wait_for_ack=True, timeout=0.3)
    assert 0.25 < time.monotonic() - t0 < 3.0  # generous: the machine is shared
    assert result["status"] == "TIMEOUT" and result["completed"] is False
    assert "last status: EXECUTING" in result["details"]


def test_non_blocking_returns_the_id_and_check_command_status_follows_it(api, fake):
    fake.delay_s = 0.05
    cmd_id = api.delay_robot(1, wait_for_ack=True, non_blocking=True)
    assert isinstance(cmd_id, str) and len(cmd_id) == 8
    deadline = time.monotonic() + 2
    while (api.check_command_status(cmd_id) or {}).get("status") != "COMPLETED":
        assert time.monotonic() < deadline
        time.sleep(0.01)
    st = api.check_command_status(cmd_id)
    assert st["history"] == ["QUEUED", "EXECUTING", "COMPLETED"]
    assert st["command"] == "DELAY|1"
    assert api.is_tracking_active() and api.get_tracking_stats()["ack_port"] == fake.ack_port


def test_a_busy_ack_port_gives_a_clear_error(api, fake):
    holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    holder.bind(("0.0.0.0", 0))
    busy = holder.getsockname()[1]
    try:
        api.configure(ack_port=busy)
        with pytest.raises(robot_api.AckPortBusyError) as info:
            api.home_robot(wait_for_ack=True)
        assert f"UDP port {busy}" in str(info.value) and "configure(ack_port=N)" in str(info.value)
    finally:
        holder.close()


def test_queries_return_parsed_values(api, fake, capsys):
    assert api.get_robot_joint_angles() == [90.0, -90.0, 180.0007, 0.0, 0.0, 180.0]
    pose = api.get_robot_pose()
    assert pose == pytest.approx([0, 262.57, 288.75, -90, 0, -90], abs=1e-6)
    assert api.get_robot_pose_matrix()[1] == pytest.approx([0.0, 0.0, 1.0, 0.26257])
    assert api.get_robot_io(verbose=True) == [1, 0, 1, 0, 1]
    assert api.get_electric_gripper_status(verbose=True) == [0, 100, 1, 200, 177, 1]
    out = capsys.readouterr().out
    assert "IN1   1 | ON" in out and "ESTOP 1 | released" in out and "calibrated=True" in out
    assert api.get_robot_joint_speeds() == [0.0] * 6
    assert api.ping_robot() is True
    assert api.is_robot_stopped() is True and api.is_estop_pressed() is False


def test_is_robot_stopped_uses_the_threshold_in_steps_per_second(api, fake):
    fake.speeds = [0, 0, 1.5, 0, 0, 0]
    assert api.is_robot_stopped() is True
    assert api.is_robot_stopped(threshold_speed=1.0) is False
    fake.speeds = [0, 0, 0, 0, 0, 100]
    assert api.wait_for_robot_stopped(timeout=0.2, poll_rate=0.05) is False
    fake.speeds = [0] * 6
    assert api.wait_for_robot_stopped(timeout=1, poll_rate=0.05) is True


def test_get_robot_status_decodes_one_status_datagram(api, fake):
    st = api.get_robot_status()
    assert st["angles"] == [90, -90, 180, 0, 0, 180]
    assert st["pose"] == pytest.approx([0, 262.57, 288.75, -90, 0, -90], abs=1e-6)
    assert st["estop"] is True  # IO=...,0 in the fake's STATUS: ESTOP pressed
    assert st["state"] == "IDLE" and st["homed"] == [True] * 6 and st["queue"] == 0
    assert st["command"] is None and st["error"] is None and st["stopped"] is True


def test_a_silent_controller_makes_queries_return_none_with_a_message(api, fake, capsys):
    fake.silent = True
    api.QUERY_TIMEOUT = 0.2
    assert api.get_robot_joint_angles() is None
    assert "no ANGLES reply" in capsys.readouterr().err


def test_matrix_to_pose_matches_spatialmath_rpy_xyz_including_the_singularity():
    from spatialmath import SE3

    rng = random.Random(7)
    for i in range(120):
        abc = [rng.uniform(-179, 179) for _ in range(3)]
        if i % 5 == 0:
            abc[1] = rng.choice([-90.0, 90.0])
        T = SE3.RPY(abc, order="xyz", unit="deg") * SE3(0.1, -0.2, 0.3)
        want = list(T.t * 1000) + list(T.rpy("deg", "xyz"))
        assert robot_api.matrix_to_pose(T.A.flatten().tolist()) == pytest.approx(want, abs=1e-9)


def test_top_level_robot_api_is_the_implementation_module_with_every_public_name():
    import parolkit
    import robot_api as top

    assert top is robot_api and parolkit.robot_api is robot_api
    for name in ("move_robot_joints", "move_robot_pose", "move_robot_cartesian", "jog_robot_joint",
                 "jog_multiple_joints", "jog_cartesian", "control_pneumatic_gripper",
                 "control_electric_gripper", "delay_robot", "home_robot", "stop_robot_movement",
                 "smooth_circle", "smooth_arc_center", "smooth_arc_parametric", "smooth_spline",
                 "smooth_helix", "smooth_blend", "get_robot_pose", "get_robot_pose_matrix",
                 "get_robot_joint_angles", "get_robot_io", "get_electric_gripper_status",
                 "get_robot_joint_speeds", "is_robot_stopped", "is_estop_pressed",
                 "get_robot_status", "wait_for_robot_stopped", "check_command_status"):
        assert name in top.__all__


def test_original_signatures_and_defaults_are_kept():
    import inspect

    sig = inspect.signature(robot_api.move_robot_joints)
    assert list(sig.parameters) == ["joint_angles", "duration", "speed_percentage", "wait_for_ack",
                                    "timeout", "non_blocking", "blend"]
    # the (ext) blend comes after the original's parameters, keyword-only
    assert sig.parameters["blend"].kind is inspect.Parameter.KEYWORD_ONLY
    assert sig.parameters["timeout"].default == 2.0
    g = inspect.signature(robot_api.control_electric_gripper).parameters
    assert (g["position"].default, g["speed"].default, g["current"].default) == (255, 150, 500)
    assert inspect.signature(robot_api.home_robot).parameters["timeout"].default == 30.0
    assert inspect.signature(robot_api.smooth_blend).parameters["timeout"].default == 15.0
    assert inspect.signature(robot_api.smooth_circle).parameters["timeout"].default == 10.0
    assert inspect.signature(robot_api.is_robot_stopped).parameters["threshold_speed"].default == 2.0
    w = inspect.signature(robot_api.wait_for_robot_stopped).parameters
    assert (w["timeout"].default, w["poll_rate"].default) == (10.0, 0.1)


# ============================================================================================
# core and Robot
# ============================================================================================


def test_status_object_of_the_protocol_decodes_into_typed_fields():
    st = RobotStatus.from_json(STATUS_OBJECT)
    assert st.state == "IDLE" and st.all_homed and st.angles == (90, -90, 180, 0, 0, 180)
    assert st.pose == Pose(0, 262.57, 288.75, -90, 0, -90)
    assert st.io.in1 and st.io.out2 and not st.io.estop_pressed
    assert st.gripper.position == 42 and st.gripper.calibrated and st.gripper.object_code == 3
    assert st.board.timing_ms == 10.0 and st.loop.period_p99_ms == 10.4
    assert st.command.name == "MOVEJOINT" and st.command.progress == 0.42 and st.queue == 2
    bad = dict(STATUS_OBJECT)
    del bad["angles"]
    with pytest.raises(ReplyError, match="'angles' is missing"):
        RobotStatus.from_json(bad)


@pytest.mark.parametrize("status,exc", [("FAILED", CommandFailed), ("INVALID", CommandInvalid),
                                        ("CANCELLED", CommandCancelled)])
def test_terminal_failures_map_to_exceptions_carrying_the_reason(status, exc):
    with pytest.raises(exc) as info:
        result_or_raise("abcd1234", "MOVEJOINT", AckStatus(status), "the reason")
    assert info.value.reason == "the reason" and info.value.command_id == "abcd1234"
    assert info.value.command == "MOVEJOINT" and "the reason" in str(info.value)
    assert result_or_raise("abcd1234", "HOME", AckStatus.COMPLETED, "").ok


def test_robot_move_waits_for_completed_and_sends_extension_fields(robot, fake):
    fake.delay_s = 0.02
    res = robot.move_joints([90, -90, 180, 0, 0, 180], speed=40, accel=20, profile="ruckig",
                            tracking="position")
    assert res.status is AckStatus.COMPLETED and res.command == "MOVEJOINT"
    assert fake.wait_for("MOVEJOINT")[0] == f"{res.id}|MOVEJOINT|90|-90|180|0|0|180|None|40|20|ruckig|position"


# ---- (ext) blend: the last field r=<radius> of MOVEJOINT / MOVEPOSE / MOVECART ---------------


def test_robot_api_sends_the_blend_radius_as_the_last_field_r(api, fake):
    api.move_robot_cartesian([0, 250, 200, 180, 0, 0], speed_percentage=50, blend=10)
    assert fake.wait_for("MOVECART") == ["MOVECART|0|250|200|180|0|0|NONE|50.0|r=10"]
    api.move_robot_joints([90, -90, 180, 0, 0, 180], duration=2, blend=5.5)
    assert fake.wait_for("MOVEJOINT") == ["MOVEJOINT|90|-90|180|0|0|180|2|None|r=5.5"]
    res = api.move_robot_pose([0, 250, 200, 180, 0, 0], speed_percentage=40, wait_for_ack=True, blend=10)
    assert res["status"] == "COMPLETED"
    assert fake.wait_for("MOVEPOSE") == [f"{res['command_id']}|MOVEPOSE|0|250|200|180|0|0|None|40|r=10"]


def test_robot_sends_the_blend_radius_after_the_extension_fields(robot, fake):
    res = robot.move_cart([0, 250, 200, 180, 0, 0], speed=50, blend=10)
    assert fake.wait_for("MOVECART") == [f"{res.id}|MOVECART|0|250|200|180|0|0|NONE|50.0|r=10"]
    res = robot.move_joints([90, -90, 180, 0, 0, 180], speed=40, accel=20, profile="trap", blend=5)
    assert fake.wait_for("MOVEJOINT") == [f"{res.id}|MOVEJOINT|90|-90|180|0|0|180|None|40|20|trap|None|r=5"]
    h = robot.move_pose([0, 250, 200, 180, 0, 0], duration=1.5, wait=False, blend=2.5)
    assert fake.wait_for("MOVEPOSE") == [f"{h.id}|MOVEPOSE|0|250|200|180|0|0|1.5|None|r=2.5"]
    assert h.result(timeout=2).ok


@pytest.mark.parametrize("call,needle", [
    (lambda r: r.move_cart([0, 250, 200, 180, 0, 0], speed=50, blend=100.5), "blend must be in 0..100 mm, got 100.5"),
    (lambda r: r.move_cart([0, 250, 200, 180, 0, 0], speed=50, blend=-1), "blend must be in 0..100 mm, got -1"),
    (lambda r: r.move_joints([90, -90, 180, 0, 0, 180], duration=1, blend=200), "blend must be in 0..100 deg"),
    (lambda r: r.move_pose([0, 250, 200, 180, 0, 0], duration=1, blend=float("inf")), "blend must be a finite"),
    (lambda r: r.move_pose([0, 250, 200, 180, 0, 0], duration=1, wait=False, blend="ten"),
     "blend must be a number, got 'ten'"),
])
def test_robot_refuses_a_bad_blend_radius_before_anything_is_sent(robot, fake, call, needle):
    with pytest.raises(ParolkitValueError) as info:
        call(robot)
    assert needle in str(info.value)
    assert fake.received_so_far() == ["ACK_HERE"]  # only the registration sent at creation


def test_async_robot_sends_the_blend_radius_too(fake):
    async def main():
        async with AsyncRobot(port=fake.port, ack_port=fake.ack_port, timeout=1.0) as r:
            res = await r.move_cart([0, 250, 200, 180, 0, 0], duration=2, blend=10)
            assert res.ok
            assert fake.wait_for("MOVECART") == [f"{res.id}|MOVECART|0|250|200|180|0|0|2|NONE|r=10"]
            with pytest.raises(ParolkitValueError, match="blend must be in 0..100 deg"):
                r.move_joints([90, -90, 180, 0, 0, 180], duration=1, blend=101)

    asyncio.run(main())


@settings(max_examples=150, deadline=None)
@given(
    kind=st.sampled_from(["MOVEJOINT", "MOVEPOSE", "MOVECART"]),
    offsets=st.lists(st.floats(-3, 3, allow_nan=False).map(lambda v: round(v, 3)), min_size=6, max_size=6),
    by_duration=st.booleans(),
    timing=st.floats(0.1, 100, allow_nan=False),
    ext=st.booleans(),
    blend=st.one_of(st.none(), st.integers(0, 100), st.floats(0, 100, allow_nan=False)),
)
def test_blended_move_text_to_command_to_text_round_trips(kind, offsets, by_duration, timing, ext, blend):
    """A builder's datagram parses to the move with that blend; the datagram built again from
    the parsed move's own fields parses to the same command."""
    from parolkit.protocol.commands import parse_datagram

    base = [90, -90, 180, 0, 0, 180] if kind == "MOVEJOINT" else [0, 250, 200, 180, 0, 0]
    values = [b + o for b, o in zip(base, offsets)]
    d, s = (timing, None) if by_duration else (None, timing)
    profile, tracking = ("trap", "speed") if ext else (None, None)
    build = {"MOVEJOINT": robot_api.build_move_joint, "MOVEPOSE": robot_api.build_move_pose}.get(kind)

    def text_of(target, d, s, profile, tracking, blend):
        if build is None:
            return robot_api.build_move_cart(target, d, s, profile, tracking, blend)
        return build(target, d, s, None, profile, tracking, blend)

    text = text_of(values, d, s, profile, tracking, blend)
    assert text.endswith(f"|r={robot_api.format_value(blend)}") == bool(blend)
    cmd = parse_datagram(text).command
    m = cmd.move
    assert m.blend == (float(blend) if blend else None)
    target = m.target_deg if kind == "MOVEJOINT" else m.pose
    again = text_of(list(target), m.duration_s, m.speed_pct, m.profile and m.profile.value,
                    m.tracking.value if ext else None, m.blend)
    assert parse_datagram(again).command == cmd


def test_robot_move_joint_path_sends_one_movejointpath_and_waits_for_completed(robot, fake):
    res = robot.move_joint_path([[90, -90, 180, 0, 0, 180], [95, -90, 180, 0, 0, 180]], [1.5, 3])
    assert res.status is AckStatus.COMPLETED and res.command == "MOVEJOINTPATH"
    assert fake.wait_for("MOVEJOINTPATH")[0] == f"{res.id}|MOVEJOINTPATH|2|1.5|90|-90|180|0|0|180|3|95|-90|180|0|0|180"
    with pytest.raises(ParolkitValueError, match=r"times\[0\] must be > 0 s"):
        robot.move_joint_path([[90, -90, 180, 0, 0, 180]], [0])


def test_robot_wait_false_returns_a_handle_after_the_first_ack(robot, fake):
    fake.acks["MOVECART"] = [("QUEUED", "Position 1 in queue")]  # the rest comes by hand
    h = robot.move_cart([0, 250, 200, -90, 0, -90], duration=1, wait=False)
    assert h.command == "MOVECART" and h.status() is AckStatus.QUEUED and not h.done()
    fake.ack(h.id, "EXECUTING")
    fake.ack(h.id, "COMPLETED")
    assert h.result(timeout=2).ok and h.done()


def test_robot_failures_raise_with_the_controller_reason(robot, fake):
    fake.acks["MOVEPOSE"] = [("QUEUED", ""), ("FAILED", "IK failed: out of reach by 12 mm")]
    with pytest.raises(CommandFailed) as info:
        robot.move_pose([600, 0, 0, 0, 0, 0], duration=1)
    assert info.value.reason == "IK failed: out of reach by 12 mm"
    fake.acks["HOME"] = [("INVALID", "HOME takes 0 arguments, got 1")]
    with pytest.raises(CommandInvalid, match="HOME takes 0 arguments"):
        robot.home()
    fake.acks["DELAY"] = [("QUEUED", "")]
    h = robot.delay(3, wait=False)  # returned after QUEUED
    fake.ack(h.id, "CANCELLED", "stopped by STOP")
    with pytest.raises(CommandCancelled, match="stopped by STOP"):
        h.result(timeout=2)


def test_robot_without_any_ack_raises_command_timeout_naming_the_ports(fake):
    fake.honour_ack_here = False  # acks go to the fake's ack port only, not to this socket
    with Robot(port=fake.port, ack_port=0, timeout=0.3) as r:
        with pytest.raises(CommandTimeout) as info:
            r.home()
        assert f"port {r.ack_port}" in str(info.value)


def test_pipelined_commands_return_before_any_ack_and_a_missing_ack_shows_at_the_result(robot, fake):
    """Robot.pipelined (the RBTscript interpreter's lines ahead): wait=False returns once the
    datagram is sent, in order; the ack comes to the handle later; a command never acked
    raises CommandTimeout (naming the ports) at its result(), within the Robot's timeout, not
    at the send; outside the block wait=False waits for the first ack again."""
    fake.acks["DELAY"] = []  # no ack at all: acks come by hand
    with robot.pipelined():  # (waiting for a first ack that never comes would raise)
        handles = [robot.delay(0.01, wait=False) for _ in range(5)]
    assert all(h.status() is None for h in handles)
    assert [m.split("|", 1)[0] for m in fake.received_so_far()][-5:] == [h.id for h in handles]
    for h in handles[:4]:
        fake.ack(h.id, "COMPLETED")
    assert all(h.result(timeout=2).ok for h in handles[:4])
    with pytest.raises(CommandTimeout) as info:
        handles[4].result(timeout=5)
    assert "no acknowledgement within 1 s" in str(info.value) and f"port {robot.ack_port}" in str(info.value)
    with pytest.raises(CommandTimeout, match="no acknowledgement"):
        robot.delay(0.01, wait=False)  # not pipelined: the send waits for the first ack


def test_robot_explicit_timeout_on_a_long_command(robot, fake):
    fake.acks["DELAY"] = [("QUEUED", ""), ("EXECUTING", "")]
    with pytest.raises(CommandTimeout, match="last status: EXECUTING"):
        robot.delay(10, timeout=0.3)


def test_robot_queries_are_typed(robot, fake):
    assert robot.angles() == (90.0, -90.0, 180.0007, 0.0, 0.0, 180.0)
    assert robot.pose() == pytest.approx((0, 262.57, 288.75, -90, 0, -90), abs=1e-6)
    assert robot.pose_matrix()[3] == (0, 0, 0, 1)
    io = robot.io()
    assert io.in1 and io.out1 and not io.estop_pressed
    g = robot.gripper()
    assert g.position == 100 and g.current == 200 and g.calibrated and g.activated
    assert robot.status().command.id == "1a2b3c4d"
    assert robot.loop_stats().frames_received == 4999
    q = robot.queue()
    assert q.active.name == "MOVEJOINT" and q.queued == (("5e6f7a8b", "DELAY"),)
    assert robot.plan_info().tcp_path[1] == (1, 250, 200)
    assert robot.tool().name == "default" and robot.ping() is True and robot.link_up() is True


def test_a_handle_returns_the_failure_instead_of_raising_it_when_asked(robot, fake):
    fake.acks["MOVEPOSE"] = [("QUEUED", "")]  # the rest comes by hand
    h = robot.move_pose([600, 0, 0, 0, 0, 0], duration=1, wait=False)
    fake.ack(h.id, "FAILED", "IK failed: out of reach by 12 mm")
    failed = h.result(timeout=2, raise_on_error=False)
    assert isinstance(failed, CommandFailed) and failed.reason == "IK failed: out of reach by 12 mm"
    assert failed.command_id == h.id and failed.status == "FAILED"
    with pytest.raises(CommandFailed, match="out of reach"):  # the default still raises
        h.result(timeout=2)
    fake.acks["DELAY"] = [("QUEUED", ""), ("EXECUTING", "")]
    late = robot.delay(10, wait=False).result(timeout=0.2, raise_on_error=False)
    assert isinstance(late, CommandTimeout) and "last status: EXECUTING" in late.reason
    done = robot.home(wait=False).result(timeout=2, raise_on_error=False)
    assert isinstance(done, CommandResult) and done.ok


def test_control_is_the_typed_lease_dict(robot, fake, api):
    expected = {"holder": "127.0.0.1:40112", "held_s": 12.5, "idle_s": 0.3, "timeout_s": 10.0,
                "secret_required": False, "refused": 2, "taken_over": 0}
    lease = robot.control()
    assert lease == expected and type(lease["timeout_s"]) is float
    assert api.get_control() == expected
    fake.replies["GET_CONTROL"] = 'CONTROL|{"holder": null, "held_s": null, "idle_s": null, ' \
                                  '"timeout_s": 10.0, "secret_required": true, "refused": 0, "taken_over": 1}'
    assert robot.control()["holder"] is None and robot.control()["secret_required"] is True


@pytest.mark.parametrize(("request_name", "reply", "query", "needle"), [
    ("GET_CONTROL", 'CONTROL|{"holder": 7, "held_s": null, "idle_s": null, "timeout_s": 10, '
                    '"secret_required": false, "refused": 0, "taken_over": 0}', "control",
     "CONTROL: holder must be str or null, got 7"),
    ("GET_CONTROL", 'CONTROL|{"holder": null}', "control", "CONTROL: field 'held_s' is missing"),
    ("GET_CONTROL", "CONTROL|[1, 2]", "control", "CONTROL: not a JSON object"),
    ("GET_LOOP_STATS", 'LOOP_STATS|{"rate_hz": "fast"}', "loop_stats", "rate_hz must be a number, got 'fast'"),
    ("GET_LOOP_STATS", "LOOP_STATS|[100]", "loop_stats", "LOOP_STATS must be a JSON object, got [100]"),
    ("GET_PLAN", 'PLAN|{"seq": 1, "target_angles": 5}', "plan_info", "target_angles must be a list, got 5"),
    ("GET_PLAN", 'PLAN|{"seq": 1, "tcp_path": [[0, "x", 0]]}', "plan_info", "tcp_path must be a number, got 'x'"),
    ("GET_QUEUE", 'QUEUE|{"queued": ["MOVEJOINT"]}', "queue", "queued must be a JSON object, got 'MOVEJOINT'"),
    ("GET_QUEUE", 'QUEUE|{"active": {"progress": "half"}}', "queue", "progress must be a number, got 'half'"),
])
def test_a_malformed_json_reply_is_a_reply_error_naming_the_field(robot, fake, request_name, reply, query, needle):
    fake.replies[request_name] = reply
    with pytest.raises(ReplyError) as info:
        getattr(robot, query)()
    assert needle in str(info.value)


def test_robot_api_reports_a_malformed_control_reply_and_returns_none(api, fake, capsys):
    fake.replies["GET_CONTROL"] = 'CONTROL|{"holder": null, "held_s": null, "idle_s": null, "timeout_s": "10", ' \
                                  '"secret_required": false, "refused": 0, "taken_over": 0}'
    assert api.get_control() is None
    assert "GET_CONTROL: CONTROL: timeout_s must be int or float, got '10'" in capsys.readouterr().err


def test_robot_query_errors(robot, fake):
    fake.query_error = "GET_ANGLES: board not connected"
    with pytest.raises(ReplyError, match="board not connected"):
        robot.angles()
    fake.query_error = None
    fake.silent = True
    robot.timeout = 0.3
    with pytest.raises(ControllerUnreachable, match="no ANGLES reply"):
        robot.angles()


def test_robot_argument_errors_are_parolkit_value_errors_and_send_nothing(robot, fake):
    with pytest.raises(ParolkitValueError, match="joint must be 1..6"):
        robot.jog_joint(0, 50, duration=1)
    with pytest.raises(ParolkitValueError, match="speed_percentage must be in 0..100"):
        robot.move_joints([0] * 6, speed=-1)
    with pytest.raises(ParolkitValueError, match="timeout must be"):
        robot.home(timeout=-1)
    assert fake.received_so_far() == ["ACK_HERE"]  # only the registration sent at creation


def test_robot_registers_its_socket_for_acks_on_creation(robot, fake):
    time.sleep(0.05)
    assert fake.received[:1] == ["ACK_HERE"]


def test_signed_joint_numbers_map_to_jog_indices(robot, fake):
    robot.jog_joint(-3, 20, duration=0.5, wait=True)
    robot.jog_multiple([1, -6], [10, 20], 0.5, wait=True)
    assert fake.wait_for("|JOG|")[0].endswith("|JOG|8|20|0.5|None")
    assert fake.wait_for("MULTIJOG")[0].endswith("|MULTIJOG|0,11|10,20|0.5")


def test_set_output_maps_to_the_pneumatic_command(robot, fake):
    robot.set_output(2, True)
    robot.set_output(1, "low")
    sent = fake.wait_for("PNEUMATICGRIPPER")
    assert sent[0].endswith("PNEUMATICGRIPPER|open|2") and sent[1].endswith("PNEUMATICGRIPPER|close|1")


def test_subscribe_renews_and_unsubscribes(robot, fake, monkeypatch):
    import parolkit.client.robot as robot_mod

    monkeypatch.setattr(robot_mod, "SUBSCRIBE_RENEW_S", 0.1)
    with robot.subscribe(every_n=5) as sub:
        got = [sub.next(timeout=1).seq for _ in range(3)]
        deadline = time.monotonic() + 3
        while len([t for t in fake.received if t.startswith("SUBSCRIBE|")]) < 3:
            assert time.monotonic() < deadline, "the subscription was not renewed"
            time.sleep(0.02)
    assert got == [0, 1, 2]
    subs = [t for t in fake.received if t.startswith("SUBSCRIBE|")]
    # the first asks for the cookie; the echo and every renewal carry it
    assert subs[0] == f"SUBSCRIBE|{sub.port}|5"
    assert set(subs[1:]) == {f"SUBSCRIBE|{sub.port}|5|{fake.COOKIE}"}
    assert fake.wait_for("UNSUBSCRIBE")[0] == f"UNSUBSCRIBE|{sub.port}"


def test_subscribe_with_a_callback(robot, fake):
    seen = []
    sub = robot.subscribe(every_n=1, callback=seen.append)
    deadline = time.monotonic() + 2
    while len(seen) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    sub.close()
    assert [s.seq for s in seen] == [0, 1, 2]


def test_async_robot_shares_the_methods_and_errors(fake):
    async def main():
        async with AsyncRobot(port=fake.port, ack_port=fake.ack_port, timeout=1.0) as r:
            assert await r.angles() == (90.0, -90.0, 180.0007, 0.0, 0.0, 180.0)
            assert await r.ping() is True and await r.link_up() is True
            res = await r.move_joints([90, -90, 180, 0, 0, 180], duration=1)
            assert res.ok
            fake.acks["HOME"] = [("QUEUED", ""), ("FAILED", "board not connected")]
            with pytest.raises(CommandFailed, match="board not connected"):
                await r.home()
            fake.acks["DELAY"] = [("QUEUED", "")]
            h = await r.delay(1, wait=False)
            assert h.status() is AckStatus.QUEUED and not h.done()
            fake.ack(h.id, "COMPLETED")
            assert (await h.result(timeout=2)).ok
            h = await r.delay(1, wait=False)
            fake.ack(h.id, "CANCELLED", "stopped by STOP")
            cancelled = await h.result(timeout=2, raise_on_error=False)
            assert isinstance(cancelled, CommandCancelled) and cancelled.reason == "stopped by STOP"
            assert (await r.control())["refused"] == 2
            with pytest.raises(ParolkitValueError):
                r.move_joints([0] * 5, duration=1)
            async with r.subscribe(every_n=2) as sub:
                seqs = [(await sub.next(timeout=1)).seq for _ in range(3)]
            assert seqs == [0, 1, 2]
            fake.silent = True
            with pytest.raises(ControllerUnreachable):
                await r.io()

    asyncio.run(main())


def test_closing_an_async_subscription_ends_a_waiting_iteration(fake):
    async def main():
        async with AsyncRobot(port=fake.port, ack_port=fake.ack_port, timeout=1.0) as r:
            sub = await r.subscribe(every_n=1, timeout=5).start()
            got = [s.seq async for s in _take(sub, 3)]
            assert got == [0, 1, 2]
            waiter = asyncio.ensure_future(sub.__anext__())  # nothing more will arrive
            await asyncio.sleep(0.05)
            await sub.close()
            with pytest.raises(StopAsyncIteration):
                await asyncio.wait_for(waiter, 1.0)

    async def _take(sub, n):
        for _ in range(n):
            yield await sub.next(timeout=1)

    asyncio.run(main())


def test_setting_server_port_on_the_top_level_module_redirects_queries(fake):
    import robot_api as top

    before = top.configure()
    try:
        top.SERVER_PORT = fake.port  # what original scripts do instead of configure()
        assert top.get_robot_joint_angles() == [90.0, -90.0, 180.0007, 0.0, 0.0, 180.0]
    finally:
        top.configure(**before)


def test_one_robot_shared_by_threads_matches_every_reply_and_ack(robot, fake):
    from concurrent.futures import ThreadPoolExecutor

    def worker(k: int) -> None:
        for _ in range(20):
            if k % 3 == 0:
                assert robot.angles()[0] == 90.0
            elif k % 3 == 1:
                assert robot.io().in1 is True
            else:
                assert robot.delay(0.1).command == "DELAY"

    with ThreadPoolExecutor(6) as pool:
        list(pool.map(worker, range(6)))
    assert len([t for t in fake.received if "|DELAY|" in t]) == 40


# ============================================================================================
# additions used by the browser commander (and open to every client user)
# ============================================================================================


def test_status_state_is_an_enum_that_still_equals_its_string():
    from parolkit.client.core import RobotState

    st = RobotStatus.from_json(STATUS_OBJECT)
    assert st.state is RobotState.IDLE and st.state == "IDLE"
    assert str(st.state) == "IDLE" and f"{st.state}" == "IDLE"
    assert RobotStatus.from_json(dict(STATUS_OBJECT, state="moving")).state is RobotState.MOVING
    with pytest.raises(ReplyError, match="state must be one of IDLE, MOVING, HOMING.*got 'FLYING'"):
        RobotStatus.from_json(dict(STATUS_OBJECT, state="FLYING"))


@pytest.mark.parametrize("changes, movable", [
    ({}, True),
    ({"enabled": False, "state": "DISABLED"}, False),
    ({"homed": [True] * 5 + [False], "all_homed": False}, False),
    ({"estop_latched": True, "state": "ESTOP"}, False),
    ({"estop_pressed": True}, False),
    ({"state": "ERROR"}, False),
    ({"state": "DISCONNECTED"}, False),
    ({"state": "MOVING"}, True),
])
def test_can_move_needs_enabled_homed_no_estop_and_no_error_state(changes, movable):
    assert RobotStatus.from_json(dict(STATUS_OBJECT, **changes)).can_move is movable


@pytest.mark.parametrize("status_byte, text", [(0x00, "idle"), (0x80, "active"), (0x81, "calibrated"),
                                               (0x83, "error"), (0x85, "error"), (0x89, "error")])
def test_gripper_status_text_summarises_the_status_byte(status_byte, text):
    gripper = dict(STATUS_OBJECT["gripper"], status=status_byte)
    g = RobotStatus.from_json(dict(STATUS_OBJECT, gripper=gripper)).gripper
    assert g.status_text == text
    # any_error is the controller's gripper.error field: E-stop, timeout or temperature bit
    assert g.any_error == (text == "error")
    assert (g.error, g.timeout_error, g.temperature_error) == (
        bool(status_byte & 2), bool(status_byte & 4), bool(status_byte & 8))


def test_error_info_any_is_true_for_a_bit_or_a_message():
    assert not RobotStatus.from_json(STATUS_OBJECT).errors.any
    pos = dict(STATUS_OBJECT["errors"], position=[False, True, False, False, False, False])
    assert RobotStatus.from_json(dict(STATUS_OBJECT, errors=pos)).errors.any
    msg = dict(STATUS_OBJECT["errors"], message="J2 position error")
    assert RobotStatus.from_json(dict(STATUS_OBJECT, errors=msg)).errors.any


@pytest.mark.parametrize("field, value, needle", [
    ("angles", [1, 2, 3], "angles must be a list of 6 finite numbers, got [1, 2, 3]"),
    ("angles", [1, 2, 3, 4, 5, float("nan")], "angles must be a list of 6 finite numbers"),
    ("pose", [0, 1, 2, 3, 4, "x"], "pose must be a list of 6 finite numbers"),
    ("speeds_deg_s", [0] * 7, "speeds_deg_s must be a list of 6 finite numbers"),
    ("homed", [True] * 3, "homed must be a list of 6 booleans"),
])
def test_a_malformed_status_vector_is_named_with_its_value(field, value, needle):
    with pytest.raises(ReplyError) as info:
        RobotStatus.from_json(dict(STATUS_OBJECT, **{field: value}))
    assert needle in str(info.value)


def test_send_nowait_returns_the_id_at_once_and_listeners_see_each_ack(fake):
    async def main():
        async with AsyncRobot(port=fake.port, ack_port=0, timeout=1.0) as r:  # acks via ACK_HERE
            seen = []
            r.add_ack_listener(lambda rec: seen.append((rec.id, rec.latest[0].value)))
            r.add_ack_listener(lambda rec: 1 / 0)  # a broken listener is logged, nothing more
            fake.acks["JOG"] = [("QUEUED", ""), ("EXECUTING", ""), ("COMPLETED", "")]
            h = r.send_nowait("JOG|2|30|0.2|None")
            assert h.command == "JOG" and h.status() is None  # nothing awaited yet
            assert (await h.result(timeout=2)).ok
            assert [s for i, s in seen if i == h.id] == ["QUEUED", "EXECUTING", "COMPLETED"]
            assert fake.wait_for("|JOG|")[0] == f"{h.id}|JOG|2|30|0.2|None"
            with pytest.raises(ParolkitValueError, match="one non-empty command line"):
                r.send_nowait("JOG|1\nSTOP")

    asyncio.run(main())


def test_send_nowait_before_open_is_a_clear_error():
    with pytest.raises(RobotError, match="not open"):
        AsyncRobot(port=free_udp_port()).send_nowait("STOP")


def test_subscription_renewal_repeats_ack_here_for_a_restarted_controller(fake):
    async def main():
        async with AsyncRobot(port=fake.port, ack_port=0, timeout=1.0) as r:
            async with r.subscribe(every_n=2) as sub:
                await sub.next(timeout=1)
                fake.ack_here.clear()  # the controller restarted and forgot us
                fake.received.clear()
                sub.renew()
                await asyncio.sleep(0.1)
                assert f"SUBSCRIBE|{sub.port}|2|{fake.COOKIE}" in fake.received and "ACK_HERE" in fake.received
                fake.acks["STOP"] = [("COMPLETED", "")]
                assert (await r.stop()).ok  # its acks reach this socket again

    asyncio.run(main())


def test_a_bad_datagram_never_stops_the_async_robot_or_its_subscription(fake):
    async def main():
        async with AsyncRobot(port=fake.port, ack_port=0, timeout=1.0) as r:
            # garbage from the controller's own address (the client's sockets are connected to
            # it: anything from elsewhere never reaches them, see the forged-ack tests)
            junk = fake.sock
            for garbage in (b"\xff\xfe", b"ACK|", b"ACK|x|", b"STATUS_JSON|{"):
                junk.sendto(garbage, ("127.0.0.1", r.ack_port))
            await asyncio.sleep(0.05)
            assert await r.angles() == (90.0, -90.0, 180.0007, 0.0, 0.0, 180.0)
            async with r.subscribe(every_n=1, timeout=1) as sub:
                # seq 0..2 first (the fake sends them at SUBSCRIBE), so that the junk below
                # cannot overtake them on a loaded machine
                assert [(await sub.next(timeout=1)).seq for _ in range(3)] == [0, 1, 2]
                junk.sendto(b"STATUS_JSON|{not json", ("127.0.0.1", sub.port))
                junk.sendto(("STATUS_JSON|" + json.dumps(dict(STATUS_OBJECT, angles=[1]))).encode(),
                            ("127.0.0.1", sub.port))
                junk.sendto(("STATUS_JSON|" + json.dumps(dict(STATUS_OBJECT, seq=3))).encode(),
                            ("127.0.0.1", sub.port))
                outcomes = []
                for _ in range(3):  # the two bad ones, then a good one from the same sender
                    try:
                        outcomes.append((await sub.next(timeout=1)).seq)
                    except ReplyError as exc:
                        outcomes.append(str(exc).split(":")[0])
                assert outcomes == ["STATUS_JSON", "status", 3]
                sub.renew()
                assert (await sub.next(timeout=1)).seq == 0  # still subscribed and parsing

    asyncio.run(main())


def test_ack_book_counts_exactly_one_terminal_ack_and_reports_repeats_as_nothing_new():
    from parolkit.client.core import AckBook

    book = AckBook()
    rec, text = book.new("JOG|2|30|0.2|None")
    cid = text.split("|", 1)[0]
    assert book.on_datagram(f"ACK|{cid}|QUEUED|") is rec
    assert book.on_datagram(f"ACK|{cid}|COMPLETED|done") is rec
    assert book.on_datagram(f"ACK|{cid}|FAILED|late duplicate") is None  # listeners see nothing
    assert rec.terminal == (AckStatus.COMPLETED, "done") and len(rec.history) == 2
    assert book.on_datagram("ACK|zzzz9999|COMPLETED|") is None and book.unmatched == 1
    assert book.on_datagram("PONG") is None


# ============================================================================================
# the original client's wire forms, byte for byte (tests/data/original-api.md, "Wire forms")
# ============================================================================================

WP1, WP2 = [0, 250, 200, -90, 0, -90], [10.5, 250, 210, -90, 0, -90]

#: (call, the datagram the original client sent for it): str() of every value as given, the
#: durations of JOG and CARTJOG and the speed of MOVECART as floats, NONE in MOVECART
ORIGINAL_WIRE = [
    (lambda a: a.move_robot_joints([90, -90, 160, 12, 12, 180], duration=5.5),
     "MOVEJOINT|90|-90|160|12|12|180|5.5|None"),
    (lambda a: a.move_robot_joints(joint_angles=[90, -90, 160.5, 12, 12, 180], speed_percentage=50),
     "MOVEJOINT|90|-90|160.5|12|12|180|None|50"),
    (lambda a: a.move_robot_pose([7, 250, 200, -100, 0, -90], duration=5.5),
     "MOVEPOSE|7|250|200|-100|0|-90|5.5|None"),
    (lambda a: a.move_robot_cartesian([7, 250, 150, -100, 0, -90], speed_percentage=50),
     "MOVECART|7|250|150|-100|0|-90|NONE|50.0"),
    (lambda a: a.move_robot_cartesian([7, 250, 150, -100, 0, -90], duration=2),
     "MOVECART|7|250|150|-100|0|-90|2|NONE"),
    (lambda a: a.jog_robot_joint(3, 50, duration=1), "JOG|3|50|1.0|None"),
    (lambda a: a.jog_robot_joint(9, 50, distance_deg=10), "JOG|9|50|None|10"),
    (lambda a: a.jog_multiple_joints([0, 8], [10, 20.5], 1.5), "MULTIJOG|0,8|10,20.5|1.5"),
    (lambda a: a.jog_cartesian("wrf", "x+", 50, 1), "CARTJOG|wrf|x+|50|1.0"),
    (lambda a: a.jog_cartesian("TRF", "RZ-", 30, 0.5), "CARTJOG|TRF|RZ-|30|0.5"),
    (lambda a: a.control_pneumatic_gripper("open", 1), "PNEUMATICGRIPPER|open|1"),
    (lambda a: a.control_electric_gripper(action="calibrate"), "ELECTRICGRIPPER|calibrate|255|150|500"),
    (lambda a: a.control_electric_gripper("move", position=100, speed=150, current=200),
     "ELECTRICGRIPPER|move|100|150|200"),
    (lambda a: a.control_electric_gripper("move", position=None), "ELECTRICGRIPPER|move|None|150|500"),
    (lambda a: a.delay_robot(0.2), "DELAY|0.2"),
    (lambda a: a.home_robot(), "HOME"),
    (lambda a: a.stop_robot_movement(), "STOP"),
    (lambda a: a.smooth_circle([0, 250, 200], 30, duration=4),
     "SMOOTH_CIRCLE|0,250,200|30|XY|WRF|CURRENT|DURATION|4|0"),
    (lambda a: a.smooth_circle([0, 250, 200], 30, plane="xz", frame="trf", start_pose=[], speed_percentage=40.0,
                               clockwise=True),
     "SMOOTH_CIRCLE|0,250,200|30|xz|trf|CURRENT|SPEED|40.0|1"),
    (lambda a: a.smooth_arc_center(WP2, [0, 250, 210], start_pose=WP1, duration=2.5),
     "SMOOTH_ARC_CENTER|10.5,250,210,-90,0,-90|0,250,210|WRF|0,250,200,-90,0,-90|DURATION|2.5|0"),
    (lambda a: a.smooth_arc_parametric(WP2, 20, 90, "TRF", None, 3),
     "SMOOTH_ARC_PARAM|10.5,250,210,-90,0,-90|20|90|TRF|CURRENT|DURATION|3|0"),
    (lambda a: a.smooth_spline([WP1, WP2], duration=3.0),
     "SMOOTH_SPLINE|2|WRF|CURRENT|DURATION|3.0|0|250|200|-90|0|-90|10.5|250|210|-90|0|-90"),
    (lambda a: a.smooth_helix([0, 250, 200], 20, 5, -20, duration=5),
     "SMOOTH_HELIX|0,250,200|20|5|-20|WRF|CURRENT|DURATION|5|0"),
    (lambda a: a.smooth_blend([{"type": "LINE", "end": WP2},
                               {"type": "CIRCLE", "center": [0, 250, 200], "radius": 10, "plane": "XZ",
                                "clockwise": True},
                               {"type": "ARC", "end": WP1, "center": [0, 0, 0], "duration": 1},
                               {"type": "SPLINE", "waypoints": [WP1, WP2]}]),
     "SMOOTH_BLEND|4|0.5|WRF|CURRENT|DEFAULT|LINE|10.5,250,210,-90,0,-90|2.0||CIRCLE|0,250,200|10|XZ|3.0|1"
     "||ARC|0,250,200,-90,0,-90|0,0,0|1|0||SPLINE|2|0,250,200,-90,0,-90;10.5,250,210,-90,0,-90|3.0"),
    (lambda a: a.smooth_blend([{"type": "LINE", "end": WP2, "duration": 1.5}], 0.25, "wrf", duration=4),
     "SMOOTH_BLEND|1|0.25|wrf|CURRENT|DURATION|4|LINE|10.5,250,210,-90,0,-90|1.5"),
]


@pytest.mark.parametrize("call,wire", ORIGINAL_WIRE, ids=[w.split("|")[0] + str(i) for i, (_, w) in
                                                          enumerate(ORIGINAL_WIRE)])
def test_every_function_sends_exactly_the_original_clients_datagram(api, fake, call, wire):
    from parolkit.protocol.commands import parse_datagram

    fired = call(api)
    assert fired == f"Successfully sent command: '{wire[:50]}...'"  # the original's confirmation
    name = wire.split("|")[0]
    assert fake.wait_for(name) == [wire]
    parse_datagram(wire.encode())  # and the controller reads it


def test_chain_and_trajectory_send_the_original_sequence_without_touching_the_callers_dicts(api, fake):
    motions = [{"type": "arc", "end_pose": WP2, "center": [0, 250, 210], "duration": 2},
               {"type": "circle", "center": [10.5, 250, 220], "radius": 10, "duration": 3},
               {"type": "helix", "center": [0, 250, 200], "radius": 5, "pitch": 5, "height": 5, "duration": 3},
               {"type": "spline", "waypoints": [WP1, WP2], "duration": 2}]
    copies = [dict(m) for m in motions]
    out = api.chain_smooth_motions(motions, frame="TRF", wait_for_ack=False)
    assert motions == copies and len(out) == 4 and all(o.startswith("Successfully sent") for o in out)
    sent = fake.wait_for("SMOOTH_SPLINE") and [t for t in fake.received if t.startswith("SMOOTH_")]
    assert sent == [
        "SMOOTH_ARC_CENTER|10.5,250,210,-90,0,-90|0,250,210|TRF|CURRENT|DURATION|2|0",
        # after an arc: from its end pose; after a circle or a helix: from where the robot is
        "SMOOTH_CIRCLE|10.5,250,220|10|XY|TRF|10.5,250,210,-90,0,-90|DURATION|3|0",
        "SMOOTH_HELIX|0,250,200|5|5|5|TRF|CURRENT|DURATION|3|0",
        "SMOOTH_SPLINE|2|TRF|CURRENT|DURATION|2|0|250|200|-90|0|-90|10.5|250|210|-90|0|-90",
    ]
    fake.received.clear()
    assert api.execute_trajectory([WP1, WP2], "speed", 40, "linear", wait_for_ack=False)[1].startswith(
        "Successfully sent")
    fake.wait_for("MOVECART|10.5")
    assert [t for t in fake.received if t.startswith("MOVECART")] == [
        "MOVECART|0|250|200|-90|0|-90|NONE|40.0", "MOVECART|10.5|250|210|-90|0|-90|NONE|40.0"]


def test_chain_checks_every_motion_before_sending_the_first(api, fake):
    with pytest.raises(ValueError, match=r"motions\[1\] \(spline\): waypoints must hold at least 2"):
        api.chain_smooth_motions([{"type": "circle", "center": [0, 250, 200], "radius": 10, "duration": 3},
                                  {"type": "spline", "waypoints": [WP1], "duration": 2}], wait_for_ack=False)
    with pytest.raises(ValueError, match=r"motions\[0\] \(helix\): .*unexpected keyword argument 'radiuss'"):
        api.chain_smooth_motions([{"type": "helix", "center": [0, 250, 200], "radiuss": 10}])
    time.sleep(0.1)
    assert not [t for t in fake.received if t.startswith("SMOOTH_")]


def test_a_chain_stops_at_the_first_failed_or_cancelled_motion(api, fake):
    fake.acks["SMOOTH_CIRCLE"] = [("QUEUED", "Position 1 in queue"), ("CANCELLED", "STOP received")]
    out = api.chain_smooth_motions([{"type": "circle", "center": [0, 250, 200], "radius": 10, "duration": 3},
                                    {"type": "helix", "center": [0, 250, 200], "radius": 5, "pitch": 5,
                                     "height": 5, "duration": 3}], timeout=2)
    assert [r["status"] for r in out] == ["CANCELLED"]
    time.sleep(0.1)
    assert not [t for t in fake.received if "SMOOTH_HELIX" in t]


def test_safe_move_with_retry_retries_failures_and_returns_an_accepted_command_at_once(api, fake):
    fake.acks["MOVEPOSE"] = [("QUEUED", "Position 1 in queue"), ("FAILED", "IK failed: out of reach")]
    r = api.safe_move_with_retry(api.move_robot_pose, [500, 0, 0, 0, 0, 0], duration=1, max_retries=3,
                                 retry_delay=0.01)
    assert r["status"] == "FAILED" and r["details"] == "IK failed: out of reach"
    assert len([t for t in fake.received if "MOVEPOSE" in t]) == 3
    # a move still running when the wait ends is not sent a second time
    fake.acks["MOVEJOINT"] = [("QUEUED", "Position 1 in queue"), ("EXECUTING", "")]
    r = api.safe_move_with_retry(api.move_robot_joints, [0] * 6, duration=5, timeout=0.3, retry_delay=0.01)
    assert r["status"] == "TIMEOUT" and r["last_status"] == "EXECUTING"
    assert len([t for t in fake.received if "MOVEJOINT" in t]) == 1
    # an INVALID command would be refused again
    fake.acks["DELAY"] = [("INVALID", "DELAY: seconds out of range")]
    assert api.safe_move_with_retry(api.delay_robot, 1, retry_delay=0.01)["status"] == "INVALID"
    assert len([t for t in fake.received if "DELAY" in t]) == 1
    with pytest.raises(ValueError, match="max_retries must be in 1"):
        api.safe_move_with_retry(api.delay_robot, 1, max_retries=0)


def test_wait_for_ack_results_carry_the_originals_keys_and_datetimes(api, fake):
    from datetime import datetime

    r = api.delay_robot(0.1, wait_for_ack=True)
    assert {"command", "sent_time", "status", "details", "completed", "ack_time", "command_id"} <= set(r)
    assert r["command"] == "DELAY|0.1" and isinstance(r["sent_time"], datetime)
    assert isinstance(r["ack_time"], datetime) and r["ack_time"] >= r["sent_time"]
    st = api.get_tracking_stats()
    assert {"active", "commands_tracked", "memory_bytes", "thread_active"} <= set(st) and st["active"]


def test_pose_matrix_is_a_numpy_array_here_and_robot_api_still_imports_numpy_only_there(api, fake):
    import subprocess
    import sys

    m = api.get_robot_pose_matrix()
    assert type(m).__name__ == "ndarray" and m.shape == (4, 4) and m[1, 3] == pytest.approx(0.26257)
    code = ("import sys; sys.modules['numpy'] = None; sys.path.insert(0, sys.argv[1]); import robot_api; "
            "robot_api.configure(port=int(sys.argv[2])); m = robot_api.get_robot_pose_matrix(); "
            "print(type(m).__name__, len(m), len(m[0]), robot_api.get_robot_pose()[1])")
    src = str(__import__("pathlib").Path(robot_api.__file__).parent)
    out = subprocess.run([sys.executable, "-I", "-S", "-c", code, src, str(fake.port)],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[:3] == ["list", "4", "4"]  # without numpy: lists
    assert float(out.stdout.split()[3]) == pytest.approx(262.57)


def test_get_robot_status_is_a_dict_even_without_a_reply(api, fake, capsys):
    fake.silent = True
    api.QUERY_TIMEOUT = 0.2
    st = api.get_robot_status()
    assert st["pose"] is None and st["angles"] is None and st["stopped"] is False and st["estop"] is False
    assert "no STATUS reply" in capsys.readouterr().err


def test_enum_words_are_sent_as_their_values(api, fake):
    from parolkit.moves import CartAxis, Frame, Plane

    api.jog_cartesian(Frame.TRF, CartAxis.RZ_NEG, 30, 0.5)
    api.smooth_circle([0, 250, 200], 30, Plane.XZ, Frame.WRF, duration=4)
    assert fake.wait_for("CARTJOG") == ["CARTJOG|TRF|RZ-|30|0.5"]
    assert fake.wait_for("SMOOTH_CIRCLE") == ["SMOOTH_CIRCLE|0,250,200|30|XZ|WRF|CURRENT|DURATION|4|0"]


# ============================================================================================
# the collision world: attach / detach / zones (ext; not in robot_api: the stock API has none)
# ============================================================================================

ZONES_REPLY = ('ZONES|{"seq": 3, "ready": true, "units": "mm, deg", "zones": ['
               '{"name": "table", "kind": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "margin": 0}, '
               '{"name": "monitor", "kind": "box", "center": [300, -250, 200], "size": [400, 60, 300], '
               '"rpy": [0, 0, 30], "margin": 10}, '
               '{"name": "post", "kind": "cylinder", "center": [200, 200, 150], "axis": [0, 0, 1], "radius": 20, '
               '"height": 300, "margin": 5}], '
               '"tool": {"name": "pen", "shape": {"kind": "capsule", "start": [0, 0, 0], "end": [0, 0, 120], '
               '"radius": 8}}, '
               '"held": [{"name": "ball", "kind": "sphere", "center": [0, 0, 170], "radius": 25}, '
               '{"name": "rod", "kind": "capsule", "start": [0, 30, 10], "end": [0, 30, 170], "radius": 8}], '
               '"self_margin": 0}')


def test_attach_and_detach_send_the_datagrams_the_controller_parses_to_the_same_shapes(robot, fake):
    from parolkit.protocol import commands as C
    from parolkit.protocol.commands import parse_datagram

    r1 = robot.attach_sphere("ball", (0, 0, 170), 25)
    r2 = robot.attach_capsule("rod", [0, 30, 10], [0, 30, 170.5], 8)
    r3 = robot.detach("ball")
    r4 = robot.detach()
    assert all(r.ok for r in (r1, r2, r3, r4))
    sent = {m.split("|", 1)[0]: m.split("|", 1)[1] for m in fake.received_so_far() if "|" in m}
    assert sent[r1.id] == "ATTACH|ball|SPHERE|0.0,0.0,170.0|25.0"
    assert sent[r2.id] == "ATTACH|rod|CAPSULE|0.0,30.0,10.0|0.0,30.0,170.5|8.0"
    assert sent[r3.id] == "DETACH|ball" and sent[r4.id] == "DETACH"
    assert parse_datagram(sent[r1.id]).command == C.Attach("ball", "sphere", (0, 0, 170), (0, 0, 170), 25)
    assert parse_datagram(sent[r2.id]).command == C.Attach("rod", "capsule", (0, 30, 10), (0, 30, 170.5), 8)


@pytest.mark.parametrize("call,needle", [
    (lambda r: r.attach_sphere("ball", (0, 0), 25), "center must have 3 values (x, y, z in mm, flange frame), got 2"),
    (lambda r: r.attach_sphere("ball", (0, 1001, 0), 25), "center: y = 1001 mm is out of range [-1000, 1000] mm"),
    (lambda r: r.attach_sphere("ball", (0, 0, 0), 0), "radius = 0 mm is out of range (0, 500] mm"),
    (lambda r: r.attach_sphere("ball", (0, 0, float("nan")), 5), "center[2] must be a finite number"),
    (lambda r: r.attach_capsule("rod", (0, 0, 0), "x", 5), "end must be a list of 3 numbers"),
    (lambda r: r.attach_sphere("a|b", (0, 0, 0), 5), "name must be 1..64 characters"),
    (lambda r: r.detach(""), "name must be 1..64 characters"),
])
def test_attach_refuses_a_bad_field_before_anything_is_sent(robot, fake, call, needle):
    with pytest.raises(ParolkitValueError) as info:
        call(robot)
    assert needle in str(info.value)
    assert fake.received_so_far() == ["ACK_HERE"]


def test_zones_answers_the_collision_world_typed(robot, fake):
    fake.replies["GET_ZONES"] = ZONES_REPLY
    z = robot.zones()
    assert (z.seq, z.ready, z.tool, z.self_margin) == (3, True, "pen", 0.0)
    assert [(q.name, q.kind, q.margin) for q in z.zones] == [("table", "plane", 0.0), ("monitor", "box", 10.0),
                                                              ("post", "cylinder", 5.0)]
    assert z.zones[0].normal == (0, 0, 1) and z.zones[1].size == (400, 60, 300) and z.zones[1].rpy == (0, 0, 30)
    assert z.zones[2].radius == 20 and z.zones[2].height == 300 and z.zones[2].axis == (0, 0, 1)
    assert z.tool_shape is not None and z.tool_shape.end == (0, 0, 120) and z.tool_shape.radius == 8
    assert z.held[0].kind == "sphere" and z.held[0].center == (0, 0, 170) and z.held[0].radius == 25
    assert z.held[1].start == (0, 30, 10) and z.held[1].end == (0, 30, 170)


def test_async_robot_attaches_detaches_and_reads_the_zones_too(fake):
    fake.replies["GET_ZONES"] = ZONES_REPLY

    async def main():
        async with AsyncRobot(port=fake.port, ack_port=fake.ack_port, timeout=1.0) as r:
            res = await r.attach_capsule("rod", (0, 30, 10), (0, 30, 170), 8)
            want = f"{res.id}|ATTACH|rod|CAPSULE|0.0,30.0,10.0|0.0,30.0,170.0|8.0"
            assert res.ok and fake.wait_for("ATTACH") == [want]
            res = await r.detach("rod")
            assert res.ok
            assert (await r.zones()).held[1].name == "rod"

    asyncio.run(main())


def test_a_malformed_zones_reply_is_a_reply_error_naming_the_field(robot, fake):
    fake.replies["GET_ZONES"] = 'ZONES|{"seq": 1, "tool": {"name": "x", "shape": null}, "zones": [{"kind": "cone"}]}'
    with pytest.raises(ReplyError, match="ZONES: zone kind must be box, plane or cylinder, got 'cone'"):
        robot.zones()
