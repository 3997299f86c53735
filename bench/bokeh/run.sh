#!/bin/sh
# bench/bokeh/run.sh: night lights through the thin lens (issue 27; `make
# bench-bokeh`): the exact reference of scenes/night.json (reference.py,
# cached in BUILD/bench/bokeh/ until the scene or the script changes), then
# lensray and Mitsuba 3 timed to relMSE 1e-3 against it (run.py).
# Usage: sh bench/bokeh/run.sh [BUILD_DIR] [run.py arguments...]
set -u
BUILD=${1:-build}
[ $# -gt 0 ] && shift
OUT=$BUILD/bench
WORK=$OUT/bokeh
SCENE=scenes/night.json
mkdir -p "$WORK"
. bench/mitsuba_env.sh
mitsuba_setup "$OUT/venv" "$OUT/pip.log"
[ "$mitsuba_ok" = 1 ] || { echo "bokeh: Mitsuba (and with it numpy) is not available"; exit 1; }
mitsuba_llvm
PY=$OUT/venv/bin/python
# The reference is keyed by the scene's and the script's contents.
key=$(cat "$SCENE" bench/bokeh/reference.py | sha256sum | cut -c1-16)
if [ ! -f "$WORK/ref-$key.npy" ] || [ ! -f "$WORK/discs-$key.json" ]; then
    echo "bokeh: computing the exact reference of $SCENE (a few minutes, once)" >&2
    "$PY" bench/bokeh/reference.py "$SCENE" --out "$WORK/ref-$key.npy.tmp.npy" \
        --exr "$WORK/ref.exr" --discs "$WORK/discs-$key.json" || exit 1
    mv "$WORK/ref-$key.npy.tmp.npy" "$WORK/ref-$key.npy"
fi
exec "$PY" bench/bokeh/run.py --lensray "$BUILD/lensray" --scene "$SCENE" \
    --ref "$WORK/ref-$key.npy" --discs "$WORK/discs-$key.json" --work "$WORK" "$@"
