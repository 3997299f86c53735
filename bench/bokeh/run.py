#!/usr/bin/env python3
"""run.py: night lights through the thin lens (issue 27), every renderer
against the exact reference of bench/bokeh/reference.py.

For each renderer, renders scenes/night.json at spp 16, 64, 256, ... up to
--max-spp (a renderer stops after its first step at or below relMSE
--target / 4) and measures each image against the reference:

  relMSE     mean over pixels and channels of (x - r)^2 / (r^2 + 0.01), as
             bench/accuracy/imgdiff.c and docs/accuracy.md
  mean       image mean / reference mean - 1
  disc       per light, the sum over its disc's box (reference.py's boxes,
             which hold every pixel the light reaches) / the reference's - 1;
             "worst" is the largest in magnitude

Time to the target relMSE: interpolated log-log between the steps that
bracket it, or extrapolated from the last step as 1/spp (relMSE x spp
constant) when no step reached it ("~" in the table); flagged "stalls"
when the last step's relMSE fell by less than half the ratio of its
samples (an unbiased estimate's falls by the whole ratio: this one is
converging to something else, and the extrapolation means nothing).

Renderers:
  lensray-default   the scene as it is (plan, adaptive sampling and the
                    light side on: what a user gets)
  lensray-camera    the defaults with --set render.light=false: camera
                    paths only, plan and adaptive sampling on
  lensray-full      camera paths only, every sample traced: --set
                    render.plan=false --set render.adaptive=false --set
                    render.light=false
  mitsuba-path      Mitsuba 3 `path` (max_depth 2) with the `thinlens` sensor
  mitsuba-ptracer   Mitsuba 3 `ptracer` (light paths to the camera)

Times are of the render alone, in CPU seconds (all threads; the time to
the target is taken from these, since the machine is shared and wall time
counts other people's work) and in wall seconds: lensray's --stats
"cpu_seconds" and "seconds" (planning included, not loading or writing),
and for Mitsuba its process's CPU time and the wall time of its
mi.render calls (after an untimed warm-up at each pass size, in passes of at most
--pass-spp samples, each with its own seed, averaged).  lensray and
Mitsuba both use every core.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests", "lenses"))
from exr import read_exr  # noqa: E402  (tests/lenses/exr.py)


def relmse(x, r):
    return float(np.mean((x - r) ** 2 / (r * r + 0.01)))


def measures(img, ref, discs):
    d = []
    for disc in discs:
        x0, x1, y0, y1 = disc["box"]
        d.append(img[y0:y1, x0:x1].sum() / ref[y0:y1, x0:x1].sum() - 1.0)
    d = np.array(d)
    return {"relmse": relmse(img, ref), "mean": img.mean() / ref.mean() - 1.0,
            "disc_worst": float(d[np.argmax(np.abs(d))]),
            "disc_rms": float(math.sqrt(np.mean(d * d))),
            "discs": d.tolist()}


# ---- lensray -------------------------------------------------------------

def lensray_render(args, extra, spp, out):
    cmd = [args.lensray, "render", args.scene, "-o", out, "-q", "--stats",
           "--set", "render.spp=%d" % spp] + extra
    p = subprocess.run(cmd, check=True, capture_output=True, text=True)
    stats = None
    for line in (p.stdout + p.stderr).splitlines():
        if line.startswith("{") and '"seconds"' in line:
            stats = json.loads(line)
    if stats is None:
        raise RuntimeError("no --stats line from %s" % " ".join(cmd))
    ch = read_exr(out)
    img = np.stack([ch["R"], ch["G"], ch["B"]], axis=-1)
    return img, stats["seconds"], stats["cpu_seconds"]


# ---- Mitsuba 3 -----------------------------------------------------------

def mitsuba_scene(mi, sc, integrator, spp, seed):
    """scenes/night.json for Mitsuba.  Its thinlens matches lensray's
    (lib/camera/camera_thinlens.c): 'fov' with fov_axis 'y' is the vertical field
    of view, the plane in focus is perpendicular to the view axis at
    focus_distance, the aperture a disk of aperture_radius sampled
    uniformly by area, every ray of weight 1; the 'box' filter counts a
    sample in its own pixel only, like lensray's box.  Each light is an
    'area' emitter on a sphere with the same RGB radiance ('rgb' values,
    which an rgb variant takes as they are) and a black BSDF, since
    lensray's emitters reflect nothing (materials hold only emission)."""
    cam = sc["camera"]
    rend = sc["render"]
    T = mi.ScalarTransform4f
    # lensray's max_depth counts bounces after the first hit; Mitsuba's
    # counts path segments (docs/path-tracing.md): this + 2.  Without one
    # (night.json) light seen directly is all there is: 2.
    depth = int(rend["max_depth"]) + 2 if "max_depth" in rend else 2
    integ = {"type": integrator, "max_depth": depth}
    if integrator == "ptracer":
        integ = {"type": "ptracer", "max_depth": depth, "hide_emitters": False}
    scene = {
        "type": "scene",
        "integrator": integ,
        "sensor": {
            "type": "thinlens", "fov": float(cam["fov"]), "fov_axis": "y",
            "aperture_radius": float(cam["aperture_radius"]),
            "focus_distance": float(cam["focus_distance"]),
            "near_clip": 1e-3, "far_clip": 1e4,
            "to_world": T().look_at(origin=cam["position"], target=cam["look_at"],
                                    up=cam.get("up", [0, 1, 0])),
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
            "film": {"type": "hdrfilm", "width": rend["width"],
                     "height": rend["height"], "rfilter": {"type": "box"},
                     "pixel_format": "rgb", "component_format": "float32",
                     "sample_border": False},
        },
    }
    for i, o in enumerate(sc["objects"]):
        if o["type"] == "plane":
            # sparkles.json's floor: a rectangle (Mitsuba's spans [-1, 1]^2
            # at z = 0 facing +z; turned to face +y, which is the only
            # normal this handles) of a rough conductor, lensray's
            # "reflect" x GGX (roughconductor, material "none", which
            # lib/integrator/bsdf.h follows).
            assert o["normal"] == [0, 1, 0], "planes facing +y only"
            m = sc["materials"][o["material"]]
            w, h = o["size"]
            scene["plane%02d" % i] = {
                "type": "rectangle",
                "to_world": T().translate([float(v) for v in o["point"]])
                @ T().rotate([1, 0, 0], -90) @ T().scale([w / 2, h / 2, 1]),
                "bsdf": {"type": "roughconductor", "distribution": "ggx",
                         "alpha": float(m["roughness"]), "material": "none",
                         "specular_reflectance": {"type": "rgb", "value": [
                             float(v) for v in m["reflect"]]}}}
            continue
        em = sc["materials"][o["material"]]["emission"]
        em = [float(em)] * 3 if not isinstance(em, list) else [float(v) for v in em]
        scene["light%02d" % i] = {
            "type": "sphere", "center": [float(v) for v in o["center"]],
            "radius": float(o["radius"]),
            "bsdf": {"type": "diffuse",
                     "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
            "emitter": {"type": "area",
                        "radiance": {"type": "rgb", "value": em}}}
    return mi.load_dict(scene)


class Mitsuba:
    def __init__(self, variant, sc, integrator, pass_spp):
        import mitsuba as mi
        mi.set_variant(variant)
        self.mi, self.sc, self.integrator, self.pass_spp = mi, sc, integrator, pass_spp
        self.scenes = {}
        self.seed = 1

    def _scene(self, spp):
        if spp not in self.scenes:
            self.scenes[spp] = mitsuba_scene(self.mi, self.sc, self.integrator, spp, 0)
            # Warm-up, untimed: the llvm variant compiles a kernel for each
            # new sample count (the count is part of the kernel).
            self.mi.render(self.scenes[spp], spp=spp, seed=0)
        return self.scenes[spp]

    def render(self, spp):
        mi = self.mi
        passes = max(1, spp // self.pass_spp)
        per = spp // passes
        scene = self._scene(per)
        acc, secs, cpu = None, 0.0, 0.0
        for _ in range(passes):
            t, c = time.perf_counter(), time.process_time()
            img = mi.render(scene, spp=per, seed=self.seed)
            a = np.array(img, dtype=np.float64)[..., :3]
            secs += time.perf_counter() - t
            cpu += time.process_time() - c
            self.seed += 1
            acc = a if acc is None else acc + a
        return acc / passes, secs, cpu


# ---- the sweep -----------------------------------------------------------

def time_to(rows, target, key):
    """(seconds, how) to relMSE `target` from a renderer's steps, by their
    times rows[i][key]."""
    for a, b in zip(rows, rows[1:]):
        if a["relmse"] > target >= b["relmse"]:
            f = math.log(a["relmse"] / target) / math.log(a["relmse"] / b["relmse"])
            return math.exp(math.log(a[key]) + f * math.log(b[key] / a[key])), ""
    if rows[0]["relmse"] <= target:
        return rows[0][key] * rows[0]["relmse"] / target, "<="
    last = rows[-1]
    how = "~"
    if len(rows) >= 2:
        gain = rows[-2]["relmse"] / last["relmse"]
        ratio = last["spp"] / rows[-2]["spp"]
        # Unbiased, relMSE falls as 1/spp; a step that bought less than
        # half of that is converging to something else.
        if gain < ratio / 2:
            how = "stalls ~"
    return last[key] * last["relmse"] / target, how


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lensray", default="build/lensray")
    ap.add_argument("--scene", default="scenes/night.json")
    ap.add_argument("--ref", required=True, help="reference.py's .npy")
    ap.add_argument("--discs", required=True, help="reference.py's disc boxes")
    ap.add_argument("--work", default="build/bench/bokeh")
    ap.add_argument("--target", type=float, default=1e-3)
    ap.add_argument("--min-spp", type=int, default=16)
    ap.add_argument("--max-spp", type=int, default=4096)
    ap.add_argument("--pass-spp", type=int, default=256,
                    help="Mitsuba's samples a pass (memory of the llvm variant)")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--only", default="", help="comma-separated renderer names")
    ap.add_argument("--lensray-set", action="append", default=[],
                    help="extra --set for both lensray runs (e.g. render.integrator=path)")
    args = ap.parse_args()

    with open(args.scene) as fh:
        sc = json.load(fh)
    ref = np.load(args.ref)
    with open(args.discs) as fh:
        discs = json.load(fh)
    os.makedirs(args.work, exist_ok=True)
    extra = sum((["--set", s] for s in args.lensray_set), [])

    camera = ["--set", "render.light=false"]
    full = camera + ["--set", "render.plan=false", "--set", "render.adaptive=false"]
    # name -> a function that sets the renderer up and returns
    # render(spp, exr_path) -> (image, seconds).
    renderers = [
        ("lensray-default",
         lambda: lambda spp, out: lensray_render(args, extra, spp, out)),
        ("lensray-camera",
         lambda: lambda spp, out: lensray_render(args, extra + camera, spp, out)),
        ("lensray-full",
         lambda: lambda spp, out: lensray_render(args, extra + full, spp, out)),
    ]
    variant = args.variant
    try:
        import mitsuba as mi
        if variant not in mi.variants() or (
                variant.startswith("llvm") and not os.environ.get("DRJIT_LIBLLVM_PATH")):
            variant = "scalar_rgb"

        def mitsuba(integ):
            m = Mitsuba(variant, sc, integ, args.pass_spp)
            return lambda spp, out: m.render(spp)
        for integ in ("path", "ptracer"):
            renderers.append(("mitsuba-" + integ, lambda integ=integ: mitsuba(integ)))
    except ImportError:
        print("bokeh: Mitsuba is not importable; its rows are skipped", file=sys.stderr)
    if args.only:
        keep = args.only.split(",")
        renderers = [r for r in renderers if r[0] in keep]

    print("bokeh: %s, %d x %d, %d lights, reference mean %.6g; Mitsuba variant %s"
          % (args.scene, ref.shape[1], ref.shape[0], len(discs), ref.mean(), variant))
    print("%-16s %6s %8s %8s %10s %9s %10s %9s" % (
        "renderer", "spp", "cpu s", "wall s", "relMSE", "mean", "disc worst", "disc rms"))
    results = {}
    for name, make in renderers:
        render = make()
        rows = []
        spp = args.min_spp
        while spp <= args.max_spp:
            img, wall, cpu = render(spp, os.path.join(args.work, "%s-%d.exr" % (name, spp)))
            m = measures(img, ref, discs)
            m.update({"spp": spp, "wall": wall, "cpu": cpu})
            rows.append(m)
            print("%-16s %6d %8.3f %8.3f %10.3e %+9.4f %+10.4f %9.4f" % (
                name, spp, cpu, wall, m["relmse"], m["mean"], m["disc_worst"],
                m["disc_rms"]), flush=True)
            if m["relmse"] <= args.target / 4:
                break
            spp *= 4
        results[name] = rows

    print()
    print("time to relMSE %g in CPU and wall seconds (~: extrapolated as 1/spp "
          "from the last step), and at the last step: relMSE, mean error, worst "
          "and rms disc energy error" % args.target)
    print("%-16s %16s %16s %6s %10s %9s %10s %9s" % (
        "renderer", "CPU s to target", "wall s to target", "spp", "relMSE", "mean",
        "disc worst", "disc rms"))
    for name, rows in results.items():
        tc, how = time_to(rows, args.target, "cpu")
        tw, _ = time_to(rows, args.target, "wall")
        last = rows[-1]
        print("%-16s %16s %16s %6d %10.3e %+9.4f %+10.4f %9.4f" % (
            name, ("%s %.3g" % (how, tc)).strip(), ("%s %.3g" % (how, tw)).strip(),
            last["spp"], last["relmse"], last["mean"], last["disc_worst"],
            last["disc_rms"]))
    with open(os.path.join(args.work, "results.json"), "w") as fh:
        json.dump(results, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
