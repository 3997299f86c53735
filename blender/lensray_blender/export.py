"""Blender scene -> lensray scene dict (docs/scene-format.md).

Units follow Cycles: a point or spot light of power P watts has radiant
intensity P / (4 pi) W/sr (a point light of radius r > 0 is a sphere of
radiance P / (4 pi^2 r^2), the same power); a sun of strength S is
irradiance S W/m^2; an area light of power P and area A is an emitter of
radiance P / (pi A); the world's Background colour times strength is a
uniform environment.
"""
import math
import os

import bpy
from mathutils import Vector

ENV_ROTATION_DEG = 90.0
LENS_DIR = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..", "lenses"))


def _vec(v):
    # Blender is Z-up, lensray's environment maps Y-up: every position and
    # direction is turned (x, y, z) -> (x, z, -y), a rotation.
    return [float(v[0]), float(v[2]), -float(v[1])]


def _col(c, scale=1.0):
    return [max(0.0, float(c[0]) * scale), max(0.0, float(c[1]) * scale),
            max(0.0, float(c[2]) * scale)]


# Principled inputs renamed in Blender 4.0: their 3.x names.
OLD_NAMES = {"Transmission Weight": "Transmission", "Emission Color": "Emission"}


def _socket(node, name):
    sock = node.inputs.get(name)
    return sock if sock is not None else node.inputs.get(OLD_NAMES.get(name, ""))


def _input(node, name, default):
    sock = _socket(node, name)
    if sock is None:
        return default
    if sock.is_linked:
        return None  # textured or driven by nodes: not mapped
    return sock.default_value


def _srgb_decode(c):
    # IEC 61966-2-1, as lensray's texture loader and Blender's "sRGB" space.
    import numpy as np
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _linear_pixels(img, warn, where):
    """An image's texels as linear float RGBA, rows from the bottom."""
    import numpy as np
    w, h = img.size
    px = np.empty(w * h * 4, np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, 4)
    space = img.colorspace_settings.name
    # Float buffers are scene linear already; byte ones are in their space.
    if img.is_float or space in ("Non-Color", "Linear Rec.709", "Linear", "Raw"):
        return px
    if space != "sRGB":
        warn.add(f"{where}: image {img.name!r}: colour space {space!r} read as sRGB")
    px[:, :, :3] = _srgb_decode(px[:, :, :3])
    return px


def _image_texture(sock, srgb, outdir, warn, where):
    """The file lensray reads for an input linked to an Image Texture node
    (its default UV map, repeat), and the channel the link takes (0, or 3
    for Alpha); None when the input is not such a link (the caller warns).

    The image's own file is used where lensray decodes it as Blender does
    (an 8-bit PNG or JPEG in "sRGB" for a colour, in "Non-Color" for data;
    an EXR). Anything else (packed, generated, other colour spaces) is
    written out as a linear EXR in outdir."""
    if sock is None or not sock.is_linked:
        return None
    link = sock.links[0]
    node = link.from_node
    if node.type != "TEX_IMAGE" or node.image is None:
        return None
    img = node.image
    if node.inputs["Vector"].is_linked:
        warn.add(f"{where}: image {img.name!r}: mapped through nodes, drawn with the default UV map")
    if node.extension != "REPEAT":
        warn.add(f"{where}: image {img.name!r}: extension {node.extension} drawn as REPEAT")
    if node.interpolation not in ("Linear", "Smart"):
        warn.add(f"{where}: image {img.name!r}: interpolation {node.interpolation} drawn as Linear")
    if node.projection != "FLAT":
        warn.add(f"{where}: image {img.name!r}: projection {node.projection} drawn as FLAT")
    channel = 3 if link.from_socket.name == "Alpha" else 0
    path = bpy.path.abspath(img.filepath) if img.source == "FILE" and not img.packed_file else ""
    space = img.colorspace_settings.name
    kind = img.file_format
    if path and os.path.isfile(path):
        if kind == "OPEN_EXR" or (kind in ("PNG", "JPEG")
                                  and space == ("sRGB" if srgb else "Non-Color")):
            return path, channel
    import lensray
    px = _linear_pixels(img, warn, where)
    # lensray's EXR writer, not Image.save, which encodes a float image
    # for display.  Rows from the top; Alpha, when linked, as the grey.
    rgb = px[::-1, :, 3] if channel == 3 else px[::-1, :, :3]
    path = os.path.join(outdir, "tex%03d.exr" % len(os.listdir(outdir)))
    lensray.write(path, rgb)
    return path, 0


def _texture_mean(sock, warn, where):
    """The mean linear RGB of the image an input is linked to."""
    px = _linear_pixels(sock.links[0].from_node.image, warn, where)
    return [float(c) for c in px[:, :, :3].reshape(-1, 3).mean(axis=0)]


def material_dict(mat, warn, outdir):
    """A Principled BSDF -> a lensray material; anything else approximated.
    Image textures on Base Color, Roughness and Emission Color (and the
    Color of Diffuse and Emission nodes) are written to or named from
    outdir."""
    if mat is None:
        return {"diffuse": 0.8}
    if not mat.use_nodes or mat.node_tree is None:
        return {"diffuse": _col(mat.diffuse_color)}
    where = f"material {mat.name!r}"
    out = next((n for n in mat.node_tree.nodes
                if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
    surf = out.inputs["Surface"].links[0].from_node if out and out.inputs["Surface"].is_linked else None
    if out is not None and out.inputs.get("Volume") is not None and out.inputs["Volume"].is_linked:
        warn.add(f"{where}: volume not drawn")
    if surf is None:
        warn.add(f"{where}: no surface shader, drawn black")
        return {}
    if surf.type in ("EMISSION", "BSDF_DIFFUSE"):
        key = "emission" if surf.type == "EMISSION" else "diffuse"
        tex = _image_texture(surf.inputs["Color"], True, outdir, warn, where)
        c = _input(surf, "Color", (0.8, 0.8, 0.8, 1))
        if c is None and tex is None:
            warn.add(f"{where}: linked Color not mapped")
        scale = 1.0
        if key == "emission":
            scale = _input(surf, "Strength", 1.0)
            if scale is None:
                warn.add(f"{where}: linked Strength not mapped")
                scale = 1.0
        if tex is not None:
            return {key: float(scale), key + "_texture": tex[0]}
        return {key: _col(c or (0.8, 0.8, 0.8, 1), scale)}
    if surf.type != "BSDF_PRINCIPLED":
        warn.add(f"{where}: node {surf.bl_idname} approximated as diffuse")
        return {"diffuse": _col(mat.diffuse_color)}
    tex = {}
    for key, name, srgb in (("base", "Base Color", True), ("rough", "Roughness", False),
                            ("emis", "Emission Color", True)):
        t = _image_texture(_socket(surf, name), srgb, outdir, warn, where)
        if t is not None:
            tex[key] = t
    vals = {}
    for key, name, dflt in (("base", "Base Color", (0.8, 0.8, 0.8, 1)),
                            ("rough", "Roughness", 0.5), ("metal", "Metallic", 0.0),
                            ("trans", "Transmission Weight", 0.0), ("ior", "IOR", 1.5),
                            ("emis", "Emission Color", (0, 0, 0, 1)),
                            ("emis_s", "Emission Strength", 0.0)):
        v = _input(surf, name, dflt)
        if v is None:
            if key not in tex:
                warn.add(f"{where}: linked input {name!r} not mapped (its default used)")
            v = dflt
        vals[key] = v
    alpha = _socket(surf, "Alpha")
    if alpha is not None and (alpha.is_linked or alpha.default_value < 1.0):
        warn.add(f"{where}: Alpha (cut-out transparency) not drawn, opaque")
    # Principled layers lensray has no lobe for (Blender 4 names; 3.4's
    # "Subsurface", "Clearcoat", "Sheen" are amounts as well).
    for name, old in (("Coat Weight", "Clearcoat"), ("Subsurface Weight", "Subsurface"),
                      ("Sheen Weight", "Sheen")):
        sock = surf.inputs.get(name) or surf.inputs.get(old)
        if sock is not None and (sock.is_linked or sock.default_value > 0.0):
            warn.add(f"{where}: {name.split()[0].lower()} layer not drawn")
    metal = float(vals["metal"])
    trans = float(vals["trans"]) * (1 - metal)
    diff = (1 - metal) * (1 - trans)
    base = _col(vals["base"])
    m = {"diffuse": [c * diff for c in base]}
    if "base" in tex:
        # lensray textures the diffuse lobe only: the others take the mean.
        m = {"diffuse": diff, "diffuse_texture": tex["base"][0]}
        if metal > 0 or trans > 0:
            warn.add(f"{where}: Base Color texture drawn on the diffuse part only "
                     "(metallic and transmission take its mean colour)")
            base = _texture_mean(surf.inputs["Base Color"], warn, where)
    if metal > 0:
        m["reflect"] = [c * metal for c in base]
    if trans > 0:
        m["transmit"] = [c * trans for c in base]
        m["ior"] = min(10.0, max(1.0, float(vals["ior"])))
    if metal > 0 or trans > 0:
        if "rough" in tex:
            # alpha = roughness * r^2 (docs/scene-format.md), r the texel
            m.update({"roughness": 1.0, "roughness_texture": tex["rough"][0],
                      "roughness_channel": tex["rough"][1]})
        else:
            m["roughness"] = min(1.0, max(0.0, float(vals["rough"]) ** 2))
    if float(vals["emis_s"]) > 0:
        if "emis" in tex:
            m.update({"emission": float(vals["emis_s"]), "emission_texture": tex["emis"][0]})
        else:
            m["emission"] = _col(vals["emis"], float(vals["emis_s"]))
    return m


def _write_obj(path, verts, tris, normals=None, uvs=None):
    """An OBJ of triangles; normals and uvs, when given, one per vertex.
    verts, normals: (n, 3) arrays or lists; uvs (n, 2); tris (m, 3) of
    0-based indices.  Written by one %-format per block (a line at a time
    in Python cost 0.03 s for the issue's 2,200 triangles)."""
    import numpy as np
    with open(path, "w") as f:
        for tag, a, k in (("v", verts, 3), ("vn", normals, 3), ("vt", uvs, 2)):
            if a is None or len(a) == 0:
                continue
            a = np.asarray(a, dtype=np.float64).reshape(-1, k)
            f.write(((tag + " %.9g" * k + "\n") * len(a)) % tuple(a.ravel().tolist()))
        corner = "%d" + ("/%d" if uvs is not None and len(uvs) else "") \
            + ("/" if normals is not None and len(normals) and not (uvs is not None and len(uvs)) else "") \
            + ("/%d" if normals is not None and len(normals) else "")
        per = corner.count("%d")
        t = np.asarray(tris, dtype=np.int64).reshape(-1, 3) + 1
        if len(t):
            face = "f " + " ".join([corner] * 3) + "\n"
            f.write((face * len(t)) % tuple(np.repeat(t.ravel(), per).tolist()))


TEXTURE_KEYS = ("diffuse_texture", "emission_texture", "roughness_texture")


def _tri_arrays(mesh, mw):
    """The mesh's loop triangles as arrays, in lensray's frame (_vec):
    corner positions (t, 3, 3) through mw, flat and split normals (t, 3)
    and (t, 3, 3) through mw's normal matrix, material index, smooth flag
    and loop index per corner.  foreach_get, not a Python loop per
    triangle (0.06 of the engine's 0.3 s at 4 spp on the issue's scene)."""
    import numpy as np
    n_v, n_t = len(mesh.vertices), len(mesh.loop_triangles)
    co = np.empty(n_v * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    lt = mesh.loop_triangles
    vi = np.empty(n_t * 3, np.int32)
    lt.foreach_get("vertices", vi)
    loops = np.empty(n_t * 3, np.int32)
    lt.foreach_get("loops", loops)
    mat = np.empty(n_t, np.int32)
    lt.foreach_get("material_index", mat)
    smooth = np.empty(n_t, bool)
    lt.foreach_get("use_smooth", smooth)
    fn = np.empty(n_t * 3, np.float32)
    lt.foreach_get("normal", fn)
    sn = np.empty(n_t * 9, np.float32)
    lt.foreach_get("split_normals", sn)
    M = np.array(mw, dtype=np.float64)
    N = np.array(mw.to_3x3().inverted_safe().transposed(), dtype=np.float64)
    # (x, y, z) -> (x, z, -y), as _vec.
    turn = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], dtype=np.float64)
    p = co.reshape(-1, 3).astype(np.float64) @ M[:3, :3].T + M[:3, 3]
    pos = (p @ turn.T)[vi].reshape(n_t, 3, 3)

    def normals(a):
        a = a.astype(np.float64) @ N.T
        ln = np.linalg.norm(a, axis=-1, keepdims=True)
        return np.where(ln > 0, a / np.where(ln > 0, ln, 1), a) @ turn.T
    sn, loops = normals(sn.reshape(n_t, 3, 3)), loops.reshape(n_t, 3)
    if np.linalg.det(M[:3, :3]) < 0:
        # A mirroring transform turns the corners clockwise: lensray's
        # front (its emitting side) would be the other one.  Reversed, the
        # front stays the side the normals (through N) point to.
        pos, sn, loops = pos[:, ::-1], sn[:, ::-1], loops[:, ::-1]
    return pos, normals(fn.reshape(n_t, 3)), sn, mat, smooth, loops


def _mesh_objects(depsgraph, outdir, materials, objects, warn):
    import numpy as np
    n = 0
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type == "VOLUME":
            warn.add(f"object {ob.name!r}: volumes are not drawn")
            continue
        if ob.type == "CURVES":
            warn.add(f"object {ob.name!r}: hair is not drawn")
            continue
        if ob.type not in ("MESH", "CURVE", "SURFACE", "META", "FONT"):
            continue
        if any(ps for ps in getattr(ob, "particle_systems", [])):
            warn.add(f"object {ob.name!r}: particles/hair are not drawn")
        # Ray visibility and holdout: lensray draws every object to every ray.
        for attr, what in (("visible_camera", "camera"), ("visible_shadow", "shadow"),
                           ("visible_diffuse", "diffuse"), ("visible_glossy", "glossy"),
                           ("visible_transmission", "transmission")):
            if not getattr(ob, attr, True):
                warn.add(f"object {ob.name!r}: hidden from {what} rays, drawn visible")
        if getattr(ob, "is_holdout", False):
            warn.add(f"object {ob.name!r}: holdout drawn as the object")
        mw = inst.matrix_world.copy()
        mesh = ob.to_mesh()
        if mesh is None:
            continue
        try:
            mesh.calc_loop_triangles()
            if hasattr(mesh, "calc_normals_split"):
                mesh.calc_normals_split()  # Blender < 4.1: split_normals need it
            if len(mesh.loop_triangles) == 0:
                continue
            pos, fnorm, snorm, mat_idx, smooth_t, loops = _tri_arrays(mesh, mw)
            # Cycles' Image Texture without a UV Map node reads the render UV map.
            uv = next((la for la in mesh.uv_layers if la.active_render), None)
            uv_all = None
            if uv is not None:
                uv_all = np.empty(len(uv.data) * 2, np.float32)
                uv.data.foreach_get("uv", uv_all)
                uv_all = uv_all.reshape(-1, 2)
            # Materials in the order their first triangle comes.
            ids, first = np.unique(mat_idx, return_index=True)
            for mi in ids[np.argsort(first)].tolist():
                sel = mat_idx == mi
                mat = ob.material_slots[mi].material if mi < len(ob.material_slots) else None
                mname = mat.name if mat else "__default"
                if mname not in materials:
                    materials[mname] = material_dict(mat, warn, outdir)
                if uv is None and any(k in materials[mname] for k in TEXTURE_KEYS):
                    warn.add(f"object {ob.name!r}: no UV map, material {mname!r} drawn untextured")
                    untex = {k: v for k, v in materials[mname].items()
                             if k not in TEXTURE_KEYS and k != "roughness_channel"}
                    mname += " (no UV map)"
                    materials[mname] = untex
                smooth = bool(smooth_t[sel].any())
                m = int(sel.sum())
                verts = pos[sel].reshape(-1, 3)
                norms = (snorm[sel] if smooth else np.repeat(fnorm[sel], 3, axis=0)).reshape(-1, 3)
                uvs = uv_all[loops[sel].ravel()] if uv_all is not None else None
                faces = np.arange(3 * m).reshape(m, 3)
                path = os.path.join(outdir, "mesh%03d.obj" % n)
                n += 1
                _write_obj(path, verts, faces, norms if smooth else None, uvs)
                objects.append({"type": "mesh", "file": path, "material": mname})
        finally:
            ob.to_mesh_clear()


def _in_view(scene, centre, r):
    """Whether a sphere at centre (Blender's frame) of radius r is in the
    camera's frame: its centre or a point r off it along an axis."""
    from bpy_extras.object_utils import world_to_camera_view
    cam = scene.camera
    if cam is None:
        return False
    for d in ((0, 0, 0), (r, 0, 0), (-r, 0, 0), (0, r, 0), (0, -r, 0), (0, 0, r), (0, 0, -r)):
        x, y, z = world_to_camera_view(scene, cam, centre + Vector(d))
        if z > 0 and 0 <= x <= 1 and 0 <= y <= 1:
            return True
    return False


def _emitter(materials, name, m):
    """materials[name] = m, or under "name #2", "#3", ... when name holds
    another emission: instances of one light at different scales (area
    lights) are emitters of different radiance."""
    key, i = name, 1
    while key in materials and materials[key] != m:
        i += 1
        key = f"{name} #{i}"
    materials[key] = m
    return key


# Cycles' spot blend is smoothstep(t), t = (cos theta - cos outer) /
# ((1 - cos outer) blend); lensray's falloff is a^2 (docs/scene-format.md)
# over its own span in cos theta.  A span of 0.75 of Cycles' gives the
# same power in the blend and is within 0.16 of smoothstep everywhere
# (over the whole span, 0.30 off at t = 2/3).
SPOT_BLEND_SPAN = 0.75


def _cast_shadow(L):
    # Cycles' Cast Shadow: Light.use_shadow since 4.0, light.cycles.cast_shadow in 3.x.
    cs = getattr(getattr(L, "cycles", None), "cast_shadow", None)
    return bool(getattr(L, "use_shadow", True) if cs is None else cs)


def _lights(scene, depsgraph, outdir, materials, objects, warn):
    lights = []
    whitted = scene.lensray.integrator == "whitted"
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type != "LIGHT":
            continue
        L = ob.data
        mw = inst.matrix_world
        if not _cast_shadow(L) and L.energy != 0:
            warn.add(f"light {ob.name!r}: Cast Shadow off, drawn casting shadows")
        pos = _vec(mw.translation)
        axis = (mw.to_3x3() @ Vector((0, 0, -1))).normalized()
        col = L.color
        r = float(L.shadow_soft_size) if L.type in ("POINT", "SPOT") else 0.0
        if L.type == "POINT" and r > 0 and whitted:
            warn.add(f"light {ob.name!r}: radius {r:g} m drawn as a point "
                     "(the Whitted integrator is not lit by sphere lights)")
        elif L.type == "POINT" and r > 0:
            # Cycles' sphere light: the same power P as the point, from a
            # sphere of radiance P / (4 pi) / (pi r^2) (intensity P / (4 pi)
            # seen from afar).  lensray's is an emitting sphere, which the
            # camera sees; Cycles' light only if its camera visibility is on.
            name = _emitter(materials, "__light_" + ob.name,
                            {"emission": _col(col, L.energy / (4 * math.pi * math.pi * r * r))})
            objects.append({"type": "sphere", "center": pos, "radius": r, "material": name})
            if not ob.visible_camera and _in_view(scene, mw.translation, r):
                warn.add(f"light {ob.name!r}: its sphere (radius {r:g} m) is seen by the camera "
                         "(Cycles hides it: camera ray visibility is off)")
        if L.type == "POINT" and (r == 0 or whitted):
            lights.append({"type": "point", "position": pos,
                           "intensity": _col(col, L.energy / (4 * math.pi))})
        elif L.type == "SPOT":
            if r > 0:
                warn.add(f"light {ob.name!r}: spot radius {r:g} m drawn as a point (hard shadows)")
            outer = math.degrees(L.spot_size) / 2
            co = math.cos(math.radians(min(90.0, outer)))
            inner = math.degrees(math.acos(min(1.0, co + SPOT_BLEND_SPAN * (1 - co) * L.spot_blend)))
            if L.spot_blend > 0:
                warn.add(f"light {ob.name!r}: spot blend {L.spot_blend:g} drawn with lensray's "
                         "falloff, a^2 over 0.75 of the blend, not Cycles' smoothstep "
                         "(the same power, within 0.16 of the full intensity)")
            lights.append({"type": "spot", "position": pos, "direction": _vec(axis),
                           "intensity": _col(col, L.energy / (4 * math.pi)),
                           "inner_angle": min(inner, outer - 1e-3) if inner < outer else max(0.0, outer - 1e-3),
                           "outer_angle": min(90.0, outer)})
        elif L.type == "SUN":
            if L.angle > 0:
                warn.add(f"light {ob.name!r}: sun angle {math.degrees(L.angle):.3g} degrees "
                         "drawn as 0 (hard shadows)")
            lights.append({"type": "directional", "direction": _vec(axis),
                           "irradiance": _col(col, L.energy)})
        elif L.type == "AREA":
            if getattr(L, "spread", math.pi) < math.pi - 1e-6:
                warn.add(f"light {ob.name!r}: spread {math.degrees(L.spread):g} degrees "
                         "drawn as 180 (a Lambertian emitter)")
            sx = L.size
            sy = L.size_y if L.shape in ("RECTANGLE", "ELLIPSE") else L.size
            if L.shape in ("DISK", "ELLIPSE"):
                warn.add(f"light {ob.name!r}: {L.shape.lower()} area light drawn as a rectangle of the same area")
                sx, sy = sx * math.sqrt(math.pi) / 2, sy * math.sqrt(math.pi) / 2
            corners = [mw @ Vector((x * sx / 2, y * sy / 2, 0))
                       for x, y in ((-1, -1), (-1, 1), (1, 1), (1, -1))]
            # world area (object scale included; a parallelogram under shear)
            area = (corners[1] - corners[0]).cross(corners[3] - corners[0]).length
            if not area > 0:
                warn.add(f"light {ob.name!r}: area light of zero area (size or scale 0) "
                         "left out: it gives no light, as in Cycles")
                continue
            name = _emitter(materials, "__light_" + ob.name,
                            {"emission": _col(col, L.energy / (math.pi * area))})
            path = os.path.join(outdir, "light_%d.obj" % len(objects))
            # counter-clockwise seen from -Z local (the side Blender's area
            # light faces); a mirroring transform turns them clockwise, so
            # they are reversed, and the quad emits along mw's -Z, as Cycles'.
            tris = [[0, 1, 2], [0, 2, 3]]
            if mw.to_3x3().determinant() < 0:
                tris = [[0, 2, 1], [0, 3, 2]]
            _write_obj(path, [_vec(c) for c in corners], tris)
            objects.append({"type": "mesh", "file": path, "material": name})
    return lights


def _world(scene, warn):
    w = scene.world
    if w is None:
        return {"background": 0}
    if not w.use_nodes or w.node_tree is None:
        return {"background": _col(w.color)}
    out = next((n for n in w.node_tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
    if out is None or not out.inputs["Surface"].is_linked:
        return {"background": 0}
    bg = out.inputs["Surface"].links[0].from_node
    if bg.type != "BACKGROUND":
        warn.add(f"world {w.name!r}: node {bg.bl_idname} not mapped, world colour used")
        return {"background": _col(w.color)}
    strength = bg.inputs["Strength"].default_value
    ci = bg.inputs["Color"]
    if ci.is_linked:
        src = ci.links[0].from_node
        if src.type == "TEX_ENVIRONMENT" and src.image is not None:
            if src.inputs["Vector"].is_linked:
                warn.add(f"world {w.name!r}: environment texture mapped through nodes "
                         "(a Mapping node's rotation, say), drawn unmapped")
            path = bpy.path.abspath(src.image.filepath)
            if path.lower().endswith(".exr"):
                return {"environment": {"file": path, "intensity": float(strength),
                                        "rotation_deg": ENV_ROTATION_DEG}}
        warn.add(f"world {w.name!r}: linked Color not mapped (only an EXR environment texture is)")
        return {"background": _col(w.color, strength)}
    return {"background": _col(ci.default_value, strength)}


def camera_dict(scene, depsgraph, warn):
    cam_ob = scene.camera
    if cam_ob is None:
        raise ValueError("scene.camera: the scene has no camera")
    # The camera as evaluated at the frame rendered: the original's
    # matrix and data are not updated by a render's depsgraph, and every
    # frame of an animation came out with the first frame's camera.
    cam_ob = cam_ob.evaluated_get(depsgraph)
    cam = cam_ob.data
    mw = cam_ob.matrix_world
    if mw.to_3x3().determinant() == 0:
        raise ValueError(f"camera {cam_ob.name!r}: its scale is 0 on an axis "
                         "(it has no view direction)")
    pos = mw.translation
    fwd = (mw.to_3x3() @ Vector((0, 0, -1))).normalized()
    up = (mw.to_3x3() @ Vector((0, 1, 0))).normalized()
    r = scene.render
    W = int(r.resolution_x * r.resolution_percentage / 100)
    H = int(r.resolution_y * r.resolution_percentage / 100)
    aspect = (W * r.pixel_aspect_x) / (H * r.pixel_aspect_y)
    if r.pixel_aspect_x != r.pixel_aspect_y:
        warn.add(f"render: pixel aspect {r.pixel_aspect_x:g}:{r.pixel_aspect_y:g} "
                 "drawn with square pixels (the frame's field of view kept)")
    if r.film_transparent:
        warn.add("film: transparent background drawn opaque (alpha 1)")
    if cam.type not in ("PERSP", "ORTHO"):
        warn.add(f"camera {cam.name!r}: {cam.type.lower()} projection drawn as perspective")
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if aspect >= 1 else "VERTICAL"
    sensor = cam.sensor_height if cam.sensor_fit == "VERTICAL" else cam.sensor_width
    half = sensor / (2 * cam.lens)
    tan_v = half / aspect if fit == "HORIZONTAL" else half
    # Lens shift moves the film by shift x the fitted side's pixels
    # (Blender's viewplane).  lensray has no shift: the frame is widened
    # by twice the shift about the axis and the shifted frame is its crop,
    # render.region (whole pixels: a shift between them is rounded).
    side = W if fit == "HORIZONTAL" else H
    dx, dy = cam.shift_x * side, cam.shift_y * side
    sx, sy = round(dx), round(dy)
    if abs(dx - sx) > 0.01 or abs(dy - sy) > 0.01:
        warn.add(f"camera {cam.name!r}: lens shift rounded to whole pixels "
                 f"({dx:.2f}, {dy:.2f} -> {sx}, {sy})")
    FW, FH = W + 2 * abs(sx), H + 2 * abs(sy)
    # Render Region (the border): the pixels Blender's pipeline asks for,
    # int(border * size) in float32 as it computes them, rows from the
    # bottom; the engine's result is that rectangle alone, which Blender
    # crops to or pastes into the frame.
    bx0, by0, bx1, by1 = 0, 0, W, H
    if r.use_border:
        import numpy as np
        def cut(f, n):
            return int(np.float32(f) * np.float32(n))
        bx0, bx1 = cut(r.border_min_x, W), cut(r.border_max_x, W)
        by0, by1 = cut(r.border_min_y, H), cut(r.border_max_y, H)
        if bx1 <= bx0 or by1 <= by0:
            raise ValueError("render.border: the render region holds no pixel")
    region = None
    if (FW, FH) != (W, H) or (bx0, by0, bx1, by1) != (0, 0, W, H):
        x0, y0 = abs(sx) + sx, abs(sy) - sy  # lensray's rows run down
        region = [x0 + bx0, y0 + H - by1, x0 + bx1, y0 + H - by0]
    fov = math.degrees(2 * math.atan(tan_v * FH / H))
    d = {"position": _vec(pos), "look_at": _vec(pos + fwd), "up": _vec(up), "fov": fov}
    if cam.type == "ORTHO":
        # Orthographic Scale spans the fitted side (Blender's viewplane);
        # lensray's view_height is the (widened) frame's height.
        vh = cam.ortho_scale / aspect if fit == "HORIZONTAL" else cam.ortho_scale
        del d["fov"]
        d.update({"model": "orthographic", "view_height": vh * FH / H})
        if cam.dof.use_dof or scene.lensray.lens:
            warn.add(f"camera {cam.name!r}: an orthographic camera has no lens: "
                     "depth of field and the lens panel are ignored")
        return d, FW, FH, region
    dof = cam.dof
    focus = dof.focus_distance
    if dof.use_dof and dof.focus_object is None and not focus > 0:
        # Cycles draws a focus distance of 0 (which Blender allows) as
        # everything blurred, not as depth of field off.
        raise ValueError(f"camera {cam_ob.name!r}: Focus Distance must be > 0 "
                         "(depth of field is on and there is no focus object)")
    if dof.focus_object is not None:
        fo = dof.focus_object.evaluated_get(depsgraph)
        focus = max(1e-3, (fo.matrix_world.translation - pos).dot(fwd))
    props = scene.lensray
    if props.lens:
        # A path relative to the .blend ("//lenses/x.json") as Blender
        # resolves it; a shipped lens's name as it is.
        lens = bpy.path.abspath(props.lens) if props.lens.startswith("//") else props.lens
        # lensray's sensor width is the frame's horizontal extent: the
        # sensor spans the fitted side (the long one under AUTO, the
        # height under VERTICAL), as Blender's viewplane takes it.
        width_mm = sensor if fit == "HORIZONTAL" else sensor * aspect
        d.update({"model": "lens", "lens": lens,
                  "sensor_width_mm": width_mm * FW / W,
                  "focus_distance": float(focus if dof.use_dof else 1e6),
                  "f_number": float(dof.aperture_fstop) if dof.use_dof else 0.0})
        del d["fov"]
    elif dof.use_dof:
        d.update({"model": "thinlens", "focus_distance": float(focus),
                  "focal_length_mm": float(cam.lens),
                  "f_number": float(dof.aperture_fstop)})
        if dof.aperture_blades >= 3:
            d.update({"aperture_shape": "polygon", "aperture_blades": int(dof.aperture_blades),
                      "aperture_rotation": math.degrees(dof.aperture_rotation)})
        if dof.aperture_ratio != 1:
            d["aperture_ratio"] = float(dof.aperture_ratio)
    return d, FW, FH, region


def clip_warnings(scene, depsgraph, z, warn):
    """Cycles draws nothing nearer than the camera's Clip Start or farther
    than its Clip End (along the view axis); lensray has no clipping.
    Warns when the render's depth z (lensray's Z, along the view axis,
    1e10 for the sky) shows a surface outside that range."""
    import numpy as np
    cam = scene.camera.evaluated_get(depsgraph).data
    hit = z[z < 1e10]
    if hit.size == 0:
        return
    if (hit > cam.clip_end).any():
        warn.add(f"camera {cam.name!r}: Clip End {cam.clip_end:g} m: surfaces beyond it "
                 f"(to {float(hit.max()):.3g} m) drawn, Cycles clips them")
    if (hit < cam.clip_start).any():
        warn.add(f"camera {cam.name!r}: Clip Start {cam.clip_start:g} m: surfaces nearer "
                 f"(from {float(np.min(hit)):.3g} m) drawn, Cycles clips them")


def scene_dict(scene, depsgraph, outdir, warn):
    materials, objects = {}, []
    # The camera first: an unusable one is the error, before the lights
    # look through it (_in_view).
    cam, W, H, region = camera_dict(scene, depsgraph, warn)
    if scene.render.use_motion_blur:
        warn.add("render: motion blur not drawn (the frame's instant is)")
    _mesh_objects(depsgraph, outdir, materials, objects, warn)
    lights = _lights(scene, depsgraph, outdir, materials, objects, warn)
    p = scene.lensray
    d = {"camera": cam,
         "render": {"width": W, "height": H, "spp": int(p.samples),
                    "integrator": p.integrator, "plan": bool(p.plan),
                    "max_depth": int(p.max_depth), "seed": int(p.seed)},
         "materials": materials, "lights": lights, "objects": objects}
    if region is not None:
        d["render"]["region"] = region
    if p.chromatic != "off" and cam.get("model") == "thinlens":
        cam["chromatic"] = {"mode": p.chromatic}
    d.update(_world(scene, warn))
    return d


def with_assets(d, upload):
    """A copy of the scene dict d whose files (the keys scene_dict writes:
    meshes, textures, the environment map, a lens file) are named by
    upload(path), e.g. lensray.Client.upload's "sha256:HEX"."""
    import copy
    d = copy.deepcopy(d)
    for ob in d["objects"]:
        ob["file"] = upload(ob["file"])
    for m in d["materials"].values():
        for k in TEXTURE_KEYS:
            if k in m:
                m[k] = upload(m[k])
    if "environment" in d:
        d["environment"]["file"] = upload(d["environment"]["file"])
    lens = d["camera"].get("lens")
    if lens is not None and os.path.isfile(lens):
        d["camera"]["lens"] = upload(lens)
    return d


def lens_efl_mm(lens, base_dir=None):
    """The effective focal length (mm) of a shipped lens or prescription
    file, from liblensray's lr_lens_describe."""
    import ctypes
    import json
    from lensray import _capi
    lib = _capi.lib()
    fn = lib.lr_lens_describe
    fn.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.POINTER(ctypes.c_double),
                   ctypes.c_int, ctypes.c_double, ctypes.POINTER(ctypes.c_void_p),
                   ctypes.POINTER(_capi.lr_error)]
    fn.restype = ctypes.c_int
    out = ctypes.c_void_p()
    err = _capi.lr_error()
    st = fn(lens.encode(), base_dir.encode() if base_dir else None, None, 0,
            587.5618, ctypes.byref(out), ctypes.byref(err))
    if st != 0:
        raise ValueError("lensray lens: " + bytes(err.message).split(b"\0")[0].decode(errors="replace"))
    try:
        text = ctypes.string_at(out.value).decode()
    finally:
        lib.lr_free.argtypes = [ctypes.c_void_p]
        lib.lr_free(out)
    return float(json.loads(text)["efl_mm"])


def write_scene(scene, depsgraph, outdir):
    """Writes the scene as lensray would render it: outdir/scene.json and
    its OBJ files, for `lensray render outdir/scene.json -o out.exr`.
    Returns (the JSON's path, the set of warnings)."""
    import json
    warn = set()
    os.makedirs(outdir, exist_ok=True)
    d = scene_dict(scene, depsgraph, outdir, warn)
    path = os.path.join(outdir, "scene.json")
    with open(path, "w") as f:
        json.dump(d, f, indent=1)
    return path, warn
