#!/usr/bin/env python3
"""reference.py: the exact image of a scene of sphere lights through
lensray's thin lens (issue 27's "exact reference"), with numpy only.

    reference.py SCENE.json --out REF.npy [--exr REF.exr] [--discs DISCS.json]
    reference.py SCENE.json --check      # validates the method itself

The scene may hold only emitting spheres (no other geometry, no lights, a
black background) seen by camera.model "thinlens" with a disk aperture;
anything else is refused, since the reference would not describe it.

The camera (lib/camera/camera.c, lib/camera/camera_thinlens.c; camera.h's "offset
lens").  Eye e, unit forward f, right r = |f x up|, up' = r x f.  Film
point (fx, fy) in pixels from the top-left corner maps to the point

    D = f + sx r + sy up',  sx = (2 fx / W - 1) tan(fov/2) W/H,
                            sy = (1 - 2 fy / H) tan(fov/2)

of the image plane at distance 1 (fov vertical).  A lens sample is a point
`off` of the disk of radius R (aperture_radius) in the plane spanned by r
and up' at e, sampled uniformly by area; the ray leaves e + off towards the
focal point Q = e + F D (F = focus_distance), weight 1.  A pixel of the
box-filtered image is the mean over its area and the aperture of the
radiance each ray meets: L times the fraction of the aperture whose rays
hit the light, averaged over the pixel.

The hit set.  In camera coordinates (x along r, y along up', z along f, e
at 0) a lens point p = (x, y, 0) sees the sphere (centre C, radius rho)
iff the line through Q and p passes within rho of C; every point of the
line that meets the sphere has z > 0, so it is the ray itself that hits.
With v = C - Q and w = p - Q that is |v x w|^2 <= rho^2 |w|^2, i.e.
w^T K w <= 0 with K = (|v|^2 - rho^2) I - v v^T: the sphere's tangent cone
from Q cut by the lens plane.  When the light lies wholly in front of or
behind the plane in focus (vz^2 > rho^2) this is an ellipse; solving the
quadratic form for its centre and axes (K's 2x2 block has eigenvector
v2 = (vx, vy) with eigenvalue vz^2 - rho^2 and v2's normal with |v|^2 -
rho^2):

    centre  c = q2 - qz vz v2 / (vz^2 - rho^2)
    axes    a = qz rho sqrt(|v|^2 - rho^2) / (vz^2 - rho^2)   along v2
            b = qz rho / sqrt(vz^2 - rho^2)                   across it

(on the axis both are F rho / |F - z|, the familiar size of a defocused
point's pencil at the lens).  The overlap of the ellipse with the aperture
disk is exact by Green's theorem, area = 1/2 of the closed integral of
x dy - y dx over the boundary of the intersection: the ellipse's arcs
inside the disk, c + A cos t + B sin t, contribute
1/2 [(c x A)(cos t2 - cos t1) + (c x B)(sin t2 - sin t1) + (A x B)(t2 - t1)]
and the circle's arcs inside the ellipse 1/2 R^2 (phi2 - phi1).  The arcs
end where |c + A cos t + B sin t| = R, a trigonometric polynomial of
degree 2 in t, i.e. a quartic in z = exp(i t) (roots from the companion
matrix, polished by Newton on the real equation).  Extra break points do
no harm (an arc split in two sums the same), so each arc is classified by
its midpoint.  See Hughes & Chraibi, "Calculating ellipse overlap areas",
Computing and Visualization in Science 15 (2012), for the same scheme
between two ellipses.

The pixel integral.  The fraction is smooth inside a disc and outside it,
with (distance)^(3/2) kinks on the two curves where the ellipse touches
the aperture from outside and from inside (the disc's soft edge, about
the light's sharp image wide).  Each pixel is integrated by 4 x 4
Gauss-Legendre compared with the same rule on its four quarters,
recursing into quarters where they disagree by more than the tolerance
(1e-6 of the light's central value by default, which leaves every pixel
within about 2e-5 of it and each disc's energy within about 1e-7:
--check's third part measures that).

--check compares, independently of the ellipse algebra: the overlap at
random film points (edges included) against a polar quadrature about the
aperture centre whose radial hit interval comes from the ray-sphere
discriminant as a quadratic in r; pixels against a Monte Carlo of the
rays themselves (film point, lens point, ray-sphere intersection in 3-D);
and the pixel quadrature against the same at a 10x tighter tolerance.
"""
import argparse
import json
import math
import struct
import sys
import time

import numpy as np


class Refused(Exception):
    pass


def _vec(v, n=3):
    if isinstance(v, (int, float)):
        return np.full(n, float(v))
    return np.asarray(v, dtype=float)


def load_scene(path):
    """The scene's camera, film and lights, in camera coordinates."""
    with open(path) as fh:
        s = json.load(fh)
    cam = s.get("camera", {})
    if cam.get("model") != "thinlens":
        raise Refused("camera.model must be thinlens")
    for k, ok in (("aperture_shape", "disk"), ("aperture_ratio", 1),
                  ("f_number", 0), ("chromatic", None)):
        if k in cam and cam[k] != ok and not (k == "chromatic" and
                                              cam[k].get("mode", "off") == "off"):
            raise Refused("camera.%s must be left at its default" % k)
    if cam.get("focus_on") is not None:
        raise Refused("camera.focus_on is not modelled")
    e = _vec(cam.get("position", [0, 0, 0]))
    look = _vec(cam.get("look_at", [0, 0, -1]))
    upv = _vec(cam.get("up", [0, 1, 0]))
    f = look - e
    f /= np.linalg.norm(f)
    r = np.cross(f, upv)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    rend = s.get("render", {})
    W, H = int(rend.get("width", 640)), int(rend.get("height", 480))
    half_h = math.tan(float(cam.get("fov", 40.0)) * math.pi / 360.0)
    bg = s.get("background", 0)
    if np.any(_vec(bg) != 0) or s.get("environment") or s.get("lights"):
        raise Refused("background must be black, with no lights or environment")
    mats = s.get("materials", {})
    lights = []
    for i, o in enumerate(s.get("objects", [])):
        if o.get("type") != "sphere" or "transform" in o:
            raise Refused("objects[%d]: only untransformed spheres" % i)
        m = mats[o["material"]]
        if set(m) - {"emission"}:
            raise Refused("materials.%s: only emission" % o["material"])
        Cw = _vec(o["center"]) - e
        lights.append({"C": np.array([Cw @ r, Cw @ u, Cw @ f]),
                       "rho": float(o["radius"]),
                       "L": _vec(m["emission"])})
    return {"W": W, "H": H, "half_h": half_h, "half_w": half_h * W / H,
            "F": float(cam.get("focus_distance", 10.0)),
            "R": float(cam.get("aperture_radius", 0.0)), "lights": lights}


def focal_points(sc, fx, fy):
    """Q = F D for film points (fx, fy): arrays of shape fx.shape + (3,)."""
    sx = (2.0 * fx / sc["W"] - 1.0) * sc["half_w"]
    sy = (1.0 - 2.0 * fy / sc["H"]) * sc["half_h"]
    return sc["F"] * np.stack([sx, sy, np.ones_like(sx)], axis=-1)


def hit_ellipse(light, Q):
    """Centre c and semi-axis vectors A, B (A x B > 0) of the lens points
    whose rays through Q hit the light (module docstring)."""
    v = light["C"] - Q
    rho2 = light["rho"] ** 2
    v2 = v[..., :2]
    vz = v[..., 2]
    n2 = np.hypot(v2[..., 0], v2[..., 1])
    d = vz * vz - rho2
    if np.any(d <= 0):
        raise Refused("a light straddles the plane in focus")
    vv = np.einsum("...i,...i->...", v, v) - rho2
    qz = Q[..., 2]
    rho = light["rho"]
    c = Q[..., :2] - (qz * vz / d)[..., None] * v2
    a = qz * rho * np.sqrt(vv) / d
    b = qz * rho / np.sqrt(d)
    safe = np.where(n2 > 0, n2, 1.0)
    u1 = np.where((n2 > 0)[..., None], v2 / safe[..., None], [1.0, 0.0])
    u2 = np.stack([-u1[..., 1], u1[..., 0]], axis=-1)
    return c, u1 * a[..., None], u2 * b[..., None]


def _cross(p, q):
    return p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0]


def ellipse_disk_area(c, A, B, R):
    """Area of the ellipse {c + s A cos t + s B sin t, s <= 1} (A, B
    orthogonal, A x B > 0) inside the disk |p| <= R; arrays of N."""
    a = np.hypot(A[:, 0], A[:, 1])
    b = np.hypot(B[:, 0], B[:, 1])
    big = np.maximum(a, b)
    dc = np.hypot(c[:, 0], c[:, 1])
    out = np.zeros(len(c))
    inside = dc + big <= R
    out[inside] = math.pi * a[inside] * b[inside]
    edge = ~inside & (dc - big < R)
    if not np.any(edge):
        return out
    c, A, B, a, b = c[edge], A[edge], B[edge], a[edge], b[edge]
    n = len(c)
    cA = np.einsum("ij,ij->i", c, A)
    cB = np.einsum("ij,ij->i", c, B)
    k0 = np.einsum("ij,ij->i", c, c) - R * R
    # g(t) = |c + A cos t + B sin t|^2 - R^2 (A . B = 0) times z^2, z = e^{it}.
    p4 = (a * a - b * b) / 4.0
    p3 = cA - 1j * cB
    p2 = k0 + (a * a + b * b) / 2.0
    scale = np.maximum.reduce([np.abs(p3), np.abs(p2), np.abs(p4)])
    # A circle-like ellipse (a = b on the axis) drops the quartic's degree:
    # a tiny leading term puts the lost roots far from the unit circle.
    p4 = np.where(np.abs(p4) < 1e-9 * scale, 1e-9 * scale, p4)
    comp = np.zeros((n, 4, 4), dtype=complex)
    comp[:, 1, 0] = comp[:, 2, 1] = comp[:, 3, 2] = 1.0
    comp[:, 0, 0] = -p3 / p4
    comp[:, 0, 1] = -p2 / p4
    comp[:, 0, 2] = -np.conj(p3) / p4
    comp[:, 0, 3] = -1.0
    t = np.angle(np.linalg.eigvals(comp))
    for _ in range(4):  # Newton on the real equation g(t) = 0
        ct, st = np.cos(t), np.sin(t)
        x = c[:, None, :] + A[:, None, :] * ct[..., None] + B[:, None, :] * st[..., None]
        dx = -A[:, None, :] * st[..., None] + B[:, None, :] * ct[..., None]
        g = np.einsum("ijk,ijk->ij", x, x) - R * R
        dg = 2.0 * np.einsum("ijk,ijk->ij", x, dx)
        step = np.where(np.abs(dg) > 0, g / np.where(dg != 0, dg, 1.0), 0.0)
        t = t - np.clip(step, -0.05, 0.05)
    t = np.sort(np.mod(t, 2 * math.pi), axis=1)
    t1 = t
    t2 = np.concatenate([t[:, 1:], t[:, :1] + 2 * math.pi], axis=1)
    tm = 0.5 * (t1 + t2)
    xm = c[:, None, :] + A[:, None, :] * np.cos(tm)[..., None] + \
        B[:, None, :] * np.sin(tm)[..., None]
    arc_in = np.einsum("ijk,ijk->ij", xm, xm) < R * R
    cxA, cxB, AxB = _cross(c, A), _cross(c, B), _cross(A, B)
    ell = 0.5 * (cxA[:, None] * (np.cos(t2) - np.cos(t1)) +
                 cxB[:, None] * (np.sin(t2) - np.sin(t1)) +
                 AxB[:, None] * (t2 - t1))
    area = np.sum(np.where(arc_in, ell, 0.0), axis=1)
    # The circle's arcs between the same points' polar angles.
    x = c[:, None, :] + A[:, None, :] * np.cos(t)[..., None] + \
        B[:, None, :] * np.sin(t)[..., None]
    phi = np.sort(np.mod(np.arctan2(x[..., 1], x[..., 0]), 2 * math.pi), axis=1)
    f1 = phi
    f2 = np.concatenate([phi[:, 1:], phi[:, :1] + 2 * math.pi], axis=1)
    fm = 0.5 * (f1 + f2)
    pm = R * np.stack([np.cos(fm), np.sin(fm)], axis=-1) - c[:, None, :]
    ea = np.einsum("ijk,ik->ij", pm, A) / (a * a)[:, None]
    eb = np.einsum("ijk,ik->ij", pm, B) / (b * b)[:, None]
    circ_in = ea * ea + eb * eb < 1.0
    area += np.sum(np.where(circ_in, 0.5 * R * R * (f2 - f1), 0.0), axis=1)
    out[edge] = area
    return out


def fraction(sc, light, fx, fy):
    """Fraction of the aperture whose rays from film point (fx, fy) hit the
    light (flat arrays)."""
    Q = focal_points(sc, fx, fy)
    c, A, B = hit_ellipse(light, Q)
    R = sc["R"]
    return ellipse_disk_area(c, A, B, R) / (math.pi * R * R)


GL_X, GL_W = np.polynomial.legendre.leggauss(4)
GL_X = 0.5 * (GL_X + 1.0)
GL_W = 0.5 * GL_W


def _cells_rule(sc, light, x0, y0, h):
    """4 x 4 Gauss-Legendre means over the squares [x0, x0+h) x [y0, y0+h)."""
    fx = x0[:, None, None] + h[:, None, None] * GL_X[None, :, None]
    fy = y0[:, None, None] + h[:, None, None] * GL_X[None, None, :]
    fx, fy = np.broadcast_arrays(fx, fy)
    v = fraction(sc, light, fx.ravel(), fy.ravel()).reshape(fx.shape)
    return np.einsum("nij,i,j->n", v, GL_W, GL_W)


def integrate_pixels(sc, light, px, py, tol, max_depth=10):
    """Mean fraction over each pixel (px, py): adaptive cubature."""
    n = len(px)
    result = np.zeros(n)
    # Active cells: owner pixel, corner, side, coarse estimate.
    own = np.arange(n)
    x0 = px.astype(float)
    y0 = py.astype(float)
    h = np.ones(n)
    coarse = _cells_rule(sc, light, x0, y0, h)
    depth = 0
    while len(own):
        hh = h / 2
        qx = np.concatenate([x0, x0 + hh, x0, x0 + hh])
        qy = np.concatenate([y0, y0, y0 + hh, y0 + hh])
        qh = np.concatenate([hh] * 4)
        qo = np.concatenate([own] * 4)
        sub = _cells_rule(sc, light, qx, qy, qh).reshape(4, -1)
        fine = sub.mean(axis=0)
        # A cell of side h weighs h^2 in its pixel; the cells left to split
        # lie along the disc's edge curves, about 1/h of them a pixel, so
        # each may err by tol h in the pixel: |fine - coarse| h^2 <= tol h.
        ok = (np.abs(fine - coarse) * h <= tol) | (depth >= max_depth)
        np.add.at(result, own[ok], fine[ok] * h[ok] ** 2)
        keep = np.tile(~ok, 4)
        own, x0, y0, h = qo[keep], qx[keep], qy[keep], qh[keep]
        coarse = sub.ravel()[keep]
        depth += 1
    return result


def disc_box(sc, light):
    """The pixels [x0, x1) x [y0, y1) whose area can see the light: the
    support of the fraction, found on a 1/8-pixel grid around the light's
    projection and padded by a pixel."""
    C, rho, R, F = light["C"], light["rho"], sc["R"], sc["F"]
    fpx = sc["H"] / (2.0 * sc["half_h"])
    cx = (C[0] / C[2] / sc["half_w"] + 1.0) * sc["W"] / 2.0
    cy = (1.0 - C[1] / C[2] / sc["half_h"]) * sc["H"] / 2.0
    # Twice a generous radius: blur plus the sphere's apparent size.
    rad = 2.0 * fpx * (R * abs(1.0 / F - 1.0 / C[2]) + 2.0 * rho / (C[2] - rho)) + 4.0
    g = np.arange(-rad, rad, 0.125)
    gx, gy = np.meshgrid(cx + g, cy + g)
    v = fraction(sc, light, gx.ravel(), gy.ravel()).reshape(gx.shape)
    on = v > 0
    if on[0, :].any() or on[-1, :].any() or on[:, 0].any() or on[:, -1].any():
        raise RuntimeError("disc_box: the search window is too small")
    ys, xs = np.nonzero(on)
    x0 = int(math.floor(gx[0, xs.min()] - 0.125)) - 1
    x1 = int(math.floor(gx[0, xs.max()] + 0.125)) + 2
    y0 = int(math.floor(gy[ys.min(), 0] - 0.125)) - 1
    y1 = int(math.floor(gy[ys.max(), 0] + 0.125)) + 2
    return [x0, x1, y0, y1], (cx, cy)


def reference(sc, tol=1e-6, log=None):
    """The image (H, W, 3) and each light's disc box, energy and size."""
    W, H = sc["W"], sc["H"]
    img = np.zeros((H, W, 3))
    owner = np.full((H, W), -1)
    discs = []
    for k, light in enumerate(sc["lights"]):
        box, (cx, cy) = disc_box(sc, light)
        x0, x1, y0, y1 = box
        if x0 < 0 or y0 < 0 or x1 > W or y1 > H:
            raise Refused("light %d's disc %s leaves the %d x %d frame" % (k, box, W, H))
        if (owner[y0:y1, x0:x1] >= 0).any():
            other = int(owner[y0:y1, x0:x1].max())
            raise Refused("the discs of lights %d and %d overlap" % (other, k))
        owner[y0:y1, x0:x1] = k
        centre = fraction(sc, light, np.array([cx]), np.array([cy]))[0]
        py, px = np.mgrid[y0:y1, x0:x1]
        px, py = px.ravel(), py.ravel()
        frac = integrate_pixels(sc, light, px, py, tol * centre)
        img[py, px, :] = frac[:, None] * light["L"][None, :]
        diam = 2.0 * math.sqrt(np.sum(frac) / centre / math.pi)
        discs.append({"box": box, "centre_px": [cx, cy],
                      "energy": (img[y0:y1, x0:x1].sum(axis=(0, 1))).tolist(),
                      "diameter_px": diam, "centre_fraction": centre})
        if log:
            log("light %2d: box x %d-%d y %d-%d, disc %.1f px across, "
                "centre %.3g of the aperture" % (k, x0, x1, y0, y1, diam, centre))
    return img, discs


def write_exr(path, img):
    """An uncompressed single-part scanline EXR of float32 R, G, B (the
    OpenEXR file layout: openexr.com/en/latest/OpenEXRFileLayout.html)."""
    H, W, _ = img.shape

    def attr(name, typ, data):
        return name.encode() + b"\0" + typ.encode() + b"\0" + \
            struct.pack("<i", len(data)) + data
    chans = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1)
                     for c in "BGR") + b"\0"
    box = struct.pack("<4i", 0, 0, W - 1, H - 1)
    head = b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + \
        attr("channels", "chlist", chans) + \
        attr("compression", "compression", b"\0") + \
        attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box) + \
        attr("lineOrder", "lineOrder", b"\0") + \
        attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)) + \
        attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0)) + \
        attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0"
    line = 8 + 3 * W * 4
    offsets = [len(head) + 8 * H + y * line for y in range(H)]
    body = b"".join(struct.pack("<ii", y, 3 * W * 4) +
                    img[y, :, ::-1].T.astype("<f4").tobytes() for y in range(H))
    with open(path, "wb") as fh:
        fh.write(head + struct.pack("<%dQ" % H, *offsets) + body)


# ---- --check: the method against independent computations -------------

def polar_fraction(sc, light, fx, fy, n_angles=20000):
    """The fraction at one film point by quadrature in polar angle about
    the aperture centre: along each radius the lens points whose line
    through Q passes within rho of C satisfy |v x (r a - Q)|^2 <=
    rho^2 |r a - Q|^2, a quadratic in r (no ellipse algebra), so the hit
    interval [r1, r2] is known in closed form and the area is the integral
    over angle of (r2^2 - r1^2) / 2, both clipped to [0, R].  When the
    aperture centre does not see the light the angles with hits form one
    interval, whose ends (a double root in r) are found by bisection; the
    substitution theta = lo + (hi - lo) (1 - cos phi) / 2 takes away the
    square-root behaviour there, and the midpoint rule in phi is left
    with the kinks where the interval meets the rim (error ~ n^-2)."""
    Q = focal_points(sc, np.array(fx), np.array(fy))
    v = light["C"] - Q
    rho2, R = light["rho"] ** 2, sc["R"]
    vxQ = np.cross(v, Q)

    def interval(th):
        a = np.stack([np.cos(th), np.sin(th), np.zeros_like(th)], axis=-1)
        vxa = np.cross(v, a)
        qa = np.einsum("ij,ij->i", vxa, vxa) - rho2
        if np.any(qa <= 0):
            raise RuntimeError("polar_fraction: an unbounded hit set")
        qb = -2.0 * (vxa @ vxQ) + 2.0 * rho2 * (a @ Q)
        qc = vxQ @ vxQ - rho2 * (Q @ Q)
        disc = qb * qb - 4 * qa * qc
        sq = np.sqrt(np.maximum(disc, 0.0))
        return disc, (-qb - sq) / (2 * qa), (-qb + sq) / (2 * qa)

    def seg(th):
        disc, r1, r2 = interval(th)
        r1, r2 = np.clip(r1, 0.0, R), np.clip(r2, 0.0, R)
        return np.where(disc > 0, 0.5 * (r2 * r2 - r1 * r1), 0.0)

    norm = math.pi * R * R
    grid = (np.arange(4096) + 0.5) * 2 * math.pi / 4096
    disc, r1, r2 = interval(grid)
    hit = (disc > 0) & (r2 > 0)
    if hit.all():
        th = (np.arange(n_angles) + 0.5) * 2 * math.pi / n_angles
        return seg(th).sum() * (2 * math.pi / n_angles) / norm
    if not hit.any():
        return 0.0
    k = int(np.argmin(hit))  # a miss: start there, so the hits are one run
    order = (np.arange(4096) + k) % 4096
    h = hit[order]
    idx = np.nonzero(h)[0]
    s, e = idx[0], idx[-1]
    if e - s + 1 != len(idx):
        raise RuntimeError("polar_fraction: the hit angles are not one interval")
    step = 2 * math.pi / 4096
    th0 = grid[order[0]]

    def at(i):  # grid angle i of the rolled order, unwrapped
        return th0 + i * step

    def edge(inside, outside):
        for _ in range(60):
            mid = 0.5 * (inside + outside)
            if interval(np.array([mid]))[0][0] > 0:
                inside = mid
            else:
                outside = mid
        return inside
    lo = edge(at(s), at(s - 1))
    hi = edge(at(e), at(e + 1))
    phi = (np.arange(n_angles) + 0.5) * math.pi / n_angles
    th = lo + (hi - lo) * (1 - np.cos(phi)) / 2
    dth = (hi - lo) * np.sin(phi) / 2
    return np.sum(seg(th) * dth) * (math.pi / n_angles) / norm


def mc_pixels(sc, light, px, py, n, rng):
    """Monte Carlo pixel values (fraction units) and their standard errors:
    uniform film points in the pixel, lens points uniform in a box around
    the hit set (widened by half, so never too small), the ray traced
    against the sphere in 3-D and counted when it hits within the
    aperture.  The box is the only thing taken from the ellipse algebra."""
    R, C, rho2 = sc["R"], light["C"], light["rho"] ** 2
    m = len(px)
    fx = px[:, None] + rng.random((m, n))
    fy = py[:, None] + rng.random((m, n))
    Q = focal_points(sc, fx, fy)
    c, A, B = hit_ellipse(light, Q)
    ext = 1.5 * np.sqrt(A ** 2 + B ** 2)  # the ellipse's half extents
    lo = np.maximum(c - ext, -R)
    hi = np.minimum(c + ext, R)
    span = np.maximum(hi - lo, 0.0)
    u = rng.random((m, n, 2))
    p = lo + span * u
    o = np.concatenate([p, np.zeros((m, n, 1))], axis=-1)
    d = Q - o
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    oc = o - C
    bq = np.einsum("ijk,ijk->ij", oc, d)
    cq = np.einsum("ijk,ijk->ij", oc, oc) - rho2
    disc = bq * bq - cq
    t = -bq - np.sqrt(np.maximum(disc, 0.0))
    hit = (disc >= 0) & (t > 0) & (np.einsum("ijk,ijk->ij", p, p) <= R * R)
    val = hit * span[..., 0] * span[..., 1] / (math.pi * R * R)
    return val.mean(axis=1), val.std(axis=1) / math.sqrt(n)


def check(sc, args):
    rng = np.random.default_rng(27)
    worst = 0.0
    # 1. The overlap at film points against the polar quadrature: points
    # across each disc's edge (where the ellipse meets the aperture's rim)
    # and inside.
    print("check 1: the overlap at film points, Green's theorem against a "
          "polar quadrature (20000 angles)")
    for k, light in enumerate(sc["lights"][:args.check_lights]):
        box, (cx, cy) = disc_box(sc, light)
        half = 0.5 * (box[1] - box[0] - 2)
        pts = []
        for _ in range(40):
            ang = rng.random() * 2 * math.pi
            rr = half * (0.6 + 0.45 * rng.random()) if rng.random() < 0.8 else \
                half * rng.random()
            pts.append((cx + rr * math.cos(ang), cy + rr * math.sin(ang)))
        fx = np.array([p[0] for p in pts])
        fy = np.array([p[1] for p in pts])
        green = fraction(sc, light, fx, fy)
        polar = np.array([polar_fraction(sc, light, x, y) for x, y in pts])
        centre = fraction(sc, light, np.array([cx]), np.array([cy]))[0]
        err = np.max(np.abs(green - polar)) / centre
        worst = max(worst, err)
        print("  light %2d: %d points (%d on the edge), max |green - polar| = "
              "%.2e of the centre value" % (k, len(pts),
                                           int(np.sum((green > 0) & (green < 0.99 * centre))), err))
    print("  worst %.2e" % worst)
    # 2. Pixels against the Monte Carlo of the rays.
    print("check 2: pixels against a Monte Carlo of the rays (%d samples a pixel)"
          % args.check_mc)
    zs_all, emc, eref = [], 0.0, 0.0
    for k, light in enumerate(sc["lights"][:args.check_lights]):
        box, (cx, cy) = disc_box(sc, light)
        py, px = np.mgrid[box[2]:box[3], box[0]:box[1]]
        px, py = px.ravel(), py.ravel()
        centre = fraction(sc, light, np.array([cx]), np.array([cy]))[0]
        ref = integrate_pixels(sc, light, px, py, args.tol * centre)
        sel = ref > 0
        mc = np.zeros(len(px))
        se = np.zeros(len(px))
        for i0 in range(0, len(px), 64):
            s = slice(i0, i0 + 64)
            mc[s], se[s] = mc_pixels(sc, light, px[s], py[s], args.check_mc, rng)
        sel &= se > 0  # (a pixel's samples that all missed say nothing of spread)
        z = (mc[sel] - ref[sel]) / se[sel]
        zs_all.append(z)
        tot_se = math.sqrt(np.sum(se ** 2))
        print("  light %2d: %4d lit pixels, mean z %+.3f, rms z %.3f, energy "
              "MC/ref - 1 = %+.2e (+- %.1e)" % (k, sel.sum(), z.mean(),
                                                 math.sqrt(np.mean(z * z)),
                                                 mc.sum() / ref.sum() - 1,
                                                 tot_se / ref.sum()))
        emc += mc.sum()
        eref += ref.sum()
    z = np.concatenate(zs_all)
    print("  all: %d pixels, mean z %+.3f (expected 0 +- %.3f), rms z %.3f "
          "(expected about 1), |z| > 4: %d" % (len(z), z.mean(),
                                               1 / math.sqrt(len(z)),
                                               math.sqrt(np.mean(z * z)),
                                               int(np.sum(np.abs(z) > 4))))
    # 3. The pixel quadrature against itself at a 100x tighter tolerance.
    print("check 3: the pixel quadrature at tolerance %g against %g"
          % (args.tol, args.tol / 10))
    worst_px, worst_e = 0.0, 0.0
    for k, light in enumerate(sc["lights"][:args.check_lights]):
        box, (cx, cy) = disc_box(sc, light)
        py, px = np.mgrid[box[2]:box[3], box[0]:box[1]]
        px, py = px.ravel(), py.ravel()
        centre = fraction(sc, light, np.array([cx]), np.array([cy]))[0]
        a = integrate_pixels(sc, light, px, py, args.tol * centre)
        b = integrate_pixels(sc, light, px, py, args.tol / 10 * centre)
        worst_px = max(worst_px, np.max(np.abs(a - b)) / centre)
        worst_e = max(worst_e, abs(a.sum() / b.sum() - 1))
    print("  worst pixel difference %.2e of the centre value, worst disc "
          "energy difference %.2e" % (worst_px, worst_e))
    ok = worst < 1e-8 and abs(z.mean()) < 4 / math.sqrt(len(z)) and \
        abs(math.sqrt(np.mean(z * z)) - 1) < 0.1 and worst_px < 3e-5
    print("check: %s" % ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--out", help="the image as float64 .npy (H, W, 3)")
    ap.add_argument("--exr", help="the image as float32 EXR")
    ap.add_argument("--discs", help="each light's disc box and energy (JSON)")
    ap.add_argument("--tol", type=float, default=1e-6,
                    help="pixel quadrature tolerance, of the light's central value")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--check-lights", type=int, default=4)
    ap.add_argument("--check-mc", type=int, default=4096)
    args = ap.parse_args()
    try:
        sc = load_scene(args.scene)
        if sc["R"] <= 0:
            raise Refused("camera.aperture_radius must be > 0")
        if args.check:
            return check(sc, args)
        t = time.time()
        img, discs = reference(sc, args.tol, log=lambda m: print(m, file=sys.stderr))
    except Refused as e:
        print("reference.py: %s: %s" % (args.scene, e), file=sys.stderr)
        return 3
    print("reference: %d lights, %.1f s, image mean %.6g" %
          (len(discs), time.time() - t, img.mean()), file=sys.stderr)
    if args.out:
        np.save(args.out, img)
    if args.exr:
        write_exr(args.exr, img)
    if args.discs:
        with open(args.discs, "w") as fh:
            json.dump(discs, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
