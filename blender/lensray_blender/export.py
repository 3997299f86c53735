"""Blender scene -> lensray scene dict (docs/scene-format.md).

Units follow Cycles: a point or spot light of power P watts has radiant
intensity P / (4 pi) W/sr; a sun of strength S is irradiance S W/m^2; an
area light of power P and area A is an emitter of radiance P / (pi A);
the world's Background colour times strength is a uniform environment.
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


def _input(node, name, default):
    sock = node.inputs.get(name)
    if sock is None:
        return default
    if sock.is_linked:
        return None  # textured or driven by nodes: not mapped
    return sock.default_value


def material_dict(mat, warn):
    """A Principled BSDF -> a lensray material; anything else approximated."""
    if mat is None:
        return {"diffuse": 0.8}
    if not mat.use_nodes or mat.node_tree is None:
        return {"diffuse": _col(mat.diffuse_color)}
    out = next((n for n in mat.node_tree.nodes
                if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
    surf = out.inputs["Surface"].links[0].from_node if out and out.inputs["Surface"].is_linked else None
    if out is not None and out.inputs.get("Volume") is not None and out.inputs["Volume"].is_linked:
        warn.add(f"material {mat.name!r}: volume not drawn")
    if surf is None:
        warn.add(f"material {mat.name!r}: no surface shader, drawn black")
        return {}
    if surf.type == "EMISSION":
        c = _input(surf, "Color", (1, 1, 1, 1)) or (1, 1, 1, 1)
        s = _input(surf, "Strength", 1.0) or 1.0
        return {"emission": _col(c, s)}
    if surf.type == "BSDF_DIFFUSE":
        c = _input(surf, "Color", (0.8, 0.8, 0.8, 1))
        if c is None:
            warn.add(f"material {mat.name!r}: linked Color not mapped")
            c = (0.8, 0.8, 0.8, 1)
        return {"diffuse": _col(c)}
    if surf.type != "BSDF_PRINCIPLED":
        warn.add(f"material {mat.name!r}: node {surf.bl_idname} approximated as diffuse")
        return {"diffuse": _col(mat.diffuse_color)}
    vals = {}
    for key, name, dflt in (("base", "Base Color", (0.8, 0.8, 0.8, 1)),
                            ("rough", "Roughness", 0.5), ("metal", "Metallic", 0.0),
                            ("trans", "Transmission Weight", 0.0), ("ior", "IOR", 1.5),
                            ("emis", "Emission Color", (0, 0, 0, 1)),
                            ("emis_s", "Emission Strength", 0.0)):
        v = _input(surf, name, dflt)
        if v is None:
            warn.add(f"material {mat.name!r}: linked input {name!r} not mapped (its default used)")
            v = dflt
        vals[key] = v
    base = _col(vals["base"])
    metal = float(vals["metal"])
    trans = float(vals["trans"]) * (1 - metal)
    diff = (1 - metal) * (1 - trans)
    m = {"diffuse": [c * diff for c in base]}
    if metal > 0:
        m["reflect"] = [c * metal for c in base]
    if trans > 0:
        m["transmit"] = [c * trans for c in base]
        m["ior"] = min(10.0, max(1.0, float(vals["ior"])))
    if metal > 0 or trans > 0:
        m["roughness"] = min(1.0, max(0.0, float(vals["rough"]) ** 2))
    if float(vals["emis_s"]) > 0:
        m["emission"] = _col(vals["emis"], float(vals["emis_s"]))
    return m


def _write_obj(path, verts, tris, normals=None):
    with open(path, "w") as f:
        for v in verts:
            f.write("v %.9g %.9g %.9g\n" % tuple(v))
        if normals is not None:
            for n in normals:
                f.write("vn %.9g %.9g %.9g\n" % tuple(n))
            for t in tris:
                f.write("f %d//%d %d//%d %d//%d\n" % (t[0] + 1, t[0] + 1, t[1] + 1,
                                                     t[1] + 1, t[2] + 1, t[2] + 1))
        else:
            for t in tris:
                f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def _mesh_objects(depsgraph, outdir, materials, objects, warn):
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
        mw = inst.matrix_world.copy()
        mesh = ob.to_mesh()
        if mesh is None:
            continue
        try:
            mesh.calc_loop_triangles()
            nmw = mw.to_3x3().inverted_safe().transposed()
            by_mat = {}
            for lt in mesh.loop_triangles:
                by_mat.setdefault(lt.material_index, []).append(lt)
            for mi, tris in by_mat.items():
                mat = ob.material_slots[mi].material if mi < len(ob.material_slots) else None
                mname = mat.name if mat else "__default"
                if mname not in materials:
                    materials[mname] = material_dict(mat, warn)
                verts, norms, faces = [], [], []
                smooth = any(lt.use_smooth for lt in tris)
                for lt in tris:
                    idx = []
                    for k in range(3):
                        idx.append(len(verts))
                        verts.append(_vec(mw @ mesh.vertices[lt.vertices[k]].co))
                        nn = Vector(lt.split_normals[k]) if smooth else Vector(lt.normal)
                        norms.append(_vec((nmw @ nn).normalized()))
                    faces.append(idx)
                if not faces:
                    continue
                path = os.path.join(outdir, "mesh%03d.obj" % n)
                n += 1
                _write_obj(path, verts, faces, norms if smooth else None)
                objects.append({"type": "mesh", "file": path, "material": mname})
        finally:
            ob.to_mesh_clear()


def _lights(depsgraph, outdir, materials, objects, warn):
    lights = []
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type != "LIGHT":
            continue
        L = ob.data
        mw = inst.matrix_world
        pos = _vec(mw.translation)
        axis = (mw.to_3x3() @ Vector((0, 0, -1))).normalized()
        col = L.color
        if L.type == "POINT":
            lights.append({"type": "point", "position": pos,
                           "intensity": _col(col, L.energy / (4 * math.pi))})
        elif L.type == "SPOT":
            outer = math.degrees(L.spot_size) / 2
            inner = outer * (1 - L.spot_blend)
            lights.append({"type": "spot", "position": pos, "direction": _vec(axis),
                           "intensity": _col(col, L.energy / (4 * math.pi)),
                           "inner_angle": min(inner, outer - 1e-3) if inner < outer else max(0.0, outer - 1e-3),
                           "outer_angle": min(90.0, outer)})
        elif L.type == "SUN":
            lights.append({"type": "directional", "direction": _vec(axis),
                           "irradiance": _col(col, L.energy)})
        elif L.type == "AREA":
            sx = L.size
            sy = L.size_y if L.shape in ("RECTANGLE", "ELLIPSE") else L.size
            if L.shape in ("DISK", "ELLIPSE"):
                warn.add(f"light {ob.name!r}: {L.shape.lower()} area light drawn as a rectangle of the same area")
                sx, sy = sx * math.sqrt(math.pi) / 2, sy * math.sqrt(math.pi) / 2
            corners = [mw @ Vector((x * sx / 2, y * sy / 2, 0))
                       for x, y in ((-1, -1), (-1, 1), (1, 1), (1, -1))]
            # world area (object scale included)
            area = (corners[1] - corners[0]).length * (corners[3] - corners[0]).length
            name = "__light_" + ob.name
            materials[name] = {"emission": _col(col, L.energy / (math.pi * area))}
            path = os.path.join(outdir, "light_%d.obj" % len(objects))
            # counter-clockwise seen from -Z local (the side Blender's area light faces)
            _write_obj(path, [_vec(c) for c in corners], [[0, 1, 2], [0, 2, 3]])
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
    cam = cam_ob.data
    mw = cam_ob.matrix_world
    pos = mw.translation
    fwd = (mw.to_3x3() @ Vector((0, 0, -1))).normalized()
    up = (mw.to_3x3() @ Vector((0, 1, 0))).normalized()
    r = scene.render
    W = int(r.resolution_x * r.resolution_percentage / 100)
    H = int(r.resolution_y * r.resolution_percentage / 100)
    aspect = (W * r.pixel_aspect_x) / (H * r.pixel_aspect_y)
    if cam.type != "PERSP":
        warn.add(f"camera {cam.name!r}: {cam.type.lower()} projection drawn as perspective")
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if aspect >= 1 else "VERTICAL"
    sensor = cam.sensor_height if cam.sensor_fit == "VERTICAL" else cam.sensor_width
    half = sensor / (2 * cam.lens)
    tan_v = half / aspect if fit == "HORIZONTAL" else half
    fov = math.degrees(2 * math.atan(tan_v))
    if cam.shift_x or cam.shift_y:
        warn.add(f"camera {cam.name!r}: lens shift not drawn")
    d = {"position": _vec(pos), "look_at": _vec(pos + fwd), "up": _vec(up), "fov": fov}
    dof = cam.dof
    focus = dof.focus_distance
    if dof.focus_object is not None:
        focus = max(1e-3, (dof.focus_object.matrix_world.translation - pos).dot(fwd))
    props = scene.lensray
    if props.lens:
        lens = props.lens
        d.update({"model": "lens", "lens": lens if os.path.exists(lens) else lens,
                  "sensor_width_mm": cam.sensor_width,
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
    return d, W, H


def scene_dict(scene, depsgraph, outdir, warn):
    materials, objects = {}, []
    _mesh_objects(depsgraph, outdir, materials, objects, warn)
    lights = _lights(depsgraph, outdir, materials, objects, warn)
    cam, W, H = camera_dict(scene, depsgraph, warn)
    p = scene.lensray
    d = {"camera": cam,
         "render": {"width": W, "height": H, "spp": int(p.samples),
                    "integrator": p.integrator, "plan": bool(p.plan),
                    "max_depth": int(p.max_depth), "seed": int(p.seed)},
         "materials": materials, "lights": lights, "objects": objects}
    if p.chromatic != "off" and cam.get("model") == "thinlens":
        cam["chromatic"] = {"mode": p.chromatic}
    d.update(_world(scene, warn))
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
