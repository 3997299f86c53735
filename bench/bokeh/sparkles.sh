#!/bin/sh
# bench/bokeh/sparkles.sh: sparkles (issue 27; `make bench-sparkles`):
# scenes/sparkles.json, six small lights above the frame seen in a rough
# metal plane (GGX alpha 0.05) far behind the focus, rendered at 160 x 100
# and timed to relMSE 1e-3 (run.py) with the defaults, camera paths only,
# and camera paths with every sample traced; Mitsuba 3's `path` and
# `ptracer` too with `--only mitsuba-path,mitsuba-ptracer` (run.py's).
#
# There is no closed form for a glint, so the reference is lensray's
# defaults with plan and adaptive sampling off at REF_SPP samples (cached
# in BUILD/bench/sparkles/ until the scene or the binary changes), with a
# seed of its own: with the scene's, a run's light paths would be the
# first of the reference's own, and its error would look smaller.  Its
# independent checks: tests/test_light_trace.c's glints against the
# camera alone, and here the camera-only rows, which must keep falling as
# 1/spp towards it (run.py flags one that stalls).
# Usage: sh bench/bokeh/sparkles.sh [BUILD_DIR] [run.py arguments...]
set -u
BUILD=${1:-build}
[ $# -gt 0 ] && shift
OUT=$BUILD/bench
WORK=$OUT/sparkles
SCENE=scenes/sparkles.json
SIZE="--set render.width=160 --set render.height=100"
REF_SPP=${REF_SPP:-8192}
mkdir -p "$WORK"
. bench/mitsuba_env.sh
mitsuba_setup "$OUT/venv" "$OUT/pip.log"
[ "$mitsuba_ok" = 1 ] || { echo "sparkles: numpy (with Mitsuba) is not available"; exit 1; }
mitsuba_llvm
PY=$OUT/venv/bin/python
key=$(cat "$SCENE" "$BUILD/lensray" | sha256sum | cut -c1-16)
ref=$WORK/ref-$key-$REF_SPP-7919
if [ ! -f "$ref.npy" ]; then
    echo "sparkles: rendering the reference ($REF_SPP spp, several CPU minutes, once)" >&2
    # shellcheck disable=SC2086
    "$BUILD/lensray" render "$SCENE" -o "$ref.exr" -q $SIZE \
        --set render.spp=$REF_SPP --set render.plan=false \
        --set render.adaptive=false --set render.seed=7919 || exit 1
    "$PY" - "$ref.exr" "$ref.tmp.npy" <<'PYEOF' || exit 1
import sys
sys.path.insert(0, "tests/lenses")
import numpy as np
from exr import read_exr
ch = read_exr(sys.argv[1])
np.save(sys.argv[2], np.stack([ch["R"], ch["G"], ch["B"]], axis=-1))
PYEOF
    mv "$ref.tmp.npy" "$ref.npy"
fi
# The "discs" run.py reports: the frame's quarters.
printf '%s\n' '[{"box": [0, 80, 0, 50]}, {"box": [80, 160, 0, 50]},' \
    '{"box": [0, 80, 50, 100]}, {"box": [80, 160, 50, 100]}]' > "$WORK/boxes.json"
# The scene at the bench's size, for lensray and Mitsuba alike.
"$PY" -c 'import json, sys
sc = json.load(open(sys.argv[1])); sc["render"].update(width=160, height=100)
json.dump(sc, open(sys.argv[2], "w"))' "$SCENE" "$WORK/scene.json" || exit 1
exec "$PY" bench/bokeh/run.py --lensray "$BUILD/lensray" --scene "$WORK/scene.json" \
    --ref "$ref.npy" --discs "$WORK/boxes.json" --work "$WORK" \
    --only lensray-default,lensray-camera,lensray-full "$@"
