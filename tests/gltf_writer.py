#!/usr/bin/env python3
"""gltf_writer.py: writes small glTF 2.0 files (.gltf with a base64 buffer,
or .glb) for the tests, the fuzz seeds and the gallery, from Python lists,
with the standard library only.  Nothing is downloaded.

    python3 tests/gltf_writer.py NAME OUT     writes one of the named scenes
                                              below (OUT ends in .gltf/.glb)

The glTF layout follows the specification (Khronos, glTF 2.0, sections
3.6 "Binary data storage", 3.7 "Geometry", 4.4 "GLB file format").
"""
import base64
import json
import math
import struct
import sys
import zlib

FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125


class Gltf:
    def __init__(self):
        self.doc = {"asset": {"version": "2.0", "generator": "lensray tests"},
                    "scenes": [{"nodes": []}], "scene": 0, "nodes": [],
                    "meshes": [], "accessors": [], "bufferViews": [],
                    "buffers": []}
        self.bin = bytearray()

    def _view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.doc["bufferViews"].append(v)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, values, kind, comp=FLOAT, target=None):
        """values: a flat list; kind: SCALAR, VEC2, VEC3."""
        n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[kind]
        fmt = {FLOAT: "f", USHORT: "H", UINT: "I"}[comp]
        view = self._view(struct.pack("<%d%s" % (len(values), fmt), *values),
                          target)
        a = {"bufferView": view, "componentType": comp,
             "count": len(values) // n, "type": kind}
        if kind == "VEC3" and comp == FLOAT:
            a["min"] = [min(values[k::3]) for k in range(3)]
            a["max"] = [max(values[k::3]) for k in range(3)]
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def uv_accessor(self, uvs, comp, normalized=True):
        """Texture coordinates as unsigned bytes or shorts, c = round(uv x
        255 or 65535), normalized (spec 3.7.2.1) unless told not."""
        top = 255 if comp == UBYTE else 65535
        raw = struct.pack("<%d%s" % (len(uvs), "B" if comp == UBYTE else "H"),
                          *[round(c * top) for c in uvs])
        view = self._view(raw + b"\0" * (-len(raw) % 4), 34962)
        a = {"bufferView": view, "componentType": comp,
             "count": len(uvs) // 2, "type": "VEC2"}
        if normalized:
            a["normalized"] = True
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def mesh(self, positions, indices, normals=None, uvs=None, material=None,
             uv_comp=FLOAT, uv_normalized=True):
        attrs = {"POSITION": self.accessor(positions, "VEC3", target=34962)}
        if normals is not None:
            attrs["NORMAL"] = self.accessor(normals, "VEC3", target=34962)
        if uvs is not None and uv_comp != FLOAT:
            attrs["TEXCOORD_0"] = self.uv_accessor(uvs, uv_comp, uv_normalized)
        elif uvs is not None:
            attrs["TEXCOORD_0"] = self.accessor(uvs, "VEC2", target=34962)
        prim = {"attributes": attrs,
                "indices": self.accessor(indices, "SCALAR", UINT, 34963)}
        if material is not None:
            prim["material"] = material
        self.doc["meshes"].append({"primitives": [prim]})
        return len(self.doc["meshes"]) - 1

    def node(self, root=True, **kw):
        self.doc["nodes"].append(kw)
        i = len(self.doc["nodes"]) - 1
        if root:
            self.doc["scenes"][0]["nodes"].append(i)
        return i

    def material(self, m):
        self.doc.setdefault("materials", []).append(m)
        return len(self.doc["materials"]) - 1

    def camera(self, c):
        self.doc.setdefault("cameras", []).append(c)
        return len(self.doc["cameras"]) - 1

    def light(self, light):
        ext = self.doc.setdefault("extensions", {}).setdefault(
            "KHR_lights_punctual", {"lights": []})
        self.doc.setdefault("extensionsUsed", [])
        if "KHR_lights_punctual" not in self.doc["extensionsUsed"]:
            self.doc["extensionsUsed"].append("KHR_lights_punctual")
        ext["lights"].append(light)
        return len(ext["lights"]) - 1

    def use_extension(self, name):
        used = self.doc.setdefault("extensionsUsed", [])
        if name not in used:
            used.append(name)

    def image_png(self, png, mime="image/png"):
        """An image stored in the buffer (a bufferView), and its texture."""
        view = self._view(png)
        self.doc.setdefault("images", []).append(
            {"bufferView": view, "mimeType": mime})
        self.doc.setdefault("samplers", [{}])
        self.doc.setdefault("textures", []).append(
            {"source": len(self.doc["images"]) - 1, "sampler": 0})
        return len(self.doc["textures"]) - 1

    def gltf_text(self, bin_uri=None):
        doc = json.loads(json.dumps(self.doc))
        if bin_uri is None:
            bin_uri = ("data:application/octet-stream;base64," +
                       base64.b64encode(bytes(self.bin)).decode())
        doc["buffers"] = [{"uri": bin_uri, "byteLength": len(self.bin)}]
        return json.dumps(doc, indent=1)

    def glb_bytes(self):
        doc = json.loads(json.dumps(self.doc))
        doc["buffers"] = [{"byteLength": len(self.bin)}]
        js = json.dumps(doc).encode()
        js += b" " * (-len(js) % 4)
        bn = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        total = 12 + 8 + len(js) + 8 + len(bn)
        return (struct.pack("<4sII", b"glTF", 2, total) +
                struct.pack("<I4s", len(js), b"JSON") + js +
                struct.pack("<I4s", len(bn), b"BIN\0") + bn)

    def write(self, path):
        """A .glb, or a .gltf: its buffer as a data: URI, or when
        self.bin_file names one, that file beside it (the URI percent-
        escaped, RFC 3986, as exporters write names with spaces)."""
        if path.endswith(".glb"):
            with open(path, "wb") as f:
                f.write(self.glb_bytes())
            return
        uri = None
        name = getattr(self, "bin_file", None)
        if name:
            import os.path
            import urllib.parse
            with open(os.path.join(os.path.dirname(path), name), "wb") as f:
                f.write(bytes(self.bin))
            uri = urllib.parse.quote(name)
        with open(path, "w") as f:
            f.write(self.gltf_text(uri))


def png_rgb(w, h, pixel):
    """An 8-bit RGB PNG; pixel(x, y) gives (r, g, b) bytes, y = 0 on top
    (PNG specification, 2nd ed., sections 5 and 11.2)."""
    raw = bytearray()
    for y in range(h):
        raw.append(0)
        for x in range(w):
            raw += bytes(pixel(x, y))

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff))
    return (b"\x89PNG\r\n\x1a\n" +
            chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(bytes(raw))) + chunk(b"IEND", b""))


# ---- shapes ------------------------------------------------------------

def corners_png():
    """A 2 x 2 PNG: red top left, green top right, blue bottom left, white
    bottom right."""
    cols = {(0, 0): (255, 0, 0), (1, 0): (0, 255, 0), (0, 1): (0, 0, 255),
            (1, 1): (255, 255, 255)}
    return png_rgb(2, 2, lambda x, y: cols[(x, y)])


def quad(size=1.0):
    """A square in the z = 0 plane facing +z, corners at +-size/2."""
    h = size / 2
    pos = [-h, -h, 0, h, -h, 0, h, h, 0, -h, h, 0]
    return pos, [0, 1, 2, 0, 2, 3], [0, 0, 1] * 4, [0, 1, 1, 1, 1, 0, 0, 0]


def box(sx, sy, sz):
    """An axis-aligned box centred on the origin, outward normals."""
    pos, nrm, uv, idx = [], [], [], []
    for axis in range(3):
        for sign in (-1, 1):
            n = [0, 0, 0]
            n[axis] = sign
            u, v = [a for a in range(3) if a != axis]
            if sign < 0:
                u, v = v, u
            base = len(pos) // 3
            for cu, cv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0, 0, 0]
                p[axis] = sign
                p[u], p[v] = cu, cv
                pos += [p[0] * sx / 2, p[1] * sy / 2, p[2] * sz / 2]
                nrm += n
                uv += [(cu + 1) / 2, (1 - cv) / 2]
            idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, idx, nrm, uv


def sphere(r, nu=24, nv=12):
    pos, nrm, uv, idx = [], [], [], []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            n = [math.sin(th) * math.cos(ph), math.cos(th),
                 -math.sin(th) * math.sin(ph)]
            pos += [r * c for c in n]
            nrm += n
            uv += [i / nu, j / nv]
    for j in range(nv):
        for i in range(nu):
            a = j * (nu + 1) + i
            b = a + nu + 1
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, idx, nrm, uv


# ---- named scenes --------------------------------------------------------

def scene_tri():
    """One triangle under a chain of two node transforms (matrix, then
    TRS): tests/gltf.bats renders it against the same triangle moved by
    tests/gltf_check.py and written as OBJ."""
    g = Gltf()
    m = g.mesh([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2],
               material=g.material({"pbrMetallicRoughness": {
                   "baseColorFactor": [0.8, 0.4, 0.2, 1],
                   "metallicFactor": 0}}))
    child = g.node(root=False, mesh=m, translation=[0.25, -0.5, 0.125],
                   rotation=[0, 0, 0.38268343236508984, 0.9238795325112867],
                   scale=[1.5, 0.75, 1.0])
    g.node(children=[child],
           matrix=[0.8, 0, 0.6, 0, 0, 1, 0, 0, -0.6, 0, 0.8, 0, 0.5, 0.25, -1, 1])
    return g


def scene_tri_spaced():
    """scene_tri with its buffer in the file "tri data.bin" beside it,
    named "tri%20data.bin"."""
    g = scene_tri()
    g.bin_file = "tri data.bin"
    return g


def scene_tri_nan():
    """scene_tri with its second vertex's y a NaN (bytes 16 to 20 of the
    buffer: the POSITION accessor comes first)."""
    g = scene_tri()
    g.bin[16:20] = struct.pack("<f", float("nan"))
    return g


def scene_camera_light(light=True):
    """A floor (y = 0, 8 x 8) of base colour 0.5 under a point light of
    20 cd at (0, 2, 0) (none with light=False), seen by a glTF camera
    (yfov 0.7, aspect 1.5)."""
    g = Gltf()
    pos, idx, nrm, _ = quad(8)
    floor = g.mesh(pos, idx, nrm, material=g.material({
        "name": "floor", "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0,
            "roughnessFactor": 1}}))
    # Rotated -90 degrees about x: +z becomes +y (the floor faces up).
    s = math.sqrt(0.5)
    g.node(mesh=floor, rotation=[-s, 0, 0, s])
    cam = g.camera({"type": "perspective", "name": "main",
                    "perspective": {"yfov": 0.7, "aspectRatio": 1.5,
                                    "znear": 0.1}})
    # The camera looks down -z of its node: placed at (0, 3, 4), tilted
    # down by atan(3/4) about x.
    a = -math.atan2(3, 4) / 2
    g.node(camera=cam, name="cam", translation=[0, 3, 4],
           rotation=[math.sin(a), 0, 0, math.cos(a)])
    if light:
        li = g.light({"type": "point", "intensity": 20, "color": [1, 1, 1]})
        g.node(extensions={"KHR_lights_punctual": {"light": li}},
               translation=[0, 2, 0])
    return g


def scene_texture_transform():
    """One 2 x 2 quad whose base colour texture (2 x 2: red, green / blue,
    white from the top left) has KHR_texture_transform offset (0.25, 0.1),
    rotation 0.3 and scale (1.5, -0.7)."""
    g = Gltf()
    g.use_extension("KHR_texture_transform")
    tex = g.image_png(corners_png())
    pos, idx, nrm, uv = quad(2)
    m = g.mesh(pos, idx, nrm, uv, g.material({
        "name": "moved", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": tex, "extensions": {
                "KHR_texture_transform": {"offset": [0.25, 0.1],
                                          "rotation": 0.3,
                                          "scale": [1.5, -0.7]}}},
            "metallicFactor": 0}}))
    g.node(mesh=m)
    return g


def scene_normal_map():
    """One 2 x 2 quad facing +z, base colour 0.5, with a 2 x 2 normal map
    (pixel (x, y) from the top left): tilted towards +u (204, 128, 230),
    towards +y up the image (128, 204, 230) / flat (128, 128, 255),
    towards -u and down (60, 70, 230); normalTexture.scale 0.8."""
    g = Gltf()
    cols = {(0, 0): (204, 128, 230), (1, 0): (128, 204, 230),
            (0, 1): (128, 128, 255), (1, 1): (60, 70, 230)}
    tex = g.image_png(png_rgb(2, 2, lambda x, y: cols[(x, y)]))
    pos, idx, nrm, uv = quad(2)
    m = g.mesh(pos, idx, nrm, uv, g.material({
        "name": "bumpy", "normalTexture": {"index": tex, "scale": 0.8},
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1],
                                 "metallicFactor": 0}}))
    g.node(mesh=m)
    return g


def scene_normal_map_moved(xf):
    """scene_normal_map's quad with a uniform normal map tilted towards +u
    and up the image (204, 160, 230), under KHR_texture_transform xf."""
    g = Gltf()
    g.use_extension("KHR_texture_transform")
    tex = g.image_png(png_rgb(2, 2, lambda x, y: (204, 160, 230)))
    pos, idx, nrm, uv = quad(2)
    m = g.mesh(pos, idx, nrm, uv, g.material({
        "name": "bumpy", "normalTexture": {
            "index": tex, "scale": 0.8,
            "extensions": {"KHR_texture_transform": xf}},
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1],
                                 "metallicFactor": 0}}))
    g.node(mesh=m)
    return g


def scene_spot_light():
    """scene_camera_light's floor and camera under a spot light of 20 cd
    at (0, 2, 0) shining straight down (its node turned -90 degrees about
    x), cone half-angles 0.3 and 0.6 radians."""
    g = scene_camera_light()
    g.doc["extensions"]["KHR_lights_punctual"]["lights"][0] = {
        "type": "spot", "intensity": 20, "color": [1, 1, 1],
        "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}}
    s = math.sqrt(0.5)
    g.doc["nodes"][-1]["rotation"] = [-s, 0, 0, s]
    return g


def scene_materials():
    """A mirror (metallic 1, roughness 0, base colour 0.9) and a diffuse
    panel side by side, for tests/gltf.bats' material test."""
    g = Gltf()
    pos, idx, nrm, _ = quad(2)
    mirror = g.mesh(pos, idx, nrm, material=g.material({
        "name": "mirror", "pbrMetallicRoughness": {
            "baseColorFactor": [0.9, 0.9, 0.9, 1], "metallicFactor": 1,
            "roughnessFactor": 0}}))
    matte = g.mesh(pos, idx, nrm, material=g.material({
        "name": "matte", "pbrMetallicRoughness": {
            "baseColorFactor": [0.2, 0.6, 0.4, 1], "metallicFactor": 0,
            "roughnessFactor": 1}}))
    g.node(mesh=mirror, translation=[-1.5, 0, 0])
    g.node(mesh=matte, translation=[1.5, 0, 0])
    return g


def scene_mapping():
    """One triangle per material, for the mapping table's test: a partly
    metallic, partly transmissive, rough, emissive material (with
    KHR_materials_transmission, _ior and _emissive_strength), and a
    primitive without a material (the spec's default)."""
    g = Gltf()
    for e in ("KHR_materials_transmission", "KHR_materials_ior",
              "KHR_materials_emissive_strength"):
        g.use_extension(e)
    m = g.mesh([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2], material=g.material({
        "name": "mixed", "emissiveFactor": [0.5, 0.25, 1],
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.7, 1],
                                 "metallicFactor": 0.25,
                                 "roughnessFactor": 0.6},
        "extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 0.5},
            "KHR_materials_ior": {"ior": 1.33},
            "KHR_materials_emissive_strength": {"emissiveStrength": 4}}}))
    plain = g.mesh([0, 0, 1, 1, 0, 1, 0, 1, 1], [0, 1, 2])
    g.node(mesh=m)
    g.node(mesh=plain)
    return g


def scene_textured(uv_comp=FLOAT, uv_normalized=True):
    """Two 2 x 2 quads facing +z: at x = -1.5 a base-colour texture, at
    x = 1.5 an emissive one, each a 2 x 2 PNG with red top left, green
    top right, blue bottom left, white bottom right.  glTF's UV (0, 0) is
    the image's top left; the quad's UVs put it at the top-left corner.
    uv_comp: the UVs' component type (floats, or normalized unsigned
    bytes or shorts)."""
    g = Gltf()
    tex = g.image_png(corners_png())
    pos, idx, nrm, uv = quad(2)
    kw = {"uv_comp": uv_comp, "uv_normalized": uv_normalized}
    base = g.mesh(pos, idx, nrm, uv, **kw, material=g.material({
        "name": "base", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": tex}, "metallicFactor": 0}}))
    glow = g.mesh(pos, idx, nrm, uv, **kw, material=g.material({
        "name": "glow", "emissiveFactor": [1, 1, 1],
        "emissiveTexture": {"index": tex},
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}}))
    g.node(mesh=base, translation=[-1.5, 0, 0])
    g.node(mesh=glow, translation=[1.5, 0, 0])
    return g


def scene_metal_no_uv():
    """One 2 x 2 quad without TEXCOORD_0: a solid red base-colour
    texture, metallicFactor 0.5, no metallic-roughness texture."""
    g = Gltf()
    base = g.image_png(png_rgb(2, 2, lambda x, y: (255, 0, 0)))
    pos, idx, nrm, uv = quad(2)
    m = g.mesh(pos, idx, nrm, None, g.material({
        "name": "metal", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": base}, "metallicFactor": 0.5}}))
    g.node(mesh=m)
    return g


def scene_metal_texture(mr=True):
    """One 2 x 2 quad, metallicFactor 0.5 and roughnessFactor 1, with a
    2 x 2 base-colour texture (pixel (x, y) from the top left: red,
    white / white, green) and a metallic-roughness texture whose B
    (metallic) is 255, 0 / 102, 255 and G (roughness) 255 everywhere
    (none with mr=False)."""
    g = Gltf()
    cols = {(0, 0): (255, 0, 0), (1, 0): (255, 255, 255),
            (0, 1): (255, 255, 255), (1, 1): (0, 255, 0)}
    metal = {(0, 0): 255, (1, 0): 0, (0, 1): 102, (1, 1): 255}
    base = g.image_png(png_rgb(2, 2, lambda x, y: cols[(x, y)]))
    mr_tex = g.image_png(png_rgb(2, 2, lambda x, y: (0, 255, metal[(x, y)])))
    pos, idx, nrm, uv = quad(2)
    pbr = {"baseColorTexture": {"index": base}, "metallicFactor": 0.5}
    if mr:
        pbr["metallicRoughnessTexture"] = {"index": mr_tex}
    m = g.mesh(pos, idx, nrm, uv, g.material({
        "name": "metal", "pbrMetallicRoughness": pbr}))
    g.node(mesh=m)
    return g


def checker_png(n=64, cells=8, a=(230, 220, 200), b=(40, 60, 90)):
    return png_rgb(n, n, lambda x, y: a if (x * cells // n + y * cells // n)
                   % 2 == 0 else b)


def scene_gallery():
    """The gallery scene: a textured floor and boxes, a glossy sphere, and
    small emissive night lights far behind, for the thin lens and the real
    lens (docs/figures.sh)."""
    g = Gltf()
    tex = g.image_png(checker_png(256, 16))
    wood = g.image_png(png_rgb(64, 64, lambda x, y: (
        150 + (x * 7 % 40), 90 + (x * 3 % 30), 50)))
    pos, idx, nrm, uv = quad(1)
    uv = [c * 50 for c in uv]
    floor = g.mesh([c * 100 for c in pos], idx, nrm, uv, g.material({
        "name": "floor", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": tex}, "metallicFactor": 0,
            "roughnessFactor": 0.6}}))
    s = math.sqrt(0.5)
    g.node(mesh=floor, rotation=[-s, 0, 0, s])
    bpos, bidx, bnrm, buv = box(0.8, 0.8, 0.8)
    crate = g.mesh(bpos, bidx, bnrm, buv, g.material({
        "name": "crate", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": wood}, "metallicFactor": 0,
            "roughnessFactor": 0.8}}))
    g.node(mesh=crate, translation=[-1.2, 0.4, -0.5],
           rotation=[0, math.sin(0.3), 0, math.cos(0.3)])
    g.node(mesh=crate, translation=[1.4, 0.4, -2.5],
           rotation=[0, math.sin(-0.2), 0, math.cos(-0.2)])
    spos, sidx, snrm, suv = sphere(0.6, 48, 24)
    gold = g.mesh(spos, sidx, snrm, suv, g.material({
        "name": "gold", "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 0.78, 0.34, 1], "metallicFactor": 1,
            "roughnessFactor": 0.25}}))
    g.node(mesh=gold, translation=[0.3, 0.6, 0.4])
    lpos, lidx, lnrm, _ = sphere(0.06, 8, 4)
    g.use_extension("KHR_materials_emissive_strength")
    for i, col in enumerate([(1, 0.6, 0.2), (1, 0.8, 0.5), (0.6, 0.8, 1)]):
        lamp = g.mesh(lpos, lidx, lnrm, material=g.material({
            "name": "lamp%d" % i, "emissiveFactor": list(col),
            "extensions": {"KHR_materials_emissive_strength": {
                "emissiveStrength": 15}},
            "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}}))
        for k in range(5):
            g.node(mesh=lamp, translation=[-7 + 3.3 * k + i * 1.1,
                                           0.9 + 1.1 * ((k + i) % 3),
                                           -11 - 2.5 * i])
    cam = g.camera({"type": "perspective", "perspective": {
        "yfov": 0.6, "aspectRatio": 1.5, "znear": 0.1},
        "extras": {"lensray": {"focus_distance": 3.6, "f_number": 1.4,
                               "focal_length_mm": 85}}})
    a = -math.atan2(1.0, 4.5) / 2
    g.node(camera=cam, translation=[0, 1.6, 4.3],
           rotation=[math.sin(a), 0, 0, math.cos(a)])
    return g


def scene_normals():
    """One triangle with a tilted vertex normal (0.6, 0, 0.8) under a
    non-uniform scale (2, 1, 1): its normal must move by the inverse
    transpose."""
    g = Gltf()
    m = g.mesh([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2],
               normals=[0.6, 0, 0.8] * 3)
    g.node(mesh=m, scale=[2, 1, 1])
    return g


def scene_sparse():
    """Two quads (x from -1.5 to -0.5 and from 0.5 to 1.5, y from -0.5 to
    0.5) whose positions come from sparse accessors (spec 3.6.2.3): the
    first over a bufferView in the plane z = 0, its two corners at
    x = -0.5 moved to z = 1 (unsigned byte indices), so that it lies in
    z = x + 1.5; the second without a bufferView (zeros), all four
    corners given at z = 0.25 (unsigned short indices)."""
    g = Gltf()

    def sparse(count, indices, comp, values):
        fmt = {UBYTE: "B", USHORT: "H"}[comp]
        raw = struct.pack("<%d%s" % (len(indices), fmt), *indices)
        iv = g._view(raw + b"\0" * (-len(raw) % 4))
        vv = g._view(struct.pack("<%df" % len(values), *values))
        return {"count": len(indices),
                "indices": {"bufferView": iv, "componentType": comp},
                "values": {"bufferView": vv}}

    idx = g.accessor([0, 1, 2, 0, 2, 3], "SCALAR", UINT, 34963)
    base = g.accessor([-1.5, -0.5, 0, -0.5, -0.5, 0, -0.5, 0.5, 0,
                       -1.5, 0.5, 0], "VEC3", target=34962)
    a = g.doc["accessors"][base]
    a["sparse"] = sparse(4, [1, 2], UBYTE, [-0.5, -0.5, 1, -0.5, 0.5, 1])
    a["min"], a["max"] = [-1.5, -0.5, 0], [-0.5, 0.5, 1]
    zeros = {"componentType": FLOAT, "count": 4, "type": "VEC3",
             "min": [0.5, -0.5, 0.25], "max": [1.5, 0.5, 0.25],
             "sparse": sparse(4, [0, 1, 2, 3], USHORT,
                              [0.5, -0.5, 0.25, 1.5, -0.5, 0.25,
                               1.5, 0.5, 0.25, 0.5, 0.5, 0.25])}
    g.doc["accessors"].append(zeros)
    g.doc["meshes"].append({"primitives": [
        {"attributes": {"POSITION": base}, "indices": idx},
        {"attributes": {"POSITION": len(g.doc["accessors"]) - 1},
         "indices": idx}]})
    g.node(mesh=len(g.doc["meshes"]) - 1)
    return g


def scene_morph():
    """A unit quad in z = 0 (corners 0 to 3 counter-clockwise from
    (-0.5, -0.5)) with two morph targets (spec 3.7.2.2): the first moves
    every corner by (0, 0, 1), the second (sparse over zeros) corners 1
    and 2, those at x = 0.5, by (0, 0, 1).  Drawn twice: at x = -1 with
    the mesh's weights (0.5, 0.4), in the plane z = 0.7 + 0.4 x (local
    x), and at x = +1 with the node's own weights (0.25, 0), in
    z = 0.25."""
    g = Gltf()
    idx = g.accessor([0, 1, 2, 0, 2, 3], "SCALAR", UINT, 34963)
    pos = g.accessor([-0.5, -0.5, 0, 0.5, -0.5, 0, 0.5, 0.5, 0,
                      -0.5, 0.5, 0], "VEC3", target=34962)
    up = g.accessor([0, 0, 1] * 4, "VEC3", target=34962)
    raw = struct.pack("<2H", 1, 2)
    iv = g._view(raw)
    vv = g._view(struct.pack("<6f", 0, 0, 1, 0, 0, 1))
    g.doc["accessors"].append({
        "componentType": FLOAT, "count": 4, "type": "VEC3",
        "min": [0, 0, 0], "max": [0, 0, 1],
        "sparse": {"count": 2,
                   "indices": {"bufferView": iv, "componentType": USHORT},
                   "values": {"bufferView": vv}}})
    tilt = len(g.doc["accessors"]) - 1
    g.doc["meshes"].append({"weights": [0.5, 0.4], "primitives": [
        {"attributes": {"POSITION": pos}, "indices": idx,
         "targets": [{"POSITION": up}, {"POSITION": tilt}]}]})
    g.node(mesh=0, translation=[-1, 0, 0])
    g.node(mesh=0, translation=[1, 0, 0], weights=[0.25, 0])
    return g


def scene_skin():
    """A unit quad in z = 0 (corners 0 to 3 counter-clockwise from
    (-0.5, -0.5)) skinned (spec 3.7.3) to two joints: corners 0 and 3 to
    joint 0, a node at (-1, 0, 0); corners 1 and 2 to joint 1, a node at
    (-1, 0, 2) whose inverse bind matrix translates by (0, 0, -1).  The
    skinned quad lies in z = x + 1.5 for x from -1.5 to -0.5, whatever
    the transform of its own node (translated by (5, 5, 5) and scaled by
    3: the spec says a skinned mesh ignores it).  A plain quad at x = +1,
    z = 0.25, beside it."""
    g = Gltf()
    idx = g.accessor([0, 1, 2, 0, 2, 3], "SCALAR", UINT, 34963)
    pos = g.accessor([-0.5, -0.5, 0, 0.5, -0.5, 0, 0.5, 0.5, 0,
                      -0.5, 0.5, 0], "VEC3", target=34962)
    joints = g._view(bytes([0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0,
                            0, 0, 0, 0]), 34962)
    g.doc["accessors"].append({"bufferView": joints, "componentType": UBYTE,
                               "count": 4, "type": "VEC4"})
    jacc = len(g.doc["accessors"]) - 1
    wacc = g.accessor([1, 0, 0, 0] * 4, "VEC4", target=34962)
    mats = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -1, 1]
    ibm = g._view(struct.pack("<32f", *mats))
    g.doc["accessors"].append({"bufferView": ibm, "componentType": FLOAT,
                               "count": 2, "type": "MAT4"})
    g.doc["meshes"].append({"primitives": [
        {"attributes": {"POSITION": pos, "JOINTS_0": jacc,
                        "WEIGHTS_0": wacc}, "indices": idx}]})
    j0 = g.node(translation=[-1, 0, 0])
    j1 = g.node(translation=[-1, 0, 2])
    g.doc["skins"] = [{"joints": [j0, j1],
                       "inverseBindMatrices": len(g.doc["accessors"]) - 1}]
    g.node(mesh=0, skin=0, translation=[5, 5, 5], scale=[3, 3, 3])
    flat = g.accessor([-0.5, -0.5, 0.25, 0.5, -0.5, 0.25, 0.5, 0.5, 0.25,
                       -0.5, 0.5, 0.25], "VEC3", target=34962)
    g.doc["meshes"].append({"primitives": [
        {"attributes": {"POSITION": flat}, "indices": idx}]})
    g.node(mesh=1, translation=[1, 0, 0])
    return g


def scene_two_scenes():
    """Layout checks for tests/gltf_depth_check.py: scene 1 of two is the
    displayed one (a box stretched by a non-uniform scale); scene 0's box
    and a node in no scene must not be drawn."""
    g = Gltf()
    bp, bi, bn, _ = box(1, 1, 1)
    m = g.mesh(bp, bi, bn)
    g.node(mesh=m, translation=[-2, 0, 0])
    n1 = g.node(root=False, mesh=m, translation=[2, 0.5, 0], scale=[1, 2, 1])
    g.doc["scenes"].append({"nodes": [n1]})
    g.doc["scene"] = 1
    g.node(root=False, mesh=m, translation=[0, 3, 0])
    return g


def scene_scaled(s):
    """A box under a parent scaled by s (1e6, 1e-5: huge and tiny scenes),
    and a mirrored one (scale (s, -s, s))."""
    g = Gltf()
    bp, bi, bn, _ = box(1, 1, 1)
    m = g.mesh(bp, bi, bn)
    p = g.node(scale=[s, s, s])
    c = g.node(root=False, mesh=m, translation=[0.5, 0.25, 0],
               rotation=[0, math.sin(0.3), 0, math.cos(0.3)])
    g.doc["nodes"][p]["children"] = [c]
    g.node(mesh=m, translation=[2 * s, 0, -s], scale=[s, -s, s])
    return g


def scene_orient():
    """Six boxes placed by column-major matrices (a rotation about z and a
    translation along each axis), seen by a camera (yfov 1.2, aspect 2)
    under a rotated, translated and scaled parent."""
    g = Gltf()
    bp, bi, bn, _ = box(2, 1.5, 1)
    m = g.mesh(bp, bi, bn)
    for k, t in enumerate([(3, 0, 0), (-3, 0, 0), (0, 3, 0), (0, -3, 0),
                           (0, 0, 3), (0, 0, -3)]):
        c, s = math.cos(0.4 * k), math.sin(0.4 * k)
        g.node(mesh=m, matrix=[c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0,
                               t[0], t[1], t[2], 1])
    cam = g.camera({"type": "perspective", "perspective": {
        "yfov": 1.2, "aspectRatio": 2.0, "znear": 0.01}})
    par = g.node(rotation=[0.2, 0.3, 0.1, 0.927], translation=[0.2, -0.1, 0.3],
                 scale=[2, 2, 2])
    cn = g.node(root=False, camera=cam, translation=[0, 0, 3],
                rotation=[0, math.sin(0.05), 0, math.cos(0.05)])
    g.doc["nodes"][par]["children"] = [cn]
    return g


def scene_layouts():
    """Accessor layouts: a box with POSITION and NORMAL interleaved
    (byteStride 24, accessor byteOffsets 0 and 12) and unsigned byte
    indices; a triangle strip without indices; an indexed fan (unsigned
    short indices) (spec 3.6.2, 3.7.2.1)."""
    g = Gltf()
    bp, bi, bn, _ = box(1, 1, 1)
    nv = len(bp) // 3
    inter = b"".join(struct.pack("<6f", *bp[3 * i:3 * i + 3],
                                 *bn[3 * i:3 * i + 3]) for i in range(nv))
    view = g._view(inter, 34962)
    g.doc["bufferViews"][view]["byteStride"] = 24
    acc = g.doc["accessors"]
    acc.append({"bufferView": view, "componentType": FLOAT, "count": nv,
                "type": "VEC3", "min": [-0.5] * 3, "max": [0.5] * 3})
    acc.append({"bufferView": view, "byteOffset": 12, "componentType": FLOAT,
                "count": nv, "type": "VEC3"})
    iv = g._view(bytes(bi) + b"\0" * (-len(bi) % 4), 34963)
    acc.append({"bufferView": iv, "componentType": UBYTE, "count": len(bi),
                "type": "SCALAR"})
    g.doc["meshes"].append({"primitives": [{
        "attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]})
    g.node(mesh=0)
    pts = []
    for k in range(8):
        pts += [k * 0.4 - 1.6, 1.0 + (k % 2) * 0.6, -0.8 + 0.05 * k]
    a = g.accessor(pts, "VEC3", target=34962)
    g.doc["meshes"].append({"primitives": [{"attributes": {"POSITION": a},
                                            "mode": 5}]})
    g.node(mesh=1)
    fp = [0, -1.5, 0]
    for k in range(7):
        t = k * 0.7
        fp += [math.cos(t), -1.5 + 0.3 * math.sin(t), math.sin(t) * 0.5]
    fa = g.accessor(fp, "VEC3", target=34962)
    fi = g.accessor(list(range(8)), "SCALAR", USHORT, 34963)
    g.doc["meshes"].append({"primitives": [{"attributes": {"POSITION": fa},
                                            "indices": fi, "mode": 6}]})
    g.node(mesh=2, translation=[0.3, 0, 0.2])
    return g


SCENES = {"tri": scene_tri, "sparse": scene_sparse, "morph": scene_morph,
          "skin": scene_skin, "two-scenes": scene_two_scenes,
          "huge": lambda: scene_scaled(1e6),
          "tiny": lambda: scene_scaled(1e-5), "orient": scene_orient,
          "layouts": scene_layouts, "tri-nan": scene_tri_nan,
          "tri-spaced": scene_tri_spaced, "normals": scene_normals,
          "mapping": scene_mapping, "textured": scene_textured,
          "textured-u8": lambda: scene_textured(UBYTE),
          "textured-u16": lambda: scene_textured(USHORT),
          "textured-u8-raw": lambda: scene_textured(UBYTE, False),
          "metal-texture": scene_metal_texture,
          "metal-base-texture": lambda: scene_metal_texture(mr=False),
          "metal-no-uv": scene_metal_no_uv,
          "spot-light": scene_spot_light,
          "normal-map": scene_normal_map,
          "normal-map-mirrored":
              lambda: scene_normal_map_moved({"scale": [-1, 1]}),
          "normal-map-turned":
              lambda: scene_normal_map_moved({"rotation": math.pi}),
          "texture-transform": scene_texture_transform,
          "camera-floor": lambda: scene_camera_light(light=False),
          "camera-light": scene_camera_light,
          "materials": scene_materials, "gallery": scene_gallery}

if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in SCENES:
        sys.exit("usage: gltf_writer.py %s OUT.gltf|OUT.glb"
                 % "|".join(SCENES))
    SCENES[sys.argv[1]]().write(sys.argv[2])
