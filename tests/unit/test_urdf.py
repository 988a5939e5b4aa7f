"""The generated URDF (parolkit.ros2.urdf) agrees with parolkit's own kinematics and limits.

The URDF is read back with xml.etree and its chain composed with numpy from the URDF
semantics alone (origin = Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll), then a rotation of q about
the joint axis), independently of the DH code that wrote it.
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
    vel = np.radians(PAROL6.max_speed_deg_s)
    for i, j in enumerate(revolute):
        limit = j.find("limit")
        assert limit is not None
        assert float(limit.get("lower", "nan")) == pytest.approx(lim[i, 0], abs=1e-12)
        assert float(limit.get("upper", "nan")) == pytest.approx(lim[i, 1], abs=1e-12)
        assert float(limit.get("velocity", "nan")) == pytest.approx(vel[i], rel=1e-12)
    # every link that is not a frame marker has geometry to draw
    drawn = {link.get("name") for link in chain.root.findall("link") if link.find("visual") is not None}
    assert {"base_link", "L1", "L2", "L3", "L4"} <= drawn


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
