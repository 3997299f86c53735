"""scenes.py: the path integrator's comparison scenes, described once and
written out for both renderers: lensray's scene JSON and Mitsuba 3's scene
dictionary.

Conventions that make the two the same picture:
  * Mitsuba's max_depth counts path segments: ours (bounces after the
    first hit) + 2.
  * Our diffuse surfaces are two-sided: Mitsuba's get 'twosided'.  Our
    glass needs no wrapper (Mitsuba's dielectric is two-sided).  Our
    metal is two-sided but Mitsuba's conductor is not (black from
    behind): no scene here shows a metal from behind; one that does
    needs 'twosided' around it.
  * Rough metal {"reflect": R, "roughness": a} is Mitsuba's roughconductor
    with material 'none' (Fresnel 1), specular_reflectance R, GGX alpha a,
    visible-normal sampling; rough glass {"transmit": T, "ior": n,
    "roughness": a} is roughdielectric with int_ior n, ext_ior 1 and T for
    both specular_reflectance and specular_transmittance.
  * A rect {"type": "plane", "point": p, "normal": n, "size": s} is
    Mitsuba's rectangle ([-1, 1]^2 at z = 0, facing +z) scaled by s / 2,
    turned so that +z is n, moved to p.  Emission is one-sided (the normal
    side) in both.
  * The environment map's direction convention is Mitsuba's (envmap.h);
    'scale' is our intensity.
  * Colours are given as 'rgb' values: a plain number in an rgb variant is
    an illuminant and comes out tinted (see mitsuba_bench.py).
"""
import math
import os


def frame(n):
    """Unit vectors u, v completing unit n to a right-handed frame."""
    nx, ny, nz = n
    a = (0.0, 0.0, 1.0) if abs(nx) > 0.9 else (1.0, 0.0, 0.0)
    d = a[0] * nx + a[1] * ny + a[2] * nz
    u = [a[i] - d * n[i] for i in range(3)]
    lu = math.sqrt(sum(c * c for c in u))
    u = [c / lu for c in u]
    v = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2],
         n[0] * u[1] - n[1] * u[0]]
    return u, v


CORNELL = {
    'name': 'cornell',
    'camera': {'position': [0, 5, 16], 'look_at': [0, 5, 0], 'up': [0, 1, 0],
               'fov': 40},
    'materials': {
        'white': {'diffuse': [0.75, 0.75, 0.75]},
        'red': {'diffuse': [0.65, 0.08, 0.06]},
        'green': {'diffuse': [0.12, 0.5, 0.1]},
        'light': {'diffuse': [0, 0, 0], 'emission': [30, 26, 20]},
        'metal': {'reflect': [0.9, 0.8, 0.6], 'roughness': 0.25},
    },
    'objects': [
        {'type': 'plane', 'point': [0, 0, -5], 'normal': [0, 1, 0], 'size': 10, 'material': 'white'},
        {'type': 'plane', 'point': [0, 10, -5], 'normal': [0, -1, 0], 'size': 10, 'material': 'white'},
        {'type': 'plane', 'point': [0, 5, -10], 'normal': [0, 0, 1], 'size': 10, 'material': 'white'},
        {'type': 'plane', 'point': [-5, 5, -5], 'normal': [1, 0, 0], 'size': 10, 'material': 'red'},
        {'type': 'plane', 'point': [5, 5, -5], 'normal': [-1, 0, 0], 'size': 10, 'material': 'green'},
        {'type': 'plane', 'point': [0, 9.99, -5], 'normal': [0, -1, 0], 'size': 3, 'material': 'light'},
        {'type': 'sphere', 'center': [-2, 2, -6.5], 'radius': 2, 'material': 'white'},
        {'type': 'sphere', 'center': [2.2, 1.8, -3], 'radius': 1.8, 'material': 'metal'},
    ],
}

ENVLIT = {
    'name': 'envlit',
    'camera': {'position': [0, 2.2, 9], 'look_at': [0, 1, 0], 'up': [0, 1, 0],
               'fov': 35},
    'environment': {'file': 'sky.exr', 'intensity': 1},
    'materials': {
        'ground': {'diffuse': [0.4, 0.4, 0.4]},
        'metal': {'reflect': [0.95, 0.7, 0.4], 'roughness': 0.2},
        'glass': {'transmit': [1, 1, 1], 'ior': 1.5, 'roughness': 0.1},
        'clay': {'diffuse': [0.6, 0.3, 0.2]},
    },
    'objects': [
        {'type': 'plane', 'point': [0, 0, 0], 'normal': [0, 1, 0], 'size': 30, 'material': 'ground'},
        {'type': 'sphere', 'center': [-2.3, 1, 0], 'radius': 1, 'material': 'metal'},
        {'type': 'sphere', 'center': [0, 1, 1], 'radius': 1, 'material': 'glass'},
        {'type': 'sphere', 'center': [2.3, 1, 0], 'radius': 1, 'material': 'clay'},
    ],
}

SCENES = {'cornell': CORNELL, 'envlit': ENVLIT}

# The Cornell box with the bunny (scenes/meshes/bunny.obj, 3,674
# triangles, flat-shaded on both sides) in place of the white sphere: a
# scene that lensray traces with Embree (few_triangles.c and spheres.c
# take only scenes of at most 32 triangles and 8 spheres), for speed.py
# --scene bunny-box.
BUNNY = os.path.join(os.path.dirname(os.path.abspath(__file__)),
                     '..', '..', 'scenes', 'meshes', 'bunny.obj')
BUNNY_BOX = dict(CORNELL, name='bunny-box', objects=[
    o for o in CORNELL['objects'] if o.get('radius') != 2] + [
    {'type': 'mesh', 'file': os.path.abspath(BUNNY), 'smooth': False,
     'material': 'white', 'scale': 0.45, 'translate': [-2, 0, -6.5]}])
# The Cornell box lit by a sphere lamp in place of the ceiling's
# rectangle (issue 30's full-length paths: max_depth 64, roulette from the
# fifth surface, as Mitsuba runs by default).  Both renderers sample a
# sphere seen from outside uniformly in the cone it subtends (lensray's
# light.c; Mitsuba's sphere.cpp sample_direction).
CORNELL_SPHERE = dict(CORNELL, name='cornell-sphere', materials=dict(
    CORNELL['materials'], light={'diffuse': [0, 0, 0],
                                 'emission': [30, 26, 20]}), objects=[
    o for o in CORNELL['objects'] if o['material'] != 'light'] + [
    {'type': 'sphere', 'center': [0, 8.6, -5], 'radius': 0.8,
     'material': 'light'}])
SCENES['cornell-sphere'] = CORNELL_SPHERE
SPEED_SCENES = {'cornell': CORNELL, 'bunny-box': BUNNY_BOX,
                'cornell-sphere': CORNELL_SPHERE}


def sky(w=128, h=64):
    """The environment map: a blue-to-white sky over a dark ground and a
    broad warm sun, smooth enough that texel lookup (ours) and bilinear
    lookup (Mitsuba's) agree.  Rows from the top (v = theta / pi)."""
    import numpy as np
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    theta = v[:, None] * math.pi
    phi = u[None, :] * 2 * math.pi
    # Mitsuba's envmap frame: d = (sin t sin p, cos t, -sin t cos p).
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta) + 0 * phi,
                  -np.sin(theta) * np.cos(phi)], axis=-1)
    up = np.clip(d[..., 1], 0, 1)
    img = np.zeros((h, w, 3))
    img += (up ** 0.5)[..., None] * np.array([0.5, 0.7, 1.2])
    img += (1 - up)[..., None] * (d[..., 1] > 0)[..., None] * np.array([1.0, 1.0, 1.0])
    img += (d[..., 1] <= 0)[..., None] * np.array([0.25, 0.22, 0.2])
    sun = np.array([0.5, 0.6, 0.62])
    sun /= np.linalg.norm(sun)
    c = np.clip(d @ sun, -1, 1)
    img += np.exp((c - 1) / 0.02)[..., None] * np.array([40.0, 32.0, 24.0])
    return img.astype(np.float32)


def lensray_json(sc, width, height, spp, max_depth, extra=None):
    r = {'width': width, 'height': height, 'spp': spp, 'max_depth': max_depth,
         'integrator': 'path', 'adaptive': False}
    r.update(extra or {})
    objs = []
    for o in sc['objects']:
        if o['type'] == 'mesh':
            o = {'type': 'mesh', 'file': o['file'], 'smooth': o['smooth'],
                 'material': o['material'],
                 'transform': [{'scale': o['scale']},
                               {'translate': o['translate']}]}
        objs.append(o)
    out = {'camera': dict(sc['camera'], model='pinhole'), 'render': r,
           'materials': sc['materials'], 'objects': objs}
    if 'environment' in sc:
        out['environment'] = sc['environment']
    return out


def _bsdf(m):
    if 'transmit' in m:
        return {'type': 'roughdielectric', 'distribution': 'ggx',
                'alpha': m['roughness'], 'int_ior': m['ior'], 'ext_ior': 1.0,
                'sample_visible': True,
                'specular_reflectance': {'type': 'rgb', 'value': m['transmit']},
                'specular_transmittance': {'type': 'rgb', 'value': m['transmit']}}
    if 'reflect' in m:
        return {'type': 'roughconductor', 'material': 'none',
                'distribution': 'ggx', 'alpha': m['roughness'],
                'sample_visible': True,
                'specular_reflectance': {'type': 'rgb', 'value': m['reflect']}}
    return {'type': 'twosided',
            'material': {'type': 'diffuse',
                         'reflectance': {'type': 'rgb', 'value': m['diffuse']}}}


def mitsuba_dict(mi, sc, width, height, spp, max_depth, env_path=None,
                 seed=0):
    T = mi.ScalarTransform4f
    cam = sc['camera']
    d = {
        'type': 'scene',
        'integrator': {'type': 'path', 'max_depth': max_depth + 2},
        'sensor': {
            'type': 'perspective', 'fov': float(cam['fov']), 'fov_axis': 'y',
            'near_clip': 0.01, 'far_clip': 10000.0,
            'to_world': T().look_at(origin=cam['position'],
                                    target=cam['look_at'], up=cam['up']),
            'sampler': {'type': 'independent', 'sample_count': spp,
                        'seed': seed},
            'film': {'type': 'hdrfilm', 'width': width, 'height': height,
                     'rfilter': {'type': 'box'}, 'pixel_format': 'rgb',
                     'component_format': 'float32', 'sample_border': False},
        },
    }
    if 'environment' in sc:
        d['env'] = {'type': 'envmap', 'filename': env_path,
                    'scale': float(sc['environment'].get('intensity', 1))}
    for i, o in enumerate(sc['objects']):
        m = sc['materials'][o['material']]
        if o['type'] == 'sphere':
            s = {'type': 'sphere', 'center': o['center'],
                 'radius': float(o['radius'])}
        elif o['type'] == 'mesh':
            s = {'type': 'obj', 'filename': o['file'], 'face_normals': True,
                 'to_world': T().translate(o['translate']).scale(o['scale'])}
        else:
            n = o['normal']
            u, v = frame(n)
            h = o['size'] / 2.0
            p = o['point']
            mat = [[u[0] * h, v[0] * h, n[0], p[0]],
                   [u[1] * h, v[1] * h, n[1], p[1]],
                   [u[2] * h, v[2] * h, n[2], p[2]],
                   [0, 0, 0, 1]]
            s = {'type': 'rectangle', 'to_world': T(mat)}
        s['bsdf'] = _bsdf(m)
        if 'emission' in m:
            s['emitter'] = {'type': 'area',
                            'radiance': {'type': 'rgb', 'value': m['emission']}}
        d['obj%d' % i] = s
    return d
