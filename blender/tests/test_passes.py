"""The passes a compositor gets: Combined, Depth and the effect plan."""
import bpy
import numpy as np

import common
import lensray_blender
from lensray_blender import export

import lensray


def _pass_and_scene(sc, pass_name, tmp_path):
    """The pass, through the compositor into the EXR the render writes,
    and the exported scene loaded in process."""
    _composite(sc, pass_name)
    got = common.render_exr(sc, "LENSRAY", str(tmp_path / "pass.exr"))
    d = export.scene_dict(sc, bpy.context.evaluated_depsgraph_get(), str(tmp_path), set())
    return got, lensray.load(d, base_dir=str(tmp_path))


def _composite(sc, pass_name):
    sc.render.engine = "LENSRAY"
    sc.use_nodes = True
    nt = sc.node_tree
    rl = next(n for n in nt.nodes if n.type == "R_LAYERS")
    comp = next(n for n in nt.nodes if n.type == "COMPOSITE")
    nt.links.new(rl.outputs[pass_name], comp.inputs["Image"])


def test_plan_pass_is_the_plan(tmp_path):
    # The issue's scene (f/2.8) with chromatic rgb: every block samples the
    # lens, 97 of 104 trace the colours apart.  The pass, read back through
    # the compositor, is Scene.plan's cells block for block (red: lens
    # sampled, green: colours apart).
    sc = common.issue_scene("POINT", width=200, height=120)
    sc.lensray.chromatic = "rgb"
    sc.lensray.samples = 4
    sc.view_layers[0].lensray_pass_plan = True
    got, s = _pass_and_scene(sc, "Plan", tmp_path)
    with s:
        cells = s.plan()
    want = lensray_blender.plan_pixels(cells, {"width": 200, "height": 120})
    assert np.array_equal(got, want)
    kinds = set(np.unique(cells))
    print("plan cells:", sorted(kinds), "lens share", (cells & 1).mean())
    assert kinds == {lensray.PLAN_LENS, lensray.PLAN_LENS | lensray.PLAN_CHROMA}, kinds


def test_depth_pass_is_the_distance(tmp_path):
    sc = common.issue_scene("POINT", width=96, height=64)
    sc.lensray.samples = 4
    sc.view_layers[0].use_pass_z = True
    got, s = _pass_and_scene(sc, "Depth", tmp_path)
    with s:
        _, z = s.render(depth=True)
    assert np.array_equal(got[:, :, 0], z) and z.min() > 5 and z.max() == 1e10
