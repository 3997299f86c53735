# bench/mitsuba_env.sh: Mitsuba 3 for the benchmarks, sourced by
# bench/run.sh and bench/path/run.sh (POSIX sh).
#
# mitsuba_setup VENV LOG: makes sure VENV holds mitsuba==$MITSUBA_VERSION and
#   numpy (installing them with pip the first time, output in LOG); sets
#   mitsuba_ok=1 if they import, else writes "MITSUBA_UNAVAILABLE reason" to
#   stdout and sets mitsuba_ok=0.
# mitsuba_llvm: sets and exports DRJIT_LIBLLVM_PATH for the llvm variants
#   (installing libllvm19 when run as root and apt knows it), empty if no
#   LLVM >= 16 is found.
MITSUBA_VERSION=3.9.1

mitsuba_setup() {
    mitsuba_ok=0
    if ! "$1/bin/python" -c "import mitsuba, numpy; assert mitsuba.__version__ == '$MITSUBA_VERSION'" >/dev/null 2>&1; then
        echo "bench: installing Mitsuba $MITSUBA_VERSION into $1 (the first time only)" >&2
        rm -rf "$1"
        if ! python3 -m venv "$1" > "$2" 2>&1; then
            echo "MITSUBA_UNAVAILABLE python3 -m venv failed (apt-get install python3-venv)"
            return 0
        elif ! "$1/bin/pip" install -q "mitsuba==$MITSUBA_VERSION" numpy >> "$2" 2>&1; then
            echo "MITSUBA_UNAVAILABLE pip install mitsuba==$MITSUBA_VERSION failed: $(grep -i error "$2" | tail -1)"
            return 0
        fi
    fi
    if "$1/bin/python" -c "import mitsuba, numpy" >/dev/null 2>&1; then
        mitsuba_ok=1
    fi
}

mitsuba_llvm() {
    # The llvm variants need an LLVM newer than Debian 12's default 14.
    # Dr.Jit 1.5 emits llvm.minimum, which LLVM 15 cannot select (it
    # aborts with "Cannot select: fminimum"): install 19 even where 15 is
    # present.
    if [ -z "${DRJIT_LIBLLVM_PATH:-}" ] && [ ! -e /usr/lib/x86_64-linux-gnu/libLLVM-19.so ] && \
       [ "$(id -u)" = 0 ] && apt-cache policy libllvm19 2>/dev/null | grep -q 'Candidate: [0-9]'; then
        echo "bench: installing libllvm19 for Mitsuba's llvm variant" >&2
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libllvm19 >/dev/null 2>&1
    fi
    if [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
        for v in 19 18 17 16; do
            for f in /usr/lib/x86_64-linux-gnu/libLLVM-$v.so /usr/lib/x86_64-linux-gnu/libLLVM-$v.so.1 \
                     /usr/lib/llvm-$v/lib/libLLVM-$v.so /usr/lib/llvm-$v/lib/libLLVM.so.1; do
                if [ -e "$f" ]; then DRJIT_LIBLLVM_PATH=$f; break 2; fi
            done
        done
    fi
    export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-}
}
