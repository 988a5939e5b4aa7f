"""parolkit.ros2.tf: the TF tree of the generated URDF composes to parolkit's FK (every link, the
flange and the TCP, in both joint conventions), with one frame prefix."""

from __future__ import annotations

import numpy as np
import pytest

from parolkit.errors import ParolkitValueError
from parolkit.kinematics.fk import fk_frames
from parolkit.robot import PAROL6
from parolkit.ros2.convention import get_convention
from parolkit.ros2.tf import WORLD_FRAME, FrameTransform, TfTree, check_frame_prefix
from parolkit.ros2.urdf import make_urdf


def matrix(t: FrameTransform) -> np.ndarray:
    x, y, z, w = t.rotation
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = t.translation
    return m


def world_poses(transforms: list[FrameTransform]) -> dict[str, np.ndarray]:
    """Every frame's pose in ``world``, composed along the tree (each frame has one parent)."""
    parents = {t.child: t for t in transforms}
    assert len(parents) == len(transforms), "a frame with two parents"
    out = {WORLD_FRAME: np.eye(4)}

    def pose(frame: str) -> np.ndarray:
        if frame not in out:
            t = parents[frame]
            out[frame] = pose(t.parent) @ matrix(t)
        return out[frame]

    for f in parents:
        pose(f)
    return out


def rz(q: float) -> np.ndarray:
    c, s = np.cos(q), np.sin(q)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


@pytest.mark.parametrize("convention", ["parolkit", "community"])
def test_the_tree_composes_to_parolkits_fk_at_300_joint_vectors(convention: str) -> None:
    tree = TfTree(make_urdf(convention=convention), "parol6/")
    conv = get_convention(convention)
    lo, hi = np.array(PAROL6.safe_limits_deg).T
    rng = np.random.default_rng(27)
    static = tree.static_transforms()
    for q in rng.uniform(lo, hi, size=(300, 6)):
        poses = world_poses(static + tree.transforms(list(conv.to_ros_rad(q))))
        frames = fk_frames(q)
        np.testing.assert_allclose(poses["parol6/base_link"], np.eye(4), atol=0)
        np.testing.assert_allclose(poses["parol6/flange"], frames[6], atol=1e-12)
        np.testing.assert_allclose(poses["parol6/tcp"], frames[7], atol=1e-12)
        for i in range(1, 7):  # link Li is DH frame i-1 turned by Rz(q_i) (parolkit's angles)
            np.testing.assert_allclose(poses[f"parol6/L{i}"], frames[i - 1] @ rz(np.radians(q[i - 1])), atol=1e-12)


def test_frames_static_and_moving() -> None:
    tree = TfTree(make_urdf(), "")
    assert tree.joint_names == ["L1", "L2", "L3", "L4", "L5", "L6"]
    assert [(t.parent, t.child) for t in tree.static_transforms()] == [
        ("world", "base_link"), ("L6", "flange"), ("flange", "tcp")]
    moving = tree.transforms([0.0] * 6)
    assert [(t.parent, t.child) for t in moving] == [
        ("base_link", "L1"), ("L1", "L2"), ("L2", "L3"), ("L3", "L4"), ("L4", "L5"), ("L5", "L6")]
    for t in tree.static_transforms() + moving:
        assert abs(sum(v * v for v in t.rotation) - 1.0) < 1e-12


def test_the_tcp_is_the_urdfs_tool() -> None:
    tree = TfTree(make_urdf(tool="flange"), "a/")
    tcp = next(t for t in tree.static_transforms() if t.child == "a/tcp")
    assert tcp.translation == (0.0, 0.0, 0.0) and tcp.rotation == (0.0, 0.0, 0.0, 1.0)


@pytest.mark.parametrize("prefix", ["/parol6/", "parol 6", "a.b", 3])
def test_a_bad_prefix_is_refused_naming_the_rule(prefix: object) -> None:
    with pytest.raises(ParolkitValueError, match="frame prefix must be letters, digits, _ and /"):
        check_frame_prefix(prefix)  # type: ignore[arg-type]


def test_bad_input_is_refused_with_a_reason() -> None:
    tree = TfTree(make_urdf())
    with pytest.raises(ParolkitValueError, match=r"expected 6 joint positions \(L1, L2, L3, L4, L5, L6\), got 5"):
        tree.transforms([0.0] * 5)
    with pytest.raises(ParolkitValueError, match="URDF: not XML"):
        TfTree("<robot")
    with pytest.raises(ParolkitValueError, match="neither revolute nor fixed"):
        TfTree('<robot><joint name="s" type="prismatic"><parent link="a"/><child link="b"/></joint></robot>')
    with pytest.raises(ParolkitValueError, match="its axis is zero"):
        TfTree('<robot><joint name="r" type="revolute"><parent link="a"/><child link="b"/>'
               '<axis xyz="0 0 0"/></joint></robot>')
