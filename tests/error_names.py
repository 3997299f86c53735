"""The names a library error sentence (on stdin) lists, one a line, sorted.

The library builds two sentences from its registries and key tables:
    camera.model must be one of "pinhole", "thinlens", got "x"
    camera.x: unknown key "x" (expected one of: model, position, fov)
test_camera_model_registry and test_integrator_registry check them
against the registries, so the bats files that compare a hand-written
list (docs/openapi.yaml, docs/scene-format.md, the daemon's options) with
the library read the library's list here.  A sentence with neither form
is an error, not an empty list.
"""

import re
import sys

text = sys.stdin.read()
if " must be one of " in text:
    listed = text.split(" must be one of ", 1)[1].rsplit(", got", 1)[0]
    names = re.findall(r'"([^"]*)"', listed)
elif "(expected one of: " in text:
    names = text.rsplit("(expected one of: ", 1)[1].strip().rstrip(")").split(", ")
else:
    sys.exit("error_names.py: no list of names in: " + text)
print("\n".join(sorted(names)))
