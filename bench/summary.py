#!/usr/bin/env python3
"""summary.py: the table of `make bench`, from the logs bench/run.sh wrote.

Usage: python3 bench/summary.py BUILD/bench

Reads machine.log, ceiling.log, lensray.log, mitsuba.log, compare.log and
busy.log in that directory and prints the summary (run.sh also writes it
to results.txt).  Standard library only.

Which lensray figure is which:
  * "every sample traced" is render.plan=false, render.adaptive=false:
    each of the W x H x spp samples is a camera ray plus (where it hits a
    lit surface) a shadow ray, the same work as the ceiling's and Mitsuba's
    samples.  The targets are checked with this one.
  * "as shipped" is the scene's defaults (effect planning and adaptive
    sampling on): its "samples/s" counts the samples actually taken, and
    its "effective" rate is W x H x spp divided by the time, the rate at
    which it delivers a picture of that many samples per pixel.
"""
import json
import os
import statistics
import sys

TARGET_MITSUBA = 1.25
TARGET_CEILING = 0.60
TARGET_SCALING = 1.9
TARGET_IMAGE = 0.02


def read(d, name):
    try:
        with open(os.path.join(d, name)) as f:
            return f.read().splitlines()
    except OSError:
        return []


def kv(line):
    out = {}
    for part in line.split()[1:]:
        if '=' in part:
            k, v = part.split('=', 1)
            try:
                out[k] = float(v)
            except ValueError:
                out[k] = v
    return out


def m(x):
    return '%.1f' % (x / 1e6) if x else '-'


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else 'build/bench'
    lines = []
    p = lines.append
    machine = read(d, 'machine.log')
    info = dict(l.split(': ', 1) for l in machine if ': ' in l)
    nproc = int(info.get('nproc', '1'))

    # ---- ceiling
    ceil = {}
    results = []
    for l in read(d, 'ceiling.log'):
        if l.startswith('CEILING '):
            c = kv(l)
            ceil[int(c['threads'])] = c
        elif l.startswith('RESULT '):
            results.append(kv(l))
    r16 = {int(r['threads']): r for r in results
           if r.get('api') == '16' and r.get('order') == 'block'}

    # ---- lensray
    runs = {}
    for l in read(d, 'lensray.log'):
        if not l.startswith('LENSRAY '):
            continue
        head, js = l.split(' {', 1)
        h = kv(head)
        s = json.loads('{' + js)
        full = s.get('plan', {}).get('full_samples') or s['width'] * s['height'] * s['spp']
        s['effective'] = full / s['seconds'] if s['seconds'] > 0 else 0.0
        runs.setdefault((h['mode'], int(h['threads'])), []).append(s)

    def best(mode, t, key='samples_per_second'):
        rs = runs.get((mode, t))
        if not rs:
            return None
        b = max(rs, key=lambda s: s['samples_per_second'])
        return b

    def med(mode, t):
        rs = runs.get((mode, t))
        return statistics.median(s['samples_per_second'] for s in rs) if rs else None

    # ---- Mitsuba
    mits = {}
    mits_msgs = []
    for l in read(d, 'mitsuba.log'):
        if l.startswith('MITSUBA '):
            j = json.loads(l[len('MITSUBA '):])
            mits[j['variant']] = j
        elif l.startswith('MITSUBA_FAILED') or l.startswith('MITSUBA_UNAVAILABLE'):
            mits_msgs.append(l.split(' ', 1)[1] if ' ' in l else l)

    comps = [json.loads(l[len('COMPARE '):]) for l in read(d, 'compare.log')
             if l.startswith('COMPARE ')]
    busy = [l.split() for l in read(d, 'busy.log')]

    # ---- print
    p('lensray benchmark: scenes/bench.json, 640 x 480, thin lens (r 0.5, focus 30), '
      '3 bunnies + ground (11,024 triangles), 1 point light, direct light + 1 shadow ray')
    for k in ('date', 'commit', 'cpu', 'nproc', 'memory', 'os', 'embree', 'cc', 'llvm', 'spp'):
        if k in info:
            p('  %-8s %s' % (k + ':', info[k]))
    hot = [(what, float(bc)) for what, bc in busy if float(bc) >= 0.25]
    if hot:
        p('  WARNING: other processes kept %s busy: these figures are pessimistic'
          % ', '.join('%.2f cores before %s' % (bc, w) for w, bc in hot))
    p('')
    T = nproc
    p('%-44s %14s %14s %9s' % ('', '1 thread', '%d threads' % T, 'scaling'))
    p('%-44s %14s %14s %9s' % ('', 'M samples/s', 'M samples/s', ''))

    def row(name, a, b, extra=''):
        sc = '%.2fx' % (b / a) if a and b else ''
        p('%-44s %14s %14s %9s%s' % (name, m(a), m(b), sc, extra))

    c1, cN = ceil.get(1), ceil.get(T)
    if c1:
        row('bare Embree ceiling (camera + shadow ray)', c1['msamples_s'] * 1e6,
            cN['msamples_s'] * 1e6 if cN else None)
    else:
        p('bare Embree ceiling: FAILED (see ceiling.log)')
    full1, fullN = best('full', 1), best('full', T)
    def1, defN = best('default', 1), best('default', T)
    if full1 or fullN:
        row('lensray, every sample traced',
            full1 and full1['samples_per_second'], fullN and fullN['samples_per_second'])
    if def1 or defN:
        row('lensray as shipped (samples taken)',
            def1 and def1['samples_per_second'], defN and defN['samples_per_second'])
        row('lensray as shipped (effective W*H*spp/s)',
            def1 and def1['effective'], defN and defN['effective'])
    for v in ('llvm_ad_rgb', 'scalar_rgb'):
        if v in mits:
            j = mits[v]
            row('Mitsuba %s %s (time per extra sample)' % (j['mitsuba'], v), None,
                j['samples_per_second'],
                '   (plain %s at %d spp; %s threads)' % (m(j['samples_per_second_plain']),
                                                         j['spp'], j['threads']))
    for msg in mits_msgs:
        p('Mitsuba: not available (%s)' % msg)
    p('')

    # details
    if c1:
        p('ceiling details (ns per ray per core; M rays/s):')
        for t, c in sorted(ceil.items()):
            p('  %d thread(s): camera %s %.2f ns (%.1f M rays/s), shadow %s %.2f ns; '
              'camera + shadow %.2f ns per sample per core'
              % (t, c['camera_api'], c['camera_ns_per_ray_core'], c['camera_mrays_s'],
                 c['shadow_api'], c['shadow_ns_per_ray_core'], c['sample_ns_core']))
        for t, r in sorted(r16.items()):
            p('  %d thread(s), rtcIntersect16 + rtcOccluded16, 4x4-pixel packets: camera '
              '%.2f ns (%.1f M rays/s), camera + shadow %.2f ns per sample per core '
              '(%.1f M samples/s)' % (t, r['camera_ns_per_ray_core'], r['camera_mrays_s'],
                                      r['sample_ns_core'], r['msamples_s']))
    for (mode, t), rs in sorted(runs.items()):
        b = best(mode, t)
        p('lensray %-7s %d thread(s): best %s M samples/s (median %s, %d runs), '
          '%s M rays/s, %.2f s, %s samples of %s'
          % (mode, t, m(b['samples_per_second']), m(med(mode, t)), len(rs),
             m(b['rays_per_second']), b['seconds'], b['samples'],
             b.get('plan', {}).get('full_samples', b['samples'])))
    p('')

    # ratios and targets
    checks = []
    ours = fullN or defN
    ours_name = 'every sample traced' if fullN else 'as shipped'
    if ours and cN:
        r = ours['samples_per_second'] / (cN['msamples_s'] * 1e6)
        p('lensray (%s) / ceiling, %d threads: %.2f' % (ours_name, T, r))
        checks.append(('lensray >= %d%% of the bare Embree ceiling' % (TARGET_CEILING * 100),
                       r >= TARGET_CEILING, '%.0f%%' % (100 * r)))
    if full1 and c1:
        p('lensray (every sample traced) / ceiling, 1 thread: %.2f'
          % (full1['samples_per_second'] / (c1['msamples_s'] * 1e6)))
    for v in ('llvm_ad_rgb', 'scalar_rgb'):
        if v in mits and ours:
            r = ours['samples_per_second'] / mits[v]['samples_per_second']
            p('lensray (%s) / Mitsuba %s: %.2fx' % (ours_name, v, r))
            if defN and fullN:
                p('lensray (as shipped, effective) / Mitsuba %s: %.2fx'
                  % (v, defN['effective'] / mits[v]['samples_per_second']))
            if v == 'llvm_ad_rgb':
                checks.append(('lensray >= %.2fx Mitsuba llvm_ad_rgb' % TARGET_MITSUBA,
                               r >= TARGET_MITSUBA, '%.2fx' % r))
    s1, sN = full1 or def1, fullN or defN
    if s1 and sN and T > 1:
        r = sN['samples_per_second'] / s1['samples_per_second']
        checks.append(('%d threads >= %.1fx 1 thread' % (T, TARGET_SCALING),
                       r >= TARGET_SCALING, '%.2fx' % r))
    for c in comps:
        p('%s: mean relative difference %.2f%% (median %.2f%%, %.1f%% of pixels over 5%%), '
          'image means %s%% apart (R G B)'
          % (c['label'], 100 * c['mean_rel'], 100 * c['median_rel'],
             100 * c['frac_over_5pct'],
             ' '.join('%+.3f' % (100 * x) for x in c['image_mean_rel_rgb'])))
        if c['label'].startswith('lensray vs Mitsuba'):
            checks.append(('same picture as Mitsuba: mean relative difference < %d%%'
                           % (TARGET_IMAGE * 100), c['mean_rel'] < TARGET_IMAGE,
                           '%.2f%%' % (100 * c['mean_rel'])))
    p('')
    p('targets:')
    for name, ok, val in checks:
        p('  [%s] %-60s %s' % ('PASS' if ok else 'FAIL', name, val))
    if not checks:
        p('  (nothing measured)')
    print('\n'.join(lines))


if __name__ == '__main__':
    main()
