"""The generated URDF (parolkit.ros2.urdf) agrees with parolkit's own kinematics and limits.

The URDF is read back with xml.etree and its chain composed with numpy from the URDF
semantics alone (origin = Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll), then a rotation of q about
the joint axis), independently of the DH code that wrote it.  The collision shapes
(``<collision>``: the base box, each capsule as a cylinder and two spheres, the tool's) placed
by that chain are parolkit's collision model placed by parolkit's FK, to 1e-9 mm; roboticstoolbox
(a dev extra) reading the same file places them the same way.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from parolkit.cli import main
from parolkit.kinematics import fk_frames, fk_matrix
from parolkit.robot import PAROL6
from parolkit.ros2.urdf import ROS_JOINT_NAMES, make_urdf, rot_to_rpy


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _axis_angle(axis: np.ndarray, q: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(q) * kx + (1 - math.cos(q)) * kx @ kx


def _floats(text: str | None) -> list[float]:
    assert text is not None
    return [float(v) for v in text.split()]


class UrdfChain:
    """The serial chain base_link -> link of a URDF, by URDF semantics."""

    def __init__(self, text: str) -> None:
        self.root = ET.fromstring(text)
        self.joints = {j.get("name"): j for j in self.root.findall("joint")}
        self.by_child = {j.find("child").get("link"): j for j in self.joints.values()}  # type: ignore[union-attr]

    def transform(self, link: str, q_rad: dict[str, float]) -> np.ndarray:
        chain = []
        while link in self.by_child:
            j = self.by_child[link]
            chain.append(j)
            link = j.find("parent").get("link")  # type: ignore[union-attr,assignment]
        assert link == "base_link"
        t = np.eye(4)
        for j in reversed(chain):
            origin = j.find("origin")
            xyz = _floats(origin.get("xyz")) if origin is not None else [0.0] * 3
            roll, pitch, yaw = _floats(origin.get("rpy")) if origin is not None else [0.0] * 3
            o = np.eye(4)
            o[:3, :3] = _rz(yaw) @ _ry(pitch) @ _rx(roll)
            o[:3, 3] = xyz
            t = t @ o
            if j.get("type") == "revolute":
                m = np.eye(4)
                m[:3, :3] = _axis_angle(np.array(_floats(j.find("axis").get("xyz"))),  # type: ignore[union-attr]
                                        q_rad[j.get("name")])  # type: ignore[index]
                t = t @ m
        return t


@pytest.fixture(scope="module")
def chain() -> UrdfChain:
    return UrdfChain(make_urdf())


def test_urdf_tcp_and_flange_match_parolkit_fk_at_random_joint_angles(chain: UrdfChain) -> None:
    rng = np.random.default_rng(17)
    lim = PAROL6.safe_limits_deg
    worst = 0.0
    for _ in range(500):
        q_deg = rng.uniform(lim[:, 0], lim[:, 1])
        q = dict(zip(ROS_JOINT_NAMES, np.radians(q_deg)))
        tcp = chain.transform("tcp", q)
        ours = fk_matrix(q_deg)
        worst = max(worst, float(np.abs(tcp[:3, 3] - ours[:3, 3]).max()))
        np.testing.assert_allclose(tcp[:3, 3], ours[:3, 3], atol=1e-6)
        np.testing.assert_allclose(tcp[:3, :3], ours[:3, :3], atol=1e-9)
        frames = fk_frames(q_deg)
        np.testing.assert_allclose(chain.transform("flange", q), frames[6], atol=1e-9)
        for i, name in enumerate(ROS_JOINT_NAMES[1:], start=1):
            # joint L(i+1) sits on DH frame i: its axis is that frame's z axis
            joint_frame = chain.transform(name, {**q, name: 0.0})
            np.testing.assert_allclose(joint_frame[:3, 3], frames[i][:3, 3], atol=1e-9)
            np.testing.assert_allclose(joint_frame[:3, 2], frames[i][:3, 2], atol=1e-9)
    assert worst < 1e-6


def test_urdf_joint_names_limits_and_velocities_come_from_the_robot_model(chain: UrdfChain) -> None:
    revolute = [j for j in chain.root.findall("joint") if j.get("type") == "revolute"]
    assert [j.get("name") for j in revolute] == ["L1", "L2", "L3", "L4", "L5", "L6"]
    lim = np.radians(PAROL6.safe_limits_deg)
    # velocity: what the controller's planner accepts for every sample of a joint path at 100 Hz
    # (the position-tracking maximum, 75-76 % of the maximum speed), not the maximum speed itself
    from parolkit.motion.validate import speed_limits

    vel = speed_limits(PAROL6, 100.0, position_tracked=True).array / PAROL6.steps_per_rad
    assert np.all(vel < 0.77 * np.radians(PAROL6.max_speed_deg_s))
    for i, j in enumerate(revolute):
        limit = j.find("limit")
        assert limit is not None
        assert float(limit.get("lower", "nan")) == pytest.approx(lim[i, 0], abs=1e-12)
        assert float(limit.get("upper", "nan")) == pytest.approx(lim[i, 1], abs=1e-12)
        assert float(limit.get("velocity", "nan")) == pytest.approx(vel[i], rel=1e-12)
    # every link that is not a frame marker has geometry to draw
    drawn = {link.get("name") for link in chain.root.findall("link") if link.find("visual") is not None}
    assert {"base_link", "L1", "L2", "L3", "L4"} <= drawn


def test_urdf_velocity_limits_are_for_the_control_rate_of_the_config_or_the_argument(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from parolkit.config import load_config
    from parolkit.motion.validate import speed_limits

    def velocities(text: str) -> np.ndarray:
        return np.array([float(j.find("limit").get("velocity")) for j in ET.fromstring(text).findall("joint")  # type: ignore[union-attr,arg-type]
                         if j.get("type") == "revolute"])

    cfg_file = tmp_path / "parolkit.toml"
    cfg_file.write_text("[controller]\nrate_hz = 250\n")
    cfg = load_config(cfg_file)
    at_250 = speed_limits(PAROL6, 250.0, position_tracked=True).array / PAROL6.steps_per_rad
    np.testing.assert_array_equal(velocities(make_urdf(cfg.robot, config=cfg)), at_250)
    np.testing.assert_array_equal(velocities(make_urdf(rate_hz=250.0)), at_250)
    assert not np.allclose(velocities(make_urdf()), at_250)  # 100 Hz: another position-tracking maximum


def test_rot_to_rpy_round_trips_including_gimbal_lock() -> None:
    rng = np.random.default_rng(3)
    for r, p, y in [*rng.uniform(-3, 3, size=(50, 3)), (0.3, math.pi / 2, 0.2), (0.1, -math.pi / 2, 1.0)]:
        m = _rz(y) @ _ry(p) @ _rx(r)
        rr, pp, yy = rot_to_rpy(m)
        np.testing.assert_allclose(_rz(yy) @ _ry(pp) @ _rx(rr), m, atol=1e-9)


def test_urdf_command_writes_the_file_and_prints_without_o(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "parol6.urdf"
    assert main(["urdf", "-o", str(out)]) == 0
    assert out.read_text() == make_urdf()
    assert main(["urdf"]) == 0
    assert capsys.readouterr().out == make_urdf()


def test_urdf_command_rejects_an_unknown_tool_precisely(capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["urdf", "--tool", "no-such-tool"]) == 2
    assert "no-such-tool" in capsys.readouterr().err


def test_ros2_command_rejects_a_bad_connect_address_precisely(capsys) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(SystemExit):
        main(["ros2", "--connect", "localhost:99999"])
    assert "--connect port must be an integer 1..65535, got '99999'" in capsys.readouterr().err


# ---- collision shapes: the collision model's, in the right links ----------------------------------


def _origin_matrix(el: ET.Element) -> np.ndarray:
    origin = el.find("origin")
    xyz = _floats(origin.get("xyz")) if origin is not None else [0.0] * 3
    roll, pitch, yaw = _floats(origin.get("rpy")) if origin is not None else [0.0] * 3
    o = np.eye(4)
    o[:3, :3] = _rz(yaw) @ _ry(pitch) @ _rx(roll)
    o[:3, 3] = xyz
    return o


def _urdf_collisions(chain: UrdfChain, q: dict[str, float]) -> dict[str, tuple[str, np.ndarray, dict[str, float]]]:
    """Every ``<collision>`` by name: (geometry tag, world pose placed by the URDF chain, its
    attributes in mm: radius, length, or the box's size as x, y, z)."""
    out = {}
    for link in chain.root.findall("link"):
        for el in link.findall("collision"):
            pose = chain.transform(link.get("name"), q) @ _origin_matrix(el)  # type: ignore[arg-type]
            geom = el.find("geometry")
            assert geom is not None and len(geom) == 1
            shape = geom[0]
            if shape.tag == "box":
                attrs = dict(zip("xyz", (v * 1e3 for v in _floats(shape.get("size")))))
            else:
                attrs = {k: float(v) * 1e3 for k, v in shape.attrib.items()}
            name = el.get("name")
            assert name is not None and name not in out
            out[name] = (shape.tag, pose, attrs)
    return out


def _check_shapes_match(found: dict, bodies: tuple, q_deg: np.ndarray) -> float:
    """Assert that the URDF shapes placed at ``q_deg`` are the bodies placed by parolkit's FK
    (1e-9 mm); the largest difference (mm)."""
    frames = fk_frames(q_deg, tool="flange")  # base, DH frames 1..5, the flange (frame 6)
    worst = 0.0
    for body in bodies:
        f = frames[body.frame]
        start = (f[:3, :3] @ np.array(body.start) * 1e-3 + f[:3, 3]) * 1e3  # mm, world
        end = (f[:3, :3] @ np.array(body.end) * 1e-3 + f[:3, 3]) * 1e3
        if body.size is not None:  # the base box: centre, axes and edges
            tag, pose, attrs = found[body.name]
            assert tag == "box"
            np.testing.assert_allclose(pose[:3, 3] * 1e3, start, rtol=0, atol=1e-9)
            np.testing.assert_allclose(pose[:3, :3], f[:3, :3], rtol=0, atol=1e-12)
            assert (attrs["x"], attrs["y"], attrs["z"]) == pytest.approx(body.size, abs=1e-9)
            continue
        tag, pose, attrs = found[body.name]
        assert tag == "cylinder" and attrs["radius"] == pytest.approx(body.radius, abs=1e-9)
        half = pose[:3, 2] * attrs["length"] / 2  # the cylinder's own z axis, mm
        ends = (pose[:3, 3] * 1e3 - half, pose[:3, 3] * 1e3 + half)
        for got, want in ((ends[0], start), (ends[1], end)):
            worst = max(worst, float(np.abs(got - want).max()))
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
        for suffix, want in ((" start", start), (" end", end)):
            tag, pose, attrs = found[body.name + suffix]
            assert tag == "sphere" and attrs["radius"] == pytest.approx(body.radius, abs=1e-9)
            worst = max(worst, float(np.abs(pose[:3, 3] * 1e3 - want).max()))
            np.testing.assert_allclose(pose[:3, 3] * 1e3, want, rtol=0, atol=1e-9)
    return worst


def test_urdf_collision_shapes_are_the_collision_model_placed_by_parolkits_fk(chain: UrdfChain) -> None:
    from parolkit.collision import default_model

    bodies = default_model().bodies
    rng = np.random.default_rng(25)
    lim = PAROL6.safe_limits_deg
    worst = 0.0
    for q_deg in [np.zeros(6), np.array(PAROL6.standby_deg), *rng.uniform(lim[:, 0], lim[:, 1], size=(300, 6))]:
        found = _urdf_collisions(chain, dict(zip(ROS_JOINT_NAMES, np.radians(q_deg))))
        # the base as a box, each of the six link capsules as a cylinder and two spheres, nothing else
        assert len(found) == 1 + 3 * (len(bodies) - 1)
        worst = max(worst, _check_shapes_match(found, bodies, q_deg))
    assert worst < 1e-9


def test_urdf_places_each_collision_body_on_the_link_that_moves_with_its_dh_frame(chain: UrdfChain) -> None:
    from parolkit.collision import default_model

    where = {el.get("name"): link.get("name") for link in chain.root.findall("link")
             for el in link.findall("collision")}
    for body in default_model().bodies:
        want = "base_link" if body.frame == 0 else ("flange" if body.frame == 6 else f"L{body.frame}")
        assert where[body.name] == want, body.name
    # the fixed transform DH frame i -> link Li is the rest of DH row i: Tz(d) Tx(a) Rx(alpha)
    from parolkit.ros2.urdf import dh_frame_in_link

    q = np.radians([10.0, -70.0, 150.0, 20.0, -30.0, 40.0])
    frames = fk_frames(np.degrees(q), tool="flange")
    for i in range(1, 7):
        link = chain.transform(ROS_JOINT_NAMES[i - 1] if i < 6 else "flange", dict(zip(ROS_JOINT_NAMES, q)))
        np.testing.assert_allclose(link @ dh_frame_in_link(PAROL6, i), frames[i], rtol=0, atol=1e-12)


def test_urdf_keeps_the_visuals_next_to_the_collision_shapes(chain: UrdfChain) -> None:
    for link in chain.root.findall("link"):
        visuals = link.findall("visual")
        if link.get("name") in ("base_link", "L1", "L2", "L3", "L4"):
            assert visuals, link.get("name")
        for v in visuals:  # the display cylinders, unchanged: 20 mm radius, grey
            assert v.find("geometry/cylinder").get("radius") == "0.02"  # type: ignore[union-attr]
            assert v.find("material").get("name") == "parol_grey"  # type: ignore[union-attr]


def test_urdf_carries_the_tools_shape_on_the_flange(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from parolkit.collision import default_model
    from parolkit.collision.model import tool_body
    from parolkit.config import load_config

    cfg_file = tmp_path / "parolkit.toml"
    cfg_file.write_text("[tools.gripper]\npose = [0, 0, 90, 0, 0, 0]\n"
                        "shape = { radius = 30, start = [0, 10, 20], end = [5, 0, 110] }\n"
                        "[tools.pen]\npose = [0, 0, 120, 0, 0, 0]\n")
    cfg = load_config(cfg_file)
    text = make_urdf(cfg.robot, "gripper", config=cfg)
    assert main(["urdf", "--tool", "gripper", "--config", str(cfg_file), "-o", str(tmp_path / "g.urdf")]) == 0
    assert (tmp_path / "g.urdf").read_text() == text
    tool_chain = UrdfChain(text)
    flange_link = tool_chain.root.find("link[@name='flange']")
    assert flange_link is not None
    flange = [el.get("name") for el in flange_link.findall("collision")]
    assert flange == ["J6 link", "J6 link start", "J6 link end", "tool 'gripper'", "tool 'gripper' start",
                      "tool 'gripper' end"]
    body = tool_body(cfg.tools[0])
    assert body is not None
    rng = np.random.default_rng(6)
    lim = PAROL6.safe_limits_deg
    for q_deg in rng.uniform(lim[:, 0], lim[:, 1], size=(50, 6)):
        found = _urdf_collisions(tool_chain, dict(zip(ROS_JOINT_NAMES, np.radians(q_deg))))
        _check_shapes_match(found, (*default_model().bodies, body), q_deg)
    # a tool without a shape, or the default tool: no tool body
    for tool in ("pen", None, "flange"):
        names = [el.get("name") for el in ET.fromstring(make_urdf(cfg.robot, tool, config=cfg)).iter("collision")]
        assert not any(n.startswith("tool") for n in names), tool  # type: ignore[union-attr]


def test_urdf_collision_shapes_match_roboticstoolbox_reading_the_same_urdf(  # type: ignore[no-untyped-def]
        tmp_path) -> None:
    """A cross-check with another URDF reader: roboticstoolbox (a dev extra) parses the file,
    its FK places each link and the shapes on it; the same places as parolkit's model."""
    rtb = pytest.importorskip("roboticstoolbox")
    urdf_robot = pytest.importorskip("roboticstoolbox.models.URDF.URDFRobot")
    import spatialgeometry as sg

    from parolkit.collision import default_model

    path = tmp_path / "parol6.urdf"
    path.write_text(make_urdf())
    elinks, name, _ = urdf_robot.URDF_read(str(path))
    robot = rtb.Robot(elinks, name=name)
    bodies = {b.name: b for b in default_model().bodies}
    shapes = {link.name: list(link.collision) for link in robot.links}
    xml_names = {link.get("name"): [el.get("name") for el in link.findall("collision")]
                 for link in ET.fromstring(path.read_text()).findall("link")}
    assert {k: len(v) for k, v in shapes.items()} == {k: len(v) for k, v in xml_names.items()}
    rng = np.random.default_rng(9)
    lim = PAROL6.safe_limits_deg
    for q_deg in rng.uniform(lim[:, 0], lim[:, 1], size=(50, 6)):
        frames = fk_frames(q_deg, tool="flange")
        q = np.radians(q_deg)
        for link_name, link_shapes in shapes.items():
            if not link_shapes:
                continue
            link_pose = robot.fkine(q, end=link_name).A
            for shape, shape_name in zip(link_shapes, xml_names[link_name]):
                pose = link_pose @ shape.T  # the shape's own pose in its link
                body = bodies[shape_name.removesuffix(" start").removesuffix(" end")]
                f = frames[body.frame]
                start = f[:3, :3] @ np.array(body.start) * 1e-3 + f[:3, 3]
                end = f[:3, :3] @ np.array(body.end) * 1e-3 + f[:3, 3]
                if isinstance(shape, sg.Cuboid):
                    np.testing.assert_allclose(pose[:3, 3], start, rtol=0, atol=1e-12)
                elif isinstance(shape, sg.Cylinder):
                    half = pose[:3, 2] * shape.length / 2
                    np.testing.assert_allclose(pose[:3, 3] - half, start, rtol=0, atol=1e-12)
                    np.testing.assert_allclose(pose[:3, 3] + half, end, rtol=0, atol=1e-12)
                    assert shape.radius == pytest.approx(body.radius * 1e-3, abs=1e-15)
                else:
                    assert isinstance(shape, sg.Sphere)
                    want = start if shape_name.endswith(" start") else end
                    np.testing.assert_allclose(pose[:3, 3], want, rtol=0, atol=1e-12)
