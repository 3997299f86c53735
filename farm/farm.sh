#!/bin/sh
# farm.sh: a render farm on this machine: N lensrayd daemons on loopback
# ports the kernel picks, and nginx in front of them on PORT, from
# farm/nginx.conf.in.  `make farm` and `make farm-stop` call it; so do
# tests/farm.bats and bench/farm.sh.
#
#   farm.sh start BUILD N PORT [DIR]   DIR defaults to BUILD/farm
#   farm.sh stop  BUILD [DIR]
#
# DIR gets everything: nginx.conf, the pids (DIR/pids, one "name pid"
# per line), the daemons' logs (daemon-K.log, their ports in
# daemon-K.port), nginx's logs, and DIR/assets, the assets directory the
# daemons share (PUT /v1/assets; on real machines, an NFS mount).  `stop` ends exactly the processes in
# DIR/pids.  Each daemon renders FARM_WORKERS jobs at once (default 2:
# while one part's last tiles finish on one core, the next part starts on
# the other; docs/deploy.md measures it).  FARM_FLAGS adds flags to every
# daemon (for example "--token-file F"); FARM_SCENES is their scenes
# directory (default: scenes).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
cmd=${1:?usage: farm.sh start|stop BUILD ...}
build=${2:?usage: farm.sh start|stop BUILD ...}

# ours PID DIR: PID is a process this farm started: its command line names
# DIR (the daemons' --assets DIR/assets, nginx's -p DIR).  A pids file
# outlives its processes (a reboot, a SIGKILL), and their numbers go to
# other programs, which must never be signalled.
ours() {
    [ -r "/proc/$1/cmdline" ] &&
        tr '\0' ' ' <"/proc/$1/cmdline" 2>/dev/null | grep -qF " $2/"
}

# orphan_workers DIR: the pids of nginx processes holding DIR's error log.
orphan_workers() {
    for p in /proc/[0-9]*; do
        [ "$(cat "$p/comm" 2>/dev/null)" = nginx ] || continue
        for f in "$p"/fd/*; do
            if [ "$(readlink "$f" 2>/dev/null)" = "$1/nginx-error.log" ]; then
                echo "${p#/proc/}"
                break
            fi
        done
    done
}

stop_farm() {
    dir=$1
    [ -f "$dir/pids" ] || return 0
    # The physical path, as start wrote it: a farm reached through a
    # symbolic link is still known by its processes.
    dir=$(cd "$dir" && pwd -P)
    # Only the processes still ours: the others have ended.
    live=""
    while read -r name pid; do
        if ours "$pid" "$dir"; then
            live="$live$name $pid
"
        fi
    done <"$dir/pids"
    printf '%s' "$live" >"$dir/pids"
    while read -r name pid; do
        if [ "$name" = nginx ]; then
            # nginx's master writes its own pid file; QUIT lets it finish
            # the requests it holds.
            kill -QUIT "$pid" 2>/dev/null || true
        else
            kill -TERM "$pid" 2>/dev/null || true
        fi
    done <"$dir/pids"
    # Wait up to 15 s for each, then SIGKILL what is left.
    while read -r name pid; do
        i=0
        while kill -0 "$pid" 2>/dev/null && [ $i -lt 150 ]; do
            sleep 0.1
            i=$((i + 1))
        done
        kill -KILL "$pid" 2>/dev/null || true
    done <"$dir/pids"
    # nginx workers outlive a master that was SIGKILLed, still serving the
    # port; they are known by the error log they hold open.
    for pid in $(orphan_workers "$dir"); do
        kill -KILL "$pid" 2>/dev/null || true
    done
    rm -f "$dir/pids"
    echo "farm: stopped ($dir)"
}

case $cmd in
stop)
    stop_farm "${3:-$build/farm}"
    exit 0
    ;;
start) ;;
*)
    echo "farm.sh: unknown command '$cmd' (start or stop)" >&2
    exit 2
    ;;
esac

n=${3:?usage: farm.sh start BUILD N PORT [DIR]}
port=${4:?usage: farm.sh start BUILD N PORT [DIR]}
dir=${5:-$build/farm}
scenes=${FARM_SCENES:-scenes}
nginx=$(command -v nginx || echo /usr/sbin/nginx)
case $n in '' | *[!0-9]* | 0)
    echo "farm.sh: FARM_N must be a positive number, got '$n'" >&2
    exit 2 ;;
esac
mkdir -p "$dir/tmp" "$dir/assets"
dir=$(cd "$dir" && pwd -P)
if [ -f "$dir/pids" ]; then
    while read -r name pid; do
        if ours "$pid" "$dir"; then
            echo "farm.sh: a farm is already running from $dir ($name is pid $pid; make farm-stop)" >&2
            exit 1
        fi
    done <"$dir/pids"
    echo "farm.sh: none of the processes in $dir/pids runs any more; starting anew" >&2
    rm -f "$dir/pids"
fi
# nginx workers left by a master that was SIGKILLed still hold the port:
# the new nginx failed to bind it ("Address already in use") until a
# second start, whose failed first had cleaned them up.
for pid in $(orphan_workers "$dir"); do
    kill -KILL "$pid" 2>/dev/null || true
done
# A smaller farm than the last one leaves no stale logs or ports behind.
rm -f "$dir"/daemon-*.log "$dir"/daemon-*.port
: >"$dir/pids"
trap 'echo "farm.sh: start failed; stopping what started" >&2; stop_farm "$dir"' EXIT

servers=""
nodes=""
jobmap=""
k=1
while [ $k -le "$n" ]; do
    log="$dir/daemon-$k.log"
    : >"$log"
    # Every request comes from nginx, one address: the per-address limit
    # (32 by default) would reset nginx's 33rd connection, a 502 (and the
    # daemon marked failed) where the queue had room or a 429 was due.
    # shellcheck disable=SC2086  # FARM_FLAGS is a list of flags
    "$build/lensrayd" --port 0 --bind 127.0.0.1 --scenes "$scenes" \
        --assets "$dir/assets" --id-prefix "$(printf %02x "$k")" \
        --workers "${FARM_WORKERS:-2}" --max-connections-per-ip 0 \
        ${FARM_FLAGS:-} >"$log" 2>&1 3>&- &
    echo "daemon-$k $!" >>"$dir/pids"
    p=""
    i=0
    while [ -z "$p" ] && [ $i -lt 600 ]; do
        p=$(sed -n 's|^lensrayd: listening on http://127\.0\.0\.1:\([0-9]*\) .*|\1|p' "$log")
        [ -n "$p" ] && break
        kill -0 "$!" 2>/dev/null || { cat "$log" >&2; exit 1; }
        sleep 0.05
        i=$((i + 1))
    done
    [ -n "$p" ] || { echo "farm.sh: daemon-$k printed no port" >&2; exit 1; }
    echo "$p" >"$dir/daemon-$k.port"
    servers="$servers        server 127.0.0.1:$p max_fails=1 fail_timeout=10s;\\n"
    node=$(printf %02x "$k")
    nodes="$nodes    upstream lensrayd_$node { server 127.0.0.1:$p; }\\n"
    jobmap="$jobmap        \"~^/v1/jobs/$node[0-9a-f]{30}\" lensrayd_$node;\\n"
    k=$((k + 1))
done

user=""
[ "$(id -u)" != 0 ] || user="user $(id -un);"
sed -e "s|@DIR@|$dir|g" -e "s|@PORT@|$port|g" -e "s|@N@|$n|g" \
    -e "s|@USER@|$user|" -e "s|@SERVERS@|$servers|g" \
    -e "s|@NODES@|$nodes|" -e "s|@JOBMAP@|$jobmap|" \
    "$here/nginx.conf.in" >"$dir/nginx.conf"
"$nginx" -e "$dir/nginx-error.log" -p "$dir" -c "$dir/nginx.conf" >&2
i=0
while [ ! -s "$dir/nginx.pid" ] && [ $i -lt 100 ]; do
    sleep 0.05
    i=$((i + 1))
done
[ -s "$dir/nginx.pid" ] || { echo "farm.sh: nginx wrote no pid" >&2; exit 1; }
echo "nginx $(cat "$dir/nginx.pid")" >>"$dir/pids"
i=0
until curl -sf -o /dev/null --max-time 2 "http://127.0.0.1:$port/healthz"; do
    i=$((i + 1))
    [ $i -lt 100 ] || { echo "farm.sh: nginx does not answer on $port" >&2; exit 1; }
    sleep 0.05
done
trap - EXIT
echo "farm: $n daemons behind nginx on http://127.0.0.1:$port (pids and logs in $dir)"
