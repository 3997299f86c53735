"""Lights and emitters the add-on exported wrongly or without a word (an
independent check): a zero-area light, mirrored emitters, instances of
one area light at different scales, features Cycles draws that lensray
does not, and the camera's degenerate settings."""
import math

import bpy
import numpy as np
import pytest

import common
from lensray_blender import export

import lensray


def _export(sc, tmp_path):
    warn = set()
    d = export.scene_dict(sc, bpy.context.evaluated_depsgraph_get(), str(tmp_path), warn)
    return d, "; ".join(sorted(warn))


def _obj_tris(path):
    """An OBJ's triangles as (t, 3, 3) corner positions."""
    v, f = [], []
    for line in open(path):
        w = line.split()
        if w and w[0] == "v":
            v.append([float(x) for x in w[1:4]])
        elif w and w[0] == "f":
            f.append([int(c.split("/")[0]) - 1 for c in w[1:4]])
    return np.array(v)[np.array(f)]


def _fronts(tris):
    """Each triangle's front (counter-clockwise) normal, lensray's frame."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _light_quads(d):
    return [o for o in d["objects"] if o["material"].startswith("__light_")]


@pytest.mark.parametrize("how", ["size", "scale"])
def test_zero_area_light_is_left_out(how, tmp_path):
    # An area light of size 0, or scaled to 0: Cycles draws no light from
    # it.  Its radiance P / (pi A) divided by zero, the exception escaped
    # render(), and Blender, writing the EXR, crashed (exit 139).
    sc = common.issue_scene("AREA", 64, 48)
    lamp = bpy.data.objects["Light"]
    if how == "size":
        lamp.data.size = 0.0
    else:
        lamp.scale = (0, 0, 0)
    d, text = _export(sc, tmp_path)
    assert _light_quads(d) == [] and "zero area" in text, (d["objects"], text)
    sc.lensray.samples = 4
    a = common.render_exr(sc, "LENSRAY", str(tmp_path / "zero.exr"))
    assert a.shape == (48, 64, 3) and np.isfinite(a).all()


def test_unexpected_exception_is_an_error(tmp_path, monkeypatch):
    # Any exception in the export or the render is one error in Blender's
    # reports (bpy.ops raises it), not a traceback and a blank frame.
    def broken(*a, **k):
        raise ZeroDivisionError("float division by zero")
    monkeypatch.setattr(export, "scene_dict", broken)
    sc = common.issue_scene("POINT", 32, 24)
    sc.render.engine = "LENSRAY"
    with pytest.raises(RuntimeError) as e:
        bpy.ops.render.render(write_still=False)
    assert "ZeroDivisionError: float division by zero" in str(e.value), e.value


@pytest.mark.parametrize("scale, down", [((1, 1, 1), True), ((-1, 1, 1), True),
                                         ((1, -1, 1), True), ((1, 1, -1), False),
                                         ((-1, -1, -1), False)])
def test_mirrored_area_light_emits_along_its_minus_z(scale, down, tmp_path):
    # lensray's emission is one-sided (the counter-clockwise side).
    # Cycles' area light emits along its object's -Z, whatever the
    # scale's signs: (-1, 1, 1) still lights the scene below.  The corners
    # went through the matrix in the same order, so a mirror turned the
    # quad's front up (an independent check: mean 86% darker).  Measured
    # against Cycles (64 x 48, 128 and 64 spp): (-1, 1, 1) mean 0.12%, p90
    # 0.74%; (1, 1, -1), which Cycles turns up, 0.34% and 1.1%.
    sc = common.issue_scene("AREA", 64, 48)
    bpy.data.objects["Light"].scale = scale
    d, _ = _export(sc, tmp_path)
    (quad,) = _light_quads(d)
    fronts = _fronts(_obj_tris(quad["file"]))
    # Blender's -Z is lensray's -Y (_vec)
    assert np.allclose(fronts, [0, -1 if down else 1, 0], atol=1e-6), fronts


def test_mirrored_area_light_lights_the_scene(tmp_path):
    sc = common.issue_scene("AREA", 64, 48)
    sc.lensray.samples = 16
    a = common.render_exr(sc, "LENSRAY", str(tmp_path / "plain.exr"))
    bpy.data.objects["Light"].scale = (-1, 1, 1)
    b = common.render_exr(sc, "LENSRAY", str(tmp_path / "mirrored.exr"))
    mean, p90 = common.compare(b, a)
    assert mean < 0.02 and p90 < 0.1, (mean, p90)


def test_mirrored_emissive_mesh_emits_outwards(tmp_path):
    # A cube mirrored by scale (-1, 1, 1) with an emissive material: its
    # triangles' fronts (where lensray emits) stay outwards (they were all
    # inwards: an independent check found it 30% darker than Cycles; now
    # mean 0.08%, p90 0.58% at 64 x 48).
    sc = common.issue_scene("POINT", 64, 48)
    m = bpy.data.materials.new("glow")
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Emission Color"].default_value = (1.0, 0.5, 0.2, 1)
    p.inputs["Emission Strength"].default_value = 5.0
    for scale in ((1, 1, 1), (-1, 1, 1), (-1, -1, 1), (2, -0.5, 1)):
        bpy.ops.mesh.primitive_cube_add(size=0.8, location=(-1.5, -1.5, 0))
        cube = bpy.context.object
        cube.scale = scale
        cube.data.materials.append(m)
        d, _ = _export(sc, tmp_path)
        (ob,) = [o for o in d["objects"] if o["material"] == "glow"]
        tris = _obj_tris(ob["file"])
        centre = tris.reshape(-1, 3).mean(axis=0)
        out = np.einsum("ij,ij->i", _fronts(tris), tris.mean(axis=1) - centre)
        assert (out > 0).all(), (scale, out)
        bpy.data.objects.remove(cube)


def test_instances_of_one_area_light_keep_their_own_radiance(tmp_path):
    # One 200 W area light (0.5 m) in a collection instanced at scales 1
    # and 2: radiances 200 / (pi 0.25) and 200 / (pi 1).  The material was
    # named after the light, so the last instance's value lit both.
    sc = common.issue_scene("POINT", 64, 48)
    bpy.data.objects["Light"].data.energy = 0
    col = bpy.data.collections.new("Lamps")
    data = bpy.data.lights.new("A", "AREA")
    data.energy, data.size = 200.0, 0.5
    col.objects.link(bpy.data.objects.new("AreaLamp", data))
    for i, (loc, s) in enumerate([((-1.5, 0, 2.5), 1.0), ((2.0, -1.0, 2.5), 2.0)]):
        inst = bpy.data.objects.new(f"inst{i}", None)
        inst.instance_type = "COLLECTION"
        inst.instance_collection = col
        inst.location, inst.scale = loc, (s, s, s)
        sc.collection.objects.link(inst)
    d, _ = _export(sc, tmp_path)
    quads = _light_quads(d)
    assert len(quads) == 2
    got = {}
    for q in quads:
        tris = _obj_tris(q["file"])
        area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0],
                                             tris[:, 2] - tris[:, 0]), axis=1).sum()
        got[round(float(area), 6)] = d["materials"][q["material"]]["emission"][0]
    assert got == {0.25: pytest.approx(200 / (math.pi * 0.25)),
                   1.0: pytest.approx(200 / (math.pi * 1.0))}, got


def test_features_cycles_draws_are_listed(tmp_path):
    # Each rendered differently from Cycles without a word (an independent
    # check: Cast Shadow off p90 28%, spot blend 1 p90 29%).
    sc = common.issue_scene("POINT", 64, 48)
    bpy.data.objects["Light"].data.use_shadow = False
    sc.render.use_motion_blur = True
    _, text = _export(sc, tmp_path)
    for want in ("'Light': Cast Shadow off", "motion blur not drawn"):
        assert want in text, (want, text)
    bpy.data.objects["Light"].data.use_shadow = True
    sc.render.use_motion_blur = False
    _, text = _export(sc, tmp_path)
    assert not text, text
    sc = common.issue_scene("SUN", 64, 48)
    bpy.data.objects["Light"].data.angle = math.radians(30)
    _, text = _export(sc, tmp_path)
    assert "sun angle 30 degrees drawn as 0" in text, text
    sc = common.issue_scene("SPOT", 64, 48)
    _, text = _export(sc, tmp_path)
    assert not text, text  # blend 0: a hard edge, as Cycles'
    bpy.data.objects["Light"].data.spot_blend = 1.0
    _, text = _export(sc, tmp_path)
    assert "spot blend 1 drawn with lensray's falloff" in text, text


def test_clip_range_is_listed(tmp_path, capfd):
    # Cycles draws nothing beyond the camera's Clip End (nor nearer than
    # its Clip Start); lensray draws it all.  The render's depth tells.
    sc = common.issue_scene("POINT", 64, 48)
    dg = bpy.context.evaluated_depsgraph_get()
    d, _ = _export(sc, tmp_path)
    d["render"]["spp"] = 1
    with lensray.load(d, base_dir=str(tmp_path)) as s:
        _, z = s.render(depth=True)
    warn = set()
    export.clip_warnings(sc, dg, z, warn)
    assert not warn, warn  # 0.1 to 100 m holds the scene
    sc.camera.data.clip_end = 8.0
    sc.camera.data.clip_start = 9.0
    export.clip_warnings(sc, bpy.context.evaluated_depsgraph_get(), z, warn)
    text = "; ".join(sorted(warn))
    assert "Clip End 8 m: surfaces beyond it" in text and "Clip Start 9 m" in text, text
    # F12: in the one warning Blender prints (in the background, on stdout)
    sc.camera.data.clip_start = 0.1
    sc.lensray.samples = 1
    capfd.readouterr()
    common.render_exr(sc, "LENSRAY", str(tmp_path / "clip.exr"))
    out = capfd.readouterr().out
    assert "not drawn as in Cycles: camera 'Camera': Clip End 8 m" in out, out


def test_spot_blend_agrees_with_cycles(tmp_path):
    # Cycles' blend is a smoothstep over cos theta from the cone's edge to
    # (1 - cos outer) x blend inside it; lensray's a^2 over 0.75 of that
    # span carries the same power.  Measured at blend 1 (64 x 48, lensray
    # 256 spp, Cycles 128): this mapping mean 0.36%, p90 6.7%; the inner
    # angle outer x (1 - blend) (the mapping before) mean 15%, p90 28%.
    sc = common.issue_scene("SPOT", 64, 48)
    L = bpy.data.objects["Light"].data
    L.spot_blend = 1.0
    d, _ = _export(sc, tmp_path)
    co = math.cos(math.radians(40))
    assert d["lights"][0]["inner_angle"] == pytest.approx(
        math.degrees(math.acos(co + 0.75 * (1 - co))), rel=1e-6)
    a, b, mean, p90 = common.against_cycles(sc, tmp_path, "spot blend 1",
                                            lensray_spp=256, cycles_spp=128)
    assert mean < 0.03 and p90 < 0.1, (mean, p90)


def test_degenerate_camera_is_named(tmp_path):
    sc = common.issue_scene("POINT", 64, 48)
    sc.camera.scale = (1, 0, 1)
    with pytest.raises(ValueError, match="camera 'Camera': its scale is 0"):
        _export(sc, tmp_path)
    sc.camera.scale = (1, 1, 1)
    dof = sc.camera.data.dof
    dof.focus_object = None
    dof.focus_distance = 0.0
    with pytest.raises(ValueError, match="Camera.: Focus Distance must be > 0"):
        _export(sc, tmp_path)
    dof.use_dof = False  # no depth of field: the distance is not used
    d, _ = _export(sc, tmp_path)
    assert "focus_distance" not in d["camera"]
    # through the engine: one error naming the camera's setting
    sc.render.engine = "LENSRAY"
    dof.use_dof = True
    with pytest.raises(RuntimeError, match="Focus Distance must be > 0"):
        bpy.ops.render.render(write_still=False)
