"""A defocused point's blur in lensray's renders against the spot diagram
of ray-optics (github.com/mjhoptics/ray-optics) for the same lens,
object point, stop and sensor (issue 12: "a defocused point's blur
matches the spot size the program predicts (within 5%)").

    python spot.py LENSRAY

Each case renders a small white sphere under ambient light (a flat disk
of uniform radiance) through a shipped lens with `lensray render`,
focused at one distance with the sphere at another, and measures the
blur's rms radius on the sensor (the square root of its polar second
moment about its centroid).  Two small, known terms come off that
moment: the pixels' box (Sheppard's correction, h^2/12 per axis: W. F.
Sheppard 1898, "On the calculation of the most probable values of
frequency-constants") and the sphere's own image, a disk of radius a
whose moment is a^2 / 2 (second moments add under convolution).

ray-optics traces, at the d line, rays from the same object point
through a dense square grid on the plane of the first vertex, each
weighted by the solid angle of its cell (cos^3 of its angle to the axis,
so that the weights are uniform in solid angle as a point source's
light is), stopped where a surface's semi-aperture is passed (the stop's
scaled as below), and gives their rms radius about their centroid on
the sensor plane: the geometric spot, no diffraction.

Both sides set up the camera by camera_lens.c's definitions, computed
here again from ray-optics' numbers: the stop is scaled until the widest
axial parallel ray that gets through is efl / (2 N) high (bisection, as
setup() does); unit focusing moves the lens by
y = ((D - L) - sqrt((D - L)^2 - 4 f^2)) / 2 from the prescription's
last thickness (Newton's equation; D the focus distance from the
sensor, L the distance between the focal points).  Ends "N passed,
N failed" and exits non-zero on any failure.
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import warnings

warnings.filterwarnings("ignore")
import logging
logging.disable(logging.CRITICAL)

import numpy as np
from rayoptics.raytr import raytrace as rt

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare import ND, build, surfaces_json  # noqa: E402
from exr import read_exr  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
LENSES = os.path.join(HERE, "..", "..", "lenses")
TOLERANCE = 0.05
SPOT_PX = 12  # the spot's farthest ray from its centroid, in pixels
SPP = 4096
SPHERE_PX = 1.0  # the sphere's image radius, in pixels (roughly)

# lens, f-number (None: wide open), focus and point distances from the
# sensor (mm), the point's height (mm, up).
CASES = [
    ("double-gauss-50", 2.8, 2000.0, 1500.0, 0.0),
    ("double-gauss-50", 2.8, 2000.0, 3000.0, 250.0),
    ("double-gauss-50", 2.8, 1500.0, 1250.0, -150.0),
    ("petzval", None, 2500.0, 2000.0, 0.0),
    ("petzval", None, 2500.0, 3500.0, 300.0),
]


class Lens:
    """A shipped lens in ray-optics, with its stop set like the camera's
    and the sensor where unit focusing puts it."""

    def __init__(self, name, f_number, focus_mm):
        surfs = surfaces_json(os.path.join(LENSES, name + ".json"))
        self.opm, _ = build(surfs)
        self.sm = self.opm["seq_model"]
        self.opm.update_model()
        fod = self.opm["analysis_results"]["parax_data"].fod
        self.sa = [s[3] for s in surfs]
        self.stop = [k for k, s in enumerate(surfs) if s[4]][0]
        t = [s[1] for s in surfs]
        f = fod.efl
        # Focal points from the first vertex (ffl is signed that way).
        z_f, z_fp = fod.ffl, sum(t[:-1]) + fod.bfl
        dl = focus_mm - (z_fp - z_f)
        y = 0.5 * (dl - math.sqrt(dl * dl - 4 * f * f))
        self.track = sum(t) + y  # first vertex to the sensor
        self.sm.gaps[-1].thi = t[-1] + y
        self.sm.gaps[0].thi = 1.0
        self.opm.update_model()
        self.scale = 1.0
        if f_number is not None:
            want = f / (2 * f_number)
            if self.reach(1.0) > want:
                lo, hi = 0.0, 1.0
                for _ in range(40):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (lo, mid) if self.reach(mid) > want else (mid, hi)
                self.scale = hi
        self.efl = f

    def trace(self, p0, d0, scale):
        """The ray's point on the sensor, or None where it is stopped."""
        try:
            ray = rt.trace(self.sm, p0, d0, ND)[0]
        except Exception:  # missed a surface or reflected totally
            return None
        for k, seg in enumerate(ray[1:-1]):
            lim = self.sa[k] * (scale if k == self.stop else 1.0)
            if seg[0][0] ** 2 + seg[0][1] ** 2 > lim * lim:
                return None
        return ray[-1][0]

    def reach(self, scale):
        """The widest axial parallel ray that gets through (bisection)."""
        lo, hi = 0.0, self.sa[0]
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            ok = self.trace(np.array([0.0, mid, 0.0]),
                            np.array([0.0, 0.0, 1.0]), scale) is not None
            lo, hi = (mid, hi) if ok else (lo, mid)
        return lo

    def spot(self, dist, h, n=48):
        """Centroid (x, y) and rms radius on the sensor of the rays from
        the point at `dist` mm in front of the sensor, `h` mm up: a
        coarse grid over the first surface finds where light gets
        through, an n x n grid over that box measures."""
        self.sm.gaps[0].thi = dist - self.track
        self.opm.update_model()
        p0 = np.array([0.0, h, 0.0])
        zq = self.sm.gaps[0].thi

        def rays(xs, ys):
            out = []
            for gy in ys:
                for gx in xs:
                    d = np.array([gx, gy - h, zq])
                    d /= np.linalg.norm(d)
                    q = self.trace(p0, d, self.scale)
                    if q is not None:
                        out.append((gx, gy, q[0], q[1], d[2] ** 3))
            return np.array(out)

        r0 = self.sa[0] * 1.05
        c = (np.arange(16) + 0.5) / 16 * 2 * r0 - r0
        got = rays(c, c)
        step = c[1] - c[0]
        x0, x1 = got[:, 0].min() - step, got[:, 0].max() + step
        y0, y1 = got[:, 1].min() - step, got[:, 1].max() + step
        u = (np.arange(n) + 0.5) / n
        got = rays(x0 + u * (x1 - x0), y0 + u * (y1 - y0))
        w = got[:, 4]
        cx, cy = np.average(got[:, 2], weights=w), \
            np.average(got[:, 3], weights=w)
        r2 = (got[:, 2] - cx) ** 2 + (got[:, 3] - cy) ** 2
        reach = math.sqrt(r2.max())
        return cx, cy, math.sqrt(np.average(r2, weights=w)), reach, len(got)


def render(lensray, tmp, name, f_number, focus_mm, dist, h, radius_mm,
           centre, reach, pitch):
    """The rendered blur's (polar second moment in mm^2, centroid (x, y)
    in mm on the sensor, share of its light on the region's border)."""
    # A frame centred on the axis, large enough to hold the spot; only a
    # region around where ray-optics puts it is rendered.
    half = int(math.ceil(1.25 * reach / pitch)) + 4
    sx, sy = centre
    # Film x runs against the sensor's x, film y with the sensor's y, as
    # camera_lens.c's lens_start maps them (the picture comes out upright).
    W = 2 * (int(abs(sx) / pitch) + half + 2)
    H = 2 * (int(abs(sy) / pitch) + half + 2)
    fx, fy = W / 2 - sx / pitch, H / 2 + sy / pitch
    reg = [int(fx) - half, int(fy) - half, int(fx) + half + 1,
           int(fy) + half + 1]
    cam = {"model": "lens", "lens": name, "position": [0, 0, 0],
           "look_at": [0, 0, -1], "up": [0, 1, 0],
           "sensor_width_mm": W * pitch, "focus_distance": focus_mm / 1000,
           "chromatic": {"mode": "off"}}
    if f_number is not None:
        cam["f_number"] = f_number
    scene = {"render": {"width": W, "height": H, "spp": SPP,
                        "max_depth": 0, "adaptive": False, "region": reg},
             "camera": cam, "materials": {"w": {"diffuse": 1}},
             "lights": [{"type": "ambient", "radiance": 1}],
             "objects": [{"type": "sphere",
                          "center": [0, h / 1000, -dist / 1000],
                          "radius": radius_mm / 1000, "material": "w"}]}
    path = os.path.join(tmp, "spot.json")
    json.dump(scene, open(path, "w"))
    out = os.path.join(tmp, "spot.exr")
    subprocess.run([lensray, "render", path, "-o", out, "--quiet"],
                   check=True)
    img = read_exr(out)
    # The EXR places the region's pixels (its data window) in the whole
    # frame (its display window); read_exr returns the frame.
    v = img["R"] + img["G"] + img["B"]
    assert v.shape == (H, W), v.shape
    v = v[reg[1]:reg[3], reg[0]:reg[2]]
    tot = v.sum()
    border = (v[0].sum() + v[-1].sum() + v[1:-1, 0].sum() +
              v[1:-1, -1].sum()) / tot
    yy, xx = np.mgrid[reg[1]:reg[3], reg[0]:reg[2]] + 0.5
    # Film pixels to sensor mm (camera_lens.c, lens_start).
    xs, ys = (W / 2 - xx) * pitch, (yy - H / 2) * pitch
    cx, cy = (v * xs).sum() / tot, (v * ys).sum() / tot
    m2 = (v * ((xs - cx) ** 2 + (ys - cy) ** 2)).sum() / tot
    return m2, (cx, cy), border


def run(lensray):
    """Prints a line per case and the worst difference; returns (passed,
    failed)."""
    passed = failed = 0
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for name, fn, focus, dist, h in CASES:
            lens = Lens(name, fn, focus)
            cx, cy, rms, reach, nrays = lens.spot(dist, h)
            # The sphere: its image a disk of about SPHERE_PX pixels'
            # radius; its exact radius a is the centroid's move per mm of
            # the point's height, times the sphere's radius.
            pitch = reach / SPOT_PX
            mag = abs(lens.spot(dist, h + 1.0, 16)[1] - cy)
            radius = SPHERE_PX * pitch / mag
            a = radius * mag
            m2, (gx, gy), border = render(lensray, tmp, name, fn, focus,
                                          dist, h, radius, (cx, cy), reach,
                                          pitch)
            m2 -= 2 * pitch ** 2 / 12 + a * a / 2
            got = math.sqrt(m2)
            e = got / rms - 1
            worst = max(worst, abs(e))
            problems = []
            if abs(e) > TOLERANCE:
                problems.append("rms radius off by %+.2f%%" % (100 * e))
            if border > 1e-3:
                problems.append("%.2g of the light on the region's border"
                                % border)
            label = "%s %s, focus %g mm, point %g mm, %+g mm up" % (
                name, "f/%g" % fn if fn else "wide open", focus, dist, h)
            print("%-62s %s  rms %.5f mm rendered, %.5f mm ray-optics "
                  "(%+.2f%%; %d rays); centroid %.4f, %.4f vs %.4f, %.4f mm"
                  % (label, "ok" if not problems else "FAIL", got, rms,
                     100 * e, nrays, gx, gy, cx, cy))
            for p in problems:
                print("    " + p)
            if problems:
                failed += 1
            else:
                passed += 1
    print("worst rms difference %.2f%%" % (100 * worst))
    return passed, failed


def main():
    passed, failed = run(sys.argv[1])
    print("%d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
