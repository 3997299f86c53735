#!/bin/sh
# `make test`: the C files against .clang-format (make test-format), then
# the tree's shape (make test-tree: check-layers, check-size), then
# the suite as built, then again under AddressSanitizer and
# UBSan, then a short libFuzzer session of each fuzz target (make fuzz-ci:
# one test per target), then the HTTP API against docs/openapi.yaml (make
# test-api: the spec validator and schemathesis on a live daemon), then the
# Python package's pytest suite (make test-python), then the lenses against
# ray-optics (make test-lenses), then the pixel-hash matrix on every code
# path this CPU runs (make test-isa), then glTF geometry against an independent
# ray caster (make test-gltf-depth), then the Blender add-on under bpy
# against Cycles (make test-blender), then one line "N
# passed, N failed, N skipped" adding them all up (tests/run.sh says which
# skips are allowed; the other steps have none).  Exit status 0 only when
# every run exited 0, which tests/run.sh does not do for a failure or a
# skip without an environment reason.  Usage: tests/all.sh MAKE BUILD_DIR
make=${1:-make}
build=${2:-build}
# Each step's builds (the library as built, under ASan, for libFuzzer)
# compile on every core; the tests themselves are run as each step says.
jobs=$(nproc 2>/dev/null || echo 2)
mkdir -p "$build"
total_pass=0
total_fail=0
total_skip=0
status=0
# The Python virtualenvs (downloads: minutes on a clean machine, mostly
# waiting on the network) are made in the background while the C suites
# run; the first step that uses them waits.  The Debian packages come
# first, so that two makes never run apt-get at once.
$make --no-print-directory deps
{ $make --no-print-directory venvs >"$build/venvs.log" 2>&1; echo $? >"$build/venvs.rc"; } &
venvs=$!
for run in test-format test-tree test-suite test-sanitize fuzz-ci test-api test-python test-lenses \
    test-isa test-gltf-depth test-blender; do
    if [ "$run" = test-api ] && [ -n "$venvs" ]; then
        wait "$venvs"
        venvs=
        # A failure shows here; the steps below then say what they lack.
        [ "$(cat "$build/venvs.rc")" -eq 0 ] || cat "$build/venvs.log"
    fi
    log="$build/$run.log"
    echo "==== $run"
    # The log keeps the last line for the count; the exit status comes
    # through a file, since a pipeline's status is its last command's.
    { $make -j"$jobs" --no-print-directory "$run"; echo $? > "$log.rc"; } 2>&1 | tee "$log"
    rc=$(cat "$log.rc")
    line=$(grep -E '^[0-9]+ passed, [0-9]+ failed' "$log" | tail -n 1)
    if [ -z "$line" ]; then
        echo "all.sh: $run printed no summary (exit status $rc)"
        total_fail=$((total_fail + 1))
        status=1
        continue
    fi
    p=$(echo "$line" | sed 's/^\([0-9]*\) passed.*/\1/')
    f=$(echo "$line" | sed 's/.* \([0-9]*\) failed.*/\1/')
    s=$(echo "$line" | sed -n 's/.* \([0-9]*\) skipped.*/\1/p')
    total_pass=$((total_pass + p))
    total_fail=$((total_fail + f))
    total_skip=$((total_skip + ${s:-0}))
    [ "$rc" -eq 0 ] || status=1
done
echo "$total_pass passed, $total_fail failed, $total_skip skipped"
[ "$status" -eq 0 ] && [ "$total_fail" -eq 0 ]
