"""The shipped lenses' contact sheet (docs/lenses.md, `make lens-sheet`).

    python docs/lens-sheet.py LENSRAY [OUT.png [LENSES.md]]

Renders one scene through every lens in lenses/ and lays the pictures out
in a grid, each under its name, focal length, f-number and field; then
rewrites the table between the "lens-sheet" markers of LENSES.md from the
same runs (`lensray lens`).  Run in the ray-optics virtualenv
(build/lens-venv), which has matplotlib and tests/lenses/compare.py.

The scene is the same for every lens, in angles and in focal lengths: a
grid of thin white bars 30 f away (1.5 m for a 50 mm lens), in focus,
that spans the frame with eight cells across, and a small bright light
20 times farther behind the middle of each cell.  Straight bars show
distortion (bowed out: barrel, in: pincushion); the lights show the
bokeh: discs whose diameter, as a part of the frame, is about 1 / (30 N
tan(field)) (the entrance pupil f / N times f over 30 f, on a sensor of
about f tan(field)): a telephoto's discs are larger than a fast normal
lens's, a wide angle's are points; cat's eyes where the lens vignettes,
and lateral colour on their rims.  The sensor of
each lens is sized so that its half diagonal is the real chief ray's
image height at the half field make test-lenses checks that lens to
(compare.ANGLES, the source's field where it gives one): every lens is
seen over the field it was designed for.  Each lens is wide open (its
stop as the source gives it).
"""
import json
import math
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "tests", "lenses"))
from compare import ANGLES  # noqa: E402  (the half field each lens is checked to)

import matplotlib  # noqa: E402
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.image as mpimg  # noqa: E402

W, H = 300, 200        # pixels a thumbnail; the sensor is 3:2
SPP = 256
DIST = 30.0            # focal lengths to the bars (the focus)
LIGHTS = 20.0          # times that to the lights
CELLS = 8              # cells across the frame (up to 60 deg half width)
EXTS = (".json", ".zmx", ".dat", ".txt")


def lens_info(lensray, name, field):
    out = subprocess.run([lensray, "lens", name, "--field-angles",
                          repr(field)], check=True, capture_output=True,
                         text=True).stdout
    return json.loads(out)


def scene(name, info, field):
    """The scene for one lens, in millimetres scaled to metres (the
    scene's unit is the metre; the sensor is in millimetres)."""
    f = info["efl_mm"]
    # Past the nearest focus, 4 f plus the hiatus, which a long lens of
    # short focus (Laikin's 170-degree: 197 mm long, f = 5.2) can exceed.
    dist = max(DIST * f, 4 * f + 2 * info["total_track_mm"])
    h = info["fields"][0]["image_height_mm"]
    if h is None:               # no chief ray at the full field
        h = f * math.tan(math.radians(field))
    diag = 2 * h
    sw, sh = diag * 3 / math.sqrt(13), diag * 2 / math.sqrt(13)
    # The frame's half width as an angle: the real chief ray's, found
    # between the axis and the full field by its image height.
    half_w = math.degrees(math.atan(sw / 2 / f)) if field < 45 else \
        field * (sw / 2) / h
    half_w = min(half_w, 60.0)
    cell = 2 * dist * math.tan(math.radians(half_w)) / CELLS
    # Bars as far out as the lens sees (a fisheye sees past 80 degrees:
    # there the grid stops and the frame is black).
    reach = dist * math.tan(math.radians(min(field + 5, 80)))
    n = int(reach / cell) + 1
    m = 1e-3                    # mm -> m
    bar = 0.06 * cell
    objs = []
    for i in range(-n, n + 1):
        objs.append({"type": "plane", "point": [i * cell * m, 0, -dist * m],
                     "normal": [0, 0, 1], "size": [bar * m, 2 * n * cell * m],
                     "material": "bar"})
        objs.append({"type": "plane", "point": [0, i * cell * m, -dist * m],
                     "normal": [0, 0, 1], "size": [2 * n * cell * m, bar * m],
                     "material": "bar"})
    k = LIGHTS
    for i in range(-n, n):
        for j in range(-n, n):
            objs.append({"type": "sphere",
                         "center": [(i + 0.5) * cell * k * m,
                                    (j + 0.5) * cell * k * m,
                                    -LIGHTS * dist * m],
                         "radius": 0.1 * cell * k * m, "material": "light"})
    return {
        "description": "lens-sheet: %s" % name,
        "camera": {"model": "lens", "lens": name, "position": [0, 0, 0],
                   "look_at": [0, 0, -1], "up": [0, 1, 0],
                   "sensor_width_mm": round(sw, 4),
                   "focus_distance": dist * m},
        "render": {"width": W, "height": round(W * sh / sw), "spp": SPP,
                   "max_depth": 0},
        "background": 0,
        "materials": {"bar": {"diffuse": 0.75},
                      "light": {"emission": [12, 12, 12]}},
        "lights": [{"type": "ambient", "radiance": 1}],
        "objects": objs,
    }


def short_source(info):
    """The name's parenthesis: its source, as each file names it."""
    m = re.search(r"\(([^()]*)\)\s*$", info["name"])
    return m.group(1) if m else info["source"].split(",")[0]


def table(rows):
    out = ["| lens | source | f (mm) | f-number | half field (deg) |",
           "|---|---|---|---|---|"]
    for name, info, field in rows:
        out.append("| `%s` | %s | %.2f | %.2f | %g |" % (
            name, short_source(info), info["efl_mm"], info["f_number"],
            field))
    return "\n".join(out)


def main():
    lensray = os.path.abspath(sys.argv[1])
    out_png = sys.argv[2] if len(sys.argv) > 2 else \
        os.path.join(HERE, "figures", "lens-sheet.png")
    md = sys.argv[3] if len(sys.argv) > 3 else os.path.join(HERE, "lenses.md")
    names = sorted(os.path.splitext(f)[0]
                   for f in os.listdir(os.path.join(REPO, "lenses"))
                   if f.endswith(EXTS))
    missing = [n for n in names if n not in ANGLES]
    if missing:
        sys.exit("lens-sheet: no field for %s: add it to ANGLES in "
                 "tests/lenses/compare.py" % ", ".join(missing))
    rows = []
    for name in names:
        field = max(ANGLES[name])
        rows.append((name, lens_info(lensray, name, field), field))
    # Widest field first, the telephotos last.
    rows.sort(key=lambda r: (-r[2], r[1]["efl_mm"]))
    tmp = tempfile.mkdtemp(prefix="lens-sheet-")
    pics = []
    for i, (name, info, field) in enumerate(rows):
        sc = os.path.join(tmp, name + ".json")
        png = os.path.join(tmp, name + ".png")
        with open(sc, "w") as f:
            json.dump(scene(name, info, field), f)
        print("lens-sheet: [%2d/%d] %s" % (i + 1, len(rows), name),
              flush=True)
        subprocess.run([lensray, "render", sc, "-o", png, "-q"], check=True)
        pics.append(png)
    cols = 4
    rws = (len(rows) + cols - 1) // cols
    fig, axes = plt.subplots(rws, cols, figsize=(cols * 3.2, rws * 2.55),
                             dpi=100)
    for ax in axes.flat:
        ax.axis("off")
    for ax, (name, info, field), png in zip(axes.flat, rows, pics):
        ax.imshow(mpimg.imread(png))
        ax.set_title("%s\nf = %.1f mm  f/%.2g  %g deg" % (
            name, info["efl_mm"], info["f_number"], field), fontsize=7.5)
    fig.tight_layout(pad=0.4)
    raw = os.path.join(tmp, "sheet.png")
    fig.savefig(raw, facecolor="white")
    # 64 colours: the pictures are nearly grey, and the full-colour PNG
    # was 1 MB in the repository (0.4 MB so).
    from PIL import Image
    Image.open(raw).convert("RGB").quantize(64).save(out_png, optimize=True)
    print("lens-sheet: %d lenses -> %s" % (len(rows), out_png))
    # The table in lenses.md, between its markers, from the same runs.
    text = open(md).read()
    begin, end = "<!-- lens-sheet table: begin -->", \
        "<!-- lens-sheet table: end -->"
    if begin in text and end in text:
        a, rest = text.split(begin, 1)
        _, b = rest.split(end, 1)
        with open(md, "w") as f:
            f.write(a + begin + "\n" + table(rows) + "\n" + end + b)
        print("lens-sheet: the table in %s" % md)


if __name__ == "__main__":
    main()
