#!/usr/bin/env bats
# install.bats: `make install` into a DESTDIR, and what a user of the
# installed files gets: the programs with the shipped lenses, and
# lensray.pc, with which a program links against the installed library,
# shared or static.  The build must be current (tests/run.sh builds it
# first), so make only copies files.
#
#     LENSRAY_BUILD=build bats tests/install.bats

bats_require_minimum_version 1.5.0

setup_file() {
    REPO="$(cd "$BATS_TEST_DIRNAME/.." && pwd)"
    export REPO ROOT="$BATS_FILE_TMPDIR/root"
    make --no-print-directory -C "$REPO" install BUILD="${LENSRAY_BUILD:-build}" \
        DESTDIR="$ROOT" PREFIX=/usr/local >"$BATS_FILE_TMPDIR/make.log" 2>&1 ||
        { cat "$BATS_FILE_TMPDIR/make.log" >&2; return 1; }
}

# pc ARGS...: pkg-config on the installed lensray.pc, its prefix moved
# under DESTDIR.
pc() {
    PKG_CONFIG_PATH="$ROOT/usr/local/lib/pkgconfig" pkg-config --define-prefix "$@" lensray
}

@test "make install puts the shipped lenses where an installed lensray finds them" {
    # Only the header, libraries and programs were installed, so on a
    # machine without the source tree (docs/deploy.md's systemd unit)
    # "lens": "double-gauss-50" and GET /v1/lenses found nothing.
    local dir="$ROOT/usr/local/share/lensray/lenses" f
    for f in "$REPO"/lenses/*.json; do
        cmp "$f" "$dir/$(basename "$f")"
    done
    # The installed program reads them from there, by name.
    LENSRAY_LENS_DIR="$dir" LD_LIBRARY_PATH="$ROOT/usr/local/lib" \
        run -0 "$ROOT/usr/local/bin/lensray" lens double-gauss-50
    [[ "$output" == *'"efl_mm":50.00'* ]]
}

@test "make install with another PREFIX than the build's compiles the lens directory in again" {
    # rx_file.o kept the first build's /usr/local/share/lensray/lenses, so
    # `make` then `make install PREFIX=X` installed a library that could
    # not find the lenses it had installed in X.  (make -n: nothing is
    # rebuilt; the directories' file is put back as it was.)
    local b="${LENSRAY_BUILD:-build}" f
    case "$b" in /*) ;; *) b="$REPO/$b" ;; esac
    f="$b/gen/lens-dirs"
    cp -p "$f" "$BATS_TEST_TMPDIR/lens-dirs"
    run -0 make --no-print-directory -n -C "$REPO" install BUILD="$b" \
        DESTDIR="$BATS_TEST_TMPDIR/x" PREFIX=/opt/elsewhere
    cp -p "$BATS_TEST_TMPDIR/lens-dirs" "$f"
    [[ "$output" == *"rx_file.o"* ]]
    [[ "$output" == *"/opt/elsewhere/share/lensray/lenses"* ]]
    run -0 make --no-print-directory -n -C "$REPO" install BUILD="$b" \
        DESTDIR="$BATS_TEST_TMPDIR/x" PREFIX=/usr/local
    cp -p "$BATS_TEST_TMPDIR/lens-dirs" "$f"
    [[ "$output" != *"rx_file.o"* ]]
}

@test "the installed shared library exports the header's functions alone" {
    # GCC's target_clones functions (lr__rx_trace16f and 13 more, with
    # their .resolver symbols) were exported despite -fvisibility=hidden.
    run -0 nm -D --defined-only "$ROOT/usr/local/lib/liblensray.so.0"
    local extra
    extra=$(printf '%s\n' "$output" | awk '$3 !~ /^lr_[a-z]/ { print $3 }')
    [ -z "$extra" ]
    [ "$(printf '%s\n' "$output" | grep -c ' lr_[a-z]')" -ge 60 ]
}

@test "lensray.pc links a program against the installed library, shared and static" {
    # Its Libs.private was written by hand and lacked -ljpeg and
    # -ldeflate, so the static library did not link with it.
    cat >"$BATS_TEST_TMPDIR/v.c" <<'EOF'
#include <lensray.h>
#include <stdio.h>
int main(void)
{
    lr_scene *s;
    lr_error err;
    if (lr_scene_load_json("{}", 2, NULL, NULL, 0, &s, &err) != LR_OK)
        return 1;
    lr_scene_free(s);
    printf("%s\n", lr_version());
    return 0;
}
EOF
    local c="$BATS_TEST_TMPDIR/v.c" want san=""
    want=$(sed -n 's/^VERSION *:= *//p' "$REPO/Makefile")
    # The sanitizer build's library needs its runtime in the program too.
    if nm "$ROOT/usr/local/lib/liblensray.a" 2>/dev/null | grep -q __asan_; then
        san="-fsanitize=address,undefined"
    fi
    # shellcheck disable=SC2046
    cc $san "$c" $(pc --cflags --libs) -o "$BATS_TEST_TMPDIR/shared"
    LD_LIBRARY_PATH="$ROOT/usr/local/lib" run -0 "$BATS_TEST_TMPDIR/shared"
    [ "$output" = "$want" ]
    # The archive by name, its dependencies from Libs.private.
    # shellcheck disable=SC2046
    cc $san "$c" $(pc --cflags --libs --static | sed 's/-llensray/-l:liblensray.a/') \
        -o "$BATS_TEST_TMPDIR/static"
    run -0 "$BATS_TEST_TMPDIR/static"
    [ "$output" = "$want" ]
    ! ldd "$BATS_TEST_TMPDIR/static" | grep -q liblensray
}
