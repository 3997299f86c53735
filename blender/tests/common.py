"""Shared by the tests: the issue's scene in bpy, rendering to linear EXR."""
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "blender"))
sys.path.insert(0, os.path.join(ROOT, "python"))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import lensray_blender  # noqa: E402

_registered = False


def register():
    global _registered
    if not _registered:
        lensray_blender.register()
        _registered = True


def issue_scene(light="POINT", width=160, height=120, world_grey=0.2):
    """Blender's default cube, a sphere and a ground plane, diffuse
    Principled, a grey world, the default light (or a sun / area / spot in
    its place), the camera at f/2.8 focused on the cube."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    register()
    sc = bpy.context.scene
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(2.2, -1.0, 0.0),
                                         segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, -1))
    for ob in sc.objects:
        if ob.type == "MESH":
            mat = bpy.data.materials.new("m_" + ob.name)
            mat.use_nodes = True
            p = mat.node_tree.nodes["Principled BSDF"]
            p.inputs["Base Color"].default_value = (0.6, 0.5, 0.4, 1) if ob.name == "Cube" else (0.5, 0.5, 0.5, 1)
            p.inputs["Roughness"].default_value = 1.0
            # "Specular" before Blender 4.0 (the binary test builds this in 3.4)
            (p.inputs.get("Specular IOR Level") or p.inputs["Specular"]).default_value = 0.0
            ob.data.materials.clear()
            ob.data.materials.append(mat)
    w = sc.world
    w.use_nodes = True
    w.node_tree.nodes["Background"].inputs["Color"].default_value = (world_grey,) * 3 + (1,)
    w.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    lamp = bpy.data.objects["Light"]
    if light != "POINT":
        old = lamp.data
        data = bpy.data.lights.new("L", light)
        lamp.data = data
        bpy.data.lights.remove(old)
        if light == "SUN":
            data.energy = 3.0
            lamp.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
        elif light == "AREA":
            data.energy = 1000.0
            data.size = 1.0
            lamp.rotation_euler = (0, 0, 0)
            lamp.location = (1.0, -1.0, 4.0)
        elif light == "SPOT":
            data.energy = 1000.0
            data.spot_size = math.radians(80)
            data.spot_blend = 0.0
            lamp.rotation_euler = (0, 0, 0)
            lamp.location = (0.5, -0.5, 4.5)
    # Radius 0: lensray's point and spot (test_point_light_radius_* covers a sphere).
    if light in ("POINT", "SPOT"):
        lamp.data.shadow_soft_size = 0.0
    cam = sc.camera
    cam.data.dof.use_dof = True
    cam.data.dof.aperture_fstop = 2.8
    cam.data.dof.focus_object = bpy.data.objects["Cube"]
    r = sc.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"
    r.film_transparent = False
    return sc


def render_exr(sc, engine, path):
    sc.render.engine = engine
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return load_exr(path)


def load_exr(path):
    """An image file's RGB as float32, rows from the top."""
    img = bpy.data.images.load(str(path))
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[::-1, :, :3].copy()


def setup_cycles(sc, samples):
    sc.render.engine = "CYCLES"
    c = sc.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = 8
    c.diffuse_bounces = 8
    c.glossy_bounces = 8
    c.transparent_max_bounces = 8
    c.sample_clamp_direct = 0
    c.sample_clamp_indirect = 0
    c.filter_width = 1.0
    c.seed = 1


def against_cycles(sc, tmp_path, label, lensray_spp=256, cycles_spp=64):
    """Renders sc with LENSRAY and with Cycles (CPU), prints and returns
    (lensray's pixels, Cycles', mean difference, p90 of 8x8 blocks)."""
    sc.lensray.samples = lensray_spp
    a = render_exr(sc, "LENSRAY", str(tmp_path / "lensray.exr"))
    setup_cycles(sc, cycles_spp)
    b = render_exr(sc, "CYCLES", str(tmp_path / "cycles.exr"))
    mean, p90 = compare(a, b)
    print(f"{label}: mean {mean:.4%} p90 of 8x8 blocks {p90:.4%}")
    return a, b, mean, p90


def compare(a, b):
    """(relative difference of the means, p90 of the 8x8 blocks' relative
    differences of their means) of luminance."""
    la = a @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float64)
    lb = b @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float64)
    mean = abs(la.mean() - lb.mean()) / lb.mean()
    h, w = la.shape
    h8, w8 = h // 8 * 8, w // 8 * 8
    ba = la[:h8, :w8].reshape(h8 // 8, 8, w8 // 8, 8).mean(axis=(1, 3))
    bb = lb[:h8, :w8].reshape(h8 // 8, 8, w8 // 8, 8).mean(axis=(1, 3))
    rel = np.abs(ba - bb) / np.maximum(bb, 1e-3 * lb.mean())
    return float(mean), float(np.percentile(rel, 90))


VARIANTS = ("POINT", "SPOT", "SUN", "AREA", "HDRI")


def variant_scene(case, width, height, workdir):
    """The issue's scene with one of VARIANTS: a light of that type, or
    "HDRI", the world's environment texture (written to workdir) with the
    light off."""
    sc = issue_scene("POINT" if case == "HDRI" else case, width, height)
    if case == "HDRI":
        bpy.data.objects["Light"].data.energy = 0.0
        hdri_world(sc, os.path.join(str(workdir), "hdri.exr"))
    return sc


def hdri_world(sc, path, w=64, h=32):
    """An equirectangular EXR with a warm bright patch and a sky gradient,
    as the world's Environment Texture."""
    img = bpy.data.images.new("hdri", w, h, float_buffer=True)
    px = np.zeros((h, w, 4), np.float32)
    ys = (np.arange(h) + 0.5) / h  # 0 bottom .. 1 top (Blender's rows)
    xs = (np.arange(w) + 0.5) / w
    px[:, :, 0] = 0.15 + 0.3 * ys[:, None]
    px[:, :, 1] = 0.2 + 0.3 * ys[:, None] + 0.2 * xs[None, :]
    px[:, :, 2] = 0.3 + 0.5 * ys[:, None]
    px[int(h * 0.7):int(h * 0.85), int(w * 0.1):int(w * 0.2), :3] = (20.0, 15.0, 8.0)
    px[:, :, 3] = 1
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw = path
    img.file_format = "OPEN_EXR"
    img.save()
    nt = sc.world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(path)
    env.interpolation = "Linear"
    nt.links.new(env.outputs["Color"], nt.nodes["Background"].inputs["Color"])


def image(name, w, h, path=None):
    """A byte (sRGB) image with no symmetry: 4x4 checker cells of warm and
    cool colours over a left-right ramp and a darker bottom band; saved as
    an 8-bit PNG at path, or left generated in memory."""
    y, x = np.mgrid[0:h, 0:w]
    check = ((x * 4 // w) + (y * 4 // h)) % 2
    px = np.zeros((h, w, 4), np.float32)
    px[:, :, 0] = np.where(check, 0.9, 0.2) * (0.4 + 0.6 * x / w)
    px[:, :, 1] = np.where(check, 0.6, 0.3)
    px[:, :, 2] = np.where(check, 0.1, 0.8) * (0.4 + 0.6 * x / w)
    px[: h // 5, :, :3] *= 0.3  # Blender's rows start at the bottom
    px[:, :, 3] = 1
    img = bpy.data.images.new(name, w, h, alpha=False, float_buffer=False)
    img.pixels.foreach_set(px.ravel())
    if path is not None:
        img.filepath_raw = path
        img.file_format = "PNG"
        img.save()
    return img


def link_image(mat_name, socket, img):
    """An Image Texture node (default UV map) into a shader input."""
    nt = bpy.data.materials[mat_name].node_tree
    node = nt.nodes.new("ShaderNodeTexImage")
    node.image = img
    shader = next(n for n in nt.nodes if n.inputs.get(socket) is not None
                  and n.type in ("BSDF_PRINCIPLED", "EMISSION", "BSDF_DIFFUSE"))
    nt.links.new(node.outputs["Color"], shader.inputs[socket])
    return node


class Daemon:
    """build/lensrayd on a free port with an asset store in `assets`."""

    def __init__(self, assets):
        import re
        import subprocess
        import threading
        self.proc = subprocess.Popen(
            [os.path.join(ROOT, "build", "lensrayd"), "--port", "0", "--workers", "1",
             "--scenes", os.path.join(ROOT, "scenes"), "--assets", str(assets)],
            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
        log = []
        for line in self.proc.stderr:
            log.append(line)
            m = re.search(r"listening on (http://\S+)", line)
            if m:
                self.url = m.group(1)
                break
        else:
            raise RuntimeError("lensrayd did not start:\n" + "".join(log))
        # Its request log is read, or it would block on a full pipe.
        threading.Thread(target=self.proc.stderr.read, daemon=True).start()

    def stop(self):
        self.proc.kill()
        self.proc.wait(timeout=10)
