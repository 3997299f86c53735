#!/usr/bin/env python3
"""speed.py: the path-traced Cornell box (scenes.py), lensray against
Mitsuba 3 `llvm_ad_rgb` with its `path` integrator, side by side in one run.

Both render the same scene description at 128 x 128, max_depth 6 here
(Mitsuba's 8: the same paths; --depth 64, Mitsuba's 66, for full-length
paths, which only Russian roulette ends: both play it from the fifth
surface on, survival min(0.95, max throughput x eta^2), lensray's path.c
and Mitsuba's default rr_depth 5).  Reported, not asserted:
  * samples per second: W H spp / t at --spp and 2 --spp, the rate from
    the difference (so start-up, scene build and Mitsuba's kernel
    compilation drop out), best of --repeat;
  * time to a relative MSE of 1e-4, mean((x - r)^2 / (r^2 + 0.01)) against
    a Mitsuba reference at --ref-spp (a separate seed): each renderer at
    spp 4, 8, ..., until it gets there, timed; the time interpolated
    log-log between the two spp that straddle 1e-4.  lensray runs with its
    adaptive sampling on (threshold --threshold, spp as the cap), Mitsuba
    with its independent sampler (Dr.Jit's default).

Every time is taken twice: wall clock and CPU time (all threads, user +
system: the renderer's own process for Mitsuba, the child's for lensray),
which other work on a shared machine inflates far less.  The summary's
rate_ratio and time_ratio are wall-clock; cpu_rate_ratio and
cpu_time_ratio the same from CPU time.

Prints "PATHSPEED {json}" lines: one per renderer and a summary per
lensray (with --lensray-base, a second lensray measured in the same run:
a change against the binary before it, under the same load).
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


def rnd(x):
    return None if x is None else round(x, 2)


def rel_mse(x, r):
    return float((((x - r) ** 2) / (r * r + 0.01)).mean())


def children_cpu():
    t = os.times()
    return t.children_user + t.children_system


def hit_time(pts, k):
    """The time (column k of pts' (spp, wall, cpu, error) rows) at which
    the error reaches TARGET, interpolated log-log; None if it never
    does."""
    if pts and pts[0][3] <= TARGET:
        return pts[0][k]
    for p0, p1 in zip(pts, pts[1:]):
        e0, e1 = p0[3], p1[3]
        if e0 > TARGET >= e1 and e1 > 0:
            f = (math.log(e0) - math.log(TARGET)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(p0[k]) + f * (math.log(p1[k]) - math.log(p0[k])))
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--lensray', default='build/lensray')
    ap.add_argument('--lensray-base', default=None,
                    help='a second lensray (e.g. built from an older commit), '
                         'measured in the same run as "lensray_base"')
    ap.add_argument('--out', default='build/bench/path')
    ap.add_argument('--lensray-set', action='append', default=[],
                    metavar='KEY=VALUE',
                    help='a --set for every lensray render, e.g. '
                         'accel.robust=false (Mitsuba traces without '
                         'robust traversal)')
    ap.add_argument('--scene', default='cornell', choices=sorted(scenes.SPEED_SCENES),
                    help='the Cornell box (the issue\'s scene), it with the '
                         'bunny, traced with Embree, or lit by a sphere lamp')
    ap.add_argument('--size', type=int, default=128)
    ap.add_argument('--depth', type=int, default=6,
                    help="lensray's max_depth (0 to 64); Mitsuba's is this + 2")
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
    sc = scenes.SPEED_SCENES[a.scene]
    W = H = a.size

    def mitsuba(spp, seed=0):
        scene = mi.load_dict(scenes.mitsuba_dict(mi, sc, W, H, spp, a.depth,
                                                 seed=seed))
        t, c = time.time(), time.process_time()
        img = np.array(mi.render(scene, spp=spp, seed=seed),
                       dtype=np.float64)[..., :3]
        return img, time.time() - t, time.process_time() - c

    def lensray(spp, adaptive, binary=a.lensray):
        path = os.path.join(a.out, a.scene + '.json')
        extra = {'adaptive': adaptive}
        with open(path, 'w') as f:
            json.dump(scenes.lensray_json(sc, W, H, spp, a.depth, extra), f)
        exr = os.path.join(a.out, a.scene + '-lensray.exr')
        t, c = time.time(), children_cpu()
        sets = [x for kv in a.lensray_set for x in ('--set', kv)]
        subprocess.run([binary, 'render', path, '-o', exr, '-q'] + sets,
                       check=True)
        dt, dc = time.time() - t, children_cpu() - c
        return np.array(mi.Bitmap(exr), dtype=np.float64)[..., :3], dt, dc

    # The reference, in passes of 512 spp with different seeds, kept as two
    # halves: their difference measures the reference's own noise, which
    # adds to every measured error (E (x - r)^2 = E (x - t)^2 + E (r - t)^2)
    # and is subtracted.
    ref_path = os.path.join(a.out, 'ref2-%s%d-%d-%d.npz' % (
        '' if a.scene == 'cornell' else a.scene + '-', W, a.depth, a.ref_spp))
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
    # Each renderer in turn, the base lensray (if any) between the two, so
    # that a change is measured against the same Mitsuba run.
    names = ['lensray'] + (['lensray_base'] if a.lensray_base else []) + \
        ['mitsuba_llvm_ad_rgb']
    binary = {'lensray': a.lensray, 'lensray_base': a.lensray_base}
    out = {}
    for name in names:
        if name == 'mitsuba_llvm_ad_rgb':
            fn = mitsuba
        else:
            fn = (lambda b: lambda s: lensray(s, False, b))(binary[name])
        # Best of --repeat, wall and CPU each.
        r1 = [fn(a.spp)[1:] for _ in range(a.repeat)]
        r2 = [fn(4 * a.spp)[1:] for _ in range(a.repeat)]
        res = {}
        for key, k in (('', 0), ('cpu_', 1)):
            t1, t2 = min(r[k] for r in r1), min(r[k] for r in r2)
            # The difference drops start-up and kernel compilation; on a
            # busy machine it can come out <= 0, and then only the plain
            # rate at 4 x spp is reported.
            rate = W * H * 3 * a.spp / (t2 - t1) if t2 > t1 else None
            res[key + 'samples_per_s'] = None if rate is None else round(rate)
            res[key + 'plain_samples_per_s'] = round(W * H * 4 * a.spp / t2)
        out[name] = res

    adaptive = {'threshold': a.threshold}
    for name in names:
        if name == 'mitsuba_llvm_ad_rgb':
            fn = mitsuba
        else:
            fn = (lambda b: lambda s: lensray(s, adaptive, b))(binary[name])
        pts = []
        spp = 4
        while spp <= a.max_spp:
            img, t, c = fn(spp)
            e = rel_mse(img, ref) - ref_noise
            pts.append((spp, t, c, e))
            if e <= TARGET:
                break
            spp *= 2
        out[name].update({'seconds_to_relmse_1e-4': rnd(hit_time(pts, 1)),
                          'cpu_seconds_to_relmse_1e-4': rnd(hit_time(pts, 2)),
                          'curve': [[s, round(t, 3), round(c, 3), float('%.3g' % e)]
                                    for s, t, c, e in pts]})
        print('PATHSPEED ' + json.dumps(dict(renderer=name, **out[name])), flush=True)

    M = out['mitsuba_llvm_ad_rgb']
    for name in names[:-1]:
        summarise(a, W, H, ref_noise, name, out[name], M)


def summarise(a, W, H, ref_noise, name, L, M):
    """Prints the summary line of lensray `name` (L) against Mitsuba (M)."""
    summary = {'lensray': name, 'scene': '%s (bench/path/scenes.py)' % a.scene,
               'size': [W, H], 'load_average': [round(x, 2) for x in os.getloadavg()],
               'max_depth': a.depth, 'mitsuba_max_depth': a.depth + 2,
               'ref_spp': a.ref_spp, 'ref_relmse': float('%.3g' % ref_noise),
               'lensray_adaptive_threshold': a.threshold,
               'curve_columns': ['spp', 'wall_s', 'cpu_s', 'relmse'],
               'plain_rate_ratio': round(L['plain_samples_per_s'] / M['plain_samples_per_s'], 3)}
    for p in ('', 'cpu_'):
        if L[p + 'samples_per_s'] and M[p + 'samples_per_s']:
            summary[p + 'rate_ratio'] = round(L[p + 'samples_per_s'] / M[p + 'samples_per_s'], 3)
        k = p + 'seconds_to_relmse_1e-4'
        if L[k] and M[k]:
            summary[p + 'time_ratio'] = round(M[k] / L[k], 3)
    print('PATHSPEED ' + json.dumps(summary), flush=True)


if __name__ == '__main__':
    sys.exit(main())
