#!/usr/bin/env python3
"""Spectral chromatic aberration: time to relative MSE 1e-3, old against new.

    python3 bench/spectral.py --old OLD/lensray --new build/lensray \
        --imgdiff build/accuracy/imgdiff --work build/bench/spectral

Renders scenes/accuracy-chroma.json (the `make accuracy` chroma scene)
with two binaries side by side in one run: OLD (a build of `main` before
issue 17's spectral sampling) in the configurations docs/accuracy.md
found best (sobol, full simulation and plan+adaptive, 8 and 16
wavelengths a sample), and NEW full and plan+adaptive at the scene's 8
(splatting, lib/render/splat.c, integrates the spectrum whatever the number).  Every image is compared with one reference made by
OLD (sobol, full simulation, 32 wavelengths a sample, --ref-spp samples,
two seeds: half their relMSE is the reference's own noise), cached in
WORK/ref.  Time is the render's CPU seconds (`cpu_seconds` of --stats),
the fastest of up to 3 runs for renders under 0.5 s, so load on the
machine inflates it little; the time to 1e-3 is interpolated log-log
between the ladder's rungs.  Prints a table and writes WORK/results.json;
docs/spectral.md quotes a run.

NEW alone (without --old) measures NEW's configurations against a
reference that NEW must then make itself: only for a look, never for the
docs' ratio.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

SCENE = "scenes/accuracy-chroma.json"
TARGET = 1e-3
REF_SEEDS = (1000001, 1000002)


def render(binary, out, sets):
    cmd = [binary, "render", SCENE, "-o", out, "--stats", "--quiet"]
    for k, v in sorted(sets.items()):
        cmd += ["--set", "%s=%s" % (k, v)]
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True)
    if p.returncode != 0:
        sys.exit("spectral.py: %s failed: %s" % (" ".join(cmd),
                                                 p.stderr.strip()))
    for line in p.stdout.splitlines():
        if line.strip().startswith("{"):
            return json.loads(line)
    sys.exit("spectral.py: no --stats line from %s" % binary)


def timed(binary, out, sets):
    """CPU seconds of the render, the fastest of up to 3 runs when short."""
    st = render(binary, out, sets)
    cpus = [st["cpu_seconds"]]
    while cpus[0] < 0.5 and len(cpus) < 3:
        cpus.append(render(binary, out, sets)["cpu_seconds"])
    return min(cpus), st


def relmse(imgdiff, ref, img):
    p = subprocess.run([imgdiff, ref, img], stdout=subprocess.PIPE,
                       text=True, check=True)
    return json.loads(p.stdout.splitlines()[0])["relmse"]


def time_to(points, target):
    """Log-log interpolated CPU time at which relMSE first reaches target,
    from (cpu, relmse) points in ladder order; None if never."""
    for (t0, e0), (t1, e1) in zip(points, points[1:]):
        if e0 > target >= e1:
            f = math.log(e0 / target) / math.log(e0 / e1)
            return math.exp(math.log(t0) + f * math.log(t1 / t0))
    if points and points[0][1] <= target:
        return points[0][0]
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", help="lensray built from main (the baseline)")
    ap.add_argument("--new", required=True)
    ap.add_argument("--imgdiff", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--quick", action="store_true",
                    help="short ladders, for a smoke run")
    o = ap.parse_args()
    os.makedirs(os.path.join(o.work, "ref"), exist_ok=True)
    os.makedirs(os.path.join(o.work, "runs"), exist_ok=True)
    started = time.time()

    ref_bin = o.old or o.new
    refs = []
    for seed in REF_SEEDS:
        path = os.path.join(o.work, "ref", "%s-%d-%d.exr" % (
            "old" if o.old else "new", o.ref_spp, seed))
        if not os.path.exists(path):
            print("spectral.py: reference seed %d at %d spp, 32 wavelengths "
                  "(cached for later runs)..." % (seed, o.ref_spp),
                  flush=True)
            render(ref_bin, path + ".tmp.exr", {
                "render.spp": o.ref_spp, "render.plan": "false",
                "render.adaptive": "false", "render.sampler": "sobol",
                "render.seed": seed, "camera.chromatic.wavelengths": 32})
            os.replace(path + ".tmp.exr", path)
        refs.append(path)
    ref = refs[0]
    ref_noise = relmse(o.imgdiff, refs[0], refs[1]) / 2

    full = {"render.plan": "false", "render.adaptive": "false"}
    ladder_old = [8, 16, 32, 64, 128] if not o.quick else [8, 16]
    ladder_new = [8, 16, 32, 64, 128] if not o.quick else [4, 8, 16]
    configs = []
    if o.old:
        for wl in (8, 16):
            for mode, sets in (("full", full), ("plan+adaptive", {})):
                configs.append(("old", o.old, "%s, %d wavelengths" % (mode, wl),
                                dict(sets, **{"camera.chromatic.wavelengths": wl}),
                                ladder_old))
    # Splatting (lib/render/splat.c) ignores the wavelengths a sample and
    # adaptive sampling: full and plan+adaptive at the scene's 8 are the
    # same picture, both measured to show it.
    for wl in (8,):
        for mode, sets in (("full", full), ("plan+adaptive", {})):
            configs.append(("new", o.new, "%s, %d wavelengths" % (mode, wl),
                            dict(sets, **{"camera.chromatic.wavelengths": wl}),
                            ladder_new))

    results = []
    for who, binary, name, sets, ladder in configs:
        pts = []
        for spp in ladder:
            out = os.path.join(o.work, "runs", "%s-%s-%d.exr" % (
                who, name.replace(" ", "").replace(",", "_"), spp))
            cpu, st = timed(binary, out, dict(sets, **{"render.spp": spp}))
            e = relmse(o.imgdiff, ref, out)
            pts.append((cpu, e))
            print("  %-3s %-36s spp %4d  cpu %7.3f s  relMSE %.3e" % (
                who, name, spp, cpu, e), flush=True)
        t = time_to(pts, TARGET)
        results.append({"binary": who, "config": name, "points": pts,
                        "time_to_target": t})

    best_old = min((r["time_to_target"] for r in results
                    if r["binary"] == "old" and r["time_to_target"]),
                   default=None)
    print()
    print("reference: %s, %d spp, 32 wavelengths; its noise (relMSE) %.2e"
          % ("old" if o.old else "new", o.ref_spp, ref_noise))
    print("| binary | configuration | CPU s to relMSE 1e-3 | "
          "best old / this | relMSE at the top rung |")
    print("|---|---|---|---|---|")
    for r in results:
        t = r["time_to_target"]
        ratio = ("%.1fx" % (best_old / t)) if (best_old and t) else "-"
        print("| %s | %s | %s | %s | %.2e (%.2f s) |" % (
            r["binary"], r["config"], "%.3f" % t if t else "never",
            ratio, r["points"][-1][1], r["points"][-1][0]))
    # Bias: NEW in the reference's own configuration, a third seed.  With
    # no bias between the methods, its distance to either reference is
    # about the references' distance to each other (each is the sum of
    # two images' noise, all three alike).
    bias = None
    if o.old:
        out = os.path.join(o.work, "runs", "new-converged.exr")
        render(o.new, out, {
            "render.spp": o.ref_spp, "render.plan": "false",
            "render.adaptive": "false", "render.sampler": "sobol",
            "render.seed": 1000003, "camera.chromatic.wavelengths": 32})
        bias = {"new_ref1": relmse(o.imgdiff, refs[0], out),
                "new_ref2": relmse(o.imgdiff, refs[1], out),
                "ref1_ref2": 2 * ref_noise}
        print("\nconverged (sobol, %d spp, 32 wavelengths, full): relMSE new "
              "vs old seed 1: %.2e, new vs old seed 2: %.2e; old seed 1 vs "
              "old seed 2: %.2e" % (o.ref_spp, bias["new_ref1"],
                                    bias["new_ref2"], bias["ref1_ref2"]))
    with open(os.path.join(o.work, "results.json"), "w") as f:
        json.dump({"reference_noise": ref_noise, "ref_spp": o.ref_spp,
                   "results": results, "best_old": best_old, "bias": bias},
                  f, indent=1)
    load = os.getloadavg()
    print("\n%d s wall; load average now %.1f %.1f %.1f" % (
        time.time() - started, *load))


if __name__ == "__main__":
    main()
