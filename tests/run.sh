#!/bin/sh
# Runs the C unit tests and the bats suites, then prints one line
# "N passed, N failed, N skipped" that adds them all up.  A skipped test
# is counted as skipped, never as passed.  Usage: tests/run.sh BUILD_DIR
#
# Skips.  A test may skip only because of its environment (a device or a
# command the machine lacks, running as root), and must say so:
#   - C tests call lr_test_skip_env("reason") (tests/test.h), which prints
#     "SKIP (environment): reason"; cmocka's bare skip() does not compile
#     there.  tests/oom never skips: a known bug's test fails.
#   - bats tests call skip "environment: reason".
# A test for a bug never skips: it fails while the bug is there.  Any
# other skip (a bats skip without the "environment: " reason) is listed
# below the summary and makes the exit status non-zero, so that
# `make test-suite` and `make test` fail on it.
#
# Exit status 0 only when nothing failed and every skip was an
# environment skip.
build=${1:-build}
passed=0
failed=0
skipped=0
unexplained=0
log=$(mktemp)
notes=$(mktemp)
# The C test binaries run in the background, one after the other, while
# the bats suites run here, so that both cores are busy (most tests use
# one).  Their output is shown after the suites'.
clog=$(mktemp -d)
trap 'rm -f "$log" "$notes"; rm -rf "$clog"' EXIT
(
    for prog in unit oom; do
        "$build/tests/$prog" >"$clog/$prog.log" 2>&1
    done
) &
cpid=$!

for suite in tests/*.bats; do
    [ -e "$suite" ] || continue
    LENSRAY_BUILD="$build" bats --tap "$suite" 2>&1 | tee "$log"
    # TAP: "ok N name", "not ok N name", "ok N name # skip [reason]".
    all_ok=$(grep -c '^ok ' "$log")
    skips=$(grep -c '^ok .* # skip' "$log")
    env_skips=$(grep -c '^ok .* # skip environment: ' "$log")
    bad=$(grep -c '^not ok ' "$log")
    plan=$(sed -n 's/^1\.\.\([0-9]*\)$/\1/p' "$log" | head -n 1)
    passed=$((passed + all_ok - skips))
    failed=$((failed + bad))
    skipped=$((skipped + skips))
    unexplained=$((unexplained + skips - env_skips))
    grep '^ok .* # skip' "$log" | sed "s|^|$suite: |" >>"$notes"
    # A suite that dies part-way counts its unreported tests as failed.
    if [ -n "$plan" ] && [ $((all_ok + bad)) -lt "$plan" ]; then
        failed=$((failed + plan - all_ok - bad))
    fi
    [ -n "$plan" ] || failed=$((failed + 1))
done

# Each C test binary ends with "NAME: N passed, N failed, N skipped".
wait "$cpid"
for prog in unit oom; do
    cat "$clog/$prog.log"
    line=$(grep "^$prog: [0-9]* passed, [0-9]* failed" "$clog/$prog.log" | tail -n 1)
    if [ -n "$line" ]; then
        p=$(echo "$line" | sed "s/^$prog: \([0-9]*\) passed.*/\1/")
        f=$(echo "$line" | sed 's/.* \([0-9]*\) failed.*/\1/')
        s=$(echo "$line" | sed -n 's/.* \([0-9]*\) skipped.*/\1/p')
        passed=$((passed + p))
        failed=$((failed + f))
        skipped=$((skipped + ${s:-0}))
        grep '^SKIP (environment): ' "$clog/$prog.log" | sed "s/^/$prog: /" >>"$notes"
    else
        echo "run.sh: the $prog test binary crashed or printed no summary"
        failed=$((failed + 1))
    fi
done

if [ -s "$notes" ]; then
    echo "skipped:"
    sed 's/^/  /' "$notes"
fi
if [ "$unexplained" -gt 0 ]; then
    echo "run.sh: $unexplained skip(s) give no \"environment: \" reason" \
        "(listed above); a test for a bug must fail, not skip"
fi
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ] && [ "$unexplained" -eq 0 ]
