#!/bin/sh
# bench/path/run.sh: the path integrator against Mitsuba 3 (`make
# compare-path`): compare.py (the pictures; exit 1 if a target is missed),
# or with "speed" as the second argument speed.py (the bench section).
# Usage: sh bench/path/run.sh [BUILD_DIR] [compare|speed]
set -u
BUILD=${1:-build}
WHAT=${2:-compare}
OUT=$BUILD/bench
mkdir -p "$OUT"
. bench/mitsuba_env.sh
mitsuba_setup "$OUT/venv" "$OUT/pip.log"
[ "$mitsuba_ok" = 1 ] || { echo "path: Mitsuba is not available"; exit 1; }
if [ "$WHAT" = speed ]; then
    mitsuba_llvm
    [ -n "$DRJIT_LIBLLVM_PATH" ] || { echo "PATHSPEED_UNAVAILABLE no libLLVM >= 16 (apt-get install libllvm19)"; exit 1; }
    exec "$OUT/venv/bin/python" bench/path/speed.py --lensray "$BUILD/lensray" --out "$OUT/path"
fi
exec "$OUT/venv/bin/python" bench/path/compare.py --lensray "$BUILD/lensray" \
    --out "$BUILD/path-compare" ${PATH_COMPARE_ARGS:-}
