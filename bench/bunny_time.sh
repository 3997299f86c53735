#!/bin/sh
# bench/bunny_time.sh: `make bench-bunny`: time to relMSE 1e-5 on the bench
# scene, lensray against Mitsuba 3's samplers (bunny_time.py, which caches
# its references in BUILD/bench/bunny-time/).
# Usage: sh bench/bunny_time.sh [BUILD_DIR] [bunny_time.py arguments...]
set -u
BUILD=${1:-build}
[ $# -gt 0 ] && shift
OUT=$BUILD/bench
mkdir -p "$OUT"
[ -f scenes/meshes/bunny.obj ] || make scenes/meshes/bunny.obj || exit 1
. bench/mitsuba_env.sh
mitsuba_setup "$OUT/venv" "$OUT/pip.log"
[ "$mitsuba_ok" = 1 ] || { echo "bunny: Mitsuba (and with it numpy) is not available"; exit 1; }
mitsuba_llvm
[ -n "$DRJIT_LIBLLVM_PATH" ] || set -- --mi-variants scalar_rgb "$@"
exec "$OUT/venv/bin/python" bench/bunny_time.py --lensray "$BUILD/lensray" \
    --work "$OUT/bunny-time" "$@"
