"""Joint conventions on the ROS side (parolkit.ros2.convention): the map to the community PAROL6
URDF's zeros and signs, checked by forward kinematics.

* round trips (positions, rates, limits) are exact to float rounding;
* the URDF generated in the community convention, composed with numpy from its own XML
  (tests.unit.test_urdf.UrdfChain: URDF semantics only), puts every link where parolkit's FK
  puts it, at the community joint values of parolkit's joint angles;
* the community's own published chain (the joint origins of the URDF exported from the PAROL6
  CAD, as PCrnjak/PAROL6-ROS2-MOVEIT publishes it: a cross-check with another model of the
  arm) puts its wrist centre on parolkit's within 0.002 mm at the mapped joint values, with its
  last frame a fixed turn of parolkit's flange frame; fed parolkit's own joint values instead it
  is half a metre off (the issue's 508 mm at standby).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from tests.unit.test_urdf import UrdfChain

from parolkit.errors import ParolkitValueError
from parolkit.kinematics import fk_frames, fk_matrix
from parolkit.robot import PAROL6
from parolkit.ros2.convention import COMMUNITY, PAROLKIT, JointConvention, get_convention
from parolkit.ros2.urdf import ROS_JOINT_NAMES, make_urdf

#: The community URDF's kinematic chain: joint Li's origin (xyz m, rpy rad) in link L(i-1)
#: (base_link for L1) and its axis, as published (rounded angles such as 3.1416 included).
COMMUNITY_CHAIN = (
    ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1),
    ((0.0234207210610375, 0.0, 0.1105), (-1.5707963267949, 0.0, 0.0), 1),
    ((0.0, -0.18, 0.0), (3.1416, 0.0, -1.5708), -1),
    ((0.0435, 0.0, 0.0), (1.5707963267949, 0.0, 3.14159265358979), -1),
    ((0.0, 0.0, -0.17635), (-1.5708, 0.0, 0.0), -1),
    ((0.0, 0.0, 0.0), (1.5708, 0.0, 0.0), -1),
)


def _community_urdf() -> str:
    """The published chain as a URDF (joints only: no geometry is needed for FK)."""
    parts = ['<robot name="community">', '<link name="base_link"/>']
    parent = "base_link"
    for name, (xyz, rpy, axis) in zip(ROS_JOINT_NAMES, COMMUNITY_CHAIN):
        parts.append(f'<link name="{name}"/><joint name="{name}" type="revolute"><parent link="{parent}"/>'
                     f'<child link="{name}"/><origin xyz="{" ".join(map(str, xyz))}" rpy="{" ".join(map(str, rpy))}"/>'
                     f'<axis xyz="0 0 {axis}"/></joint>')
        parent = name
    return "".join(parts) + "</robot>"


def _random_q(n: int, seed: int) -> np.ndarray:
    lim = PAROL6.safe_limits_deg
    return np.random.default_rng(seed).uniform(lim[:, 0], lim[:, 1], size=(n, 6))


def test_positions_rates_and_limits_round_trip() -> None:
    q = _random_q(1000, 1)
    for conv in (PAROLKIT, COMMUNITY):
        np.testing.assert_allclose(conv.from_ros_deg(conv.to_ros_deg(q)), q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(conv.from_ros_rad(conv.to_ros_rad(q)), np.radians(q), rtol=0, atol=1e-14)
        np.testing.assert_array_equal(conv.rate_from_ros(conv.rate_to_ros(q)), q)
        lim = conv.limits_deg(PAROL6.safe_limits_deg)
        assert np.all(lim[:, 0] < lim[:, 1])
        inside = conv.to_ros_deg(q)  # every joint value inside parolkit's limits is inside the mapped ones
        assert np.all((inside >= lim[:, 0] - 1e-9) & (inside <= lim[:, 1] + 1e-9))
    np.testing.assert_array_equal(PAROLKIT.to_ros_deg(q), q)
    assert PAROLKIT.is_identity and not COMMUNITY.is_identity


def test_the_community_map_is_the_issues_with_the_offsets_that_fit_the_community_limits() -> None:
    q = np.array([10.0, -60.0, 150.0, 20.0, -30.0, 100.0])
    np.testing.assert_allclose(COMMUNITY.to_ros_deg(q), [10.0, 30.0, 30.0, -20.0, 30.0, 80.0], atol=1e-12)
    np.testing.assert_allclose(COMMUNITY.rate_to_ros([1, 2, 3, 4, 5, 6]), [1, 2, -3, -4, -5, -6])
    # standby is the community's zero but for J1; J3 and J6 land on the community URDF's ranges
    np.testing.assert_allclose(COMMUNITY.to_ros_deg(PAROL6.standby_deg), [90, 0, 0, 0, 0, 0], atol=1e-12)
    lim = COMMUNITY.limits_deg(PAROL6.limits_deg)
    np.testing.assert_allclose(lim[2], [180 - 287.8675, 180 - 107.866], atol=1e-9)
    np.testing.assert_allclose(lim[5], [-180, 180], atol=1e-9)
    assert get_convention("community") is COMMUNITY and get_convention(PAROLKIT) is PAROLKIT
    with pytest.raises(ParolkitValueError, match=r"joint convention must be one of \['community', 'parolkit'\], "
                       r"got 'ros'"):
        get_convention("ros")
    with pytest.raises(ParolkitValueError, match="signs must be"):
        JointConvention("bad", (1.0, 1.0, 1.0, 1.0, 1.0, 0.5), (0.0,) * 6)


def test_the_community_convention_urdf_has_parolkits_links_at_the_community_joint_values() -> None:
    ours = UrdfChain(make_urdf())
    comm = UrdfChain(make_urdf(convention="community"))
    worst = 0.0
    for q in [np.array(PAROL6.standby_deg), *_random_q(300, 2)]:
        q_ours = dict(zip(ROS_JOINT_NAMES, np.radians(q)))
        q_comm = dict(zip(ROS_JOINT_NAMES, COMMUNITY.to_ros_rad(q)))
        tcp = comm.transform("tcp", q_comm)
        worst = max(worst, float(np.abs(tcp - fk_matrix(q)).max()))
        np.testing.assert_allclose(tcp, fk_matrix(q), rtol=0, atol=1e-9)
        np.testing.assert_allclose(comm.transform("flange", q_comm), fk_frames(q, tool="flange")[6], rtol=0, atol=1e-12)
        for link in ROS_JOINT_NAMES:  # every link (and so every shape on it) where it is in parolkit's URDF
            np.testing.assert_allclose(comm.transform(link, q_comm), ours.transform(link, q_ours), rtol=0, atol=1e-12)
    assert worst < 1e-12


def test_the_community_convention_urdf_limits_and_axes() -> None:
    text = make_urdf(convention="community")
    assert "<!-- Joint convention: community (parolkit.ros2.convention) -->" in text
    assert "Joint convention" not in make_urdf()  # parolkit's own URDF is unchanged
    root = ET.fromstring(text)
    revolute = [j for j in root.findall("joint") if j.get("type") == "revolute"]
    want = np.radians(COMMUNITY.limits_deg(PAROL6.safe_limits_deg))
    for i, j in enumerate(revolute):
        limit, axis = j.find("limit"), j.find("axis")
        assert limit is not None and axis is not None
        assert (float(limit.get("lower", "nan")), float(limit.get("upper", "nan"))) == (want[i, 0], want[i, 1])
        assert axis.get("xyz") == f"0 0 {int(COMMUNITY.signs[i])}"


def test_the_community_urdfs_own_chain_agrees_with_parolkits_fk_through_the_map() -> None:
    published = UrdfChain(_community_urdf())
    turn = None
    worst = 0.0
    for q in [np.array(PAROL6.standby_deg), *_random_q(300, 3)]:
        g = published.transform("L6", dict(zip(ROS_JOINT_NAMES, COMMUNITY.to_ros_rad(q))))
        f = fk_frames(q, tool="flange")[6]
        worst = max(worst, float(np.linalg.norm(g[:3, 3] - f[:3, 3])))
        rel = f[:3, :3].T @ g[:3, :3]  # the community's last frame in parolkit's flange frame
        turn = rel if turn is None else turn
        np.testing.assert_allclose(rel, turn, rtol=0, atol=2e-4)  # the same at every pose (rounded angles)
    assert worst < 2e-6  # m: the wrist centres agree within 0.002 mm
    np.testing.assert_allclose(turn, np.diag([-1.0, 1.0, -1.0]), atol=2e-4)  # 180 deg about the flange's y
    # parolkit's values fed to the community chain unconverted: the wrist half a metre off
    g = published.transform("L6", dict(zip(ROS_JOINT_NAMES, np.radians(PAROL6.standby_deg))))
    off_mm = 1000 * float(np.linalg.norm(g[:3, 3] - fk_frames(PAROL6.standby_deg, tool="flange")[6][:3, 3]))
    assert off_mm == pytest.approx(508, abs=1)


def test_j3_minus_180_of_the_issue_is_the_same_fk_outside_the_limits() -> None:
    """The issue wrote q3 -> -q3 - 180: 360 deg from 180 - q3, the same FK, but outside every
    community joint limit (-2..1 rad), so the map uses 180 - q3."""
    published = UrdfChain(_community_urdf())
    q = np.array(PAROL6.standby_deg)
    a = COMMUNITY.to_ros_rad(q)
    b = a.copy()
    b[2] = math.radians(-q[2] - 180)
    ja, jb = (published.transform("L6", dict(zip(ROS_JOINT_NAMES, v))) for v in (a, b))
    np.testing.assert_allclose(ja, jb, atol=1e-12)
    assert -2.0 <= a[2] <= 1.0 and not -2.0 <= b[2] <= 1.0
