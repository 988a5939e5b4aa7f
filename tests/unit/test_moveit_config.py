"""`parolkit moveit-config -o DIR` (parolkit.ros2.moveit_config): the real command, every file parsed.

The command runs as a subprocess (``python -m parolkit moveit-config``) in a directory of its
own (no config file found there or in its HOME unless the test writes one).  XML is read with
xml.etree; YAML with :func:`read_yaml` below, a strict reader of the subset the generator
writes (tested here on its own, and against PyYAML when PyYAML is importable: it is not a
parolkit dependency).  What is checked:

* the URDF is `parolkit urdf`'s, collision shapes included; the SRDF's group, end effector and
  named states refer to the URDF's links and joints, the states lie within the URDF's limits;
* the SRDF's ``<disable_collisions>`` are exactly the link pairs parolkit's collision model
  computes as always touching (``Adjacent`` for neighbours in the URDF's tree, else ``Always``)
  or never touching (``Never``), with and without a tool shape;
* joint_limits.yaml's velocities are the URDF's and what the controller accepts for a
  trajectory, its accelerations the robot model's; at its default scaling factors, 720
  time-optimal (MoveIt-style, resampled) trajectories of every joint are taken on time, at
  1.0 / 1.0 nearly all are refused;
* ``--joint-convention community`` (or ``[ros2] joint_convention``) writes the community
  convention's values; bad input ends with one line naming it.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from tests.conftest import REPO_ROOT

from parolkit.collision import default_model
from parolkit.config import load_config
from parolkit.errors import ParolkitValueError
from parolkit.robot import PAROL6, steps_to_deg
from parolkit.ros2.convention import COMMUNITY, PAROLKIT
from parolkit.ros2.moveit_config import (
    ACTION_NS,
    ARM_GROUP,
    CONTROLLER_NAME,
    FILES,
    KINEMATICS_PLUGIN,
    TOOL_GROUP,
    to_yaml,
)
from parolkit.ros2.trajectory import TrajectoryPoint, TrajectoryRefused, plan_joint_trajectory
from parolkit.ros2.urdf import ROS_JOINT_NAMES, make_urdf, trajectory_velocity_limits_rad_s

# ---- a strict reader for the YAML subset the generator writes --------------------------------------------------

_INT = re.compile(r"-?[0-9]+")
_FLOAT = re.compile(r"-?[0-9]+\.[0-9]+(e[-+][0-9]+)?")
_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_./-]*")


class YamlSubsetError(ValueError):
    pass


def _scalar(text: str, line: int) -> object:
    if text in ("true", "false"):
        return text == "true"
    if _INT.fullmatch(text):
        return int(text)
    if _FLOAT.fullmatch(text):
        return float(text)
    if _WORD.fullmatch(text) and text.lower() not in ("yes", "no", "on", "off", "null", "y", "n"):
        return text
    raise YamlSubsetError(f"line {line}: {text!r} is not a boolean, a number or a plain word")


def read_yaml(text: str) -> dict[str, Any]:
    """Block mappings indented by exactly two spaces per level, ``- item`` lists of scalars
    under a key, scalars (true/false, integers, decimal floats, plain words), whole-line
    comments at column 0.  Anything else (tabs, flow style, quotes, trailing comments, a
    repeated key, a key without a value or a block, wrong indentation) is an error."""
    lines: list[tuple[int, int, str]] = []  # (line number, indent, content)
    for n, raw in enumerate(text.split("\n"), start=1):
        if raw == "" or raw.startswith("#"):
            continue
        if "\t" in raw or raw != raw.rstrip():
            raise YamlSubsetError(f"line {n}: tabs or trailing spaces")
        content = raw.lstrip(" ")
        indent = len(raw) - len(content)
        if indent % 2:
            raise YamlSubsetError(f"line {n}: indentation of {indent} spaces is not a multiple of 2")
        lines.append((n, indent, content))
    value, end = _mapping(lines, 0, 0)
    if end != len(lines):
        raise YamlSubsetError(f"line {lines[end][0]}: indented deeper than its place allows")
    return value


def _mapping(lines: list[tuple[int, int, str]], i: int, indent: int) -> tuple[dict[str, Any], int]:
    out: dict[str, Any] = {}
    while i < len(lines) and lines[i][1] == indent:
        n, _, content = lines[i]
        key, sep, rest = content.partition(":")
        if not sep or not _WORD.fullmatch(key) or (rest and not rest.startswith(" ")):
            raise YamlSubsetError(f"line {n}: not 'key: value' or 'key:'")
        if key in out:
            raise YamlSubsetError(f"line {n}: key {key!r} repeated")
        rest = rest.strip()
        i += 1
        if rest:
            if "#" in rest:
                raise YamlSubsetError(f"line {n}: a comment after a value")
            out[key] = _scalar(rest, n)
        elif i < len(lines) and lines[i][1] == indent + 2 and lines[i][2].startswith("- "):
            items = []
            while i < len(lines) and lines[i][1] == indent + 2 and lines[i][2].startswith("- "):
                items.append(_scalar(lines[i][2][2:], lines[i][0]))
                i += 1
            out[key] = items
        elif i < len(lines) and lines[i][1] == indent + 2:
            out[key], i = _mapping(lines, i, indent + 2)
        else:
            raise YamlSubsetError(f"line {n}: key {key!r} has neither a value nor a block under it")
    return out, i


def _pyyaml_agrees(text: str) -> None:
    """PyYAML (when importable) reads the same as the strict reader."""
    try:
        import yaml
    except ImportError:
        return
    assert yaml.safe_load(text) == read_yaml(text)


SAMPLE = {"a": 1, "b": {"c": -2.5e-07, "d": ["x", "y_1", "ns/name"], "e": {"f": True, "g": "kdl/Plugin"}},
          "h": 0.1, "i": False}


def test_the_yaml_writer_and_the_strict_reader_round_trip() -> None:
    text = to_yaml(SAMPLE)
    assert read_yaml(text) == SAMPLE
    _pyyaml_agrees(text)
    for v in (0.1, 1e-300, -123456.789, 2.0**60, 1 / 3, 5e-324):  # floats read back exactly, also by PyYAML
        assert read_yaml(to_yaml({"v": v}))["v"] == v
        _pyyaml_agrees(to_yaml({"v": v}))


@pytest.mark.parametrize(("text", "why"), [
    ("a:\n\tb: 1\n", "tabs"),
    ("a:\n   b: 1\n", "multiple of 2"),
    ("a: 1\na: 2\n", "repeated"),
    ("a: [1, 2]\n", "not a boolean"),
    ("a: 'x'\n", "not a boolean"),
    ("a: 1 # one\n", "comment after"),
    ("a:\nb: 1\n", "neither a value nor a block"),
    ("a: 1\n  b: 2\n", "deeper"),
    ("a: yes\n", "not a boolean"),
    ("a:b\n", "not 'key: value'"),
    ("a: 1 \n", "trailing"),
])
def test_the_strict_reader_refuses_what_the_writer_never_writes(text: str, why: str) -> None:
    with pytest.raises(YamlSubsetError, match=why):
        read_yaml(text)


@pytest.mark.parametrize("value", [math.nan, math.inf, "two words", "true", "", None, "quote'", 1 + 2j])
def test_the_yaml_writer_refuses_values_outside_its_subset(value: object) -> None:
    with pytest.raises(ParolkitValueError, match="to_yaml: "):
        to_yaml({"k": value})


# ---- the command ----------------------------------------------------------------------------------------------


def run_moveit_config(tmp: Path, *args: str,
                      config: str | None = None) -> tuple[subprocess.CompletedProcess[str], Path]:
    """``python -m parolkit moveit-config -o OUT ARGS`` in ``tmp`` (with ``config`` as its
    parolkit.toml when given); the result and OUT."""
    tmp.mkdir(parents=True, exist_ok=True)
    extra = []
    if config is not None:
        (tmp / "parolkit.toml").write_text(config)
        extra = ["--config", str(tmp / "parolkit.toml")]
    out = tmp / "moveit"
    env = {**os.environ, "HOME": str(tmp), "PYTHONPATH": str(REPO_ROOT / "src")}
    res = subprocess.run([sys.executable, "-m", "parolkit", "moveit-config", "-o", str(out), *extra, *args],
                         cwd=tmp, env=env, capture_output=True, text=True, timeout=120)
    return res, out


class Generated:
    """The files of one run, parsed."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.urdf_text = (out / "parol6.urdf").read_text()
        self.urdf = ET.fromstring(self.urdf_text)
        self.srdf = ET.fromstring((out / "parol6.srdf").read_text())
        self.yaml = {}
        for name in ("joint_limits.yaml", "kinematics.yaml", "moveit_controllers.yaml"):
            text = (out / name).read_text()
            _pyyaml_agrees(text)
            self.yaml[name] = read_yaml(text)
        self.readme = (out / "README.txt").read_text()

    def revolute(self) -> list[ET.Element]:
        return [j for j in self.urdf.findall("joint") if j.get("type") == "revolute"]

    def limits(self) -> np.ndarray:
        return np.array([[float(j.find("limit").get(k)) for k in ("lower", "upper")]  # type: ignore[union-attr,arg-type]
                         for j in self.revolute()])

    def velocities(self) -> np.ndarray:
        return np.array([float(j.find("limit").get("velocity")) for j in self.revolute()])  # type: ignore[union-attr,arg-type]

    def states(self) -> dict[str, dict[str, float]]:
        return {s.get("name"): {j.get("name"): float(j.get("value")) for j in s.findall("joint")}  # type: ignore[arg-type,misc]
                for s in self.srdf.findall("group_state")}


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    res, out = run_moveit_config(tmp_path_factory.mktemp("moveit"))
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == (f"parolkit moveit-config: wrote 6 files to {out} (parol6.urdf, parol6.srdf, "
                                  "joint_limits.yaml, kinematics.yaml, moveit_controllers.yaml, README.txt)")
    assert sorted(p.name for p in out.iterdir()) == sorted(FILES)
    return Generated(out)


def test_the_urdf_is_parolkits_with_the_collision_models_shapes(generated: Generated) -> None:
    assert generated.urdf_text == make_urdf()
    collisions = [c for link in generated.urdf.findall("link") for c in link.findall("collision")]
    assert len(collisions) == 1 + 3 * (len(default_model().bodies) - 1)  # the base box, each capsule in 3 shapes


def _urdf_links_with_geometry(urdf: ET.Element) -> dict[str, int]:
    return {link.get("name"): len(link.findall("collision")) for link in urdf.findall("link")  # type: ignore[misc]
            if link.findall("collision")}


def test_the_srdf_group_end_effector_and_states_refer_to_the_urdf(generated: Generated) -> None:
    srdf, urdf = generated.srdf, generated.urdf
    links = {link.get("name") for link in urdf.findall("link")}
    assert srdf.get("name") == urdf.get("name") == "parol6"
    groups = {g.get("name"): g for g in srdf.findall("group")}
    assert set(groups) == {ARM_GROUP, TOOL_GROUP}
    chain = groups[ARM_GROUP].find("chain")
    assert chain is not None and (chain.get("base_link"), chain.get("tip_link")) == ("base_link", "tcp")
    assert [link.get("name") for link in groups[TOOL_GROUP].findall("link")] == ["tcp"]
    ee = srdf.findall("end_effector")
    assert len(ee) == 1 and ee[0].attrib == {"name": TOOL_GROUP, "parent_link": "tcp", "group": TOOL_GROUP,
                                             "parent_group": ARM_GROUP}
    assert {chain.get("base_link"), chain.get("tip_link"), ee[0].get("parent_link")} <= links
    for pair in srdf.findall("disable_collisions"):
        assert {pair.get("link1"), pair.get("link2")} <= set(_urdf_links_with_geometry(urdf))


def test_the_named_states_are_standby_and_home_within_the_urdfs_limits(generated: Generated) -> None:
    states = generated.states()
    assert set(states) == {"standby", "home"}
    lim = generated.limits()
    for name, values in states.items():
        assert list(values) == list(ROS_JOINT_NAMES), name
        q = np.array(list(values.values()))
        assert np.all((lim[:, 0] <= q) & (q <= lim[:, 1])), name
    np.testing.assert_array_equal(list(states["standby"].values()), np.radians(PAROL6.standby_deg))
    home = np.radians(steps_to_deg(list(PAROL6.standby_steps)))  # where HOME leaves the arm
    np.testing.assert_array_equal(list(states["home"].values()), home)
    assert np.abs(home - np.radians(PAROL6.standby_deg)).max() < 2e-5  # a fraction of a step from standby


def _expected_disabled(urdf: ET.Element, tool: object = None) -> dict[frozenset[str], str]:
    """From the collision model's pair table and the URDF alone: each link pair whose body pairs
    are all excluded (always in contact) or never in contact, with MoveIt's reason."""
    link_of = {c.get("name"): link.get("name") for link in urdf.findall("link") for c in link.findall("collision")}
    parent = {j.find("child").get("link"): j.find("parent").get("link") for j in urdf.findall("joint")}  # type: ignore[union-attr]
    with_geometry = set(_urdf_links_with_geometry(urdf))

    def geometric_parent(link: str) -> str | None:  # skip links without shapes, as MoveIt's setup assistant does
        p = parent.get(link)
        while p is not None and p not in with_geometry:
            p = parent.get(p)
        return p

    kinds: dict[frozenset[str], set[str]] = {}
    for p in default_model().pair_table(tool).pairs:  # type: ignore[arg-type]
        la, lb = link_of[p.a], link_of[p.b]  # the body's cylinder is named as the body
        if la == lb:
            continue
        kind = "contact" if not p.checked else ("never" if p.min_mm > 0 else "check")
        kinds.setdefault(frozenset((la, lb)), set()).add(kind)
    out = {}
    for pair, k in kinds.items():
        if "check" in k:
            continue
        a, b = sorted(pair)
        adjacent = geometric_parent(a) == b or geometric_parent(b) == a
        out[pair] = ("Adjacent" if adjacent else "Always") if "contact" in k else "Never"
    return out


def _srdf_disabled(srdf: ET.Element) -> dict[frozenset[str], str]:
    found = {}
    for el in srdf.findall("disable_collisions"):
        pair = frozenset((el.get("link1"), el.get("link2")))
        assert len(pair) == 2 and pair not in found  # type: ignore[arg-type]
        found[pair] = el.get("reason")
    return found  # type: ignore[return-value]


def test_the_srdfs_disabled_pairs_are_the_collision_models_computed_pairs(generated: Generated) -> None:
    found = _srdf_disabled(generated.srdf)
    want = _expected_disabled(generated.urdf)
    assert found == want
    # the stock arm: the 8 pairs that meet at a joint and the 7 that never touch in 20,064 samples
    assert sorted(found.values()).count("Never") == 7
    assert {p for p, r in found.items() if r in ("Adjacent", "Always")} == {
        frozenset(p) for p in (("base_link", "L1"), ("L1", "L2"), ("L2", "L3"), ("L2", "L4"), ("L3", "L4"),
                               ("L4", "L5"), ("L4", "flange"), ("L5", "flange"))}
    assert found[frozenset(("L5", "flange"))] == "Adjacent"  # through L6, which has no shape
    assert found[frozenset(("L2", "L4"))] == "Always"
    # the pairs parolkit's collision model checks and that can touch stay enabled in MoveIt
    assert frozenset(("base_link", "L4")) not in found and frozenset(("L1", "L5")) not in found


def test_joint_limits_are_the_urdfs_velocities_and_the_models_accelerations(generated: Generated) -> None:
    jl = generated.yaml["joint_limits.yaml"]
    assert set(jl) == {"default_velocity_scaling_factor", "default_acceleration_scaling_factor", "joint_limits"}
    assert list(jl["joint_limits"]) == list(ROS_JOINT_NAMES)
    vel = np.array([jl["joint_limits"][n]["max_velocity"] for n in ROS_JOINT_NAMES])
    acc = np.array([jl["joint_limits"][n]["max_acceleration"] for n in ROS_JOINT_NAMES])
    for n in ROS_JOINT_NAMES:
        assert list(jl["joint_limits"][n]) == ["has_position_limits", "min_position", "max_position",
                                               "has_velocity_limits", "max_velocity",
                                               "has_acceleration_limits", "max_acceleration"]
        assert jl["joint_limits"][n]["has_position_limits"] is True
        assert jl["joint_limits"][n]["has_velocity_limits"] is True
        assert jl["joint_limits"][n]["has_acceleration_limits"] is True
    pos = np.array([[jl["joint_limits"][n][k] for k in ("min_position", "max_position")] for n in ROS_JOINT_NAMES])
    np.testing.assert_array_equal(pos, generated.limits())  # the URDF's
    # the same numbers: the YAML, the URDF and what the controller accepts for a trajectory
    np.testing.assert_array_equal(vel, generated.velocities())
    np.testing.assert_array_equal(vel, trajectory_velocity_limits_rad_s(PAROL6, 100.0))
    np.testing.assert_array_equal(acc, np.radians(PAROL6.max_accel_deg_s2))


def _moveit_like(j: int, dist_rad: float, v: float, a: float, dt: float) -> tuple[list[TrajectoryPoint], list[float]]:
    """What MoveIt's time-optimal parameterisation makes of a move of joint ``j`` by
    ``dist_rad`` from one end of its range at speed ``v`` and acceleration ``a`` (rad/s, rad/s^2):
    the trapezoid (or triangle) resampled every ``dt`` s plus its end, positions and
    velocities at every point, the first at time 0; and the start (deg)."""
    ta = v / a
    if dist_rad < v * ta:
        ta = math.sqrt(dist_rad / a)
        v = a * ta
    tc = (dist_rad - v * ta) / v
    total = 2 * ta + tc
    start = list(PAROL6.standby_deg)
    start[j] = float(PAROL6.safe_limits_deg[j][0]) + 0.5
    pts = []
    for t in [*np.arange(0.0, total, dt), total]:
        if t < ta:
            s, sd = a * t * t / 2, a * t
        elif t < ta + tc:
            s, sd = a * ta * ta / 2 + v * (t - ta), v
        else:
            s, sd = dist_rad - a * (total - t) ** 2 / 2, a * (total - t)
        q = [math.radians(x) for x in start]
        q[j] += s
        pts.append(TrajectoryPoint(q, float(t), [sd if i == j else 0.0 for i in range(6)]))
    return pts, start


def _taken(vel_scale: float, acc_scale: float, vel: np.ndarray, acc: np.ndarray) -> tuple[int, int]:
    """How many of 720 MoveIt-like trajectories (every joint, 60 distances up to nearly its whole
    range, resampled at 0.1 and 0.05 s) are accepted on time at these scaling factors."""
    taken = total = 0
    for j in range(6):
        room = math.radians(float(np.diff(PAROL6.safe_limits_deg[j])[0])) - math.radians(1.0)
        for dist in np.linspace(0.002, room, 60):
            for dt in (0.1, 0.05):
                pts, start = _moveit_like(j, float(dist), float(vel[j]) * vel_scale, float(acc[j]) * acc_scale, dt)
                total += 1
                try:
                    path = plan_joint_trajectory(list(ROS_JOINT_NAMES), pts, start, PAROL6, 100.0)
                except TrajectoryRefused:
                    continue
                assert path.ticks == round(pts[-1].time_s * 100)
                taken += 1
    return taken, total


def test_moveits_plans_at_the_default_scaling_factors_are_taken_on_time(generated: Generated) -> None:
    jl = generated.yaml["joint_limits.yaml"]
    vel = np.array([jl["joint_limits"][n]["max_velocity"] for n in ROS_JOINT_NAMES])
    acc = np.array([jl["joint_limits"][n]["max_acceleration"] for n in ROS_JOINT_NAMES])
    vs, as_ = jl["default_velocity_scaling_factor"], jl["default_acceleration_scaling_factor"]
    assert (vs, as_) == (0.95, 0.5)
    assert _taken(vs, as_, vel, acc) == (720, 720)
    # at the full limits the controller's cubics between the waypoints go over them: refused
    taken, total = _taken(1.0, 1.0, vel, acc)
    assert taken < total // 10


def test_kinematics_and_controllers_yaml(generated: Generated) -> None:
    assert generated.yaml["kinematics.yaml"] == {ARM_GROUP: {
        "kinematics_solver": KINEMATICS_PLUGIN, "kinematics_solver_search_resolution": 0.005,
        "kinematics_solver_timeout": 0.05}}
    assert generated.yaml["moveit_controllers.yaml"] == {
        "moveit_controller_manager": "moveit_simple_controller_manager/MoveItSimpleControllerManager",
        "moveit_simple_controller_manager": {
            "controller_names": [CONTROLLER_NAME],
            CONTROLLER_NAME: {"type": "FollowJointTrajectory", "action_ns": ACTION_NS, "default": True,
                              "joints": list(ROS_JOINT_NAMES)}},
        "trajectory_execution": {"allowed_start_tolerance": 0.01},
    }
    assert (CONTROLLER_NAME, ACTION_NS) == ("parol6_arm_controller", "follow_joint_trajectory")
    assert "/parol6_arm_controller/follow_joint_trajectory" in generated.readme
    assert "parolkit's own joint angles" in generated.readme


def test_the_community_convention_by_flag_or_config(tmp_path: Path) -> None:
    res, out = run_moveit_config(tmp_path / "flag", "--joint-convention", "community", "--namespace", "parol6")
    assert res.returncode == 0, res.stderr
    gen = Generated(out)
    assert gen.urdf_text == make_urdf(convention="community")
    states = gen.states()
    np.testing.assert_allclose(list(states["standby"].values()), np.radians([90, 0, 0, 0, 0, 0]), atol=1e-12)
    np.testing.assert_allclose(list(states["home"].values()),
                               COMMUNITY.to_ros_rad(steps_to_deg(list(PAROL6.standby_steps))), atol=1e-12)
    lim = gen.limits()
    for values in states.values():
        q = np.array(list(values.values()))
        assert np.all((lim[:, 0] <= q) & (q <= lim[:, 1]))
    assert _srdf_disabled(gen.srdf) == _expected_disabled(gen.urdf)  # the links are the same
    jl = gen.yaml["joint_limits.yaml"]["joint_limits"]
    pos = np.array([[jl[n]["min_position"], jl[n]["max_position"]] for n in ROS_JOINT_NAMES])
    np.testing.assert_array_equal(pos, lim)  # the community convention's limits, the URDF's
    np.testing.assert_allclose(pos, np.radians(COMMUNITY.limits_deg(PAROL6.safe_limits_deg)), rtol=0, atol=1e-15)
    assert 'joint_convention = "community"' in gen.readme
    assert "/parol6/parol6_arm_controller/follow_joint_trajectory" in gen.readme
    assert 'PushRosNamespace("parol6")' in gen.readme
    # the config's [ros2] joint_convention (and start tolerance) without the flag: the same files
    res, out2 = run_moveit_config(tmp_path / "config", config='[ros2]\njoint_convention = "community"\n'
                                  'namespace = "parol6"\nstart_tolerance_rad = 0.02\n')
    assert res.returncode == 0, res.stderr
    for name in ("parol6.urdf", "parol6.srdf", "joint_limits.yaml", "kinematics.yaml", "README.txt"):
        assert (out2 / name).read_text() == (out / name).read_text(), name
    ctl = read_yaml((out2 / "moveit_controllers.yaml").read_text())
    assert ctl["trajectory_execution"] == {"allowed_start_tolerance": 0.02}
    assert PAROLKIT.is_identity  # (the default run above used parolkit's own convention)


def test_a_tools_shape_adds_its_pairs(tmp_path: Path) -> None:
    toml = ('[tools.gripper]\npose = [0, 0, 90, 0, 0, 0]\n'
            'shape = { radius = 30, start = [0, 0, 0], end = [0, 0, 110] }\n')
    res, out = run_moveit_config(tmp_path, "--tool", "gripper", config=toml)
    assert res.returncode == 0, res.stderr
    gen = Generated(out)
    cfg = load_config(tmp_path / "parolkit.toml")
    assert gen.urdf_text == make_urdf(cfg.robot, "gripper", config=cfg)
    assert _urdf_links_with_geometry(gen.urdf)["flange"] == 6  # the J6 link and the tool, 3 shapes each
    assert _srdf_disabled(gen.srdf) == _expected_disabled(gen.urdf, cfg.tools[0])
    assert "Tool at link 'tcp': gripper" in gen.readme


@pytest.mark.parametrize(("args", "code", "message"), [
    (("--rate", "0"), 2, r"^parolkit moveit-config: command line: \[controller\]: controller\.rate_hz must be a "
                         r"number in \(0, 1000\], got 0\.0$"),
    (("--tool", "nosuch"), 2, r"^parolkit moveit-config: .*'nosuch'"),
    (("--joint-convention", "ros"), 2, r"argument --joint-convention: invalid choice: 'ros'"),
    (("--namespace", "1arm"), 2, r"ros2\.namespace must be a ROS name"),
])
def test_bad_input_ends_with_one_line_naming_it(tmp_path: Path, args: tuple[str, ...], code: int, message: str) -> None:
    res, out = run_moveit_config(tmp_path, *args)
    assert res.returncode == code
    assert re.search(message, res.stderr.strip().splitlines()[-1]), res.stderr
    assert "Traceback" not in res.stderr and not out.exists()


def test_an_output_that_is_a_file_ends_with_one_line(tmp_path: Path) -> None:
    (tmp_path / "moveit").write_text("not a directory")
    res, _ = run_moveit_config(tmp_path)
    assert res.returncode == 1 and "Traceback" not in res.stderr
    assert res.stderr.startswith("parolkit moveit-config: ") and len(res.stderr.strip().splitlines()) == 1
