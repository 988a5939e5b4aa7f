"""``parolkit moveit-config -o DIR``: a MoveIt 2 configuration generated from parolkit's own models.

    parolkit moveit-config -o DIR [--joint-convention parolkit|community] [--tool NAME]
                                  [--namespace NS] [--rate HZ] [--config FILE]

Writes into ``DIR`` (created if missing):

* ``parol6.urdf``: :func:`parolkit.ros2.urdf.make_urdf` (the collision model's shapes as
  ``<collision>`` elements, velocity limits = what the controller accepts for a trajectory);
* ``parol6.srdf``: group ``parol6_arm`` (the chain ``base_link`` -> ``tcp``), group ``tool``
  (link ``tcp``) as its end effector, named states ``standby`` (:attr:`RobotModel.standby_deg`)
  and ``home`` (where HOME leaves the arm: :attr:`RobotModel.standby_steps`, the counts the
  firmware writes when homing ends, in degrees), and a ``<disable_collisions>`` for every pair of
  links whose shapes always touch or never touch in parolkit's collision model
  (:func:`disabled_pairs`);
* ``joint_limits.yaml``: per joint the URDF's position limits (rad), ``max_velocity`` (rad/s,
  the URDF's: the position-tracking maximum,
  :func:`parolkit.ros2.urdf.trajectory_velocity_limits_rad_s`) and
  ``max_acceleration`` (rad/s^2, :attr:`RobotModel.max_accel_deg_s2`), and default scaling
  factors that keep MoveIt's plans within what the controller accepts between the waypoints
  (:data:`DEFAULT_VELOCITY_SCALING`, :data:`DEFAULT_ACCELERATION_SCALING`);
* ``kinematics.yaml``: the KDL plugin for ``parol6_arm``;
* ``moveit_controllers.yaml``: ``moveit_simple_controller_manager`` with one
  ``FollowJointTrajectory`` controller, ``parol6_arm_controller`` (action
  ``parol6_arm_controller/follow_joint_trajectory``, served by ``parolkit ros2``), and
  MoveIt's start tolerance = ``[ros2] start_tolerance_rad``.  No ros2_control: parolkit's
  controller is the controller;
* ``README.txt``: how to use it.

``--joint-convention community`` writes every joint value (limits, named states) in the
community PAROL6 URDF's zeros and signs (:mod:`parolkit.ros2.convention`); run ``parolkit ros2``
with ``[ros2] joint_convention = "community"`` to publish and accept the same.

The YAML files are written by :func:`to_yaml`, a writer for the small subset they need
(mappings, lists of plain strings, numbers, booleans); no YAML library is needed.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

import numpy as np

from parolkit.errors import ParolkitError, ParolkitValueError
from parolkit.robot import RobotModel, steps_to_deg
from parolkit.ros2.convention import CONVENTIONS, JointConvention
from parolkit.ros2.urdf import (
    BASE_LINK,
    FLANGE_LINK,
    ROS_JOINT_NAMES,
    TCP_LINK,
    collision_link,
    make_urdf,
    tool_settings,
    trajectory_velocity_limits_rad_s,
    urdf_convention,
    urdf_rate_hz,
)

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.collision.model import CollisionModel
    from parolkit.config import Config, ToolSettings

__all__ = [
    "ARM_GROUP", "TOOL_GROUP", "CONTROLLER_NAME", "ACTION_NS", "KINEMATICS_PLUGIN", "ROBOT_NAME",
    "DEFAULT_VELOCITY_SCALING", "DEFAULT_ACCELERATION_SCALING", "FILES",
    "DisabledPair", "named_states_deg", "disabled_pairs", "make_srdf", "joint_limits", "kinematics",
    "moveit_controllers", "to_yaml", "write_moveit_config", "register",
]

ROBOT_NAME = "parol6"
ARM_GROUP = "parol6_arm"
TOOL_GROUP = "tool"
CONTROLLER_NAME = "parol6_arm_controller"
ACTION_NS = "follow_joint_trajectory"
KINEMATICS_PLUGIN = "kdl_kinematics_plugin/KDLKinematicsPlugin"
#: The files :func:`write_moveit_config` writes, in order.
FILES = ("parol6.urdf", "parol6.srdf", "joint_limits.yaml", "kinematics.yaml", "moveit_controllers.yaml",
         "README.txt")

#: MoveIt's time parameterisation keeps the WAYPOINTS within the limits; parolkit's controller
#: joins them with cubics (the message's accelerations are not used), which between waypoints
#: 0.1 s apart (MoveIt's resampling) reach up to 1.70x the plan's acceleration and a few
#: percent over its speed (4.3 % at ten times the speed per second, the steepest acceleration
#: a configuration allows).  At these default scaling factors every such plan stays within the
#: speed and acceleration the controller accepts (tests/unit/test_moveit_config.py plans 720
#: time-optimal trajectories of every joint at them: all accepted, on time; at 1.0 / 1.0 nearly
#: all are refused).  A plan scaled higher may be refused, with the factor to slow it by.
DEFAULT_VELOCITY_SCALING = 0.95
DEFAULT_ACCELERATION_SCALING = 0.5


@dataclass(frozen=True)
class DisabledPair:
    """Two links MoveIt need not check against each other, and MoveIt's word for why:
    ``Adjacent`` (neighbours in the chain, their shapes always touch), ``Always`` (not
    neighbours, but in contact in every sampled configuration) or ``Never`` (never in contact)."""

    link1: str
    link2: str
    reason: str


def named_states_deg(model: RobotModel) -> dict[str, tuple[float, ...]]:
    """The SRDF's named states in parolkit's joint angles (deg): ``standby`` (the standby pose)
    and ``home`` (where HOME leaves the arm: the firmware overwrites the counters with
    :attr:`RobotModel.standby_steps` when homing ends; the same pose to a fraction of a step)."""
    home = steps_to_deg(list(model.standby_steps), model)
    return {"standby": tuple(float(v) for v in model.standby_deg), "home": tuple(float(v) for v in home)}


def _links_with_geometry(links_of_bodies: Sequence[str]) -> list[str]:
    """The chain's links (base to tcp) that carry a collision shape, in chain order."""
    chain = [BASE_LINK, *ROS_JOINT_NAMES, FLANGE_LINK, TCP_LINK]
    return [link for link in chain if link in set(links_of_bodies)]


def disabled_pairs(collision_model: CollisionModel, tool: ToolSettings | None = None) -> list[DisabledPair]:
    """Every pair of links MoveIt need not check, from parolkit's collision model's pair
    table (:meth:`CollisionModel.pair_table`, with ``tool``'s shape when it has one): every
    body pair between the two links is either excluded (in contact in every sampled
    configuration: they meet at a joint) or never in contact in the samples (parolkit's
    controller still checks those).  Reason ``Adjacent`` for an
    excluded pair of neighbouring links (links without shapes in between do not count, as
    MoveIt's setup assistant counts them), ``Always`` for one that is not, ``Never`` else."""
    bodies = collision_model.all_bodies(tool)
    link_of = {b.name: collision_link(b.frame) for b in bodies}
    geometry = _links_with_geometry(list(link_of.values()))
    position = {link: i for i, link in enumerate(geometry)}
    verdicts: dict[tuple[str, str], list[str]] = {}
    for p in collision_model.pair_table(tool).pairs:
        la, lb = link_of[p.a], link_of[p.b]
        if la == lb:
            continue  # on one link: not a pair of links
        key = (la, lb) if position[la] < position[lb] else (lb, la)
        if not p.checked:
            verdicts.setdefault(key, []).append("contact")
        elif p.min_mm > 0.0:
            verdicts.setdefault(key, []).append("never")
        else:
            verdicts.setdefault(key, []).append("check")
    out = []
    for (la, lb), kinds in sorted(verdicts.items(), key=lambda kv: (position[kv[0][0]], position[kv[0][1]])):
        if "check" in kinds:
            continue
        if "contact" in kinds:
            reason = "Adjacent" if position[lb] - position[la] == 1 else "Always"
        else:
            reason = "Never"
        out.append(DisabledPair(la, lb, reason))
    return out


def _joint_values(convention: JointConvention, q_deg: Sequence[float]) -> list[tuple[str, float]]:
    return list(zip(ROS_JOINT_NAMES, (float(v) for v in convention.to_ros_rad(q_deg))))


def _num(v: float) -> str:
    """A float written so that it reads back exactly; -0 as 0."""
    return repr(float(v) + 0.0)


def make_srdf(model: RobotModel, convention: JointConvention, pairs: Sequence[DisabledPair]) -> str:
    """The SRDF document (XML text): the arm group, the tool group as its end effector, the
    named states (in ``convention``) and ``pairs`` as ``<disable_collisions>``."""
    out = [
        '<?xml version="1.0"?>',
        "<!-- Generated by `parolkit moveit-config` from parolkit.robot and parolkit.collision. Do not edit. -->",
        f"<!-- Joint convention: {convention.name} (parolkit.ros2.convention) -->",
        f"<robot name={quoteattr(ROBOT_NAME)}>",
        f"  <group name={quoteattr(ARM_GROUP)}>",
        f"    <chain base_link={quoteattr(BASE_LINK)} tip_link={quoteattr(TCP_LINK)}/>",
        "  </group>",
        f"  <group name={quoteattr(TOOL_GROUP)}>",
        f"    <link name={quoteattr(TCP_LINK)}/>",
        "  </group>",
    ]
    for state, q_deg in named_states_deg(model).items():
        out.append(f"  <group_state name={quoteattr(state)} group={quoteattr(ARM_GROUP)}>")
        out.extend(f"    <joint name={quoteattr(j)} value=\"{_num(v)}\"/>" for j, v in _joint_values(convention, q_deg))
        out.append("  </group_state>")
    out.append(f"  <end_effector name={quoteattr(TOOL_GROUP)} parent_link={quoteattr(TCP_LINK)} "
               f"group={quoteattr(TOOL_GROUP)} parent_group={quoteattr(ARM_GROUP)}/>")
    out.append("  <!-- link pairs that always touch at a joint (Adjacent, Always) or never touch (Never) in "
               "parolkit's collision model's pair table (docs/collision.md) -->")
    out.extend(f"  <disable_collisions link1={quoteattr(p.link1)} link2={quoteattr(p.link2)} "
               f"reason={quoteattr(p.reason)}/>" for p in pairs)
    out.append("</robot>")
    return "\n".join(out) + "\n"


def acceleration_limits_rad_s2(model: RobotModel) -> NDArray[np.float64]:
    """Each joint's acceleration limit (rad/s^2): :attr:`RobotModel.max_accel_deg_s2`."""
    return np.radians(model.max_accel_deg_s2)


def joint_limits(model: RobotModel, rate_hz: float, convention: JointConvention) -> dict[str, object]:
    """joint_limits.yaml: per joint the position limits (rad, the URDF's, in ``convention``:
    copied over another configuration's, they keep its plans inside parolkit's ranges), the
    velocity limits the controller accepts (the URDF's) and the acceleration limits; the
    default scaling factors."""
    pos = np.radians(convention.limits_deg(model.safe_limits_deg))
    vel = trajectory_velocity_limits_rad_s(model, rate_hz)
    acc = acceleration_limits_rad_s2(model)
    return {
        "default_velocity_scaling_factor": DEFAULT_VELOCITY_SCALING,
        "default_acceleration_scaling_factor": DEFAULT_ACCELERATION_SCALING,
        "joint_limits": {name: {"has_position_limits": True, "min_position": float(pos[i, 0]),
                                "max_position": float(pos[i, 1]),
                                "has_velocity_limits": True, "max_velocity": float(vel[i]),
                                "has_acceleration_limits": True, "max_acceleration": float(acc[i])}
                         for i, name in enumerate(ROS_JOINT_NAMES)},
    }


def kinematics() -> dict[str, object]:
    """kinematics.yaml: KDL for the arm group."""
    return {ARM_GROUP: {"kinematics_solver": KINEMATICS_PLUGIN, "kinematics_solver_search_resolution": 0.005,
                        "kinematics_solver_timeout": 0.05}}


def moveit_controllers(start_tolerance_rad: float) -> dict[str, object]:
    """moveit_controllers.yaml: MoveIt's simple controller manager with the one
    FollowJointTrajectory controller ``parolkit ros2`` serves; MoveIt's start tolerance is
    the bridge's (``[ros2] start_tolerance_rad``)."""
    return {
        "moveit_controller_manager": "moveit_simple_controller_manager/MoveItSimpleControllerManager",
        "moveit_simple_controller_manager": {
            "controller_names": [CONTROLLER_NAME],
            CONTROLLER_NAME: {"type": "FollowJointTrajectory", "action_ns": ACTION_NS, "default": True,
                              "joints": list(ROS_JOINT_NAMES)},
        },
        "trajectory_execution": {"allowed_start_tolerance": float(start_tolerance_rad)},
    }


# ---- a YAML writer for the subset above ----------------------------------------------------------------------

_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_./-]*")
_RESERVED = {"true", "false", "yes", "no", "on", "off", "null", "y", "n", "~"}


def _scalar(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ParolkitValueError(f"to_yaml: {v!r} is not a finite number")
        text = _num(v)
        mantissa, e, exponent = text.partition("e")
        # YAML 1.1 readers (PyYAML: what ROS 2 launch files load parameters with) take a float
        # only with a decimal point: 1e-300 is written 1.0e-300
        return (mantissa if "." in mantissa else mantissa + ".0") + e + exponent
    if isinstance(v, str) and _PLAIN.fullmatch(v) and v.lower() not in _RESERVED:
        return v
    raise ParolkitValueError(f"to_yaml: {v!r} is not a plain string, a number or a boolean")


def to_yaml(data: Mapping[str, object], indent: int = 0) -> str:
    """``data`` as block YAML: nested mappings (string keys), lists of scalars, and scalars
    (booleans, integers, finite floats written to read back exactly and always with a decimal
    point, plain strings: a letter or ``_`` then letters, digits, ``_./-``).  Anything else is a ParolkitValueError."""
    pad = " " * indent
    lines = []
    for key, value in data.items():
        k = _scalar(key)
        if isinstance(value, Mapping):
            lines.append(f"{pad}{k}:")
            lines.append(to_yaml(value, indent + 2).rstrip("\n"))
        elif isinstance(value, list):
            lines.append(f"{pad}{k}:")
            lines.extend(f"{pad}  - {_scalar(item)}" for item in value)
        else:
            lines.append(f"{pad}{k}: {_scalar(value)}")
    return "\n".join(lines) + "\n"


# ---- the directory ----------------------------------------------------------------------------------------------


def _readme(convention: JointConvention, namespace: str, rate_hz: float, tool: str | None) -> str:
    ns = f"/{namespace}" if namespace else ""
    conv_line = ("parolkit's own joint angles (the bridge's default)" if convention.is_identity else
                 f"the {convention.name} convention: run the bridge with [ros2] joint_convention = "
                 f"\"{convention.name}\" in its parolkit.toml")
    return f"""MoveIt 2 configuration for the PAROL6, generated by `parolkit moveit-config`
===========================================================================

Joint values: {conv_line}.
Velocity limits: what parolkit's controller accepts for a trajectory at {rate_hz:g} Hz.
Tool at link 'tcp': {tool or "the default tool"}.

Files
  parol6.urdf              the robot (collision shapes = parolkit's collision model)
  parol6.srdf              group '{ARM_GROUP}' (base_link -> tcp), end effector '{TOOL_GROUP}',
                           named states 'standby' and 'home', <disable_collisions> for the link
                           pairs that always touch at a joint or never touch (parolkit's collision
                           model's pair table; parolkit's controller still checks the latter)
  joint_limits.yaml        position limits (rad, the URDF's), max_velocity (rad/s) and
                           max_acceleration (rad/s^2) per joint;
                           default scaling {DEFAULT_VELOCITY_SCALING:g} / {DEFAULT_ACCELERATION_SCALING:g}: \
higher may be refused
  kinematics.yaml          KDL for '{ARM_GROUP}'
  moveit_controllers.yaml  moveit_simple_controller_manager -> the FollowJointTrajectory action
                           {ns}/{CONTROLLER_NAME}/{ACTION_NS} that `parolkit ros2` serves

Use (ROS 2 Jazzy with MoveIt 2 on the ROS machine; parolkit needs no ROS)
  1. On the robot PC:   parolkit serve --port /dev/ttyACM0
                        parolkit ros2{f" --namespace {namespace}" if namespace else ""}
  2. On the ROS machine, make a package for the files:
        ros2 pkg create parol6_parolkit_moveit_config --build-type ament_cmake
        mkdir -p parol6_parolkit_moveit_config/config parol6_parolkit_moveit_config/launch
        cp parol6.urdf parol6.srdf *.yaml parol6_parolkit_moveit_config/config/
     add   install(DIRECTORY config launch DESTINATION share/${{PROJECT_NAME}})   to its CMakeLists.txt
     and write launch/move_group.launch.py:
{_launch_file(namespace)}
  3. colcon build --packages-select parol6_parolkit_moveit_config && source install/setup.bash
  4. ros2 launch parol6_parolkit_moveit_config move_group.launch.py
     ({"move_group runs in the bridge's namespace " + ns + ": joint_states and the action resolve there"
       if namespace else "the bridge runs without a namespace: /joint_states, /" + CONTROLLER_NAME + "/..."})
  5. Plan and execute from RViz's MotionPlanning panel or the MoveIt API; the plan goes to the
     action, parolkit's controller checks it whole before anything moves and runs it on time.

docs/ros2.md ("MoveIt with the generated config") has the details.
"""


def _launch_file(namespace: str) -> str:
    """A move_group launch file for the package of README step 2 (in the bridge's namespace)."""
    lines = ["from launch import LaunchDescription",
             "from launch.actions import GroupAction",
             "from launch_ros.actions import PushRosNamespace",
             "from moveit_configs_utils import MoveItConfigsBuilder",
             "from moveit_configs_utils.launches import generate_move_group_launch",
             "",
             "def generate_launch_description():",
             '    config = (MoveItConfigsBuilder("parol6", package_name="parol6_parolkit_moveit_config")',
             '              .robot_description(file_path="config/parol6.urdf")',
             '              .robot_description_semantic(file_path="config/parol6.srdf")',
             '              .joint_limits(file_path="config/joint_limits.yaml")',
             '              .robot_description_kinematics(file_path="config/kinematics.yaml")',
             '              .trajectory_execution(file_path="config/moveit_controllers.yaml")',
             '              .planning_pipelines(pipelines=["ompl"])',
             "              .to_moveit_configs())",
             "    move_group = generate_move_group_launch(config).entities",
             f'    return LaunchDescription([GroupAction([PushRosNamespace("{namespace}"), *move_group])])'
             if namespace else "    return LaunchDescription(move_group)"]
    if not namespace:
        lines = [ln for ln in lines if "GroupAction" not in ln and "PushRosNamespace" not in ln]
    return "\n".join(f"        {ln}" if ln else "" for ln in lines)


def write_moveit_config(out_dir: Path, cfg: Config, *, tool: str | None = None,
                        convention: str | JointConvention | None = None, namespace: str | None = None,
                        rate_hz: float | None = None, collision_model: CollisionModel | None = None) -> list[Path]:
    """Write :data:`FILES` into ``out_dir`` (created if missing); the paths written.
    ``convention``, ``namespace`` and ``rate_hz`` default to the config's."""
    from parolkit.collision.model import CollisionModel

    conv = urdf_convention(cfg, convention)
    rate = urdf_rate_hz(cfg, rate_hz)
    ns = (cfg.ros2.namespace if namespace is None else namespace).strip("/")
    model = cfg.robot
    cm = collision_model if collision_model is not None else CollisionModel(model)
    texts = {
        "parol6.urdf": make_urdf(model, tool, ROBOT_NAME, cfg, cm, rate_hz=rate, convention=conv),
        "parol6.srdf": make_srdf(model, conv, disabled_pairs(cm, tool_settings(tool, cfg))),
        "joint_limits.yaml": _yaml_file("joint_limits.yaml", joint_limits(model, rate, conv)),
        "kinematics.yaml": _yaml_file("kinematics.yaml", kinematics()),
        "moveit_controllers.yaml": _yaml_file("moveit_controllers.yaml",
                                              moveit_controllers(cfg.ros2.start_tolerance_rad)),
        "README.txt": _readme(conv, ns, rate, tool),
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name in FILES:
        path = out_dir / name
        path.write_text(texts[name], encoding="utf-8")
        written.append(path)
    return written


def _yaml_file(name: str, data: Mapping[str, object]) -> str:
    head = f"# {name}: generated by `parolkit moveit-config` (parolkit.ros2.moveit_config). Do not edit.\n"
    return head + to_yaml(data)


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser], name: str) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        name, help="write a MoveIt 2 configuration (URDF, SRDF, limits, kinematics, controllers) for the PAROL6",
        description="Write a MoveIt 2 configuration generated from parolkit's robot and collision models into "
        "DIR: parol6.urdf, parol6.srdf, joint_limits.yaml, kinematics.yaml, moveit_controllers.yaml (the "
        "FollowJointTrajectory action of `parolkit ros2`) and README.txt.")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR", help="the directory to write")
    p.add_argument("--joint-convention", choices=sorted(CONVENTIONS), default=None,
                   help="joint zeros and signs: parolkit's or the community PAROL6 URDF's "
                   "(default: config [ros2] joint_convention)")
    p.add_argument("--tool", default=None, help="tool at link 'tcp' (default: the original commander's TCP)")
    p.add_argument("--namespace", default=None, help="the bridge's ROS namespace (default: config [ros2])")
    p.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help="the controller's rate the velocity limits are for (default: config [controller])")
    p.add_argument("--config", type=Path, default=None, help="parolkit.toml to use")
    p.set_defaults(func=_run)
    return p


def _run(args: argparse.Namespace) -> int:
    from parolkit.config import load_config

    try:
        cfg = load_config(args.config, overrides={"ros2": {"namespace": args.namespace,
                                                           "joint_convention": args.joint_convention},
                                                  "controller": {"rate_hz": args.rate}})
        written = write_moveit_config(args.output, cfg, tool=args.tool)
    except ParolkitError as exc:
        print(f"parolkit moveit-config: {exc}", file=sys.stderr)
        return 2
    print(f"parolkit moveit-config: wrote {len(written)} files to {args.output} ({', '.join(p.name for p in written)})")
    return 0
