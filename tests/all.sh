#!/bin/sh
# `make test`: the suite as built, then again under AddressSanitizer and
# UBSan, then a short libFuzzer session of each fuzz target (make fuzz-ci:
# one test per target), then the Python package's pytest suite (make
# test-python), then one line "N passed, N failed" adding all four up.
# Exit status 0 only when every run passed.  Usage: tests/all.sh MAKE
# BUILD_DIR
make=${1:-make}
build=${2:-build}
mkdir -p "$build"
total_pass=0
total_fail=0
status=0
for run in test-suite test-sanitize fuzz-ci test-python; do
    log="$build/$run.log"
    echo "==== $run"
    # The log keeps the last line for the count; the exit status comes
    # through a file, since a pipeline's status is its last command's.
    { $make --no-print-directory "$run"; echo $? > "$log.rc"; } 2>&1 | tee "$log"
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
    total_pass=$((total_pass + p))
    total_fail=$((total_fail + f))
    [ "$rc" -eq 0 ] || status=1
done
echo "$total_pass passed, $total_fail failed"
[ "$status" -eq 0 ] && [ "$total_fail" -eq 0 ]
