"""ROS 2 action types as cyclonedds IDL structs: action_msgs, unique_identifier_msgs,
service_msgs, control_msgs' FollowJointTrajectory and GripperCommand.

As :mod:`parolkit.ros2.msgs`: a message ``pkg/msg/Name`` is the DDS type
``pkg::msg::dds_::Name_``, the fields in the exact order and types of the ROS 2 Jazzy
definitions (control_msgs 5.x; its ``.action``/``.msg`` files are in tests/data/control_msgs),
so that their RIHS01 type hashes (:mod:`parolkit.ros2.type_hash`) equal ROS's own.

An action ``pkg/action/Name`` with goal, result and feedback structs has, as rosidl generates
them (:func:`action_types`):

* ``Name_SendGoal_Request {UUID goal_id; Name_Goal goal}``,
  ``Name_SendGoal_Response {bool accepted; builtin_interfaces/Time stamp}``;
* ``Name_GetResult_Request {UUID goal_id}``, ``Name_GetResult_Response {int8 status; Name_Result result}``;
* ``Name_FeedbackMessage {UUID goal_id; Name_Feedback feedback}``;
* the services ``Name_SendGoal`` / ``Name_GetResult`` and their ``_Event`` messages (service
  introspection; part of the type description, never sent by parolkit).

A service's request and reply travel on DDS as rmw_cyclonedds_cpp lays them out: a request
header ``{uint64 guid; int64 seq}`` in front of the message (:func:`service_wire_type`).

No ``from __future__ import annotations``: cyclonedds resolves the annotations at run time.
"""

import dataclasses
import types
import typing
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int8, int32, int64, uint8, uint16, uint64

from parolkit.ros2.msgs import Duration, JointTrajectory, JointTrajectoryPoint, MsgHeader, Time, Transform, Vector3

if TYPE_CHECKING:  # for the type checker a sequence or array field is a list (what it holds at run time)
    from builtins import list as sequence

    Bytes16 = list[int]
    OneCancelRequest = list["CancelGoal_Request"]
    OneCancelResponse = list["CancelGoal_Response"]
else:
    from cyclonedds.idl.types import sequence

    Bytes16 = array[uint8, 16]

__all__ = [
    "UUID", "GoalInfo", "GoalStatus", "GoalStatusArray", "CancelGoal_Request", "CancelGoal_Response",
    "CancelGoal_Event", "ServiceEventInfo", "Twist", "MultiDOFJointTrajectoryPoint", "MultiDOFJointTrajectory",
    "JointTolerance", "JointComponentTolerance", "FollowJointTrajectory_Goal", "FollowJointTrajectory_Result",
    "FollowJointTrajectory_Feedback", "GripperCommand", "GripperCommand_Goal", "GripperCommand_Result",
    "GripperCommand_Feedback", "ActionTypes", "action_types", "service_types", "service_wire_type",
    "FOLLOW_JOINT_TRAJECTORY", "GRIPPER_COMMAND", "CANCEL_GOAL", "wrap", "unwrap", "HEADER_FIELDS",
]


def _uuid16() -> list[int]:
    return [0] * 16


# ---- unique_identifier_msgs, action_msgs, service_msgs ----

@dataclass
class UUID(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
    """unique_identifier_msgs/msg/UUID: 16 bytes (a goal's id)."""

    uuid: Bytes16 = field(default_factory=_uuid16)


@dataclass
class GoalInfo(IdlStruct, typename="action_msgs::msg::dds_::GoalInfo_"):
    """action_msgs/msg/GoalInfo: a goal's id and the time it was accepted."""

    goal_id: UUID = field(default_factory=UUID)
    stamp: Time = field(default_factory=Time)


@dataclass
class GoalStatus(IdlStruct, typename="action_msgs::msg::dds_::GoalStatus_"):
    """action_msgs/msg/GoalStatus (the STATUS_* constants)."""

    goal_info: GoalInfo = field(default_factory=GoalInfo)
    status: int8 = 0

    STATUS_UNKNOWN = 0
    STATUS_ACCEPTED = 1
    STATUS_EXECUTING = 2
    STATUS_CANCELING = 3
    STATUS_SUCCEEDED = 4
    STATUS_CANCELED = 5
    STATUS_ABORTED = 6


@dataclass
class GoalStatusArray(IdlStruct, typename="action_msgs::msg::dds_::GoalStatusArray_"):
    """action_msgs/msg/GoalStatusArray: the ``_action/status`` topic."""

    status_list: sequence[GoalStatus] = field(default_factory=list)


@dataclass
class ServiceEventInfo(IdlStruct, typename="service_msgs::msg::dds_::ServiceEventInfo_"):
    """service_msgs/msg/ServiceEventInfo (``char[16] client_gid`` is uint8 in IDL, as rosidl maps char)."""

    event_type: uint8 = 0
    stamp: Time = field(default_factory=Time)
    client_gid: Bytes16 = field(default_factory=_uuid16)
    sequence_number: int64 = 0


@dataclass
class CancelGoal_Request(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Request_"):
    """action_msgs/srv/CancelGoal request: which goals (zero id: all; zero stamp: no time bound)."""

    goal_info: GoalInfo = field(default_factory=GoalInfo)


@dataclass
class CancelGoal_Response(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Response_"):
    """action_msgs/srv/CancelGoal response (the ERROR_* return codes)."""

    return_code: int8 = 0
    goals_canceling: sequence[GoalInfo] = field(default_factory=list)

    ERROR_NONE = 0
    ERROR_REJECTED = 1
    ERROR_UNKNOWN_GOAL_ID = 2
    ERROR_GOAL_TERMINATED = 3


if not TYPE_CHECKING:
    OneCancelRequest = sequence[CancelGoal_Request, 1]
    OneCancelResponse = sequence[CancelGoal_Response, 1]


@dataclass
class CancelGoal_Event(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Event_"):
    """action_msgs/srv/CancelGoal's introspection event (type description only)."""

    info: ServiceEventInfo = field(default_factory=ServiceEventInfo)
    request: OneCancelRequest = field(default_factory=list)
    response: OneCancelResponse = field(default_factory=list)


# ---- geometry_msgs / trajectory_msgs used by FollowJointTrajectory ----

@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    """geometry_msgs/msg/Twist."""

    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class MultiDOFJointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::MultiDOFJointTrajectoryPoint_"):
    """trajectory_msgs/msg/MultiDOFJointTrajectoryPoint."""

    transforms: sequence[Transform] = field(default_factory=list)
    velocities: sequence[Twist] = field(default_factory=list)
    accelerations: sequence[Twist] = field(default_factory=list)
    time_from_start: Duration = field(default_factory=Duration)


@dataclass
class MultiDOFJointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::MultiDOFJointTrajectory_"):
    """trajectory_msgs/msg/MultiDOFJointTrajectory (the PAROL6 has none: must be empty)."""

    header: MsgHeader = field(default_factory=MsgHeader)
    joint_names: sequence[str] = field(default_factory=list)
    points: sequence[MultiDOFJointTrajectoryPoint] = field(default_factory=list)


# ---- control_msgs ----

@dataclass
class JointTolerance(IdlStruct, typename="control_msgs::msg::dds_::JointTolerance_"):
    """control_msgs/msg/JointTolerance: rad, rad/s, rad/s^2; 0 = the default, -1 = not checked."""

    name: str = ""
    position: float64 = 0.0
    velocity: float64 = 0.0
    acceleration: float64 = 0.0


@dataclass
class JointComponentTolerance(IdlStruct, typename="control_msgs::msg::dds_::JointComponentTolerance_"):
    """control_msgs/msg/JointComponentTolerance (multi-DOF joints; the PAROL6 has none)."""

    joint_name: str = ""
    component: uint16 = 0
    position: float64 = 0.0
    velocity: float64 = 0.0
    acceleration: float64 = 0.0


@dataclass
class FollowJointTrajectory_Goal(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_Goal_"):
    """control_msgs/action/FollowJointTrajectory goal."""

    trajectory: JointTrajectory = field(default_factory=JointTrajectory)
    multi_dof_trajectory: MultiDOFJointTrajectory = field(default_factory=MultiDOFJointTrajectory)
    path_tolerance: sequence[JointTolerance] = field(default_factory=list)
    component_path_tolerance: sequence[JointComponentTolerance] = field(default_factory=list)
    goal_tolerance: sequence[JointTolerance] = field(default_factory=list)
    component_goal_tolerance: sequence[JointComponentTolerance] = field(default_factory=list)
    goal_time_tolerance: Duration = field(default_factory=Duration)


@dataclass
class FollowJointTrajectory_Result(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_Result_"):
    """control_msgs/action/FollowJointTrajectory result (the error codes as constants)."""

    error_code: int32 = 0
    error_string: str = ""

    SUCCESSFUL = 0
    INVALID_GOAL = -1
    INVALID_JOINTS = -2
    OLD_HEADER_TIMESTAMP = -3
    PATH_TOLERANCE_VIOLATED = -4
    GOAL_TOLERANCE_VIOLATED = -5


@dataclass
class FollowJointTrajectory_Feedback(IdlStruct,
                                     typename="control_msgs::action::dds_::FollowJointTrajectory_Feedback_"):
    """control_msgs/action/FollowJointTrajectory feedback: desired, actual and error (desired - actual)."""

    header: MsgHeader = field(default_factory=MsgHeader)
    joint_names: sequence[str] = field(default_factory=list)
    desired: JointTrajectoryPoint = field(default_factory=JointTrajectoryPoint)
    actual: JointTrajectoryPoint = field(default_factory=JointTrajectoryPoint)
    error: JointTrajectoryPoint = field(default_factory=JointTrajectoryPoint)
    multi_dof_joint_names: sequence[str] = field(default_factory=list)
    multi_dof_desired: MultiDOFJointTrajectoryPoint = field(default_factory=MultiDOFJointTrajectoryPoint)
    multi_dof_actual: MultiDOFJointTrajectoryPoint = field(default_factory=MultiDOFJointTrajectoryPoint)
    multi_dof_error: MultiDOFJointTrajectoryPoint = field(default_factory=MultiDOFJointTrajectoryPoint)


@dataclass
class GripperCommand(IdlStruct, typename="control_msgs::msg::dds_::GripperCommand_"):
    """control_msgs/msg/GripperCommand: position (the gap, m) and max_effort."""

    position: float64 = 0.0
    max_effort: float64 = 0.0


@dataclass
class GripperCommand_Goal(IdlStruct, typename="control_msgs::action::dds_::GripperCommand_Goal_"):
    """control_msgs/action/GripperCommand goal."""

    command: GripperCommand = field(default_factory=GripperCommand)


@dataclass
class GripperCommand_Result(IdlStruct, typename="control_msgs::action::dds_::GripperCommand_Result_"):
    """control_msgs/action/GripperCommand result."""

    position: float64 = 0.0
    effort: float64 = 0.0
    stalled: bool = False
    reached_goal: bool = False


@dataclass
class GripperCommand_Feedback(IdlStruct, typename="control_msgs::action::dds_::GripperCommand_Feedback_"):
    """control_msgs/action/GripperCommand feedback."""

    position: float64 = 0.0
    effort: float64 = 0.0
    stalled: bool = False
    reached_goal: bool = False


# ---- the generated wrappers (as rosidl generates them) ----

def _typename(cls: type) -> str:
    name: str = cls.__idl_typename__  # type: ignore[attr-defined]
    return name


def _struct(typename: str, fields: list[tuple[str, Any, Any]]) -> type[Any]:
    """A dataclass IdlStruct ``typename`` with ``fields`` (name, annotation, default factory)."""
    pyname = typename.split("::")[-1].rstrip("_")

    def body(ns: dict[str, Any]) -> None:
        ns["__annotations__"] = {n: t for n, t, _ in fields}
        for n, _, factory in fields:
            ns[n] = field(default_factory=factory)

    cls = types.new_class(pyname, (IdlStruct,), {"typename": typename}, body)
    return dataclass(cls)


def _bounded(element: type, n: int) -> Any:
    """The annotation ``sequence[element, n]`` (a bounded sequence)."""
    from cyclonedds.idl.types import sequence as bounded

    return typing.cast(Any, bounded)[element, n]


def _event_type(service_typename: str, request: type, response: type) -> type[Any]:
    return _struct(f"{service_typename}_Event_", [
        ("info", ServiceEventInfo, ServiceEventInfo),
        ("request", _bounded(request, 1), list),
        ("response", _bounded(response, 1), list),
    ])


@dataclass(frozen=True)
class ServiceTypes:
    """A service's request, response and (introspection) event types; ``name``: pkg/srv/Name."""

    name: str
    request: type[Any]
    response: type[Any]
    event: type[Any]


def service_types(name: str, request: type, response: type) -> ServiceTypes:
    """The :class:`ServiceTypes` of service ``name`` (``pkg/srv/Name`` or ``pkg/action/Name_SendGoal``)."""
    base = "::".join(name.split("/")[:2]) + "::dds_::" + name.split("/")[2]
    return ServiceTypes(name, request, response, _event_type(base, request, response))


@dataclass(frozen=True)
class ActionTypes:
    """Every type of action ``name`` (``pkg/action/Name``), as rosidl generates them."""

    name: str
    goal: type[Any]
    result: type[Any]
    feedback: type[Any]
    send_goal: ServiceTypes
    get_result: ServiceTypes
    feedback_message: type[Any]


def action_types(name: str, goal: type, result: type, feedback: type) -> ActionTypes:
    """The :class:`ActionTypes` of action ``name`` = ``pkg/action/Name`` from its goal, result and
    feedback structs (whose typenames must be ``pkg::action::dds_::Name_Goal_`` etc.)."""
    pkg, kind, short = name.split("/")
    base = f"{pkg}::{kind}::dds_::{short}"
    for cls, part in ((goal, "Goal"), (result, "Result"), (feedback, "Feedback")):
        if _typename(cls) != f"{base}_{part}_":
            raise ValueError(f"{name}: the {part.lower()} type must be {base}_{part}_, got {_typename(cls)}")
    send_req = _struct(f"{base}_SendGoal_Request_", [("goal_id", UUID, UUID), ("goal", goal, goal)])
    send_resp = _struct(f"{base}_SendGoal_Response_", [("accepted", bool, bool), ("stamp", Time, Time)])
    get_req = _struct(f"{base}_GetResult_Request_", [("goal_id", UUID, UUID)])
    get_resp = _struct(f"{base}_GetResult_Response_", [("status", int8, int), ("result", result, result)])
    fb = _struct(f"{base}_FeedbackMessage_", [("goal_id", UUID, UUID), ("feedback", feedback, feedback)])
    return ActionTypes(
        name, goal, result, feedback,
        ServiceTypes(f"{name}_SendGoal", send_req, send_resp, _event_type(f"{base}_SendGoal", send_req, send_resp)),
        ServiceTypes(f"{name}_GetResult", get_req, get_resp, _event_type(f"{base}_GetResult", get_req, get_resp)),
        fb)


_WIRE: dict[type, type[Any]] = {}
#: the request header's fields on the wire, in front of the message's
HEADER_FIELDS = ("guid", "seq")


def service_wire_type(message: type) -> type[Any]:
    """The DDS type of a service request or reply ``message`` on the wire: the same typename,
    rmw_cyclonedds_cpp's request header ``{uint64 guid; int64 seq}`` in front of the message's
    own fields (flat: one struct, as rmw_cyclonedds_cpp serializes them; a struct nested in one
    of the same name would be a recursive type).  :func:`wrap` / :func:`unwrap` convert."""
    wire = _WIRE.get(message)
    if wire is None:
        hints = typing.get_type_hints(message, include_extras=True)
        own = [(f.name, hints[f.name], _factory(f)) for f in dataclasses.fields(message)]
        if any(n in HEADER_FIELDS for n, _, _ in own):
            raise ValueError(f"{message.__name__}: a field is named like the request header's {HEADER_FIELDS}")
        wire = _struct(_typename(message), [("guid", uint64, int), ("seq", int64, int), *own])
        _WIRE[message] = wire
    return wire


def _factory(f: "dataclasses.Field[Any]") -> Any:
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory
    value = f.default
    return lambda: value


def wrap(body: Any, guid: int, seq: int) -> Any:
    """``body`` (a request or reply) with its request header, ready to write."""
    values = {f.name: getattr(body, f.name) for f in dataclasses.fields(body)}
    return service_wire_type(type(body))(guid=guid, seq=seq, **values)


def unwrap(sample: Any, message: type) -> Any:
    """The ``message`` (a request or reply type) a wire sample carries (without its header)."""
    return message(**{f.name: getattr(sample, f.name) for f in dataclasses.fields(message)})


FOLLOW_JOINT_TRAJECTORY = action_types("control_msgs/action/FollowJointTrajectory", FollowJointTrajectory_Goal,
                                       FollowJointTrajectory_Result, FollowJointTrajectory_Feedback)
GRIPPER_COMMAND = action_types("control_msgs/action/GripperCommand", GripperCommand_Goal, GripperCommand_Result,
                               GripperCommand_Feedback)
CANCEL_GOAL = ServiceTypes("action_msgs/srv/CancelGoal", CancelGoal_Request, CancelGoal_Response, CancelGoal_Event)
