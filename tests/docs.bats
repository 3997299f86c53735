#!/usr/bin/env bats
# docs.bats: what the documentation names exists.  The README and docs/*.md
# cite cmocka tests by function name, unit groups to run alone, the fuzz
# targets and the fuzzing time of `make test`; a rename or a new target
# leaves the prose behind without any other test noticing.  Each check
# reads the prose and looks the name up in the sources (or asks the unit
# runner), never in the prose itself.
#
# Run from the repository root, by tests/run.sh or directly:
#     LENSRAY_BUILD=build bats tests/docs.bats

bats_require_minimum_version 1.5.0

setup() {
    REPO="$(cd "$BATS_TEST_DIRNAME/.." && pwd)"
    local build="${LENSRAY_BUILD:-build}"
    case "$build" in
    /*) ;;
    *) build="$REPO/$build" ;;
    esac
    UNIT="$build/tests/unit"
    DOCS=("$REPO/README.md" "$REPO"/docs/*.md)
}

@test "every test function the docs cite is defined in tests/" {
    local missing="" t
    for t in $(grep -oh '`test_[a-z0-9_]*`' "${DOCS[@]}" | tr -d '`' | sort -u); do
        grep -rqw "$t" "$REPO/tests" "$REPO/python/tests" "$REPO/blender/tests" ||
            missing="$missing $t"
    done
    [ -z "$missing" ] || { echo "cited but not defined:$missing" >&2; return 1; }
}

@test "every unit group the docs tell you to run exists" {
    [ -x "$UNIT" ] || { echo "$UNIT not built (make build/tests/unit)" >&2; return 1; }
    local groups missing="" g
    groups=$("$UNIT" --list | cut -d' ' -f1)
    [ -n "$groups" ]
    for g in $(grep -oh 'build/tests/unit [a-z0-9_ ]*' "${DOCS[@]}" |
               cut -d' ' -f2- | tr ' ' '\n' | sort -u); do
        grep -qx "$g" <<<"$groups" || missing="$missing $g"
    done
    [ -z "$missing" ] || { echo "no such unit group:$missing" >&2; return 1; }
}

@test "reliability.md's fuzz table has a row for every fuzz target, and the time make test gives each" {
    local doc="$REPO/docs/reliability.md" f missing=""
    for f in "$REPO"/fuzz/fuzz_*.c; do
        case "$f" in */fuzz_common.c) continue ;; esac
        grep -q "^| \`fuzz/$(basename "$f")\` |" "$doc" || missing="$missing $(basename "$f")"
    done
    [ -z "$missing" ] || { echo "fuzz targets without a row:$missing" >&2; return 1; }
    # The seconds a target in make test, as the Makefile sets them.
    local secs
    secs=$(sed -n 's/^FUZZ_CI_SECONDS *?= *\([0-9]*\)$/\1/p' "$REPO/Makefile")
    [ -n "$secs" ]
    run grep -ohE '[0-9]+ s (per fuzzer|a target in `make test`|of each fuzzer)' \
        "${DOCS[@]}"
    [ "${#lines[@]}" -gt 0 ]
    local l
    for l in "${lines[@]}"; do
        [ "${l%% *}" = "$secs" ] || { echo "docs say '$l', the Makefile $secs s" >&2; return 1; }
    done
}
