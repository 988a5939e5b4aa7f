"""The compiled collision kernel (_ccollide.c) gives the answers of the numpy reference.

Scenes run the C kernel when it is built; ``_reference`` is the code it copies (and what runs
without a C compiler or with ``PAROLKIT_PURE_PYTHON=1``).  Both must give the same verdicts,
distances (to 1e-9 mm: the same operations, summed in a different order here and there), first
violations and sweep evaluations, so switching between them never changes what is refused.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from parolkit.collision import (
    TABLE_ZONE,
    BoxZone,
    CollisionModel,
    CylinderZone,
    PlaneZone,
    Scene,
    Sphere,
    ToolShape,
    kernel_name,
)
from parolkit.collision import _reference as ref
from parolkit.collision._kernel import ccollide
from parolkit.robot import PAROL6

PURE = os.environ.get("PAROLKIT_PURE_PYTHON", "") not in ("", "0")
needs_kernel = pytest.mark.skipif(ccollide is None, reason="the C kernel is not built (pure-Python run)")
LIM = np.radians(PAROL6.safe_limits_deg)


def _scenes(seed: int) -> tuple[Scene, Scene]:
    """The same random scene twice: the first runs the kernel, the second the reference."""
    rng = np.random.default_rng(seed)
    zones = (
        TABLE_ZONE,
        BoxZone("b", tuple(rng.uniform(-250, 250, 3) + [0, 0, 200]), tuple(rng.uniform(20, 200, 3)),
                tuple(rng.uniform(-90, 90, 3)), margin=float(rng.uniform(0, 20))),
        CylinderZone("c", tuple(rng.uniform(-250, 250, 3) + [0, 0, 200]), tuple(rng.normal(size=3)),
                     float(rng.uniform(10, 80)), float(rng.uniform(50, 400)), margin=float(rng.uniform(0, 20))),
        PlaneZone("wall", (0, float(rng.uniform(-400, -200)), 0), (0, 1, 0), margin=3),
    )
    model = CollisionModel(self_margin=2.0)
    model.attach(Sphere(float(rng.uniform(5, 30))), (0, 0, float(rng.uniform(40, 120)), 0, 0, 0), name="part")
    tool = ToolShape("t", float(rng.uniform(3, 15)), end=(0, 0, float(rng.uniform(60, 150))))
    fast, slow = Scene(model, zones, tool), Scene(model, zones, tool)
    slow._kernel = None
    return fast, slow


def test_the_kernel_is_built_in_this_checkout():
    if PURE:
        pytest.skip("PAROLKIT_PURE_PYTHON is set")
    assert ccollide is not None, "build it: pip install -e . (setup.py compiles src/parolkit/collision/_ccollide.c)"
    assert kernel_name() == "compiled"


@needs_kernel
@pytest.mark.parametrize("seed", range(4))
def test_single_pose_verdicts_agree(seed):
    fast, slow = _scenes(seed)
    rng = np.random.default_rng(50 + seed)
    for q in rng.uniform(LIM[:, 0], LIM[:, 1], size=(300, 6)):
        a, b = fast.check(q), slow.check(q)
        for x, y in ((a.self_closest, b.self_closest), (a.zone_closest, b.zone_closest),
                     (a.attached_closest, b.attached_closest), (a.worst, b.worst)):
            assert (x is None) == (y is None)
            if x is not None and y is not None:
                assert x.pair == y.pair
                assert x.distance_mm == pytest.approx(y.distance_mm, abs=1e-9)
        assert a.clear == b.clear


@needs_kernel
def test_every_pairs_distance_and_closest_points_agree():
    fast, slow = _scenes(9)
    qs = np.random.default_rng(9).uniform(LIM[:, 0], LIM[:, 1], size=(2000, 6))
    d1, pa1, pb1 = fast.distances_batch(qs)
    d2, pa2, pb2 = slow.distances_batch(qs)
    assert np.abs(d1 - d2).max() < 1e-9
    # where a box or cylinder's distance is flat along the capsule, the point may slide a little
    assert np.abs(pa1 - pa2).max() < 1e-6 and np.abs(pb1 - pb2).max() < 1e-6


@needs_kernel
@pytest.mark.parametrize("swept", [True, False])
def test_paths_give_the_same_first_violation_and_evaluations(swept):
    fast, slow = _scenes(21)
    rng = np.random.default_rng(21)
    seen = {True: 0, False: 0}
    for _ in range(40):
        a, b = rng.uniform(LIM[:, 0], LIM[:, 1], size=(2, 6))
        qs = np.linspace(a, b, int(rng.integers(2, 300)))
        va, vb = fast.check_path(qs, swept=swept), slow.check_path(qs, swept=swept)
        assert (va.status, va.index, va.evaluations) == (vb.status, vb.index, vb.evaluations)
        assert va.fraction == pytest.approx(vb.fraction, abs=1e-12)
        if va.pair is not None and vb.pair is not None:
            assert va.pair.pair == vb.pair.pair
            assert va.pair.distance_mm == pytest.approx(vb.pair.distance_mm, abs=1e-9)
        seen[va.clear] += 1
    assert seen[True] and seen[False]


@needs_kernel
def test_odd_joint_vectors_take_the_python_path_and_its_error():
    fast, _ = _scenes(0)
    k = fast._kernel
    assert k.check(fast.packed, [0.0] * 5) is None
    assert k.check(fast.packed, [0.0, float("nan"), 0, 0, 0, 0]) is None
    assert k.check(fast.packed, ["0", 0, 0, 0, 0, 0]) is None
    assert k.check(fast.packed, np.zeros(6, dtype=np.float32)) is None
    assert k.check(fast.packed, np.zeros(6)) is not None
    assert k.check(fast.packed, (True, 0, 0, 0, 0, 0)) is None  # not a plain number: the Python path
    assert fast.check((True, 0, 0, 0, 0, 0)) == fast.check((1.0, 0, 0, 0, 0, 0))  # ... takes it as numpy does
    with pytest.raises(ValueError, match="not a packed collision scene"):
        k.check(np.zeros(40), [0.0] * 6)
    with pytest.raises(TypeError, match="packed must be a C-contiguous float64 array"):
        k.check(b"x" * 240, [0.0] * 6)


def test_pure_python_runs_the_reference_with_the_same_verdict():
    code = ("import numpy as np\n"
            "from parolkit.collision import Scene, TABLE_ZONE, kernel_name\n"
            "s = Scene(zones=(TABLE_ZONE,))\n"
            "v = s.check(np.radians([90, -90, 180, 0, 0, 180]))\n"
            "print(kernel_name(), '|', s._kernel is None, '|', v)\n")
    env = dict(os.environ, PAROLKIT_PURE_PYTHON="1")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True,
                         timeout=60)
    name, is_ref, verdict = (p.strip() for p in out.stdout.split("|"))
    assert name == "pure Python: PAROLKIT_PURE_PYTHON is set" and is_ref == "True"
    here = Scene(zones=(TABLE_ZONE,)).check(np.radians([90, -90, 180, 0, 0, 180]))
    assert verdict == str(here)


def test_the_reference_reads_the_packed_scene_it_is_given():
    fast, _ = _scenes(1)
    u = ref.unpack(fast.packed)
    assert u.pairs.shape[0] == len(fast.pairs) and u.bodies.shape[0] == len(fast.bodies) - 1
    with pytest.raises(ValueError, match="not a packed collision scene"):
        ref.unpack(np.zeros(40))
    with pytest.raises(ValueError, match="wrong length"):
        ref.unpack(np.concatenate([fast.packed, [0.0]]))
