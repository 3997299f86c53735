#!/bin/sh
# isa-matrix.sh: the pixel-hash matrix (tools/pixel-hashes.sh) on every
# code path this CPU can run (issue 28, item 8).  Users' CPUs differ: one
# has AVX-512, another only AVX2 or SSE.  Each run below must render
# every line of the matrix, and its hashes must equal the default run's
# (the same pixels on every CPU, so a farm of mixed machines stitches
# parts without seams); a line that differs is named.
#
#   - Embree forced to each ISA the CPU has, among sse2, sse4.2, avx,
#     avx2 and avx512 (LENSRAY_EMBREE_CONFIG=isa=...; Embree refuses an
#     ISA the CPU lacks, and the run says so and is left out);
#   - lensray's own SIMD forced down to the baseline (the build BASE,
#     made with SIMD='$(SIMD_BASE)': no AVX2 or AVX-512 clone, no AVX2
#     Sobol), with Embree's default and its sse2 code: a CPU without AVX;
#   - and to its AVX2 code (the build AVX2, made with SIMD='$(SIMD_AVX2)':
#     every clone and run-time choice the AVX2 one), with Embree's
#     default: lensray's part of a CPU with AVX2 and without AVX-512, as
#     AMD's Zen 3 (Embree's avx2 code is the run embree-avx2).  Left out,
#     and said so, on a CPU without AVX2 (the build is not made).
#
# Ends "N passed, N failed" (one test a run).  PYTHON: a Python with
# numpy for isa_diff.py.  Usage:
#   tools/isa-matrix.sh BUILD BASE [AVX2]
build=${1:-build}
base=${2:-build/simd-base}
avx2=${3:-}
python=${PYTHON:-python3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
pass=0
fail=0

# run NAME BUILD CONFIG: the matrix with that build and Embree config,
# its hashes in NAME.txt and its images in NAME/.
run() {
    name=$1
    mkdir -p "$tmp/$name"
    KEEP="$tmp/$name" LENSRAY_EMBREE_CONFIG=$3 \
        sh tools/pixel-hashes.sh "$2" >"$tmp/$name.txt" 2>&1
}

# check NAME EXACT: every line rendered, with the default run's hashes
# (EXACT 1) or the same picture (EXACT 0).
check() {
    name=$1
    lines=$(wc -l <"$tmp/$name.txt")
    bad=$(grep -c FAILED "$tmp/$name.txt")
    differ=$(diff "$tmp/default.txt" "$tmp/$name.txt" | grep -c '^>')
    if [ "$bad" -ne 0 ] || [ "$lines" -ne "$want" ]; then
        echo "FAIL $name: $lines renders of $want, $bad failed:"
        grep FAILED "$tmp/$name.txt" | head -5
        fail=$((fail + 1))
    elif [ "$differ" -eq 0 ]; then
        echo "ok   $name: $lines renders, every hash the default's"
        pass=$((pass + 1))
    elif [ "$2" -eq 0 ] && "$python" tools/isa_diff.py "$tmp/default" \
        "$tmp/$name" >"$tmp/$name.diff"; then
        echo "ok   $name: $lines renders, $differ hashes differ, the same picture:"
        cat "$tmp/$name.diff"
        pass=$((pass + 1))
    else
        echo "FAIL $name: $lines renders, $differ hashes differ from the default's:"
        diff "$tmp/default.txt" "$tmp/$name.txt" | grep '^>' | head -10
        [ ! -s "$tmp/$name.diff" ] || cat "$tmp/$name.diff"
        fail=$((fail + 1))
    fi
}

run default "$build" ""
want=$(wc -l <"$tmp/default.txt")
if grep -q FAILED "$tmp/default.txt" || [ "$want" -lt 100 ]; then
    echo "FAIL default: the matrix did not render:"
    grep FAILED "$tmp/default.txt" | head -5
    fail=$((fail + 1))
else
    echo "ok   default: $want renders"
    pass=$((pass + 1))
fi
# The Embree ISAs this CPU takes.
isas=
for isa in sse2 sse4.2 avx avx2 avx512; do
    if LENSRAY_EMBREE_CONFIG="isa=$isa" "$build/lensray" render \
        scenes/accuracy-focus.json -o "$tmp/probe.exr" -q \
        --set render.width=8 --set render.height=8 --set render.spp=1 \
        2>"$tmp/probe.err"; then
        isas="$isas $isa"
    else
        echo "--   embree-$isa: not on this CPU ($(head -c 120 "$tmp/probe.err"))"
    fi
done
# lensray's AVX2 code, where this CPU runs it.
avx2_runs=
if [ -n "$avx2" ] && [ -x "$avx2/lensray" ] &&
    echo " $isas " | grep -q ' avx2 '; then
    avx2_runs="simd-avx2:$avx2:"
elif [ -n "$avx2" ]; then
    echo "--   simd-avx2: not on this CPU (no AVX2)"
fi
# Two runs at a time (a small render leaves a core idle).
set -- $(for isa in $isas; do echo "embree-$isa:$build:isa=$isa"; done) \
    "simd-base:$base:" "simd-base-sse2:$base:isa=sse2" $avx2_runs
while [ $# -gt 0 ]; do
    a=$1
    shift
    run "${a%%:*}" "$(echo "$a" | cut -d: -f2)" "${a##*:}" &
    if [ $# -gt 0 ]; then
        b=$1
        shift
        run "${b%%:*}" "$(echo "$b" | cut -d: -f2)" "${b##*:}"
    fi
    wait
done
for isa in $isas; do
    check "embree-$isa" 0
done
check simd-base 1
check simd-base-sse2 0
[ -z "$avx2_runs" ] || check simd-avx2 1
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
