#!/usr/bin/env python3
"""speed.py: the path-traced Cornell box (scenes.py), lensray against
Mitsuba 3 `llvm_ad_rgb` with its `path` integrator, side by side in one run.

Both render the same scene description at 128 x 128, max_depth 6 here
(Mitsuba's 8: the same paths).  Reported, not asserted:
  * samples per second: W H spp / t at --spp and 2 --spp, the rate from
    the difference (so start-up, scene build and Mitsuba's kernel
    compilation drop out), best of --repeat;
  * time to a relative MSE of 1e-4, mean((x - r)^2 / (r^2 + 0.01)) against
    a Mitsuba reference at --ref-spp (a separate seed): each renderer at
    spp 4, 8, ..., until it gets there, timed; the time interpolated
    log-log between the two spp that straddle 1e-4.  lensray runs with its
    adaptive sampling on (threshold --threshold, spp as the cap), Mitsuba
    with its independent sampler (Dr.Jit's default).

Prints "PATHSPEED {json}" lines: one per renderer and a summary.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scenes  # noqa: E402

TARGET = 1e-4


def rel_mse(x, r):
    return float((((x - r) ** 2) / (r * r + 0.01)).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--lensray', default='build/lensray')
    ap.add_argument('--out', default='build/bench/path')
    ap.add_argument('--size', type=int, default=128)
    ap.add_argument('--depth', type=int, default=6)
    ap.add_argument('--spp', type=int, default=64, help='timing spp')
    ap.add_argument('--repeat', type=int, default=2)
    ap.add_argument('--ref-spp', type=int, default=8192)
    ap.add_argument('--max-spp', type=int, default=4096)
    ap.add_argument('--threshold', type=float, default=0.003,
                    help="lensray's adaptive threshold (its default, 0.01, "
                         "stops pixels near a relative MSE of 1e-4)")
    a = ap.parse_args()

    import mitsuba as mi
    import numpy as np
    mi.set_variant('llvm_ad_rgb')
    os.makedirs(a.out, exist_ok=True)
    sc = scenes.CORNELL
    W = H = a.size

    def mitsuba(spp, seed=0):
        scene = mi.load_dict(scenes.mitsuba_dict(mi, sc, W, H, spp, a.depth,
                                                 seed=seed))
        t = time.time()
        img = np.array(mi.render(scene, spp=spp, seed=seed),
                       dtype=np.float64)[..., :3]
        return img, time.time() - t

    def lensray(spp, adaptive):
        path = os.path.join(a.out, 'cornell.json')
        extra = {'adaptive': adaptive}
        with open(path, 'w') as f:
            json.dump(scenes.lensray_json(sc, W, H, spp, a.depth, extra), f)
        exr = os.path.join(a.out, 'cornell-lensray.exr')
        t = time.time()
        subprocess.run([a.lensray, 'render', path, '-o', exr, '-q'],
                       check=True)
        dt = time.time() - t
        return np.array(mi.Bitmap(exr), dtype=np.float64)[..., :3], dt

    # The reference, in passes of 512 spp with different seeds, kept as two
    # halves: their difference measures the reference's own noise, which
    # adds to every measured error (E (x - r)^2 = E (x - t)^2 + E (r - t)^2)
    # and is subtracted.
    ref_path = os.path.join(a.out, 'ref2-%d-%d-%d.npz' % (W, a.depth, a.ref_spp))
    if os.path.exists(ref_path):
        z = np.load(ref_path)
        half_a, half_b = z['a'], z['b']
    else:
        passes = max(2, a.ref_spp // 512) // 2
        half_a = sum(mitsuba(512, seed=1000 + k)[0] for k in range(passes)) / passes
        half_b = sum(mitsuba(512, seed=2000 + k)[0] for k in range(passes)) / passes
        np.savez(ref_path, a=half_a, b=half_b)
    ref = (half_a + half_b) / 2
    # Var(ref) = Var(half) / 2 and E (a - b)^2 = 2 Var(half) = 4 Var(ref).
    ref_noise = rel_mse(half_a, half_b) / 4

    mitsuba(4)  # compiles the kernel
    out = {}
    for name, fn in (('lensray', lambda s: lensray(s, False)),
                     ('mitsuba_llvm_ad_rgb', lambda s: mitsuba(s))):
        t1 = min(fn(a.spp)[1] for _ in range(a.repeat))
        t2 = min(fn(4 * a.spp)[1] for _ in range(a.repeat))
        # The difference drops start-up and kernel compilation; on a busy
        # machine it can come out <= 0, and then only the plain rate at
        # 4 x spp is reported.
        rate = W * H * 3 * a.spp / (t2 - t1) if t2 > t1 else None
        plain = W * H * 4 * a.spp / t2
        out[name] = {'samples_per_s': None if rate is None else round(rate),
                     'plain_samples_per_s': round(plain)}

    for name, fn in (('lensray', lambda s: lensray(s, {'threshold': a.threshold})),
                     ('mitsuba_llvm_ad_rgb', lambda s: mitsuba(s))):
        pts = []
        spp = 4
        while spp <= a.max_spp:
            img, t = fn(spp)
            e = rel_mse(img, ref) - ref_noise
            pts.append((spp, t, e))
            if e <= TARGET:
                break
            spp *= 2
        t_hit = None
        for (s0, t0, e0), (s1, t1, e1) in zip(pts, pts[1:]):
            if e0 > TARGET >= e1:
                f = (math.log(e0) - math.log(TARGET)) / (math.log(e0) - math.log(e1))
                t_hit = math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
        if pts and pts[0][2] <= TARGET:
            t_hit = pts[0][1]
        out[name].update({'seconds_to_relmse_1e-4': None if t_hit is None else round(t_hit, 2),
                          'curve': [[s, round(t, 3), float('%.3g' % e)] for s, t, e in pts]})
        print('PATHSPEED ' + json.dumps(dict(renderer=name, **out[name])), flush=True)

    L, M = out['lensray'], out['mitsuba_llvm_ad_rgb']
    summary = {'scene': 'cornell (bench/path/scenes.py)', 'size': [W, H],
               'max_depth': a.depth, 'mitsuba_max_depth': a.depth + 2,
               'ref_spp': a.ref_spp, 'ref_relmse': float('%.3g' % ref_noise),
               'lensray_adaptive_threshold': a.threshold,
               'plain_rate_ratio': round(L['plain_samples_per_s'] / M['plain_samples_per_s'], 3)}
    if L['samples_per_s'] and M['samples_per_s']:
        summary['rate_ratio'] = round(L['samples_per_s'] / M['samples_per_s'], 3)
    if L['seconds_to_relmse_1e-4'] and M['seconds_to_relmse_1e-4']:
        summary['time_ratio'] = round(M['seconds_to_relmse_1e-4'] / L['seconds_to_relmse_1e-4'], 3)
    print('PATHSPEED ' + json.dumps(summary), flush=True)


if __name__ == '__main__':
    sys.exit(main())
