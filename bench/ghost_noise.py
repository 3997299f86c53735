#!/usr/bin/env python3
"""ghost_noise.py: how noisy the rendered ghosts are, and what they cost.

    python3 bench/ghost_noise.py [--bin build/lensray] [--seeds 4] \\
        [--ref-spp 1024] [--set PATH=VALUE ...] SCENE.json

The ghosts alone are the render with camera.ghosts true less the same
render with false (the main image is the same bytes either way, so the
difference is the ghosts' splats).  The reference is that difference at
--ref-spp (the ghosts' paths grow with render.spp).  For each of --seeds
seeds at the scene's own spp it prints the ghosts' error against the
reference over the frame: its rms in units of display white (1.0) and
the largest pixel error, the relMSE (mean of err^2 / (ref^2 + 1e-4))
over the pixels where the reference ghosts reach 1/256 of white, and
the CPU seconds ghosts on took.  Pure Python: it reads the
uncompressed float EXR it asks lensray for.

A small source's ghosts drawn as meshes (lib/integrator/ghost_grid.c)
are the same at every spp and seed: against the same build's reference
they show no error at all.  Give --ref-bin a build that traces paths
(one from before the meshes, 4e3a12a's parent), whose reference is
unbiased, or compare against a finer mesh.
"""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile

from ghosts import parser, sets


def read_exr(path):
    """(width, height, [r, g, b] lists) of an uncompressed float EXR."""
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError("%s: not an EXR" % path)
    at, chans, window = 8, [], None
    while data[at] != 0:
        end = data.index(b"\0", at)
        name = data[at:end].decode()
        end2 = data.index(b"\0", end + 1)
        kind = data[end + 1:end2].decode()
        size = struct.unpack_from("<i", data, end2 + 1)[0]
        value = data[end2 + 5:end2 + 5 + size]
        if name == "channels":
            p = 0
            while value[p] != 0:
                e = value.index(b"\0", p)
                chans.append((value[p:e].decode(),
                              struct.unpack_from("<i", value, e + 1)[0]))
                p = e + 17
        elif name == "dataWindow":
            window = struct.unpack("<4i", value)
        elif name == "compression" and value[0] != 0:
            raise ValueError("%s: compressed (%s)" % (path, kind))
        at = end2 + 5 + size
    at += 1
    w = window[2] - window[0] + 1
    h = window[3] - window[1] + 1
    at += 8 * h  # the offset table: one chunk a scanline
    planes = {name: [0.0] * (w * h) for name, _ in chans}
    for _ in range(h):
        y = struct.unpack_from("<i", data, at)[0] - window[1]
        at += 8
        for name, ptype in chans:
            if ptype != 2:
                raise ValueError("%s: channel %s not float" % (path, name))
            planes[name][y * w:(y + 1) * w] = struct.unpack_from(
                "<%df" % w, data, at)
            at += 4 * w
    return w, h, [planes["R"], planes["G"], planes["B"]]


def render(binary, scene, extra, out):
    cmd = [binary, "render", scene, "-o", out, "-q", "--stats",
           "--compression", "none"] + extra
    p = subprocess.run(cmd, check=True, capture_output=True, text=True)
    stats = None
    for line in (p.stdout + p.stderr).splitlines():
        if line.startswith("{") and '"cpu_seconds"' in line:
            stats = json.loads(line)
    return read_exr(out), stats


def ghosts(binary, scene, extra, tmp):
    (w, h, on), st = render(binary, scene,
                            extra + ["--set", "camera.ghosts=true"],
                            os.path.join(tmp, "on.exr"))
    (_, _, off), _ = render(binary, scene,
                            extra + ["--set", "camera.ghosts=false"],
                            os.path.join(tmp, "off.exr"))
    diff = [[a - b for a, b in zip(on[k], off[k])] for k in range(3)]
    return diff, st


def main():
    ap = parser(__doc__)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--ref-bin", help="the reference's lensray "
                    "(default --bin)")
    ap.add_argument("--ref-cache", help="keep the reference in this JSON "
                    "file, and read it from there when it exists")
    a = ap.parse_args()
    extra = sets(a)
    with tempfile.TemporaryDirectory() as tmp:
        if a.ref_cache and os.path.exists(a.ref_cache):
            with open(a.ref_cache) as fh:
                ref, st = json.load(fh)
            a.ref_spp = st["spp"]
        else:
            ref, st = ghosts(a.ref_bin or a.bin, a.scene,
                             extra + ["--set", "render.spp=%d" % a.ref_spp,
                                      "--set", "render.seed=1000"], tmp)
            if a.ref_cache:
                with open(a.ref_cache, "w") as fh:
                    json.dump([ref, st], fh)
        n = len(ref[0])
        peak = max(max(c) for c in ref)
        lit = [i for i in range(n) if max(ref[k][i] for k in range(3))
               >= 1.0 / 256.0]
        print("reference at spp %d: ghost_paths %s, brightest ghost pixel "
              "%.4g of white, %d pixels over 1/256" %
              (a.ref_spp, st["plan"].get("ghost_paths"), peak, len(lit)))
        for seed in range(1, a.seeds + 1):
            g, st = ghosts(a.bin, a.scene,
                           extra + ["--set", "render.seed=%d" % seed], tmp)
            se, worst, rel = 0.0, 0.0, 0.0
            for k in range(3):
                for i in range(n):
                    e = g[k][i] - ref[k][i]
                    se += e * e
                    worst = max(worst, abs(e))
            for i in lit:
                for k in range(3):
                    e = g[k][i] - ref[k][i]
                    rel += e * e / (ref[k][i] ** 2 + 1e-4)
            rel /= max(1, 3 * len(lit))
            print("seed %d: rms %.3g of white, worst %.3g, relMSE %.3g over "
                  "the lit pixels; ghost_paths %s, %.3f s CPU" %
                  (seed, math.sqrt(se / (3 * n)), worst, rel,
                   st["plan"].get("ghost_paths"), st["cpu_seconds"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
