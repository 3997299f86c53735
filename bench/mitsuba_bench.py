#!/usr/bin/env python3
"""mitsuba_bench.py: the benchmark's reference scene rendered by Mitsuba 3.

The same scene as scenes/bench.json (keep them in step): three smooth
bunnies (scenes/meshes/bunny.obj, unscaled) translated by (-9, 0, 0),
(0, 0, -15) and (9, 0, -30), albedo (0.7, 0.5, 0.3); a 200 x 200 ground
square at y = 0, albedo 0.5; a point light at (10, 30, 30) of 2000 W/sr;
a thin lens at (0, 4, 30) looking at (0, 4, 0), up +y, vertical fov 40,
aperture radius 0.5, focus distance 30; 640 x 480; direct lighting with
one emitter sample and no BSDF sample; black background, no ambient.

Mitsuba conventions that matter here:
  * thinlens 'fov' with fov_axis 'y' is the vertical field of view, as
    ours; its plane in focus is perpendicular to the view axis at
    'focus_distance' (camera-space z), as ours; the aperture is a disk
    sampled uniformly by area.
  * 'rectangle' is [-1, 1]^2 in the z = 0 plane facing +z: scaled by 100
    and rotated -90 degrees about x it is the ground, facing +y.
  * 'diffuse' is one-sided in Mitsuba; ours are two-sided, so every BSDF
    is wrapped in 'twosided'.
  * the film's 'box' filter: each sample counts for its own pixel only,
    like our box pixel filter.
  * 'point' intensity is in W/sr, irradiance I cos / r^2, as ours.  It
    is given as 'rgb' [2000, 2000, 2000]: a plain number (or a 'spectrum'
    value) in an rgb variant is taken as an illuminant and comes out tinted
    by about (1.20, 0.95, 0.91), a pink light.

Timing: one render to warm up (the llvm variant compiles its kernel then),
then, best of --repeat, renders at --spp and at 2 x --spp; the samples per
second reported is the time per extra sample: W H spp / (t(2 spp) - t(spp)).
The plain rate W H spp / t(spp) is reported too.

With --ref-spp N it also renders the scene at N spp (in passes of at most
--pass-spp, with different seeds, averaged) and writes it to --out (EXR).

Prints one JSON line (prefixed with "MITSUBA ") with the results.
"""
import argparse
import json
import os
import sys
import time


def build_scene(mi, obj, width, height, spp, sampler, obj_normals, robust=False):
    T = mi.ScalarTransform4f
    bunny_bsdf = {'type': 'twosided',
                  'material': {'type': 'diffuse',
                               'reflectance': {'type': 'rgb', 'value': [0.7, 0.5, 0.3]}}}
    ground_bsdf = {'type': 'twosided',
                   'material': {'type': 'diffuse',
                                'reflectance': {'type': 'rgb', 'value': [0.5, 0.5, 0.5]}}}
    scene = {
        'type': 'scene',
        # Embree's robust traversal, lensray's only mode (lib/scene/scene.c);
        # Mitsuba's default is off.
        'embree_use_robust_intersections': robust,
        'integrator': {'type': 'direct', 'emitter_samples': 1, 'bsdf_samples': 0,
                       'hide_emitters': True},
        'sensor': {
            'type': 'thinlens',
            'fov': 40.0,
            'fov_axis': 'y',
            'aperture_radius': 0.5,
            'focus_distance': 30.0,
            'near_clip': 0.01,
            'far_clip': 10000.0,
            'to_world': T().look_at(origin=[0, 4, 30], target=[0, 4, 0], up=[0, 1, 0]),
            'sampler': {'type': sampler, 'sample_count': spp},
            'film': {'type': 'hdrfilm', 'width': width, 'height': height,
                     'rfilter': {'type': 'box'}, 'pixel_format': 'rgb',
                     'component_format': 'float32', 'sample_border': False},
        },
        'light': {'type': 'point', 'position': [10.0, 30.0, 30.0],
                  'intensity': {'type': 'rgb', 'value': [2000.0, 2000.0, 2000.0]}},
        'ground': {'type': 'rectangle',
                   'to_world': T().rotate([1, 0, 0], -90).scale(100),
                   'bsdf': ground_bsdf},
    }
    for i, off in enumerate([(-9, 0, 0), (0, 0, -15), (9, 0, -30)]):
        scene['bunny%d' % i] = {'type': 'obj', 'filename': obj,
                                'face_normals': False,
                                'to_world': T().translate(list(off)),
                                'bsdf': bunny_bsdf}
    return mi.load_dict(scene)


def write_obj_with_normals(src, dst):
    """The OBJ with 'vn' normals computed the way lensray computes them for
    "smooth": true (area-weighted average of the face normals at each
    vertex index), so that both renderers shade with the same normals.
    Only for --same-normals (a diagnostic)."""
    import numpy as np
    vs, fs = [], []
    with open(src) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == 'v':
                vs.append([float(x) for x in p[1:4]])
            elif p[0] == 'f':
                idx = [int(c.split('/')[0]) for c in p[1:]]
                idx = [i - 1 if i > 0 else len(vs) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    fs.append([idx[0], idx[k], idx[k + 1]])
    v = np.array(vs, dtype=np.float64)
    t = np.array(fs, dtype=np.int64)
    fn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])  # 2 x area
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, t[:, k], fn)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    with open(dst, 'w') as f:
        for p in v:
            f.write('v %.9g %.9g %.9g\n' % tuple(p))
        for p in n:
            f.write('vn %.9g %.9g %.9g\n' % tuple(p))
        for a, b, c in t + 1:
            f.write('f %d//%d %d//%d %d//%d\n' % (a, a, b, b, c, c))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--variant', required=True)
    ap.add_argument('--obj', default='scenes/meshes/bunny.obj')
    ap.add_argument('--width', type=int, default=640)
    ap.add_argument('--height', type=int, default=480)
    ap.add_argument('--spp', type=int, default=16, help='timing spp')
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--sampler', default='independent')
    ap.add_argument('--threads', type=int, default=0, help='0: all')
    ap.add_argument('--ref-spp', type=int, default=0)
    ap.add_argument('--pass-spp', type=int, default=64)
    ap.add_argument('--out', default='')
    ap.add_argument('--same-normals', action='store_true',
                    help="give Mitsuba lensray's smooth normals in the OBJ")
    ap.add_argument('--no-timing', action='store_true')
    ap.add_argument('--robust', action='store_true',
                    help="Embree's robust traversal, as lensray traces")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi
    mi.set_variant(a.variant)
    if a.threads > 0:
        dr.set_thread_count(a.threads)

    obj = os.path.abspath(a.obj)
    if a.same_normals:
        dst = os.path.join(os.path.dirname(os.path.abspath(a.out or 'x')),
                           'bunny_lensray_normals.obj')
        write_obj_with_normals(obj, dst)
        obj = dst

    res = {'variant': a.variant, 'mitsuba': mi.__version__, 'drjit': dr.__version__,
           'width': a.width, 'height': a.height, 'spp': a.spp, 'sampler': a.sampler,
           'threads': dr.thread_count()}
    pixels = a.width * a.height

    def render(scene, spp, seed):
        img = mi.render(scene, spp=spp, seed=seed)
        if a.variant.startswith(('llvm', 'cuda')):
            dr.eval(img)
            dr.sync_thread()
        return img

    t0 = time.perf_counter()
    scene = build_scene(mi, obj, a.width, a.height, a.spp, a.sampler, a.same_normals,
                        a.robust)
    res['robust'] = a.robust
    res['load_seconds'] = time.perf_counter() - t0

    if not a.no_timing:
        # Warm up both sizes (the first render compiles; a new spp may too).
        t0 = time.perf_counter()
        render(scene, a.spp, 0)
        res['first_render_seconds'] = time.perf_counter() - t0
        render(scene, 2 * a.spp, 1)
        t1 = t2 = c1 = c2 = float('inf')
        for r in range(a.repeat):
            t, c = time.perf_counter(), time.process_time()
            render(scene, a.spp, 2 + 2 * r)
            t1 = min(t1, time.perf_counter() - t)
            c1 = min(c1, time.process_time() - c)
            t, c = time.perf_counter(), time.process_time()
            render(scene, 2 * a.spp, 3 + 2 * r)
            t2 = min(t2, time.perf_counter() - t)
            c2 = min(c2, time.process_time() - c)
        res['seconds_spp'] = t1
        res['seconds_2spp'] = t2
        res['samples_per_second_plain'] = pixels * a.spp / t1
        extra = t2 - t1
        res['samples_per_second'] = (pixels * a.spp / extra if extra > 0
                                     else res['samples_per_second_plain'])
        # CPU time (all threads): an estimate that other processes on the
        # cores do not drag down, "samples per CPU second times threads".
        res['cpu_seconds_spp'] = c1
        res['cpu_seconds_2spp'] = c2
        cextra = c2 - c1
        res['samples_per_second_cpu'] = (pixels * a.spp / cextra * res['threads']
                                         if cextra > 0 else 0.0)

    if a.ref_spp > 0 and a.out:
        import numpy as np
        acc = None
        done = 0
        seed = 1000
        t0 = time.perf_counter()
        while done < a.ref_spp:
            n = min(a.pass_spp, a.ref_spp - done)
            img = np.array(render(scene, n, seed), dtype=np.float64)
            acc = img * n if acc is None else acc + img * n
            done += n
            seed += 1
        res['ref_spp'] = a.ref_spp
        res['ref_seconds'] = time.perf_counter() - t0
        img = (acc / done).astype(np.float32)
        mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(a.out)
        res['out'] = a.out

    print('MITSUBA ' + json.dumps(res))
    sys.stdout.flush()


if __name__ == '__main__':
    main()
