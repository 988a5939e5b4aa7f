"""The types users of ``parolkit.Robot`` / ``parolkit.AsyncRobot`` see.

Every public method of both clients and of the values they return is typed without ``Any``:
a command gives its :class:`CommandResult` (``wait=True``) or a handle (``wait=False``, chosen
by ``@overload`` on ``wait``), a query its typed value, and on ``AsyncRobot`` a coroutine of
the same.  mypy runs (``--strict`` and ``disallow_any_expr``) on a user script against THIS
checkout (tests/conftest.py::run_mypy): ``assert_type`` pins the intended type of each call,
and code that misuses a result must be refused.  A static walk over the annotations
(``typing.get_type_hints``, each overload too) finds no ``Any`` in the public surface.
"""

from __future__ import annotations

import dataclasses
import inspect
import types
import typing
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TypeVar

import pytest
from tests.conftest import run_mypy

import parolkit.client as client
from parolkit.client.async_robot import AsyncRobot
from parolkit.client.robot import Robot

#: A user's script: every line with assert_type states what the call gives.
USER_SCRIPT = '''
import asyncio
from typing import assert_type

from parolkit import AsyncRobot, Robot
from parolkit.client import (
    AckStatus, ActiveCommand, AsyncCommandHandle, CommandFailed, CommandHandle, CommandNotCompleted,
    CommandResult, ControlInfo, ControllerUnreachable, GripperState, IOState, LoopStats, PlanInfo,
    Pose, QueueInfo, RobotError, RobotState, RobotStatus, StatusSubscription, ToolInfo,
)

STANDBY = [90.0, -90.0, 180.0, 0.0, 0.0, 180.0]
ABOVE = [0.0, 250.0, 200.0, -90.0, 0.0, -90.0]


def drive(robot: Robot, really: bool) -> None:
    assert_type(robot.enable(), CommandResult)
    assert_type(robot.home(), CommandResult)
    done = robot.move_joints(STANDBY, duration=2.0)
    assert_type(done, CommandResult)
    assert_type(done.status, AckStatus)
    assert_type(done.ok, bool)
    assert_type(done.details, str)
    assert_type(robot.move_pose(ABOVE, speed=50, profile="trap"), CommandResult)
    assert_type(robot.move_cart(ABOVE, duration=1.0, wait=True, timeout=5.0), CommandResult)
    assert_type(robot.move_cart_rel_trf([0.0, 0.0, -10.0, 0.0, 0.0, 0.0], speed=20), CommandResult)
    assert_type(robot.move_cart(ABOVE, speed=50, blend=10.0, wait=False), CommandHandle)
    assert_type(robot.move_joints(STANDBY, speed=50, blend=5), CommandResult)
    assert_type(robot.move_pose(ABOVE, None, 50, None, None, None, True, None, blend=2.5), CommandResult)
    assert_type(robot.move_joint_path([STANDBY, STANDBY], [1.0, 2.0]), CommandResult)

    moving = robot.move_joints(STANDBY, duration=2.0, wait=False)
    assert_type(moving, CommandHandle)
    assert_type(moving.id, str)
    assert_type(moving.command, str)
    assert_type(moving.status(), AckStatus | None)
    assert_type(moving.done(), bool)
    assert_type(moving.result(), CommandResult)
    assert_type(moving.result(10.0, raise_on_error=True), CommandResult)
    outcome = moving.result(timeout=10.0, raise_on_error=False)
    assert_type(outcome, CommandResult | CommandNotCompleted)
    if isinstance(outcome, CommandNotCompleted):
        assert_type(outcome.reason, str)
        assert_type(outcome.command_id, str)
    else:
        assert_type(outcome.details, str)
    assert_type(moving.result(raise_on_error=really), CommandResult | CommandNotCompleted)
    assert_type(robot.move_joints(STANDBY, duration=2.0, wait=really), CommandResult | CommandHandle)

    assert_type(robot.jog_joint(1, 30.0, duration=0.5), CommandHandle)
    assert_type(robot.jog_joint(-2, 30.0, distance=5.0, wait=True), CommandResult)
    assert_type(robot.jog_multiple([1, -3], [20.0, 30.0], 1.0), CommandHandle)
    assert_type(robot.jog_cartesian("WRF", "Z+", 20.0, 1.0), CommandHandle)
    assert_type(robot.speed_joint([1.0, 0.0, 0.0, 0.0, 0.0, 0.0], 1.0), CommandResult)
    assert_type(robot.delay(0.5, wait=False), CommandHandle)

    assert_type(robot.smooth_circle([0.0, 250.0, 200.0], 30.0, duration=4.0), CommandResult)
    assert_type(robot.smooth_arc_center(ABOVE, [0.0, 240.0, 200.0], speed=40.0), CommandResult)
    assert_type(robot.smooth_arc_param(ABOVE, 20.0, 90.0, duration=3.0, wait=False), CommandHandle)
    assert_type(robot.smooth_spline([ABOVE, ABOVE], duration=3.0), CommandResult)
    assert_type(robot.smooth_helix([0.0, 250.0, 200.0], 20.0, 5.0, 20.0, duration=5.0), CommandResult)
    assert_type(robot.smooth_blend([{"type": "LINE", "end": ABOVE, "duration": 2.0}]), CommandResult)

    assert_type(robot.set_output(1, True), CommandResult)
    assert_type(robot.pneumatic("open", 2, wait=False), CommandHandle)
    assert_type(robot.wait_input(1, "high", input_timeout=5.0), CommandResult)
    assert_type(robot.gripper_calibrate(), CommandResult)
    assert_type(robot.gripper_move(100, speed=150, current=400, wait=False), CommandHandle)
    assert_type(robot.gripper_clear_error(), CommandResult)
    grip = robot.gripper()
    assert_type(grip, GripperState)
    assert_type(grip.position, int)
    assert_type(grip.object_detected, bool)
    io = robot.io()
    assert_type(io, IOState)
    assert_type(io.in1, bool)
    assert_type(io.estop_pressed, bool)

    status = robot.status()
    assert_type(status, RobotStatus)
    assert_type(status.state, RobotState)
    assert_type(status.can_move, bool)
    assert_type(status.angles, tuple[float, ...])
    assert_type(status.pose, Pose)
    assert_type(status.pose.x, float)
    assert_type(status.io.out1, bool)
    assert_type(status.gripper.status_text, str)
    assert_type(status.errors.message, str | None)
    assert_type(status.board.timing_ms, float)
    assert_type(status.loop.rate_hz, float)
    assert_type(status.command, ActiveCommand | None)
    assert_type(status.raw, dict[str, object])
    assert_type(robot.angles(), tuple[float, ...])
    assert_type(robot.pose(), Pose)
    assert_type(robot.pose().c, float)
    assert_type(robot.pose_matrix(), tuple[tuple[float, ...], ...])
    assert_type(robot.speeds(), tuple[float, ...])
    assert_type(robot.loop_stats(), LoopStats)
    assert_type(robot.plan_info(), PlanInfo)
    assert_type(robot.queue(), QueueInfo)
    assert_type(robot.queue().queued, tuple[tuple[str | None, str], ...])
    assert_type(robot.tool(), ToolInfo)
    assert_type(robot.ping(), bool)
    assert_type(robot.link_up(), bool)
    assert_type(robot.wait_until_idle(timeout=10.0), RobotStatus)

    lease = robot.control()
    assert_type(lease, ControlInfo)
    assert_type(lease["holder"], str | None)
    assert_type(lease["timeout_s"], float)
    assert_type(robot.take_control(force=True), CommandResult)
    assert_type(robot.release_control(), CommandResult)

    try:
        robot.move_pose([900.0, 0.0, 0.0, 0.0, 0.0, 0.0], duration=1.0)
    except CommandFailed as exc:
        assert_type(exc.reason, str)
        assert_type(exc.status, str)
    except ControllerUnreachable as exc:
        assert_type(exc, ControllerUnreachable)
    except RobotError as exc:
        assert_type(exc, RobotError)

    with robot.subscribe(every_n=10) as stream:
        assert_type(stream, StatusSubscription)
        for st in stream:
            assert_type(st, RobotStatus)
            break
        assert_type(stream.next(timeout=1.0), RobotStatus)
    assert_type(robot.stream(True), CommandResult)
    assert_type(robot.set_tool("flange"), CommandResult)
    assert_type(robot.stop(), CommandResult)
    assert_type(robot.disable(), CommandResult)
    assert_type(robot.clear_error(), CommandResult)
    assert_type(robot.estop(), CommandResult)


async def drive_async(robot: AsyncRobot, really: bool) -> None:
    assert_type(await robot.open(), AsyncRobot)
    assert_type(await robot.enable(), CommandResult)
    assert_type(await robot.move_joints(STANDBY, duration=2.0), CommandResult)
    handle = await robot.move_pose(ABOVE, duration=2.0, wait=False)
    assert_type(await robot.move_cart(ABOVE, duration=2.0, blend=10.0), CommandResult)
    assert_type(handle, AsyncCommandHandle)
    assert_type(handle.status(), AckStatus | None)
    assert_type(await handle.result(), CommandResult)
    assert_type(await handle.result(5.0, raise_on_error=False), CommandResult | CommandNotCompleted)
    assert_type(await robot.home(wait=really), CommandResult | AsyncCommandHandle)
    assert_type(await robot.jog_joint(3, 20.0, duration=0.3), AsyncCommandHandle)
    assert_type(await robot.jog_cartesian("TRF", "RZ-", 20.0, 0.3, wait=True), CommandResult)
    assert_type(robot.send_nowait("JOG|2|30|0.2|None"), AsyncCommandHandle)

    homing = asyncio.create_task(robot.home())
    assert_type(await homing, CommandResult)
    pose, angles = await asyncio.gather(robot.pose(), robot.angles())
    assert_type(pose, Pose)
    assert_type(angles, tuple[float, ...])
    assert_type(await asyncio.wait_for(robot.status(), 1.0), RobotStatus)
    assert_type((await robot.status()).state, RobotState)
    assert_type(await robot.io(), IOState)
    assert_type(await robot.gripper(), GripperState)
    assert_type(await robot.gripper_move(50), CommandResult)
    assert_type(await robot.control(), ControlInfo)
    assert_type(await robot.ping(), bool)
    assert_type(await robot.wait_until_idle(), RobotStatus)
    async with robot.subscribe(every_n=10) as stream:
        async for st in stream:
            assert_type(st, RobotStatus)
            break
    assert_type(await robot.stop(), CommandResult)
    await robot.close()


def legacy() -> None:
    """An existing PAROL6 script (robot_api): the original dicts and lists, typed."""
    from robot_api import (
        CommandRecord, RobotStatusDict, TrackingStats, check_command_status, get_control,
        get_robot_io, get_robot_joint_angles, get_robot_pose, get_robot_status,
        get_tracking_stats, home_robot, move_robot_joints, ping_robot, send_and_wait,
    )

    assert_type(move_robot_joints(STANDBY, duration=2.0), CommandRecord | str | None)
    record = send_and_wait("HOME", timeout=30.0)
    assert_type(record, CommandRecord)
    assert_type(record["status"], str)
    assert_type(record["completed"], bool)
    assert_type(send_and_wait("HOME", non_blocking=True), str | None)
    assert_type(home_robot(wait_for_ack=True, timeout=30.0), CommandRecord | str | None)
    assert_type(check_command_status("abcd1234"), CommandRecord | None)
    assert_type(get_robot_joint_angles(), list[float] | None)
    assert_type(get_robot_pose(), list[float] | None)
    assert_type(get_robot_io(), list[int] | None)
    status = get_robot_status()
    assert_type(status, RobotStatusDict)
    assert_type(status["angles"], list[float] | None)
    assert_type(status["serial"], bool | None)
    assert_type(status["estop"], bool)
    assert_type(get_control(), ControlInfo | None)
    assert_type(get_tracking_stats(), TrackingStats)
    assert_type(ping_robot(), bool | None)


def main() -> None:
    with Robot("127.0.0.1", 5001, timeout=2.0) as robot:
        assert_type(robot, Robot)
        drive(robot, really=True)

    async def run() -> None:
        async with AsyncRobot() as robot:
            assert_type(robot, AsyncRobot)
            await drive_async(robot, really=False)

    asyncio.run(run())
'''

#: Misuses a type checker must refuse: (line, what mypy's error on that line says).
REFUSED = [
    ("handle: CommandHandle = robot.move_joints(STANDBY)",
     'expression has type "CommandResult", variable has type "CommandHandle"'),
    ("robot.move_joints(STANDBY, wait=False).details", '"CommandHandle" has no attribute "details"'),
    ("robot.jog_joint(1, 30.0).ok", '"CommandHandle" has no attribute "ok"'),
    ("robot.home(wait=False).result(raise_on_error=False).details",
     'Item "CommandNotCompleted" of "CommandResult | CommandNotCompleted" has no attribute "details"'),
    ("robot.pose().w", '"Pose" has no attribute "w"'),
    ("robot.status().state = 'IDLE'", 'Property "state" defined in "RobotStatus" is read-only'),
    ("robot.control()['owner']", 'TypedDict "ControlInfo" has no key "owner"'),
    ("robot.set_output(1, 2)", 'No overload variant of "set_output" of "RobotCommands" matches argument types'),
    ("robot.move_cart(ABOVE, speed=50, blend='10')",
     'No overload variant of "move_cart" of "RobotCommands" matches argument types'),
    ("x: float = arobot.pose().x", '"Coroutine[object, None, Pose]" has no attribute "x"'),
    ("robot_api.get_robot_status()['speed']", 'TypedDict "RobotStatusDict" has no key "speed"'),
    ("robot_api.move_robot_joints(STANDBY)['status']",
     'Value of type "CommandRecord | str | None" is not indexable'),
    ("done: CommandResult = arobot.home()",
     'expression has type "Coroutine[object, None, CommandResult]", variable has type "CommandResult"'),
]
_REFUSED_HEADER = """\
import robot_api
from parolkit.client import AsyncRobot, CommandHandle, CommandResult, Robot

STANDBY = [90.0, -90.0, 180.0, 0.0, 0.0, 180.0]
robot = Robot()
arobot = AsyncRobot()
"""


@pytest.fixture(scope="module")
def mypy_errors(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[int, list[str]]]:
    return run_mypy(tmp_path_factory.mktemp("client_typing"), {
        "user_script.py": USER_SCRIPT.lstrip(),
        "refused.py": _REFUSED_HEADER + "".join(f"{code}\n" for code, _ in REFUSED),
    }, "disallow_any_expr = True")


def test_a_user_script_type_checks_strictly_with_every_call_of_its_intended_type_and_no_any(mypy_errors):
    errors = mypy_errors["user_script.py"]
    lines = USER_SCRIPT.lstrip().splitlines()
    assert errors == {}, "\n".join(f"{n}: {lines[n - 1].strip()}\n    {m}" for n, ms in errors.items() for m in ms)
    assert sum("assert_type(" in line for line in lines) > 100  # (not vacuous)


@pytest.mark.parametrize("k", range(len(REFUSED)), ids=[code for code, _ in REFUSED])
def test_misusing_a_result_is_a_type_error(mypy_errors, k):
    code, message = REFUSED[k]
    line = _REFUSED_HEADER.count("\n") + 1 + k
    assert any(message in e for e in mypy_errors["refused.py"].get(line, [])), (code, mypy_errors["refused.py"])


# =============================================================================================
# the annotations themselves: no Any in the public surface
# =============================================================================================


_PAROLKIT = Path(client.__file__).resolve().parents[1]


def _parolkit_function(obj: object) -> bool:
    """A function written in parolkit's source (not one generated by dataclass or NamedTuple)."""
    return inspect.isfunction(obj) and Path(obj.__code__.co_filename).resolve().is_relative_to(_PAROLKIT)


def _public_functions(cls: type) -> Iterator[tuple[str, Any]]:
    """(name, function) of each public method, property getter and dunder of ``cls`` written in
    parolkit (inherited ones included), every ``@overload`` variant separately."""
    for name in dir(cls):
        if name.startswith("_") and not (name.startswith("__") and name.endswith("__")):
            continue
        attr = inspect.getattr_static(cls, name)
        if isinstance(attr, property):
            attr = attr.fget
        elif isinstance(attr, (staticmethod, classmethod)):
            attr = attr.__func__
        if not _parolkit_function(attr):
            continue
        variants = typing.get_overloads(attr)
        for k, fn in enumerate(variants):
            yield f"{cls.__name__}.{name} (overload {k + 1})", fn
        yield f"{cls.__name__}.{name}", attr


def _bindings(cls: type) -> dict[TypeVar, object]:
    """Type variable -> the type ``cls`` binds it to through its generic bases
    (``Robot(RobotCommands[CommandResult, CommandHandle])``)."""
    out: dict[TypeVar, object] = {}
    for klass in cls.__mro__:
        for base in getattr(klass, "__orig_bases__", ()):
            params = getattr(typing.get_origin(base), "__parameters__", ())
            for var, arg in zip(params, typing.get_args(base)):
                out.setdefault(var, arg)
    return out


def _any_in(tp: object, bound: dict[TypeVar, object], seen: set[type], where: str) -> list[str]:
    """Where ``Any`` (or an unbound type variable) occurs in ``tp``; the parolkit classes it
    names are walked as well (their fields and public methods)."""
    if tp is Any:
        return [where]
    if isinstance(tp, TypeVar):
        return _any_in(bound[tp], bound, seen, where) if tp in bound else [f"{where}: unbound {tp}"]
    if isinstance(tp, type) and tp.__module__.startswith("parolkit.") and tp not in seen:
        seen.add(tp)
        return _class_any(tp, seen)
    found: list[str] = []
    for arg in typing.get_args(tp):
        if isinstance(arg, (list, tuple)):  # Callable[[args], result]
            for a in arg:
                found += _any_in(a, bound, seen, where)
        elif arg is not Ellipsis and not isinstance(arg, (str, int, bool, types.NoneType)):
            found += _any_in(arg, bound, seen, where)
    return found


def _class_any(cls: type, seen: set[type]) -> list[str]:
    bound = _bindings(cls)
    found: list[str] = []
    if dataclasses.is_dataclass(cls) or typing.is_typeddict(cls) or hasattr(cls, "_fields"):
        for name, hint in typing.get_type_hints(cls).items():
            found += _any_in(hint, bound, seen, f"{cls.__name__}.{name}")
    for where, fn in _public_functions(cls):
        hints = typing.get_type_hints(fn)
        params = [p for p in inspect.signature(fn).parameters.values()
                  if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
        missing = [p.name for p in params if p.name not in hints] + (["return"] * ("return" not in hints))
        found += [f"{where}: {m} not annotated" for m in missing]
        for name, hint in hints.items():
            found += _any_in(hint, bound, seen, f"{where} {name}")
    return found


@pytest.mark.parametrize("cls", [Robot, AsyncRobot], ids=lambda c: c.__name__)
def test_no_public_method_of_the_client_or_of_what_it_returns_is_typed_any(cls):
    seen: set[type] = {cls}
    found = _class_any(cls, seen)
    assert found == [], "\n".join(found)
    walked = {c.__name__ for c in seen}
    assert {"CommandResult", "RobotStatus", "Pose", "GripperState", "ControlInfo", "AckRecord"} <= walked
    assert {"CommandHandle", "AsyncCommandHandle"} & walked  # (not vacuous)


def test_every_value_type_a_user_annotates_with_is_exported_from_parolkit_client():
    seen: set[type] = {Robot, AsyncRobot}
    _class_any(Robot, seen)
    _class_any(AsyncRobot, seen)
    user_facing = {c.__name__ for c in seen if not c.__name__.startswith("_")} - {
        "AckRecord", "RobotCommands", "QuerySpec"}
    assert user_facing <= set(client.__all__), user_facing - set(client.__all__)
    assert all(getattr(client, name) is not None for name in client.__all__)
