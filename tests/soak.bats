#!/usr/bin/env bats
# soak.bats: the short soak and abuse run of lensrayd (tests/soak/soak.sh)
# for SOAK_SECONDS (default 20) of load, then one test per check of its
# summary.  `make soak` runs the long version (docs/reliability.md).
#
#     LENSRAY_BUILD=build bats tests/soak.bats
#
# The script starts its own daemon on a free loopback port and kills it,
# by pid, whatever happens; its summary and logs are left in
# $LENSRAY_BUILD/soak/.

setup_file() {
    REPO="$(cd "$BATS_TEST_DIRNAME/.." && pwd)"
    local build="${LENSRAY_BUILD:-build}"
    case "$build" in
    /*) ;;
    *) build="$REPO/$build" ;;
    esac
    export SOAK_OUT="$build/soak"
    export SUMMARY="$SOAK_OUT/summary.txt"
    # fd 3 is bats' own channel: nothing the soak starts may keep it.
    bash "$REPO/tests/soak/soak.sh" "${SOAK_SECONDS:-20}" "$build" \
        >"$BATS_FILE_TMPDIR/soak.out" 2>&1 3>&- || true
}

# check TEXT: the summary's check line that starts with TEXT passed; on
# failure shows the summary.  A check the soak skipped (only the RSS check,
# under AddressSanitizer) skips the test, as an environment skip that
# tests/run.sh reports apart from the passes.
check() {
    if [ ! -s "$SUMMARY" ]; then
        echo "the soak wrote no summary; its output:" >&2
        cat "$BATS_FILE_TMPDIR/soak.out" >&2
        return 1
    fi
    local skipped
    skipped=$(grep -E "^  SKIP  $1" "$SUMMARY" | head -n 1 | sed 's/^  SKIP  //')
    if [ -n "$skipped" ]; then
        skip "environment: $skipped"
    fi
    if ! grep -Eq "^  PASS  $1" "$SUMMARY"; then
        cat "$SUMMARY" >&2
        [ -s "$SOAK_OUT/unexpected.log" ] && head -n 20 "$SOAK_OUT/unexpected.log" >&2
        return 1
    fi
}

@test "soak: the daemon serves the whole load and answers requests" {
    check "the daemon ran through the load"
    check "requests were answered"
}

@test "soak: every status is documented for its request" {
    check "every status is one documented"
}

@test "soak: no 5xx, except 503 during the shutdown" {
    check "no 5xx before the shutdown"
    check "no 5xx but 503 during the shutdown"
}

@test "soak: no connection failures under load" {
    check "no connection failures before the shutdown"
}

@test "soak: RSS does not grow over the load" {
    check "RSS (does not grow|growth)"
}

@test "soak: threads and descriptors come back to the start" {
    check "threads back near the start"
    check "descriptors back near the start"
}

@test "soak: /healthz is ok after the load" {
    check "/healthz 200 ok after the load"
}

@test "soak: SIGTERM with requests in flight exits 0" {
    check "exit status 0 after SIGTERM"
    check "the daemon logged its clean stop"
}

@test "soak: the summary says PASS" {
    grep -q '^soak: PASS$' "$SUMMARY" || { cat "$SUMMARY" >&2; return 1; }
}
