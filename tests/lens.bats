#!/usr/bin/env bats
# lens.bats: `lensray lens`, end to end: the JSON it prints, the three
# prescription forms, and its errors (exit codes, messages that name the
# field or the file and line, the shipped names for an unknown lens).
# The numbers themselves are checked against ray-optics by make
# test-lenses and against matrices by tests/test_paraxial.c; here, their
# shape and a few that a patent or a formula gives.
#
#     LENSRAY_BUILD=build bats tests/lens.bats

bats_require_minimum_version 1.5.0

setup() {
    REPO="$(cd "$BATS_TEST_DIRNAME/.." && pwd)"
    local build="${LENSRAY_BUILD:-build}"
    case "$build" in
    /*) ;;
    *) build="$REPO/$build" ;;
    esac
    LENSRAY="$build/lensray"
    [ -x "$LENSRAY" ] || { echo "no $LENSRAY (run make first)" >&2; return 1; }
    T="$BATS_TEST_TMPDIR"
    cd "$REPO"
}

# Prints the value of a JSON expression over the output, e.g. j efl_mm.
j() {
    python3 -c 'import json,sys; d=json.load(sys.stdin); print(eval(sys.argv[1], {}, {"d": d}))' "$1"
}

@test "a shipped lens by name: the fields asked for, in order" {
    run -0 "$LENSRAY" lens double-gauss-50 --field-angles 0,10,-10
    [ "$(echo "$output" | j 'len(d["fields"])')" = 3 ]
    [ "$(echo "$output" | j 'd["fields"][1]["angle_deg"]')" = 10 ]
    # The image is symmetric in the field angle.
    [ "$(echo "$output" | j 'abs(d["fields"][1]["image_height_mm"] + d["fields"][2]["image_height_mm"]) < 1e-9')" = True ]
    # Tronnier's patent: f = 50 at 1:2, back focus 0.71436 f.
    [ "$(echo "$output" | j 'abs(d["efl_mm"] - 50) < 0.05 and abs(d["bfl_mm"] / d["efl_mm"] - 0.71436) < 5e-5')" = True ]
    [ "$(echo "$output" | j 'abs(d["f_number"] - 2) < 0.05')" = True ]
    for k in efl_mm bfl_mm ffl_mm f_number total_track_mm wavelength_nm; do
        echo "$output" | j "d['$k']" >/dev/null
    done
}

@test "--wavelength moves the focus: blue focuses nearer than red" {
    run -0 "$LENSRAY" lens double-gauss-50.json --wavelength 450
    blue=$(echo "$output" | j 'd["bfl_mm"]')
    run -0 "$LENSRAY" lens double-gauss-50 --wavelength 650
    red=$(echo "$output" | j 'd["bfl_mm"]')
    python3 -c "import sys; sys.exit(0 if $blue < $red else 1)"
}

@test "a pbrt-v4 file and a Zemax file by path" {
    run -0 "$LENSRAY" lens tests/data/lenses/dgauss.50mm.dat --field-angles 5
    [ "$(echo "$output" | j 'd["name"]')" = "D-GAUSS F/2 22deg HFOV" ]
    run -0 "$LENSRAY" lens tests/data/lenses/cooke-triplet.zmx
    [ "$(echo "$output" | j 'round(d["efl_mm"], 2)')" = 50.02 ]
}

@test "a flat front surface: the chief rays are found (Clark's double Gauss)" {
    # A flat first surface opens to 1e6 mm in the chief-ray search, which
    # started its rays 1 km away and aimed them in metre steps: every
    # field was null.  Heights from ray-optics 0.9.8 on the same .zmx (d
    # line, the paraxial focal plane), within 1e-4 of f.
    run -0 "$LENSRAY" lens tests/data/lenses/clark-double-gauss.zmx --field-angles 10,20
    [ "$(echo "$output" | j 'abs(d["fields"][0]["image_height_mm"] - 8.721093) < 5e-3')" = True ]
    [ "$(echo "$output" | j 'abs(d["fields"][1]["image_height_mm"] - 18.094739) < 5e-3')" = True ]
}

@test "a fisheye's chief rays up to 89 degrees" {
    # Near 90 degrees the aim's guess along the paraxial pupil (tan grows
    # without bound) left the lens: 85 and 89 degrees were null.  Heights
    # from ray-optics 0.9.8 (wide-angle field), within 1e-4 of f.
    run -0 "$LENSRAY" lens fisheye-10 --field-angles 85,89
    [ "$(echo "$output" | j 'abs(d["fields"][0]["image_height_mm"] - 14.766645) < 1e-3')" = True ]
    [ "$(echo "$output" | j 'abs(d["fields"][1]["image_height_mm"] - 15.380104) < 1e-3')" = True ]
}

@test "a thin singlet: the lensmaker's focal length" {
    # 1/f = (n - 1)(1/R1 - 1/R2) for a thin lens; n = 1.5, R = +-100: f = 100
    # (0.3 mm high, so that its 1 um thickness holds at the rim).
    cat >"$T/thin.json" <<'J'
{"surfaces": [{"stop": true, "thickness": 0, "semi_aperture": 0.3},
 {"radius": 100, "thickness": 0.001, "material": {"nd": 1.5}, "semi_aperture": 0.3},
 {"radius": -100, "thickness": 100, "material": "air", "semi_aperture": 0.3}]}
J
    run -0 "$LENSRAY" lens "$T/thin.json"
    [ "$(echo "$output" | j 'abs(d["efl_mm"] - 100) < 1e-3')" = True ]
}

@test "--ghosts: a nearly flat bare plate's one ghost carries R^2 of the main image; the double Gauss's 55" {
    # n = 1.5 on both faces, square on: R = ((n - 1) / (n + 1))^2 = 0.04
    # (Fresnel), and the ghost reflecting at the back face, then the
    # front, keeps R^2 = 1.6e-3 of what the main image keeps.  Paths that
    # reflect at the stop (in air) carry nothing.
    cat >"$T/plate.json" <<'J'
{"surfaces": [{"stop": true, "thickness": 1, "semi_aperture": 5},
 {"radius": 100000, "thickness": 2, "material": {"nd": 1.5}, "semi_aperture": 5},
 {"radius": -100000, "thickness": 10, "material": "air", "semi_aperture": 5}]}
J
    run -0 "$LENSRAY" lens "$T/plate.json" --ghosts --coating none
    [ "$(echo "$output" | j 'd["ghost_paths"]')" = 3 ]
    [ "$(echo "$output" | j 'd["ghosts"][0]["surfaces"]')" = "[2, 1]" ]
    [ "$(echo "$output" | j 'abs(d["ghosts"][0]["flux"] / 0.04 ** 2 - 1) < 0.02')" = True ]
    [ "$(echo "$output" | j 'd["ghosts"][1]["flux"] + d["ghosts"][2]["flux"] == 0')" = True ]
    # The main image keeps (1 - R)^2 of the beam.
    [ "$(echo "$output" | j 'abs(d["main_transmission"] / 0.96 ** 2 - 1) < 0.02')" = True ]
    # MgF2 on both faces: far less.
    run -0 "$LENSRAY" lens "$T/plate.json" --ghosts --coating mgf2
    [ "$(echo "$output" | j 'd["ghosts"][0]["flux"] < 0.04 ** 2 / 4')" = True ]
    # The double Gauss: N(N-1)/2 = 55 paths, brightest first, summed.
    run -0 "$LENSRAY" lens double-gauss-50 --ghosts --wavelength 550 --coating none
    [ "$(echo "$output" | j 'len(d["ghosts"]) == d["ghost_paths"] == 55')" = True ]
    [ "$(echo "$output" | j 'all(a["flux"] >= b["flux"] for a, b in zip(d["ghosts"], d["ghosts"][1:]))')" = True ]
    [ "$(echo "$output" | j 'abs(sum(g["flux"] for g in d["ghosts"]) - d["total_flux"]) < 1e-12')" = True ]
    run -2 "$LENSRAY" lens double-gauss-50 --coating none
    run -2 "$LENSRAY" lens double-gauss-50 --ghosts --coating ito
}

@test "--ghosts --field-angles A: the ghosts of a point A degrees off the axis" {
    # The plate behind a 5 mm stop, its faces wide: a beam at 10 degrees
    # crosses 1 mm of air, the 2 mm plate at the refracted angle
    # (sin tg = sin 10 / 1.5) and 10 mm of air; the ghost (2, 1) crosses
    # the plate twice more: x = 11 tan 10 + 6 tan tg = 2.6389 mm.  (It
    # printed the on-axis ghosts, field_deg 0, whatever the angle.)
    cat >"$T/plate50.json" <<'J'
{"surfaces": [{"stop": true, "thickness": 1, "semi_aperture": 5},
 {"radius": 100000, "thickness": 2, "material": {"nd": 1.5}, "semi_aperture": 50},
 {"radius": -100000, "thickness": 10, "material": "air", "semi_aperture": 50}]}
J
    run -0 "$LENSRAY" lens "$T/plate50.json" --ghosts --coating none --field-angles 10
    [ "$(echo "$output" | j 'd["field_deg"]')" = 10 ]
    [ "$(echo "$output" | j 'd["ghosts"][0]["surfaces"]')" = "[2, 1]" ]
    [ "$(echo "$output" | j 'abs(abs(d["ghosts"][0]["centroid_mm"][0]) - 2.6389) < 2e-3')" = True ]
    # lenses.md's 10-degree row of the double Gauss.
    run -0 "$LENSRAY" lens double-gauss-50 --ghosts --coating none --wavelength 550 --field-angles 10
    [ "$(echo "$output" | j 'd["ghosts"][0]["surfaces"]')" = "[10, 8]" ]
    [ "$(echo "$output" | j '"%.1e %.1f %.1e" % (d["ghosts"][0]["flux"], d["ghosts"][0]["rms_radius_mm"], d["total_flux"])')" = "3.8e-03 5.9 4.7e-02" ]
    grep -qF '| none | 10 deg | 550 nm | (10, 8): 3.8e-3 | 5.9 mm | 4.7e-2 |' "$REPO/docs/lenses.md"
    # One distant point: one angle; and it is checked as describe's are.
    run -2 "$LENSRAY" lens double-gauss-50 --ghosts --field-angles 10,20
    [[ "$output" == *"--ghosts takes one field angle"* ]]
    run -2 "$LENSRAY" lens double-gauss-50 --ghosts --field-angles 95
}

@test "an unknown lens lists the shipped ones" {
    run -3 "$LENSRAY" lens double-gauss-55
    [[ "$output" == *'lens "double-gauss-55": no such file'* ]]
    # The files of lenses/, sorted, each named whole or counted ("and N
    # more"): two dozen did not fit an error message and were cut mid-name.
    local -a all=() shown=()
    local f listed more=0
    for f in lenses/*.json lenses/*.zmx lenses/*.dat lenses/*.txt; do
        [ -f "$f" ] && all+=("$(basename "${f%.*}")")
    done
    [ "${#all[@]}" -ge 20 ]
    mapfile -t all < <(printf '%s\n' "${all[@]}" | LC_ALL=C sort)
    listed="${output#*shipped lenses: }"
    if [[ "$listed" =~ ^(.*)\ and\ ([0-9]+)\ more$ ]]; then
        listed="${BASH_REMATCH[1]}" more="${BASH_REMATCH[2]}"
    fi
    IFS=',' read -ra shown <<<"${listed//, /,}"
    [ "$(( ${#shown[@]} + more ))" -eq "${#all[@]}" ]
    [ "${shown[*]}" = "${all[*]:0:${#shown[@]}}" ]
}

@test "errors name the field, or the file and line" {
    cat >"$T/bad.json" <<'J'
{"surfaces": [{"stop": true, "thickness": 1, "semi_aperture": 5},
 {"radius": 50, "thickness": 4, "material": "N-BK8", "semi_aperture": 10},
 {"radius": -50, "thickness": 48, "material": "air", "semi_aperture": 10}]}
J
    run -3 "$LENSRAY" lens "$T/bad.json"
    [[ "$output" == *'surfaces[1].material: unknown glass "N-BK8"; nearest: N-BK7'* ]]
    printf '0 1 0 10\n50 4 1.5 20\n-50 4x 1 20\n' >"$T/bad.dat"
    run -3 "$LENSRAY" lens "$T/bad.dat"
    [[ "$output" == *'bad.dat:3: "4x" is not a number'* ]]
    printf 'SURF 0\n  DISZ INFINITY\nSURF 1\n  TYPE TOROIDAL\n' >"$T/bad.zmx"
    run -3 "$LENSRAY" lens "$T/bad.zmx"
    [[ "$output" == *'bad.zmx:4: surface type TOROIDAL is not supported'* ]]
}

@test "lens --list: every shipped lens, its name and title" {
    run -0 "$LENSRAY" lens --list
    # One line a file of lenses/, in its order, each "NAME<tab>title".
    diff <(printf '%s\n' "$output" | cut -f1) \
        <(ls "$BATS_TEST_DIRNAME/../lenses" | sed -n 's/\.json$//p' | LC_ALL=C sort)
    [[ "$output" == *$'double-gauss-50\tDouble Gauss 50 mm f/2'* ]]
    run -2 "$LENSRAY" lens --list double-gauss-50
    run -2 "$LENSRAY" lens double-gauss-50 --list
    [[ "$output" == *"--list takes no other arguments"* ]]
}

@test "usage errors exit 2" {
    run -2 "$LENSRAY" lens
    run -2 "$LENSRAY" lens petzval --field-angles 1,x
    [[ "$output" == *"--field-angles '1,x'"* ]]
    run -2 "$LENSRAY" lens petzval --field-angles 1,
    [[ "$output" == *"--field-angles '1,'"* ]]
    run -2 "$LENSRAY" lens petzval --field-angles ""
    run -2 "$LENSRAY" lens petzval --field-angles ,1
    run -2 "$LENSRAY" lens petzval --wavelength
    run -2 "$LENSRAY" lens petzval --bogus
    # Numbers out of range are bad arguments too (they exited 3, a bad
    # lens's status), with --ghosts as without.
    run -2 "$LENSRAY" lens petzval --field-angles 95
    [[ "$output" == *"field angle 95"* ]]
    run -2 "$LENSRAY" lens petzval --wavelength 100
    [[ "$output" == *"between 300 and 2000 nm, got 100"* ]]
    run -2 "$LENSRAY" lens petzval --ghosts --wavelength 2500
    [[ "$output" == *"got 2500"* ]]
}

@test "--wavelength outside 380 to 780 nm warns that glass formulas may be extrapolated" {
    # The catalogue keeps no fitted range (HIKARI's 400 to 700 nm): at
    # 1500 nm the answer came without a word.
    run -0 --separate-stderr "$LENSRAY" lens petzval --wavelength 1500
    [[ "$stderr" == *"warning: --wavelength 1500: outside 380 to 780 nm"* ]]
    [[ "$output" == *'"wavelength_nm":1500'* ]]
    run -0 --separate-stderr "$LENSRAY" lens petzval --wavelength 780
    [ -z "$stderr" ]
}

@test "a lens whose image circle misses the film: a black picture with a warning" {
    # US 8,879,901's objective covers a 14 mm circle; a corner of a 36 mm
    # film lies outside it: every ray is stopped and the picture is black,
    # which was written without a word (an independent check).
    local scene="$BATS_TEST_TMPDIR/white.json"
    echo '{"camera": {"model": "lens", "lens": "objective-us8879901-36mm-f2", "focus_distance": 10}, "render": {"width": 96, "height": 64, "spp": 4}, "background": 1}' >"$scene"
    run -0 --separate-stderr "$LENSRAY" render "$scene" -o "$BATS_TEST_TMPDIR/a.exr" -q \
        --set 'render.region=[0,0,8,8]'
    [[ "$stderr" == *"the lens stopped every camera ray"* ]]
    # The whole frame passes light in its centre: no warning.
    run -0 --separate-stderr "$LENSRAY" render "$scene" -o "$BATS_TEST_TMPDIR/b.exr" -q
    [ -z "$stderr" ]
    # Night lights through the same lens, planned: the plan traces camera
    # rays only in blocks beyond the circle's edge (all stopped) while
    # the light side lights the picture; it warned that it was black.
    run -0 --separate-stderr "$LENSRAY" render "$BATS_TEST_DIRNAME/../scenes/night-lens.json" \
        -o "$BATS_TEST_TMPDIR/c.exr" -q --set 'camera.lens="objective-us8879901-36mm-f2"' \
        --set render.width=96 --set render.height=54 --set render.spp=8
    [ -z "$stderr" ]
}
