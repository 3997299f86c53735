#!/usr/bin/env python3
"""gltf_depth_check.py: lensray's Z channel of a glTF file against an
independent pinhole ray caster.

    python3 tests/gltf_depth_check.py LENSRAY FILE [--size W H]
        [--camera EYE_X,EYE_Y,EYE_Z,AT_X,AT_Y,AT_Z,FOV]

It reads the glTF itself (numpy only: no libassimp, nothing of lensray's):
the GLB container or the JSON, buffers from data: URIs or files beside it,
accessors with their byteStride, normalization and sparse substitution
(spec 3.6.2), morph targets at the node's or mesh's weights (3.7.2.2),
skins at their joints' own transforms (3.7.3.3),
triangle lists, strips and fans (3.7.2.1), node transforms
(3.5.2: a column-major matrix, or T * R * S, parent times child) of the
displayed scene ("scene", else scenes[0]).  The camera is the file's first
camera node in index order (lensray's documented choice), looking down its
node's -Z with +Y up (3.10.1), yfov vertical, the image height
round(width / aspectRatio); or, with --camera, a camera lensray is given in
a scene that wraps the file.  One ray per pixel centre, Moller-Trumbore
against every triangle, the hit's distance along the view axis compared
with lensray's Z (docs/scene-format.md, 14).

Pixels on a silhouette or a jump in depth are left out: those where a
ray 0.02 pixels away from the centre, in any of four directions, hits
nothing, or something at a depth more than 1e-3 away (relative), while
the centre's does not; there a ray a float away from the pixel centre may
hit another surface.  Prints one JSON line:
the pixels compared, the max and median relative difference, and the
pixels where one side hit and the other did not.  Exit 1 when the max
relative difference exceeds --tol (default 1e-4) or any non-edge pixel
disagrees on hit or miss.
"""
import argparse
import base64
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import urllib.parse

import numpy as np

NONE = 1e10
COMP = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
        5125: np.uint32, 5126: np.float32}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4,
         "MAT3": 9, "MAT4": 16}


# ---- the file --------------------------------------------------------------

def load(path):
    raw = open(path, "rb").read()
    binchunk = None
    if raw[:4] == b"glTF":
        jlen = struct.unpack_from("<I", raw, 12)[0]
        doc = json.loads(raw[20:20 + jlen])
        at = 20 + jlen
        if at + 8 <= len(raw):
            blen = struct.unpack_from("<I", raw, at)[0]
            binchunk = raw[at + 8:at + 8 + blen]
    else:
        doc = json.loads(raw.decode("utf-8-sig"))
    bufs = []
    for i, b in enumerate(doc.get("buffers", [])):
        uri = b.get("uri")
        if uri is None:
            bufs.append(binchunk)
        elif uri.startswith("data:"):
            bufs.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            f = os.path.join(os.path.dirname(path), urllib.parse.unquote(uri))
            bufs.append(open(f, "rb").read())
    return doc, bufs


def read_view(doc, bufs, view_index, offset, count, comp, n):
    """count elements of n components of type comp from a bufferView."""
    v = doc["bufferViews"][view_index]
    data = bufs[v["buffer"]]
    dt = np.dtype(COMP[comp]).newbyteorder("<")
    esize = dt.itemsize * n
    stride = v.get("byteStride", 0) or esize
    start = v.get("byteOffset", 0) + offset
    out = np.empty((count, n), dtype=dt)
    for i in range(count):
        out[i] = np.frombuffer(data, dtype=dt, count=n,
                               offset=start + i * stride)
    return out


def accessor(doc, bufs, k):
    """Accessor k as float64 (count, n): normalized integers scaled as
    spec 3.11 says, sparse values substituted (3.6.2.3)."""
    a = doc["accessors"][k]
    n = NCOMP[a["type"]]
    comp = a["componentType"]
    if "bufferView" in a:
        x = read_view(doc, bufs, a["bufferView"], a.get("byteOffset", 0),
                      a["count"], comp, n)
    else:
        x = np.zeros((a["count"], n), dtype=COMP[comp])
    sp = a.get("sparse")
    if sp is not None:
        ix = sp["indices"]
        idx = read_view(doc, bufs, ix["bufferView"], ix.get("byteOffset", 0),
                        sp["count"], ix["componentType"], 1)[:, 0]
        vals = sp["values"]
        val = read_view(doc, bufs, vals["bufferView"],
                        vals.get("byteOffset", 0), sp["count"], comp, n)
        x = x.copy()
        x[idx.astype(np.int64)] = val
    x = x.astype(np.float64)
    if a.get("normalized"):
        x = {5120: lambda v: np.maximum(v / 127.0, -1.0),
             5121: lambda v: v / 255.0,
             5122: lambda v: np.maximum(v / 32767.0, -1.0),
             5123: lambda v: v / 65535.0}[comp](x)
    return x


def triangles(doc, bufs, prim):
    """The primitive's triangles as vertex indices (m, 3); none for points
    and lines (spec 3.7.2.1: strips alternate, fans turn about vertex 0)."""
    mode = prim.get("mode", 4)
    npos = doc["accessors"][prim["attributes"]["POSITION"]]["count"]
    if "indices" in prim:
        idx = accessor(doc, bufs, prim["indices"])[:, 0].astype(np.int64)
    else:
        idx = np.arange(npos)
    if mode == 4:
        return idx[:len(idx) // 3 * 3].reshape(-1, 3)
    if mode == 5:
        t = [(idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2])
             for i in range(len(idx) - 2)]
        return np.array(t, dtype=np.int64).reshape(-1, 3)
    if mode == 6:
        t = [(idx[i + 1], idx[i + 2], idx[0]) for i in range(len(idx) - 2)]
        return np.array(t, dtype=np.int64).reshape(-1, 3)
    return np.zeros((0, 3), dtype=np.int64)


def local_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = math.sqrt(x * x + y * y + z * z + w * w) or 1
    x, y, z, w = x / s, y / s, z / s, w / s
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w),
                   2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z),
                   2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w),
                   1 - 2 * (x * x + y * y)]])
    T = np.eye(4)
    T[:3, 3] = node.get("translation", [0, 0, 0])
    Rm = np.eye(4)
    Rm[:3, :3] = R
    S = np.diag(list(node.get("scale", [1, 1, 1])) + [1.0])
    return T @ Rm @ S


def walk(doc, roots):
    """{node index: world matrix} of the trees under `roots`."""
    nodes = doc.get("nodes", [])
    out = {}
    stack = [(r, np.eye(4)) for r in roots]
    while stack:
        i, parent = stack.pop()
        m = parent @ local_matrix(nodes[i])
        out[i] = m
        stack.extend((c, m) for c in nodes[i].get("children", []))
    return out


def world_matrices(doc):
    """{node index: world matrix} of the displayed scene's nodes."""
    scenes = doc.get("scenes", [])
    if not scenes:
        return {}
    return walk(doc, scenes[doc.get("scene", 0)].get("nodes", []))


def all_world_matrices(doc):
    """{node index: world matrix} of every node, in a scene or not (a
    skin's joints need not be)."""
    nodes = doc.get("nodes", [])
    child = {c for n in nodes for c in n.get("children", [])}
    return walk(doc, [r for r in range(len(nodes)) if r not in child])


def skinned(doc, bufs, prim, skin, p):
    """Positions p skinned (spec 3.7.3.3): the sum of weight x joint's
    world matrix x inverse bind matrix, the mesh node's own transform
    ignored."""
    allw = all_world_matrices(doc)
    nj = len(skin["joints"])
    if "inverseBindMatrices" in skin:
        ibm = accessor(doc, bufs, skin["inverseBindMatrices"])[:nj]
        ibm = ibm.reshape(-1, 4, 4).transpose(0, 2, 1)
    else:
        ibm = np.tile(np.eye(4), (nj, 1, 1))
    J = np.array([allw[j] for j in skin["joints"]]) @ ibm
    ph = np.c_[p, np.ones(len(p))]
    out = np.zeros_like(ph)
    k = 0
    while "JOINTS_%d" % k in prim["attributes"]:
        jt = accessor(doc, bufs, prim["attributes"]["JOINTS_%d" % k])
        wt = accessor(doc, bufs, prim["attributes"]["WEIGHTS_%d" % k])
        for c in range(4):
            M = J[jt[:, c].astype(int)]
            out += wt[:, c:c + 1] * np.einsum("vij,vj->vi", M, ph)
        k += 1
    return out[:, :3]


def world_triangles(doc, bufs, world):
    tris = []
    for i, m in world.items():
        node = doc["nodes"][i]
        if "mesh" not in node:
            continue
        mesh = doc["meshes"][node["mesh"]]
        weights = node.get("weights", mesh.get("weights", []))
        for prim in mesh["primitives"]:
            p = accessor(doc, bufs, prim["attributes"]["POSITION"])
            # Morph targets at the default weights (spec 3.7.2.2).
            for w, t in zip(weights, prim.get("targets", [])):
                if "POSITION" in t:
                    p = p + w * accessor(doc, bufs, t["POSITION"])
            if "skin" in node:
                w = skinned(doc, bufs, prim, doc["skins"][node["skin"]], p)
            else:
                w = (m[:3, :3] @ p.T).T + m[:3, 3]
            t = triangles(doc, bufs, prim)
            if len(t):
                tris.append(w[t])
    return np.concatenate(tris) if tris else np.zeros((0, 3, 3))


# ---- the camera and the rays ---------------------------------------------

def gltf_camera(doc, world, width):
    """(eye, forward, up, yfov, height) of the first camera node in index
    order, or None."""
    for i in sorted(world):
        node = doc["nodes"][i]
        if "camera" not in node:
            continue
        cam = doc["cameras"][node["camera"]]
        per = cam["perspective"]
        m = world[i]
        eye = m[:3, 3]
        fwd = m[:3, :3] @ np.array([0, 0, -1.0])
        up = m[:3, :3] @ np.array([0, 1.0, 0])
        ar = per.get("aspectRatio")
        height = max(1, int(math.floor(width / ar + 0.5))) if ar else None
        return eye, fwd, up, per["yfov"], height
    return None


class Camera:
    """A pinhole at eye looking along fwd, up-vector up, vertical field
    yfov, w x h pixels; pixel (i, j) has its centre at (i + 0.5, j + 0.5),
    j down from the top (docs/scene-format.md, 5)."""

    def __init__(self, eye, fwd, up, yfov, w, h):
        self.eye, self.w, self.h = np.asarray(eye, float), w, h
        self.f = fwd / np.linalg.norm(fwd)
        r = np.cross(self.f, up)
        self.r = r / np.linalg.norm(r)
        self.u = np.cross(self.r, self.f)
        self.th = math.tan(yfov / 2)

    def dirs(self, i, j):
        """Directions through image points (i, j) (arrays, in pixels)."""
        x = (2 * i / self.w - 1) * self.th * self.w / self.h
        y = (1 - 2 * j / self.h) * self.th
        return self.f + x[..., None] * self.r + y[..., None] * self.u

    def boxes(self, tris):
        """Each triangle's pixel box (i0, i1, j0, j1), one pixel wider; the
        whole image for one reaching behind the eye, where the projection
        of its corners says nothing."""
        v = tris - self.eye
        z = v @ self.f
        front = np.all(z > 1e-12 * np.abs(v).max(axis=2), axis=1)
        zs = np.where(z > 0, z, 1)
        px = ((v @ self.r) / zs / (self.th * self.w / self.h) + 1) * self.w / 2
        py = (1 - (v @ self.u) / zs / self.th) * self.h / 2
        big = 1e18
        box = np.stack([px.min(1) - 1, px.max(1) + 1, py.min(1) - 1,
                        py.max(1) + 1], axis=1)
        box[~front] = [-big, big, -big, big]
        return np.nan_to_num(box, nan=0, posinf=big, neginf=-big)


def cast(eye, dirs, tris):
    """Nearest hit distance along each (unnormalized) direction, inf for
    a miss: Moller & Trumbore (1997), double precision."""
    best = np.full(len(dirs), np.inf)
    if len(tris) == 0:
        return best
    v0 = tris[:, 0]
    e1 = tris[:, 1] - v0
    e2 = tris[:, 2] - v0
    tv = eye - v0
    q = np.cross(tv, e1)
    tq = np.einsum("tk,tk->t", e2, q)
    step = max(1, 400000 // len(tris))
    for s in range(0, len(dirs), step):
        d = dirs[s:s + step]
        p = np.cross(d[:, None, :], e2[None])
        det = np.einsum("rtk,tk->rt", p, e1)
        ok = np.abs(det) > 1e-300
        inv = np.where(ok, 1.0 / np.where(ok, det, 1), 0)
        uu = np.einsum("rtk,tk->rt", p, tv) * inv
        vv = (d @ q.T) * inv
        t = tq[None] * inv
        hit = ok & (uu >= 0) & (vv >= 0) & (uu + vv <= 1) & (t > 0)
        best[s:s + step] = np.where(hit, t, np.inf).min(axis=1)
    return best


OFFSETS = ((0, 0), (0.02, 0), (-0.02, 0), (0, 0.02), (0, -0.02))


def depths(cam, tris, tile=8):
    """Z at the pixel centres and at the four points 0.02 pixels off each,
    shape (5, h, w): one tile of pixels at a time, against the triangles
    whose box meets the tile."""
    out = np.full((len(OFFSETS), cam.h, cam.w), np.inf)
    box = cam.boxes(tris)
    for j0 in range(0, cam.h, tile):
        for i0 in range(0, cam.w, tile):
            j1, i1 = min(j0 + tile, cam.h), min(i0 + tile, cam.w)
            sel = ((box[:, 1] >= i0) & (box[:, 0] <= i1) &
                   (box[:, 3] >= j0) & (box[:, 2] <= j1))
            if not sel.any():
                continue
            jj, ii = np.mgrid[j0:j1, i0:i1] + 0.5
            d = np.concatenate([cam.dirs(ii + dx, jj + dy).reshape(-1, 3)
                                for dx, dy in OFFSETS])
            z = cast(cam.eye, d, tris[sel]) * (d @ cam.f)
            out[:, j0:j1, i0:i1] = z.reshape(len(OFFSETS), j1 - j0, i1 - i0)
    return out


# ---- lensray ----------------------------------------------------------------

def read_z(exr):
    import OpenEXR
    with OpenEXR.File(exr) as f:
        ch = f.channels()
        return np.asarray(ch["Z"].pixels, dtype=np.float64)


def render(lensray, path, w, h, cam):
    out = tempfile.mkdtemp(prefix="gltfdepth")
    exr = os.path.join(out, "z.exr")
    args = [lensray, "render"]
    if cam is None:
        args += [path, "--set", "render.width=%d" % w]
        if h is not None:
            args += ["--set", "render.height=%d" % h]
    else:
        eye, at, fov = cam[:3], cam[3:6], cam[6]
        scene = {"render": {"width": w, "height": h},
                 "camera": {"position": eye, "look_at": at, "fov": fov},
                 "objects": [{"type": "gltf",
                              "file": os.path.abspath(path)}]}
        sj = os.path.join(out, "scene.json")
        with open(sj, "w") as f:
            json.dump(scene, f)
        args += [sj]
    args += ["-o", exr, "--depth", "--set", "render.spp=1", "-q"]
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError("lensray failed (%d): %s" % (p.returncode,
                                                        p.stderr.strip()))
    return read_z(exr)


def compare(mine, theirs, edge, tol):
    hit_m = np.isfinite(mine)
    hit_t = theirs < NONE
    both = hit_m & hit_t & ~edge
    rel = np.abs(theirs[both] - mine[both]) / mine[both]
    disagree = int(np.sum((hit_m != hit_t) & ~edge))
    res = {"pixels": int(both.sum()), "edge": int(edge.sum()),
           "max_rel": float(rel.max()) if len(rel) else 0.0,
           "median_rel": float(np.median(rel)) if len(rel) else 0.0,
           "hit_miss_disagree": disagree}
    res["ok"] = bool(res["pixels"] > 0 and res["max_rel"] <= tol and
                     disagree == 0)
    return res


def auto_camera(tris):
    """A camera string viewing the triangles' box from the front, up and
    to the right, the box's sphere filling a 40 degree field."""
    lo = tris.reshape(-1, 3).min(axis=0)
    hi = tris.reshape(-1, 3).max(axis=0)
    mid, r = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2 or 1
    eye = mid + np.array([0.3, 0.4, 1]) / np.linalg.norm([0.3, 0.4, 1]) * (
        r / math.sin(math.radians(20)))
    return ",".join("%.17g" % v for v in list(eye) + list(mid) + [40])


def silhouettes(z):
    """Pixels whose rays 0.02 pixels off hit something else (z from
    depths())."""
    mine = z[0]
    edge = np.zeros(mine.shape, dtype=bool)
    for o in z[1:]:
        same = (np.isinf(o) & np.isinf(mine)) | (
            np.abs(o - mine) <= 1e-3 * np.minimum(o, mine))
        edge |= ~same
    return edge


def check(lensray, path, size=(64, 48), camera=None, tol=1e-4):
    """The comparison of one file as a dict ("ok" says the verdict);
    camera None: the file's own, "auto": auto_camera, else a string
    "eye,at,fov" of 7 numbers."""
    doc, bufs = load(path)
    world = world_matrices(doc)
    tris = world_triangles(doc, bufs, world)
    w, h = size
    if camera == "auto":
        camera = auto_camera(tris)
    height_given = True
    if camera:
        c = [float(v) for v in camera.split(",")]
        eye, at = np.array(c[:3]), np.array(c[3:6])
        fwd, up, yfov = at - eye, np.array([0, 1.0, 0]), math.radians(c[6])
        cam = c
    else:
        g = gltf_camera(doc, world, w)
        if g is None:
            return {"file": path, "ok": False, "why": "no camera"}
        eye, fwd, up, yfov, gh = g
        height_given = gh is None
        h = gh if gh is not None else h
        cam = None
    np.seterr(invalid="ignore")
    z = depths(Camera(eye, fwd, up, yfov, w, h), tris)
    try:
        theirs = render(lensray, path, w, h if height_given else None, cam)
    except RuntimeError as e:
        return {"file": path, "ok": False, "why": str(e)}
    if theirs.size != w * h:
        return {"file": path, "ok": False,
                "why": "lensray's image has %d pixels, the checker's %d x %d"
                % (theirs.size, w, h)}
    res = compare(z[0], theirs.reshape(h, w), silhouettes(z), tol)
    res["file"] = os.path.basename(path)
    res["size"] = [w, h]
    return res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("lensray")
    ap.add_argument("file")
    ap.add_argument("--size", nargs=2, type=int, default=[64, 48])
    ap.add_argument("--camera")
    ap.add_argument("--tol", type=float, default=1e-4)
    a = ap.parse_args()
    res = check(a.lensray, a.file, a.size, a.camera, a.tol)
    print(json.dumps(res))
    return 0 if res["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
