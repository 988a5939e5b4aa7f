"""The original PAROL6 client API, complete: every function of the original ``robot_api`` (and
the class ``LazyCommandTracker``) has the original signature and works against a REAL
controller (``parolkit serve --sim`` subprocess, real UDP on 127.0.0.1).

The signatures are compared with the table of tests/data/original-api.md (a copy of the
project's spec of the original client): the test parses the table (names, parameter names and
kinds, defaults) and compares it with :func:`inspect.signature`.  Then every function and
method is called and the test checks the return shape the original had and that the
(simulated) robot did what was asked.  Robot moves are short (a few mm / deg).
"""

from __future__ import annotations

import ast
import functools
import inspect
import json
import re
import socket
from datetime import datetime

import pytest
from tests.conftest import DATA_DIR, free_udp_port, start_controller, wait_until

from parolkit.client import robot_api

SPEC = DATA_DIR / "original-api.md"
STANDBY = [90, -90, 180, 0, 0, 180]
#: away from the wrist singularity of the standby pose (J5 = 0): Cartesian paths are free here
WORK = [90, -100, 160, 0, 30, 180]
#: the keys of the original's ``wait_for_ack=True`` result
ACK_KEYS = {"command", "sent_time", "status", "details", "completed", "ack_time", "command_id"}
#: the keys of the original's get_robot_status()
STATUS_KEYS = {"pose", "angles", "speeds", "io", "gripper", "stopped", "estop"}


# ============================================================================================
# the table of the spec
# ============================================================================================


def _signature_from_text(text: str) -> list[tuple[str, str, object]]:
    """``name(a, b=1, *args, c=2, **kw)`` -> [(parameter, kind, default or EMPTY), ...]."""
    node = ast.parse(f"def {text}: pass").body[0]
    assert isinstance(node, ast.FunctionDef)
    a = node.args
    out: list[tuple[str, str, object]] = []
    positional = a.posonlyargs + a.args
    defaults = [inspect.Parameter.empty] * (len(positional) - len(a.defaults)) + [
        ast.literal_eval(d) for d in a.defaults]
    for arg, default in zip(positional, defaults):
        out.append((arg.arg, "POSITIONAL_OR_KEYWORD", default))
    if a.vararg is not None:
        out.append((a.vararg.arg, "VAR_POSITIONAL", inspect.Parameter.empty))
    for arg, default in zip(a.kwonlyargs, a.kw_defaults):
        out.append((arg.arg, "KEYWORD_ONLY",
                    inspect.Parameter.empty if default is None else ast.literal_eval(default)))
    if a.kwarg is not None:
        out.append((a.kwarg.arg, "VAR_KEYWORD", inspect.Parameter.empty))
    return out


def spec_table() -> tuple[dict[str, str], dict[str, str]]:
    """(functions, LazyCommandTracker methods): name -> ``name(parameters)`` from the spec."""
    text = SPEC.read_text()
    section = text.split("## Functions and the one public class")[1].split("## ")[0]
    functions: dict[str, str] = {}
    methods: dict[str, str] = {}
    for line in section.splitlines():
        if not line.startswith("* "):
            continue
        sigs = re.findall(r"`([A-Za-z_]\w*\([^`]*?\))(?:\s*->[^`]*)?`", line)
        target = methods if line.startswith("* class `LazyCommandTracker`") else functions
        for sig in sigs:
            target[sig.partition("(")[0]] = sig
    return functions, methods


def _actual(fn) -> list[tuple[str, str, object]]:
    return [(p.name, p.kind.name, p.default) for p in inspect.signature(fn).parameters.values()]


#: the (ext) parameters parolkit adds after an original function's own: keyword-only with a
#: default, so every call the original accepted means what it meant
EXTENSIONS: dict[str, list[tuple[str, str, object]]] = {
    "move_robot_joints": [("blend", "KEYWORD_ONLY", None)],
    "move_robot_pose": [("blend", "KEYWORD_ONLY", None)],
    "move_robot_cartesian": [("blend", "KEYWORD_ONLY", None)],
}


def test_every_original_function_and_method_has_the_original_signature():
    functions, methods = spec_table()
    assert len(functions) == 36, sorted(functions)
    assert set(methods) == {"__init__", "track_command", "get_status", "wait_for_completion", "is_active"}
    for name, sig in functions.items():
        assert name in robot_api.__all__, name
        assert _actual(getattr(robot_api, name)) == _signature_from_text(sig) + EXTENSIONS.get(name, []), sig
    for name, sig in methods.items():
        assert _actual(getattr(robot_api.LazyCommandTracker, name)) == _signature_from_text(sig), sig
    assert "LazyCommandTracker" in robot_api.__all__


def test_a_call_the_original_accepted_is_never_a_type_error():
    """Keyword names of the original work (``joint_angles=`` was ``angles=`` before); the
    argument checks raise ValueError, never TypeError."""
    with pytest.raises(ValueError, match="either duration"):
        robot_api.move_robot_joints(joint_angles=STANDBY)
    with pytest.raises(ValueError, match="motions\\[0\\]\\['type'\\] must be one of"):
        robot_api.chain_smooth_motions([{"type": "zigzag"}])
    with pytest.raises(ValueError, match="frame='WRF'"):
        robot_api.execute_trajectory([[0, 250, 200, -90, 0, -90]], motion_type="linear", frame="TRF")


# ============================================================================================
# calling everything against a real controller
# ============================================================================================


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    cp = start_controller(log_dir=tmp_path_factory.mktemp("ctl"))
    yield cp
    cp.stop()


@pytest.fixture
def api(served):
    """robot_api pointed at the served controller (restored afterwards)."""
    before = robot_api.configure()
    robot_api.configure(host="127.0.0.1", port=served.port, ack_port=served.ack_port)
    yield robot_api
    robot_api.configure(**before)


class CallLog:
    """Records which original functions and tracker methods a test called itself (calls they
    make among themselves are not counted)."""

    def __init__(self, monkeypatch, functions, methods) -> None:
        self.called: set[str] = set()
        self._depth = 0
        for name in functions:
            monkeypatch.setattr(robot_api, name, self._wrap(name, getattr(robot_api, name)))
        for name in methods:
            cls = robot_api.LazyCommandTracker
            monkeypatch.setattr(cls, name, self._wrap(f"LazyCommandTracker.{name}", getattr(cls, name)))

    def _wrap(self, name, fn):
        @functools.wraps(fn)
        def recorded(*args, **kwargs):
            if self._depth == 0:
                self.called.add(name)
            self._depth += 1
            try:
                return fn(*args, **kwargs)
            finally:
                self._depth -= 1
        return recorded


def completed(result, label: str) -> dict:
    """``result`` is the original's dict of a COMPLETED command of class ``label``."""
    assert isinstance(result, dict) and ACK_KEYS <= set(result), result
    assert result["status"] == "COMPLETED" and result["completed"] is True, result
    # (a move the PC's late replies held back says so after it: "; warning: ran stretched ...")
    assert result["details"].startswith(f"{label} finished successfully"), result
    assert isinstance(result["sent_time"], datetime) and isinstance(result["ack_time"], datetime)
    assert result["ack_time"] >= result["sent_time"]
    assert isinstance(result["command_id"], str) and len(result["command_id"]) == 8
    return result


def fired(result) -> None:
    """The original's fire-and-forget confirmation."""
    assert isinstance(result, str) and result.startswith("Successfully sent command: '"), result


def near(values, want, tol: float) -> bool:
    return values is not None and all(abs(a - b) <= tol for a, b in zip(values, want))


def at_pose(api, want, tol: float = 0.5) -> bool:
    """The TCP is within ``tol`` mm of ``want`` (position only)."""
    return near(api.get_robot_pose()[:3], want[:3], tol)


def _status_json(served) -> dict:
    """The controller's status (GET_STATUS_JSON) as a dict, {} when no reply came."""
    reply = served.query("GET_STATUS_JSON", 2.0) or ""
    return json.loads(reply.split("|", 1)[1]) if reply.startswith("STATUS_JSON|") else {}


def settle(api) -> None:
    assert api.wait_for_robot_stopped(timeout=15, poll_rate=0.05)


@pytest.mark.slow
def test_every_original_function_runs_against_the_controller_and_the_robot_does_it(api, served, monkeypatch,
                                                                                     capsys):
    functions, methods = spec_table()
    log = CallLog(monkeypatch, functions, methods)
    api = robot_api

    # ---- sending: fire and forget, tracked, send_and_wait -----------------------------------
    fired(api.send_robot_command("MOVEJOINT|" + "|".join(map(str, WORK)) + "|2.0|None"))
    wait_until(lambda: near(api.get_robot_joint_angles(), WORK, 0.02), 20, what="at WORK")
    msg, cid = api.send_robot_command_tracked("DELAY|0.1")
    assert msg == f"Command sent with tracking (ID: {cid})"
    wait_until(lambda: (api.check_command_status(cid) or {}).get("completed"), 10, what="DELAY done")
    assert api.check_command_status(cid)["history"] == ["QUEUED", "EXECUTING", "COMPLETED"]
    completed(api.check_command_status(cid), "Delay")
    completed(api.send_and_wait("DELAY|0.1", timeout=5.0), "Delay")
    cid = api.send_and_wait("DELAY|0.1", 5.0, True)
    assert isinstance(cid, str) and len(cid) == 8
    wait_until(lambda: (api.check_command_status(cid) or {}).get("status") == "COMPLETED", 10)
    assert api.is_tracking_active() is True
    stats = api.get_tracking_stats()
    assert {"active", "commands_tracked", "memory_bytes", "thread_active"} <= set(stats)
    assert stats["active"] and stats["thread_active"] and stats["ack_port"] == served.ack_port
    assert api.check_command_status("zz99ZZ99") is None  # never sent

    # ---- joint moves and jogs ---------------------------------------------------------------
    target = [95, -100, 160, 5, 30, 175]
    completed(api.move_robot_joints(joint_angles=target, duration=1.5, wait_for_ack=True, timeout=15),
              "MoveJoint")
    assert near(api.get_robot_joint_angles(), target, 0.02)
    fired(api.move_robot_joints(WORK, None, 60))  # positional, as the original's scripts call it
    wait_until(lambda: near(api.get_robot_joint_angles(), WORK, 0.02), 20, what="back at WORK")
    settle(api)
    j = api.get_robot_joint_angles()
    completed(api.jog_robot_joint(0, 20, duration=0.3, wait_for_ack=True, timeout=10), "Jog")
    assert api.get_robot_joint_angles()[0] > j[0] + 0.5  # J1 turned positive
    j = api.get_robot_joint_angles()
    completed(api.jog_robot_joint(6, 20, distance_deg=2, wait_for_ack=True, timeout=10), "Jog")
    assert api.get_robot_joint_angles()[0] == pytest.approx(j[0] - 2, abs=0.05)  # J1 -2 deg
    j = api.get_robot_joint_angles()
    completed(api.jog_multiple_joints([0, 7], [20, 20], 0.3, wait_for_ack=True, timeout=10), "MultiJog")
    j2 = api.get_robot_joint_angles()
    assert j2[0] > j[0] + 0.5 and j2[1] < j[1] - 0.5  # J1 +, J2 -
    completed(api.move_robot_joints(WORK, duration=1.5, wait_for_ack=True, timeout=15), "MoveJoint")

    # ---- Cartesian moves --------------------------------------------------------------------
    home_pose = api.get_robot_pose()
    x, y, z, a, b, c = home_pose
    p = api.get_robot_pose()
    completed(api.jog_cartesian("wrf", "z+", 20, 0.3, wait_for_ack=True, timeout=10), "CartJog")
    q = api.get_robot_pose()
    assert q[2] > p[2] + 1.0 and near(q[:2], p[:2], 0.5)  # up along world Z only
    completed(api.move_robot_pose([x, y, z - 10, a, b, c], duration=1.5, wait_for_ack=True, timeout=15),
              "MovePose")
    assert at_pose(api, [x, y, z - 10])
    completed(api.move_robot_cartesian([x + 10, y, z - 10, a, b, c], speed_percentage=50,
                                       wait_for_ack=True, timeout=15), "MoveCart")
    assert at_pose(api, [x + 10, y, z - 10])
    cid = api.move_robot_cartesian(home_pose, duration=1.5, wait_for_ack=True, non_blocking=True)
    wait_until(lambda: api.is_robot_stopped() is False, 5, interval=0.005, what="moving")
    assert api.wait_for_robot_stopped(timeout=15, poll_rate=0.05) is True
    wait_until(lambda: (api.check_command_status(cid) or {}).get("completed"), 10)
    completed(api.check_command_status(cid), "MoveCart")
    assert at_pose(api, home_pose)

    # ---- IO and grippers --------------------------------------------------------------------
    completed(api.control_pneumatic_gripper("open", 1, wait_for_ack=True), "PneumaticGripper")
    assert api.get_robot_io()[2] == 1
    completed(api.control_pneumatic_gripper("close", 1, wait_for_ack=True), "PneumaticGripper")
    assert api.get_robot_io()[2] == 0
    assert api.is_estop_pressed() is False
    # COMPLETED once the gripper reports calibrated (a move sent after it is not lost)
    completed(api.control_electric_gripper("calibrate", wait_for_ack=True, timeout=20), "ElectricGripper")
    assert api.get_electric_gripper_status()[4] & 0x01
    completed(api.control_electric_gripper("move", position=100, speed=150, current=200, wait_for_ack=True),
              "ElectricGripper")
    wait_until(lambda: api.get_electric_gripper_status()[1] == 100, 10, what="gripper at 100")

    # ---- smooth paths (from the WORK pose: x, y, z) -----------------------------------------
    completed(api.smooth_circle([x + 10, y, z], 10, plane="XY", frame="WRF", duration=4.0,
                                wait_for_ack=True, timeout=20), "SmoothCircle")
    assert at_pose(api, home_pose)  # a full circle ends where it started
    completed(api.smooth_arc_center([x + 20, y, z, a, b, c], [x + 10, y, z], duration=2.0,
                                    wait_for_ack=True, timeout=20), "SmoothArcCenter")
    assert at_pose(api, [x + 20, y, z])
    # back over a 20 mm chord on a 20 mm radius: a 60 deg arc
    completed(api.smooth_arc_parametric([x, y, z, a, b, c], 20, 60, duration=2.0, wait_for_ack=True,
                                        timeout=20), "SmoothArcParam")
    assert at_pose(api, home_pose)
    completed(api.smooth_spline([[x + 5, y, z, a, b, c], [x + 10, y, z, a, b, c]], duration=2.0,
                                wait_for_ack=True, timeout=20), "SmoothSpline")
    assert at_pose(api, [x + 10, y, z])
    # one turn of 5 mm pitch around the axis through (x, y): up 5 mm, same place
    completed(api.smooth_helix([x, y, z], 10, 5, 5, duration=3.0, wait_for_ack=True, timeout=20),
              "SmoothHelix")
    assert at_pose(api, [x + 10, y, z + 5])
    # the original's blend: DEFAULT timing, a SPLINE segment as n|wp;wp|duration
    completed(api.smooth_blend([{"type": "LINE", "end": [x, y, z + 5, a, b, c], "duration": 1.0},
                                {"type": "SPLINE", "waypoints": [[x, y, z + 2, a, b, c], [x, y, z, a, b, c]],
                                 "duration": 1.0}], wait_for_ack=True, timeout=20), "SmoothBlend")
    assert at_pose(api, home_pose)
    chain = api.chain_smooth_motions([
        {"type": "arc", "end_pose": [x + 20, y, z, a, b, c], "center": [x + 10, y, z], "duration": 2.0},
        {"type": "spline", "waypoints": [[x + 10, y, z, a, b, c], [x, y, z, a, b, c]], "duration": 2.0},
    ])
    assert isinstance(chain, list) and len(chain) == 2
    completed(chain[0], "SmoothArcCenter")
    completed(chain[1], "SmoothSpline")
    # continuity: the spline was sent starting at the arc's end pose
    assert chain[1]["command"].split("|")[3] == ",".join(map(str, [x + 20, y, z, a, b, c]))
    assert at_pose(api, home_pose)
    completed(api.execute_trajectory([[x + 5, y, z, a, b, c], [x + 10, y, z, a, b, c]], "duration", 2.0),
              "SmoothSpline")
    assert at_pose(api, [x + 10, y, z])
    linear = api.execute_trajectory([[x + 10, y, z - 5, a, b, c], [x, y, z - 5, a, b, c]], timing_mode="speed",
                                    timing_value=50, motion_type="linear")
    assert isinstance(linear, list) and len(linear) == 2
    for r in linear:
        completed(r, "MoveCart")
    assert at_pose(api, [x, y, z - 5])

    # ---- delay, stop, retry -----------------------------------------------------------------
    r = completed(api.delay_robot(0.3, wait_for_ack=True, timeout=5), "Delay")
    assert (r["ack_time"] - r["sent_time"]).total_seconds() >= 0.3
    before = api.get_robot_joint_angles()
    far = [60, -100, 160, 0, 30, 180]
    cid = api.move_robot_joints(far, duration=4.0, wait_for_ack=True, non_blocking=True)
    # STOP once a quarter of the move has run (its progress on the controller, not a sleep)
    wait_until(lambda: (_status_json(served).get("command") or {}).get("progress", 0) >= 0.25, 10)
    stop = api.stop_robot_movement(wait_for_ack=True)
    # a planned move slows down on its path, then ends CANCELLED (issue 24)
    assert stop["status"] == "COMPLETED" and stop["details"].startswith("stopping: the running move slows down")
    wait_until(lambda: (api.check_command_status(cid) or {}).get("status") == "CANCELLED", 5)
    settle(api)
    j = api.get_robot_joint_angles()
    assert before[0] - 1.0 > j[0] > far[0] + 5  # stopped on the way
    completed(api.safe_move_with_retry(api.move_robot_joints, WORK, duration=2.0, max_retries=2,
                                       retry_delay=0.1, timeout=15), "MoveJoint")
    assert near(api.get_robot_joint_angles(), WORK, 0.02)
    tracked = api.get_tracking_stats()["commands_tracked"]
    failed = api.safe_move_with_retry(api.move_robot_pose, [900, 0, 0, 0, 0, 0], duration=1, max_retries=2,
                                      retry_delay=0.05)
    assert failed["status"] == "FAILED" and "reach" in failed["details"]
    assert api.get_tracking_stats()["commands_tracked"] == tracked + 2  # tried twice
    assert near(api.get_robot_joint_angles(), WORK, 0.02)  # nothing moved

    # ---- queries ----------------------------------------------------------------------------
    pose = api.get_robot_pose()
    assert isinstance(pose, list) and len(pose) == 6 and all(isinstance(v, float) for v in pose)
    m = api.get_robot_pose_matrix()
    assert type(m).__name__ == "ndarray" and m.shape == (4, 4)
    assert list(m[:3, 3] * 1000) == pytest.approx(pose[:3], abs=0.01) and list(m[3]) == [0, 0, 0, 1]
    assert near(api.get_robot_joint_angles(), WORK, 0.02)
    io = api.get_robot_io(verbose=True)
    assert io == [0, 0, 0, 0, 1] and "ESTOP" in capsys.readouterr().out
    g = api.get_electric_gripper_status(verbose=True)
    assert len(g) == 6 and g[1] == 100 and "Electric gripper" in capsys.readouterr().out
    assert api.get_robot_joint_speeds() == [0.0] * 6
    assert api.is_robot_stopped() is True and api.is_robot_stopped(threshold_speed=2.0) is True
    st = api.get_robot_status()
    assert STATUS_KEYS <= set(st) and st["pose"] == pytest.approx(pose, abs=0.01)
    assert st["angles"] == pytest.approx(WORK, abs=0.02) and st["io"] == io and st["stopped"] is True
    assert st["estop"] is False and st["serial"] is True

    # ---- the tracker class on its own (the module's listener is moved away from the ack port) --
    api.configure(ack_port=free_udp_port())
    t = api.LazyCommandTracker(listen_port=served.ack_port, history_size=10)
    try:
        assert t.is_active() is False and t.get_status("zz99ZZ99") is None
        assert t.wait_for_completion("zz99ZZ99", timeout=0.1)["status"] == "NO_TRACKING"
        tracked_text, cid = t.track_command("DELAY|0.2")
        assert tracked_text == f"{cid}|DELAY|0.2" and t.is_active() is True
        assert t.get_status(cid)["status"] == "SENT"
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:  # sent as a user would
            s.sendto(tracked_text.encode(), ("127.0.0.1", served.port))
        completed(t.wait_for_completion(cid, timeout=5.0), "Delay")
        assert t.get_status(cid)["history"] == ["QUEUED", "EXECUTING", "COMPLETED"]
        _, slow = t.track_command("DELAY|3")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(f"{slow}|DELAY|3".encode(), ("127.0.0.1", served.port))
        late = t.wait_for_completion(slow)  # the original's default timeout: 5 s
        assert late["status"] == "COMPLETED"
        _, never = t.track_command("DELAY|0.1")  # registered, never sent
        gone = t.wait_for_completion(never, timeout=0.2)
        assert gone["status"] == "TIMEOUT" and gone["completed"] is False and gone["last_status"] == "SENT"
    finally:
        t.close()
        api.configure(ack_port=served.ack_port)

    # ---- homing last: it ends at standby ----------------------------------------------------
    completed(api.home_robot(wait_for_ack=True, timeout=60), "Home")
    assert near(api.get_robot_joint_angles(), STANDBY, 0.01)
    assert api.wait_for_robot_stopped(timeout=10.0, poll_rate=0.1) is True

    want = set(functions) | {f"LazyCommandTracker.{n}" for n in methods}
    assert want - log.called == set(), "not called: " + ", ".join(sorted(want - log.called))


def test_a_gripper_move_sent_right_after_calibrate_is_never_lost(api):
    """Issue 22 item 9, as reported: ``control_electric_gripper('calibrate', wait_for_ack=True)``
    returned COMPLETED after 0.02 s and the move sent next arrived during the SSG-48's 1 s
    calibration and was lost for good.  Now the calibrate returns once the gripper reports
    calibrated, and the move then runs; so does a move sent without waiting at all (it queues
    behind the calibration)."""
    completed(api.control_electric_gripper("calibrate", wait_for_ack=True, timeout=10), "ElectricGripper")
    assert api.get_electric_gripper_status()[4] & 0x01, "COMPLETED before the gripper reported calibrated"
    completed(api.control_electric_gripper("move", position=180, speed=255, current=400, wait_for_ack=True),
              "ElectricGripper")
    wait_until(lambda: api.get_electric_gripper_status()[1] == 180, 10, what="the gripper at 180")
    # the seed's script without its time.sleep(2): calibrate and move back to back
    cal = api.control_electric_gripper("calibrate", wait_for_ack=True, non_blocking=True)
    move = api.control_electric_gripper("move", position=60, speed=255, current=400, wait_for_ack=True,
                                        timeout=10)
    completed(move, "ElectricGripper")
    completed(api.check_command_status(cal), "ElectricGripper")
    wait_until(lambda: api.get_electric_gripper_status()[1] == 60, 10, what="the gripper at 60")


# ============================================================================================
# the replies the original client parses, byte for byte
# ============================================================================================


def test_replies_the_original_client_parses_have_its_exact_form(served):
    """The original parsed ``TAG|payload`` with ``split('|')`` and ``len(parts) == 2``,
    compared ``PONG`` as text, and read acks as ``ACK|ID|STATUS|details``."""
    number = r"-?\d+(?:\.\d+)?"
    forms = {
        "GET_POSE": rf"POSE\|{number}(?:,{number}){{15}}",
        "GET_ANGLES": rf"ANGLES\|{number}(?:,{number}){{5}}",
        "GET_IO": r"IO\|[01](?:,[01]){4}",
        "GET_GRIPPER": r"GRIPPER\|\d+(?:,\d+){5}",
        "GET_SPEEDS": r"SPEEDS\|-?\d+(?:,-?\d+){5}",
        "PING": r"PONG",
    }
    ack_port = served.ack_port
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as acks:
        acks.bind(("127.0.0.1", ack_port))
        acks.settimeout(10)
        s.settimeout(5)
        for query, form in forms.items():
            s.sendto(query.encode(), ("127.0.0.1", served.port))
            reply = s.recvfrom(65535)[0].decode()
            assert re.fullmatch(form, reply), (query, reply)
        s.sendto(b"abcd1234|DELAY|0.05", ("127.0.0.1", served.port))
        seen: list[str] = []
        while not seen or seen[-1].split("|")[2] in ("QUEUED", "EXECUTING"):
            seen.append(acks.recvfrom(65535)[0].decode())
    assert seen == ["ACK|abcd1234|QUEUED|Position 1 in queue", "ACK|abcd1234|EXECUTING|",
                    "ACK|abcd1234|COMPLETED|Delay finished successfully"]
