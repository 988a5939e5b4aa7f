"""The generated MoveIt configuration read by pinocchio (PyPI ``pin``, a dev extra; never imported
by src/): a robotics library of its own reading our URDF and SRDF.

* ``buildModelFromXML`` / ``buildGeomFromUrdfString`` load the URDF with its collision shapes;
  pinocchio's FK puts the tool point where parolkit's FK does (both joint conventions);
* all collision pairs added, ``removeCollisionPairsFromXML`` removes the SRDF's disabled pairs:
  the count left is the geometry pairs between the link pairs parolkit's collision model
  checks, and exactly those;
* ``loadReferenceConfigurationsFromXML`` reads the named states 'standby' and 'home'.
"""

from __future__ import annotations

import itertools
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from parolkit.kinematics import fk_matrix
from parolkit.robot import PAROL6
from parolkit.ros2.convention import COMMUNITY, PAROLKIT, JointConvention
from parolkit.ros2.moveit_config import disabled_pairs, make_srdf
from parolkit.ros2.urdf import make_urdf

pin = pytest.importorskip("pinocchio")


def _load(convention: JointConvention) -> tuple[object, object, str, str]:
    from parolkit.collision import default_model

    urdf = make_urdf(convention=convention)
    srdf = make_srdf(PAROL6, convention, disabled_pairs(default_model()))
    model = pin.buildModelFromXML(urdf)
    geom = pin.buildGeomFromUrdfString(model, urdf, pin.COLLISION)
    return model, geom, urdf, srdf


def _parent_link(model: object, geom: object, k: int) -> str:
    return str(model.frames[geom.geometryObjects[k].parentFrame].name)  # type: ignore[attr-defined]


@pytest.mark.parametrize("convention", [PAROLKIT, COMMUNITY], ids=lambda c: c.name)
def test_pinocchio_loads_the_urdf_and_removes_the_srdfs_disabled_pairs(convention: JointConvention) -> None:
    model, geom, urdf, srdf = _load(convention)
    assert model.nq == 6 and list(model.names)[1:] == ["L1", "L2", "L3", "L4", "L5", "L6"]  # type: ignore[attr-defined]
    shapes = {}  # link -> number of its collision shapes, as pinocchio attached them
    for k in range(geom.ngeoms):  # type: ignore[attr-defined]
        link = _parent_link(model, geom, k)
        shapes[link] = shapes.get(link, 0) + 1
    assert shapes == {"base_link": 1, "L1": 3, "L2": 3, "L3": 3, "L4": 3, "L5": 3, "flange": 3}
    geom.addAllCollisionPairs()  # type: ignore[attr-defined]
    all_pairs = len(geom.collisionPairs)  # type: ignore[attr-defined]
    # every two shapes on different links (pinocchio leaves out shapes on one joint: flange is on L6's)
    assert all_pairs == sum(shapes[a] * shapes[b] for a, b in itertools.combinations(shapes, 2))
    pin.removeCollisionPairsFromXML(model, geom, srdf, False)
    disabled = {frozenset((el.get("link1"), el.get("link2"))) for el in ET.fromstring(srdf).iter("disable_collisions")}
    left = {frozenset((_parent_link(model, geom, cp.first), _parent_link(model, geom, cp.second)))
            for cp in geom.collisionPairs}  # type: ignore[attr-defined]
    assert len(geom.collisionPairs) == all_pairs - sum(  # type: ignore[attr-defined]
        shapes[a] * shapes[b] for a, b in (sorted(p) for p in disabled))  # type: ignore[misc]
    # what is left is the link pairs parolkit's collision model checks and that can touch
    from parolkit.collision import default_model
    from parolkit.collision.model import BodyRole
    from parolkit.ros2.urdf import collision_link

    arm = (BodyRole.BASE, BodyRole.LINK)
    link_of = {b.name: collision_link(b.frame) for b in default_model().bodies if b.role in arm}
    checked = {frozenset((link_of[p.a], link_of[p.b])) for p in default_model().pair_table().pairs
               if p.checked and p.min_mm <= 0.0}
    assert left == checked and len(checked) == 6
    assert not left & disabled


@pytest.mark.parametrize("convention", [PAROLKIT, COMMUNITY], ids=lambda c: c.name)
def test_pinocchios_fk_of_the_urdf_is_parolkits_and_it_reads_the_named_states(convention: JointConvention) -> None:
    model, _, _, srdf = _load(convention)
    data = model.createData()  # type: ignore[attr-defined]
    tcp = model.getFrameId("tcp")  # type: ignore[attr-defined]
    lim = PAROL6.safe_limits_deg
    for q in [np.array(PAROL6.standby_deg), *np.random.default_rng(4).uniform(lim[:, 0], lim[:, 1], size=(100, 6))]:
        pin.framesForwardKinematics(model, data, convention.to_ros_rad(q))
        np.testing.assert_allclose(data.oMf[tcp].homogeneous, fk_matrix(q), rtol=0, atol=1e-12)
    pin.loadReferenceConfigurationsFromXML(model, srdf, False)
    refs = model.referenceConfigurations  # type: ignore[attr-defined]
    from parolkit.ros2.moveit_config import named_states_deg

    for name, q_deg in named_states_deg(PAROL6).items():
        np.testing.assert_allclose(refs[name], convention.to_ros_rad(q_deg), rtol=0, atol=1e-15)
