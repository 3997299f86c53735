#!/usr/bin/env bats
# cli.bats: the lensray command-line tool, end to end: exit codes, error
# messages that name the JSON path, output files (PNG/EXR headers, sizes,
# atomic replacement), glTF files alone, --set overrides (including the lens models, samplers
# and regions), --stats and determinism.
#
# Run from the repository root, by tests/run.sh or directly:
#     LENSRAY_BUILD=build bats tests/cli.bats
# LENSRAY_BUILD is the build directory (default: build); a relative one is
# taken relative to the repository root.  Every scene is tiny (16x12, a few
# samples), so the whole file runs in a few seconds.  No network is used.

bats_require_minimum_version 1.5.0

setup() {
    REPO="$(cd "$BATS_TEST_DIRNAME/.." && pwd)"
    local build="${LENSRAY_BUILD:-build}"
    case "$build" in
    /*) ;;
    *) build="$REPO/$build" ;;
    esac
    LENSRAY="$build/lensray"
    if [ ! -x "$LENSRAY" ]; then
        echo "lensray binary not found at $LENSRAY (run make first)" >&2
        return 1
    fi

    T="$BATS_TEST_TMPDIR"

    # The scene most tests use: a red sphere on a finite floor, lit by a
    # point light and a little ambient light.
    cat >"$T/scene.json" <<'EOF'
{
  "description": "cli.bats test scene",
  "camera": { "model": "pinhole", "position": [0, 1, 5], "look_at": [0, 0.5, 0],
              "up": [0, 1, 0], "fov": 40 },
  "render": { "width": 16, "height": 12, "spp": 2, "max_depth": 2 },
  "background": [0.2, 0.3, 0.4],
  "materials": {
    "red":    { "diffuse": [0.7, 0.1, 0.1], "specular": 0.2, "shininess": 30 },
    "ground": { "diffuse": 0.5, "reflect": 0.2 }
  },
  "lights": [
    { "type": "point", "position": [3, 5, 4], "intensity": 80 },
    { "type": "ambient", "radiance": 0.05 }
  ],
  "objects": [
    { "type": "sphere", "center": [0, 1, 0], "radius": 1, "material": "red" },
    { "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "size": 6,
      "material": "ground" }
  ]
}
EOF
}

# ---- helpers ----------------------------------------------------------------

# Writes $T/NAME.json with the given JSON text.
scene() {
    printf '%s\n' "$2" >"$T/$1.json"
}

# Prints the bytes at OFFSET..OFFSET+COUNT-1 of FILE as one hex string.
hex_bytes() {
    od -An -v -tx1 -j "$2" -N "$3" "$1" | tr -d ' \n'
}

# Prints "WIDTH HEIGHT" from a PNG's IHDR chunk; fails if FILE is not a PNG.
png_size() {
    [ "$(hex_bytes "$1" 0 8)" = 89504e470d0a1a0a ] || return 1
    [ "$(hex_bytes "$1" 12 4)" = 49484452 ] || return 1 # "IHDR"
    local b
    b="$(hex_bytes "$1" 16 8)"
    echo "$((16#${b:0:8})) $((16#${b:8:8}))"
}

# True if DIR contains a leftover temporary file of an atomic write.
has_temp_files() {
    local f
    for f in "$1"/*.tmp.* "$1"/.*.tmp.*; do
        [ -e "$f" ] && return 0
    done
    return 1
}

# ---- help, version, usage errors --------------------------------------------

@test "--help exits 0 and describes the render command" {
    run -0 "$LENSRAY" --help
    [[ "$output" == *"render"* ]]
    [[ "$output" == *"--set"* ]]
}

@test "render --help and lens --help exit 0 with the usage, whatever follows" {
    for cmd in render lens; do
        for flag in --help -h; do
            run --separate-stderr -0 "$LENSRAY" "$cmd" "$flag"
            [[ "$output" == *"usage: lensray render"* ]]
            [[ "$output" == *"--field-angles"* ]]
            [ -z "$stderr" ]
        done
    done
    # Help wins over what else is on the line, as with most tools.
    run -0 "$LENSRAY" render scene.json --help -o x.png
    [[ "$output" == *"usage"* ]]
    [ ! -e x.png ]
}

@test "version prints the version from include/lensray.h" {
    local major minor patch
    major=$(sed -n 's/^#define LR_VERSION_MAJOR \([0-9]*\).*/\1/p' "$REPO/include/lensray.h")
    minor=$(sed -n 's/^#define LR_VERSION_MINOR \([0-9]*\).*/\1/p' "$REPO/include/lensray.h")
    patch=$(sed -n 's/^#define LR_VERSION_PATCH \([0-9]*\).*/\1/p' "$REPO/include/lensray.h")
    [ -n "$major" ]
    [ -n "$minor" ]
    [ -n "$patch" ]
    run -0 "$LENSRAY" version
    [ "$output" = "lensray $major.$minor.$patch" ]
}

@test "no arguments is a usage error (2)" {
    run -2 "$LENSRAY"
    [[ "$output" == *"usage"* ]]
}

@test "an unknown command is a usage error (2) that names it" {
    run -2 "$LENSRAY" frobnicate
    [[ "$output" == *"frobnicate"* ]]
}

@test "an unknown option is a usage error (2) that names it" {
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --frobnicate
    [[ "$output" == *"--frobnicate"* ]]
    [ ! -e "$T/out.png" ]
}

@test "render without -o is a usage error (2)" {
    run -2 "$LENSRAY" render "$T/scene.json"
    [[ "$output" == *"-o"* ]]
}

@test "render without a scene is a usage error (2)" {
    run -2 "$LENSRAY" render -o "$T/out.png"
    [ ! -e "$T/out.png" ]
}

@test "a second scene argument is a usage error (2)" {
    run -2 "$LENSRAY" render "$T/scene.json" "$T/scene.json" -o "$T/out.png"
    [ ! -e "$T/out.png" ]
}

@test "-o given twice is a usage error (2) that names both, and writes neither" {
    # The last one won, and the first file the user asked for never came.
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/a.png" --output="$T/b.png"
    [[ "$output" == *"-o given twice ('$T/a.png', then '$T/b.png')"* ]]
    [ ! -e "$T/a.png" ]
    [ ! -e "$T/b.png" ]
}

@test "--set without PATH=VALUE is a usage error (2)" {
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --set camera.fov
    [[ "$output" == *"camera.fov"* ]]
}

@test "an output name ending in .jpg is a usage error (2) and writes nothing" {
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/out.jpg"
    [[ "$output" == *".exr"* ]]
    [[ "$output" == *".png"* ]]
    [ ! -e "$T/out.jpg" ]
    ! has_temp_files "$T"
}

# ---- I/O errors (4) ----------------------------------------------------------

@test "a missing scene file is an I/O error (4) that names it" {
    run -4 "$LENSRAY" render "$T/no-such-scene.json" -o "$T/out.png"
    [[ "$output" == *"no-such-scene.json"* ]]
    [ ! -e "$T/out.png" ]
}

@test "an output directory that does not exist is an I/O error (4)" {
    run -4 "$LENSRAY" render "$T/scene.json" -o "$T/no-such-dir/out.png"
    [[ "$output" == *"no-such-dir"* ]]
    [ ! -e "$T/no-such-dir" ]
}

@test "an output 'directory' that is a regular file is an I/O error (4)" {
    : >"$T/plainfile"
    run -4 "$LENSRAY" render "$T/scene.json" -o "$T/plainfile/out.png"
    [ ! -s "$T/plainfile" ]
}

@test "an output that cannot be written is refused before the scene is read (4)" {
    # access(2) on its directory passed all three: the render ran and
    # its picture was lost at the rename (bad.json, unreadable, shows
    # that the output is checked first).
    printf '{' >"$T/bad.json"
    mkdir "$T/d.exr"
    run -4 "$LENSRAY" render "$T/bad.json" -o "$T/d.exr"
    [[ "$output" == *"cannot write '$T/d.exr': Is a directory"* ]]
    ln -s "$T/nowhere/x.exr" "$T/dangling.exr"
    run -4 "$LENSRAY" render "$T/bad.json" -o "$T/dangling.exr"
    [[ "$output" == *"'$T/dangling.exr' (a link to '$T/nowhere/x.exr'): No such file"* ]]
    run -4 "$LENSRAY" render "$T/bad.json" -o /proc/lensray-test.exr
    [[ "$output" == *"/proc/lensray-test.exr"* ]]
    ! has_temp_files "$T"
}

@test "an output name of 250 bytes, legal, is written (its temporary name had no room)" {
    local n
    n=$(printf 'a%.0s' $(seq 1 246)).png
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/$n" -q
    [ -s "$T/$n" ]
    ! has_temp_files "$T"
}

@test "a PNG that cannot be written all says why (4)" {
    # The reason was lost (an overlapping snprintf): "cannot write a
    # 400 x 300 PNG: " and nothing after it.
    run -4 bash -c "trap '' XFSZ; ulimit -f 8; '$LENSRAY' render '$T/scene.json' \
        -o '$T/big.png' -q --set render.width=400 --set render.height=300 \
        --set render.spp=1"
    [[ "$output" == *"PNG: File too large"* ]]
    [ ! -e "$T/big.png" ]
    ! has_temp_files "$T"
}

@test "a read-only output directory is an I/O error (4)" {
    if [ "$(id -u)" = 0 ]; then
        skip "environment: root can write to read-only directories"
    fi
    mkdir "$T/ro"
    chmod 555 "$T/ro"
    run -4 "$LENSRAY" render "$T/scene.json" -o "$T/ro/out.png"
    chmod 755 "$T/ro"
    [ ! -e "$T/ro/out.png" ]
    ! has_temp_files "$T/ro"
}

# ---- scene errors (3) ---------------------------------------------------------

@test "malformed JSON is a scene error (3) that gives the line" {
    printf '{\n  "camera": {\n    "fov": 40,\n  }\n}\n' >"$T/bad.json"
    run -3 "$LENSRAY" render "$T/bad.json" -o "$T/out.png"
    [[ "$output" == *"line"* ]]
    [[ "$output" == *"bad.json"* ]]
    [ ! -e "$T/out.png" ]
}

@test "an unknown key is a scene error (3) that names its path" {
    scene typo '{ "camera": { "fvo": 30 } }'
    run -3 "$LENSRAY" render "$T/typo.json" -o "$T/out.png"
    [[ "$output" == *"camera.fvo"* ]]
    [ ! -e "$T/out.png" ]
}

@test "a negative radius is a scene error (3) that names objects[0].radius" {
    scene negr '{ "objects": [ { "type": "sphere", "center": [0, 0, -5], "radius": -1 } ] }'
    run -3 "$LENSRAY" render "$T/negr.json" -o "$T/out.png"
    [[ "$output" == *"objects[0].radius"* ]]
}

@test "an unknown material is a scene error (3) that names it" {
    scene nomat '{ "objects": [ { "type": "sphere", "center": [0, 0, -5], "radius": 1, "material": "unobtainium" } ] }'
    run -3 "$LENSRAY" render "$T/nomat.json" -o "$T/out.png"
    [[ "$output" == *"unobtainium"* ]]
    [[ "$output" == *"objects[0].material"* ]]
}

@test "a missing mesh file fails and names the file" {
    scene nomesh '{ "objects": [ { "type": "mesh", "file": "meshes/missing-mesh.obj" } ] }'
    run "$LENSRAY" render "$T/nomesh.json" -o "$T/out.png"
    [ "$status" -ne 0 ]
    [[ "$output" == *"missing-mesh.obj"* ]]
    [[ "$output" == *"objects[0].file"* ]]
    [ ! -e "$T/out.png" ]
}

@test "a texture that is not an image is a scene error (3) naming the file and key" {
    printf 'GIF89a not really' >"$T/tex.png"
    scene badtex '{ "materials": { "m": { "diffuse_texture": "tex.png" } } }'
    run -3 "$LENSRAY" render "$T/badtex.json" -o "$T/out.png"
    [[ "$output" == *"materials.m.diffuse_texture: tex.png is not a PNG, JPEG or OpenEXR image"* ]]
    [ ! -e "$T/out.png" ]
}

@test "the shipped textured scene renders with both integrators" {
    local integ
    for integ in path whitted; do
        run -0 "$LENSRAY" render "$REPO/scenes/textured.json" -o "$T/tex-$integ.png" -q \
            --set render.width=24 --set render.height=16 --set render.spp=2 \
            --set render.integrator=$integ
        [ "$(png_size "$T/tex-$integ.png")" = "24 16" ]
    done
}

@test "mesh paths are relative to the scene file, not the current directory" {
    mkdir -p "$T/scenedir/meshes" "$T/elsewhere"
    cat >"$T/scenedir/meshes/quad.obj" <<'EOF'
# a unit quad facing +z
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
f 1 2 3 4
EOF
    scene scenedir/mesh '{
      "camera": { "position": [0, 0, 4] },
      "render": { "width": 16, "height": 12, "spp": 1 },
      "lights": [ { "type": "ambient", "radiance": 1 } ],
      "objects": [ { "type": "mesh", "file": "meshes/quad.obj", "smooth": true } ]
    }'
    cd "$T/elsewhere"
    run -0 "$LENSRAY" render ../scenedir/mesh.json -o out.png --stats --quiet
    [ "$(png_size out.png)" = "16 12" ]
    [[ "$output" == *'"primitives": 2'* ]]
}

# ---- successful renders --------------------------------------------------------

@test "--stats reports the peak memory, which holds the film and not much more" {
    # 1500 x 1000 RGB floats are 17.2 MiB (17578 KiB); writing the EXR
    # streams into the file, so the peak stays near film + program + scene
    # (about 10 MiB more as built, 37 MiB under AddressSanitizer).
    run -0 "$LENSRAY" render "$BATS_TEST_DIRNAME/data/tiny.json" -o "$T/big.exr" \
        --set render.width=1500 --set render.height=1000 --set render.spp=1 \
        --stats --quiet
    rss=$(echo "$output" | sed -n 's/.*"peak_rss_kib": \([0-9]*\).*/\1/p')
    [ -n "$rss" ]
    [ "$rss" -ge 17578 ]
    [ "$rss" -le $((17578 + 80000)) ]
}

@test "a PNG render exits 0 and writes a PNG of the scene's size" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/out.png"
    [ "$(hex_bytes "$T/out.png" 0 8)" = 89504e470d0a1a0a ]
    [ "$(png_size "$T/out.png")" = "16 12" ]
    ! has_temp_files "$T"
}

@test "the extension is matched in any case (.PNG)" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/out.PNG"
    [ "$(png_size "$T/out.PNG")" = "16 12" ]
}

@test "an EXR render starts with the OpenEXR magic number" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/out.exr"
    [ "$(hex_bytes "$T/out.exr" 0 4)" = 762f3101 ]
}

@test "--half, --depth and --png16 give valid EXR and PNG files" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/half.exr" --half
    [ "$(hex_bytes "$T/half.exr" 0 4)" = 762f3101 ]
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/depth.exr" --depth
    [ "$(hex_bytes "$T/depth.exr" 0 4)" = 762f3101 ]
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/png16.png" --png16
    [ "$(png_size "$T/png16.png")" = "16 12" ]
    # The IHDR bit depth byte follows width and height.
    [ "$(hex_bytes "$T/png16.png" 24 1)" = 10 ]
}

@test "--compression picks the EXR compression, and a wrong name or a PNG is a usage error" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/zip.exr" -q
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/none.exr" -q --compression none
    # Uncompressed float RGB is at least 12 bytes a pixel.
    [ "$(wc -c < "$T/none.exr")" -gt "$(wc -c < "$T/zip.exr")" ]
    [ "$(wc -c < "$T/none.exr")" -gt $((16 * 12 * 12)) ]
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/x.exr" --compression lzw
    [[ "$output" == *'--compression: output.compression must be "zip", "none", "zips", "rle" or "piz"'* ]]
    [ ! -e "$T/x.exr" ]
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/x.png" --compression zip
    [[ "$output" == *"--compression: output.compression applies to exr only, not png"* ]]
    [ ! -e "$T/x.png" ]
}

@test "--half with a PNG and --png16 with an EXR are usage errors, not ignored" {
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/x.png" --half
    [[ "$output" == *"--half: output.half applies to exr only, not png"* ]]
    [ ! -e "$T/x.png" ]
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/x.exr" --png16
    [[ "$output" == *"--png16: output.bit_depth applies to png only, not exr"* ]]
    [ ! -e "$T/x.exr" ]
}

@test "--depth adds a Z channel to the EXR header" {
    if ! command -v python3 >/dev/null 2>&1; then
        skip "environment: python3 is needed to read the EXR header"
    fi
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/rgb.exr"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/rgbz.exr" --depth
    # Prints the channel names of an EXR file, sorted, comma-separated.
    channels='
import struct, sys
d = open(sys.argv[1], "rb").read()
i = 8
def cstr(i):
    j = d.index(b"\0", i)
    return d[i:j].decode(), j + 1
while True:
    name, i = cstr(i)
    if not name:
        break
    typ, i = cstr(i)
    size, = struct.unpack("<i", d[i:i + 4])
    i += 4
    if name == "channels":
        k, names = i, []
        while d[k] != 0:
            n, k = cstr(k)
            names.append(n)
            k += 16
        print(",".join(sorted(names)))
    i += size
'
    run -0 python3 -c "$channels" "$T/rgb.exr"
    [ "$output" = "B,G,R" ]
    run -0 python3 -c "$channels" "$T/rgbz.exr"
    [ "$output" = "B,G,R,Z" ]
}

# ---- --set overrides -----------------------------------------------------------

@test "--set render.width and render.height change the PNG size" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" \
        --set render.width=7 --set render.height=5
    [ "$(png_size "$T/out.png")" = "7 5" ]
}

@test "--set=PATH=VALUE is accepted too" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" \
        --set=render.width=9 --set=render.height=3
    [ "$(png_size "$T/out.png")" = "9 3" ]
}

@test "every option's value may follow it after '=', as --set= always could" {
    # --output=out.png was "unknown option", though --help shows --output
    # and --set=PATH=VALUE worked.
    run -0 "$LENSRAY" render "$T/scene.json" --output="$T/eq.exr" \
        --compression=none --set render.width=9 -q
    [ "$(hex_bytes "$T/eq.exr" 0 4)" = 762f3101 ]
    grep -aq 'compression' "$T/eq.exr"
    run -0 "$LENSRAY" render "$T/scene.json" --output "$T/two.exr" \
        --compression none --set render.width=9 -q
    cmp "$T/eq.exr" "$T/two.exr"
    run -0 "$LENSRAY" lens petzval --field-angles=0,5 --wavelength=550
    local eq="$output"
    run -0 "$LENSRAY" lens petzval --field-angles 0,5 --wavelength 550
    [ "$eq" = "$output" ]
    # Flags take no value, and '=' does not make a new option.
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/x.png" --stats=1
    [[ "$output" == *"unknown option '--stats=1'"* ]]
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/x.png" --outputs=y.png
    [[ "$output" == *"unknown option '--outputs=y.png'"* ]]
}

@test "--set adds keys, and whole objects, the file does not have" {
    scene bare '{ "objects": [ { "type": "sphere", "center": [0, 0, -5], "radius": 1 } ] }'
    run -0 "$LENSRAY" render "$T/bare.json" -o "$T/out.png" \
        --set 'render={"width": 6, "height": 4, "spp": 1}' --set render.width=5
    [ "$(png_size "$T/out.png")" = "5 4" ]
}

@test "--set camera.fov=500 is a scene error (3) that names camera.fov" {
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --set camera.fov=500
    [[ "$output" == *"camera.fov"* ]]
    [[ "$output" == *"500"* ]]
    [ ! -e "$T/out.png" ]
}

@test "render.integrator=path renders the scene differently; an unknown integrator names the field" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/w.exr" -q
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/p.exr" -q --set render.integrator=path
    run ! cmp -s "$T/w.exr" "$T/p.exr"
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --set render.integrator=bidir
    [[ "$output" == *"render.integrator"* ]]
    [[ "$output" == *"bidir"* ]]
    [ ! -e "$T/out.png" ]
}

@test "--set with an unknown key is rejected like one in the file" {
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --set camera.fvo=30
    [[ "$output" == *"camera.fvo"* ]]
}

@test "--set 'objects[0].radius=2' changes the sphere" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/r1.png"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/r2.png" --set 'objects[0].radius=2'
    [ "$(png_size "$T/r2.png")" = "16 12" ]
    ! cmp -s "$T/r1.png" "$T/r2.png"
}

@test "--set 'objects[0].radius=-2' is validated and names the path" {
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --set 'objects[0].radius=-2'
    [[ "$output" == *"objects[0].radius"* ]]
}

@test "--set 'objects[9].radius=2' is a scene error (3): no such element" {
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --set 'objects[9].radius=2'
    [[ "$output" == *"objects[9]"* ]]
    [ ! -e "$T/out.png" ]
}

@test "--set with a malformed array index is a scene error (3)" {
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --set 'objects[x].radius=2'
    [[ "$output" == *"index"* ]]
}

# ---- lens models, samplers and regions through --set ----------------------------

# Runs a render of the test scene with the given --set overrides (one
# override per argument), expects exit status 3, and checks that the
# message names FIELD and that no image was written.
#     fails_naming FIELD OVERRIDE...
fails_naming() {
    local field="$1" a
    shift
    local args=()
    for a in "$@"; do
        args+=(--set "$a")
    done
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/bad.png" "${args[@]}"
    [[ "$output" == *"$field"* ]]
    [ ! -e "$T/bad.png" ]
    ! has_temp_files "$T"
}

@test "a thin-lens render succeeds and is blurred where the pinhole is sharp" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/pin.png"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/thin.png" \
        --set camera.model=thinlens --set camera.focus_distance=2 \
        --set camera.aperture_radius=0.3
    [ "$(png_size "$T/thin.png")" = "16 12" ]
    ! cmp -s "$T/pin.png" "$T/thin.png"
}

@test "thin-lens options render: f-number, polygon aperture, autofocus, chromatic" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/a.png" \
        --set camera.model=thinlens --set camera.focal_length_mm=50 \
        --set camera.f_number=2 --set camera.focus_distance=5 \
        --set camera.aperture_shape=polygon --set camera.aperture_blades=5 \
        --set camera.aperture_rotation=90 --set camera.aperture_ratio=1.5 \
        --set 'camera.focus_on=[8,6]' \
        --set 'camera.chromatic={"mode": "spectral", "glass": "F2", "wavelengths": 5}'
    [ "$(png_size "$T/a.png")" = "16 12" ]
}

@test "a bracket render with rgb chromatic aberration succeeds" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/b.png" \
        --set camera.model=bracket --set camera.aperture=0.2 \
        --set camera.focal_length=3 \
        --set 'camera.chromatic={"mode": "rgb", "amplify": 20, "focal_model": "lensmaker"}'
    [ "$(png_size "$T/b.png")" = "16 12" ]
}

@test "a zero-aperture thin lens and bracket give the pinhole's PNG byte for byte" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/pin.png"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/thin0.png" \
        --set camera.model=thinlens --set camera.aperture_radius=0 \
        --set camera.focus_distance=3
    cmp "$T/pin.png" "$T/thin0.png"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/bracket0.png" \
        --set camera.model=bracket --set camera.aperture=0
    cmp "$T/pin.png" "$T/bracket0.png"
}

@test "lens-models.md: the bracket equals a square thin lens, PNG byte for byte, small and full frame" {
    # The commands of lens-models.md section 3 on the shipped spheres scene
    # (the doc had one pixel of the 640 x 360 frame differ).
    local size
    for size in "160 90" "640 360"; do
        set -- $size
        "$LENSRAY" render "$REPO/scenes/spheres.json" -o "$T/bracket.png" -q \
            --set camera.model=bracket --set camera.aperture=0.2 \
            --set camera.focal_length=9 --set render.width=$1 --set render.height=$2
        "$LENSRAY" render "$REPO/scenes/spheres.json" -o "$T/thin.png" -q \
            --set camera.model=thinlens --set camera.aperture_shape=square \
            --set camera.aperture_radius=0.11111111111111112 \
            --set camera.focus_distance=10 --set render.width=$1 --set render.height=$2
        cmp "$T/bracket.png" "$T/thin.png"
        # Not trivially equal: the lens blurs what the pinhole keeps sharp.
        "$LENSRAY" render "$REPO/scenes/spheres.json" -o "$T/pin.png" -q \
            --set render.width=$1 --set render.height=$2
        run ! cmp -s "$T/pin.png" "$T/thin.png"
    done
}

@test "every sampler name renders" {
    local s
    for s in grid jittered random sobol; do
        run -0 "$LENSRAY" render "$T/scene.json" -o "$T/$s.png" \
            --set render.sampler=$s --set camera.model=thinlens \
            --set camera.aperture_radius=0.2 --set camera.focus_distance=4
        [ "$(png_size "$T/$s.png")" = "16 12" ]
    done
}

@test "render.region crops the PNG to x1-x0 by y1-y0 pixels" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/crop.png" \
        --set 'render.region=[2, 3, 10, 9]'
    [ "$(png_size "$T/crop.png")" = "8 6" ]
}

@test "camera.aperture_radius=-1 on a thin lens is a scene error (3) naming it" {
    fails_naming camera.aperture_radius camera.model=thinlens camera.aperture_radius=-1
    [[ "$output" == *"-1"* ]]
}

@test "camera.model=fisheye is a scene error (3) that lists the models" {
    fails_naming camera.model camera.model=fisheye
    [[ "$output" == *'"fisheye"'* ]]
    [[ "$output" == *'"pinhole"'* ]]
    [[ "$output" == *'"thinlens"'* ]]
    [[ "$output" == *'"bracket"'* ]]
}

@test "camera.aperture_shape=star is a scene error (3) that lists the shapes" {
    fails_naming camera.aperture_shape camera.model=thinlens camera.aperture_shape=star
    [[ "$output" == *'"disk"'* ]]
    [[ "$output" == *'"polygon"'* ]]
}

@test "camera.aperture_blades=2 is a scene error (3) naming it" {
    fails_naming camera.aperture_blades camera.model=thinlens \
        camera.aperture_shape=polygon camera.aperture_blades=2
}

@test "camera.chromatic.mode=rainbow is a scene error (3) naming it" {
    fails_naming camera.chromatic.mode camera.chromatic.mode=rainbow
    [[ "$output" == *'"spectral"'* ]]
}

@test "chromatic aberration on a thin lens without focal_length_mm names camera.focal_length_mm" {
    fails_naming camera.focal_length_mm camera.model=thinlens \
        camera.aperture_radius=0.1 camera.chromatic.mode=rgb
}

@test "a thin lens focused inside its focal length with chromatic aberration names camera.focus_distance" {
    fails_naming camera.focus_distance camera.model=thinlens \
        camera.focal_length_mm=50 camera.focus_distance=0.05 \
        camera.chromatic.mode=spectral
}

@test "render.sampler=magic is a scene error (3) that lists the samplers" {
    fails_naming render.sampler render.sampler=magic
    [[ "$output" == *'"sobol"'* ]]
    [[ "$output" == *'"grid"'* ]]
}

@test "camera.focus_on outside the image is a scene error (3) naming camera.focus_on" {
    fails_naming camera.focus_on camera.model=thinlens \
        camera.aperture_radius=0.1 'camera.focus_on=[9999,0]'
}

@test "camera.focus_on on a surface the camera sits on is an error naming camera.focus_on" {
    # The camera on the sphere's surface: the focus found is 0, and the
    # message named camera.focus_distance, which nobody set.
    fails_naming "camera.focus_on [8, 6]: the surface there, 0 from the camera" \
        camera.model=thinlens camera.aperture_radius=0.1 \
        'camera.position=[0, 1, 1]' 'camera.look_at=[0, 1, 0]' \
        'camera.focus_on=[8, 6]'
}

@test "render.region outside the frame is a scene error (3) naming render.region" {
    fails_naming render.region 'render.region=[0, 0, 17, 12]'
}

@test "--depth with a .png output is a usage error (2) and writes nothing" {
    run -2 "$LENSRAY" render "$T/scene.json" -o "$T/depth.png" --depth
    [[ "$output" == *"--depth"* ]]
    [[ "$output" == *".exr"* ]]
    [ ! -e "$T/depth.png" ]
    ! has_temp_files "$T"
}

@test "a scene's render.depth with a .png output warns, skips the Z rays and writes the PNG" {
    # scene-format.md had said the Z channel was rendered and dropped
    # without a warning.
    run -0 --separate-stderr "$LENSRAY" render "$T/scene.json" -o "$T/z.png" \
        --set render.depth=true --stats -q
    [[ "$stderr" == *"warning: render.depth is set but"*"z.png has no Z channel"* ]]
    local with="$output"
    png_size "$T/z.png"
    run -0 --separate-stderr "$LENSRAY" render "$T/scene.json" -o "$T/noz.png" --stats -q
    # The same rays as without render.depth: no ray through pixel centres
    # for Z (an EXR with --depth traces one more per pixel).
    [ "$(echo "$with" | sed 's/.*"rays": \([0-9]*\).*/\1/')" = \
      "$(echo "$output" | sed 's/.*"rays": \([0-9]*\).*/\1/')" ]
    run -0 --separate-stderr "$LENSRAY" render "$T/scene.json" -o "$T/z.exr" --depth --stats -q
    [ "$(echo "$output" | sed 's/.*"rays": \([0-9]*\).*/\1/')" -gt \
      "$(echo "$with" | sed 's/.*"rays": \([0-9]*\).*/\1/')" ]
    cmp "$T/z.png" "$T/noz.png"
}

# ---- --stats ---------------------------------------------------------------------

@test "--stats prints one JSON line with seconds, rays and samples_per_second" {
    run -0 --separate-stderr "$LENSRAY" render "$T/scene.json" -o "$T/out.png" --stats
    [ "${#lines[@]}" -eq 1 ]
    [[ "$output" == *'"seconds"'* ]]
    [[ "$output" == *'"rays"'* ]]
    [[ "$output" == *'"samples_per_second"'* ]]
    if command -v python3 >/dev/null 2>&1; then
        run -0 python3 -c '
import json, sys
s = json.loads(sys.argv[1])
assert isinstance(s["seconds"], (int, float)) and s["seconds"] >= 0, s
assert isinstance(s["rays"], int) and s["rays"] > 0, s
assert isinstance(s["samples_per_second"], (int, float)), s
assert s["width"] == 16 and s["height"] == 12 and s["spp"] == 2, s
assert s["samples"] == 16 * 12 * 2, s
assert s["rays"] >= s["samples"], s
' "$output"
    else
        [[ "$output" =~ ^\{.*\}$ ]]
        [[ "$output" =~ \"samples\":\ 384[,}] ]]
    fi
}

@test "without --stats nothing is printed on stdout" {
    run -0 --separate-stderr "$LENSRAY" render "$T/scene.json" -o "$T/out.png"
    [ -z "$output" ]
}

# ---- determinism -------------------------------------------------------------------

@test "rendering the same scene twice gives identical bytes" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/a.png" --set render.spp=4
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/b.png" --set render.spp=4
    cmp "$T/a.png" "$T/b.png"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/a.exr" --depth
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/b.exr" --depth
    cmp "$T/a.exr" "$T/b.exr"
}

@test "render.threads=1 and render.threads=2 give identical bytes" {
    # Small tiles, so that two threads really share the image.
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/t1.png" \
        --set render.tile_size=4 --set render.threads=1 --set render.spp=4
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/t2.png" \
        --set render.tile_size=4 --set render.threads=2 --set render.spp=4
    cmp "$T/t1.png" "$T/t2.png"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/t1.exr" \
        --set render.tile_size=4 --set render.threads=1 --set render.spp=4
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/t2.exr" \
        --set render.tile_size=3 --set render.threads=2 --set render.spp=4
    cmp "$T/t1.exr" "$T/t2.exr"
}

@test "a different render.seed gives a different image" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/s0.exr" --set render.seed=0
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/s1.exr" --set render.seed=1
    ! cmp -s "$T/s0.exr" "$T/s1.exr"
}

# ---- atomic output -----------------------------------------------------------------

@test "rendering onto an existing file replaces it atomically" {
    mkdir "$T/outdir"
    printf 'not an image\n' >"$T/outdir/out.png"
    local before after
    before=$(stat -c %i "$T/outdir/out.png")
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/outdir/out.png"
    [ "$(png_size "$T/outdir/out.png")" = "16 12" ]
    # A new file was renamed over the old one (not rewritten in place) ...
    after=$(stat -c %i "$T/outdir/out.png")
    [ "$before" != "$after" ]
    # ... and nothing else is left in the directory.
    run ! has_temp_files "$T/outdir"
    [ "$(ls -A "$T/outdir")" = "out.png" ]
    # The file replaced keeps its permission bits (0664 had become the
    # umask's 0644).
    chmod 0604 "$T/outdir/out.png"
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/outdir/out.png"
    [ "$(stat -c %a "$T/outdir/out.png")" = 604 ]
}

@test "Ctrl-C while the image is written keeps the file there before; a second Ctrl-C is not ignored" {
    # The write did not look at the flag: the new file replaced the old
    # one and the exit status said 130, "no file is written".  The signal
    # is sent once the temporary file has bytes: the encoder is writing.
    echo before >"$T/race.exr"
    "$LENSRAY" render "$T/scene.json" -o "$T/race.exr" -q --depth \
        --set render.width=2048 --set render.height=2048 --set render.spp=1 \
        --set render.threads=1 2>"$T/err" &
    local pid=$! i
    # (Up to two minutes: a sanitizer build renders slowly.)
    for i in $(seq 1 6000); do
        [ -n "$(find "$T" -maxdepth 1 -name 'race.exr.tmp.*' -size +0 2>/dev/null)" ] && break
        sleep 0.02
    done
    kill -INT "$pid"
    local st=0
    wait "$pid" || st=$?
    [ "$st" -eq 130 ]
    [ "$(cat "$T/race.exr")" = before ]
    grep -q "writing '$T/race.exr' was cancelled" "$T/err"
    run ! has_temp_files "$T"
    # The handler gives way after the first signal: a second one ends the
    # process at once (it had been ignored).
    scene slow '{"render": {"width": 32, "height": 24, "spp": 1000000, "adaptive": false, "plan": false, "threads": 1},
                 "objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1}],
                 "lights": [{"type": "ambient", "radiance": 1}]}'
    "$LENSRAY" render "$T/slow.json" -o "$T/slow.png" -q 2>/dev/null &
    pid=$!
    sleep 0.5
    kill -INT "$pid"
    sleep 0.02
    kill -INT "$pid" 2>/dev/null || true
    st=0
    wait "$pid" || st=$?
    [ "$st" -eq 130 ]
}

@test "an output name the rename would refuse is refused before the scene is read" {
    # Over 255 bytes: the check's short temporary name had passed, and
    # the render was lost at the rename ("File name too long").
    local long
    long=$(printf 'x%.0s' $(seq 300))
    run -4 "$LENSRAY" render "$T/no-such-scene.json" -o "$T/$long.png"
    [[ "$output" == *"File name too long"* ]]
    [[ "$output" != *"no-such-scene"* ]]
    # Another user's file in a sticky directory (as /tmp) cannot be
    # replaced but by its owner: rename(2) says EPERM.
    if [ "$(id -u)" != 0 ] || ! command -v setpriv >/dev/null; then
        skip "environment: needs root and setpriv to make another user's file"
    fi
    # (Outside bats's private temporary directory, which nobody cannot
    # enter, with a copy of the program that nobody can run.)
    local d
    d=$(mktemp -d /tmp/lensray-sticky.XXXXXX)
    chmod 755 "$d"
    cp "$LENSRAY" "$d/lensray"
    mkdir -m 1777 "$d/sticky"
    echo root >"$d/sticky/out.png"
    chmod 666 "$d/sticky/out.png"
    run -4 setpriv --reuid=65534 --regid=65534 --clear-groups \
        "$d/lensray" render "$d/no-such-scene.json" -o "$d/sticky/out.png"
    local out=$output
    local kept
    kept=$(cat "$d/sticky/out.png")
    rm -rf "$d"
    [[ "$out" == *"Operation not permitted"*"sticky"* ]]
    [ "$kept" = root ]
}

@test "a failed write to standard output is exit 4, not 0 with the JSON cut short" {
    [ -w /dev/full ] || skip "environment: no /dev/full"
    run -4 bash -c '"$0" lens double-gauss-50 >/dev/full' "$LENSRAY"
    [[ "$output" == *"cannot write the standard output"* ]]
    run -4 bash -c '"$0" render "$1" -o "$2" -q --stats >/dev/full' \
        "$LENSRAY" "$T/scene.json" "$T/s.png"
    run -4 bash -c '"$0" version >/dev/full' "$LENSRAY"
}

@test "%% is a % in a one-scene name without a number; a batch's --stats lines name their frames" {
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/p100%%.png" -q
    [ -e "$T/p100%.png" ]
    [ ! -e "$T/p100%%.png" ]
    # A stray % that is no pattern stays as it is.
    run -0 "$LENSRAY" render "$T/scene.json" -o "$T/q100%.png" -q
    [ -e "$T/q100%.png" ]
    scene bad '{"render": {"spp": -1}}'
    run -3 --separate-stderr "$LENSRAY" render "$T/scene.json" "$T/bad.json" \
        "$T/scene.json" -o "$T/f-%d.png" -q --stats
    [ "${#lines[@]}" -eq 2 ]
    [[ "${lines[0]}" == '{"frame": 1, "peak_rss_kib": '* ]]
    [[ "${lines[1]}" == '{"frame": 3, "peak_rss_kib": '* ]]
}

@test "Ctrl-C in a batch says which frames were written, and calls no frame failed" {
    # It said "frame 2/3 (...) failed" and nothing of frame 1.  Frame 1 is
    # quick; frame 2 takes minutes on one thread, in small tiles, so the
    # signal, sent once frame 1 is on disk, lands in its render.
    local slow=(--set render.threads=1 --set render.tile_size=2
                --set render.adaptive=false --set render.plan=false)
    scene quick '{"render": {"width": 4, "height": 4, "spp": 1}}'
    scene slow '{"render": {"width": 32, "height": 24, "spp": 1000000},
                 "objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1}],
                 "lights": [{"type": "ambient", "radiance": 1}]}'
    "$LENSRAY" render "$T/quick.json" "$T/slow.json" "$T/quick.json" \
        -o "$T/f-%d.png" "${slow[@]}" 2>"$T/err" &
    local pid=$! i
    for i in $(seq 1 600); do
        [ -e "$T/f-1.png" ] && break
        sleep 0.1
    done
    [ -e "$T/f-1.png" ]
    sleep 0.5
    kill -INT "$pid"
    local st=0
    wait "$pid" || st=$?
    [ "$st" -eq 130 ]
    grep -q 'interrupted: 1 of 3 frames written' "$T/err"
    run ! grep -q 'failed' "$T/err"
    [ ! -e "$T/f-2.png" ]
    [ ! -e "$T/f-3.png" ]
    ! has_temp_files "$T"
}

@test "a failed render leaves an existing output file untouched" {
    printf 'previous image\n' >"$T/keep.png"
    run -3 "$LENSRAY" render "$T/scene.json" -o "$T/keep.png" --set camera.fov=0
    [ "$(cat "$T/keep.png")" = "previous image" ]
    ! has_temp_files "$T"
}

# ---- glTF files -----------------------------------------------------------------

@test "a .glb renders alone, through its own camera, its aspect ratio setting the height" {
    python3 "$BATS_TEST_DIRNAME/gltf_writer.py" camera-light "$T/cl.glb"
    run -0 "$LENSRAY" render "$T/cl.glb" -o "$T/cl.png" --set render.width=30 \
        --set render.spp=2
    [ "$(png_size "$T/cl.png")" = "30 20" ] # aspectRatio 1.5
    [ -z "$output" ]
    # A .gltf without a camera is framed automatically.
    python3 "$BATS_TEST_DIRNAME/gltf_writer.py" tri "$T/tri.gltf"
    run -0 "$LENSRAY" render "$T/tri.gltf" -o "$T/tri.png" --set render.width=16 \
        --set render.height=12 --set render.spp=2
    [ "$(png_size "$T/tri.png")" = "16 12" ]
}

@test "glTF: ignored parts are warned about, bad files are exit 3 naming the file and field" {
    python3 "$BATS_TEST_DIRNAME/gltf_writer.py" camera-light "$T/cl.gltf"
    sed 's/"type": "point"/"type": "point", "range": 5/' "$T/cl.gltf" >"$T/range.gltf"
    run -0 "$LENSRAY" render "$T/range.gltf" -o "$T/range.png" --set render.width=12 \
        --set render.spp=1
    [[ "$output" == *"lensray: warning: range.gltf: extensions.KHR_lights_punctual.lights[0].range is ignored"* ]]
    python3 "$BATS_TEST_DIRNAME/gltf_writer.py" tri "$T/tri.glb"
    head -c 500 "$T/tri.glb" >"$T/cut.glb"
    run -3 "$LENSRAY" render "$T/cut.glb" -o "$T/cut.png"
    [[ "$output" == *"cut.glb: the GLB header says"*"truncated"* ]]
    [ ! -e "$T/cut.png" ]
    sed '0,/"count": 4,/s//"count": 3000000,/' "$T/cl.gltf" >"$T/count.gltf"
    run ! cmp -s "$T/cl.gltf" "$T/count.gltf"
    run -3 "$LENSRAY" render "$T/count.gltf" -o "$T/count.png"
    [[ "$output" == *"count.gltf: accessors["*"elements reach byte"* ]]
}

@test "a light render whose paths all miss the film is black with a warning" {
    # A field of view of 0.01 degrees: none of 1024 light paths joins the
    # lens inside the frame, and the picture was black without a word
    # (an independent check); the path integrator lights it.
    scene tinyfov '{"camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 0.01},
                    "render": {"width": 16, "height": 16, "spp": 4, "integrator": "light"},
                    "materials": {"d": {"diffuse": 0.8}},
                    "lights": [{"type": "point", "position": [0, 5, 0], "intensity": 10}],
                    "objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1, "material": "d"}]}'
    run -0 --separate-stderr "$LENSRAY" render "$T/tinyfov.json" -o "$T/a.png" -q
    [[ "$stderr" == *"none of the 1024 light paths reached the film, so the picture is black"* ]]
    run -0 --separate-stderr "$LENSRAY" render "$T/tinyfov.json" -o "$T/b.png" -q \
        --set 'render.integrator="path"'
    [ -z "$stderr" ]
}
