#!/usr/bin/env python3
"""summary.py: the table of `make bench`, from the logs bench/run.sh wrote.

Usage: python3 bench/summary.py BUILD/bench

Reads machine.log, ceiling.log, lensray.log, mitsuba.log, persample.log,
compare.log, memory.log, python.log and busy.log in that directory and prints the summary (run.sh also writes it
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

Two kinds of figure:
  * wall clock: what the issue asks for; only meaningful on a quiet machine;
  * CPU-time estimate: samples per CPU second (all threads, user + system)
    times the threads, which other processes on the cores hardly change.
    It assumes every thread is busy all the time, so it cannot see idle
    threads: its "scaling" shows only per-thread slowdowns.
When other processes kept the cores busy during the run, the targets are
judged on the estimates, and say so.
"""
import json
import os
import statistics
import sys

TARGET_MITSUBA = 1.25
TARGET_CEILING = 0.60
TARGET_SCALING = 1.9
TARGET_IMAGE = 0.02
TARGET_PYTHON = 0.02
BUSY = 0.25  # cores used by others that make a section "busy"


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
    T = int(info.get('nproc', '1'))

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
    overhead = 0.0
    runs = {}
    for l in read(d, 'lensray.log'):
        if l.startswith('OVERHEAD '):
            overhead = kv(l).get('cpu_seconds', 0.0)
        if not l.startswith('LENSRAY '):
            continue
        head, js = l.split(' {', 1)
        h = kv(head)
        s = json.loads('{' + js)
        full = s.get('plan', {}).get('full_samples') or s['width'] * s['height'] * s['spp']
        s['full'] = full
        s['effective'] = full / s['seconds'] if s['seconds'] > 0 else 0.0
        cpu = h.get('cpu_seconds', 0.0) - overhead
        if isinstance(cpu, float) and cpu > 0:
            s['cpu_rate'] = s['samples'] / cpu * s['threads']
            s['cpu_effective'] = full / cpu * s['threads']
        runs.setdefault((h['mode'], int(h['threads'])), []).append(s)

    def best(mode, t, key='samples_per_second'):
        rs = [s for s in runs.get((mode, t), []) if s.get(key)]
        return max(s[key] for s in rs) if rs else None

    def best_run(mode, t):
        rs = runs.get((mode, t))
        return max(rs, key=lambda s: s['samples_per_second']) if rs else None

    # ---- Mitsuba
    mits = {}
    mits_msgs = []
    for l in read(d, 'mitsuba.log'):
        if l.startswith('MITSUBA '):
            j = json.loads(l[len('MITSUBA '):])
            mits[j['variant'] + (' robust' if j.get('robust') else '')] = j
        elif l.startswith('MITSUBA_FAILED') or l.startswith('MITSUBA_UNAVAILABLE'):
            mits_msgs.append(l.split(' ', 1)[1] if ' ' in l else l)

    comps = [json.loads(l[len('COMPARE '):]) for l in read(d, 'compare.log')
             if l.startswith('COMPARE ')]
    busy = [(w, float(bc)) for w, bc in (l.split() for l in read(d, 'busy.log'))]
    hot = [(w, bc) for w, bc in busy if bc >= BUSY]

    # ---- the table
    p('lensray benchmark: scenes/bench.json, 640 x 480, thin lens (r 0.5, focus 30), '
      '3 bunnies + ground (11,024 triangles), 1 point light, direct light + 1 shadow ray')
    for k in ('date', 'commit', 'cpu', 'nproc', 'memory', 'os', 'embree', 'cc', 'llvm', 'spp'):
        if k in info:
            p('  %-8s %s' % (k + ':', info[k]))
    if hot:
        p('  WARNING: the machine was busy: other processes kept %s. The wall-clock '
          'figures are too low; the targets are judged on the CPU-time estimates.'
          % ', '.join('%.2f cores busy before %s' % (bc, w) for w, bc in hot))
    else:
        p('  the machine was quiet (other processes used < %.2f cores before each section)' % BUSY)
    p('')
    W = 44
    p('%-*s %s   %s' % (W, 'M samples/s', ' wall clock '.center(27, '-'),
                         ' CPU-time estimate '.center(27, '-')))
    p('%-*s %9s %9s %7s   %9s %9s %7s' % (W, '', '1 thread', '%d thr.' % T, 'scaling',
                                          '1 thread', '%d thr.' % T, 'scaling'))

    def sc(a, b):
        return '%.2fx' % (b / a) if a and b else ''

    def row(name, a, b, ea, eb, extra=''):
        p('%-*s %9s %9s %7s   %9s %9s %7s%s' % (W, name, m(a), m(b), sc(a, b),
                                                m(ea), m(eb), sc(ea, eb), extra))

    c1, cN = ceil.get(1), ceil.get(T)
    g = lambda c, k: c[k] * 1e6 if c and k in c else None
    if c1:
        row('bare Embree ceiling (camera + shadow ray)', g(c1, 'msamples_s'),
            g(cN, 'msamples_s'), g(c1, 'msamples_s_cpu'), g(cN, 'msamples_s_cpu'))
    else:
        p('bare Embree ceiling: FAILED (see ceiling.log)')
    if runs.get(('full', 1)) or runs.get(('full', T)):
        row('lensray, every sample traced', best('full', 1), best('full', T),
            best('full', 1, 'cpu_rate'), best('full', T, 'cpu_rate'))
    if runs.get(('fast', 1)) or runs.get(('fast', T)):
        row('lensray, every sample, accel.robust=false', best('fast', 1), best('fast', T),
            best('fast', 1, 'cpu_rate'), best('fast', T, 'cpu_rate'))
    if runs.get(('default', 1)) or runs.get(('default', T)):
        row('lensray as shipped (samples taken)', best('default', 1), best('default', T),
            best('default', 1, 'cpu_rate'), best('default', T, 'cpu_rate'))
        row('lensray as shipped (effective W*H*spp/s)', best('default', 1, 'effective'),
            best('default', T, 'effective'), best('default', 1, 'cpu_effective'),
            best('default', T, 'cpu_effective'))
    for v in ('llvm_ad_rgb', 'llvm_ad_rgb robust', 'scalar_rgb'):
        if v in mits:
            j = mits[v]
            row('Mitsuba %s %s' % (j['mitsuba'], v), None, j['samples_per_second'],
                None, j.get('samples_per_second_cpu'))
    for msg in mits_msgs:
        p('Mitsuba: not available (%s)' % msg)
    p('(Mitsuba: time per extra sample, W H spp / (t(2 spp) - t(spp)), after a warm-up '
      'render; at all threads only)')
    p('')

    # ---- details
    if c1:
        p('ceiling details (per core; the fastest camera and shadow passes over every API '
          'and packet order):')
        for t, c in sorted(ceil.items()):
            p('  %d thread(s): camera %s %.2f ns/ray (%.1f M rays/s), shadow %s %.2f ns/ray; '
              'camera + shadow %.2f ns/sample (CPU time: %.2f ns/sample)'
              % (t, c['camera_api'], c['camera_ns_per_ray_core'], c['camera_mrays_s'],
                 c['shadow_api'], c['shadow_ns_per_ray_core'], c['sample_ns_core'],
                 c.get('sample_ns_cpu', 0.0)))
        for t, r in sorted(r16.items()):
            p('  %d thread(s), rtcIntersect16 + rtcOccluded16, 4x4-pixel packets: camera '
              '%.2f ns/ray (%.1f M rays/s), camera + shadow %.2f ns/sample (%.1f M samples/s)'
              % (t, r['camera_ns_per_ray_core'], r['camera_mrays_s'], r['sample_ns_core'],
                 r['msamples_s']))
    for (mode, t), rs in sorted(runs.items()):
        b = best_run(mode, t)
        p('lensray %-7s %d thread(s): best %s M samples/s (median %s, %d runs), '
          '%s M rays/s, %.2f s, %d of %d samples taken'
          % (mode, t, m(b['samples_per_second']),
             m(statistics.median(s['samples_per_second'] for s in rs)), len(rs),
             m(b['rays_per_second']), b['seconds'], b['samples'], b['full']))
    for v in ('llvm_ad_rgb', 'llvm_ad_rgb robust', 'scalar_rgb'):
        if v in mits:
            j = mits[v]
            p('Mitsuba %s: %.3f s at %d spp, %.3f s at %d spp (plain rate %s M samples/s), '
              '%s threads, first render %.2f s'
              % (v, j['seconds_spp'], j['spp'], j['seconds_2spp'], 2 * j['spp'],
                 m(j['samples_per_second_plain']), j['threads'],
                 j.get('first_render_seconds', 0.0)))
    p('')

    # ---- ratios and targets
    est = bool(hot)
    how = 'CPU-time estimate' if est else 'wall clock'
    key_full = 'cpu_rate' if est else 'samples_per_second'
    ours_mode = 'full' if runs.get(('full', T)) else 'default'
    ours_name = 'every sample traced' if ours_mode == 'full' else 'as shipped'
    o1, oN = best(ours_mode, 1, key_full), best(ours_mode, T, key_full)
    ceil_key = 'msamples_s_cpu' if est else 'msamples_s'
    checks = []
    p('ratios (%s):' % how)
    if oN and cN and g(cN, ceil_key):
        r = oN / g(cN, ceil_key)
        p('  lensray (%s) / ceiling, %d threads: %.2f' % (ours_name, T, r))
        checks.append(('lensray >= %d%% of the bare Embree ceiling' % (TARGET_CEILING * 100),
                       r >= TARGET_CEILING, '%.0f%%' % (100 * r)))
    if o1 and c1 and g(c1, ceil_key):
        p('  lensray (%s) / ceiling, 1 thread: %.2f' % (ours_name, o1 / g(c1, ceil_key)))
    for v in ('llvm_ad_rgb', 'scalar_rgb'):
        if v in mits and oN:
            mv = mits[v].get('samples_per_second_cpu') if est else mits[v]['samples_per_second']
            if not mv:
                continue
            r = oN / mv
            p('  lensray (%s) / Mitsuba %s: %.2fx' % (ours_name, v, r))
            eff = best('default', T, 'cpu_effective' if est else 'effective')
            if eff:
                p('  lensray (as shipped, effective) / Mitsuba %s: %.2fx' % (v, eff / mv))
            if v == 'llvm_ad_rgb':
                checks.append(('lensray >= %.2fx Mitsuba llvm_ad_rgb' % TARGET_MITSUBA,
                               r >= TARGET_MITSUBA, '%.2fx' % r))
    # Like for like: the same Embree traversal on both sides (issue 17's
    # per-sample target; Mitsuba's default is not robust, lensray's is).
    # The interleaved rounds of bench/persample.py judge it when they ran:
    # the sections above are minutes apart, and this VM's drift between
    # them is as large as the ratio's distance from 1.
    inter = {}
    for l in read(d, 'persample.log'):
        if l.startswith('PERSAMPLE '):
            ps = json.loads(l[len('PERSAMPLE '):])
            for what, r in ps['pairings'].items():
                inter[what] = r
                p('  like for like, %s, interleaved (%d rounds of %d spp, %d threads): '
                  'lensray / Mitsuba llvm_ad_rgb median %.2fx (rounds %.2fx to %.2fx)'
                  % (what, ps['rounds'], ps['spp'], ps['threads'], r['median'],
                     r['min'], r['max']))
    for mode, v, what in (('full', 'llvm_ad_rgb robust', 'both robust'),
                          ('fast', 'llvm_ad_rgb', 'neither robust')):
        ours = best(mode, T, key_full)
        if v in mits and ours:
            mv = mits[v].get('samples_per_second_cpu') if est else mits[v]['samples_per_second']
            if mv:
                p('  like for like, %s, best of the sections: lensray (every sample traced) / '
                  'Mitsuba llvm_ad_rgb: %.2fx' % (what, ours / mv))
                if what not in inter:
                    checks.append(('per sample, %s, >= 1.0x Mitsuba llvm_ad_rgb (issue 17)'
                                   % what, ours / mv >= 1.0, '%.3fx' % (ours / mv)))
    for what, r in inter.items():
        checks.append(('per sample, %s, interleaved, >= 1.0x Mitsuba llvm (issue 17)'
                       % what, r['median'] >= 1.0, '%.3fx' % r['median']))
    if o1 and oN and T > 1:
        r = oN / o1
        checks.append(('%d threads >= %.1fx 1 thread%s' % (T, TARGET_SCALING,
                                                          ' (CPU time: per-thread only)' if est else ''),
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
    for l in read(d, 'memory.log'):
        if l.startswith('MEMORY '):
            mm = kv(l)
            film = mm['film_bytes'] / 1048576.0
            base, peak = mm['base_kib'] / 1024.0, mm['peak_kib'] / 1024.0
            if peak > 0:
                p('memory: %dx%d at %d spp: peak RSS %.1f MiB; film %.1f MiB + the '
                  'process with the scene (an 8x8 render) %.1f MiB = %.1f MiB; '
                  'over by %.1f MiB (%.1f%%)'
                  % (mm['width'], mm['height'], mm['spp'], peak, film, base,
                     film + base, peak - film - base,
                     100.0 * (peak - film - base) / (film + base)))
                checks.append(('peak RSS within film + scene (+5%)',
                               peak <= 1.05 * (film + base),
                               '%.1f of %.1f MiB' % (peak, film + base)))
    for l in read(d, 'python.log'):
        if l.startswith('PYTHON_OVERHEAD '):
            po = kv(l)
            p('python: scene.render() over the CLI\'s render, %d spp (about 1 s): '
              'wall %+.1f%%, CPU %+.1f%% (with the tqdm bar; without: wall %+.1f%%, '
              'CPU %+.1f%%); %.1f ms per render outside the library'
              % (po['spp'], 100 * po['wall_overhead'], 100 * po['cpu_overhead'],
                 100 * po['wall_overhead_nobar'], 100 * po['cpu_overhead_nobar'],
                 1000 * po.get('wrapper_seconds', 0)))
            checks.append(('Python costs at most 2% over the CLI (CPU time)',
                           po['cpu_overhead'] <= TARGET_PYTHON,
                           '%+.2f%%' % (100 * po['cpu_overhead'])))
    for l in read(d, 'lens.log'):
        if l.startswith('LENS '):
            le = kv(l)
            # Older logs took each side's minimum CPU time (no ratio_lo).
            spread = ('median of %d interleaved turns\' ratios, %.2f to %.2f'
                      % (le['turns'], le['ratio_lo'], le['ratio_hi'])
                      if 'ratio_lo' in le else 'min CPU of %d turns each' % le['turns'])
            p('real lens: the double Gauss at f/2.8 on the bench scene, every sample '
              'traced, 1 thread: %.2f M samples/s against the thin lens\'s %.2f M '
              '(%.2f, %s); rays the lens stops: %.1f%% on axis '
              'at full aperture, %.1f%% over the frame'
              % (le['lens_samples_per_second'] / 1e6, le['thin_samples_per_second'] / 1e6,
                 le['ratio'], spread, 100 * le['lost_axis_open'],
                 100 * le['lost_frame_open']))
            checks.append(('real lens at least half the thin lens\'s samples/s',
                           le['ratio'] >= 0.5, '%.2f' % le['ratio']))
            checks.append(('real lens at least 0.8x the thin lens\'s samples/s (issue 30)',
                           le['ratio'] >= 0.8, '%.2f' % le['ratio']))
            checks.append(('real lens loses under 10% of rays on axis, open',
                           le['lost_axis_open'] < 0.10,
                           '%.1f%%' % (100 * le['lost_axis_open'])))
    # The planner through a real lens (issue 30): bench/lens_plan.py's lines.
    for l in read(d, 'lens_plan.log'):
        if l.startswith('LENSPLAN '):
            f = l.split()
            case = f[1].split('=')[1]
            v = {k: float(x) for k, x in (w.split('=') for w in f[2:6])}
            p('real lens planned, %s: lens sampled on %.0f%% of pixels; planned '
              'relMSE %.3fx the full simulation\'s, defaults %.3fx; time to the '
              'full\'s error %.2fx sooner' % (case, 100 * v['lens_pixels'],
                                               v['plan_err'], v['default_err'],
                                               v['time_to_error']))
            if case == 'focus':
                checks.append(('f/11 in focus: defaults within 1.2x the full '
                               'simulation\'s relMSE (issue 30)',
                               v['default_err'] <= 1.2, '%.3f' % v['default_err']))
                checks.append(('f/11 in focus: the full\'s error 2x sooner (issue 30)',
                               v['time_to_error'] >= 2.0, '%.2fx' % v['time_to_error']))
            elif case == 'fool':
                checks.append(('fool scene: planned within 1.1x the full '
                               'simulation\'s relMSE (issue 30)',
                               v['plan_err'] <= 1.1, '%.3f' % v['plan_err']))
    for l in read(d, 'bunny_time.log'):
        if l.startswith('lensray defaults against '):
            r = float(l.split(':')[1].split('x')[0])
            p('bench scene to relMSE 1e-5: ' + l.strip())
            checks.append(('bench scene: relMSE 1e-5 8x sooner than Mitsuba\'s best '
                           'sampler (issue 30)', r >= 8.0, '%.2fx' % r))
    # The path tracer on the Cornell box (issue 13): bench/path/speed.py's
    # summary line, by the wall clock as the rest.
    for l in read(d, 'path.log'):
        if l.startswith('PATHSPEED ') and '"scene": "cornell (' in l:
            ps = json.loads(l[len('PATHSPEED '):])
            checks.append(('path, Cornell box: samples/s >= 1.0x Mitsuba (issue 13)',
                           ps['rate_ratio'] >= 1.0, '%.3fx' % ps['rate_ratio']))
            checks.append(('path, Cornell box: >= 2x sooner to relMSE 1e-4 (issue 13)',
                           ps['time_ratio'] >= 2.0, '%.2fx' % ps['time_ratio']))
        elif l.startswith('PATHSPEED ') and '"scene": "cornell-sphere' in l:
            # Full-length paths: max depth 64, roulette from the fifth
            # bounce (issue 30).
            ps = json.loads(l[len('PATHSPEED '):])
            checks.append(('path, sphere-lit box, depth 64: samples/s >= 1.1x '
                           'Mitsuba (issue 30)',
                           ps['rate_ratio'] >= 1.1, '%.3fx' % ps['rate_ratio']))
            checks.append(('path, sphere-lit box, depth 64: >= 2x sooner to relMSE '
                           '1e-4 (issue 30)',
                           ps['time_ratio'] >= 2.0, '%.2fx' % ps['time_ratio']))
    p('')
    p('targets (%s):' % how)
    for name, ok, val in checks:
        p('  [%s] %-62s %s' % ('PASS' if ok else 'FAIL', name, val))
    if not checks:
        p('  (nothing measured)')
    print('\n'.join(lines))


if __name__ == '__main__':
    main()
