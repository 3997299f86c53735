#!/bin/sh
# bench/farm.sh: the farm's section of `make bench` (docs/deploy.md).
#
#   sh bench/farm.sh BUILD_DIR          (from the repo root)
#
# On scenes/bench.json at 640 x 480 (bench/README.md), with the farm of
# farm/farm.sh on loopback:
#   1. throughput of a batch of parts at render.threads=1: the frame as
#      BENCH_FARM_PARTS parts (default 16) on 1 daemon, then through nginx
#      on 2 (one worker each: on 2 cores, one core per daemon);
#   2. the overhead of splitting: the frame whole (one part) against 16
#      parts, both on one daemon at all threads, one part at a time.
# Each time is the best of BENCH_REPEAT runs (default 3).  The ratios are
# reported, never asserted: this machine is shared.  Output: lines on
# stdout and BUILD_DIR/bench/farm.txt.
set -u
BUILD=${1:-build}
OUT=$BUILD/bench
LENSRAY=$BUILD/lensray
PARTS=${BENCH_FARM_PARTS:-16}
REPEAT=${BENCH_REPEAT:-3}
SPP=${BENCH_FARM_SPP:-64}
DIR=$OUT/farm
mkdir -p "$OUT"
say() { echo "bench: $*"; }

sh farm/farm.sh stop "$BUILD" "$DIR" >/dev/null 2>&1
port=""
for i in 1 2 3 4 5; do
    p=$((20000 + $(od -An -N2 -tu2 /dev/urandom) % 40000))
    if sh farm/farm.sh start "$BUILD" 2 "$p" "$DIR" >"$OUT/farm-start.log" 2>&1; then
        port=$p
        break
    fi
done
[ -n "$port" ] || { say "the farm did not start:"; cat "$OUT/farm-start.log"; exit 1; }
trap 'sh farm/farm.sh stop "$BUILD" "$DIR" >/dev/null 2>&1' EXIT
nginx_url="http://127.0.0.1:$port"
one_url="http://127.0.0.1:$(cat "$DIR/daemon-1.port")"

# The daemons' CPU time so far, in seconds (utime + stime of each pid in
# the farm's pids file, /proc/PID/stat fields 14 and 15): the work a
# render cost them, however busy the machine is.
daemon_cpu() {
    tck=$(getconf CLK_TCK)
    grep '^daemon-' "$DIR/pids" | while read -r _ pid; do
        awk '{print $14 + $15}' "/proc/$pid/stat"
    done | awk -v t="$tck" '{s += $1} END {printf "%.2f", s / t}'
}

# best URL PARTS PARALLEL THREADS: the best wall time of REPEAT renders;
# CPU gets the daemons' CPU seconds per render (the mean).
best() {
    b=""
    c0=$(daemon_cpu)
    for r in $(seq "$REPEAT"); do
        t0=$(date +%s.%N)
        "$LENSRAY" render scenes/bench.json -o "$OUT/farm-out.exr" -q \
            --set render.spp="$SPP" --set render.threads="$4" \
            --remote "$1" --parts "$2" --parallel "$3" || exit 1
        t=$(echo "$t0 $(date +%s.%N)" | awk '{printf "%.3f", $2 - $1}')
        b=$(echo "${b:-$t} $t" | awk '{print ($2 < $1) ? $2 : $1}')
    done
    echo "$b $(echo "$c0 $(daemon_cpu) $REPEAT" | awk '{printf "%.2f", ($2 - $1) / $3}')"
}

# A first render sends the bunny's mesh and loads the scene on both
# daemons (each caches it), so that no timed run pays for that.
best "$nginx_url" 4 4 1 >/dev/null

say "farm: $PARTS parts of scenes/bench.json at $SPP spp, render.threads=1, best of $REPEAT"
t1=$(best "$one_url" "$PARTS" 2 1)
t2=$(best "$nginx_url" "$PARTS" 4 1)
say "farm: 1 daemon $t1, 2 daemons behind nginx $t2 (wall s, daemons' CPU s)"
whole=$(best "$one_url" 1 1 0)
split=$(best "$one_url" 16 1 0)
say "farm: whole frame $whole, as 16 parts $split (one daemon, all threads, one part at a time)"
# The machine is shared: how busy it was, from /proc/loadavg.
load=$(cut -d' ' -f1 /proc/loadavg)
{
    echo "farm (scenes/bench.json 640 x 480, $SPP spp, $(nproc) cores, best of $REPEAT, load average $load):"
    echo "$t1 $t2" | awk '{printf "  batch of '"$PARTS"' parts, render.threads=1: 1 daemon %.3f s, 2 daemons %.3f s: %.2fx (target >= 1.8x); daemons'"'"' CPU %.2f s and %.2f s\n", $1, $3, $1 / $3, $2, $4}'
    echo "$whole $split" | awk '{printf "  one frame whole %.3f s, in 16 parts %.3f s: overhead %+.1f%% wall, %+.1f%% daemon CPU (%.2f s against %.2f s) (target < 5%%)\n", $1, $3, 100 * ($3 / $1 - 1), 100 * ($4 / $2 - 1), $4, $2}'
} | tee "$OUT/farm.txt"
