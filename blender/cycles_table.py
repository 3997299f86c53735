"""The table of docs/blender.md: LENSRAY against Cycles on the issue's
scene, one row per light (and the HDRI world).  Run with the venv of
`make test-blender`:  build/blender-venv/bin/python blender/cycles_table.py
"""
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "tests"))
import common  # noqa: E402


W, H, LR_SPP, CY_SPP = 320, 240, 512, 512
rows = []
with tempfile.TemporaryDirectory() as tmp:
    for case in common.VARIANTS:
        sc = common.variant_scene(case, W, H, tmp)
        sc.lensray.samples = LR_SPP
        t = time.time()
        a = common.render_exr(sc, "LENSRAY", os.path.join(tmp, "a.exr"))
        ta = time.time() - t
        common.setup_cycles(sc, CY_SPP)
        t = time.time()
        b = common.render_exr(sc, "CYCLES", os.path.join(tmp, "b.exr"))
        tb = time.time() - t
        mean, p90 = common.compare(a, b)
        rows.append(f"| {case.lower()} | {mean:.2%} | {p90:.2%} | {ta:.1f} s | {tb:.1f} s |")
print(f"{W}x{H}; lensray path tracer {LR_SPP} spp (adaptive); Cycles CPU {CY_SPP} spp, "
      "no adaptive sampling, no denoising")
print("| light | mean difference | p90 of 8x8 blocks | lensray wall | Cycles wall |")
print("|---|---|---|---|---|")
print("\n".join(rows), flush=True)
os._exit(0)
