#!/usr/bin/python3
"""The page of lensrayd (service/ui/, docs/page.md) in Debian's headless
Chromium through Selenium: nothing is downloaded at run time.

    page_test.py BUILD_DIR OUT_DIR                 the checks (tests/page.bats)
    page_test.py BUILD_DIR OUT_DIR --measure       slider move -> first picture, per scene
    page_test.py BUILD_DIR OUT_DIR --screenshots D screenshots into D

The checks write OUT_DIR/results: one line per check, "ok NAME" or
"fail NAME: why", which tests/page.bats reads.  Every wait is for a state
(of the page's DOM or of a job on the daemon) with a generous timeout;
no verdict depends on how long anything took.
"""
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select, WebDriverWait

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WAIT = 120  # seconds: generous, for a loaded machine and a sanitizer build


class Daemon:
    """lensrayd on a free loopback port with a token, one worker."""

    def __init__(self, build, work, scenes):
        self.work = work
        sdir = os.path.join(work, "scenes")
        os.makedirs(sdir, exist_ok=True)
        for s in scenes:
            shutil.copy(s, sdir)
        self.token = "page-" + os.urandom(8).hex()
        with open(os.path.join(work, "token"), "w") as f:
            f.write(self.token + "\n")
        self.log = open(os.path.join(work, "daemon.log"), "w+")
        self.proc = subprocess.Popen(
            [os.path.join(build, "lensrayd"), "--port", "0", "--bind", "127.0.0.1",
             "--scenes", sdir, "--workers", "1", "--token-file", os.path.join(work, "token")],
            stderr=self.log, stdout=self.log)
        deadline = time.monotonic() + WAIT
        while True:
            self.log.seek(0)
            m = re.search(r"listening on http://127\.0\.0\.1:(\d+)", self.log.read())
            if m:
                self.url = "http://127.0.0.1:" + m.group(1)
                break
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("lensrayd did not start")
            time.sleep(0.05)

    def call(self, method, path, body=None):
        req = urllib.request.Request(self.url + path, method=method,
                                     headers={"Authorization": "Bearer " + self.token})
        if body is not None:
            req.data = json.dumps(body).encode()
            req.add_header("Content-Type", "application/json")
        with urllib.request.urlopen(req, timeout=WAIT) as r:
            return r.read()

    def json(self, method, path, body=None):
        return json.loads(self.call(method, path, body))

    def wait_job(self, job_id, states):
        deadline = time.monotonic() + WAIT
        while True:
            st = self.json("GET", "/v1/jobs/" + job_id)
            if st["status"] in states:
                return st
            if time.monotonic() > deadline:
                raise AssertionError("job %s stayed %s (wanted %s)" % (job_id, st["status"], states))
            time.sleep(0.05)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def browser(downloads):
    opts = webdriver.ChromeOptions()
    opts.binary_location = "/usr/bin/chromium"
    for a in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
              "--window-size=1400,900", "--no-first-run", "--disable-extensions",
              "--disable-background-networking", "--disable-component-update"]:
        opts.add_argument(a)
    opts.add_experimental_option("prefs", {"download.default_directory": downloads,
                                           "download.prompt_for_download": False})
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    d = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
    d.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": downloads})
    return d


def until(driver, what, fn):
    try:
        return WebDriverWait(driver, WAIT, poll_frequency=0.05).until(lambda d: fn())
    except Exception as e:
        raise AssertionError("waited %ds for %s" % (WAIT, what)) from e


def body_data(driver, key):
    return driver.execute_script("return document.body.dataset[arguments[0]] || ''", key)


def wait_done(driver):
    until(driver, "the page to finish its picture", lambda: body_data(driver, "state") == "done")


def series(driver):
    return int(body_data(driver, "series") or 0)


def act(driver, action):
    """Does `action` (a change on the page) and waits for the picture of
    the series it started to finish."""
    before = series(driver)
    action()
    until(driver, "a new series", lambda: series(driver) > before)
    wait_done(driver)


def open_page(driver, daemon):
    driver.get(daemon.url + "/")
    until(driver, "the token form", lambda: driver.find_element(By.ID, "token").is_displayed())
    driver.find_element(By.ID, "token").send_keys(daemon.token + Keys.ENTER)
    wait_done(driver)


# ---- the independent depth of a pixel --------------------------------------

def sub(a, b): return [a[i] - b[i] for i in range(3)]
def dot(a, b): return sum(a[i] * b[i] for i in range(3))
def scale(a, s): return [x * s for x in a]
def norm(a): return scale(a, 1 / math.sqrt(dot(a, a)))
def cross(a, b): return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def frame(cam, w, h):
    """Eye, axes and half extents: a vertical field of view, pixel (x, y)
    from the top-left, the image plane at distance 1 (docs/scene-format.md)."""
    e = cam["position"]
    fwd = norm(sub(cam["look_at"], e))
    right = norm(cross(fwd, cam["up"]))
    up = cross(right, fwd)
    hh = math.tan(math.radians(cam["fov"]) / 2)
    return e, fwd, right, up, hh * w / h, hh


def pixel_of(cam, w, h, p):
    e, fwd, right, up, hw, hh = frame(cam, w, h)
    r = sub(p, e)
    z = dot(r, fwd)
    sx, sy = dot(r, right) / z, dot(r, up) / z
    return (sx / hw + 1) * w / 2, (1 - sy / hh) * h / 2


def depth_at(cam, w, h, x, y, spheres):
    """View-axis depth of the nearest sphere hit by the ray through the
    centre of pixel (x, y): ray-sphere intersection in closed form."""
    e, fwd, right, up, hw, hh = frame(cam, w, h)
    sx = (2 * (x + 0.5) / w - 1) * hw
    sy = (1 - 2 * (y + 0.5) / h) * hh
    d = norm([fwd[i] + right[i] * sx + up[i] * sy for i in range(3)])
    best = None
    for s in spheres:
        oc = sub(e, s["center"])
        b = dot(oc, d)
        disc = b * b - (dot(oc, oc) - s["radius"] ** 2)
        if disc >= 0:
            t = -b - math.sqrt(disc)
            if t > 0 and (best is None or t < best):
                best = t
    return None if best is None else best * dot(d, fwd)


# ---- the checks --------------------------------------------------------------

def check_load(driver, daemon, ctx):
    open_page(driver, daemon)
    bad = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    assert not bad, "console errors on load: %s" % bad
    assert driver.find_element(By.ID, "picture").get_attribute("data-job"), "no picture shown"
    # The model menu is GET /v1/options' list (the library's registry,
    # page.bats checks), in its order: the page names no model itself.
    shown = [o.get_attribute("value") for o in
             Select(driver.find_element(By.ID, "model")).options]
    listed = [m["name"] for m in daemon.json("GET", "/v1/options")["camera_models"]]
    assert shown == listed, "the model menu shows %s, the daemon lists %s" % (shown, listed)
    return "models: " + " ".join(shown)


def move_focus(driver):
    """One step of the focus slider: the thin lens's focus distance, or
    the bracket's focal length."""
    sliders = (driver.find_elements(By.ID, "key-focus_distance") or
               driver.find_elements(By.ID, "key-focal_length"))
    sliders[0].send_keys(Keys.ARROW_RIGHT)


def check_cancel(driver, daemon, ctx):
    act(driver, lambda: Select(driver.find_element(By.ID, "model")).select_by_value("thinlens"))
    # The one worker is kept busy by a long job of the test's own, so the
    # page's jobs wait in the queue: the superseded one is certainly not
    # finished when the slider moves again.
    blocker = daemon.json("POST", "/v1/jobs", {
        "scene": "tiny", "render": {"width": 32, "height": 24, "spp": 200000, "threads": 1,
                                    "tile_size": 2, "adaptive": False}})["id"]
    try:
        daemon.wait_job(blocker, ["running"])
        before = body_data(driver, "job")
        move_focus(driver)
        until(driver, "a job for the first slider move",
              lambda: body_data(driver, "job") not in ("", before))
        first = body_data(driver, "job")
        assert daemon.json("GET", "/v1/jobs/" + first)["status"] == "queued"
        move_focus(driver)
        until(driver, "a job for the second slider move",
              lambda: body_data(driver, "job") not in ("", first))
        second = body_data(driver, "job")
        st = daemon.wait_job(first, ["cancelled", "done", "failed"])
        assert st["status"] == "cancelled", "the superseded job ended %s" % st["status"]
        assert daemon.json("GET", "/v1/jobs/" + second)["status"] in ("queued", "running", "done")
        detail = "job %s cancelled, %s after it" % (first[:8], second[:8])
    finally:
        daemon.call("DELETE", "/v1/jobs/" + blocker)
    wait_done(driver)
    return detail


def check_focus(driver, daemon, ctx):
    scene = ctx["scene"]
    shown = body_data(driver, "shown")
    st = daemon.json("GET", "/v1/jobs/" + shown)
    w, h, cam = st["width"], st["height"], scene["camera"]
    spheres = [o for o in scene["objects"] if o["type"] == "sphere"]
    before = driver.find_element(By.ID, "focus-distance").get_attribute("data-value")
    # Aim at the centre of the sphere farthest from the current focus.
    target = max(spheres, key=lambda s: abs(-dot(sub(s["center"], cam["position"]),
                                                  norm(sub(cam["look_at"], cam["position"])))
                                             + float(before or 0)))
    px, py = pixel_of(cam, w, h, target["center"])
    img = driver.find_element(By.ID, "picture")
    cw, ch = img.size["width"], img.size["height"]
    act(driver, lambda: ActionChains(driver).move_to_element_with_offset(
        img, int(px / w * cw - cw / 2), int(py / h * ch - ch / 2)).click().perform())
    x, y = map(int, driver.find_element(By.ID, "focus-pixel").get_attribute("data-pixel").split(","))
    want = depth_at(cam, w, h, x, y, spheres)
    assert want is not None, "pixel %d,%d hits no sphere" % (x, y)
    got = float(driver.find_element(By.ID, "focus-distance").get_attribute("data-value"))
    assert got != float(before or 0), "the focus distance did not change"
    assert abs(got - want) <= 0.02 * want, "focus %.4f, the sphere is at depth %.4f" % (got, want)
    return "pixel %d,%d: shown %.4f, sphere depth %.4f (%+.2g%%), before %s" % (
        x, y, got, want, 100 * (got - want) / want, before)


def check_overlay(driver, daemon, ctx):
    # An aperture, so that some blocks sample the lens.
    slider = driver.find_element(By.ID, "key-aperture_radius")
    for _ in range(40):
        slider.send_keys(Keys.ARROW_RIGHT)
    until(driver, "the aperture to reach 0.2",
          lambda: float(driver.find_element(By.ID, "value-aperture_radius").text) >= 0.2)
    wait_done(driver)
    overlay = driver.find_element(By.ID, "overlay")
    assert not overlay.is_displayed(), "the overlay shows before it is asked for"
    driver.find_element(By.ID, "show-plan").click()
    assert overlay.is_displayed(), "the overlay does not show"
    shown = body_data(driver, "shown")
    plan = daemon.json("GET", "/v1/jobs/%s/plan" % shown)
    lens = sum(c in "13" for row in plan["cells"] for c in row)
    assert overlay.get_attribute("data-job") == shown, "the overlay is of another job"
    assert int(overlay.get_attribute("data-lens-blocks")) == lens > 0, \
        "the overlay has %s lens blocks, the plan %d" % (overlay.get_attribute("data-lens-blocks"), lens)
    # Canvas pixels drawn where the plan says the lens was sampled.
    painted = driver.execute_script(
        "const c = document.getElementById('overlay');"
        "const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
        "let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; return n;")
    assert painted > 0, "the overlay is empty"
    driver.find_element(By.ID, "show-plan").click()
    assert not overlay.is_displayed(), "the overlay does not hide"
    return "%d lens blocks of %d, as the plan" % (lens, plan["columns"] * plan["rows"])


def check_download(driver, daemon, ctx):
    shown = body_data(driver, "shown")
    driver.find_element(By.ID, "dl-png").click()
    path = os.path.join(ctx["downloads"], driver.find_element(By.ID, "dl-png").get_attribute("download"))
    until(driver, "the download of " + path, lambda: os.path.exists(path))
    got = open(path, "rb").read()
    want = daemon.call("GET", "/v1/jobs/%s/image" % shown)
    assert got == want, "the download (%d bytes) differs from the API's image (%d bytes)" % (len(got), len(want))
    return "%d bytes, equal" % len(got)


def check_kept(driver, daemon, ctx):
    """A change leaves the finished job whose picture is shown on the
    daemon (page.md: finished jobs stay for --job-ttl); the page's
    DELETE of its last job, finished, removed it (404)."""
    shown = body_data(driver, "shown")
    act(driver, lambda: move_focus(driver))
    st = daemon.json("GET", "/v1/jobs/" + shown)
    assert st["status"] == "done", "the shown job is %s" % st["status"]
    return "job %s still there, done" % shown[:8]


def check_valuetext(driver, daemon, ctx):
    """A log-scale slider's position (0 to 1000) is not its value: a
    screen reader gets the value shown (aria-valuetext), after a move and
    after a click's focus set the slider."""
    said = []
    for key in ("focus_distance", "focal_length", "image_plane_distance", "view_height"):
        for slider in driver.find_elements(By.ID, "key-" + key):
            text = driver.find_element(By.ID, "value-" + key).text
            got = slider.get_attribute("aria-valuetext")
            assert got == text, "%s: aria-valuetext %r, the page shows %r" % (key, got, text)
            said.append("%s %s" % (key, text))
    assert said, "no log-scale slider on the page"
    act(driver, lambda: move_focus(driver))
    slider = driver.find_element(By.ID, "key-focus_distance")
    text = driver.find_element(By.ID, "value-focus_distance").text
    assert slider.get_attribute("aria-valuetext") == text, \
        "after a move: aria-valuetext %r, the page shows %r" % (slider.get_attribute("aria-valuetext"), text)
    return ", ".join(said) + "; then " + text


# The page's fetch wrapped to hold job-status answers (GET /v1/jobs/ID),
# so that a test decides in which order the page reads them: with
# holdRequests > 0 the request waits until released (its answer is then
# the daemon's state at the release), with holdDone > 0 an answer that
# says "done" is kept from the page until released.  reqs: every request.
WRAP_FETCH = """
    if (!window.unwrappedFetch) window.unwrappedFetch = window.fetch;
    const real = window.unwrappedFetch;
    Object.assign(window, {reqs: [], held: [], holdRequests: 0, holdDone: 0, states: []});
    const hold = (path) => new Promise((go) => window.held.push({path, go}));
    window.fetch = async (path, init) => {
      const method = (init && init.method) || "GET";
      window.reqs.push(method + " " + path);
      const status = method === "GET" && /^[/]v1[/]jobs[/][0-9a-f]+$/.test(path);
      if (status && window.holdRequests > 0) { window.holdRequests--; await hold(path); }
      const res = await real(path, init);
      if (status && window.holdDone > 0 && (await res.clone().json()).status === "done") {
        window.holdDone--;
        await hold(path);
      }
      return res;
    };
    window.releaseFirst = () => window.held.shift().go();
    new MutationObserver(() => window.states.push(document.body.dataset.state))
      .observe(document.body, {attributes: true, attributeFilter: ["data-state"]});
"""


def unwrap_fetch(driver):
    driver.execute_script("window.fetch = window.unwrappedFetch; window.unwrappedFetch = null;"
                          "window.held.forEach((h) => h.go()); window.held = [];")


def click_pixel(driver, w, h, x, y):
    img = driver.find_element(By.ID, "picture")
    cw, ch = img.size["width"], img.size["height"]
    ActionChains(driver).move_to_element_with_offset(
        img, int((x + 0.5) / w * cw - cw / 2), int((y + 0.5) / h * ch - ch / 2)).click().perform()


def check_stale_answer(driver, daemon, ctx):
    """Two clicks in quick succession: the first click's job answers
    after the second click (its status request held), and its answer
    ("cancelled" when the change had cancelled it) must not touch the
    page.  It set the focus slider to the first click's depth and, as a
    "cancelled" error, dropped the second click: the picture focused on
    the first click while the label named the second."""
    scene = ctx["scene"]
    st = daemon.json("GET", "/v1/jobs/" + body_data(driver, "shown"))
    w, h, cam = st["width"], st["height"], scene["camera"]
    spheres = sorted((o for o in scene["objects"] if o["type"] == "sphere"),
                     key=lambda s: dot(sub(s["center"], cam["position"]), sub(cam["look_at"], cam["position"])))
    a = [int(v) for v in pixel_of(cam, w, h, spheres[0]["center"])]
    b = [int(v) for v in pixel_of(cam, w, h, spheres[-1]["center"])]
    driver.execute_script(WRAP_FETCH)
    blocker = daemon.json("POST", "/v1/jobs", {
        "scene": "tiny", "render": {"width": 32, "height": 24, "spp": 200000, "threads": 1,
                                    "tile_size": 2, "adaptive": False}})["id"]
    try:
        daemon.wait_job(blocker, ["running"])
        driver.execute_script("window.holdRequests = 2;")
        click_pixel(driver, w, h, *a)
        until(driver, "the first click's status request", lambda: driver.execute_script("return window.held.length") == 1)
        ja = body_data(driver, "job")
        click_pixel(driver, w, h, *b)
        until(driver, "the second click's status request", lambda: driver.execute_script("return window.held.length") == 2)
        jb = body_data(driver, "job")
        assert ja != jb, "the second click started no job"
        n = driver.execute_script("return window.reqs.length")
        driver.execute_script("window.releaseFirst();")
        # The page has read the first job's answer: it cancels the job
        # now (it was queued), or (before the fix) says it was cancelled.
        until(driver, "the page to read the first job's answer", lambda: driver.execute_script(
            "return window.reqs.slice(arguments[0]).includes('DELETE /v1/jobs/' + arguments[1]) ||"
            " window.states.includes('error')", n, ja))
        assert daemon.wait_job(ja, ["cancelled", "done", "failed"])["status"] == "cancelled"
        driver.execute_script("window.releaseFirst();")
    finally:
        daemon.call("DELETE", "/v1/jobs/" + blocker)
    wait_done(driver)
    states = driver.execute_script("return window.states")
    label = driver.find_element(By.ID, "focus-pixel").get_attribute("data-pixel")
    unwrap_fetch(driver)
    assert "error" not in states, "the superseded job's answer put the page in error (states %s)" % states
    assert label == "%d,%d" % tuple(b), "the label names pixel %r, the second click was %s" % (label, b)
    want = daemon.json("GET", "/v1/jobs/" + jb)["camera"]["focus_distance"]
    shown = daemon.json("GET", "/v1/jobs/" + body_data(driver, "shown"))["camera"]["focus_distance"]
    slider = driver.execute_script("return state.values.focus_distance")
    assert shown == want == slider, \
        "the picture is focused at %r, the slider at %r, the second click at %r" % (shown, slider, want)
    return "clicks at %s then %s: focused at %.4f, as the second" % (a, b, want)


def check_done_in_flight(driver, daemon, ctx):
    """A change while the answer that the job is done is on its way: the
    page deletes no finished job (page.md), and the superseded series
    fetches no image (it got 404 for the job its own DELETE removed)."""
    driver.get_log("browser")
    driver.execute_script(WRAP_FETCH)
    driver.execute_script("window.holdDone = 1;")
    move_focus(driver)
    until(driver, "a done answer held", lambda: driver.execute_script("return window.held.length") == 1)
    j1 = driver.execute_script("return window.held[0].path").rsplit("/", 1)[1]
    act(driver, lambda: (move_focus(driver),
                         until(driver, "the next change's job", lambda: body_data(driver, "job") != j1),
                         driver.execute_script("window.releaseFirst();")))
    reqs = driver.execute_script("return window.reqs")
    unwrap_fetch(driver)
    assert "DELETE /v1/jobs/" + j1 not in reqs, "the page deleted job %s, done" % j1
    assert "GET /v1/jobs/%s/image" % j1 not in reqs, "the superseded series fetched its image"
    st = daemon.json("GET", "/v1/jobs/" + j1)
    assert st["status"] == "done", "job %s is %s" % (j1, st["status"])
    bad = [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    assert not bad, "console errors: %s" % bad
    return "job %s done and kept, %d requests, none for it after the change" % (j1[:8], len(reqs))


def check_keyboard_focus(driver, daemon, ctx):
    """The picture takes the keyboard focus (Tab); the arrow keys move its
    marker a twentieth of the picture, and Enter focuses there, as a click."""
    img = driver.find_element(By.ID, "picture")
    assert img.get_attribute("tabindex") == "0", "the picture is not in the tab order"
    st = daemon.json("GET", "/v1/jobs/" + body_data(driver, "shown"))
    w, h = st["width"], st["height"]
    driver.execute_script("arguments[0].focus();", img)
    assert driver.find_element(By.ID, "key-point").is_displayed(), "no marker with the focus on the picture"
    img.send_keys(Keys.ARROW_DOWN, Keys.ARROW_DOWN, Keys.ARROW_LEFT)
    act(driver, lambda: img.send_keys(Keys.ENTER))
    want = "%d,%d" % (int(0.45 * w), int(0.6 * h))
    got = driver.find_element(By.ID, "focus-pixel").get_attribute("data-pixel")
    assert got == want, "Enter focused on pixel %r, the marker is at %s" % (got, want)
    shown = daemon.json("GET", "/v1/jobs/" + body_data(driver, "shown"))["camera"]["focus_distance"]
    first = daemon.json("POST", "/v1/jobs", {
        "scene": "spheres", "camera": dict(st["camera"], focus_on=[int(v) for v in want.split(",")]),
        "render": {"width": w, "height": h, "spp": 1}})
    resolved = daemon.wait_job(first["id"], ["done", "failed"])["camera"]["focus_distance"]
    assert shown == resolved, "the picture is focused at %r, pixel %s at %r" % (shown, want, resolved)
    return "pixel %s, focus %.4f" % (want, shown)


def check_sky_click(driver, daemon, ctx):
    """A click on a pixel that sees nothing: its error once, then the
    next change renders (the click's pixel was sent with every later
    job, which all failed the same way)."""
    img = driver.find_element(By.ID, "picture")
    cw, ch = img.size["width"], img.size["height"]
    before = series(driver)
    ActionChains(driver).move_to_element_with_offset(
        img, int(2 - cw / 2), int(2 - ch / 2)).click().perform()
    until(driver, "the click's series", lambda: series(driver) > before)
    until(driver, "the click's error", lambda: body_data(driver, "state") == "error")
    said = driver.find_element(By.ID, "status").text
    assert "focus_on" in said, "the error says %r" % said
    act(driver, lambda: move_focus(driver))
    assert body_data(driver, "state") == "done"
    return "said %r, then rendered" % said[:60]


def check_exr_shown(driver, daemon, ctx):
    """The EXR is the shown picture's job: with the worker busy, the
    size changed (the picture still the old one), the EXR job has the
    shown job's scene, camera and size (it took the controls' own)."""
    shown = daemon.json("GET", "/v1/jobs/" + body_data(driver, "shown"))
    blocker = daemon.json("POST", "/v1/jobs", {
        "scene": "tiny", "render": {"width": 32, "height": 24, "spp": 200000, "threads": 1,
                                    "tile_size": 2, "adaptive": False}})["id"]
    try:
        daemon.wait_job(blocker, ["running"])
        size = Select(driver.find_element(By.ID, "size"))
        other = [o.get_attribute("value") for o in size.options
                 if o.get_attribute("value") != size.first_selected_option.get_attribute("value")][0]
        size.select_by_value(other)
        before = {j["id"] for j in daemon.json("GET", "/v1/jobs")["jobs"]}
        driver.find_element(By.ID, "dl-exr").click()
        until(driver, "the EXR job", lambda: any(
            j["format"] == "exr" for j in daemon.json("GET", "/v1/jobs")["jobs"] if j["id"] not in before))
        exr = [j for j in daemon.json("GET", "/v1/jobs")["jobs"]
               if j["id"] not in before and j["format"] == "exr"][0]
    finally:
        daemon.call("DELETE", "/v1/jobs/" + blocker)
    st = daemon.wait_job(exr["id"], ["done", "failed", "cancelled"])
    for k in ("scene", "width", "height", "spp", "camera"):
        assert st[k] == shown[k], "the EXR's %s is %r, the picture's %r" % (k, st[k], shown[k])
    wait_done(driver)
    return "EXR job %s as job %s" % (exr["id"][:8], shown["id"][:8])


def check_lens(driver, daemon, ctx):
    """The lens model, which GET /v1/options lists from the library, with
    a lens from GET /v1/lenses: the page renders through it."""
    models = [o.get_attribute("value") for o in Select(driver.find_element(By.ID, "model")).options]
    want = [m["name"] for m in daemon.json("GET", "/v1/options")["camera_models"]]
    assert models == want, "the page offers %s, the daemon %s" % (models, want)
    act(driver, lambda: Select(driver.find_element(By.ID, "model")).select_by_value("lens"))
    lenses = [o.get_attribute("value") for o in Select(driver.find_element(By.ID, "key-lens")).options]
    ids = [l["id"] for l in daemon.json("GET", "/v1/lenses")["lenses"]]
    assert lenses == ids, "the page offers lenses %s, the daemon %s" % (lenses, ids)
    act(driver, lambda: Select(driver.find_element(By.ID, "key-lens")).select_by_value(ids[-1]))
    st = daemon.json("GET", "/v1/jobs/" + body_data(driver, "shown"))
    assert st["status"] == "done" and st["camera"]["model"] == "lens" and \
        st["camera"]["lens"] == ids[-1], "the picture is not through %s: %s" % (ids[-1], st["camera"])
    return "%s through %s" % (st["camera"]["model"], st["camera"]["lens"])


def uncaught(driver):
    """The console's uncaught exceptions since the last look (a failed
    request's own network line is the browser's, not the page's)."""
    return [e["message"] for e in driver.get_log("browser") if "Uncaught" in e["message"]]


def check_token_again(driver, daemon, ctx):
    """A token refused mid-session (the daemon restarted with another) is
    asked for again; with it the page starts over with its lists made
    anew, and a change starts one series, not one per start."""
    def count(sel):
        return len(Select(driver.find_element(By.ID, sel)).options)
    scenes, spps = count("scene"), count("spp")
    driver.execute_script("state.token = 'stale'; sessionStorage.setItem('lensray-token', 'stale');")
    Select(driver.find_element(By.ID, "spp")).select_by_value("1")
    until(driver, "the token form", lambda: driver.find_element(By.ID, "token").is_displayed())
    field = driver.find_element(By.ID, "token")
    field.clear()
    field.send_keys(daemon.token + Keys.ENTER)
    wait_done(driver)
    assert (count("scene"), count("spp")) == (scenes, spps), \
        "after the token the lists have %d scenes and %d spp choices, not %d and %d" % (
            count("scene"), count("spp"), scenes, spps)
    before = series(driver)
    act(driver, lambda: Select(driver.find_element(By.ID, "spp")).select_by_value("4"))
    assert series(driver) == before + 1, "one change started %d series" % (series(driver) - before)
    return "%d scenes, one series a change" % scenes


def check_token_ascii(driver, daemon, ctx):
    """A token with a character no header can carry (a typographic
    quote, as a pasted token may have): the token form again, saying so,
    and the right token then works.  fetch refused every request and the
    token was kept: the page stayed locked, even after a reload."""
    driver.execute_script("state.token = '\u201c' + arguments[0] + '\u201d';"
                          "sessionStorage.setItem('lensray-token', state.token);", daemon.token)
    driver.refresh()
    until(driver, "the token form", lambda: driver.find_element(By.ID, "token").is_displayed())
    said = driver.find_element(By.ID, "token-error").text
    assert "ASCII" in said, "the token form says %r" % said
    field = driver.find_element(By.ID, "token")
    field.clear()
    field.send_keys(daemon.token + Keys.ENTER)
    wait_done(driver)
    return "said %r" % said


def check_lost_image(driver, daemon, ctx):
    """A picture that cannot be fetched after its job is done (the daemon
    gone in between: the page's fetch made to fail for /image) is an error
    on the page, and the page renders again after the next change."""
    uncaught(driver)
    driver.execute_script("""
        window.realFetch = window.fetch;
        window.fetch = (path, init) => /[/]image$/.test(path)
            ? Promise.reject(new TypeError("Failed to fetch"))
            : window.realFetch(path, init);""")
    before = series(driver)
    Select(driver.find_element(By.ID, "spp")).select_by_value("1")
    until(driver, "a new series", lambda: series(driver) > before)
    until(driver, "the page to show the error", lambda: body_data(driver, "state") == "error")
    status = driver.find_element(By.ID, "status").text
    assert "does not answer" in status and "/image" in status, "the status says %r" % status
    bad = uncaught(driver)
    assert not bad, "uncaught in the console: %s" % bad
    driver.execute_script("window.fetch = window.realFetch;")
    act(driver, lambda: Select(driver.find_element(By.ID, "spp")).select_by_value("4"))
    return "said: " + status


def check_daemon_gone(driver, daemon, ctx):
    """The daemon killed while the page renders: the page says the server
    does not answer, with no uncaught exception.  Last: it ends the daemon."""
    uncaught(driver)
    before = series(driver)
    Select(driver.find_element(By.ID, "spp")).select_by_value("65536")
    until(driver, "a new series", lambda: series(driver) > before)
    until(driver, "a job of the series to run",
          lambda: body_data(driver, "job") and
          daemon.json("GET", "/v1/jobs/" + body_data(driver, "job"))["status"] == "running")
    daemon.proc.kill()
    daemon.proc.wait()
    until(driver, "the page to show the error", lambda: body_data(driver, "state") == "error")
    status = driver.find_element(By.ID, "status").text
    assert "does not answer" in status, "the status says %r" % status
    bad = uncaught(driver)
    assert not bad, "uncaught in the console: %s" % bad
    return "said: " + status


CHECKS = [("load", check_load), ("cancel", check_cancel), ("focus", check_focus),
          ("overlay", check_overlay), ("download", check_download), ("kept", check_kept),
          ("valuetext", check_valuetext), ("stale-answer", check_stale_answer),
          ("done-in-flight", check_done_in_flight), ("keyboard-focus", check_keyboard_focus),
          ("sky-click", check_sky_click), ("exr-shown", check_exr_shown), ("lens", check_lens),
          ("token-again", check_token_again), ("token-ascii", check_token_ascii), ("lost-image", check_lost_image), ("daemon-gone", check_daemon_gone)]


def run_checks(build, out):
    work = tempfile.mkdtemp(prefix="page-", dir=out)
    downloads = os.path.join(work, "downloads")
    os.makedirs(downloads)
    scene_file = os.path.join(ROOT, "scenes", "spheres.json")
    daemon = Daemon(build, work, [scene_file, os.path.join(ROOT, "tests", "data", "tiny.json")])
    ctx = {"downloads": downloads, "scene": json.load(open(scene_file))}
    results = []
    driver = None
    try:
        driver = browser(downloads)
        broken = None
        for name, fn in CHECKS:
            if broken:
                results.append("fail %s: not run, %s failed first" % (name, broken))
                continue
            try:
                detail = fn(driver, daemon, ctx)
                results.append("ok " + name + (": " + detail if detail else ""))
            except Exception as e:  # a check's failure, reported by name
                results.append("fail %s: %s: %s" % (name, type(e).__name__, e))
                broken = name
    except Exception as e:
        results.extend("fail %s: the browser did not start: %s" % (n, e) for n, _ in CHECKS
                       if not any(r.split()[1].rstrip(":") == n for r in results))
    finally:
        if driver is not None:
            driver.quit()
        daemon.stop()
    with open(os.path.join(out, "results"), "w") as f:
        f.write("\n".join(results) + "\n")
    print("\n".join(results))
    return all(r.startswith("ok") for r in results)


def screenshot(driver, name, shots):
    """The page as docs/page.md shows it: spheres with an aperture, focused
    by a click on the third sphere, with the plan drawn over it; the other
    scenes as they load."""
    if name == "spheres":
        slider = driver.find_element(By.ID, "key-aperture_radius")
        act(driver, lambda: [slider.send_keys(Keys.ARROW_RIGHT) for _ in range(50)])
        img = driver.find_element(By.ID, "picture")
        act(driver, lambda: ActionChains(driver).move_to_element_with_offset(
            img, int(-0.04 * img.size["width"]), int(0.02 * img.size["height"])).click().perform())
        driver.save_screenshot(os.path.join(shots, "page-spheres.png"))
        driver.find_element(By.ID, "show-plan").click()
        driver.save_screenshot(os.path.join(shots, "page-spheres-plan.png"))
        driver.find_element(By.ID, "show-plan").click()
    else:
        driver.save_screenshot(os.path.join(shots, "page-%s.png" % name))
        if name == "chromatic":
            amp = driver.find_element(By.ID, "chroma-amplify")
            act(driver, lambda: [amp.send_keys(Keys.ARROW_RIGHT) for _ in range(14)])
            driver.save_screenshot(os.path.join(shots, "page-chromatic-amplified.png"))
            driver.find_element(By.ID, "show-plan").click()
            driver.save_screenshot(os.path.join(shots, "page-chromatic-plan.png"))
            driver.find_element(By.ID, "show-plan").click()


def measure(build, out, shots=None):
    """Slider move -> first picture on each shipped scene at the page's
    default size; and, with shots, screenshots of the page."""
    work = tempfile.mkdtemp(prefix="page-measure-", dir=out)
    scenes = sorted(os.path.join(ROOT, "scenes", f) for f in os.listdir(os.path.join(ROOT, "scenes"))
                    if f.endswith(".json"))
    daemon = Daemon(build, work, scenes)
    meshes = os.path.join(ROOT, "scenes", "meshes")
    if os.path.isdir(meshes):
        shutil.copytree(meshes, os.path.join(work, "scenes", "meshes"))
    driver = browser(work)
    try:
        open_page(driver, daemon)
        names = [o.get_attribute("value") for o in
                 Select(driver.find_element(By.ID, "scene")).options]
        if shots:
            names = ["spheres", "bokeh", "chromatic"]
        for name in names:
            if Select(driver.find_element(By.ID, "scene")).first_selected_option.get_attribute("value") != name:
                act(driver, lambda: Select(driver.find_element(By.ID, "scene")).select_by_value(name))
            if Select(driver.find_element(By.ID, "model")).first_selected_option.get_attribute("value") == "pinhole":
                act(driver, lambda: Select(driver.find_element(By.ID, "model")).select_by_value("thinlens"))
            times = []
            for _ in range(5):
                act(driver, lambda: move_focus(driver))
                times.append(float(body_data(driver, "firstPictureMs")))
            st = daemon.json("GET", "/v1/jobs/" + body_data(driver, "shown"))
            times.sort()
            print("%-18s %4dx%-4d first picture after a slider move: median %4.0f ms (min %.0f, max %.0f)"
                  % (name, st["width"], st["height"], times[2], times[0], times[4]))
            if shots:
                screenshot(driver, name, shots)
        if shots:
            # The real lens: spheres through the shipped double Gauss.
            act(driver, lambda: Select(driver.find_element(By.ID, "scene")).select_by_value("spheres"))
            act(driver, lambda: Select(driver.find_element(By.ID, "model")).select_by_value("lens"))
            if Select(driver.find_element(By.ID, "key-lens")).first_selected_option.get_attribute("value") != "double-gauss-50":
                act(driver, lambda: Select(driver.find_element(By.ID, "key-lens")).select_by_value("double-gauss-50"))
            img = driver.find_element(By.ID, "picture")
            act(driver, lambda: ActionChains(driver).move_to_element_with_offset(
                img, int(-0.04 * img.size["width"]), int(0.02 * img.size["height"])).click().perform())
            driver.save_screenshot(os.path.join(shots, "page-lens.png"))
    finally:
        driver.quit()
        daemon.stop()


if __name__ == "__main__":
    build, out = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    os.makedirs(out, exist_ok=True)
    if "--measure" in sys.argv:
        measure(build, out)
    elif "--screenshots" in sys.argv:
        measure(build, out, os.path.abspath(sys.argv[sys.argv.index("--screenshots") + 1]))
    else:
        sys.exit(0 if run_checks(build, out) else 1)
