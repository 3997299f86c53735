#!/usr/bin/env python3
"""gltf_depth_suite.py: `make test-gltf-depth`.  Writes scenes of
tests/gltf_writer.py (as .gltf with a data: URI and as .glb) and checks
lensray's Z channel of each against the independent ray caster of
tests/gltf_depth_check.py: node hierarchies (TRS and column-major
matrices, two scenes, a node in none, huge and tiny scales, mirroring),
accessor layouts (interleaved, byte indices, strips and fans without
indices), sparse accessors, morph targets, skins, and the glTF camera
(yfov, aspect ratio, a rotated and scaled parent).  Nothing is
downloaded.  Ends with "N passed, N failed".

    python3 tests/gltf_depth_suite.py LENSRAY
"""
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gltf_depth_check  # noqa: E402
import gltf_writer  # noqa: E402

# (scene, camera): None for the file's own camera, "auto" for the
# caster's view of the whole file.
CASES = [("tri", "auto"), ("normals", "auto"), ("materials", "auto"),
         ("textured", "auto"), ("camera-floor", None), ("gallery", None),
         ("gallery", "auto"), ("orient", None), ("orient", "auto"),
         ("two-scenes", "auto"), ("huge", "auto"), ("tiny", "auto"),
         ("layouts", "auto"), ("sparse", "auto"), ("morph", "auto"),
         ("skin", "auto")]


def main():
    lensray = sys.argv[1]
    passed = failed = 0
    with tempfile.TemporaryDirectory(prefix="gltfdepth") as tmp:
        for name, cam in CASES:
            for ext in ("gltf", "glb"):
                path = os.path.join(tmp, "%s.%s" % (name, ext))
                if not os.path.exists(path):
                    gltf_writer.SCENES[name]().write(path)
                r = gltf_depth_check.check(lensray, path, camera=cam)
                ok = r["ok"]
                passed += ok
                failed += not ok
                print("%s %s.%s camera %s: %s" % (
                    "ok  " if ok else "FAIL", name, ext, cam or "glTF",
                    r.get("why") or "%d pixels, max %.2g, median %.2g, "
                    "%d hit/miss apart" % (r["pixels"], r["max_rel"],
                                           r["median_rel"],
                                           r["hit_miss_disagree"])))
    print("%d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
