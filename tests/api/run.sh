#!/bin/sh
# `make test-api`: docs/openapi.yaml against a real OpenAPI validator, then
# a property-based tester (schemathesis) against a live lensrayd for a
# bounded number of requests: any 5xx, any status, header, content type or
# body the spec does not describe, and any request the spec calls invalid
# that the daemon accepts, fails.  Ends with "N passed, N failed" (the
# validator is one test, each operation schemathesis exercised another).
# Usage: tests/api/run.sh BUILD_DIR VENV EXAMPLES
build=${1:-build}
venv=${2:-$build/api-venv}
examples=${3:-25}
spec=docs/openapi.yaml
# Absolute, since schemathesis runs from the scratch directory.
venv=$(cd "$venv" && pwd) || { echo "api: no virtualenv at $2"; echo "0 passed, 1 failed"; exit 1; }
work=$(mktemp -d)
pid=""
# The daemon is killed whatever happens, and only the one started here.
cleanup() {
    if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
        kill -TERM "$pid" 2>/dev/null
        i=0
        while kill -0 "$pid" 2>/dev/null && [ $i -lt 100 ]; do
            sleep 0.1
            i=$((i + 1))
        done
        kill -KILL "$pid" 2>/dev/null
        wait "$pid" 2>/dev/null
    fi
    rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

passed=0
failed=0

echo "api: openapi-spec-validator $spec"
if "$venv/bin/openapi-spec-validator" "$spec"; then
    passed=$((passed + 1))
else
    failed=$((failed + 1))
fi

# The scenes the spec's examples name, small limits so that every render
# the tester can ask for finishes in well under a second (a render that hit
# --max-render-seconds would answer 504, a 5xx), and a queue short enough
# to reach 429.
# With a token, so that the tester also checks that a request without it,
# or with a wrong one, is refused (its ignored_auth check); the daemon
# without a token is the bats suites' business.
token="api-$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')"
printf '%s\n' "$token" >"$work/token"
mkdir -p "$work/scenes/meshes" "$work/assets"
cp scenes/spheres.json scenes/cornell.json tests/data/tiny.json "$work/scenes/"
[ -f scenes/meshes/bunny.obj ] && cp scenes/meshes/bunny.obj "$work/scenes/meshes/"
"$build/lensrayd" --port 0 --bind 127.0.0.1 --scenes "$work/scenes" \
    --workers 1 --queue 4 --max-body 64k --max-pixels 16384 \
    --max-samples 100000 --max-render-seconds 60 --job-ttl 60 \
    --token-file "$work/token" --assets "$work/assets" --max-asset-bytes 64k \
    >"$work/daemon.log" 2>&1 &
pid=$!
port=""
i=0
while [ -z "$port" ] && [ $i -lt 200 ] && kill -0 "$pid" 2>/dev/null; do
    port=$(sed -n 's|^lensrayd: listening on http://127\.0\.0\.1:\([0-9]*\) .*|\1|p' "$work/daemon.log")
    [ -n "$port" ] || sleep 0.05
    i=$((i + 1))
done
if [ -z "$port" ]; then
    echo "api: lensrayd did not start:"
    cat "$work/daemon.log"
    echo "$passed passed, $((failed + 1)) failed"
    exit 1
fi
echo "api: schemathesis against lensrayd on port $port ($examples examples per operation, positive and negative, and stateful links)"

# Hypothesis keeps its example database under .hypothesis in the current
# directory; it goes to the scratch directory instead, and the seed is
# fixed so that a run is repeatable.
(cd "$work" && HYPOTHESIS_STORAGE_DIRECTORY="$work/hypothesis" \
    "$venv/bin/st" run "$OLDPWD/$spec" --base-url "http://127.0.0.1:$port" \
    -H "Authorization: Bearer $token" \
    --checks all --data-generation-method all --stateful=links \
    --hypothesis-max-examples "$examples" --hypothesis-seed 1 \
    --hypothesis-deadline None --hypothesis-suppress-health-check all \
    --request-timeout 120000 --workers 1 --no-color \
    --junit-xml "$work/junit.xml" >"$work/st.log" 2>&1)
st=$?
cat "$work/st.log"

# One test per operation from the JUnit report: failed if it has a
# failure or an error.
counts=$("$venv/bin/python" - "$work/junit.xml" <<'PY'
import sys, xml.etree.ElementTree as ET
try:
    root = ET.parse(sys.argv[1]).getroot()
except Exception as e:
    print("0 1")
    sys.exit(0)
ok = bad = 0
for case in root.iter("testcase"):
    if case.find("failure") is not None or case.find("error") is not None:
        bad += 1
    else:
        ok += 1
print(ok, bad)
PY
)
ok=${counts% *}
bad=${counts#* }
passed=$((passed + ok))
failed=$((failed + bad))
if [ "$st" -ne 0 ] && [ "$bad" -eq 0 ]; then
    echo "api: schemathesis exited with status $st"
    failed=$((failed + 1))
fi
# A daemon that died under the tester fails too (its log shows why).
if ! kill -0 "$pid" 2>/dev/null; then
    echo "api: lensrayd is no longer running:"
    tail -n 20 "$work/daemon.log"
    failed=$((failed + 1))
fi
grep -q '^lensrayd: .* 5[0-9][0-9] ' "$work/daemon.log" &&
    { echo "api: the daemon's log shows 5xx answers:"; grep '^lensrayd: .* 5[0-9][0-9] ' "$work/daemon.log" | head; }
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
