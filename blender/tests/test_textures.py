"""Image textures on Principled inputs, against Cycles."""

import bpy
import numpy as np

import common
from lensray_blender import export


def _textured_scene(tmp_path):
    # The ground's Base Color from a PNG file (read by lensray as it is);
    # the cube's Emission Color from an image only in memory (written out
    # as a linear EXR).
    sc = common.issue_scene("POINT")
    png = str(tmp_path / "ground.png")
    common.link_image("m_Plane", "Base Color", common.image("ground", 128, 128, png))
    common.link_image("m_Cube", "Emission Color", common.image("glow", 64, 64))
    p = bpy.data.materials["m_Cube"].node_tree.nodes["Principled BSDF"]
    p.inputs["Emission Strength"].default_value = 1.5
    return sc, png


def test_image_textures_agree_with_cycles(tmp_path):
    sc, png = _textured_scene(tmp_path)
    warn = set()
    d = export.scene_dict(sc, bpy.context.evaluated_depsgraph_get(), str(tmp_path), warn)
    assert d["materials"]["m_Plane"]["diffuse_texture"] == png
    assert d["materials"]["m_Cube"]["emission_texture"].endswith(".exr")
    assert d["materials"]["m_Cube"]["emission"] == 1.5
    assert not warn, warn
    a, b, mean, p90 = common.against_cycles(sc, tmp_path, "textures")
    assert mean < 0.03 and p90 < 0.08, (mean, p90)
    # The comparison sees the mapping: the ground's image upside down
    # (v = 0 at the top) is far outside the targets.
    img = bpy.data.images.load(png, check_existing=False)
    px = np.empty(128 * 128 * 4, np.float32)
    img.pixels.foreach_get(px)
    img.pixels.foreach_set(px.reshape(128, 128, 4)[::-1].ravel())
    img.filepath_raw = png
    img.save()
    sc.lensray.samples = 64
    c = common.render_exr(sc, "LENSRAY", str(tmp_path / "flipped.exr"))
    _, p90_flipped = common.compare(c, b)
    print(f"textures, ground flipped: p90 {p90_flipped:.4%}")
    assert p90_flipped > 0.15, p90_flipped


def test_texture_without_uv_map_is_reported(tmp_path):
    sc, _ = _textured_scene(tmp_path)
    plane = bpy.data.objects["Plane"].data
    while plane.uv_layers:
        plane.uv_layers.remove(plane.uv_layers[0])
    warn = set()
    d = export.scene_dict(sc, bpy.context.evaluated_depsgraph_get(), str(tmp_path), warn)
    assert any("'Plane': no UV map" in w for w in warn), warn
    import lensray
    lensray.load(d, base_dir=str(tmp_path)).close()


def test_roughness_texture_mapping(tmp_path):
    # A metal's Roughness from a Non-Color PNG: the file itself, alpha =
    # 1 * r^2.  The same PNG tagged sRGB is decoded by Blender, so it is
    # written out linear (an EXR) rather than read raw by lensray.
    sc = common.issue_scene("POINT")
    png = str(tmp_path / "rough.png")
    img = common.image("rough", 32, 32, png)
    img.colorspace_settings.name = "Non-Color"
    p = bpy.data.materials["m_Sphere"].node_tree.nodes["Principled BSDF"]
    p.inputs["Metallic"].default_value = 1.0
    common.link_image("m_Sphere", "Roughness", img)
    warn = set()
    d = export.scene_dict(sc, bpy.context.evaluated_depsgraph_get(), str(tmp_path), warn)
    m = d["materials"]["m_Sphere"]
    assert (m["roughness_texture"], m["roughness"], m["roughness_channel"]) == (png, 1.0, 0)
    assert m["reflect"] == [0.5, 0.5, 0.5] and not warn, (m, warn)
    img.colorspace_settings.name = "sRGB"
    d = export.scene_dict(sc, bpy.context.evaluated_depsgraph_get(), str(tmp_path), warn)
    exr = d["materials"]["m_Sphere"]["roughness_texture"]
    assert exr.endswith(".exr")
    import lensray
    lensray.load(d, base_dir=str(tmp_path)).close()


def test_linear_texture_agrees_closely(tmp_path):
    # From a float EXR both renderers filter linear values, so the ground
    # agrees as closely as the untextured scene (measured: mean 0.005%,
    # p90 0.29%).  An 8-bit sRGB PNG does not: Cycles filters its codes
    # and decodes after, lensray decodes first, which brightens lensray's
    # checker edges (p90 1.9% with the same image as a PNG).
    import lensray
    sc = common.issue_scene("POINT")
    px = export._linear_pixels(common.image("ground", 128, 128), set(), "test")
    lensray.write(str(tmp_path / "ground.exr"), np.ascontiguousarray(px[::-1, :, :3]))
    common.link_image("m_Plane", "Base Color", bpy.data.images.load(str(tmp_path / "ground.exr")))
    a, b, mean, p90 = common.against_cycles(sc, tmp_path, "EXR texture")
    assert mean < 0.003 and p90 < 0.01, (mean, p90)
