#!/usr/bin/env python3
"""persample.py: lensray against Mitsuba 3 per sample, in interleaved rounds.

Issue 17's per-sample target (every sample traced, at least 1.0x Mitsuba
llvm_ad_rgb) measured so that the machine's drift falls on both sides:
on this shared VM one core's speed moves by up to 30% from one second to
the next, and bench/run.sh's sections (all of lensray's runs, then all of
Mitsuba's, minutes apart) let that drift decide a ratio near 1.

One Python process holds Mitsuba's two scenes (Embree robust traversal
on and off, bench/mitsuba_bench.py's build_scene), compiled and warmed
up once.  Each round then renders, for each pairing, lensray (a
subprocess, every sample traced) and Mitsuba back to back at the same
spp and thread count, the order swapped every other round, and takes
the ratio of the two rates.  A rate is W H spp / render seconds on both
sides: lensray's "seconds" of --stats (the render, not loading or
writing), Mitsuba's mi.render with the image evaluated (the scene is
loaded once, before).  The pairings are like for like:

  both robust     lensray (accel.robust default, true) / Mitsuba robust
  neither robust  lensray accel.robust=false / Mitsuba's default

Prints one line per round and a summary line "PERSAMPLE {json}" with the
per-round ratios and their median, least and largest.  Reported, never
asserted (bench/summary.py prints the median against the target).

Usage (the venv of bench/run.sh, DRJIT_LIBLLVM_PATH set by
bench/mitsuba_env.sh's mitsuba_llvm):
  python bench/persample.py --lensray build/lensray [--rounds 7] [--spp 128]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_bench import build_scene  # noqa: E402

FULL = ['--set', 'render.plan=false', '--set', 'render.adaptive=false']


def lensray_rate(a, robust, seed):
    """Samples per second of one lensray render (render seconds only)."""
    cmd = [a.lensray, 'render', a.scene, '-o', a.tmp, '--quiet', '--stats',
           '--set', 'render.spp=%d' % a.spp, '--set', 'render.threads=%d' % a.threads,
           '--set', 'render.seed=%d' % seed] + FULL
    if not robust:
        cmd += ['--set', 'accel.robust=false']
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    st = json.loads(next(l for l in out.splitlines() if l.startswith('{')))
    if st['samples'] != a.width * a.height * a.spp:
        sys.exit('persample: lensray took %d samples, not every one (%d)'
                 % (st['samples'], a.width * a.height * a.spp))
    return st['samples'] / st['seconds']


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--lensray', required=True)
    ap.add_argument('--scene', default='scenes/bench.json')
    ap.add_argument('--obj', default='scenes/meshes/bunny.obj')
    ap.add_argument('--spp', type=int, default=128)
    ap.add_argument('--rounds', type=int, default=7)
    ap.add_argument('--threads', type=int, default=os.cpu_count())
    ap.add_argument('--tmp', default='build/bench/persample.exr')
    a = ap.parse_args()
    a.width, a.height = 640, 480

    import drjit as dr
    import mitsuba as mi
    mi.set_variant('llvm_ad_rgb')
    dr.set_thread_count(a.threads)
    obj = os.path.abspath(a.obj)
    scenes = {r: build_scene(mi, obj, a.width, a.height, a.spp, 'independent', False, r)
              for r in (True, False)}

    def mitsuba_rate(robust, seed):
        t = time.perf_counter()
        img = mi.render(scenes[robust], spp=a.spp, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        return a.width * a.height * a.spp / (time.perf_counter() - t)

    # Warm-up: Mitsuba compiles its kernels on the first render of each
    # scene; lensray's first run reads the files into the page cache.
    for r in (True, False):
        mitsuba_rate(r, 0)
        lensray_rate(a, r, 0)

    pairings = (('both robust', True), ('neither robust', False))
    res = {'spp': a.spp, 'threads': a.threads, 'rounds': a.rounds,
           'mitsuba': mi.__version__, 'pairings': {}}
    rows = {name: [] for name, _ in pairings}
    for k in range(a.rounds):
        for name, robust in pairings:
            seed = 1 + k
            if k % 2 == 0:
                lr = lensray_rate(a, robust, seed)
                mr = mitsuba_rate(robust, seed)
            else:
                mr = mitsuba_rate(robust, seed)
                lr = lensray_rate(a, robust, seed)
            rows[name].append((lr, mr))
            print('persample: round %d, %s: lensray %.1f, Mitsuba %.1f M samples/s: %.3fx'
                  % (k + 1, name, lr / 1e6, mr / 1e6, lr / mr), flush=True)
    for name, _ in pairings:
        ratios = [lr / mr for lr, mr in rows[name]]
        res['pairings'][name] = {
            'lensray': [round(lr) for lr, _ in rows[name]],
            'mitsuba': [round(mr) for _, mr in rows[name]],
            'ratios': [round(r, 4) for r in ratios],
            'median': statistics.median(ratios),
            'min': min(ratios), 'max': max(ratios)}
    try:
        os.remove(a.tmp)
    except OSError:
        pass
    res['load_average'] = list(os.getloadavg())
    print('PERSAMPLE ' + json.dumps(res))


if __name__ == '__main__':
    main()
