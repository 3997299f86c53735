#!/usr/bin/env bats
# page.bats: the page of lensrayd (service/ui/, docs/page.md).  First the
# routes it needs, with curl: the page and its files (open, with their
# security headers; 404 under --no-ui), GET /v1/options, a job's plan map
# against the render's own counts, and a job's resolved autofocus against
# a render of the resolved camera.  Then the page itself in Debian's
# headless Chromium (tests/page/page_test.py, run once in setup_file; one
# test here per check it makes).
#
#     LENSRAY_BUILD=build bats tests/page.bats

bats_require_minimum_version 1.5.0

PY=/usr/bin/python3  # Debian's, with python3-selenium

# start_daemon [FLAGS...]: lensrayd on a free port; sets DPID and DURL.
start_daemon() {
    local log="$WORK/daemon.$$.$RANDOM.log" port="" i
    : >"$log"
    "$LENSRAYD" --port 0 --bind 127.0.0.1 --scenes "$WORK/scenes" "$@" \
        >"$log" 2>&1 3>&- &
    DPID=$!
    echo "$DPID" >>"$WORK/pids"
    for i in $(seq 1 400); do
        port=$(sed -n 's|^lensrayd: listening on http://127\.0\.0\.1:\([0-9]*\) .*|\1|p' "$log")
        [ -n "$port" ] && break
        kill -0 "$DPID" 2>/dev/null || { cat "$log" >&2; return 1; }
        sleep 0.05
    done
    [ -n "$port" ] || { cat "$log" >&2; return 1; }
    DURL="http://127.0.0.1:$port"
}

setup_file() {
    export LENSRAYD="${LENSRAY_BUILD:-build}/lensrayd"
    export WORK="$BATS_FILE_TMPDIR"
    mkdir -p "$WORK/scenes"
    cp scenes/spheres.json tests/data/tiny.json "$WORK/scenes/"
    : >"$WORK/pids"
    # The browser's checks, once for all the tests below that read them.
    if command -v chromium >/dev/null && command -v chromedriver >/dev/null &&
        "$PY" -c 'import selenium' 2>/dev/null; then
        "$PY" tests/page/page_test.py "${LENSRAY_BUILD:-build}" "$WORK/browser" \
            >"$WORK/browser.log" 2>&1 3>&- || true
    fi
}

teardown_file() {
    local pid
    for pid in $(cat "$WORK/pids"); do
        kill -TERM "$pid" 2>/dev/null || true
    done
}

# browser_check NAME: passes when page_test.py reported "ok NAME".
browser_check() {
    command -v chromium >/dev/null ||
        skip "environment: chromium is not installed (make installs chromium, chromium-driver and python3-selenium as root)"
    if ! grep -Eq "^ok $1(:|\$)" "$WORK/browser/results" 2>/dev/null; then
        grep "^fail $1" "$WORK/browser/results" 2>/dev/null || true
        cat "$WORK/browser.log"
        return 1
    fi
    grep "^ok $1" "$WORK/browser/results"
}

# json FILE EXPR: a Python expression of the document `d` in FILE.
json() {
    "$PY" -c "import json,sys; d=json.load(open(sys.argv[1])); print($2)" "$1"
}

@test "GET / serves the page and its files without the token, with a content security policy" {
    echo secret >"$WORK/token"
    start_daemon --token-file "$WORK/token"
    run curl -s -D "$WORK/h" -o "$WORK/index.html" -w '%{http_code}' "$DURL/"
    [ "$output" = 200 ]
    grep -qi '^content-type: text/html' "$WORK/h"
    grep -qi "^content-security-policy: default-src 'none'; script-src 'self'" "$WORK/h"
    grep -q '<script src="/ui/page.js"' "$WORK/index.html"
    # The files served are the repository's, byte for byte.
    cmp "$WORK/index.html" service/ui/index.html
    curl -s -o "$WORK/page.js" "$DURL/ui/page.js"
    cmp "$WORK/page.js" service/ui/page.js
    curl -s -o "$WORK/page.css" "$DURL/ui/page.css"
    cmp "$WORK/page.css" service/ui/page.css
    # The API behind it still needs the token; /healthz says so.
    run curl -s -o /dev/null -w '%{http_code}' "$DURL/v1/options"
    [ "$output" = 401 ]
    curl -s -o "$WORK/health" "$DURL/healthz"
    [ "$(json "$WORK/health" 'd["token_required"]')" = True ]
    kill -TERM "$DPID"
}

@test "--no-ui: the page and its files are 404; the API is untouched" {
    start_daemon --no-ui
    for path in / /ui/page.js /ui/page.css; do
        run curl -s -o "$WORK/body" -w '%{http_code}' "$DURL$path"
        [ "$output" = 404 ]
        grep -q '"code":"not_found"' "$WORK/body"
    done
    run curl -s -o /dev/null -w '%{http_code}' "$DURL/v1/options"
    [ "$output" = 200 ]
    kill -TERM "$DPID"
}

@test "GET /v1/options lists the library's camera models with their keys, samplers, integrators and chromatic modes" {
    start_daemon
    curl -s -o "$WORK/options" "$DURL/v1/options"
    # The models are the registry's (lib/camera/camera.c), as the
    # library's error for a bad model lists them (tests/error_names.py);
    # the integrators likewise.
    curl -s -o "$WORK/bad-model" "$DURL/v1/render" -H 'Content-Type: application/json' \
        -d '{"scene": "tiny", "camera": {"model": "?"}}'
    grep -q '"path":"camera.model"' "$WORK/bad-model"
    diff <(json "$WORK/bad-model" 'd["error"]["message"]' | "$PY" tests/error_names.py) \
        <(json "$WORK/options" '"\n".join(sorted(m["name"] for m in d["camera_models"]))')
    [ "$(json "$WORK/options" 'len(d["camera_models"])')" -ge 4 ]
    curl -s -o "$WORK/bad-integrator" "$DURL/v1/render" -H 'Content-Type: application/json' \
        -d '{"scene": "tiny", "render": {"integrator": "?"}}'
    grep -q '"path":"render.integrator"' "$WORK/bad-integrator"
    diff <(json "$WORK/bad-integrator" 'd["error"]["message"]' | "$PY" tests/error_names.py) \
        <(json "$WORK/options" '"\n".join(sorted(d["integrators"]))')
    [ "$(json "$WORK/options" '[m for m in d["camera_models"] if m["name"] == "thinlens"][0]["defaults"]["focus_distance"]')" = 10 ]
    # A pinhole has nothing to focus; a thin lens has.
    [ "$(json "$WORK/options" '[m["autofocus"] for m in d["camera_models"] if m["name"] in ("pinhole", "thinlens")]')" = "[False, True]" ]
    [ "$(json "$WORK/options" '" ".join(d["samplers"])')" = "random grid jittered sobol" ]
    [ "$(json "$WORK/options" '" ".join(d["chromatic_modes"])')" = "off rgb spectral" ]
    # Every model's defaults are a camera the daemon accepts (the lens
    # model's with a lens named, as it has no default lens).
    local m cam
    for m in $(json "$WORK/options" '" ".join(m["name"] for m in d["camera_models"])'); do
        cam=$(json "$WORK/options" "json.dumps(dict([m for m in d['camera_models'] if m['name'] == '$m'][0]['defaults'], **({'lens': 'double-gauss-50'} if '$m' == 'lens' else {})))")
        run curl -s -o /dev/null -w '%{http_code}' "$DURL/v1/render" -H 'Content-Type: application/json' \
            -d "{\"scene\": \"tiny\", \"camera\": $cam, \"render\": {\"width\": 8, \"height\": 6, \"spp\": 1}}"
        [ "$output" = 200 ]
    done
    kill -TERM "$DPID"
}

@test "GET /v1/jobs/{id}/plan: the map's lens blocks cover the pixels the render says sampled the lens" {
    start_daemon
    curl -s -o "$WORK/job" "$DURL/v1/jobs" -H 'Content-Type: application/json' -d \
        '{"scene": "spheres", "camera": {"model": "thinlens", "aperture_radius": 0.3, "focus_distance": 14},
          "render": {"width": 200, "height": 120, "spp": 4}}'
    id=$(json "$WORK/job" 'd["id"]')
    for i in $(seq 1 600); do
        curl -s -o "$WORK/status" "$DURL/v1/jobs/$id"
        [ "$(json "$WORK/status" 'd["status"]')" = done ] && break
        sleep 0.1
    done
    [ "$(json "$WORK/status" 'd["status"]')" = done ]
    curl -s -o "$WORK/plan" "$DURL/v1/jobs/$id/plan"
    [ "$(json "$WORK/plan" '(d["block"], d["columns"], d["rows"])')" = "(16, 13, 8)" ]
    # Pixels of lens blocks (edge blocks clipped to the 200 x 120 frame)
    # against the render's own count, stats.plan.lens_pixels x pixels.
    lens=$(json "$WORK/plan" 'sum(min(16, 200 - 16 * x) * min(16, 120 - 16 * y) for y, r in enumerate(d["cells"]) for x, c in enumerate(r) if c in "13")')
    # (The status gives the share to 4 decimals, 2.4 pixels here; a block
    # is 256.)
    share=$(json "$WORK/status" 'd["stats"]["plan"]["lens_pixels"]')
    echo "plan map: $lens lens pixels of 24000; the render: a share of $share"
    "$PY" -c "import sys; sys.exit(abs($lens / 24000 - $share) > 0.5e-4)"
    [ "$lens" -gt 0 ]
    [ "$lens" -lt 24000 ]
    run curl -s -o /dev/null -w '%{http_code}' "$DURL/v1/jobs/0123456789abcdef0123456789abcdef/plan"
    [ "$output" = 404 ]
    kill -TERM "$DPID"
}

@test "the job status's camera has the autofocus resolved, and rendering it gives the same bytes" {
    start_daemon
    body='{"scene": "spheres", "camera": {"model": "thinlens", "aperture_radius": 0.3, "focus_on": [100, 115]},
           "render": {"width": 200, "height": 120, "spp": 2}}'
    curl -s -o "$WORK/job" "$DURL/v1/jobs" -H 'Content-Type: application/json' -d "$body"
    id=$(json "$WORK/job" 'd["id"]')
    curl -s -o "$WORK/status" "$DURL/v1/jobs/$id"
    [ "$(json "$WORK/status" '"focus_on" in d["camera"]')" = False ]
    focus=$(json "$WORK/status" 'repr(d["camera"]["focus_distance"])')
    # The pixel's ray (bottom centre) meets the ground plane (y = 0) from the eye (0, 2.2, 2)
    # looking at (0, 1, -16): its view-axis depth, worked out here.
    want=$("$PY" -c '
import math
e=[0,2.2,2]; f=[0,-1.2,-18]; n=math.sqrt(sum(x*x for x in f)); f=[x/n for x in f]
r=[1,0,0]; u=[r[1]*f[2]-r[2]*f[1], r[2]*f[0]-r[0]*f[2], r[0]*f[1]-r[1]*f[0]]
hh=math.tan(math.radians(40)/2); hw=hh*200/120
sx=(2*100.5/200-1)*hw; sy=(1-2*115.5/120)*hh
d=[f[i]+r[i]*sx+u[i]*sy for i in range(3)]; n=math.sqrt(sum(x*x for x in d)); d=[x/n for x in d]
t=-e[1]/d[1]; print(t*sum(d[i]*f[i] for i in range(3)))')
    echo "resolved focus $focus, the ground at $want"
    "$PY" -c "import sys; a, b = float('$focus'), float('$want'); sys.exit(abs(a - b) > 1e-6 * b)"
    curl -s -o "$WORK/a.png" "$DURL/v1/render" -H 'Content-Type: application/json' -d "$body"
    curl -s -o "$WORK/b.png" "$DURL/v1/render" -H 'Content-Type: application/json' -d \
        "{\"scene\": \"spheres\", \"camera\": {\"model\": \"thinlens\", \"aperture_radius\": 0.3, \"focus_distance\": $focus},
          \"render\": {\"width\": 200, \"height\": 120, \"spp\": 2}}"
    cmp "$WORK/a.png" "$WORK/b.png"
    kill -TERM "$DPID"
}

@test "browser: the page loads without console errors, and its model menu is GET /v1/options' list" {
    browser_check load
}

@test "browser: moving the focus slider starts a new render and cancels the superseded job on the daemon" {
    browser_check cancel
}

@test "browser: clicking a sphere focuses on it (the distance shown is its depth within 2%)" {
    browser_check focus
}

@test "browser: the plan overlay toggles and draws the daemon's plan" {
    browser_check overlay
}

@test "browser: the PNG download equals the API's image byte for byte" {
    browser_check download
}

@test "browser: a change leaves the finished job of the shown picture on the daemon" {
    browser_check kept
}

@test "browser: a log-scale slider gives a screen reader the value shown (aria-valuetext)" {
    browser_check valuetext
}

@test "browser: two clicks in quick succession: the first click's late answer changes nothing, the picture focuses on the second" {
    browser_check stale-answer
}

@test "browser: a change while the job's done answer is on its way deletes no finished job and fetches no image" {
    browser_check done-in-flight
}

@test "browser: the picture focuses from the keyboard (Tab, arrows move a marker, Enter)" {
    browser_check keyboard-focus
}

@test "browser: a click on a pixel that sees nothing is said once; the next change renders" {
    browser_check sky-click
}

@test "browser: the EXR download is the shown picture's job, whatever the controls say since" {
    browser_check exr-shown
}

@test "browser: the lens model and the shipped lenses come from the daemon, and the page renders through one" {
    browser_check lens
}

@test "browser: a token refused mid-session is asked for again, and the page starts over without doubled lists or handlers" {
    browser_check token-again
}

@test "browser: a token no header can carry is asked for again, with the reason" {
    browser_check token-ascii
}

@test "browser: a picture that cannot be fetched is an error on the page, not an uncaught exception" {
    browser_check lost-image
}

@test "browser: the daemon killed mid-render: the page says the server does not answer" {
    browser_check daemon-gone
}
