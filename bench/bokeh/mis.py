#!/usr/bin/env python3
"""mis.py: the light side joined to the camera by multiple importance
sampling against the split that came before it (issue 27), two lensray
builds on one scene.

    python bench/bokeh/mis.py --old OLD/lensray --new build/lensray \\
        [--scene bench/bokeh/lamps.json] [--spp 16,64,256] [--seeds 6]

bench/bokeh/lamps.json: two lamps a few pixels wide, a few times that
blurred (strategies' ratio rho about 4, where both sides matter), and
one far out of focus, over a grey background (no dark block).  The
reference is --new at --ref-spp with every sample traced (render.plan
and render.adaptive off).  Each build renders with the defaults at each
spp and seeds 1 .. --seeds; printed: the mean relMSE (run.py's) and the
median CPU seconds, and their product's ratio (the efficiency).
"""
import argparse
import os
import statistics
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from run import lensray_render, relmse  # noqa: E402


def render(binary, scene, spp, extra, out):
    args = argparse.Namespace(lensray=binary, scene=scene)
    img, _, cpu = lensray_render(args, extra, spp, out)
    return img, cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True)
    ap.add_argument("--new", required=True)
    ap.add_argument("--scene", default=os.path.join(HERE, "lamps.json"))
    ap.add_argument("--spp", default="16,64,256")
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--ref-spp", type=int, default=16384)
    ap.add_argument("--out", default="build/bench/mis")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    ref, _ = render(a.new, a.scene, a.ref_spp,
                    ["--set", "render.plan=false", "--set",
                     "render.adaptive=false"], os.path.join(a.out, "ref.exr"))
    print("spp  build  relMSE     CPU s   relMSE x CPU s")
    for spp in [int(s) for s in a.spp.split(",")]:
        cost = {}
        for name, binary in (("old", a.old), ("new", a.new)):
            errs, cpus = [], []
            for seed in range(1, a.seeds + 1):
                img, cpu = render(binary, a.scene, spp,
                                  ["--set", "render.seed=%d" % seed],
                                  os.path.join(a.out, name + ".exr"))
                errs.append(relmse(img, ref))
                cpus.append(cpu)
            e, t = statistics.mean(errs), statistics.median(cpus)
            cost[name] = e * t
            print("%-4d %-6s %.3e  %.3f  %.3e" % (spp, name, e, t, e * t),
                  flush=True)
        print("%-4d efficiency new / old: %.2f" %
              (spp, cost["old"] / cost["new"]))


if __name__ == "__main__":
    main()
