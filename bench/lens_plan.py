#!/usr/bin/env python3
"""lens_plan.py: the planner's real-lens bound (issue 30) against the full
simulation, on the scenes of its targets.

Usage: python3 bench/lens_plan.py LENSRAY IMGDIFF [--rounds K] [--spp N]
                                  [--ref-spp M] [--case NAME]

Cases (scenes/ with overrides; `fool` is written to a temporary file):
  focus      scenes/spheres.json through the double Gauss at f/11,
             focused at 16 m (the row of spheres 8 to 32 m away)
  focus-320  the same at 320 x 180
  focus-rgb  focus-320 in rgb mode: the full simulation traces a ray per
             channel, the plan one for all three where the colours land
             within a quarter pixel (each channel with its share)
  fool       scenes/accuracy-focus.json through the double Gauss at f/2.8
             focused on the wall (8 m), with a small sphere 1.2 m from
             the camera blurred over it: the scene built to fool a
             planner
  fool-f8    the same at f/8, where the wall's blocks skip the lens and
             the foreground's blur must keep it where it reaches

Per case: a reference (the full simulation, render.plan and
render.adaptive off, at --ref-spp); then K interleaved rounds, one
thread each, of the full simulation at N spp, the plan alone (adaptive
off) at N spp, and the defaults at N/4, N/2, N and 2N spp.  relMSE
against the reference by IMGDIFF (bench/accuracy/imgdiff); CPU seconds
from --stats.  The defaults' time to the full simulation's error is
interpolated log-log between the two rungs around it (extrapolated from
the nearest two when none are).  The least-squares line through the
rungs N/4 to N that this script drew before is printed beside it
("fit"); on 2026-12-06 the two agreed within 3%.  Printed: medians over the rounds of the
error ratios (planned / full, defaults / full at N spp) and of the time
ratio (full's time / the defaults' time to the same error), with the
share of pixels that sample the lens.
"""
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile

TMP = tempfile.mkdtemp(prefix='lensray-bench-lensplan-')
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LENS = ['--set', 'camera.model="lens"', '--set', 'camera.lens="double-gauss-50"']
FULL = ['--set', 'render.plan=false', '--set', 'render.adaptive=false']
PLAN = ['--set', 'render.plan=true', '--set', 'render.adaptive=false']


def fool_scene():
    with open(os.path.join(ROOT, 'scenes', 'accuracy-focus.json')) as f:
        d = json.load(f)
    d['description'] = 'lens_plan.py: a blurred foreground sphere over a wall in focus'
    d['camera'] = {'model': 'lens', 'lens': 'double-gauss-50',
                   'position': [0, 1.4, 6], 'look_at': [0, 1.1, 0],
                   'up': [0, 1, 0], 'sensor_width_mm': 36,
                   'focus_distance': 8, 'f_number': 2.8}
    d['objects'].append({'type': 'sphere', 'center': [0.25, 1.45, 4.8],
                         'radius': 0.12, 'material': 'red'})
    path = os.path.join(TMP, 'fool.json')
    with open(path, 'w') as f:
        json.dump(d, f)
    return path


def cases():
    sph = os.path.join(ROOT, 'scenes', 'spheres.json')
    focus = LENS + ['--set', 'camera.f_number=11',
                    '--set', 'camera.focus_distance=16']
    return {
        'focus': (sph, focus),
        'focus-320': (sph, focus + ['--set', 'render.width=320',
                                    '--set', 'render.height=180']),
        'focus-rgb': (sph, focus + ['--set', 'render.width=320',
                                    '--set', 'render.height=180',
                                    '--set', 'camera.chromatic.mode="rgb"']),
        'fool': (fool_scene(), []),
        'fool-f8': (fool_scene(), ['--set', 'camera.f_number=8']),
    }


def render(lensray, scene, extra, out, threads=1):
    r = subprocess.run([lensray, 'render', scene, '-o', out, '--quiet', '--stats',
                        '--set', 'render.threads=%d' % threads] + extra,
                       capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit('lens_plan.py: lensray failed: ' + r.stderr.strip())
    return json.loads([l for l in r.stdout.splitlines() if l.startswith('{')][0])


def relmse(imgdiff, ref, img):
    r = subprocess.run([imgdiff, ref, img], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit('lens_plan.py: imgdiff failed: ' + r.stderr.strip())
    return json.loads(r.stdout.splitlines()[0])['relmse']


def time_to(err, rungs):
    """Seconds at which the rungs [(t, e)] (more samples each) reach err:
    log-log between the two around it, or along the nearest two."""
    for a, b in zip(rungs, rungs[1:]):
        if a[1] >= err >= b[1] and a[1] > b[1]:
            break
    else:
        a, b = (rungs[0], rungs[1]) if err > rungs[0][1] else (rungs[-2], rungs[-1])
    if not (a[1] > b[1] > 0 and a[0] > 0 and b[0] > 0):
        return time_fit(err, rungs)
    f = math.log(a[1] / err) / math.log(a[1] / b[1])
    return math.exp(math.log(a[0]) + f * math.log(b[0] / a[0]))


def time_fit(err, rungs):
    """Seconds at which the log-log least-squares line through rungs
    [(t, e)] reaches err."""
    xs = [math.log(t) for t, _ in rungs]
    ys = [math.log(e) for _, e in rungs]
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / \
        sum((x - mx) ** 2 for x in xs)
    a = my - b * mx
    return math.exp((math.log(err) - a) / b)


def main():
    args = sys.argv[1:]
    if len(args) < 2:
        sys.exit(__doc__)
    lensray, imgdiff = args[0], args[1]
    opt = {'--rounds': '3', '--spp': '64', '--ref-spp': '1024', '--case': ''}
    for k in opt:
        if k in args:
            opt[k] = args[args.index(k) + 1]
    rounds, spp, ref_spp = int(opt['--rounds']), int(opt['--spp']), int(opt['--ref-spp'])
    all_cases = cases()
    names = [opt['--case']] if opt['--case'] else list(all_cases)
    print('lens_plan.py: %d rounds, %d spp, reference %d spp' % (rounds, spp, ref_spp))
    for name in names:
        scene, extra = all_cases[name]
        ref = os.path.join(TMP, name + '-ref.exr')
        render(lensray, scene, extra + FULL + ['--set', 'render.spp=%d' % ref_spp],
               ref, threads=2)
        r_plan, r_def, r_time, r_fit, lens_share = [], [], [], [], []
        for rnd in range(rounds):
            runs = [('full', FULL, spp), ('plan', PLAN, spp),
                    ('d4', [], spp // 4), ('d2', [], spp // 2), ('d1', [], spp),
                    ('d0', [], 2 * spp)]
            if rnd % 2:
                runs = runs[::-1]
            got = {}
            for tag, sets, n in runs:
                out = os.path.join(TMP, '%s-%s.exr' % (name, tag))
                st = render(lensray, scene, extra + sets + ['--set', 'render.spp=%d' % n], out)
                got[tag] = (st['cpu_seconds'], relmse(imgdiff, ref, out),
                            st['plan']['lens_pixels'])
            tf, ef, _ = got['full']
            r_plan.append(got['plan'][1] / ef)
            r_def.append(got['d1'][1] / ef)
            rungs = [got[t][:2] for t in ('d4', 'd2', 'd1', 'd0')]
            r_time.append(tf / time_to(ef, rungs))
            r_fit.append(tf / time_fit(ef, rungs[:3]))
            lens_share.append(got['plan'][2])
            print('  %s round %d: full %.2f s relMSE %.3e; plan relMSE %.3e; '
                  'defaults %s' % (name, rnd, tf, ef, got['plan'][1],
                                   ', '.join('%.2f s %.3e' % r for r in rungs)))
        med = statistics.median
        print('LENSPLAN case=%s lens_pixels=%.3f plan_err=%.3f default_err=%.3f '
              'time_to_error=%.2f (ranges: plan %.3f-%.3f, defaults %.3f-%.3f, '
              'time %.2f-%.2f; fit through N/4 to N %.2f, %.2f-%.2f)' % (
                  name, med(lens_share), med(r_plan), med(r_def),
                  med(r_time), min(r_plan), max(r_plan),
                  min(r_def), max(r_def), min(r_time), max(r_time),
                  med(r_fit), min(r_fit), max(r_fit)))
        sys.stdout.flush()


if __name__ == '__main__':
    main()
