#!/usr/bin/env python3
"""lens.py: the real-lens camera against the thin lens on the bench scene.

Usage: python3 bench/lens.py LENSRAY SCENE [--spp N] [--turns K]

Every sample traced (render.plan and render.adaptive off), one thread:
the thin lens of the scene and the shipped double Gauss at f/2.8, run in
turns, the two back to back and their order swapped every turn, so that
both see the same machine; each render's CPU time is taken from --stats.
The ratio is the median over the turns of each turn's ratio of samples
per CPU second (issue 30's measure), printed with its range; the rates
are each side's median.  Also the share of camera rays the lens stops
(lens_blocked), on axis (a 16 x 16 crop at the centre) at full aperture
and at f/2.8, and over the whole frame.

Prints "LENS key=value ..." lines for bench/summary.py and a short table.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile

LENS = ['--set', 'camera.model="lens"', '--set', 'camera.lens="double-gauss-50"']
FULL = ['--set', 'render.plan=false', '--set', 'render.adaptive=false',
        '--set', 'render.threads=1']


TMP = tempfile.mkdtemp(prefix='lensray-bench-lens-')


def stats(lensray, scene, extra):
    out = subprocess.run([lensray, 'render', scene, '-o', os.path.join(TMP, 'x.exr'), '--quiet',
                          '--stats'] + FULL + extra, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit('lens.py: lensray failed: ' + out.stderr.strip())
    return json.loads([l for l in out.stdout.splitlines() if l.startswith('{')][0])


def main():
    args = sys.argv[1:]
    if len(args) < 2:
        sys.exit(__doc__)
    lensray, scene = args[0], args[1]
    spp, turns = 64, 5
    if '--spp' in args:
        spp = int(args[args.index('--spp') + 1])
    if '--turns' in args:
        turns = int(args[args.index('--turns') + 1])
    common = ['--set', 'render.spp=%d' % spp]
    rates = {'thin': [], 'lens': []}
    ratios = []
    runs = [('thin', []), ('lens', LENS + ['--set', 'camera.f_number=2.8'])]
    for turn in range(turns):
        got = {}
        for name, extra in (runs if turn % 2 == 0 else runs[::-1]):
            st = stats(lensray, scene, common + extra)
            got[name] = st['samples'] / st['cpu_seconds']
            rates[name].append(got[name])
        ratios.append(got['lens'] / got['thin'])
    rate = {k: statistics.median(v) for k, v in rates.items()}
    ratio = statistics.median(ratios)
    centre = ['--set', 'render.region=[312,232,328,248]']
    lost = {}
    for label, fn, extra in (('axis_open', 0, centre), ('axis_f2.8', 2.8, centre),
                             ('frame_open', 0, []), ('frame_f2.8', 2.8, [])):
        st = stats(lensray, scene, ['--set', 'render.spp=16'] + LENS +
                   ['--set', 'camera.f_number=%g' % fn] + extra)
        p = st['plan']
        lost[label] = p.get('lens_blocked', 0) / max(p['camera_rays'], 1)
    print('LENS thin_samples_per_second=%.0f lens_samples_per_second=%.0f ratio=%.3f '
          'ratio_lo=%.3f ratio_hi=%.3f turns=%d spp=%d %s'
          % (rate['thin'], rate['lens'], ratio, min(ratios), max(ratios), turns, spp,
             ' '.join('lost_%s=%.4f' % kv for kv in lost.items())))
    print('  thin lens          %6.2f M samples/s (median CPU rate of %d turns)'
          % (rate['thin'] / 1e6, turns))
    print('  double Gauss f/2.8 %6.2f M samples/s: %.2f of the thin lens '
          '(median of the turns\' ratios; %.2f to %.2f)'
          % (rate['lens'] / 1e6, ratio, min(ratios), max(ratios)))
    print('  rays the lens stops: on axis %.1f%% open, %.1f%% at f/2.8; '
          'over the frame %.1f%% open, %.1f%% at f/2.8' %
          (100 * lost['axis_open'], 100 * lost['axis_f2.8'],
           100 * lost['frame_open'], 100 * lost['frame_f2.8']))


if __name__ == '__main__':
    try:
        main()
    finally:
        for f in os.listdir(TMP):
            os.unlink(os.path.join(TMP, f))
        os.rmdir(TMP)
