#!/usr/bin/env bats
# docs.bats: what the documentation names exists.  The README and docs/*.md
# cite source files by path or name, cmocka tests by function name, unit
# groups to run alone, the fuzz
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
    LENSRAY="$build/lensray"
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

@test "every source file the docs name exists" {
    # `dir/file.c` must be that file; a bare `file.c` some tracked file of
    # that name; a pattern (`lib/camera/camera_<name>.c`, `tests/corpus/
    # NAME`) its folder.  A file moved without its docs fails here.
    local missing="" f base
    local names
    # The tracked files' names (every file's outside a git checkout).
    names=$({ git -C "$REPO" ls-files 2>/dev/null ||
        find "$REPO" -path "$REPO/build" -prune -o -type f -print; } |
        sed 's|.*/||' | sort -u)
    for f in $(grep -ohE '`[A-Za-z0-9_./<>-]+\.(c|h|py|sh|bats|js|yaml)`|`(lib|tools|service|tests|fuzz|bench|python|blender|farm|include)/[A-Za-z0-9_./<>-]+`' \
               "${DOCS[@]}" | tr -d '`' | sort -u); do
        case "$f" in
        /*) ;; # a URL path (/ui/page.js), not a file
        *'<'* | *NAME*)
            base=${f%%[<N]*}
            [ -d "$REPO/${base%/*}" ] || missing="$missing $f"
            ;;
        */*) [ -e "$REPO/$f" ] || missing="$missing $f" ;;
        *)
            base=${f##*/}
            grep -qxF "$base" <<<"$names" || missing="$missing $f"
            ;;
        esac
    done
    [ -z "$missing" ] || { echo "named but not in the tree:$missing" >&2; return 1; }
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

# library_names SET: the names the library's error lists for the
# override SET (tests/error_names.py): the registry's camera models or
# integrators, or the keys an object takes.
library_names() {
    local out
    out=$("$LENSRAY" render "$REPO/tests/data/tiny.json" --set "$1" \
        -o "$BATS_TEST_TMPDIR/x.png" 2>&1) && return 1
    python3 "$BATS_TEST_DIRNAME/error_names.py" <<<"$out"
}

# doc_names DOC SECTION WHAT: names that the section of DOC (a heading
# prefix, up to the next heading of its level) lists by hand, one a line,
# sorted.  WHAT: "row KEY N" the quoted or backquoted names in cell N
# (from 1) of the table row of `KEY`; "bullets" the `"NAME"` that open its bullets;
# "columns TITLE" the `"NAME"` column titles of the first table from the
# text TITLE on; "keys TITLE" the `key`s of that table's first column.
doc_names() {
    python3 - "$@" <<'PY'
import re, sys
doc, section, what = sys.argv[1], sys.argv[2], sys.argv[3:]
text = open(doc).read()
start = text.index("\n" + section) + 1
level = section.split(" ")[0]
end = text.find("\n" + level + " ", start + 1)
sec = text[start:end if end >= 0 else len(text)]
def table(title):
    blocks = sec[sec.index(title):].split("\n\n")
    return [b for b in blocks if b.startswith("|")][0].splitlines()
if what[0] == "row":
    row = [l for l in sec.splitlines() if l.startswith("| `%s` |" % what[1])][0]
    names = re.findall(r'[`"]+([a-z]+)[`"]+', row.split("|")[int(what[2])])
elif what[0] == "bullets":
    names = re.findall(r'^\* `"([a-z]+)"`', sec, re.M)
elif what[0] == "columns":
    names = re.findall(r'`"([a-z]+)"`', table(what[1])[0])
else:
    names = [k for l in table(what[1])[2:] for k in re.findall(r"`([a-z_.]+)`", l.split("|")[1])]
print("\n".join(sorted(names)))
PY
}

@test "scene-format.md and reliability.md list the library's camera models, camera keys and integrators" {
    [ -x "$LENSRAY" ] || { echo "$LENSRAY not built (make)" >&2; return 1; }
    local sf="$REPO/docs/scene-format.md" models
    models=$(library_names camera.model=nope)
    [ "$(wc -l <<<"$models")" -ge 4 ]
    # The models: the model key's row, the bullets that open section 6,
    # and the columns of "Which keys matter for which model".
    diff <(doc_names "$sf" '## 6.' row model 4) - <<<"$models"
    diff <(doc_names "$sf" '## 6.' bullets) - <<<"$models"
    diff <(doc_names "$sf" '## 6.' columns '### Which keys matter') - <<<"$models"
    # Every key a camera takes has its row in that table (model aside),
    # and every key of the chromatic table is one chromatic takes.
    diff <(doc_names "$sf" '## 6.' keys '### Which keys matter') \
        <(library_names camera.no_such_key=1 | grep -vx model)
    diff <(doc_names "$sf" '### `chromatic`' keys '') \
        <(library_names 'camera.chromatic={"no_such_key": 1}')
    # The render keys, and the integrators in both places that list them.
    diff <(doc_names "$sf" '## 7.' keys '') <(library_names render.no_such_key=1)
    diff <(doc_names "$sf" '## 7.' row integrator 4) <(library_names render.integrator=nope)
    diff <(doc_names "$REPO/docs/reliability.md" '## Limits' row render.integrator 2) \
        <(library_names render.integrator=nope)
    # Section 15's example of an unknown key is the message as printed
    # (it lacked the keys added since).
    printf '{"camera": {"fvo": 30}}' >"$BATS_TEST_TMPDIR/fvo.json"
    run -3 "$LENSRAY" render "$BATS_TEST_TMPDIR/fvo.json" -o "$BATS_TEST_TMPDIR/x.png"
    grep -qxF "${output#lensray: }" "$sf"
}
