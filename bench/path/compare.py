#!/usr/bin/env python3
"""compare.py: the path integrator against Mitsuba 3's `path`, same scene
description (scenes.py), both at high spp.

For each scene: lensray renders with the CLI, Mitsuba with --variant; the
images are cut into 16 x 16 blocks and for each block and channel the
relative difference of the block means, |A - B| / B, is taken (block means,
so that the two renderers' remaining noise, ~1/16 of a pixel's, does not
count as a difference).  Reported: the mean of these over all blocks
(target < 1%) and their 90th percentile (target < 3%), plus the whole
image's mean relative difference sum|a - b| / sum b, noise included.

Prints one line per scene, "PATHCMP {json}", and writes both images as EXR
under --out.  Exit status 1 if a target is missed.
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scenes  # noqa: E402


def block_stats(a, b, k=16):
    import numpy as np
    h, w, _ = a.shape
    hb, wb = h // k, w // k
    A = a[:hb * k, :wb * k].reshape(hb, k, wb, k, 3).mean(axis=(1, 3))
    B = b[:hb * k, :wb * k].reshape(hb, k, wb, k, 3).mean(axis=(1, 3))
    ok = B > 1e-3 * B.mean()  # blocks of a channel that is black in both
    rel = np.abs(A - B)[ok] / B[ok]
    return float(rel.mean()), float(np.percentile(rel, 90))


def render_lensray(binary, sc, w, h, spp, depth, out_dir):
    path = os.path.join(out_dir, sc['name'] + '.json')
    with open(path, 'w') as f:
        json.dump(scenes.lensray_json(sc, w, h, spp, depth), f, indent=1)
    exr = os.path.join(out_dir, sc['name'] + '-lensray.exr')
    t = time.time()
    subprocess.run([binary, 'render', path, '-o', exr, '-q'], check=True)
    return exr, time.time() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--lensray', default='build/lensray')
    ap.add_argument('--variant', default='scalar_rgb')
    ap.add_argument('--out', default='build/path-compare')
    ap.add_argument('--width', type=int, default=128)
    ap.add_argument('--height', type=int, default=128)
    ap.add_argument('--spp', type=int, default=1024)
    ap.add_argument('--depth', type=int, default=6, help='ours; Mitsuba +2')
    ap.add_argument('--scenes', default='cornell,envlit')
    a = ap.parse_args()

    import mitsuba as mi
    import numpy as np
    mi.set_variant(a.variant)
    os.makedirs(a.out, exist_ok=True)
    env = os.path.join(a.out, 'sky.exr')
    mi.Bitmap(scenes.sky()).write(env)
    failed = False
    for name in a.scenes.split(','):
        sc = scenes.SCENES[name]
        exr, t_ours = render_lensray(a.lensray, sc, a.width, a.height, a.spp,
                                     a.depth, a.out)
        ours = np.array(mi.Bitmap(exr), dtype=np.float64)[..., :3]
        scene = mi.load_dict(scenes.mitsuba_dict(mi, sc, a.width, a.height,
                                                 a.spp, a.depth, env))
        t = time.time()
        img = mi.render(scene, spp=a.spp)
        ref = np.array(img, dtype=np.float64)[..., :3]
        t_mi = time.time() - t
        mi.Bitmap(ref.astype(np.float32)).write(
            os.path.join(a.out, name + '-mitsuba.exr'))
        mean_blk, p90 = block_stats(ours, ref)
        whole = float(np.abs(ours - ref).sum() / ref.sum())
        ratio = (ours.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0))
        ok = mean_blk < 0.01 and p90 < 0.03
        failed |= not ok
        print('PATHCMP ' + json.dumps({
            'scene': name, 'size': [a.width, a.height], 'spp': a.spp,
            'max_depth': a.depth, 'mitsuba_max_depth': a.depth + 2,
            'variant': a.variant,
            'block_mean_rel': round(mean_blk, 5), 'block_p90_rel': round(p90, 5),
            'pixel_mean_rel': round(whole, 5),
            'mean_ratio_rgb': [round(float(x), 5) for x in ratio],
            'seconds_lensray': round(t_ours, 2), 'seconds_mitsuba': round(t_mi, 2),
            'pass': ok}), flush=True)
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
