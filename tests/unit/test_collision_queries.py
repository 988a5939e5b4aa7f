"""Collision queries: a pose's verdict (closest self, link-zone and tool/held-zone pairs, named
in words, margins), the swept check between poses (a thin zone cannot be jumped over; clear
means every pose in between is clear), and the first violation along a trajectory."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from parolkit.collision import (
    TABLE_ZONE,
    BoxZone,
    CollisionModel,
    CylinderZone,
    PairKind,
    PathStatus,
    PlaneZone,
    Scene,
    Sphere,
    ToolShape,
    check,
    check_path,
    check_swept,
    default_model,
)
from parolkit.collision import scene as scene_mod
from parolkit.errors import ParolkitValueError
from parolkit.kinematics import fk_frames
from parolkit.robot import PAROL6

STANDBY = np.radians(PAROL6.standby_deg)
LIM = np.radians(PAROL6.safe_limits_deg)


def _world_capsules(q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray, float]]:
    """Each link's axis end points (mm, world) and radius, from fk_frames (not the kernel)."""
    f = fk_frames(np.degrees(q))
    out = {}
    for b in default_model().bodies[1:]:
        r, o = f[b.frame][:3, :3], f[b.frame][:3, 3] * 1e3
        out[b.name] = (r @ np.array(b.start) + o, r @ np.array(b.end) + o, b.radius)
    return out


def _random_q(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(LIM[:, 0], LIM[:, 1], size=(n, 6))


def test_the_standby_pose_is_clear_of_itself_and_the_table():
    v = check(STANDBY, (TABLE_ZONE,))
    assert v.clear and v.violation is None
    assert v.self_closest is not None and v.self_closest.pair.kind is PairKind.SELF
    assert v.zone_closest is not None and v.zone_closest.pair.b == "zone 'table'"
    assert v.attached_closest is None  # no tool shape, nothing held
    assert str(v).startswith("clear (closest: ")


def test_a_plane_zones_clearance_is_exact_and_names_the_nearest_link():
    """A ceiling 40 mm above the arm's highest point: the clearance is 40 mm, to that link."""
    q = np.radians([30, -70, 160, 20, 40, 90])
    caps = _world_capsules(q)
    top_name, top = max(((n, max(a[2], b[2]) + r) for n, (a, b, r) in caps.items()), key=lambda t: t[1])
    ceiling = PlaneZone("ceiling", point=(0, 0, top + 40.0), normal=(0, 0, -1), margin=5)
    v = check(q, (ceiling,))
    assert v.zone_closest is not None
    assert str(v.zone_closest.pair) == f"{top_name} vs zone 'ceiling'"
    assert v.zone_closest.distance_mm == pytest.approx(40.0, abs=1e-9)
    assert v.clear
    # the margin decides: 40 mm away with a 45 mm margin is a violation
    close = PlaneZone("ceiling", point=(0, 0, top + 40.0), normal=(0, 0, -1), margin=45)
    v2 = check(q, (close,))
    assert not v2.clear and v2.violation is not None and v2.violation.within_margin and not v2.violation.contact
    assert v2.violation.pair == v2.zone_closest.pair  # type: ignore[union-attr]
    assert str(v2) == f"within margin: {top_name} vs zone 'ceiling': 40.0 mm (margin 45 mm)"


def test_a_box_around_the_wrist_is_contact_for_every_link_that_enters_it():
    f = fk_frames(PAROL6.standby_deg)
    wrist = f[6][:3, 3] * 1e3
    box = BoxZone("box", center=tuple(wrist), size=(20, 20, 20))
    scene = Scene(zones=(TABLE_ZONE, box))
    d, pa, pb = scene.distances(STANDBY)
    names = [str(p) for p in scene.pairs]
    for link, radius in (("J4 link", 28.0), ("J5 link", 26.0), ("J6 link", 22.0)):
        # the link's axis passes through the box: contact, reported as minus its radius
        assert d[names.index(f"{link} vs zone 'box'")] == pytest.approx(-radius)
    v = scene.check(STANDBY)
    assert not v.clear and v.worst is not None and str(v.worst.pair) == "J4 link vs zone 'box'"
    assert v.worst.contact and v.worst.distance_mm == pytest.approx(-28.0)
    assert v.zone_closest == v.worst


def test_the_tool_and_held_objects_are_checked_against_zones_as_their_own_category():
    pen = ToolShape("pen", 5, end=(0, 0, 200))
    f = fk_frames(PAROL6.standby_deg)
    tip = f[6][:3, :3] @ np.array([0, 0, 200.0]) + f[6][:3, 3] * 1e3
    # the cup's rim is 20 mm above the pen's tip: the pen reaches into it
    cup = CylinderZone("cup", center=tuple(tip + np.array([0, 0, -30.0])), axis=(0, 0, 1), radius=30, height=100)
    v = check(STANDBY, (TABLE_ZONE, cup), tool=pen)
    assert v.attached_closest is not None and str(v.attached_closest.pair) == "tool 'pen' vs zone 'cup'"
    assert v.attached_closest.pair.kind is PairKind.ATTACHED_ZONE and v.attached_closest.contact
    assert not v.clear and v.worst is not None and v.worst.pair.a == "tool 'pen'"
    # a held sphere
    model = CollisionModel()
    model.attach(Sphere(15), (0, 0, 60, 0, 0, 0), name="part")
    v2 = check(STANDBY, (TABLE_ZONE, cup), model=model)
    assert v2.attached_closest is not None and v2.attached_closest.pair.a == "held 'part'"
    model.detach()
    assert check(STANDBY, (TABLE_ZONE, cup), model=model).attached_closest is None


def test_an_arm_folded_into_its_base_is_a_self_collision_named_by_its_links():
    scene = Scene(zones=())
    rng = np.random.default_rng(5)
    qs = _random_q(rng, 3000)
    d, _, _ = scene.distances_batch(qs)
    self_pairs = [k for k, p in enumerate(scene.pairs) if p.kind is PairKind.SELF]
    k = int(np.argmin(d[:, self_pairs].min(axis=1)))
    v = scene.check(qs[k])
    assert not v.clear and v.self_closest is not None and v.self_closest.contact
    assert v.worst == v.self_closest
    text = str(v.self_closest.pair)
    assert text in {f"{a} vs {b}" for a, b in [(p.a, p.b) for p in default_model().pair_table().checked]}
    assert " vs " in text and "zone" not in text


def test_the_sweep_catches_a_thin_zone_between_two_samples():
    """A 2 mm plate stands where the wrist passes halfway through a 60 deg J1 turn: both end
    poses are clear and so is a check of the two samples; the sweep is not."""
    q0 = STANDBY.copy()
    q1 = STANDBY.copy()
    q1[0] -= math.radians(60)
    mid = STANDBY.copy()
    mid[0] -= math.radians(30)
    wrist = fk_frames(np.degrees(mid))[6][:3, 3] * 1e3
    yaw = math.degrees(mid[0])  # the plate faces along the turn
    plate = BoxZone("plate", center=tuple(wrist), size=(80, 2, 80), rpy=(0, 0, yaw), margin=1)
    scene = Scene(zones=(plate,))
    assert scene.check(q0).clear and scene.check(q1).clear
    assert scene.check_path(np.stack([q0, q1]), swept=False).clear
    hit = scene.check_swept(q0, q1)
    assert hit.status is PathStatus.BETWEEN_SAMPLES and hit.index == 0 and 0 < hit.fraction < 1
    assert hit.pair is not None and hit.pair.pair.b == "zone 'plate'"
    q_hit = q0 + hit.fraction * (q1 - q0)
    d, _, _ = scene.distances(q_hit)
    k = scene.pairs.index(hit.pair.pair)
    assert d[k] <= plate.margin + scene.tau_mm + 1e-9
    assert "between samples 0 and 1" in str(hit)
    # the module-level function agrees
    assert check_swept(q0, q1, (plate,)).status is PathStatus.BETWEEN_SAMPLES


@pytest.mark.parametrize("seed", range(3))
def test_a_clear_sweep_has_every_pose_in_between_clear_and_a_violation_is_where_it_says(seed):
    rng = np.random.default_rng(100 + seed)

    def somewhere_the_wrist_goes() -> tuple[float, ...]:
        return tuple(fk_frames(np.degrees(_random_q(rng, 1)[0]))[6][:3, 3] * 1e3)

    zones = (TABLE_ZONE,
             BoxZone("b", somewhere_the_wrist_goes(), tuple(rng.uniform(10, 150, 3)),
                     tuple(rng.uniform(-180, 180, 3)), margin=float(rng.uniform(0, 10))),
             CylinderZone("c", somewhere_the_wrist_goes(), tuple(rng.normal(size=3)), float(rng.uniform(5, 60)),
                          float(rng.uniform(20, 300)), margin=float(rng.uniform(0, 10))))
    scene = Scene(zones=zones, tool=ToolShape("t", 10, end=(0, 0, 100)))
    clear_seen = hit_seen = 0
    for _ in range(40):
        q0 = _random_q(rng, 1)[0]
        while not scene.check(q0).clear:  # start from a clear pose: the sweep then proves a stretch
            q0 = _random_q(rng, 1)[0]
        q1 = np.clip(q0 + rng.normal(scale=0.4, size=6), LIM[:, 0], LIM[:, 1])
        v = scene.check_swept(q0, q1)
        s_end = 1.0 if v.clear else v.fraction
        dense = q0 + np.linspace(0, s_end, 400, endpoint=v.clear)[:, None] * (q1 - q0)
        d, _, _ = scene.distances_batch(dense)
        margins = np.array([p.margin_mm for p in scene.pairs])
        # every pose proven clear (all of them, or all before the reported one) is clear
        assert (d > margins).all(), (v, float((d - margins).min()))
        if v.clear:
            clear_seen += 1
        else:
            hit_seen += 1
            assert v.pair is not None
            q_hit = q0 + v.fraction * (q1 - q0)
            dh, _, _ = scene.distances(q_hit)
            k = scene.pairs.index(v.pair.pair)
            assert dh[k] <= v.pair.margin_mm + (scene.tau_mm if v.status is PathStatus.BETWEEN_SAMPLES else 0) + 1e-9
            assert dh[k] == pytest.approx(v.pair.distance_mm, abs=1e-9)
    assert clear_seen and hit_seen


def test_the_lipschitz_bound_holds_for_large_joint_steps():
    """No pair's clearance changes by more than its bound times the joint step, even for steps
    of up to a whole joint range (what the sweep relies on)."""
    zones = (TABLE_ZONE, BoxZone("b", (200, 100, 150), (100, 80, 60), (10, 20, 30)),
             CylinderZone("c", (-100, 250, 100), (1, 0, 1), 30, 200))
    scene = Scene(zones=zones, tool=ToolShape("t", 10, end=(20, 0, 120)))
    lip = scene._u.lipschitz * 1e3  # mm per rad
    rng = np.random.default_rng(3)
    q0 = _random_q(rng, 500)
    q1 = _random_q(rng, 500)
    q1[:250] = np.clip(q0[:250] + rng.normal(scale=0.05, size=(250, 6)), LIM[:, 0], LIM[:, 1])
    d0, _, _ = scene.distances_batch(q0)
    d1, _, _ = scene.distances_batch(q1)
    bound = np.abs(q1 - q0) @ lip.T  # (N, P)
    # only the part of a clearance above 0 is a distance (an overlap's value is not bounded)
    change = np.abs(np.maximum(d1, 0) - np.maximum(d0, 0))
    assert (change <= bound + 1e-9).all()
    assert (change / np.maximum(bound, 1e-12)).max() > 0.3  # the bound is not vacuous


def test_a_trajectory_reports_its_first_violating_sample():
    scene = Scene(zones=(TABLE_ZONE, CylinderZone("post", (200, 200, 150), (0, 0, 1), 20, 300, margin=5)))
    qs = np.linspace(np.radians([90, -90, 180, 0, 0, 180]), np.radians([-60, -40, 120, 30, 80, 0]), 600)
    per_sample = [scene.check(q).clear for q in qs]
    first = per_sample.index(False)
    plain = scene.check_path(qs, swept=False)
    assert plain.status is PathStatus.AT_SAMPLE and plain.index == first and plain.fraction == 0.0
    assert plain.pair is not None and str(plain.pair.pair) == "J5 link vs zone 'post'"
    assert plain.pair == scene.check(qs[first]).worst
    swept = scene.check_path(qs)
    assert not swept.clear and swept.position is not None and swept.position <= first
    assert swept.position > first - 1
    assert check_path(qs, scene.zones).position == swept.position
    # clear paths
    assert scene.check_path(qs[:first]).clear or scene.check_path(qs[:first]).position > first - 1
    assert scene.check_path(qs[:10]).clear and scene.check_path(qs[:10]).index is None
    assert scene.check_path(qs[:1]).clear and scene.check_path(np.empty((0, 6))).clear


def test_a_violation_at_the_first_sample_is_at_that_sample():
    box = BoxZone("box", center=tuple(fk_frames(PAROL6.standby_deg)[6][:3, 3] * 1e3), size=(20, 20, 20))
    v = check_path(np.stack([STANDBY, STANDBY]), (box,))
    assert v.status is PathStatus.AT_SAMPLE and v.index == 0 and str(v).startswith("sample 0: J4 link vs zone 'box'")


def test_bad_joint_vectors_are_refused_with_the_precise_error():
    scene = Scene()
    with pytest.raises(ParolkitValueError, match=r"q must be 6 values, got shape \(5,\)"):
        scene.check([0.0] * 5)
    with pytest.raises(ParolkitValueError, match=r"q: J2 is not a finite number"):
        scene.check([0.0, math.nan, 0, 0, 0, 0])
    with pytest.raises(ParolkitValueError, match=r"q must be numbers"):
        scene.check(["a", 0, 0, 0, 0, 0])
    with pytest.raises(ParolkitValueError, match=r"qs must be 6 values or an \(N, 6\) array"):
        scene.check_path(np.zeros((3, 5)))
    with pytest.raises(ParolkitValueError, match=r"zone names must be unique, 'table' given twice"):
        Scene(zones=(TABLE_ZONE, TABLE_ZONE))
    # numpy scalars, ints and arrays are joint vectors too
    assert scene.check(np.array(STANDBY)).clear and scene.check([int(v) for v in (0, -1, 3, 0, 0, 0)]) is not None
    assert scene.check(tuple(np.float64(v) for v in STANDBY)).clear


def test_disabled_zones_are_left_out():
    off = BoxZone("off", (0, 0, 0), (5000, 5000, 5000), enabled=False)
    scene = Scene(zones=(TABLE_ZONE, off))
    assert [z.name for z in scene.zones] == ["table"]
    assert scene.check(STANDBY).clear


def test_the_module_functions_reuse_the_scene_until_the_held_objects_change():
    zones = (TABLE_ZONE,)
    model = CollisionModel()
    check(STANDBY, zones, model=model)
    first = scene_mod._CACHE["last"][1]
    check(STANDBY, zones, model=model)
    assert scene_mod._CACHE["last"][1] is first
    check(STANDBY, list(zones), model=model)  # an equal list of zones: the same scene
    assert scene_mod._CACHE["last"][1] is first
    model.attach(Sphere(10), (0, 0, 50, 0, 0, 0))
    v = check(STANDBY, zones, model=model)
    assert scene_mod._CACHE["last"][1] is not first and v.clear
    assert any(p.a == "held 'object'" for p in scene_mod._CACHE["last"][1].pairs)


def test_path_raw_is_check_path_for_a_few_poses_in_a_hurry():
    sc = Scene(zones=(TABLE_ZONE, PlaneZone("near", point=(0, 240, 0), normal=(0, -1, 0), margin=10)))
    q0 = np.radians([90.0, -100.0, 180.0, 0.0, 0.0, 180.0])
    q1 = np.radians([90.0, -80.0, 180.0, 0.0, 0.0, 180.0])
    full = sc.check_path(np.stack([q0, q1]))
    status, index, frac, k, d = sc.path_raw(list(q0) + list(q1))
    assert (status, index, k) == (list(PathStatus).index(full.status), full.index, sc.pairs.index(full.pair.pair))
    assert frac == pytest.approx(full.fraction) and d == pytest.approx(full.pair.distance_mm)
    assert sc.path_raw(list(q0) + list(q0))[0] == 0


def test_with_margins_lowers_only_the_pairs_named_and_reports_true_clearances():
    near = PlaneZone("near", point=(0, 240, 0), normal=(0, -1, 0), margin=10)
    sc = Scene(zones=(near,))
    q = np.radians((90.0, -90.0, 180.0, 0.0, 0.0, 180.0))
    v = sc.check(q)
    assert not v.clear and str(v.worst.pair) == "J6 link vs zone 'near'"
    k = sc.pairs.index(v.worst.pair)
    status, index, frac, kk, dist = sc.path_raw(list(q) + list(q))
    assert (status, index, frac, kk) == (1, 0, 0.0, k) and dist == pytest.approx(v.worst.distance_mm)
    relaxed = sc.with_margins({k: v.worst.distance_mm - 1.0})
    assert relaxed.kernel_margins_mm[k] == pytest.approx(v.worst.distance_mm - 1.0)
    assert sc.kernel_margins_mm[k] == sc.pairs[k].margin_mm == 10.0  # the scene itself unchanged
    assert relaxed.path_raw(list(q) + list(q))[0] == 0 and relaxed.check_swept(q, q).clear
    # 2 mm further in: violated again, the distance reported the true clearance
    q2 = np.radians([90.0, -88.5, 180.0, 0.0, 0.0, 180.0])
    w = relaxed.check_swept(q, q2)
    assert not w.clear and w.pair.pair == sc.pairs[k] and w.pair.distance_mm <= v.worst.distance_mm - 1.0 + 0.01
    assert sc.with_margins({k: 1.0}) is sc.with_margins({k: 1.0})  # kept: asked for tick after tick


def test_a_zone_pair_no_joint_can_change_is_not_checked_and_a_zone_the_column_stands_in_is_refused():
    """The J1 link turns about its own axis: its clearance to the table plane (or to any zone:
    the capsule lies on the axis) is the same at every pose.  Within the zone's margin it would
    refuse every pose, so such a pair is left out and kept, with its clearance, in
    ``Scene.fixed_pairs``; a zone it touches is an error naming the zone and the link."""
    table = dataclasses.replace(TABLE_ZONE, margin=10.0)  # the column's foot is 5 mm above it
    sc = Scene(zones=(table,))
    (fixed,) = sc.fixed_pairs
    assert str(fixed.pair) == "J1 link vs zone 'table'" and fixed.distance_mm == pytest.approx(5.0)
    assert fixed.pair not in sc.pairs
    assert sc.check(np.radians([90.0, -90.0, 180.0, 0.0, 0.0, 180.0])).clear
    # the other links are still checked against the table, with its margin
    low = sc.check(np.radians([90.0, -40.0, 120.0, 0.0, 90.0, 180.0]))
    assert any(p.b == "zone 'table'" and p.a != "J1 link" for p in sc.pairs) and low.zone_closest is not None
    with pytest.raises(ParolkitValueError, match=r"zone 'post' overlaps the J1 link \(.* mm deep\) at every pose"):
        Scene(zones=(BoxZone("post", center=(0, 0, 100), size=(20, 20, 20)),))
