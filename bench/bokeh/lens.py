#!/usr/bin/env python3
"""lens.py: night lights through a traced lens (issue 27's real-lens
target), lensray's defaults against camera paths alone.

    python bench/bokeh/lens.py [--scene scenes/night-lens.json] [--rounds 3]

No analytic reference exists for a traced lens, so the reference is the
defaults (light side on) at --ref-spp with another seed (render.seed 7;
the timed renders use the scene's seed, so their light paths are not a
prefix of the reference's).  It is checked against camera paths alone at
--check-spp (every sample traced), rendered with --check-seeds seeds (7,
8, ...): per disc, the energy ratio of their mean to the reference, its
standard error from the spread between seeds, and the shape (relMSE
inside the disc's box, next to the camera's own noise there, which is
what an unbiased camera image must show).

The discs are the 8-connected sets of the reference's non-zero pixels (the
background is black), as boxes padded by 2 pixels.

Then each renderer, the defaults and `render.light=false`, renders at
spp 16, 64, 256, ... until relMSE <= --target / 4; each step is timed
--rounds times (CPU seconds from --stats, planning included) and the
median is kept.  Time to --target is interpolated log-log between the
steps that bracket it (run.py's time_to).

relMSE is run.py's: mean over pixels and channels of (x - r)^2 / (r^2 +
0.01).
"""
import argparse
import hashlib
import json
import os
import statistics
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests", "lenses"))
from exr import read_exr  # noqa: E402
sys.path.insert(0, HERE)
from run import lensray_render, relmse, time_to  # noqa: E402


def render(args, spp, out, extra):
    """run.py's lensray_render: the image and the render's CPU seconds."""
    img, _, cpu = lensray_render(args, extra, spp, out)
    return img, cpu


def disc_boxes(ref):
    lit = ref.sum(axis=-1) > 0
    h, w = lit.shape
    seen = np.zeros_like(lit)
    boxes = []
    for y0 in range(h):
        for x0 in range(w):
            if not lit[y0, x0] or seen[y0, x0]:
                continue
            stack = [(y0, x0)]
            seen[y0, x0] = True
            ys, xs = [], []
            while stack:
                y, x = stack.pop()
                ys.append(y), xs.append(x)
                for dy in (-1, 0, 1):
                    for dx in (-1, 0, 1):
                        v, u = y + dy, x + dx
                        if 0 <= v < h and 0 <= u < w and lit[v, u] and not seen[v, u]:
                            seen[v, u] = True
                            stack.append((v, u))
            if len(ys) >= 4:
                boxes.append([max(min(xs) - 2, 0), min(max(xs) + 3, w),
                              max(min(ys) - 2, 0), min(max(ys) + 3, h)])
    return boxes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lensray", default="build/lensray")
    ap.add_argument("--scene", default="scenes/night-lens.json")
    ap.add_argument("--work", default="build/bench/bokeh-lens")
    ap.add_argument("--target", type=float, default=1e-3)
    ap.add_argument("--ref-spp", type=int, default=16384)
    ap.add_argument("--check-spp", type=int, default=2048)
    ap.add_argument("--check-seeds", type=int, default=1,
                    help="camera-alone check renders, each with its own seed")
    ap.add_argument("--max-spp", type=int, default=4096)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--set", action="append", default=[],
                    help="extra --set for every render (e.g. camera.focus_distance=0.5)")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    extra = sum((["--set", s] for s in args.set), [])
    seed = ["--set", "render.seed=7"]

    with open(args.lensray, "rb") as fh:
        key = hashlib.sha256(open(args.scene, "rb").read() + fh.read() +
                             repr((args.set, args.ref_spp, args.check_spp)).encode()
                             ).hexdigest()[:16]
    ref_npy = os.path.join(args.work, "ref-%s.npy" % key)
    cam_npy = os.path.join(args.work, "cam-%s.npy" % key)
    if not os.path.exists(ref_npy):
        ref, t = render(args, args.ref_spp, os.path.join(args.work, "ref.exr"),
                        extra + seed)
        np.save(ref_npy, ref)
        print("reference: defaults at %d spp, seed 7: %.1f CPU s" % (args.ref_spp, t))
    ref = np.load(ref_npy)
    boxes = disc_boxes(ref)
    # The check: camera paths alone, every sample traced, at --check-spp
    # with each of --check-seeds seeds (7, 8, ...).  Their mean is the
    # camera's estimate; the spread between seeds gives each disc's
    # standard error, so a difference can be read against the camera's
    # own noise.
    full = ["--set", "render.light=false", "--set", "render.plan=false",
            "--set", "render.adaptive=false"]
    cams = []
    for k in range(args.check_seeds):
        npy = cam_npy if k == 0 else cam_npy.replace(".npy", "-s%d.npy" % (7 + k))
        if not os.path.exists(npy):
            img, t = render(args, args.check_spp, os.path.join(args.work, "cam.exr"),
                            extra + full + ["--set", "render.seed=%d" % (7 + k)])
            np.save(npy, img)
            print("check: camera alone, every sample traced, %d spp, seed %d: %.1f CPU s"
                  % (args.check_spp, 7 + k, t), flush=True)
        cams.append(np.load(npy))
    cam = sum(cams) / len(cams)

    print("%s %s: %d x %d, %d discs, reference mean %.6g, camera/reference mean %+.4f"
          % (args.scene, " ".join(args.set), ref.shape[1], ref.shape[0], len(boxes),
             ref.mean(), cam.mean() / ref.mean() - 1))
    print("check: %d x %d spp of camera paths alone" % (len(cams), args.check_spp))
    print("%-4s %-20s %6s %10s %9s %12s" % ("disc", "box x0 x1 y0 y1", "px", "energy",
                                             "std err", "relMSE in box"))
    worst = 0.0
    for i, (x0, x1, y0, y1) in enumerate(boxes):
        r, c = ref[y0:y1, x0:x1], cam[y0:y1, x0:x1]
        e = c.sum() / r.sum() - 1
        per = [k[y0:y1, x0:x1].sum() / r.sum() - 1 for k in cams]
        se = statistics.stdev(per) / len(per) ** 0.5 if len(per) > 1 else float("nan")
        worst = max(worst, abs(e))
        lit = int((r.sum(axis=-1) > 0).sum())
        print("%-4d %-20s %6d %+10.4f %9.4f %12.3e" % (i, "%d %d %d %d" % (x0, x1, y0, y1),
                                                       lit, e, se, relmse(c, r)))
    print("worst disc energy, camera alone / reference - 1: %.4f" % worst)

    results = {}
    for name, more in (("defaults", []), ("camera", ["--set", "render.light=false"])):
        rows = []
        spp = 16
        while spp <= args.max_spp:
            out = os.path.join(args.work, "%s-%d.exr" % (name, spp))
            times = []
            for _ in range(args.rounds):
                img, t = render(args, spp, out, extra + more)
                times.append(t)
            m = {"spp": spp, "cpu": statistics.median(times), "cpu_all": times,
                 "relmse": relmse(img, ref), "mean": img.mean() / ref.mean() - 1}
            rows.append(m)
            print("%-9s %6d spp  CPU s %7.3f (%s)  relMSE %.3e  mean %+.4f" % (
                name, spp, m["cpu"], " ".join("%.3f" % x for x in times),
                m["relmse"], m["mean"]), flush=True)
            if m["relmse"] <= args.target / 4:
                break
            spp *= 4
        results[name] = rows
    td, hd = time_to(results["defaults"], args.target, "cpu")
    tc, hc = time_to(results["camera"], args.target, "cpu")
    print("time to relMSE %g (CPU s): defaults %s%.3g, camera alone %s%.3g: %.1fx"
          % (args.target, hd, td, hc, tc, tc / td))
    with open(os.path.join(args.work, "results.json"), "w") as fh:
        json.dump({"boxes": boxes, "results": results}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
