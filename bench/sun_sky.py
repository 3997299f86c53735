#!/usr/bin/env python3
"""sun_sky.py: writes the sky with a sun that lights docs/lenses.md's
landscape ghost picture (bench/ghost_gallery.sh): a latitude-longitude
OpenEXR image, RGB float, uncompressed (docs/gltf-sky.py's writer), from a
formula.

    python3 bench/sun_sky.py OUT.exr [AZIMUTH_DEG ELEVATION_DEG]

The sun is a disc 0.53 degrees across (the real sun's) of radiance SUN,
AZIMUTH degrees right of -z (toward +x) and ELEVATION above the horizon
(default 23, 8); around it a faint aureole, under 1/64 of the sun's
radiance everywhere, so that the library's sun cone (lr__envmap_sun)
holds the disc alone.  Texels are placed as envmap.h says: column x at u
= (x + 1/2) / W, u = atan2(x, -z) / (2 pi); row y at v = y / (H - 1), v =
acos(y) / pi.
"""
import importlib.util
import math
import os
import sys

W, H = 2048, 1024
SUN = 3.0e5  # some 0.5 of the real sun-to-sky radiance ratio
SUN_RADIUS = math.radians(0.265)


def writer():
    here = os.path.dirname(os.path.abspath(__file__))
    spec = importlib.util.spec_from_file_location(
        "gltf_sky", os.path.join(here, "..", "docs", "gltf-sky.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.write_exr


def sky(theta):
    """The sky at polar angle theta (0: zenith): blue overhead, pale at
    the horizon; a dull ground below."""
    if theta > math.pi / 2:
        return (0.05, 0.045, 0.04)
    h = 1 - theta / (math.pi / 2)
    haze = math.exp(-h * 6)
    return (0.15 + 0.55 * haze, 0.3 + 0.5 * haze, 0.75 + 0.2 * haze)


def texel_dir(x, y):
    phi, th = 2 * math.pi * (x + 0.5) / W, math.pi * y / (H - 1)
    return (math.sin(th) * math.sin(phi), math.cos(th),
            -math.sin(th) * math.cos(phi))


def main(path, az, el):
    a, e = math.radians(az), math.radians(el)
    sun = (math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a))
    rows = [[[c] * W for c in sky(math.pi * y / (H - 1))] for y in range(H)]
    # The sun and its aureole: the texels within 3 degrees of it.
    reach = math.radians(3.0)
    y_sun = (math.pi / 2 - e) / math.pi * (H - 1)
    dy = int(math.ceil(reach / math.pi * (H - 1))) + 1
    for y in range(max(0, int(y_sun) - dy), min(H, int(y_sun) + dy + 2)):
        for x in range(W):
            d = texel_dir(x, y)
            c = sum(p * q for p, q in zip(d, sun))
            t = math.acos(max(-1.0, min(1.0, c)))
            if t > reach:
                continue
            glow = 40.0 * math.exp(-t / math.radians(1.0))
            v = SUN if t < SUN_RADIUS else glow
            for k, tint in enumerate((1.0, 0.95, 0.85)):
                rows[y][k][x] += v * tint
    writer()(path, W, H, lambda y: rows[y])


if __name__ == "__main__":
    if len(sys.argv) not in (2, 4):
        sys.exit("usage: sun_sky.py OUT.exr [AZIMUTH_DEG ELEVATION_DEG]")
    az, el = (23.0, 8.0) if len(sys.argv) == 2 else map(float, sys.argv[2:])
    main(sys.argv[1], az, el)
