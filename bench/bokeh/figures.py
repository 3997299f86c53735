"""bench/bokeh/figures.py: docs/bokeh.md's pictures, from a `make
bench-bokeh` run's images and results (build/bench/bokeh/):

  docs/figures/bokeh-night.png  the night lights at about equal CPU time:
                                camera paths only, lensray's defaults
                                (light side on), the analytic reference
  docs/figures/bokeh-chart.png  relMSE against CPU seconds for every
                                renderer of the run (gnuplot)

or, from a `make bench-sparkles` run (build/bench/sparkles/, NAME
sparkles), docs/figures/bokeh-sparkles.png: the glints at about equal CPU
time, camera paths only, the defaults, the reference; or, from a
bench/bokeh/lens.py run (build/bench/bokeh-lens/, NAME night-lens),
docs/figures/bokeh-night-lens.png: the lights through the double Gauss
at about equal CPU time, camera paths only, the defaults, and lens.py's
reference (the defaults at 16384 spp: a traced lens has no closed form).

Usage: python bench/bokeh/figures.py [WORK_DIR] [DOCS_FIGURES_DIR] [NAME]
(numpy; the PNG writer is below, the chart needs gnuplot).
"""
import json
import os
import struct
import subprocess
import sys
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests", "lenses"))
from exr import read_exr  # noqa: E402


def load(path):
    if path.endswith(".npy"):
        return np.load(path)
    d = read_exr(path)
    return np.stack([d["R"], d["G"], d["B"]], -1)


def srgb8(img, exposure):
    """Linear RGB -> 8-bit sRGB after exposure and a soft shoulder
    (x / (1 + x)), so that the discs' rims and cores both show."""
    x = img * exposure
    x = x / (1.0 + x)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0), 1 / 2.4) - 0.055)
    return (np.clip(x, 0, 1) * 255 + 0.5).astype(np.uint8)


def write_png(path, rgb8):
    """A minimal 8-bit RGB PNG (PNG specification, chunks IHDR, IDAT, IEND;
    filter 0 on every row)."""
    h, w, _ = rgb8.shape
    raw = b"".join(b"\0" + rgb8[y].tobytes() for y in range(h))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path, "wb") as fh:
        fh.write(png)


def pick(rows, cpu):
    """The row whose CPU time is nearest `cpu` (log scale)."""
    return min(rows, key=lambda r: abs(np.log(r["cpu"] / cpu)))


def main():
    work = sys.argv[1] if len(sys.argv) > 1 else "build/bench/bokeh"
    out = sys.argv[2] if len(sys.argv) > 2 else "docs/figures"
    name = sys.argv[3] if len(sys.argv) > 3 else "night"
    with open(os.path.join(work, "results.json")) as fh:
        results = json.load(fh)
    refs = sorted((f for f in os.listdir(work) if f.startswith("ref-") and f.endswith(".npy")),
                  key=lambda f: os.path.getmtime(os.path.join(work, f)))
    ref = load(os.path.join(work, refs[-1]))
    # lens.py names its renderers and images "defaults" and "camera";
    # run.py and sparkles.sh "lensray-default" and "lensray-camera".
    if name == "night-lens":
        results, dname, cname = results["results"], "defaults", "camera"
    else:
        dname, cname = "lensray-default", "lensray-camera"
    # Equal time: the defaults' step nearest 0.5 CPU s (sparkles: 1.5),
    # and the camera's step nearest the same time.
    d = pick(results[dname], 1.5 if name == "sparkles" else 0.5)
    c = pick(results[cname], d["cpu"])
    panels = [load(os.path.join(work, "%s-%d.exr" % (cname, c["spp"]))),
              load(os.path.join(work, "%s-%d.exr" % (dname, d["spp"]))), ref]
    gap = np.full((ref.shape[0], 4, 3), 255, np.uint8)
    strip = []
    for i, p in enumerate(panels):
        strip += [srgb8(p, 0.7 if name == "sparkles" else 4.0)] + ([gap] if i < 2 else [])
    write_png(os.path.join(out, "bokeh-%s.png" % name), np.concatenate(strip, 1))
    print("bokeh-%s.png: camera %d spp (%.2f CPU s, relMSE %.2e), defaults %d spp "
          "(%.2f CPU s, relMSE %.2e), reference"
          % (name, c["spp"], c["cpu"], c["relmse"], d["spp"], d["cpu"], d["relmse"]))
    if name != "night":
        return 0
    # The chart.
    dat = os.path.join(work, "chart.dat")
    names = [n for n in ("lensray-default", "lensray-camera", "lensray-full",
                         "mitsuba-path", "mitsuba-ptracer") if n in results]
    with open(dat, "w") as fh:
        for n in names:
            fh.write("# %s\n" % n)
            for r in results[n]:
                fh.write("%g %g\n" % (r["cpu"], r["relmse"]))
            fh.write("\n\n")
    plot = ", ".join("'%s' index %d with linespoints lw 2 title '%s'" % (dat, i, n)
                     for i, n in enumerate(names))
    script = ("set terminal pngcairo size 640,400 font ',10'\n"
              "set output '%s'\n"
              "set logscale xy\nset grid\nset format y '%%.0e'\n"
              "set xlabel 'CPU seconds (both threads)'\nset ylabel 'relMSE'\n"
              "set key bottom left\n"
              "set arrow from graph 0, first 1e-3 to graph 1, first 1e-3 nohead dt 2\n"
              "plot %s\n" % (os.path.join(out, "bokeh-chart.png"), plot))
    subprocess.run(["gnuplot"], input=script.encode(), check=True)
    print("bokeh-chart.png: %s" % ", ".join(names))
    return 0


if __name__ == "__main__":
    sys.exit(main())
