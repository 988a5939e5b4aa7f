"""The collision model: bodies sized and placed from parolkit.robot's DH table through parolkit's
FK, the self-collision pairs computed by sampling (deterministic, with the reason for each
exclusion), the tool's shape and held objects attached to the flange."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from parolkit.collision import (
    PAIR_SAMPLE_SEED,
    PAIR_SAMPLES,
    ArmEnvelope,
    BodyRole,
    Capsule,
    CollisionModel,
    Scene,
    Sphere,
    ToolShape,
    default_model,
)
from parolkit.collision import _reference as ref
from parolkit.collision.model import held_body
from parolkit.config import ToolSettings
from parolkit.errors import ParolkitValueError
from parolkit.kinematics import fk_frames
from parolkit.robot import PAROL6

LINKS = ("J1 link", "J2 link", "J3 link", "J4 link", "J5 link", "J6 link")


def _length(body) -> float:
    return math.dist(body.start, body.end)


def test_the_links_have_the_dh_tables_lengths():
    m = default_model()
    names = [b.name for b in m.bodies]
    assert names == ["base", *LINKS]
    by = {b.name: b for b in m.bodies}
    dh = PAROL6.dh
    assert _length(by["J2 link"]) == pytest.approx(abs(dh[1].a) * 1e3)      # 180 mm upper arm
    assert _length(by["J3 link"]) == pytest.approx(abs(dh[2].a) * 1e3)      # 43.5 mm elbow
    assert _length(by["J4 link"]) == pytest.approx(abs(dh[3].d) * 1e3)      # 176.35 mm forearm
    env = ArmEnvelope()
    assert _length(by["J1 link"]) == pytest.approx(dh[0].d * 1e3 - env.base_size[2])
    assert by["base"].size == env.base_size and by["base"].role is BodyRole.BASE
    assert [by[n].frame for n in LINKS] == [1, 2, 3, 4, 5, 6]
    assert [by[n].radius for n in LINKS] == [env.j1_radius, env.j2_radius, env.j3_radius, env.j4_radius,
                                             env.j5_radius, env.j6_radius]


def test_the_links_are_placed_by_parolkits_fk_at_every_configuration():
    """Each link's segment, moved by the kernel's frames, is where fk_frames puts it: the J2 link
    runs from the J2 axis (frame 1's origin) to the J3 axis (frame 2's), the forearm ends at the
    wrist centre (the flange's origin), and so on."""
    scene = Scene(default_model())
    rng = np.random.default_rng(11)
    lim = np.radians(PAROL6.safe_limits_deg)
    qs = rng.uniform(lim[:, 0], lim[:, 1], size=(40, 6))
    a, b = ref.body_segments(scene._u, qs)  # metres, kernel order: J1..J6 (the base is static)
    for n, q in enumerate(qs):
        f = fk_frames(np.degrees(q))  # (8, 4, 4) metres: base, frames 1..6, TCP
        o = f[:, :3, 3]
        assert np.allclose(a[n, 1], o[1], atol=1e-12) and np.allclose(b[n, 1], o[2], atol=1e-12)  # J2
        assert np.allclose(a[n, 2], o[2], atol=1e-12) and np.allclose(b[n, 2], o[3], atol=1e-12)  # J3
        assert np.allclose(a[n, 3], o[3], atol=1e-12) and np.allclose(b[n, 3], o[6], atol=1e-12)  # J4
        assert np.allclose(b[n, 0], [0, 0, PAROL6.dh[0].d], atol=1e-12)  # J1 link: up to the J2 axis's height
        assert np.allclose(0.5 * (a[n, 4] + b[n, 4]), o[6], atol=1e-12)  # J5 link: centred on the wrist
        assert np.allclose(np.cross(b[n, 4] - a[n, 4], f[4, :3, 2]), 0, atol=1e-12)  # ... along the J5 axis
        assert np.allclose(a[n, 5], o[6], atol=1e-12)  # J6 link: from the wrist centre along the flange's z
        assert np.allclose((b[n, 5] - a[n, 5]) / np.linalg.norm(b[n, 5] - a[n, 5]), f[6, :3, 2], atol=1e-12)


def test_links_that_meet_at_a_joint_are_excluded_and_the_others_checked():
    table = default_model().pair_table()
    assert table.samples == PAIR_SAMPLES + 64 and table.seed == PAIR_SAMPLE_SEED
    assert "20,000 configurations" in table.method and "64 corners" in table.method
    excluded = {(p.a, p.b) for p in table.excluded}
    checked = {(p.a, p.b) for p in table.checked}
    assert len(table.pairs) == 21 and excluded | checked == {(p.a, p.b) for p in table.pairs}
    # consecutive links always touch at their joint (and the base holds the J1 link)
    for pair in [("base", "J1 link"), ("J1 link", "J2 link"), ("J2 link", "J3 link"), ("J3 link", "J4 link"),
                 ("J4 link", "J5 link"), ("J5 link", "J6 link")]:
        assert pair in excluded, pair
    for p in table.excluded:
        assert p.max_mm <= 0.0 and p.contact_fraction == 1.0
        assert p.reason.startswith("in contact in all 20,064 sampled configurations") and "meet at a joint" in p.reason
    # the arm can fold its wrist into its base or column: those pairs are checked, and the
    # sampling saw them touch
    for pair in [("base", "J4 link"), ("base", "J5 link"), ("base", "J6 link"), ("J1 link", "J5 link")]:
        assert pair in checked, pair
    info = {(p.a, p.b): p for p in table.checked}
    assert 0 < info[("base", "J5 link")].contact_fraction < 0.1 and info[("base", "J5 link")].min_mm < 0
    assert all(p.max_mm > 0 for p in table.checked)
    assert "closest" in info[("J2 link", "J5 link")].reason


def test_the_pair_table_is_deterministic_and_cached():
    first = default_model().pair_table()
    again = CollisionModel().pair_table()
    assert first is again  # cached per geometry
    from parolkit.collision.model import _pair_table, _sampled_pairs

    _pair_table.cache_clear()
    _sampled_pairs.cache_clear()
    fresh = CollisionModel().pair_table()
    assert fresh == first and fresh is not first


def test_a_tool_shape_adds_its_pairs_with_the_arm():
    pen = ToolShape("pen", 8, end=(0, 0, 150))
    table = default_model().pair_table(tool=pen)
    by = {(p.a, p.b): p for p in table.pairs}
    t = "tool 'pen'"
    # the tool and the flange move together: never sampled
    assert not by[("J6 link", t)].checked and "move together" in by[("J6 link", t)].reason
    assert math.isnan(by[("J6 link", t)].min_mm)
    # it starts inside the wrist: always touching the links that meet there
    assert not by[("J5 link", t)].checked and not by[("J4 link", t)].checked
    # a 150 mm pen can reach the base, the column and the upper arm
    for a in ("base", "J1 link", "J2 link"):
        assert by[(a, t)].checked and by[(a, t)].contact_fraction > 0
    # a config tool carries the same shape
    cfg_tool = ToolSettings("pen", (0, 0, 150, 0, 0, 0), shape=pen)
    assert default_model().pair_table(tool=cfg_tool) == table
    # a tool without a shape adds nothing
    assert default_model().pair_table(tool=ToolSettings("bare", (0, 0, 50, 0, 0, 0))) == default_model().pair_table()


def test_held_objects_are_attached_replaced_and_detached_by_name():
    m = CollisionModel()
    assert m.held == ()
    part = m.attach(Sphere(20), (0, 0, 100, 0, 0, 0), name="part")
    assert m.held == (part,) and part.pose == (0.0, 0.0, 100.0, 0.0, 0.0, 0.0)
    rod = m.attach(Capsule(radius=5, length=200), (0, 0, 80, 0, 90, 0), name="rod")
    assert [h.name for h in m.held] == ["part", "rod"]
    body = held_body(rod)
    # a capsule lies along its own z: rotated B = 90 deg about y, z points along the flange's x
    assert body.start == pytest.approx((-100.0, 0.0, 80.0), abs=1e-9)
    assert body.end == pytest.approx((100.0, 0.0, 80.0), abs=1e-9)
    assert body.name == "held 'rod'" and body.role is BodyRole.HELD and body.frame == 6
    v = m.version
    bigger = m.attach(Sphere(30), (0, 0, 100, 0, 0, 0), name="part")  # same name: replaced
    assert [h.name for h in m.held] == ["rod", "part"] and m.held[1] is bigger and m.version == v + 1
    rod_now = m.held[0]
    assert m.detach("rod") == (rod_now,)
    assert [h.name for h in m.held] == ["part"]
    with pytest.raises(ParolkitValueError, match=r"detach\(\): no held object named 'rod' \('part'\)"):
        m.detach("rod")
    assert m.detach() == (bigger,) and m.held == ()
    assert m.detach() == ()


def test_attach_refuses_what_it_cannot_hold_naming_the_problem():
    m = CollisionModel()
    with pytest.raises(ParolkitValueError, match=r"shape must be a Capsule or a Sphere \(a box is held as "
                                                 r"Capsule.around_box\(size\)\)"):
        m.attach("box", (0, 0, 0, 0, 0, 0))  # type: ignore[arg-type]
    with pytest.raises(ParolkitValueError, match=r"pose must be 6 finite numbers"):
        m.attach(Sphere(5), (0, 0, 0))
    with pytest.raises(ParolkitValueError, match=r"pose z = 5000 mm is out of range \[-1000, 1000\] mm"):
        m.attach(Sphere(5), (0, 0, 5000, 0, 0, 0))
    with pytest.raises(ParolkitValueError, match=r"held object name must be"):
        m.attach(Sphere(5), name="it's")
    with pytest.raises(ParolkitValueError, match=r"Sphere.radius must be a number in \(0, 500\] mm, got 0"):
        Sphere(0)
    with pytest.raises(ParolkitValueError, match=r"Capsule.length must be a number in \[0, 2000\] mm, got -1"):
        Capsule(5, -1)


def test_a_box_is_held_as_the_capsule_that_encloses_it():
    c = Capsule.around_box((60, 80, 40))
    assert c.radius == pytest.approx(50.0) and c.length == 40.0
    # every corner of the box is inside the capsule
    for x in (-30, 30):
        for y in (-40, 40):
            for z in (-20, 20):
                assert math.hypot(x, y) <= c.radius + 1e-9 and abs(z) <= c.length / 2


def test_a_model_with_its_own_envelope_and_self_margin():
    slim = CollisionModel(envelope=ArmEnvelope(j2_radius=20.0), self_margin=5.0)
    assert {b.name: b.radius for b in slim.bodies}["J2 link"] == 20.0
    assert slim.self_margin == 5.0
    with pytest.raises(ParolkitValueError, match=r"ArmEnvelope.j2_radius must be a number in \(0, 200\] mm"):
        ArmEnvelope(j2_radius=0.0)
    with pytest.raises(ParolkitValueError, match=r"self_margin must be a number in \[0, 100\] mm"):
        CollisionModel(self_margin=-1)
    with pytest.raises(ParolkitValueError, match=r"height \(200 mm\) must be below the J2 axis \(110.5 mm\)"):
        CollisionModel(envelope=ArmEnvelope(base_size=(100, 100, 200)))


def test_a_kinematics_tool_without_a_shape_is_refused_not_ignored():
    from parolkit.kinematics import get_tool

    with pytest.raises(ParolkitValueError, match=r"tool must be a ToolShape, a config tool \(ToolSettings\) or None"):
        Scene(tool=get_tool("default"))  # type: ignore[arg-type]


def test_docs_list_the_computed_pairs():
    """docs/collision.md's pair table is the computed one (checked or excluded, the clearance
    range over the samples, the share in contact)."""
    doc = Path(__file__).resolve().parents[2] / "docs" / "collision.md"
    row = re.compile(r"^\| (.+?) vs (.+?) \| (checked|excluded)[^|]* \| (-?[\d.]+) \.\. (-?[\d.]+) \| ([\d.]+) % \|$")
    rows = [m.groups() for line in doc.read_text(encoding="utf-8").splitlines() if (m := row.match(line))]
    table = default_model().pair_table()
    assert len(rows) == len(table.pairs)
    for (a, b, status, lo, hi, pct), p in zip(rows, table.pairs):
        assert (a, b) == (p.a, p.b)
        assert (status == "checked") == p.checked, (a, b)
        assert float(lo) == pytest.approx(p.min_mm, abs=0.05) and float(hi) == pytest.approx(p.max_mm, abs=0.05)
        assert float(pct) == pytest.approx(100 * p.contact_fraction, abs=0.005 if "." in pct else 0.5)
