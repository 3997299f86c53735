#!/bin/sh
# bench/farm.sh: the farm's section of `make bench` (docs/deploy.md).
#
#   sh bench/farm.sh BUILD_DIR          (from the repo root)
#
# On scenes/bench.json at 640 x 480 (bench/README.md), at each sample
# count of BENCH_FARM_SPP (default "64 256": a frame of 0.5 s of one core,
# where the client's own 0.1 s weighs, and one of 2 s, nearer what a farm
# is for), with the farm of farm/farm.sh on loopback:
#   1. throughput of a batch of parts at render.threads=1: the frame as
#      BENCH_FARM_PARTS parts (default 16) on 1 daemon, then through nginx
#      on 2 (one worker each: on 2 cores, one core per daemon); once for
#      one frame, and once for a batch of BENCH_FARM_FRAMES frames
#      (default 4), where the client's start and each frame's writing
#      overlap other frames' parts, as in an animation; the frames are
#      written without compression, and the client's CPU is given with
#      and without ZIP (it shares the daemons' two cores here);
#   2. the overhead of splitting: the frame whole (one part) against 16
#      parts, both on one daemon at all threads, with two workers (the
#      farm's default, farm/farm.sh) and the parts three in flight, so
#      that one part's last tiles overlap the next part and no worker
#      waits for the client.
# Each set-up runs BENCH_FARM_REPEAT times (default 5), in turn with the one it
# is compared with; the least wall time and the least daemon CPU time are
# kept (other load only adds to them), the median over the rounds of the
# two set-ups' ratio in each round is given too (drift between rounds
# does not move it), and the rays and samples the daemons counted show
# the work itself, exactly.  bench/farm_schedule.py then gives what the
# dispatch alone allows for this frame's unequal bands (each band's CPU
# time measured, the farm's dispatch replayed).  The ratios are reported,
# never asserted: this machine is shared.  Output: lines on stdout and
# BUILD_DIR/bench/farm.txt.
set -u
BUILD=${1:-build}
OUT=$BUILD/bench
LENSRAY=$BUILD/lensray
PARTS=${BENCH_FARM_PARTS:-16}
FRAMES=${BENCH_FARM_FRAMES:-4}
REPEAT=${BENCH_FARM_REPEAT:-5}
SPPS=${BENCH_FARM_SPP:-64 256}
DIR=$OUT/farm
mkdir -p "$OUT"
say() { echo "bench: $*"; }

DIR2=$OUT/farm-ov
# start_farm N WORKERS DIR: a farm of N daemons of WORKERS workers on a
# free port; prints the port.
start_farm() {
    sh farm/farm.sh stop "$BUILD" "$3" >/dev/null 2>&1
    for i in 1 2 3 4 5; do
        p=$((20000 + $(od -An -N2 -tu2 /dev/urandom) % 40000))
        if FARM_WORKERS=$2 sh farm/farm.sh start "$BUILD" "$1" "$p" "$3" \
            >"$OUT/farm-start.log" 2>&1; then
            echo "$p"
            return 0
        fi
    done
    say "the farm did not start:" >&2
    cat "$OUT/farm-start.log" >&2
    return 1
}
# The throughput farm: one worker a daemon, so that at render.threads=1
# each daemon is one core.
port=$(start_farm 2 1 "$DIR") || exit 1
trap 'sh farm/farm.sh stop "$BUILD" "$DIR" >/dev/null 2>&1; sh farm/farm.sh stop "$BUILD" "$DIR2" >/dev/null 2>&1' EXIT
port2=$(start_farm 1 2 "$DIR2") || exit 1
nginx_url="http://127.0.0.1:$port"
one_url="http://127.0.0.1:$(cat "$DIR/daemon-1.port")"
ov_url="http://127.0.0.1:$(cat "$DIR2/daemon-1.port")"

# The daemons' CPU time so far, in seconds (utime + stime of each pid in
# the farm's pids file, /proc/PID/stat fields 14 and 15): the work a
# render cost them, however busy the machine is.
daemon_cpu() {
    tck=$(getconf CLK_TCK)
    grep -h '^daemon-' "$DIR/pids" "$DIR2/pids" | while read -r _ pid; do
        awk '{print $14 + $15}' "/proc/$pid/stat"
    done | awk -v t="$tck" '{s += $1} END {printf "%.2f", s / t}'
}

# metric NAME: NAME (a counter of /metrics) summed over the daemons.
metric() {
    for f in "$DIR"/daemon-*.port "$DIR2"/daemon-*.port; do
        curl -s "http://127.0.0.1:$(cat "$f")/metrics" | sed -n "s/^$1 //p"
    done | awk '{s += $1} END {printf "%.0f", s}'
}

# once URL PARTS PARALLEL THREADS [FRAMES]: one render of FRAMES frames
# (default 1) of the bench scene; prints its wall seconds,
# the daemons' CPU seconds, and the rays, samples and scene-cache misses
# the daemons counted for it (exact, whatever the load).
once() {
    c0=$(daemon_cpu) r0=$(metric lensrayd_rays_traced_total)
    s0=$(metric lensrayd_samples_total) m0=$(metric lensrayd_scene_cache_misses_total)
    scenes=$(for f in $(seq "${5:-1}"); do echo scenes/bench.json; done)
    t0=$(date +%s.%N)
    # The client's CPU seconds, from the cutime and cstime (fields 16 and
    # 17 of /proc/PID/stat) of the shell that waited for it, into
    # $OUT/farm-client.last.
    # shellcheck disable=SC2016,SC2086
    sh -c '"$@" || exit 1
           awk -v t="$(getconf CLK_TCK)" "{printf \"%.3f\\n\", (\$16 + \$17) / t}" /proc/$$/stat' \
        sh "$LENSRAY" render $scenes -o "$OUT/farm-out%d.exr" -q \
        --set render.spp="$SPP" --set render.threads="$4" --compression "$COMP" \
        --remote "$1" --parts "$2" --parallel "$3" >"$OUT/farm-client.last" || exit 1
    t1=$(date +%s.%N)
    echo "$t0 $t1 $c0 $(daemon_cpu) $r0 $(metric lensrayd_rays_traced_total)" \
         "$s0 $(metric lensrayd_samples_total) $m0 $(metric lensrayd_scene_cache_misses_total)" |
        awk '{printf "%.3f %.2f %d %d %d\n", $2 - $1, $4 - $3, $6 - $5, $8 - $7, $10 - $9}'
}

# pair A B: REPEAT renders of each of the two set-ups (each "URL PARTS
# PARALLEL THREADS"), taken in turn so that a change in the machine's
# load falls on both; prints for each the least wall and the least CPU
# (a busy machine only ever adds to either), then its rays, samples and
# cache misses (of the last run; they do not vary), with B's client CPU
# of each round in $OUT/farm-cb.txt:
# "wallA cpuA raysA samplesA missesA wallB cpuB raysB samplesB missesB
# median(wallA / wallB)".
pair() {
    : >"$OUT/farm-a.txt"
    : >"$OUT/farm-b.txt"
    : >"$OUT/farm-cb.txt"
    for r in $(seq "$REPEAT"); do
        # shellcheck disable=SC2086
        once $1 >>"$OUT/farm-a.txt"
        # shellcheck disable=SC2086
        once $2 >>"$OUT/farm-b.txt"
        cat "$OUT/farm-client.last" >>"$OUT/farm-cb.txt"
    done
    for f in "$OUT/farm-a.txt" "$OUT/farm-b.txt"; do
        awk 'NR == 1 || $1 < w {w = $1} NR == 1 || $2 < c {c = $2}
             {r = $3; s = $4; m = $5} END {printf "%.3f %.2f %d %d %d ", w, c, r, s, m}' "$f"
    done
    # The median over the rounds of A's wall over B's in the same round:
    # a second estimate, which drift between rounds does not move.
    paste "$OUT/farm-a.txt" "$OUT/farm-b.txt" | awk '{print $1 / $6}' | sort -g |
        awk '{v[NR] = $1} END {printf "%.4f\n", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'
}

# A first render sends the bunny's mesh and loads the scene on both
# daemons (each caches it), so that no timed run pays for that.
SPP=16 COMP=zip
once "$nginx_url" 4 4 1 >/dev/null
once "$nginx_url" 4 4 1 >/dev/null
once "$ov_url" 2 2 0 >/dev/null

# pair_at SPP: both comparisons at SPP samples a pixel; prints the
# throughput pair's line, then the overhead pair's.
pair_at() {
    SPP=$1
    say "farm: $PARTS parts of scenes/bench.json at $SPP spp, render.threads=1, best of $REPEAT"
    # The frames are written without compression: the daemons' throughput
    # is what is measured, and the client's ZIP encoding of the stitched
    # frame (about 30 ms of CPU a 640 x 480 frame) would run here on the
    # daemons' two cores, where a farm's client has a machine of its own.
    # Its cost is measured apart below.
    COMP=none
    tp=$(pair "$one_url $PARTS 2 1" "$nginx_url $PARTS 4 1")
    say "farm: 1 daemon, 2 daemons behind nginx: $tp"
    say "farm: the same for a batch of $FRAMES frames"
    tpb=$(pair "$one_url $PARTS 2 1 $FRAMES" "$nginx_url $PARTS 4 1 $FRAMES")
    say "farm: $FRAMES frames, 1 daemon, 2 daemons behind nginx: $tpb"
    # The client's least CPU over the 2-daemon batch runs, and that of one
    # more such batch written with ZIP (the default).
    cnone=$(sort -g "$OUT/farm-cb.txt" | head -1)
    COMP=zip
    once "$nginx_url" "$PARTS" 4 1 "$FRAMES" >/dev/null
    czip=$(cat "$OUT/farm-client.last")
    say "farm: the client's CPU for $FRAMES frames, written without compression and with ZIP: $cnone $czip"
    echo "$SPP $cnone $czip" >>"$OUT/farm-client.txt"
    # What two cores give the same frame here and now, without the farm:
    # a local render on 1 thread against 2 (this VM's own 2-core scaling
    # drifts between runs), least wall of REPEAT each, taken in turn.
    lc=$(for r in $(seq "$REPEAT"); do
        for t in 1 2; do
            t0=$(date +%s.%N)
            "$LENSRAY" render scenes/bench.json -o "$OUT/farm-local.exr" -q \
                --set render.spp="$SPP" --set render.threads="$t"
            echo "$t $t0 $(date +%s.%N)"
        done
    done | awk '{d = $3 - $2; if (!($1 in m) || d < m[$1]) m[$1] = d}
                END {printf "%.3f %.3f", m[1], m[2]}')
    say "farm: the frame rendered locally on 1 and 2 threads: $lc"
    echo "$SPP $lc" >>"$OUT/farm-local.txt"
    # Three parts in flight on the daemon's two workers, so that the
    # next part waits in its queue while the client takes the last one
    # in: the daemon never idles for a round trip (as --parallel is meant
    # to be used).
    COMP=zip
    say "farm: whole frame against 16 parts, one daemon of 2 workers, all threads, 3 parts in flight"
    ov=$(pair "$ov_url 1 1 0" "$ov_url 16 3 0")
    say "farm: whole, 16 parts: $ov"
    echo "$SPP $tp" >>"$OUT/farm-tp.txt"
    echo "$SPP $tpb" >>"$OUT/farm-tpb.txt"
    echo "$SPP $ov" >>"$OUT/farm-ov.txt"
}
: >"$OUT/farm-tp.txt"
: >"$OUT/farm-tpb.txt"
: >"$OUT/farm-ov.txt"
: >"$OUT/farm-local.txt"
: >"$OUT/farm-client.txt"
for spp in $SPPS; do
    pair_at "$spp"
done
# A part's fixed cost: the daemons' CPU for 100 one-row parts at 1 spp
# (parsing, the scene cache, the plan, threads, the EXR, HTTP), asked
# straight with curl so that the client's share is left out.
body='{"scene": "bench", "render": {"spp": 1, "threads": 0, "region": [0, 100, 640, 101]}, "output": {"format": "exr", "compression": "none"}}'
c0=$(daemon_cpu)
for i in $(seq 100); do
    curl -s -o /dev/null -H 'Content-Type: application/json' -d "$body" "$one_url/v1/render"
done
fixed=$(echo "$c0 $(daemon_cpu)" | awk '{printf "%.2f", 10 * ($2 - $1)}')
say "farm: a part's fixed cost $fixed ms"
# What the schedule alone allows for this frame: each band's CPU time
# measured here, the dispatch replayed (bench/farm_schedule.py).
: >"$OUT/farm-sched.txt"
for spp in $SPPS; do
    echo "$spp $(python3 bench/farm_schedule.py "$LENSRAY" scenes/bench.json \
        "$spp" "$PARTS" "$FRAMES" "$fixed")" >>"$OUT/farm-sched.txt"
done
# The machine is shared: how busy it was, from /proc/loadavg.
load=$(cut -d' ' -f1 /proc/loadavg)
{
    echo "farm (scenes/bench.json 640 x 480, $(nproc) cores, least of $REPEAT runs taken in turn, load average $load):"
    awk -v n="$PARTS" '{printf "  %d spp, a batch of %d parts, render.threads=1: 1 daemon %.3f s, 2 daemons %.3f s: %.2fx wall, median of the rounds %.2fx (target >= 1.8x); daemons'"'"' CPU %.2f s and %.2f s (%.1f ms and %.1f ms a part)\n", $1, n, $2, $7, $2 / $7, $12, $3, $8, 1000 * $3 / n, 1000 * $8 / n}' "$OUT/farm-tp.txt"
    awk -v n="$PARTS" -v f="$FRAMES" '{printf "  %d spp, a batch of %d frames of %d parts, render.threads=1: 1 daemon %.3f s, 2 daemons %.3f s (%.3f s and %.3f s a frame): %.2fx wall, median of the rounds %.2fx (target >= 1.8x); daemons'"'"' CPU %.2f s and %.2f s\n", $1, f, n, $2, $7, $2 / f, $7 / f, $2 / $7, $12, $3, $8}' "$OUT/farm-tpb.txt"
    awk -v n="$PARTS" -v f="$FRAMES" '{split($4, c, ","); lo = hi = c[1]; for (i in c) {if (c[i] + 0 < lo + 0) lo = c[i]; if (c[i] + 0 > hi + 0) hi = c[i]}
        printf "  %d spp, the schedule alone (bench/farm_schedule.py: this frame'"'"'s %d bands, %s to %s ms of CPU each, dispatched as above, no other effect): 2 daemons against 1 at most %.2fx for one frame, %.2fx for %d frames\n", $1, n, lo, hi, $2, $3, f}' "$OUT/farm-sched.txt"
    awk -v f="$FRAMES" '{printf "  %d spp, the client'"'"'s CPU (stitching, writing) on the same two cores: %.1f ms a frame written without compression (as above), %.1f ms with ZIP, the default\n", $1, 1000 * $2 / f, 1000 * $3 / f}' "$OUT/farm-client.txt"
    awk '{printf "  %d spp, the same frame rendered locally (no farm): 1 thread %.3f s, 2 threads %.3f s: %.2fx, what two cores gave here in this run\n", $1, $2, $3, $2 / $3}' "$OUT/farm-local.txt"
    awk '{printf "  %d spp, one frame whole %.3f s, in 16 parts %.3f s: overhead %+.1f%% wall (median of the rounds %+.1f%%), %+.1f%% daemon CPU (%.2f s against %.2f s), %+.2f%% rays, %+.2f%% samples, scene loads %d and %d (target < 5%%)\n", $1, $2, $7, 100 * ($7 / $2 - 1), 100 * (1 / $12 - 1), 100 * ($8 / $3 - 1), $8, $3, 100 * ($9 / $4 - 1), 100 * ($10 / $5 - 1), $6, $11}' "$OUT/farm-ov.txt"
    head -1 "$OUT/farm-ov.txt" | awk -v f="$fixed" '{printf "  a part'"'"'s fixed cost %.2f ms of daemon CPU (100 one-row parts at 1 spp): 16 parts add %.1f%% to the %d-spp whole frame'"'"'s %.2f s\n", f, 100 * 16 * f / 1000 / $3, $1, $3}'
} | tee "$OUT/farm.txt"
