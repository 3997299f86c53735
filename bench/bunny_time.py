#!/usr/bin/env python3
"""bunny_time.py: time to a relative MSE on the bench scene (three bunnies
through the thin lens, scenes/bench.json), lensray against Mitsuba 3's
samplers (issue 30: 1e-5 at least 8x sooner than Mitsuba's best).

Each renderer climbs a ladder of sample counts (x4 a step, from
--min-spp) until its error is at most --target / 2, and its time to the
target is interpolated log-log between the steps around it.

Error.  relMSE as bench/accuracy/imgdiff.c defines it: the mean over
pixels and channels of (x - r)^2 / (r^2 + 0.01).  At 1e-5 the
reference's own noise matters, so each reference is two independent
halves A and B (other seeds) and r = (A + B) / 2; the noise it adds to a
measured relMSE is relMSE(A, B) / 4 (independent noise adds, and A - B
holds twice the variance of each half, r a half of it), which is
subtracted: the table's relMSE is that "corrected" value, the raw one
beside it.

References.  lensray is measured against its own full simulation (plan
and adaptive sampling off, Sobol), Mitsuba against its own (`ldsampler`
unless --mi-ref-sampler), so that neither pays for the other's small
differences (the ground is a plane here and a rectangle there, a bunny's
normals are averaged with other weights: bench/README.md).  The two
references are compared too, with Mitsuba given lensray's normals
(bench/mitsuba_bench.py --same-normals): that line says how far apart the
two converged pictures are.

Times: CPU seconds of the render alone (lensray's --stats cpu_seconds,
which leaves out loading and writing; Mitsuba's process time around
mi.render, after an untimed warm-up at each pass size), all threads; the
machine is shared, so wall time would count other people's work.  Both
use every core.  Mitsuba renders in passes of at most --pass-spp samples
(the llvm variant holds a pass's every sample in memory) with their own
seeds, averaged; the `scalar_rgb` variant (--mi-variants) takes any count
in one pass, so its stratified samplers stratify over every sample.
"""
import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "lenses"))
sys.path.insert(0, HERE)
from exr import read_exr  # noqa: E402  (tests/lenses/exr.py)
import mitsuba_bench  # noqa: E402


def relmse(x, r):
    return float(np.mean((x - r) ** 2 / (r * r + 0.01)))


def time_to(rows, target):
    """CPU seconds to relMSE `target`, log-log between the two steps
    around it; "~" when extrapolated from the last step as 1/spp."""
    for a, b in zip(rows, rows[1:]):
        if a["relmse"] > target >= b["relmse"] > 0:
            f = math.log(a["relmse"] / target) / math.log(a["relmse"] / b["relmse"])
            return math.exp(math.log(a["cpu"]) + f * math.log(b["cpu"] / a["cpu"])), ""
    last = rows[-1]
    if last["relmse"] <= target:
        return last["cpu"] * last["relmse"] / target, "<="
    return last["cpu"] * last["relmse"] / target, "~"


class Lensray:
    def __init__(self, args, extra):
        self.args, self.extra = args, extra

    def render(self, spp, seed):
        out = os.path.join(self.args.work, "lensray.exr")
        cmd = [self.args.lensray, "render", self.args.scene, "-o", out, "-q",
               "--stats", "--set", "render.spp=%d" % spp,
               "--set", "render.seed=%d" % seed] + self.extra
        p = subprocess.run(cmd, check=True, capture_output=True, text=True)
        stats = None
        for line in (p.stdout + p.stderr).splitlines():
            if line.startswith("{") and '"cpu_seconds"' in line:
                stats = json.loads(line)
        ch = read_exr(out)
        img = np.stack([ch["R"], ch["G"], ch["B"]], axis=-1).astype(np.float64)
        return img, stats["cpu_seconds"]


class Mitsuba:
    def __init__(self, args, variant, sampler, obj):
        import drjit as dr
        import mitsuba as mi
        mi.set_variant(variant)
        self.mi, self.dr, self.args = mi, dr, args
        self.variant, self.sampler, self.obj = variant, sampler, obj
        self.scenes = {}

    def _scene(self, spp):
        if spp not in self.scenes:
            s = mitsuba_bench.build_scene(self.mi, self.obj, 640, 480, spp,
                                          self.sampler, False)
            self._go(s, spp, 0)  # warm-up, untimed: llvm compiles per count
            self.scenes[spp] = s
        return self.scenes[spp]

    def _go(self, scene, spp, seed):
        img = self.mi.render(scene, spp=spp, seed=seed)
        self.dr.eval(img)
        self.dr.sync_thread()
        return img

    def render(self, spp, seed):
        per = spp
        if self.variant.startswith("llvm"):
            per = min(spp, self.args.pass_spp)
        passes = spp // per
        scene = self._scene(per)
        acc, cpu = None, 0.0
        for k in range(passes):
            c = time.process_time()
            img = self._go(scene, per, 1000 * seed + k + 1)
            cpu += time.process_time() - c
            a = np.array(img, dtype=np.float64)[..., :3]
            acc = a if acc is None else acc + a
        return acc / passes, cpu


def digest(*paths):
    """A key for a cached reference: the contents that make it."""
    h = hashlib.sha256()
    for p in paths:
        with open(p, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:12]


def reference(name, r, spp, path):
    """Two halves of spp / 2 at seeds 1 and 2; cached in `path`."""
    if os.path.exists(path):
        z = np.load(path)
        return z["ref"], float(z["floor"])
    a, _ = r.render(spp // 2, 1)
    b, _ = r.render(spp // 2, 2)
    ref = (a + b) / 2
    floor = relmse(a, b) / 4
    np.savez(path, ref=ref, floor=floor)
    print("reference %s: %d spp, its noise in a relMSE %.3e" % (name, spp, floor),
          flush=True)
    return ref, floor


def ladder(name, r, ref, floor, args):
    rows, spp = [], args.min_spp
    while spp <= args.max_spp:
        img, cpu = r.render(spp, 7)
        raw = relmse(img, ref)
        row = {"spp": spp, "cpu": cpu, "raw": raw, "relmse": raw - floor}
        rows.append(row)
        print("%-26s %6d %9.3f %11.3e %11.3e" % (name, spp, cpu, row["relmse"], raw),
              flush=True)
        if row["relmse"] <= args.target / 2:
            break
        spp *= 4
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lensray", default="build/lensray")
    ap.add_argument("--scene", default="scenes/bench.json")
    ap.add_argument("--obj", default="scenes/meshes/bunny.obj")
    ap.add_argument("--work", default="build/bench/bunny-time")
    ap.add_argument("--target", type=float, default=1e-5)
    ap.add_argument("--min-spp", type=int, default=16)
    ap.add_argument("--max-spp", type=int, default=4096)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--mi-ref-spp", type=int, default=4096)
    ap.add_argument("--mi-ref-sampler", default="ldsampler")
    ap.add_argument("--pass-spp", type=int, default=64)
    ap.add_argument("--mi-variants", default="llvm_ad_rgb")
    ap.add_argument("--mi-samplers",
                    default="independent,stratified,multijitter,ldsampler",
                    help="orthogonal rounds a pass's count to a prime's square "
                    "(64 to 121), so its ladder is not the others'")
    ap.add_argument("--lensray-only", action="store_true")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)

    full = ["--set", "render.plan=false", "--set", "render.adaptive=false"]
    ref, floor = reference("lensray", Lensray(args, full), args.ref_spp,
                           os.path.join(args.work, "ref-lensray-%d-%s.npz" % (
                               args.ref_spp, digest(args.lensray, args.scene))))
    print("%-26s %6s %9s %11s %11s" % ("renderer", "spp", "CPU s", "relMSE", "raw"))
    results = {}
    for name, extra in (("lensray defaults", []), ("lensray full", full)):
        results[name] = ladder(name, Lensray(args, extra), ref, floor, args)

    if not args.lensray_only:
        obj = os.path.abspath(args.obj)
        variants = args.mi_variants.split(",")
        mref = Mitsuba(args, variants[0], args.mi_ref_sampler, obj)
        mkey = digest(mitsuba_bench.__file__, obj)
        mpath = os.path.join(args.work, "ref-mitsuba-%s-%d-%s.npz"
                             % (args.mi_ref_sampler, args.mi_ref_spp, mkey))
        mref_img, mfloor = reference("mitsuba", mref, args.mi_ref_spp, mpath)
        # The two converged pictures, Mitsuba with lensray's normals.
        same = os.path.join(args.work, "bunny_lensray_normals.obj")
        mitsuba_bench.write_obj_with_normals(obj, same)
        sref = Mitsuba(args, variants[0], args.mi_ref_sampler, same)
        spath = os.path.join(args.work, "ref-mitsuba-same-normals-%s-%d-%s.npz"
                             % (args.mi_ref_sampler, args.mi_ref_spp, mkey))
        sref_img, sfloor = reference("mitsuba, lensray's normals", sref,
                                     args.mi_ref_spp, spath)
        print("the references apart: relMSE %.3e (Mitsuba's own normals), %.3e "
              "(lensray's), less their noise" % (
                  relmse(mref_img, ref) - mfloor - floor,
                  relmse(sref_img, ref) - sfloor - floor), flush=True)
        for v in variants:
            for s in args.mi_samplers.split(","):
                name = "mitsuba %s %s" % (v.split("_")[0], s)
                results[name] = ladder(name, Mitsuba(args, v, s, obj), mref_img,
                                       mfloor, args)

    print()
    print("time to relMSE %g, CPU seconds (~: extrapolated as 1/spp)" % args.target)
    best_mi = None
    for name, rows in results.items():
        t, how = time_to(rows, args.target)
        print("%-26s %12s" % (name, ("%s %.3g" % (how, t)).strip()))
        if name.startswith("mitsuba") and (best_mi is None or t < best_mi[1]):
            best_mi = (name, t)
    if best_mi:
        t, _ = time_to(results["lensray defaults"], args.target)
        print("lensray defaults against %s: %.2fx sooner" % (best_mi[0], best_mi[1] / t))
    with open(os.path.join(args.work, "results.json"), "w") as fh:
        json.dump(results, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
