"""LENSRAY against Cycles (CPU) on the issue's scene: CPU seconds to the
same relMSE.  docs/blender.md quotes a run.  With the venv of
`make test-blender`:

    build/blender-venv/bin/python bench/blender_cycles.py [--work DIR] [--quick]
        [--scene point|spot|sun|area|hdri]

--scene swaps the light as blender/tests do (common.variant_scene; hdri
is the environment texture with the light off); point by default.

Each renderer is measured against its own reference, so relMSE is its
noise alone (the two references agree to the table of docs/blender.md):
lensray's is the full simulation (render.plan and render.adaptive off),
Cycles' has adaptive sampling off, both at REF_SPP, cached in WORK.
Ladders: LENSRAY with the engine's defaults (plan and adaptive sampling
on); Cycles without adaptive sampling and with its default adaptive
sampling (noise threshold 0.01); no denoising.  Time is the CPU seconds
(user + system, all threads) of bpy.ops.render.render for one frame,
scene export and the EXR written included on both sides; the time to a
relMSE is interpolated log-log between rungs (bench/spectral.py's
time_to).  relMSE is imgdiff's (docs/accuracy.md): mean over pixels
and channels of (x - r)^2 / (r^2 + 1e-2).
"""
import argparse
import os
import resource
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender", "tests"))
sys.path.insert(0, HERE)
import common  # noqa: E402
from spectral import time_to  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

W, H, REF_SPP = 320, 240, 2048
TARGETS = (1e-3, 3e-4, 1e-4)


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def timed(sc, engine, path):
    t0, w0 = cpu_seconds(), time.time()
    img = common.render_exr(sc, engine, path)
    return img, cpu_seconds() - t0, time.time() - w0


def relmse(x, r):
    return float(np.mean((x.astype(np.float64) - r) ** 2 / (r.astype(np.float64) ** 2 + 1e-2)))


def cached(path, make):
    if not os.path.exists(path + ".npy"):
        np.save(path + ".npy", make())
    return np.load(path + ".npy")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", default=os.path.join(os.path.dirname(HERE), "build", "bench", "blender"))
    ap.add_argument("--quick", action="store_true", help="small ladders and references")
    ap.add_argument("--scene", default="point", choices=[v.lower() for v in common.VARIANTS])
    o = ap.parse_args()
    os.makedirs(o.work, exist_ok=True)
    ref_spp = 128 if o.quick else REF_SPP
    sc = common.variant_scene(o.scene.upper(), W, H, o.work)
    tag = "" if o.scene == "point" else o.scene + "-"  # point: the caches of before
    exr = os.path.join(o.work, "img.exr")

    def lensray_ref():
        import lensray
        from lensray_blender import export
        d = export.scene_dict(sc, bpy.context.evaluated_depsgraph_get(), o.work, set())
        with lensray.load(d, base_dir=o.work) as s:
            return s.render(render={"spp": ref_spp, "plan": False, "adaptive": False}, progress=False)

    def cycles_ref():
        common.setup_cycles(sc, ref_spp)
        return common.render_exr(sc, "CYCLES", exr)

    ref_l = cached(os.path.join(o.work, "ref-lensray-%s%d" % (tag, ref_spp)), lensray_ref)
    ref_c = cached(os.path.join(o.work, "ref-cycles-%s%d" % (tag, ref_spp)), cycles_ref)
    mean, p90 = common.compare(ref_l, ref_c)
    print("references (%d spp) agree: mean %.2f%%, p90 of 8x8 blocks %.2f%%, relMSE %.2e"
          % (ref_spp, 100 * mean, 100 * p90, relmse(ref_l, ref_c)), flush=True)

    # Ladders from above the largest target, so that each crosses it.
    ladder = [2, 4, 8, 16, 32] if o.quick else [2, 4, 8, 16, 32, 64, 128, 256]
    series = {}

    def run(name, spps, setup, engine, ref):
        pts = []
        for spp in spps:
            setup(spp)
            img, cpu, wall = timed(sc, engine, exr)
            e = relmse(img, ref)
            pts.append((cpu, e))
            print("  %-26s spp %4d  cpu %7.2f s  wall %6.2f s  relMSE %.3e"
                  % (name, spp, cpu, wall, e), flush=True)
        series[name] = pts

    def lr(spp):
        sc.lensray.samples = spp

    def cy(adaptive):
        def f(spp):
            common.setup_cycles(sc, spp)
            sc.cycles.use_adaptive_sampling = adaptive
        return f

    run("lensray (plan, adaptive)", ladder + ([] if o.quick else [512]), lr, "LENSRAY", ref_l)
    run("Cycles", ladder, cy(False), "CYCLES", ref_c)
    run("Cycles adaptive 0.01", ladder, cy(True), "CYCLES", ref_c)

    cpu_name = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo")
                     if ln.startswith("model name")), "?")
    print("\n%dx%d, the issue's scene (%s, f/2.8); %s, %d cores (shared); "
          "load average %.1f" % (W, H, "HDRI world, light off" if o.scene == "hdri"
                                 else o.scene + " light", cpu_name, os.cpu_count(),
                                 os.getloadavg()[0]))
    print("| relMSE | " + " | ".join("%s CPU s" % n for n in series)
          + " | best Cycles / lensray |")
    print("|---" * (len(series) + 2) + "|")
    for t in TARGETS:
        times = {n: time_to(p, t) for n, p in series.items()}
        cells = ["%.2f" % v if v is not None else "not reached" for v in times.values()]
        cyc = [v for n, v in times.items() if n.startswith("Cycles") and v is not None]
        lrt = times["lensray (plan, adaptive)"]
        ratio = "%.1fx" % (min(cyc) / lrt) if cyc and lrt else "-"
        print("| %.0e | %s | %s |" % (t, " | ".join(cells), ratio))
    sys.stdout.flush()
    os._exit(0)  # bpy can hang at interpreter exit


if __name__ == "__main__":
    main()
