#!/bin/sh
# bench/run.sh: the benchmark behind `make bench` (see bench/README.md).
#
# Usage: sh bench/run.sh [BUILD_DIR]      (default build; run from the repo root)
#
# In one run, on scenes/bench.json:
#   1. the bare-Embree ceiling (build/bench/ceiling, from bench/ceiling.c);
#   2. lensray at 1 thread and at all threads, best of BENCH_REPEAT runs, as
#      shipped (effect planning and adaptive sampling on), with every
#      sample traced (render.plan=false, render.adaptive=false), and so
#      without robust traversal (accel.robust=false, Mitsuba's default);
#   3. Mitsuba 3.9.1 (llvm_ad_rgb, also with robust traversal, and
#      scalar_rgb), from a virtual
#      environment under BUILD_DIR/bench/venv, when it can be installed;
#      then lensray and Mitsuba llvm_ad_rgb per sample in interleaved
#      rounds, like for like (bench/persample.py, issue 17's target);
#   4. both renderers at BENCH_REF_SPP spp, and the mean relative difference
#      between the pictures;
#   5. peak memory;
#   6. the Python package's scene.render() against the CLI for a one-second
#      render (bench/python_overhead.py);
#   7. a real lens: the double Gauss against the thin lens (bench/lens.py),
#      and the planner through it, in focus at f/11 and on the scene built
#      to fool it (bench/lens_plan.py);
#   8. the path-traced Cornell box, the box with the bunny, and the box
#      with a sphere lamp at max depth 64, against Mitsuba llvm_ad_rgb
#      `path` (bench/path/speed.py); the bench scene's time to relMSE 1e-5
#      against Mitsuba's samplers (bench/bunny_time.py);
#   9. the farm: a batch of parts on 1 and 2 daemons behind nginx, and a
#      frame whole against 16 parts (bench/farm.sh).
# Raw outputs go to BUILD_DIR/bench/*.log; bench/summary.py prints the table
# and writes BUILD_DIR/bench/results.txt.
#
# Knobs (environment): BENCH_SPP (lensray timing spp, default 256),
# BENCH_REPEAT (3), BENCH_REF_SPP (1024), BENCH_MI_SPP (llvm timing spp,
# 64), BENCH_MI_SCALAR_SPP (16), BENCH_PS_ROUNDS (interleaved rounds, 9),
# BENCH_SKIP_MITSUBA=1, BENCH_SAME_NORMALS=0
# (skips the diagnostic render), BENCH_SKIP_LENS_PLAN=1,
# BENCH_SKIP_BUNNY_TIME=1, DRJIT_LIBLLVM_PATH.
set -u

BUILD=${1:-build}
OUT=$BUILD/bench
LENSRAY=$BUILD/lensray
CEILING=$OUT/ceiling
SCENE=scenes/bench.json
SPP=${BENCH_SPP:-256}
REPEAT=${BENCH_REPEAT:-3}
REF_SPP=${BENCH_REF_SPP:-1024}
MI_SPP=${BENCH_MI_SPP:-64}
MI_SCALAR_SPP=${BENCH_MI_SCALAR_SPP:-16}
PS_ROUNDS=${BENCH_PS_ROUNDS:-9}
VENV=$OUT/venv
NPROC=$(nproc)

mkdir -p "$OUT"
rm -f "$OUT"/*.log "$OUT"/results.txt
say() { echo "bench: $*"; }

[ -x "$LENSRAY" ] || { say "no $LENSRAY (run make)"; exit 1; }
[ -x "$CEILING" ] || { say "no $CEILING (run make bench)"; exit 1; }
command -v python3 >/dev/null 2>&1 || { say "python3 is needed (apt-get install python3)"; exit 1; }

# ---- how busy is the machine? --------------------------------------------
# Cores kept busy by other processes over one second (from /proc/stat).
busy_cores() {
    a=$(awk '/^cpu /{print $2+$3+$4+$7+$8, $5+$6}' /proc/stat)
    sleep 1
    b=$(awk '/^cpu /{print $2+$3+$4+$7+$8, $5+$6}' /proc/stat)
    echo "$a $b $NPROC" | awk '{bu=$3-$1; id=$4-$2; t=bu+id; if (t<=0) t=1; printf "%.2f", $5*bu/t}'
}
# Waits (up to 15 s) for the other processes to leave the cores alone, and
# logs how busy the machine was before each section.
quiet() {
    n=0
    while :; do
        bc=$(busy_cores)
        if awk "BEGIN{exit !($bc < 0.25)}"; then break; fi
        n=$((n + 1))
        if [ $n -ge 8 ]; then
            say "warning: the machine is busy ($bc cores used by other processes) before $1; measuring anyway"
            break
        fi
        sleep 1
    done
    echo "$1 $bc" >> "$OUT/busy.log"
}

# ---- the machine -----------------------------------------------------------
{
    echo "date: $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
    echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet HEAD -- lib include tools 2>/dev/null || echo ' (lib/include/tools modified)')"
    echo "nproc: $NPROC"
    echo "cpu: $(awk -F': ' '/^model name/{print $2; exit}' /proc/cpuinfo)"
    echo "memory: $(awk '/^MemTotal/{printf "%.1f GiB", $2/1048576}' /proc/meminfo)"
    echo "kernel: $(uname -r)"
    echo "os: $(. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME")"
    echo "embree: $(dpkg-query -W -f '${Version}' libembree3-3 2>/dev/null || echo unknown)"
    echo "cc: $(${CC:-cc} --version | head -1)"
    echo "spp: $SPP  repeat: $REPEAT  ref_spp: $REF_SPP  mitsuba_spp: llvm $MI_SPP, scalar $MI_SCALAR_SPP"
} > "$OUT/machine.log"
cat "$OUT/machine.log"

# ---- 1. the ceiling ----------------------------------------------------------
quiet ceiling
say "bare Embree ceiling ($CEILING)"
"$CEILING" --obj scenes/meshes/bunny.obj --threads "$NPROC" --repeat 5 \
    > "$OUT/ceiling.log" 2>&1 || say "the ceiling failed (see $OUT/ceiling.log)"
grep -v '^RESULT' "$OUT/ceiling.log"

# ---- 2. lensray --------------------------------------------------------------
# The probe also gives the CPU time of everything but the render (loading,
# the BVH, writing), taken off each run's CPU time for the estimates.
FULL="--set render.plan=false --set render.adaptive=false"
probe() {
    python3 bench/cputime.py "$LENSRAY" render "$SCENE" -o "$OUT/probe.exr" --quiet "$@" \
        --set render.width=8 --set render.height=8 --set render.spp=1 2>/dev/null
}
if ! probe $FULL > "$OUT/probe.log"; then
    FULL=""   # a lensray without render.plan / render.adaptive
    say "this lensray has no render.plan/render.adaptive: one mode only"
    probe > "$OUT/probe.log"
fi
OVERHEAD=$(sed -n 's/^CPUTIME cpu_seconds=\([0-9.]*\).*/\1/p' "$OUT/probe.log")
echo "OVERHEAD cpu_seconds=${OVERHEAD:-0}" >> "$OUT/lensray.log"
rm -f "$OUT/probe.exr"
# "fast": every sample traced without Embree's robust traversal
# (accel.robust=false), which is how Mitsuba traces by default: the
# like-for-like pair of its llvm run (Mitsuba with robust traversal is
# the pair of "full").
for mode in default full fast; do
    if [ $mode = full ]; then
        [ -n "$FULL" ] || continue
        sets=$FULL
    elif [ $mode = fast ]; then
        [ -n "$FULL" ] || continue
        sets="$FULL --set accel.robust=false"
    else
        sets=""
    fi
    for t in 1 $NPROC; do
        [ $t = 1 ] || [ $NPROC -gt 1 ] || continue
        quiet "lensray-$mode-$t"
        say "lensray $mode, $t thread(s), $SPP spp, $REPEAT runs"
        r=0
        while [ $r -lt $REPEAT ]; do
            out=$(python3 bench/cputime.py "$LENSRAY" render "$SCENE" \
                   -o "$OUT/lensray-timing.exr" --quiet \
                   --stats --set render.spp="$SPP" --set render.threads="$t" $sets)
            rc=$?
            if [ $rc -ne 0 ]; then
                say "lensray failed (exit $rc)"
                break
            fi
            line=$(echo "$out" | grep '^{')
            cpu=$(echo "$out" | sed -n 's/^CPUTIME cpu_seconds=\([0-9.]*\).*/\1/p')
            echo "LENSRAY mode=$mode threads=$t cpu_seconds=$cpu $line" >> "$OUT/lensray.log"
            echo "$line" | sed 's/, "plan".*//; s/^/  /'
            r=$((r + 1))
        done
    done
done
rm -f "$OUT/lensray-timing.exr"

# ---- 3. Mitsuba --------------------------------------------------------------
. bench/mitsuba_env.sh
mitsuba_ok=0
if [ "${BENCH_SKIP_MITSUBA:-0}" = 1 ]; then
    echo "MITSUBA_UNAVAILABLE skipped (BENCH_SKIP_MITSUBA=1)" > "$OUT/mitsuba.log"
else
    mitsuba_setup "$VENV" "$OUT/pip.log" > "$OUT/mitsuba.log"
fi

if [ $mitsuba_ok = 1 ]; then
    mitsuba_llvm
    echo "llvm: ${DRJIT_LIBLLVM_PATH:-none found (needs libllvm >= 16, e.g. apt-get install libllvm19)}" >> "$OUT/machine.log"
    MI="$VENV/bin/python bench/mitsuba_bench.py --obj scenes/meshes/bunny.obj"
    if [ -n "$DRJIT_LIBLLVM_PATH" ]; then
        quiet mitsuba-llvm
        say "Mitsuba llvm_ad_rgb, $MI_SPP and $((2 * MI_SPP)) spp (LLVM: $DRJIT_LIBLLVM_PATH)"
        $MI --variant llvm_ad_rgb --spp "$MI_SPP" --repeat 3 >> "$OUT/mitsuba.log" 2>"$OUT/mitsuba-llvm.err" ||
            echo "MITSUBA_FAILED llvm_ad_rgb (exit $?): $(tail -1 "$OUT/mitsuba-llvm.err")" >> "$OUT/mitsuba.log"
        quiet mitsuba-llvm-robust
        say "Mitsuba llvm_ad_rgb with robust traversal, as lensray's default traces"
        $MI --variant llvm_ad_rgb --spp "$MI_SPP" --repeat 3 --robust >> "$OUT/mitsuba.log" 2>"$OUT/mitsuba-llvm.err" ||
            echo "MITSUBA_FAILED llvm_ad_rgb robust (exit $?): $(tail -1 "$OUT/mitsuba-llvm.err")" >> "$OUT/mitsuba.log"
        # Per sample in interleaved rounds: lensray and Mitsuba back to
        # back, so that the machine's drift falls on both (bench/persample.py).
        quiet persample
        say "per sample, interleaved: lensray and Mitsuba llvm_ad_rgb back to back, $PS_ROUNDS rounds"
        "$VENV/bin/python" bench/persample.py --lensray "$LENSRAY" --scene "$SCENE" \
            --rounds "$PS_ROUNDS" --tmp "$OUT/persample.exr" > "$OUT/persample.log" 2> "$OUT/persample.err" ||
            say "the interleaved per-sample run failed (see $OUT/persample.err)"
        grep '^persample' "$OUT/persample.log"
    else
        echo "MITSUBA_FAILED llvm_ad_rgb: no libLLVM >= 16 (apt-get install libllvm19)" >> "$OUT/mitsuba.log"
    fi
    quiet mitsuba-scalar
    say "Mitsuba scalar_rgb, $MI_SCALAR_SPP and $((2 * MI_SCALAR_SPP)) spp"
    $MI --variant scalar_rgb --spp "$MI_SCALAR_SPP" --repeat 2 >> "$OUT/mitsuba.log" 2>"$OUT/mitsuba-scalar.err" ||
        echo "MITSUBA_FAILED scalar_rgb (exit $?): $(tail -1 "$OUT/mitsuba-scalar.err")" >> "$OUT/mitsuba.log"
    grep '^MITSUBA' "$OUT/mitsuba.log" | cut -c1-200

    # ---- 4. the same picture? -------------------------------------------------
    say "reference images at $REF_SPP spp"
    ref_variant=llvm_ad_rgb
    grep -q '"variant": "llvm_ad_rgb"' "$OUT/mitsuba.log" || ref_variant=scalar_rgb
    $MI --variant $ref_variant --no-timing --ref-spp "$REF_SPP" --out "$OUT/mitsuba.exr" \
        >> "$OUT/mitsuba-ref.log" 2>&1 || say "Mitsuba's reference render failed (see $OUT/mitsuba-ref.log)"
    "$LENSRAY" render "$SCENE" -o "$OUT/lensray.exr" --quiet --stats \
        --set render.spp="$REF_SPP" > "$OUT/lensray-ref.log" 2>&1
    "$LENSRAY" render "$SCENE" -o "$OUT/lensray-seed1.exr" --quiet --stats \
        --set render.spp="$REF_SPP" --set render.seed=1 >> "$OUT/lensray-ref.log" 2>&1
    if [ -e "$OUT/mitsuba.exr" ] && [ -e "$OUT/lensray.exr" ]; then
        "$VENV/bin/python" bench/compare.py "$OUT/lensray.exr" "$OUT/mitsuba.exr" \
            --label "lensray vs Mitsuba $ref_variant" --diff "$OUT/diff.png" >> "$OUT/compare.log" 2>&1
        "$VENV/bin/python" bench/compare.py "$OUT/lensray.exr" "$OUT/lensray-seed1.exr" \
            --label "noise floor: lensray seed 0 vs seed 1" >> "$OUT/compare.log" 2>&1
        # Diagnostic: Mitsuba given lensray's own smooth normals (area-weighted
        # vertex normals written into the OBJ), which removes the one
        # modelling difference between the two scenes.
        if [ "${BENCH_SAME_NORMALS:-1}" = 1 ] && \
           $MI --variant $ref_variant --no-timing --ref-spp "$REF_SPP" --same-normals \
               --out "$OUT/mitsuba-same-normals.exr" >> "$OUT/mitsuba-ref.log" 2>&1; then
            "$VENV/bin/python" bench/compare.py "$OUT/lensray.exr" "$OUT/mitsuba-same-normals.exr" \
                --label "diagnostic: lensray vs Mitsuba given lensray's normals" \
                --diff "$OUT/diff-same-normals.png" >> "$OUT/compare.log" 2>&1
        fi
    fi
else
    [ -s "$OUT/mitsuba.log" ] || echo "MITSUBA_UNAVAILABLE the virtual environment has no mitsuba" > "$OUT/mitsuba.log"
    say "Mitsuba: not available ($(sed 's/^MITSUBA_UNAVAILABLE //' "$OUT/mitsuba.log" | head -1))"
fi

# ---- 5. memory ---------------------------------------------------------------
# Peak RSS of a MEM_W x MEM_H render at MEM_SPP spp (every sample traced,
# written as EXR) against the film's own size plus what the same process
# holds for an 8 x 8 render of the scene (the program, Embree's BVH, the
# mesh): peak_rss_kib of --stats, the process's VmHWM after writing.
MEM_W=${BENCH_MEM_W:-3840}
MEM_H=${BENCH_MEM_H:-2160}
MEM_SPP=${BENCH_MEM_SPP:-64}
say "peak memory: ${MEM_W} x ${MEM_H} at $MEM_SPP spp, and an 8 x 8 render"
base=$("$LENSRAY" render "$SCENE" -o "$OUT/mem-small.exr" --quiet --stats \
        --set render.width=8 --set render.height=8 --set render.spp=1 |
       sed -n 's/.*"peak_rss_kib": \([0-9]*\).*/\1/p')
big=$("$LENSRAY" render "$SCENE" -o "$OUT/mem-big.exr" --quiet --stats $FULL \
        --set render.width="$MEM_W" --set render.height="$MEM_H" --set render.spp="$MEM_SPP" |
      sed -n 's/.*"peak_rss_kib": \([0-9]*\).*/\1/p')
echo "MEMORY width=$MEM_W height=$MEM_H spp=$MEM_SPP film_bytes=$((MEM_W * MEM_H * 12)) base_kib=${base:-0} peak_kib=${big:-0}" > "$OUT/memory.log"
cat "$OUT/memory.log"
rm -f "$OUT/mem-small.exr" "$OUT/mem-big.exr"

# ---- 6. Python -----------------------------------------------------------------
# scene.render() from the Python package against the CLI, for a one-second
# render (bench/python_overhead.py; the venv comes from `make python`).
if [ -x "$BUILD/python/venv/bin/python" ]; then
    quiet python
    say "Python against the CLI, a one-second render"
    "$BUILD/python/venv/bin/python" bench/python_overhead.py --lensray "$LENSRAY" \
        --scene "$SCENE" --repeat "$((REPEAT + 2))" > "$OUT/python.log" 2> "$OUT/python.err" ||
        say "the Python overhead run failed (see $OUT/python.err)"
    cat "$OUT/python.log"
else
    say "Python: no $BUILD/python/venv (make python)"
fi

# ---- 7. a real lens -------------------------------------------------------------
# The double Gauss against the thin lens, in turns (bench/lens.py).
quiet lens
say "a real lens: the double Gauss at f/2.8 against the thin lens, every sample traced"
python3 bench/lens.py "$LENSRAY" "$SCENE" --turns "$((REPEAT + 2))" > "$OUT/lens.log" ||
    say "the real-lens run failed"
cat "$OUT/lens.log"

# The planner through the double Gauss (issue 30; bench/lens_plan.py):
# spheres in focus at f/11 and the scene built to fool the planner, the
# defaults' error and time to the full simulation's error; and the
# spheres in rgb mode (reported, no target).
if [ -x "$BUILD/accuracy/imgdiff" ] && [ "${BENCH_SKIP_LENS_PLAN:-0}" != 1 ]; then
    quiet lens_plan
    say "a real lens planned: in focus at f/11 and the fool scene, against the full simulation"
    rm -f "$OUT/lens_plan.log"
    for c in focus fool focus-rgb; do
        python3 bench/lens_plan.py "$LENSRAY" "$BUILD/accuracy/imgdiff" --case $c \
            --rounds "$((REPEAT + 2))" >> "$OUT/lens_plan.log" ||
            say "the planned-lens run ($c) failed"
    done
    grep '^LENSPLAN' "$OUT/lens_plan.log"
fi

# ---- 8. path tracing -----------------------------------------------------------
# The path-traced Cornell box against Mitsuba llvm_ad_rgb `path`: samples per
# second and time to relative MSE 1e-4 (bench/path/speed.py; reported, not
# asserted).
if [ $mitsuba_ok = 1 ] && [ -n "${DRJIT_LIBLLVM_PATH:-}" ]; then
    quiet path
    say "path tracing: the Cornell box, lensray against Mitsuba llvm_ad_rgb"
    "$VENV/bin/python" bench/path/speed.py --lensray "$LENSRAY" --out "$OUT/path" \
        > "$OUT/path.log" 2> "$OUT/path.err" || say "the path-tracing section failed (see $OUT/path.err)"
    # The same box with the bunny in place of a sphere: 3,674 triangles,
    # which lensray traces with Embree (the box alone is few enough
    # primitives to skip it: docs/path-tracing.md).
    say "path tracing: the box with the bunny (Embree on both sides)"
    "$VENV/bin/python" bench/path/speed.py --lensray "$LENSRAY" --out "$OUT/path" \
        --scene bunny-box >> "$OUT/path.log" 2>> "$OUT/path.err" ||
        say "the bunny-box path run failed (see $OUT/path.err)"
    # Full-length paths (issue 30): the box lit by a sphere lamp at max
    # depth 64 (Mitsuba's 66), ended by roulette alone from the fifth
    # surface on, as both renderers do by default.  Noisier than the
    # rectangle's box: Mitsuba needs some 7000 spp to reach 1e-4, and an
    # 8192-spp reference's own error (8.5e-5) would be most of that.
    say "path tracing: the box with a sphere lamp, max depth 64"
    "$VENV/bin/python" bench/path/speed.py --lensray "$LENSRAY" --out "$OUT/path" \
        --scene cornell-sphere --depth 64 --ref-spp 16384 --max-spp 16384 \
        >> "$OUT/path.log" 2>> "$OUT/path.err" ||
        say "the deep path run failed (see $OUT/path.err)"
else
    echo "PATHSPEED_UNAVAILABLE Mitsuba llvm_ad_rgb is not available" > "$OUT/path.log"
fi
cat "$OUT/path.log"

# The bench scene's time to relMSE 1e-5 against Mitsuba's samplers (issue
# 30; bench/bunny_time.py, references cached in $OUT/bunny-time).
if [ $mitsuba_ok = 1 ] && [ -n "${DRJIT_LIBLLVM_PATH:-}" ] &&
   [ "${BENCH_SKIP_BUNNY_TIME:-0}" != 1 ]; then
    quiet bunny_time
    say "time to relMSE 1e-5 on the bench scene: lensray against Mitsuba's samplers"
    "$VENV/bin/python" bench/bunny_time.py --lensray "$LENSRAY" --work "$OUT/bunny-time" \
        > "$OUT/bunny_time.log" 2> "$OUT/bunny_time.err" ||
        say "the bunny time-to-error run failed (see $OUT/bunny_time.err)"
    tail -8 "$OUT/bunny_time.log"
fi

# ---- 9. the farm ---------------------------------------------------------------
# A batch of parts on 1 and 2 daemons behind nginx, and a frame whole
# against 16 parts (bench/farm.sh, docs/deploy.md).
quiet farm
sh bench/farm.sh "$BUILD" > "$OUT/farm.log" 2>&1 || say "the farm section failed (see $OUT/farm.log)"
cat "$OUT/farm.log"

# ---- summary ---------------------------------------------------------------
python3 bench/summary.py "$OUT" | tee "$OUT/results.txt"
grep '^PATHSPEED' "$OUT/path.log" >> "$OUT/results.txt"
[ -f "$OUT/farm.txt" ] && cat "$OUT/farm.txt" | tee -a "$OUT/results.txt"
