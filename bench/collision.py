"""Collision checking: parolkit.collision against python-fcl on the same shapes, in one run.

The scene: the stock arm's model (base box, six link capsules), the table plane, a box
("monitor") and a cylinder ("post") beside the arm, a pen tool (capsule flange -> TCP) and a
held sphere: 47 pairs, 23 of them self pairs (the arm's 13, the pen's and the sphere's against
the arm) and 24 body-zone pairs.  Measured:

* one pose: ``Scene.check(q)`` (self + zones + tool + held object: the closest pair of each
  category and the worst pair against its margin, a Verdict) and the module function
  ``check(q, zones, tool)`` (the same through its one-entry scene cache), on random in-limit
  joint vectors; for information the raw kernel call and the numpy reference;
* a 600-sample plan (a joint move from standby, 6 s at 100 Hz): ``check_path`` swept (every
  pose on the segments between samples, not only the samples) and per sample;
* python-fcl on the same shapes through its fastest public path: the collision objects built
  once (capsules, spheres, boxes, cylinders, the table as a Halfspace for collide and a 4 m box
  for distance: FCL's distance crashes on a Halfspace), per pose the moving objects' transforms
  updated (``setTransform``) and ``fcl.distance`` called on each of the same pairs (what the
  verdict needs: every distance), or ``fcl.collide`` on each (contact only, less than our
  verdict says).  Two FCL figures: the queries alone, with the transforms computed beforehand
  (the floor of any FCL-based check), and with each pose's link frames computed by parolkit's
  FK (``fk_frames``) and turned into transforms, as a user's check would.  For the plan, FCL
  checks the 600 samples only (it has no sweep between them).

Caches: both sides build their objects once, as a user keeps them (our ``Scene``, FCL's
collision objects); neither keeps anything from one pose to the next (every call computes the
frames and every pair), and the poses are all different, so nothing is served from a cache.

Figures are medians of CPU time per call (``time.process_time``; loops long enough that the
clock's own cost does not count), ours and FCL's measured in alternating rounds so both see
the same load; ratio = FCL / ours (how many times faster parolkit is).  One-time costs
(imports, building the scene and FCL's objects) are printed apart.  Targets (issue 25): one
pose check <= 10 us, a 600-sample plan <= 2 ms; the script says whether they are met
(benchmarks print, they never fail on timing).

Usage: ``python bench/collision.py [--poses N] [--rounds N]``
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np

from parolkit.collision._geometry import frame_with_z


def _per_call_us(fn, items, min_s: float = 0.002) -> float:
    """CPU time per call (us) of ``fn(item)`` over ``items``, repeated until >= ``min_s``."""
    clock = time.process_time
    n = 0
    t0 = clock()
    while True:
        for it in items:
            fn(it)
        n += len(items)
        t = clock() - t0
        if t >= min_s:
            return t / n * 1e6


def _rounds(fns: dict, items: dict, rounds: int) -> dict:
    """Median per-call time (us) of each function over ``rounds`` alternating rounds."""
    out: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            out[name].append(_per_call_us(fn, items[name]))
    return {k: statistics.median(v) for k, v in out.items()}


class FclScene:
    """The scene's shapes as FCL objects, in metres, and the same pair list."""

    def __init__(self, scene, fcl) -> None:
        from parolkit.collision import _reference as ref

        self.fcl = fcl
        u = scene._u
        self.u = u
        self.frames = u.body_frame
        self.local = u.bodies[:, 1:7].reshape(-1, 2, 3)
        rad = u.bodies[:, 7]
        self.length = np.linalg.norm(self.local[:, 1] - self.local[:, 0], axis=1)
        self.caps = [fcl.CollisionObject(fcl.Capsule(r, ln) if ln > 1e-12 else fcl.Sphere(r))
                     for r, ln in zip(rad, self.length)]
        eye = np.eye(3)
        self.col, self.dist = [], []
        for st in u.statics:
            kind, c, rot, e = int(st[0]), st[1:4], st[4:13].reshape(3, 3), st[13:16]
            if kind == ref.PLANE:
                self.col.append(fcl.CollisionObject(fcl.Halfspace(e, float(e @ c)), fcl.Transform(eye, np.zeros(3))))
                foot = e * float(e @ c)
                big = fcl.Box(4.0, 4.0, 4.0)  # its top face on the plane
                self.dist.append(fcl.CollisionObject(big, fcl.Transform(frame_with_z(e), foot - e * 2.0)))
            elif kind == ref.BOX:
                o = fcl.CollisionObject(fcl.Box(*(2 * e)), fcl.Transform(np.ascontiguousarray(rot), c.copy()))
                self.col.append(o)
                self.dist.append(o)
            else:
                cyl = fcl.Cylinder(e[0], 2 * e[1])
                o = fcl.CollisionObject(cyl, fcl.Transform(np.ascontiguousarray(rot), c.copy()))
                self.col.append(o)
                self.dist.append(o)
        self.pairs_dist = []
        self.pairs_col = []
        for kind, i, j in zip(u.kind, u.pi, u.pj):
            if kind == ref.CAP_CAP:
                self.pairs_dist.append((self.caps[i], self.caps[j]))
                self.pairs_col.append((self.caps[i], self.caps[j]))
            else:
                self.pairs_dist.append((self.caps[i], self.dist[j]))
                self.pairs_col.append((self.caps[i], self.col[j]))

    def transforms(self, frames_4x4: np.ndarray) -> list:
        """Each moving object's Transform for one pose's frames (base, DH 1..5, flange), metres."""
        fcl = self.fcl
        out = []
        for k in range(len(self.caps)):
            f = frames_4x4[self.frames[k]]
            a = f[:3, :3] @ self.local[k, 0] + f[:3, 3]
            b = f[:3, :3] @ self.local[k, 1] + f[:3, 3]
            if self.length[k] > 1e-12:
                out.append(fcl.Transform(frame_with_z(b - a), 0.5 * (a + b)))
            else:
                out.append(fcl.Transform(np.eye(3), a))
        return out

    def distances(self, tfs: list) -> float:
        fcl = self.fcl
        for obj, tf in zip(self.caps, tfs):
            obj.setTransform(tf)
        best = math.inf
        req = fcl.DistanceRequest()
        for o1, o2 in self.pairs_dist:
            best = min(best, fcl.distance(o1, o2, req, fcl.DistanceResult()))
        return best

    def collides(self, tfs: list) -> bool:
        fcl = self.fcl
        for obj, tf in zip(self.caps, tfs):
            obj.setTransform(tf)
        req = fcl.CollisionRequest()
        hit = False
        for o1, o2 in self.pairs_col:
            hit |= bool(fcl.collide(o1, o2, req, fcl.CollisionResult()))
        return hit


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=2000, help="random joint vectors (default 2000)")
    ap.add_argument("--rounds", type=int, default=15, help="alternating measurement rounds (default 15)")
    args = ap.parse_args()

    load = os.getloadavg()
    print(f"machine: {os.cpu_count()} CPUs, load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}")
    t0 = time.perf_counter()
    from parolkit.collision import (
        TABLE_ZONE,
        BoxZone,
        CollisionModel,
        CylinderZone,
        Scene,
        Sphere,
        ToolShape,
        check,
        kernel_name,
    )
    from parolkit.collision import _reference as ref
    from parolkit.kinematics import fk_frames
    from parolkit.robot import PAROL6

    t_import = time.perf_counter() - t0
    print(f"import parolkit.collision: {t_import * 1e3:.0f} ms (numpy included); kernel: {kernel_name()}")

    zones = (TABLE_ZONE,
             BoxZone("monitor", center=(250, -300, 200), size=(400, 60, 300), rpy=(0, 0, 20), margin=10),
             CylinderZone("post", center=(-150, 280, 200), axis=(0, 0, 1), radius=25, height=400, margin=10))
    pen = ToolShape("pen", 8, end=(0, 0, 120))
    model = CollisionModel()
    t0 = time.perf_counter()
    model.attach(Sphere(20), (0, 0, 140, 0, 0, 0), name="part")
    scene = Scene(model, zones, pen)
    t_scene = time.perf_counter() - t0
    t0 = time.perf_counter()
    Scene(model, zones, pen)
    t_scene_warm = time.perf_counter() - t0
    n_self = sum(p.kind.value == "self" for p in scene.pairs)
    print(f"scene: {len(scene.bodies)} bodies, {len(zones)} zones, {len(scene.pairs)} pairs ({n_self} self); "
          f"built in {t_scene * 1e3:.0f} ms cold (the self pairs of the tool and the held sphere sampled over "
          f"20,064 poses), {t_scene_warm * 1e3:.1f} ms again (cached)")

    rng = np.random.default_rng(0)
    lim = np.radians(PAROL6.safe_limits_deg)
    qs = rng.uniform(lim[:, 0], lim[:, 1], size=(args.poses, 6))
    q_lists = [q.tolist() for q in qs]
    verdicts = [scene.check(q) for q in q_lists]
    clear = sum(v.clear for v in verdicts)
    print(f"{args.poses} random in-limit poses: {clear} clear, {args.poses - clear} within a margin "
          f"(self-collisions, zones, the table)")

    try:
        import fcl
    except ImportError:
        fcl = None
        print("python-fcl is not installed (pip install -e '.[dev]'): parolkit's figures only")

    ref_scene = Scene(model, zones, pen)
    ref_scene._kernel = None
    fns = {
        "check": scene.check,
        "check (function)": lambda q: check(q, zones, pen, model=model),
    }
    items = {"check": q_lists, "check (function)": q_lists}
    if scene._kernel is not None:
        packed, kc = scene.packed, scene._kernel.check
        fns["kernel"] = lambda q: kc(packed, q)
        items["kernel"] = q_lists
    f = None
    if fcl is not None:
        f = FclScene(scene, fcl)
        t0 = time.perf_counter()
        FclScene(scene, fcl)
        t_fcl_build = time.perf_counter() - t0
        frames = [np.asarray(fk_frames(np.degrees(q))) for q in qs]
        tfs = [f.transforms(fr) for fr in frames]
        fns["fcl distance"] = f.distances
        fns["fcl collide"] = f.collides
        fns["fcl distance + FK"] = lambda q: f.distances(f.transforms(fk_frames(np.degrees(q))))
        items["fcl distance"] = tfs
        items["fcl collide"] = tfs
        items["fcl distance + FK"] = list(qs)
        print(f"fcl objects built in {t_fcl_build * 1e3:.1f} ms")
    res = _rounds(fns, items, args.rounds)
    t_ref = _per_call_us(lambda q: ref.check(ref_scene._u, np.asarray(q)), q_lists[:50], min_s=0.2)

    print("\n== one pose (self + 3 zones + tool + held sphere), median CPU time per call ==")
    print(f"Scene.check(q) -> Verdict          {res['check']:8.2f} us")
    print(f"check(q, zones, tool) (function)   {res['check (function)']:8.2f} us")
    if "kernel" in res:
        print(f"  the C kernel alone               {res['kernel']:8.2f} us")
    print(f"  numpy reference (no C kernel)    {t_ref:8.1f} us")
    if f is not None:
        print(f"python-fcl, fcl.distance x {len(f.pairs_dist)} pairs   {res['fcl distance']:8.1f} us   "
              f"ratio {res['fcl distance'] / res['check']:6.1f}x")
        print(f"python-fcl, fcl.collide x {len(f.pairs_col)} pairs    {res['fcl collide']:8.1f} us   "
              f"ratio {res['fcl collide'] / res['check']:6.1f}x   (contact only)")
        print(f"python-fcl, distance + FK/transforms{res['fcl distance + FK']:7.1f} us   "
              f"ratio {res['fcl distance + FK'] / res['check']:6.1f}x   (what a user's FCL check costs)")

    # ---- a 600-sample plan ----
    start = np.radians(PAROL6.standby_deg)
    goals = rng.uniform(lim[:, 0], lim[:, 1], size=(400, 6))
    s = np.linspace(0.0, 1.0, 600)
    blend = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5  # a quintic time law
    plans_clear, plans_hit = [], []
    for g in goals:
        plan = np.ascontiguousarray(start + blend[:, None] * (g - start))
        (plans_clear if scene.check_path(plan).clear else plans_hit).append(plan)
        if len(plans_clear) >= 40 and len(plans_hit) >= 40:
            break
    plans_clear, plans_hit = plans_clear[:40], plans_hit[:40]
    evals = [scene.check_path(p).evaluations for p in plans_clear]
    fns2 = {
        "swept": lambda p: scene.check_path(p),
        "samples": lambda p: scene.check_path(p, swept=False),
        "swept hit": lambda p: scene.check_path(p),
    }
    items2 = {"swept": plans_clear, "samples": plans_clear, "swept hit": plans_hit}
    if f is not None:
        plan_tfs = [[f.transforms(fr) for fr in (fk_frames(np.degrees(q)) for q in p)] for p in plans_clear[:3]]
        fns2["fcl collide 600"] = lambda tl: [f.collides(t) for t in tl]
        fns2["fcl distance 600"] = lambda tl: [f.distances(t) for t in tl]
        items2["fcl collide 600"] = plan_tfs
        items2["fcl distance 600"] = plan_tfs
    res2 = _rounds(fns2, items2, max(3, args.rounds // 3))
    print("\n== a 600-sample plan (a quintic joint move from standby), median CPU time per plan ==")
    print(f"check_path, swept (samples and between)  {res2['swept'] / 1e3:8.3f} ms   "
          f"({len(plans_clear)} clear plans, {statistics.median(evals):.0f} pose evaluations median)")
    print(f"check_path, samples only                 {res2['samples'] / 1e3:8.3f} ms")
    print(f"check_path, swept, plans that collide    {res2['swept hit'] / 1e3:8.3f} ms   (stops at the first)")
    if f is not None:
        print(f"python-fcl collide, 600 samples          {res2['fcl collide 600'] / 1e3:8.2f} ms   "
              f"ratio {res2['fcl collide 600'] / res2['swept']:6.1f}x vs swept, "
              f"{res2['fcl collide 600'] / res2['samples']:6.1f}x vs samples only (transforms given)")
        print(f"python-fcl distance, 600 samples         {res2['fcl distance 600'] / 1e3:8.2f} ms   "
              f"ratio {res2['fcl distance 600'] / res2['swept']:6.1f}x vs swept")

    print("\n== targets (issue 25) ==")
    ok1 = res["check"] <= 10.0
    ok2 = res2["swept"] <= 2000.0
    print(f"one pose check <= 10 us: {res['check']:.2f} us ({'met' if ok1 else 'NOT met'})")
    print(f"600-sample plan <= 2 ms: {res2['swept'] / 1e3:.3f} ms swept ({'met' if ok2 else 'NOT met'})")
    load = os.getloadavg()
    print(f"(load average at the end: {load[0]:.1f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
