#!/bin/sh
# Runs the libFuzzer targets built by `make fuzz-build`, one after the
# other, each for SECONDS.  Usage:
#
#   fuzz/run.sh explore FUZZ_BUILD SECONDS TARGET...   (make fuzz)
#   fuzz/run.sh ci      FUZZ_BUILD SECONDS TARGET...   (make fuzz-ci, make test)
#
# explore: the corpus grows in FUZZ_BUILD/corpus/TARGET from run to run
# and the first crash stops the run.
#
# ci: every target starts from fuzz/seeds/TARGET and tests/corpus/TARGET
# only (new inputs go to FUZZ_BUILD/ci/corpus/TARGET, emptied first) with
# a fixed seed, so that a run does not depend on earlier ones; each
# target is run even when an earlier one failed, its output goes to
# FUZZ_BUILD/ci/TARGET.log, and one line per target and a last line
# "N passed, N failed" say how it went.
#
# Either way a crash (or a leak, a timeout, a broken promise of
# fuzz/fuzz_*.c) makes the exit status non-zero and prints where the
# input was saved, with the input in base64 when it is small, so that a
# CI log is enough to reproduce it.  FUZZ_OPTS adds libFuzzer options.
mode=$1
build=$2
seconds=$3
shift 3
case $mode in explore | ci) ;; *)
    echo "usage: fuzz/run.sh explore|ci FUZZ_BUILD SECONDS TARGET..." >&2
    exit 2 ;;
esac

passed=0
failed=0
for t in "$@"; do
    if [ "$mode" = ci ]; then
        corpus=$build/ci/corpus/$t
        crashes=$build/ci/crashes/$t
        log=$build/ci/$t.log
        rm -rf "$corpus" "$crashes"
        seed=-seed=1
    else
        corpus=$build/corpus/$t
        crashes=$build/crashes/$t
        log=$build/$t.log
        seed=
    fi
    mkdir -p "$corpus" "$crashes"
    echo "fuzz: $t for $seconds s (log: $log)"
    start=$(date +%s)
    # shellcheck disable=SC2086 # FUZZ_OPTS and seed are lists of options
    LSAN_OPTIONS=suppressions=fuzz/lsan.supp \
        "$build/fuzz_$t" -max_total_time="$seconds" $seed $FUZZ_OPTS \
        -print_final_stats=1 \
        -dict="fuzz/$t.dict" -artifact_prefix="$crashes/" \
        "$corpus" "fuzz/seeds/$t" "tests/corpus/$t" >"$log" 2>&1
    rc=$?
    took=$(($(date +%s) - start))
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    cov=$(sed -n 's/^#[0-9]*[[:space:]]*DONE[[:space:]]*cov: \([0-9]*\).*/\1/p' "$log")
    # A target that did not run at all (missing binary, bad option) has
    # no statistics: that is a failure too, not a pass.
    if [ "$rc" -eq 0 ] && [ -n "$runs" ] && [ "$runs" -gt 0 ]; then
        echo "fuzz: $t: ok, $runs inputs in $took s (coverage $cov," \
            "corpus $(ls "$corpus" | wc -l) new inputs)"
        passed=$((passed + 1))
        continue
    fi
    failed=$((failed + 1))
    echo "fuzz: $t: FAILED (exit status $rc after ${runs:-0} inputs in" \
        "$took s); from $log:"
    # The report: from the target's own message or the sanitizer's first
    # line on (the end of the log when there is neither).
    report=$(sed -n '/^fuzz: \|==[0-9]*==\|runtime error\|ERROR: libFuzzer/,$p' \
        "$log" | head -n 80)
    [ -n "$report" ] || report=$(tail -n 40 "$log")
    echo "$report" | sed 's/^/    /'
    found=0
    for f in "$crashes"/*; do
        [ -f "$f" ] || continue
        found=1
        echo "fuzz: $t: the input is $f ($(wc -c <"$f") bytes);" \
            "replay it with $build/fuzz_$t $f"
        if [ "$(wc -c <"$f")" -gt 0 ] && [ "$(wc -c <"$f")" -le 4096 ]; then
            echo "fuzz: $t: the input in base64 (base64 -d > input):"
            base64 "$f" | sed 's/^/    /'
        fi
    done
    [ "$found" = 1 ] || echo "fuzz: $t: no input was saved (see the log)"
    echo "fuzz: $t: once fixed, copy the input into tests/corpus/$t/ so" \
        "that make test replays it"
    [ "$mode" = explore ] && exit 1
done
if [ "$mode" = ci ]; then
    echo "$passed passed, $failed failed"
fi
[ "$failed" -eq 0 ]
