"""The add-on in a `blender` binary (Debian 12's is 3.4.1), when one is
on PATH: the issue's scene built and saved by that Blender, rendered
with `blender -b scene.blend -E LENSRAY -f 1` (the add-on enabled with
--addons), against that Blender's Cycles and against `lensray render` of
the scene its export operator writes."""
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import common

BLENDER = shutil.which("blender")

# Run inside the binary: the scene (point light, radius 0) with
# Diffuse BSDFs: 3.4's Principled diffuse is Disney's (brighter at grazing
# angles than lensray's Lambert: measured mean 6.0%, p90 13%), 4.0's Lambert.
BUILD = """
import sys
sys.path.insert(0, {tests!r})
import bpy, common
sc = common.issue_scene("POINT")
for mat in bpy.data.materials:
    if mat.node_tree is not None:
        nt = mat.node_tree
        p = nt.nodes.get("Principled BSDF")
        d = nt.nodes.new("ShaderNodeBsdfDiffuse")
        d.inputs["Color"].default_value = p.inputs["Base Color"].default_value
        nt.links.new(d.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
sc.lensray.samples = 256
common.setup_cycles(sc, 64)
bpy.ops.wm.save_as_mainfile(filepath={blend!r})
print("BUILT", bpy.app.version_string)
# Principled inputs by the names of the binary's version
import json
from lensray_blender import export
m = bpy.data.materials.new("glass")
m.use_nodes = True
p = m.node_tree.nodes["Principled BSDF"]
(p.inputs.get("Transmission Weight") or p.inputs["Transmission"]).default_value = 1.0
(p.inputs.get("Emission Color") or p.inputs["Emission"]).default_value = (1, 0.5, 0, 1)
p.inputs["Emission Strength"].default_value = 2.0
print("MAT", json.dumps(export.material_dict(m, set(), "")))
"""
# Run in the saved file, as the render is (its meshes as the file holds them).
EXPORT = """
import bpy
assert bpy.ops.lensray.export_scene(directory={export!r}) == {{"FINISHED"}}
"""


def _run(args, tmp_path):
    env = dict(os.environ, BLENDER_USER_SCRIPTS=str(tmp_path / "scripts"),
               PYTHONPATH=os.path.join(common.ROOT, "python"))
    p = subprocess.run([BLENDER, "-b", "--python-use-system-env"] + args, env=env,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0 and "Error" not in p.stdout + p.stderr, p.stdout + p.stderr
    return p.stdout


@pytest.mark.skipif(BLENDER is None, reason="no blender binary on PATH "
                    "(Debian: apt-get install --no-install-recommends blender python3-numpy)")
def test_blender_binary_renders_lensray(tmp_path):
    (tmp_path / "scripts" / "addons").mkdir(parents=True)
    os.symlink(os.path.join(common.ROOT, "blender", "lensray_blender"),
               tmp_path / "scripts" / "addons" / "lensray_blender")
    blend, export = tmp_path / "scene.blend", tmp_path / "export"
    out = _run(["--factory-startup", "--python-expr",
                BUILD.format(tests=common.HERE, blend=str(blend))], tmp_path)
    version = out.split("BUILT ")[1].split()[0]
    mat = json.loads(out.split("MAT ")[1].splitlines()[0])
    assert mat["transmit"] == pytest.approx([0.8] * 3) and mat["emission"] == [2, 1, 0], mat
    _run([str(blend), "--addons", "lensray_blender", "--python-expr",
          EXPORT.format(export=str(export))], tmp_path)
    out = _run([str(blend), "--addons", "lensray_blender", "-E", "LENSRAY",
                "-o", str(tmp_path / "lensray_#"), "-f", "1"], tmp_path)
    assert "Saved:" in out, out
    _run([str(blend), "-E", "CYCLES", "-o", str(tmp_path / "cycles_#"), "-f", "1"], tmp_path)
    subprocess.run([os.path.join(common.ROOT, "build", "lensray"), "render",
                    str(export / "scene.json"), "-o", str(tmp_path / "cli.exr"), "-q"],
                   check=True)
    a, b, cli = (common.load_exr(tmp_path / f)
                 for f in ("lensray_1.exr", "cycles_1.exr", "cli.exr"))
    assert a.shape == (120, 160, 3) and a.mean() > 0.01
    # The frame is the engine's pixels, rows and channels as lensray's
    # own (a flip or a swap moves values by 0.1 and more).  Not asserted
    # bit for bit: in 3 runs of some 15, up to 14 of the 57600 values
    # were 1 to 2 ulp off the CLI's (cause not found; the caller's
    # floating-point mode, lib/util/fp_mode.h, was ruled out).  The bit
    # for bit check of a real lens is test_engine.py's, in one process.
    d = np.abs(a - cli)
    assert d.max() < 1e-6 and np.count_nonzero(d) <= 60, (d.max(), np.count_nonzero(d))
    mean, p90 = common.compare(a, b)
    print(f"blender {version}: LENSRAY against its Cycles: mean {mean:.4%} p90 {p90:.4%}")
    assert mean < 0.03 and p90 < 0.08, (version, mean, p90)
