"""lensray as a Blender render engine (LENSRAY): real lenses and thin-lens
depth of field, rendered in process through the lensray Python package.

Install: put the ``lensray`` package (python/, with liblensray) and this
folder where Blender's Python finds them (docs/blender.md).
"""
import os
import tempfile

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from . import export

bl_info = {
    "name": "lensray",
    "blender": (3, 4, 0),
    "category": "Render",
    "description": "Physically based camera-lens rendering (lensray on Embree)",
}


def _lens_items(self, context):
    items = [("", "Camera (thin lens)", "Blender's camera as lensray's thin lens")]
    if os.path.isdir(export.LENS_DIR):
        for f in sorted(os.listdir(export.LENS_DIR)):
            if f.endswith(".json"):
                items.append((f[:-5], f[:-5], "shipped lens " + f))
    return items


def _lens_update(self, context):
    """Blender's field of view follows the lens: its focal length becomes
    the camera's (the sensor width stays)."""
    scene = context.scene if context is not None else None
    if not self.lens or scene is None or scene.camera is None:
        return
    try:
        scene.camera.data.lens = export.lens_efl_mm(bpy.path.abspath(self.lens)
                                                    if os.path.exists(bpy.path.abspath(self.lens))
                                                    else self.lens)
    except ValueError as e:
        print(e)


class LensraySettings(bpy.types.PropertyGroup):
    samples: IntProperty(name="Samples", default=64, min=1, max=1048576)
    integrator: EnumProperty(name="Integrator", default="path",
                             items=[("path", "Path", "path tracer"),
                                    ("whitted", "Whitted", "direct light"),
                                    ("light", "Light",
                                     "every path from the lights")])
    plan: BoolProperty(name="Effect plan", default=True)
    max_depth: IntProperty(name="Max bounces", default=8, min=0, max=64)
    seed: IntProperty(name="Seed", default=0, min=0)
    chromatic: EnumProperty(name="Chromatic", default="off",
                            items=[("off", "Off", ""), ("rgb", "RGB", ""),
                                   ("spectral", "Spectral", "")])
    daemon_url: StringProperty(name="Daemon URL", default="",
                               description="render on lensrayd at this URL (run with --assets, "
                                           "which receives the scene's files); empty: in process")
    lens: StringProperty(name="Lens", default="",
                         description="a shipped lens name or a prescription file; "
                                     "empty: Blender's camera as a thin lens",
                         update=_lens_update)


class LensrayRenderEngine(bpy.types.RenderEngine):
    bl_idname = "LENSRAY"
    bl_label = "lensray"
    bl_use_preview = False

    def render(self, depsgraph):
        import lensray
        scene = depsgraph.scene
        url = scene.lensray.daemon_url.strip()
        want_plan = depsgraph.view_layer.lensray_pass_plan
        warn = set()

        def report_warnings():
            # One warning, for the export's findings and the depth's.
            if warn:
                self.report({"WARNING"}, "lensray: not drawn as in Cycles: "
                            + "; ".join(sorted(warn)))
        with tempfile.TemporaryDirectory(prefix="lensray-blender-") as tmp:
            try:
                d = export.scene_dict(scene, depsgraph, tmp, warn)
                if url:
                    out = self._render_daemon(url, d, want_plan)
                else:
                    out = self._render_here(d, tmp, want_plan)
                if out is not None:
                    export.clip_warnings(scene, depsgraph, out[1], warn)
            except lensray.CancelledError:
                # Esc (test_break) says nothing; a job cancelled on the
                # daemon by someone else is an error, not a silent blank.
                report_warnings()
                if not self.test_break():
                    self.report({"ERROR"}, "lensray: the render was cancelled "
                                "before it finished (on the daemon, by another client)")
                return
            except (lensray.LensrayError, ValueError) as e:
                report_warnings()
                self.report({"ERROR"}, f"lensray: {e}")
                return
            except OSError as e:
                report_warnings()
                self.report({"ERROR"}, f"lensray: Daemon URL {url}: {e}")
                return
            except Exception as e:  # noqa: BLE001
                # A defect of the add-on: reported, not escaping (an
                # exception out of render() left Blender writing a frame
                # that was never begun, and it crashed writing an EXR).
                import traceback
                traceback.print_exc()
                report_warnings()
                self.report({"ERROR"}, f"lensray: internal error, please report: "
                            f"{type(e).__name__}: {e}")
                return
        report_warnings()
        if out is None:
            return
        if want_plan:
            self.add_pass("Plan", 3, "RGB", layer=depsgraph.view_layer.name)
        rgb, z, cells = out
        if cells is not None:
            cells = plan_pixels(cells, d["render"])
        self._write_result(rgb, z, cells)

    def _render_here(self, d, tmp, want_plan):
        """In process: (rgb, z, plan cells or None)."""
        import lensray
        engine = self

        class _Break:
            def is_set(self):
                return engine.test_break()

        def progress(done, total):
            engine.update_progress(done / total)

        with lensray.load(d, base_dir=tmp) as sc:
            rgb, z = sc.render(depth=True, progress=progress, cancel=_Break())
            return rgb, z, sc.plan() if want_plan else None

    def _render_daemon(self, url, d, want_plan):
        """On lensrayd at url: the scene's files are sent as assets, the
        job is queued and watched (Esc cancels it on the daemon).  (rgb, z,
        plan cells or None), or None when cancelled."""
        import time
        import lensray
        client = lensray.Client(url)
        job = client.submit(export.with_assets(d, client.upload), depth=True)
        while True:
            info = job.info()
            self.update_progress(float(info.get("progress", 0)))
            if info["status"] in ("done", "failed", "cancelled"):
                break
            if self.test_break():
                job.cancel()
                return None
            time.sleep(0.1)
        rgb, z = job.result()
        return rgb, z, job.plan() if want_plan else None

    def _write_result(self, rgb, z, plan):
        """Blender's passes from lensray's pixels: rows from the bottom."""
        import numpy as np
        H, W = rgb.shape[:2]
        rgba = np.ones((H, W, 4), dtype=np.float32)
        rgba[:, :, :3] = rgb[::-1]
        result = self.begin_result(0, 0, W, H)
        layer = result.layers[0]
        _set_rect(layer.passes["Combined"], rgba)
        zp = layer.passes.get("Depth")
        if zp is not None:
            _set_rect(zp, np.where(z >= 1e10, np.float32(1e10), z)[::-1])
        pp = layer.passes.get("Plan")
        if pp is not None and plan is not None:
            _set_rect(pp, plan[::-1])
        self.end_result(result)

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        if renderlayer is not None and renderlayer.use_pass_z:
            self.register_pass(scene, renderlayer, "Depth", 1, "Z", "VALUE")
        if renderlayer is not None and renderlayer.lensray_pass_plan:
            self.register_pass(scene, renderlayer, "Plan", 3, "RGB", "COLOR")


def _set_rect(render_pass, a):
    """A pass's pixels from an (H, W) or (H, W, channels) array.  Blender
    4 takes them flat; 3.4 counts pixels, and takes a row per pixel."""
    import numpy as np
    a = np.ascontiguousarray(a, dtype=np.float32).reshape(-1, render_pass.channels)
    try:
        render_pass.rect.foreach_set(a.ravel())
    except TypeError:  # "expected sequence size" of Blender 3.4
        render_pass.rect.foreach_set(a)


def plan_pixels(cells, render):
    """The effect plan as a float32 image of the render's pixels (its
    region, if any), rows from the top: red 1 where the block sampled the
    lens, green 1 where it traced the colours apart (lensray.Scene.plan's
    bits, for the whole frame)."""
    import numpy as np
    import lensray
    b = lensray.PLAN_BLOCK
    x0, y0, x1, y1 = render.get("region", [0, 0, render["width"], render["height"]])
    full = np.repeat(np.repeat(cells, b, axis=0), b, axis=1)[y0:y1, x0:x1]
    H, W = full.shape
    out = np.zeros((H, W, 3), np.float32)
    out[:, :, 0] = (full & lensray.PLAN_LENS) != 0
    out[:, :, 1] = (full & lensray.PLAN_CHROMA) != 0
    return out


class _Panel:
    # A properties-editor panel shown when LENSRAY is the render engine.
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {"LENSRAY"}

    @classmethod
    def poll(cls, context):
        return context.engine == "LENSRAY"


class LENSRAY_OT_export_scene(bpy.types.Operator):
    """Write the scene as lensray renders it: a folder with scene.json and
    its OBJ, texture and map files, for `lensray render` or a daemon"""
    bl_idname = "lensray.export_scene"
    bl_label = "Export lensray scene"
    directory: StringProperty(name="Folder", subtype="DIR_PATH")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        if not self.directory:
            self.report({"ERROR"}, "lensray: export: no folder given")
            return {"CANCELLED"}
        outdir = bpy.path.abspath(self.directory)
        try:
            path, warn = export.write_scene(context.scene,
                                            context.evaluated_depsgraph_get(), outdir)
        except (OSError, ValueError) as e:
            self.report({"ERROR"}, f"lensray: export to {outdir}: {e}")
            return {"CANCELLED"}
        except Exception as e:  # noqa: BLE001  (a defect of the add-on: reported)
            import traceback
            traceback.print_exc()
            self.report({"ERROR"}, f"lensray: export to {outdir}: internal error, "
                        f"please report: {type(e).__name__}: {e}")
            return {"CANCELLED"}
        if warn:
            self.report({"WARNING"}, "lensray: not drawn as in Cycles: "
                        + "; ".join(sorted(warn)))
        self.report({"INFO"}, f"lensray: wrote {path} (lensray render {path} -o out.exr)")
        return {"FINISHED"}


def _export_menu(self, context):
    self.layout.operator(LENSRAY_OT_export_scene.bl_idname, text="lensray scene")


class LENSRAY_PT_render(_Panel, bpy.types.Panel):
    bl_label = "lensray"
    bl_context = "render"

    def draw(self, context):
        p = context.scene.lensray
        for k in ("samples", "integrator", "plan", "max_depth", "seed", "chromatic",
                  "daemon_url"):
            self.layout.prop(p, k)
        self.layout.operator(LENSRAY_OT_export_scene.bl_idname)


class LENSRAY_PT_lens(_Panel, bpy.types.Panel):
    bl_label = "lensray lens"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return context.engine == "LENSRAY" and context.camera is not None

    def draw(self, context):
        self.layout.prop(context.scene.lensray, "lens")


class LENSRAY_PT_passes(_Panel, bpy.types.Panel):
    bl_label = "lensray passes"
    bl_context = "view_layer"

    def draw(self, context):
        self.layout.prop(context.view_layer, "use_pass_z")
        self.layout.prop(context.view_layer, "lensray_pass_plan")


def _compatible_panels():
    # Blender's own panels (camera, light, material, world) for LENSRAY too.
    for name in ("DATA_PT_lens", "DATA_PT_camera", "DATA_PT_camera_dof",
                 "DATA_PT_camera_dof_aperture", "DATA_PT_light", "DATA_PT_EEVEE_light",
                 "RENDER_PT_format", "RENDER_PT_color_management", "EEVEE_MATERIAL_PT_surface",
                 "CYCLES_LIGHT_PT_light", "WORLD_PT_context_world"):
        p = getattr(bpy.types, name, None)
        if p is not None and hasattr(p, "COMPAT_ENGINES"):
            yield p


_classes = (LensraySettings, LensrayRenderEngine, LENSRAY_OT_export_scene,
            LENSRAY_PT_render, LENSRAY_PT_lens, LENSRAY_PT_passes)


def register():
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.lensray = bpy.props.PointerProperty(type=LensraySettings)
    bpy.types.ViewLayer.lensray_pass_plan = BoolProperty(
        name="Plan", default=False,
        update=lambda layer, context: layer.update_render_passes(),
        description="the effect plan as a pass: red where the lens was sampled, "
                    "green where the colours were traced apart (per 16 x 16 block)")
    for p in _compatible_panels():
        p.COMPAT_ENGINES.add("LENSRAY")
    bpy.types.TOPBAR_MT_file_export.append(_export_menu)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(_export_menu)
    for p in _compatible_panels():
        p.COMPAT_ENGINES.discard("LENSRAY")
    del bpy.types.ViewLayer.lensray_pass_plan
    del bpy.types.Scene.lensray
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
