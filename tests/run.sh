#!/bin/sh
# Runs the C unit tests and the bats suites, then prints one line
# "N passed, N failed" that adds them all up.  Exit status 0 only when
# nothing failed.  Usage: tests/run.sh BUILD_DIR
build=${1:-build}
passed=0
failed=0
log=$(mktemp)
trap 'rm -f "$log"' EXIT

# Each C test binary ends with "NAME: N passed, N failed" (the OOM test
# adds ", N skipped": known library bugs, not counted either way).
for prog in unit oom; do
    "$build/tests/$prog" 2>&1 | tee "$log"
    line=$(grep "^$prog: [0-9]* passed, [0-9]* failed" "$log" | tail -n 1)
    if [ -n "$line" ]; then
        p=$(echo "$line" | sed "s/^$prog: \([0-9]*\) passed.*/\1/")
        f=$(echo "$line" | sed 's/.* \([0-9]*\) failed.*/\1/')
        passed=$((passed + p))
        failed=$((failed + f))
    else
        echo "run.sh: the $prog test binary crashed or printed no summary"
        failed=$((failed + 1))
    fi
done

for suite in tests/*.bats; do
    [ -e "$suite" ] || continue
    LENSRAY_BUILD="$build" bats --tap "$suite" 2>&1 | tee "$log"
    ok=$(grep -c '^ok ' "$log")
    bad=$(grep -c '^not ok ' "$log")
    plan=$(sed -n 's/^1\.\.\([0-9]*\)$/\1/p' "$log" | head -n 1)
    passed=$((passed + ok))
    failed=$((failed + bad))
    # A suite that dies part-way counts its unreported tests as failed.
    if [ -n "$plan" ] && [ $((ok + bad)) -lt "$plan" ]; then
        failed=$((failed + plan - ok - bad))
    fi
    [ -n "$plan" ] || failed=$((failed + 1))
done

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
