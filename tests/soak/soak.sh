#!/usr/bin/env bash
# soak.sh: a bounded soak and abuse run of lensrayd, on the loopback
# interface only.
#
#     tests/soak/soak.sh [SECONDS [BUILD_DIR]]      (default 20, build)
#
# Starts build/lensrayd on a free 127.0.0.1 port with small limits, warms
# it up, then for SECONDS runs at once:
#   - synchronous renders (POST /v1/render, 32x24, spp 4; PNG, EXR, thin
#     lens, and inline scenes in 24 variants that churn the scene cache);
#   - queued jobs created in bursts past the queue's size (429s) and then
#     cancelled, polled, fetched and deleted, on the job table's edge;
#   - abuse: bodies over --max-body (declared and chunked), a header over
#     the connection memory, wrong and missing content types, malformed
#     JSON, text after the JSON, nesting 100000 deep, bad values, unknown
#     scenes, routes, methods and jobs, bodies that stop short then close,
#     and garbage request lines;
#   - slow clients (slowloris, over bash's /dev/tcp): requests dribbled a
#     few bytes at a time, requests and bodies that stop half way and go
#     silent (the daemon must close them after --connection-timeout);
#   - a monitor that samples the daemon's VmRSS, threads and descriptors
#     (/proc/PID) and GET /healthz every second.
# Then it waits for the load to drain, checks that threads and descriptors
# are back near where they started and that /healthz answers, and ends with
# the shutdown: SIGTERM while synchronous renders and queued jobs are in
# flight, requests on new and on already open connections during the
# shutdown, and the exit status.
#
# Every request is logged with the status it got and whether that status
# is one the API documents for it; the summary is printed and written to
# BUILD_DIR/soak/summary.txt (samples in samples.tsv, the daemon's log in
# lensrayd.log, surprises in unexpected.log).  Exit status 0 when every
# check passes:
#   - no status outside what docs/api.md documents for the request, no 5xx
#     at all before the shutdown and none but 503 during it;
#   - no connection failures before the shutdown;
#   - RSS: the mean of the last quarter of the run, after a warm-up of a
#     fifth of it, at most 8 MiB above the first quarter's (no growth);
#   - threads and descriptors back within 2 of the warmed-up baseline;
#   - /healthz 200 "ok" at the end of the load;
#   - the daemon exits 0 after SIGTERM, in time.
#
# Bounded: each client stops at the deadline or after a fixed number of
# requests, every curl has --max-time, the daemon it started is killed by
# its pid on any exit (and the clients by theirs).  Environment:
# SOAK_RENDERERS (3), SOAK_SLOW (6) clients of each kind; SOAK_OUT for
# the output directory; SOAK_MALLOC=default for glibc's malloc defaults
# (see below); SOAK_NO_ARENA_WARMUP=1 to leave out the warm-up's uploads.
# Under AddressSanitizer (make test-sanitize) the RSS check is skipped:
# ASan's quarantine keeps freed memory on purpose.

set -u

DURATION=${1:-20}
BUILD=${2:-${LENSRAY_BUILD:-build}}
REPO=$(cd "$(dirname "$0")/../.." && pwd)
case $BUILD in /*) ;; *) BUILD="$REPO/$BUILD" ;; esac
LENSRAYD=$BUILD/lensrayd
OUT=${SOAK_OUT:-$BUILD/soak}
RENDERERS=${SOAK_RENDERERS:-3}
SLOW=${SOAK_SLOW:-6}

# The daemon's limits: small, so that the load reaches them.
WORKERS=2
QUEUE=8
MAX_CONN=64
CONN_TIMEOUT=3
GRACE=3
MAX_BODY=8M

case $DURATION in '' | *[!0-9]*) echo "soak: SECONDS must be a whole number" >&2; exit 2 ;; esac
[ "$DURATION" -ge 5 ] || { echo "soak: run for at least 5 seconds" >&2; exit 2; }
[ -x "$LENSRAYD" ] || { echo "soak: $LENSRAYD not found (run make first)" >&2; exit 2; }
command -v curl >/dev/null || { echo "soak: curl is needed" >&2; exit 2; }

WORK=$OUT/work
SUMMARY=$OUT/summary.txt
SAMPLES=$OUT/samples.tsv
DLOG=$OUT/lensrayd.log
UNEXPECTED=$OUT/unexpected.log
# Only what an earlier run left: OUT may be shared with other files.
rm -rf "$WORK"
rm -f "$SUMMARY" "$SAMPLES" "$DLOG" "$UNEXPECTED" "$OUT/requests.log" "$OUT/metrics.txt"
mkdir -p "$WORK/scenes" "$WORK/logs" "$WORK/tmp"
: >"$UNEXPECTED"

# The caller's LENSRAYD_* variables must not change the daemon.
for v in $(env | sed -n 's/^\(LENSRAYD_[A-Z_]*\)=.*/\1/p'); do unset "$v"; done

# ---- cleanup: the daemon and the clients, by pid, whatever happens --------
DPID=""
CLIENT_PIDS=()
cleanup() {
    local pid kid
    for pid in "${CLIENT_PIDS[@]}"; do
        if kill -0 "$pid" 2>/dev/null; then
            for kid in $(ps -o pid= --ppid "$pid" 2>/dev/null); do
                kill "$kid" 2>/dev/null
            done
            kill "$pid" 2>/dev/null
        fi
    done
    if [ -n "$DPID" ] && kill -0 "$DPID" 2>/dev/null; then
        kill -TERM "$DPID" 2>/dev/null
        for _ in $(seq 1 50); do
            kill -0 "$DPID" 2>/dev/null || break
            sleep 0.1
        done
        kill -KILL "$DPID" 2>/dev/null
    fi
    rm -f "$WORK/big.json" "$WORK/deep.json"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
# A write to a connection the daemon has closed must fail, not kill us.
trap '' PIPE

# ---- inputs ---------------------------------------------------------------
# The small scene daemon.bats uses too.
cp "$REPO/tests/data/tiny.json" "$WORK/scenes/tiny.json"
# Over --max-body (8 MiB), and a body nested 100000 deep (under it).
head -c $((9 * 1024 * 1024)) /dev/zero | tr '\0' ' ' >"$WORK/big.json"
{
    printf '{"scene": "tiny", "render": '
    head -c 100000 /dev/zero | tr '\0' '['
} >"$WORK/deep.json"
BIG_HEADER=$(head -c 70000 /dev/zero | tr '\0' 'h')

# ---- the daemon -----------------------------------------------------------
# The RSS check looks for leaks, so RSS should follow the live heap.  With
# glibc's defaults it does not: after the first large free, its dynamic
# mmap threshold keeps freed request bodies (up to --max-body, 8 MiB) in
# the per-thread malloc arenas, and RSS climbs in 8 MiB steps to a plateau
# of about (arenas in use) x 8 MiB, in the order threads happen to take
# arenas.  A fixed 1 MiB threshold sends large blocks to mmap, which gives
# them back when freed.  SOAK_MALLOC=default runs with glibc's defaults
# (docs/reliability.md has both).
case ${SOAK_MALLOC:-tuned} in
tuned) MALLOC_ENV=(GLIBC_TUNABLES=glibc.malloc.mmap_threshold=1048576) ;;
default) MALLOC_ENV=() ;;
*) echo "soak: SOAK_MALLOC is tuned or default" >&2; exit 2 ;;
esac
env "${MALLOC_ENV[@]}" "$LENSRAYD" --port 0 --bind 127.0.0.1 --scenes "$WORK/scenes" \
    --workers "$WORKERS" --queue "$QUEUE" --max-connections "$MAX_CONN" \
    --max-connections-per-ip 48 --connection-timeout "$CONN_TIMEOUT" \
    --shutdown-grace "$GRACE" --max-body "$MAX_BODY" --job-ttl 20 \
    --max-finished-jobs 40 --scene-cache 8 --max-render-seconds 60 \
    >"$DLOG" 2>&1 3>&- &
DPID=$!
PORT=""
for _ in $(seq 1 200); do
    PORT=$(sed -n 's|^lensrayd: listening on http://127\.0\.0\.1:\([0-9]*\) .*|\1|p' "$DLOG")
    [ -n "$PORT" ] && break
    kill -0 "$DPID" 2>/dev/null || break
    sleep 0.05
done
if [ -z "$PORT" ]; then
    echo "soak: lensrayd did not start:" >&2
    cat "$DLOG" >&2
    exit 1
fi
URL=http://127.0.0.1:$PORT
for _ in $(seq 1 100); do
    curl -s -o /dev/null --max-time 2 "$URL/healthz" && break
    sleep 0.05
done

# bash's /dev/tcp is what the slow clients use; a bash built without it
# skips them.
HAVE_TCP=0
if (exec 9<>"/dev/tcp/127.0.0.1/$PORT") 2>/dev/null; then HAVE_TCP=1; fi

# ---- helpers for the clients ----------------------------------------------
PHASE=steady
STOP=$WORK/stop
stop_now() { [ -e "$STOP" ] || [ "$EPOCHSECONDS" -ge "$END" ]; }
usec() { echo "${EPOCHREALTIME/./}"; }

# req LOG KIND EXPECTED CURL-ARGS...: one request.  Appends "PHASE KIND
# CODE ok|bad" to LOG (000: no answer); the body is left in $BODY.
req() {
    local log=$1 kind=$2 expected=$3 code verdict
    shift 3
    code=$(curl -s -o "$BODY" -w '%{http_code}' --max-time 30 "$@" 2>/dev/null)
    [ -n "$code" ] || code=000
    verdict=bad
    [[ $code =~ ^($expected)$ ]] && verdict=ok
    echo "$PHASE $kind $code $verdict" >>"$log"
    if [ $verdict = bad ]; then
        echo "$PHASE $kind: HTTP $code, expected $expected: $(head -c 300 "$BODY" 2>/dev/null | tr '\n' ' ')" >>"$UNEXPECTED"
    fi
    CODE=$code
}

# Is $BODY the image the job asked for?
is_png() { local m; LC_ALL=C IFS= read -r -n 4 m <"$BODY"; [ "$m" = $'\x89PNG' ]; }
is_exr() { local m; LC_ALL=C IFS= read -r -n 4 m <"$BODY"; [ "$m" = $'\x76\x2f\x31\x01' ]; }

inline_scene() {
    # One of 24 variants: more than --scene-cache, so the cache churns.
    local r=$((RANDOM % 24))
    printf '{"scene": {"camera": {"position": [0, 1, 5], "look_at": [0, 0.5, 0], "fov": 40},
      "lights": [{"type": "point", "position": [3, 5, 4], "intensity": 80}],
      "objects": [{"type": "sphere", "center": [0, 1, 0], "radius": 0.%02d},
                  {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}]},
     "render": {"width": 32, "height": 24, "spp": 4, "threads": 1}}' $((r + 50))
}

# ---- clients ----------------------------------------------------------------

render_client() {
    local log=$WORK/logs/render.$1 i body want
    BODY=$WORK/tmp/render.$1
    for ((i = 0; i < 100000; i++)); do
        stop_now && break
        want=png
        case $((i % 4)) in
        0) body='{"scene": "tiny", "render": {"width": 32, "height": 24, "spp": 4, "threads": 1}}' ;;
        1) body='{"scene": "tiny", "render": {"width": 32, "height": 24, "spp": 4, "threads": 1}, "output": {"format": "exr", "half": true}}'
           want=exr ;;
        2) body='{"scene": "tiny", "camera": {"model": "thinlens", "aperture_radius": 0.2, "focus_distance": 4.5},
                  "render": {"width": 32, "height": 24, "spp": 4, "threads": 1}, "output": {"format": "png", "bit_depth": 16}}' ;;
        3) body=$(inline_scene) ;;
        esac
        req "$log" render '200|429' -X POST -H 'Content-Type: application/json' \
            --data-binary "$body" "$URL/v1/render"
        if [ "$CODE" = 200 ]; then
            if { [ $want = png ] && ! is_png; } || { [ $want = exr ] && ! is_exr; }; then
                echo "$PHASE render_image bad_image bad" >>"$log"
                echo "$PHASE render: a 200 whose body is not a $want" >>"$UNEXPECTED"
            fi
        elif [ "$CODE" = 429 ]; then
            sleep 0.1
        fi
    done
}

jobs_client() {
    local log=$WORK/logs/jobs.$1 i k id ids spp
    BODY=$WORK/tmp/jobs.$1
    for ((i = 0; i < 20000; i++)); do
        stop_now && break
        # A burst past the queue's size: the first two jobs (and every
        # fourth) take about a second, so both workers are busy, the queue
        # fills and the last few are refused with 429.
        ids=()
        for ((k = 0; k < QUEUE + 6; k++)); do
            spp=4
            ((k < 2 || k % 4 == 3)) && spp=8000
            req "$log" job_create '202|429' -X POST -H 'Content-Type: application/json' \
                --data-binary "{\"scene\": \"tiny\", \"render\": {\"width\": 32, \"height\": 24, \"spp\": $spp, \"threads\": 1, \"tile_size\": 4, \"adaptive\": false}}" \
                "$URL/v1/jobs"
            if [ "$CODE" = 202 ]; then
                id=$(sed -n 's/.*"id":"\([0-9a-f]*\)".*/\1/p' "$BODY")
                [ -n "$id" ] && ids+=("$id")
            fi
        done
        for id in "${ids[@]}"; do
            case $((RANDOM % 4)) in
            0) # cancel at once
                req "$log" job_delete '200|202|404' -X DELETE "$URL/v1/jobs/$id" ;;
            1) # look, then cancel or drop
                req "$log" job_status '200|404' "$URL/v1/jobs/$id"
                req "$log" job_delete '200|202|404' -X DELETE "$URL/v1/jobs/$id" ;;
            2) # the image: not ready, or ready; then drop the job
                req "$log" job_image '200|409|404' "$URL/v1/jobs/$id/image"
                req "$log" job_delete '200|202|404' -X DELETE "$URL/v1/jobs/$id" ;;
            3) # leave it to finish and expire (--job-ttl, --max-finished-jobs)
                ;;
            esac
        done
        # 404 above only when a finished job was already dropped: the
        # table keeps --max-finished-jobs, and jobs expire after --job-ttl.
        req "$log" job_missing '404' "$URL/v1/jobs/0123456789abcdef0123456789abcdef"
        req "$log" metrics '200' "$URL/metrics"
    done
}

# raw_send KIND BYTES: opens a connection, sends BYTES (printf format),
# closes at once.  Logged with code "sent" (no answer is read).
raw_send() {
    local log=$1 kind=$2 fd
    if exec {fd}<>"/dev/tcp/127.0.0.1/$PORT"; then
        printf "$3" >&"$fd" 2>/dev/null
        exec {fd}>&-
        echo "$PHASE $kind sent ok" >>"$log"
    else
        echo "$PHASE $kind 000 bad" >>"$log"
    fi
}

abuse_client() {
    local log=$WORK/logs/abuse.$1 i
    BODY=$WORK/tmp/abuse.$1
    local J=(-X POST -H 'Content-Type: application/json')
    for ((i = 0; i < 100000; i++)); do
        stop_now && break
        case $((i % 18)) in
        0) req "$log" body_over_limit '413' "${J[@]}" --data-binary "@$WORK/big.json" "$URL/v1/render" ;;
        1) req "$log" body_over_limit_chunked '413' "${J[@]}" -H 'Transfer-Encoding: chunked' \
               --data-binary "@$WORK/big.json" "$URL/v1/jobs" ;;
        2) req "$log" header_over_limit '431' -H "X-Big: $BIG_HEADER" "$URL/healthz" ;;
        3) req "$log" content_type_text '415' -X POST -H 'Content-Type: text/plain' \
               --data-binary '{"scene": "tiny"}' "$URL/v1/render" ;;
        4) req "$log" content_type_none '415' -X POST -H 'Content-Type:' \
               --data-binary '{"scene": "tiny"}' "$URL/v1/jobs" ;;
        5) req "$log" content_type_form '415' -X POST -d 'scene=tiny' "$URL/v1/render" ;;
        6) req "$log" json_malformed '400' "${J[@]}" --data-binary '{"scene": "tiny", "render": {"spp": 4' "$URL/v1/render" ;;
        7) req "$log" json_trailing '400' "${J[@]}" --data-binary '{"scene": "tiny"} {"scene": "tiny"}' "$URL/v1/jobs" ;;
        8) req "$log" json_deep '400' "${J[@]}" --data-binary "@$WORK/deep.json" "$URL/v1/render" ;;
        9) req "$log" json_empty '400' "${J[@]}" --data-binary '' "$URL/v1/render" ;;
        10) req "$log" value_invalid '422' "${J[@]}" \
                --data-binary '{"scene": "tiny", "render": {"spp": -4}, "camera": {"fov": 500}}' "$URL/v1/render" ;;
        11) req "$log" key_unknown '422' "${J[@]}" --data-binary '{"scene": "tiny", "colour": "red"}' "$URL/v1/jobs" ;;
        12) req "$log" scene_unknown '404' "${J[@]}" --data-binary '{"scene": "nosuchscene"}' "$URL/v1/render"
            req "$log" scene_bad_name '422' "${J[@]}" --data-binary '{"scene": "../tiny"}' "$URL/v1/render" ;;
        13) req "$log" route_unknown '404' "$URL/v2/render"
            req "$log" method_wrong '405' -X PUT "$URL/v1/render" ;;
        14) req "$log" image_too_large '413' "${J[@]}" \
                --data-binary '{"scene": "tiny", "render": {"width": 8192, "height": 8192, "spp": 1}}' "$URL/v1/render" ;;
        15) if [ "$HAVE_TCP" = 1 ]; then
                # A body that stops short, then the client leaves.
                raw_send "$log" truncated_body \
                    'POST /v1/render HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 5000\r\n\r\n{"scene": "tiny", "render": {'
                # Headers that stop short, then the client leaves.
                raw_send "$log" truncated_headers 'POST /v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Ty'
            fi ;;
        16) if [ "$HAVE_TCP" = 1 ]; then
                raw_send "$log" garbage_request 'HELLO \x01\x02\x03 WORLD\r\n\r\n'
                raw_send "$log" garbage_binary '\x00\xff\x00\xff\r\n\r\n\r\n'
            fi ;;
        17) req "$log" healthz '200' "$URL/healthz" ;;
        esac
    done
}

# A slow client: dribbles a request a few bytes at a time (the daemon
# must answer it), or stops half way and goes silent (the daemon must
# close it after --connection-timeout).
slow_client() {
    local log=$WORK/logs/slow.$1 i fd text n step t0 first
    for ((i = 0; i < 10000; i++)); do
        stop_now && break
        if ! exec {fd}<>"/dev/tcp/127.0.0.1/$PORT"; then
            echo "$PHASE slow_connect 000 bad" >>"$log"
            sleep 1
            continue
        fi
        case $(((i + $1) % 3)) in
        0) # the whole request, 3 bytes every 0.3 s
            text=$'GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nUser-Agent: slowloris\r\nX-Padding: slow-slow-slow\r\nConnection: close\r\n\r\n'
            n=${#text}
            for ((step = 0; step < n; step += 3)); do
                printf '%s' "${text:step:3}" >&"$fd" 2>/dev/null || break
                stop_now && break
                sleep 0.3
            done
            if ((step >= n)); then
                first=$(timeout 10 head -n 1 <&"$fd" | tr -d '\r')
                case $first in
                "HTTP/1.1 200 "*) echo "$PHASE slow_request 200 ok" >>"$log" ;;
                *) echo "$PHASE slow_request ${first:-000} bad" >>"$log"
                   echo "$PHASE slow_request: got '${first}'" >>"$UNEXPECTED" ;;
                esac
            else
                echo "$PHASE slow_request cut ok" >>"$log"
            fi ;;
        1|2) # half a request, or headers and half a body, then silence
            if (((i + $1) % 3 == 1)); then
                text=$'GET /v1/scenes HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: '
            else
                text=$'POST /v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 4000\r\n\r\n{"scene": "tiny",'
            fi
            printf '%s' "$text" >&"$fd" 2>/dev/null
            t0=$(usec)
            # The daemon closes the connection: cat sees the end.
            if timeout $((CONN_TIMEOUT + 5)) cat <&"$fd" >/dev/null 2>&1; then
                echo "$PHASE slow_silent closed_in_$(( ($(usec) - t0 + 500000) / 1000000 ))s ok" >>"$log"
            else
                echo "$PHASE slow_silent not_closed bad" >>"$log"
                echo "$PHASE slow_silent: the daemon kept a silent connection open for $((CONN_TIMEOUT + 5)) s" >>"$UNEXPECTED"
            fi ;;
        esac
        exec {fd}>&-
    done
}

# Samples the daemon every second until told to stop; also /healthz.
monitor() {
    local log=$WORK/logs/monitor t0 rss hwm thr fds k v rest f
    BODY=$WORK/tmp/monitor
    t0=$EPOCHSECONDS
    while [ ! -e "$WORK/monitor.stop" ]; do
        rss="" hwm="" thr=""
        while read -r k v rest; do
            case $k in
            VmRSS:) rss=$v ;;
            VmHWM:) hwm=$v ;;
            Threads:) thr=$v ;;
            esac
        done <"/proc/$DPID/status" 2>/dev/null
        [ -n "$rss" ] || break
        fds=0
        for f in /proc/"$DPID"/fd/*; do fds=$((fds + 1)); done
        printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$((EPOCHSECONDS - t0))" "$(cat "$WORK/phase" 2>/dev/null)" \
            "$rss" "$hwm" "$thr" "$fds" >>"$SAMPLES"
        if [ "$(cat "$WORK/phase" 2>/dev/null)" = steady ]; then
            req "$log" healthz_monitor '200' --max-time 5 "$URL/healthz"
        fi
        sleep 1
    done
}

# One sample now: "rss threads fds".
sample() {
    local k v rest rss="" thr="" fds=0 f
    while read -r k v rest; do
        case $k in
        VmRSS:) rss=$v ;;
        Threads:) thr=$v ;;
        esac
    done <"/proc/$DPID/status"
    for f in /proc/"$DPID"/fd/*; do fds=$((fds + 1)); done
    echo "$rss $thr $fds"
}

# ---- warm-up: lazy thread pools, the scene cache, the job table ----------
BODY=$WORK/tmp/main
WLOG=$WORK/logs/warmup
PHASE=warmup
echo warmup >"$WORK/phase"
printf 't\tphase\trss_kb\thwm_kb\tthreads\tfds\n' >"$SAMPLES"
for i in 1 2 3; do
    req "$WLOG" render '200' -X POST -H 'Content-Type: application/json' \
        --data-binary '{"scene": "tiny", "render": {"width": 32, "height": 24, "spp": 4}}' "$URL/v1/render"
    req "$WLOG" render '200' -X POST -H 'Content-Type: application/json' \
        --data-binary "$(inline_scene)" "$URL/v1/render"
done
req "$WLOG" job_create '202' -X POST -H 'Content-Type: application/json' \
    --data-binary '{"scene": "tiny", "render": {"width": 32, "height": 24, "spp": 4}}' "$URL/v1/jobs"
# Over-limit bodies from 20 connections at once, twice: each connection
# thread collects up to --max-body before its 413, and the malloc arenas
# those threads create (up to 8 per CPU) reach their working size now,
# before the baseline, rather than one by one during the load.
if [ "${SOAK_NO_ARENA_WARMUP:-0}" != 1 ]; then
    for round in 1 2; do
        WPIDS=()
        for ((k = 0; k < 20; k++)); do
            (BODY=/dev/null
             req "$WLOG.$k" body_over_limit_chunked '413' -X POST -H 'Content-Type: application/json' \
                 -H 'Transfer-Encoding: chunked' --data-binary "@$WORK/big.json" "$URL/v1/jobs") &
            WPIDS+=($!)
        done
        for pid in "${WPIDS[@]}"; do wait "$pid"; done
    done
fi
sleep 1
read -r BASE_RSS BASE_THREADS BASE_FDS <<<"$(sample)"
BASE_HWM=$(awk '$1 == "VmHWM:" { print $2 }' "/proc/$DPID/status")

# ---- the steady phase -----------------------------------------------------
START=$EPOCHSECONDS
END=$((START + DURATION))
PHASE=steady
echo steady >"$WORK/phase"
monitor &
MONITOR_PID=$!
CLIENT_PIDS+=("$MONITOR_PID")
LOAD_PIDS=()
for ((c = 0; c < RENDERERS; c++)); do render_client "$c" & LOAD_PIDS+=($!); done
jobs_client 0 & LOAD_PIDS+=($!)
abuse_client 0 & LOAD_PIDS+=($!)
if [ "$HAVE_TCP" = 1 ]; then
    for ((c = 0; c < SLOW; c++)); do slow_client "$c" & LOAD_PIDS+=($!); done
else
    echo "soak: bash has no /dev/tcp here: the slow clients and raw-socket abuse are skipped" >&2
fi
CLIENT_PIDS+=("${LOAD_PIDS[@]}")
echo "soak: lensrayd pid $DPID on $URL; load for $DURATION s (${#LOAD_PIDS[@]} clients)" >&2

# Wait for the deadline, then for the clients (each stops by itself; the
# slowest waits out a silent connection or a render).
while [ "$EPOCHSECONDS" -lt "$END" ]; do
    kill -0 "$DPID" 2>/dev/null || break
    sleep 1
done
touch "$STOP"
for pid in "${LOAD_PIDS[@]}"; do wait "$pid" 2>/dev/null; done
LOAD_END=$EPOCHSECONDS
echo drain >"$WORK/phase"

# ---- after the load: back to the baseline? ------------------------------
DAEMON_ALIVE=1
kill -0 "$DPID" 2>/dev/null || DAEMON_ALIVE=0
END_RSS=0 END_THREADS=0 END_FDS=0
if [ $DAEMON_ALIVE = 1 ]; then
    # Connections close as their clients go; silent ones at the timeout.
    for _ in $(seq 1 $(((CONN_TIMEOUT + 10) * 4))); do
        read -r END_RSS END_THREADS END_FDS <<<"$(sample)"
        [ "$END_THREADS" -le $((BASE_THREADS + 2)) ] && [ "$END_FDS" -le $((BASE_FDS + 2)) ] && break
        sleep 0.25
    done
fi
PHASE=end
HLOG=$WORK/logs/end
req "$HLOG" healthz_end '200' --max-time 5 "$URL/healthz"
HEALTH_END=$CODE
HEALTH_BODY=$(head -c 200 "$BODY" 2>/dev/null)
curl -s --max-time 5 -o "$OUT/metrics.txt" "$URL/metrics"
touch "$WORK/monitor.stop"
wait "$MONITOR_PID" 2>/dev/null

# ---- the shutdown, with requests in flight --------------------------------
PHASE=shutdown
echo shutdown >"$WORK/phase"
SLOG=$WORK/logs/shutdown
SD_PIDS=()
# Jobs left from the load would hold queue places the three queued below
# need (a 429 there is not the case under test): let them drain first.
for _ in $(seq 1 300); do
    curl -s --max-time 2 "$URL/healthz" | grep -q '"running":0,"queue_depth":0' && break
    sleep 0.1
done
# Two synchronous renders of several seconds, one per worker (tiles of
# 2 x 2 stop quickly when cancelled): they finish within --shutdown-grace
# (200) or are cancelled at its end (503).
slow_render='{"scene": "tiny", "render": {"width": 32, "height": 24, "spp": 40000, "threads": 1, "tile_size": 2, "adaptive": false}}'
for c in 0 1; do
    (BODY=$WORK/tmp/sd_render.$c
     req "$SLOG.render.$c" render_in_flight '200|503' -X POST -H 'Content-Type: application/json' \
         --data-binary "$slow_render" "$URL/v1/render") &
    SD_PIDS+=($!)
done
CLIENT_PIDS+=("${SD_PIDS[@]}")
for _ in $(seq 1 50); do
    curl -s --max-time 2 "$URL/healthz" | grep -q '"running":2' && break
    sleep 0.1
done
# Queued jobs behind them: cancelled by the shutdown.
for c in 0 1 2; do
    req "$SLOG" job_queued_before '202' -X POST -H 'Content-Type: application/json' \
        --data-binary "$slow_render" "$URL/v1/jobs"
done
# Connections opened now and used after SIGTERM.
OPEN_FDS=()
if [ "$HAVE_TCP" = 1 ]; then
    for c in 0 1 2; do
        if exec {fd}<>"/dev/tcp/127.0.0.1/$PORT"; then OPEN_FDS+=("$fd"); fi
    done
fi
SIGTERM_AT=$(usec)
kill -TERM "$DPID"
sleep 0.1
# A request on each connection that was already open: 503 (or, if the
# daemon has already closed it, no answer).
for fd in "${OPEN_FDS[@]}"; do
    printf 'GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n' >&"$fd" 2>/dev/null
    first=$(timeout 5 head -n 1 <&"$fd" | tr -d '\r')
    case $first in
    "HTTP/1.1 503 "*) echo "shutdown during_shutdown_open 503 ok" >>"$SLOG" ;;
    "") echo "shutdown during_shutdown_open closed ok" >>"$SLOG" ;;
    *) echo "shutdown during_shutdown_open ${first// /_} bad" >>"$SLOG"
       echo "shutdown: an open connection got '$first'" >>"$UNEXPECTED" ;;
    esac
    exec {fd}>&-
done
# New connections during the shutdown: refused (000) once the listening
# socket is shut, 503 if one slips in before.
for c in 0 1 2 3 4; do
    req "$SLOG" during_shutdown_new '503|000' --max-time 5 "$URL/healthz"
    req "$SLOG" during_shutdown_new '503|000' --max-time 5 -X POST -H 'Content-Type: application/json' \
        --data-binary '{"scene": "tiny"}' "$URL/v1/render"
done
EXIT_STATUS=""
for _ in $(seq 1 $(((GRACE + 15) * 10))); do
    if ! kill -0 "$DPID" 2>/dev/null; then
        wait "$DPID"
        EXIT_STATUS=$?
        break
    fi
    sleep 0.1
done
STOP_SECONDS=$(( ($(usec) - SIGTERM_AT) / 1000 ))
[ -n "$EXIT_STATUS" ] && DPID=""
for pid in "${SD_PIDS[@]}"; do wait "$pid" 2>/dev/null; done

# ---- the summary --------------------------------------------------------------
cat "$WORK"/logs/* >"$OUT/requests.log" 2>/dev/null
FAIL=0
CHECKS=""
check() { # check OK? TEXT
    if [ "$1" = 1 ]; then CHECKS+="  PASS  $2"$'\n'; else CHECKS+="  FAIL  $2"$'\n'; FAIL=1; fi
}

{
    echo "lensrayd soak: $DURATION s of load ($(date -u +%Y-%m-%dT%H:%M:%SZ), $(nproc) CPUs)"
    echo "daemon: --workers $WORKERS --queue $QUEUE --max-connections $MAX_CONN --max-connections-per-ip 48"
    echo "        --connection-timeout $CONN_TIMEOUT --shutdown-grace $GRACE --max-body $MAX_BODY --scene-cache 8"
    echo "malloc: ${SOAK_MALLOC:-tuned}${MALLOC_ENV[0]:+ (${MALLOC_ENV[0]})}"
    echo "clients: $RENDERERS render, 1 jobs, 1 abuse, $([ "$HAVE_TCP" = 1 ] && echo "$SLOW" || echo "0 (no /dev/tcp)") slow, 1 monitor"
    echo
    echo "requests sent, by kind and status (000: no answer; sent: written, then closed):"
    awk '$1 != "warmup" { k = $1 " " $2; n[k]++; s[k, $3]++; codes[$3] = 1; kinds[k] = 1; if ($4 == "bad") bad[k]++ }
         END {
           for (k in kinds) {
             line = ""
             for (c in codes) if (s[k, c]) line = line sprintf(" %s:%d", c, s[k, c])
             printf "  %-36s %7d %s%s\n", k, n[k], line, bad[k] ? sprintf("   UNEXPECTED %d", bad[k]) : ""
           }
         }' "$OUT/requests.log" | sort
    echo
    awk '$1 != "warmup" { t++; if ($3 ~ /^[0-9][0-9][0-9]$/ && $3 != "000") { a++; s[$3]++ } }
         END { printf "total sent: %d, answered: %d; by status:", t, a
               for (c in s) printf " %s:%d", c, s[c]; printf "\n" }' "$OUT/requests.log"
    echo "served, from the daemon's request log (499: client left first):"
    awk '$1 == "lensrayd:" && $4 ~ /^[0-9][0-9][0-9]$/ { t++; s[$4]++ }
         END { printf "  %d requests;", t; for (c in s) printf " %s:%d", c, s[c]; printf "\n" }' "$DLOG"
    echo "libmicrohttpd messages in the log: $(grep -c 'libmicrohttpd:' "$DLOG")"
} >"$SUMMARY"

UNEXP=$(awk '$4 == "bad"' "$OUT/requests.log" | wc -l)
FIVEXX_STEADY=$(awk '$1 != "shutdown" && $1 != "warmup" && $3 ~ /^5/' "$OUT/requests.log" | wc -l)
FIVEXX_SD=$(awk '$1 == "shutdown" && $3 ~ /^5/ && $3 != "503"' "$OUT/requests.log" | wc -l)
CONNFAIL=$(awk '$1 != "shutdown" && $3 == "000"' "$OUT/requests.log" | wc -l)
ANSWERED=$(awk '$1 == "steady" && $3 ~ /^[1-5][0-9][0-9]$/' "$OUT/requests.log" | wc -l)

# RSS over the steady phase: warm-up (a fifth, at least 3 s) left out,
# then the first and last quarters of the rest compared.
read -r PEAK_RSS PEAK_THREADS PEAK_FDS HWM N_STEADY Q1 Q4 SLOPE <<<"$(awk -F'\t' '
    NR > 1 && $2 == "steady" { n++; t[n] = $1; r[n] = $3; if ($3 > pr) pr = $3; if ($5 > pt) pt = $5; if ($6 > pf) pf = $6 }
    NR > 1 { if ($4 > hwm) hwm = $4 }
    END {
      skip = int(n / 5); if (skip < 3) skip = 3
      m = n - skip; q = int(m / 4); if (q < 1) q = 1
      for (i = skip + 1; i <= skip + q; i++) { a += r[i]; na++ }
      for (i = n - q + 1; i <= n; i++) { b += r[i]; nb++ }
      # least-squares slope of RSS after the warm-up, KiB per minute
      for (i = skip + 1; i <= n; i++) { sx += t[i]; sy += r[i]; sxx += t[i] * t[i]; sxy += t[i] * r[i]; k++ }
      d = k * sxx - sx * sx; slope = d > 0 ? (k * sxy - sx * sy) / d * 60 : 0
      printf "%d %d %d %d %d %d %d %.0f\n", pr, pt, pf, hwm, n, na ? a / na : 0, nb ? b / nb : 0, slope
    }' "$SAMPLES")"

kib() { awk -v k="$1" 'BEGIN { printf "%.1f MiB", k / 1024 }'; }
{
    echo
    echo "daemon resources ($N_STEADY samples, about one a second, over the load):"
    printf '  %-34s %s\n' "RSS after warm-up" "$(kib "$BASE_RSS")"
    printf '  %-34s %s\n' "RSS, first quarter (after warm-up)" "$(kib "$Q1")"
    printf '  %-34s %s\n' "RSS, last quarter" "$(kib "$Q4")"
    printf '  %-34s %s KiB/min\n' "RSS trend after warm-up" "$SLOPE"
    printf '  %-34s %s\n' "RSS, peak sample" "$(kib "$PEAK_RSS")"
    printf '  %-34s %s (%s at the end of the warm-up)\n' "VmHWM (peak resident)" "$(kib "$HWM")" "$(kib "$BASE_HWM")"
    printf '  %-34s %s\n' "RSS after the load" "$(kib "$END_RSS")"
    printf '  %-34s start %s, peak %s, end %s\n' "threads" "$BASE_THREADS" "$PEAK_THREADS" "$END_THREADS"
    printf '  %-34s start %s, peak %s, end %s\n' "open descriptors" "$BASE_FDS" "$PEAK_FDS" "$END_FDS"
    printf '  %-34s %s %s\n' "/healthz after the load" "$HEALTH_END" "$HEALTH_BODY"
    printf '  %-34s %s after %s ms (grace %s s)\n' "exit status after SIGTERM" "${EXIT_STATUS:-none: still running}" "$STOP_SECONDS" "$GRACE"
    echo
    echo "checks:"
} >>"$SUMMARY"

check "$DAEMON_ALIVE" "the daemon ran through the load"
check "$([ "$ANSWERED" -gt 0 ] && echo 1)" "requests were answered ($ANSWERED in the load)"
check "$([ "$UNEXP" -eq 0 ] && echo 1)" "every status is one documented for its request ($UNEXP unexpected, see unexpected.log)"
check "$([ "$FIVEXX_STEADY" -eq 0 ] && echo 1)" "no 5xx before the shutdown ($FIVEXX_STEADY)"
check "$([ "$FIVEXX_SD" -eq 0 ] && echo 1)" "no 5xx but 503 during the shutdown ($FIVEXX_SD)"
check "$([ "$CONNFAIL" -eq 0 ] && echo 1)" "no connection failures before the shutdown ($CONNFAIL)"
if grep -q __asan_init "$LENSRAYD"; then
    CHECKS+="  SKIP  RSS growth: an AddressSanitizer build (its quarantine holds freed memory)"$'\n'
else
    check "$(awk -v a="$Q1" -v b="$Q4" 'BEGIN { print (b - a <= 8192) ? 1 : 0 }')" \
        "RSS does not grow: last quarter $(kib "$Q4") vs first $(kib "$Q1") (limit +8 MiB)"
fi
check "$([ "$END_THREADS" -le $((BASE_THREADS + 2)) ] && echo 1)" "threads back near the start ($END_THREADS vs $BASE_THREADS)"
check "$([ "$END_FDS" -le $((BASE_FDS + 2)) ] && echo 1)" "descriptors back near the start ($END_FDS vs $BASE_FDS)"
check "$([ "$HEALTH_END" = 200 ] && [[ $HEALTH_BODY == *'"status":"ok"'* ]] && echo 1)" "/healthz 200 ok after the load"
check "$([ "$EXIT_STATUS" = 0 ] && echo 1)" "exit status 0 after SIGTERM with requests in flight"
check "$(grep -q '^lensrayd: stopped' "$DLOG" && echo 1)" "the daemon logged its clean stop"

{
    printf '%s' "$CHECKS"
    echo
    if [ $FAIL = 0 ]; then echo "soak: PASS"; else echo "soak: FAIL"; fi
} >>"$SUMMARY"
cat "$SUMMARY"
exit $FAIL
