#!/usr/bin/env python3
"""Accuracy against time: the harness behind `make accuracy`.

Renders the accuracy scenes (scenes/accuracy-*.json) with the lensray CLI
at increasing samples per pixel, for every sampler and every combination
of effect planning and adaptive sampling, measures each image against a
converged reference with bench/accuracy/imgdiff (relative MSE, an
edge-aware gradient error and 1 - SSIM), and writes

  build/accuracy/results.csv         one row per render
  build/accuracy/summary.md          every generated table
  build/accuracy/plots/*.dat, *.gp   the data and gnuplot scripts
  docs/accuracy-*.png                the plots (gnuplot)
  docs/accuracy.md                   the generated blocks between
                                     <!-- generated: NAME --> and
                                     <!-- end generated: NAME --> markers

References are cached in build/accuracy/ref/, keyed by a hash of the
scene file and the settings, so only the first run pays for them.

Only the Python standard library is used.  See docs/accuracy.md for
what is measured and why.
"""

import argparse
import csv
import datetime
import hashlib
import json
import math
import os
import platform
import re
import resource
import shutil
import statistics
import subprocess
import sys
import time

# ---- what is measured -------------------------------------------------------

SAMPLERS = ["grid", "jittered", "random", "sobol"]

# The four ways of spending samples.  "full" is the full simulation: lens
# and colours simulated in every pixel, spp samples everywhere.
MODES = [
    ("full", {"render.plan": "false", "render.adaptive": "false"}),
    ("plan", {"render.plan": "true", "render.adaptive": "false"}),
    ("adaptive", {"render.plan": "false", "render.adaptive": "true"}),
    ("plan+adaptive", {"render.plan": "true", "render.adaptive": "true"}),
]
MODE_NAMES = [m for m, _ in MODES]

POW2 = [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024]
SQUARES = [1, 4, 16, 64, 256, 1024]

# Each scene: its file, how far its ladders go (grid and jittered need
# square counts, so they get the squares up to the same maximum), and its
# references: two sobol renders with different seeds at ref_spp.
SCENES = [
    {
        "name": "focus",
        "file": "scenes/accuracy-focus.json",
        "title": "mostly in focus",
        "max_spp": 1024,
        "ref_spp": 8192,
        "ref_sets": {},
    },
    {
        "name": "defocus",
        "file": "scenes/accuracy-defocus.json",
        "title": "strongly defocused",
        "max_spp": 1024,
        "ref_spp": 8192,
        "ref_sets": {},
    },
    {
        "name": "chroma",
        "file": "scenes/accuracy-chroma.json",
        "title": "spectral chromatic aberration (8 wavelengths)",
        "max_spp": 128,
        "ref_spp": 512,
        # The reference sees the spectrum with 32 wavelengths per sample
        # (the ladders use the scene's 8): it stands for the continuous
        # spectrum, against which every wavelength count is judged.
        "ref_sets": {"camera.chromatic.wavelengths": "32"},
    },
]

# rgb against spectral on the chroma scene, sobol, each colour model with
# and without planning plus adaptive sampling.  The ladders are cut so
# that every model gets about the same render time at the top.
COLOUR_SCENE = "chroma"
COLOUR_MODELS = [
    ("rgb", None, 512),
    ("spectral-3", 3, 512),
    ("spectral-5", 5, 256),
    ("spectral-8", 8, 128),
    ("spectral-16", 16, 64),
]
COLOUR_MODES = ["full", "plan+adaptive"]

# The dominant wavelengths of the sRGB primaries (nm): rgb mode traces the
# glass at these three, with the lens and the sensor of the spectral
# render (see colour_sets()).
RGB_WAVELENGTHS = (611.3, 549.1, 464.3)

ERROR_TARGETS = [1e-2, 1e-3, 1e-4]

# Issue 17: the default's relMSE at every rung at most this many times the
# full simulation's at the same spp and sampler.
BUDGET_ERROR = 1.2
EQUAL_TIMES = [0.1, 0.3, 1.0]

REF_SEEDS = (1000001, 1000002)
REF_VERSION = "1"  # bump to invalidate every cached reference

# Timing: renders shorter than MIN_TIMED seconds are repeated (at least
# 3, at most MAX_REPEATS runs, until MIN_TIMED seconds were spent) and the
# fastest run is kept.
MIN_TIMED = 1.0
MAX_REPEATS = 7

# Points used for the slope fits: spp >= FIT_MIN_SPP (below that every
# sampler is in its pre-asymptotic regime) and an error at least
# FLOOR_FACTOR times the reference's own noise.
FIT_MIN_SPP = 4
FLOOR_FACTOR = 10.0

# Slopes of relative MSE against spp that theory predicts (MSE, so twice
# the RMSE rate): Monte Carlo N^-1; stratified and randomised-QMC
# integrands with discontinuities (edges) in d dimensions N^-(1 + 1/d)
# (Mitchell 1996; Owen 1997 and Pharr et al. for scrambled nets), with d
# = 2 where only the pixel is integrated over and d = 4 with the lens;
# the grid's midpoint rule is deterministic and errs by O(N^-1/2) in each
# edge pixel, so N^-1 in MSE, with no noise.
THEORY = {
    "random": ("-1", "Monte Carlo: MSE ~ N^-1 (RMSE N^-0.5) on any integrand"),
    "grid": ("-1", "midpoint rule: O(N^-1/2) error in edge pixels, MSE ~ N^-1, deterministic"),
    "jittered": ("-1.5 (pixel edges, 2-D) to -1.25 (4-D with the lens)",
                 "stratified: MSE ~ N^-(1+1/d) with discontinuities in d dimensions"),
    "sobol": ("-1.5 (2-D) to -1.25 (4-D); steeper where smooth",
              "Owen-scrambled net: N^-(1+1/d) with edges, up to N^-3 on smooth integrands"),
}


# ---- small helpers ----------------------------------------------------------

def log(msg):
    print(msg, flush=True)


def fmt_e(v):
    """A number in compact scientific notation, for errors."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "n/a"
    return "%.2e" % v


def fmt_t(v):
    """A time in seconds with sensible precision."""
    if v is None:
        return "n/a"
    if v < 0.1:
        return "%.3f s" % v
    if v < 10:
        return "%.2f s" % v
    return "%.1f s" % v


def ladder(sampler, max_spp):
    steps = SQUARES if sampler in ("grid", "jittered") else POW2
    return [n for n in steps if n <= max_spp]


def sets_args(sets):
    args = []
    for k, v in sets.items():
        args += ["--set", "%s=%s" % (k, v)]
    return args


class RenderError(Exception):
    pass


class Harness:
    def __init__(self, opts):
        self.opts = opts
        self.lensray = opts.lensray
        self.imgdiff = opts.imgdiff
        self.work = opts.work
        self.rows = []
        self.failures = []  # (what, message)
        self.mode_ok = {}   # mode -> None or the reason it is unavailable
        self.plan_keys = False
        self.refs = {}      # scene -> {"path", "floor", ...}
        self.started = time.time()
        self.finished = None
        self.load_start = os.getloadavg()
        self.load_end = None
        self.child_cpu = 0.0
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        self.child_cpu = ru.ru_utime + ru.ru_stime
        self.overhead = {}  # scene -> CPU seconds of a render of one pixel
        self.scene_now = None
        self.clock = opts.clock
        os.makedirs(os.path.join(self.work, "ref"), exist_ok=True)
        os.makedirs(os.path.join(self.work, "runs"), exist_ok=True)
        os.makedirs(os.path.join(self.work, "plots"), exist_ok=True)

    # ---- running the CLI ----------------------------------------------------

    def render(self, scene_file, out, sets):
        """One render; returns the --stats JSON, with "cpu" added: the
        process's user + system CPU seconds.  Raises RenderError."""
        cmd = [self.lensray, "render", scene_file, "-o", out, "--stats",
               "--quiet"] + sets_args(sets)
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        self.child_cpu = ru.ru_utime + ru.ru_stime
        p = subprocess.Popen(cmd, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
        stdout, stderr = p.communicate()
        # communicate() reaped the child; its CPU time is what the
        # children's total grew by (one child at a time runs here).
        if p.returncode != 0:
            msg = (stderr.strip().splitlines() or ["exit %d" % p.returncode])[-1]
            raise RenderError(msg)
        for line in stdout.splitlines():
            line = line.strip()
            if line.startswith("{"):
                st = json.loads(line)
                ru = resource.getrusage(resource.RUSAGE_CHILDREN)
                total = ru.ru_utime + ru.ru_stime
                st["cpu"] = total - self.child_cpu
                self.child_cpu = total
                return st
        raise RenderError("no --stats line in the output")

    def render_cpu(self, st):
        """The render's own CPU seconds: `cpu_seconds` of --stats (the
        render's threads, planning included; not starting the process,
        loading the scene or writing the image), or, from a CLI without
        it, the process's CPU time less the scene's fixed cost."""
        if "cpu_seconds" in st:
            return st["cpu_seconds"]
        return max(st["cpu"] - self.overhead.get(self.scene_now, 0.0), 1e-4)

    def timed_render(self, scene_file, out, sets):
        """Renders, repeating short renders; returns (stats, wall, cpu,
        runs).

        Both clocks keep the fastest run: other processes on the machine
        only ever add time, so the minimum is the best estimate of the
        render's own cost."""
        st = self.render(scene_file, out, sets)
        walls, cpus = [st["seconds"]], [self.render_cpu(st)]
        while (walls[0] < MIN_TIMED and len(walls) < MAX_REPEATS and
               (len(walls) < 3 or sum(walls) < MIN_TIMED)):
            again = self.render(scene_file, out, sets)
            walls.append(again["seconds"])
            cpus.append(self.render_cpu(again))
        return st, min(walls), min(cpus), walls

    def diff(self, ref, img):
        p = subprocess.run([self.imgdiff, ref, img], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
        if p.returncode != 0:
            raise RenderError("imgdiff: " + p.stderr.strip())
        return json.loads(p.stdout.strip().splitlines()[-1])

    # ---- which settings this build has ------------------------------------

    def probe(self):
        """Finds which modes the CLI accepts, with a tiny render each."""
        scene = SCENES[0]["file"]
        out = os.path.join(self.work, "runs", "probe.exr")
        tiny = {"render.width": "8", "render.height": "6", "render.spp": "1"}
        for name, sets in MODES:
            try:
                self.render(scene, out, dict(tiny, **sets))
                self.mode_ok[name] = None
            except RenderError as e:
                self.mode_ok[name] = str(e)
        self.plan_keys = self.mode_ok["full"] is None
        if not self.plan_keys:
            # A build without the planner: its only mode is the full
            # simulation, which it does without being asked.
            try:
                self.render(scene, out, tiny)
                self.mode_ok["full"] = None
            except RenderError as e:
                sys.exit("accuracy: the CLI cannot render %s: %s" % (scene, e))
        for name in MODE_NAMES:
            if self.mode_ok[name] is not None:
                log("accuracy: mode %s is not available in this build (%s); "
                    "its rows are skipped" % (name, self.mode_ok[name]))
                self.failures.append(("mode " + name, "not available in this "
                                      "build: " + self.mode_ok[name]))

    def mode_sets(self, mode):
        if mode == "full" and not self.plan_keys:
            return {}
        return dict(dict(MODES)[mode])

    # ---- references ---------------------------------------------------------

    def reference(self, sc):
        """Renders (or finds in the cache) the scene's two references."""
        # The key is the scene's content without its description, so that
        # rewording the description does not throw the references away.
        with open(sc["file"]) as f:
            scene = json.load(f)
        scene.pop("description", None)
        scene_bytes = json.dumps(scene, sort_keys=True).encode()
        logical = {"ref_version": REF_VERSION, "spp": sc["ref_spp"],
                   "sampler": "sobol", "mode": "full",
                   "sets": sorted(sc["ref_sets"].items())}
        h = hashlib.sha256(scene_bytes + json.dumps(logical, sort_keys=True)
                           .encode()).hexdigest()[:16]
        paths, seconds = [], []
        for seed in REF_SEEDS:
            path = os.path.join(self.work, "ref", "ref-%s-%s-%d.exr"
                                % (sc["name"], h, seed))
            meta = path[:-4] + ".json"
            if os.path.exists(path) and os.path.exists(meta):
                with open(meta) as f:
                    seconds.append(json.load(f)["seconds"])
                log("accuracy: [%s] reference seed %d cached (%s)"
                    % (sc["name"], seed, os.path.basename(path)))
            else:
                log("accuracy: [%s] rendering reference seed %d at %d spp "
                    "(cached for later runs)..." % (sc["name"], seed,
                                                    sc["ref_spp"]))
                sets = dict(sc["ref_sets"])
                sets.update({"render.spp": str(sc["ref_spp"]),
                             "render.sampler": "sobol",
                             "render.seed": str(seed)})
                sets.update(self.mode_sets("full"))
                tmp = path + ".tmp.exr"
                st = self.render(sc["file"], tmp, sets)
                os.replace(tmp, path)
                with open(meta, "w") as f:
                    json.dump({"seconds": st["seconds"], "stats": st,
                               "settings": logical, "seed": seed}, f)
                seconds.append(st["seconds"])
                log("accuracy: [%s] reference seed %d took %s"
                    % (sc["name"], seed, fmt_t(st["seconds"])))
            paths.append(path)
        d = self.diff(paths[0], paths[1])
        # Both references carry the same amount of noise, so relMSE(A, B)
        # is about twice what reference A adds to every measurement.
        ref = {"path": paths[0], "other": paths[1], "hash": h,
               "floor": d["relmse"] / 2, "grad_floor": d["grad_relmse"] / 2,
               "dssim_floor": d["dssim"] / 2, "seconds": seconds,
               "spp": sc["ref_spp"]}
        log("accuracy: [%s] reference noise (half the relMSE of the two "
            "seeds): %s" % (sc["name"], fmt_e(ref["floor"])))
        self.refs[sc["name"]] = ref
        return ref

    def measure_overhead(self, sc):
        """CPU seconds of everything but the render proper (starting the
        process, loading the scene, building the BVH, writing the EXR),
        from the fastest of five renders of one pixel; subtracted from
        the process's CPU time when the CLI does not report the render's
        own (cpu_seconds); logged either way."""
        out = os.path.join(self.work, "runs", "overhead.exr")
        cpus = []
        for _ in range(5):
            st = self.render(sc["file"], out, {"render.spp": "1",
                                               "render.region": "[0, 0, 1, 1]"})
            cpus.append(st["cpu"])
        self.overhead[sc["name"]] = min(cpus)
        log("accuracy: [%s] fixed CPU cost of a run (subtracted from the "
            "process's CPU time only for a CLI without cpu_seconds): %s"
            % (sc["name"], fmt_t(min(cpus))))

    def choose_clock(self):
        """The clock of the tables and plots: wall time from --stats, or,
        when the machine was shared (wall time well above CPU time over
        the threads), CPU time."""
        ratios = sorted(r["wall"] / (r["cpu"] / r["threads"]) for r in self.rows
                        if r["wall"] >= 0.05 and r["cpu"] > 0)
        self.wall_cpu_ratio = ratios[len(ratios) // 2] if ratios else None
        if self.clock == "auto":
            shared = self.wall_cpu_ratio is not None and self.wall_cpu_ratio > 1.3
            self.clock = "cpu" if shared else "wall"
        for r in self.rows:
            r["seconds"] = r["cpu"] if self.clock == "cpu" else r["wall"]
        log("accuracy: median wall / (CPU / threads) = %s: times are %s"
            % ("%.2f" % self.wall_cpu_ratio if self.wall_cpu_ratio else "n/a",
               "CPU seconds" if self.clock == "cpu" else "wall seconds"))

    # ---- ladders ------------------------------------------------------------

    def run_ladder(self, sc, group, config, sampler, mode, spps, extra):
        """Renders one configuration's ladder and records a row per step."""
        ref = self.refs[sc["name"]]
        if self.mode_ok.get(mode) is not None:
            return
        rundir = os.path.join(self.work, "runs", sc["name"])
        os.makedirs(rundir, exist_ok=True)
        line = []
        for spp in spps:
            sets = dict(extra)
            sets.update({"render.spp": str(spp), "render.sampler": sampler})
            sets.update(self.mode_sets(mode))
            out = os.path.join(rundir, "%s-%d.exr"
                               % (re.sub(r"[^A-Za-z0-9.-]+", "_", config), spp))
            try:
                st, wall, cpu, all_t = self.timed_render(sc["file"], out, sets)
                d = self.diff(ref["path"], out)
            except RenderError as e:
                self.failures.append(("%s %s spp %d" % (sc["name"], config, spp),
                                      str(e)))
                log("accuracy: [%s] %s at spp %d FAILED: %s; the rest of this "
                    "ladder is skipped" % (sc["name"], config, spp, e))
                break
            pixels = st["width"] * st["height"]
            plan = st.get("plan", {})
            row = {
                "scene": sc["name"], "group": group, "config": config,
                "sampler": sampler, "mode": mode, "spp": spp,
                "mean_spp": st["samples"] / pixels,
                "seconds": wall, "wall": wall, "wall_max": max(all_t),
                "cpu": cpu, "cpu_raw": st["cpu"], "runs": len(all_t), "threads": st["threads"],
                "samples": st["samples"], "rays": st["rays"],
                "camera_rays": plan.get("camera_rays", ""),
                "full_camera_rays": plan.get("full_camera_rays", ""),
                "lens_pixels": plan.get("lens_pixels", ""),
                "chroma_pixels": plan.get("chroma_pixels", ""),
                "relmse": d["relmse"], "grad_relmse": d["grad_relmse"],
                "dssim": d["dssim"],
            }
            self.rows.append(row)
            line.append("%d:%s/%s" % (spp, fmt_e(d["relmse"]), fmt_t(wall)))
        log("accuracy: [%s] %-28s %s" % (sc["name"], config, "  ".join(line)))

    def run_all(self):
        self.probe()
        for sc in SCENES:
            if self.opts.scenes and sc["name"] not in self.opts.scenes:
                continue
            sc = dict(sc)
            if self.opts.quick:
                sc["max_spp"] = min(sc["max_spp"], 64)
                sc["ref_spp"] = min(sc["ref_spp"], 512)
            self.reference(sc)
            self.scene_now = sc["name"]
            self.measure_overhead(sc)
            for sampler in SAMPLERS:
                for mode in MODE_NAMES:
                    self.run_ladder(sc, "main", "%s %s" % (sampler, mode),
                                    sampler, mode,
                                    ladder(sampler, sc["max_spp"]), {})
            if sc["name"] == COLOUR_SCENE and not self.opts.skip_colour:
                for model, n, top in COLOUR_MODELS:
                    if self.opts.quick:
                        top = min(top, 32)
                    for mode in COLOUR_MODES:
                        cfg = "%s %s" % (model, mode)
                        if n == scene_wavelengths(sc["file"]):
                            # The scene's own wavelength count: the main
                            # ladder's sobol rows are this model's.
                            self.copy_rows(sc["name"], "sobol " + mode, cfg,
                                           top)
                            continue
                        self.run_ladder(sc, "colour", cfg, "sobol", mode,
                                        ladder("sobol", top),
                                        self.colour_sets(sc, n))

    def copy_rows(self, scene, src, dst, top):
        rows = [dict(r, group="colour", config=dst) for r in self.rows
                if r["scene"] == scene and r["config"] == src and r["spp"] <= top]
        self.rows += rows
        log("accuracy: [%s] %-28s the rows of %s" % (scene, dst, src))

    def colour_sets(self, sc, n):
        """Overrides for one colour model of the chroma scene."""
        if n is not None:
            return {"camera.chromatic.wavelengths": str(n)}
        return rgb_mode_sets(sc["file"])

    # ---- output -------------------------------------------------------------

    def save_meta(self):
        meta = {"started": self.started, "finished": time.time(),
                "load_start": self.load_start, "load_end": os.getloadavg(),
                "failures": self.failures, "renders": len(self.rows),
                "cpu_count": os.cpu_count()}
        with open(os.path.join(self.work, "run.json"), "w") as f:
            json.dump(meta, f, indent=1)

    def load_previous(self):
        """The rows and run facts of the last run (--from-csv): the
        tables and plots are rebuilt without rendering again."""
        with open(os.path.join(self.work, "run.json")) as f:
            meta = json.load(f)
        self.started = meta["started"]
        self.finished = meta["finished"]
        self.load_start = tuple(meta["load_start"])
        self.load_end = tuple(meta["load_end"])
        self.failures = [tuple(x) for x in meta["failures"]]
        ints = {"spp", "runs", "threads", "samples", "rays", "camera_rays",
                "full_camera_rays"}
        text = {"scene", "group", "config", "sampler", "mode"}
        with open(os.path.join(self.work, "results.csv"), newline="") as f:
            for r in csv.DictReader(f):
                for k, v in r.items():
                    if k in text or v == "":
                        continue
                    r[k] = int(v) if k in ints else float(v)
                self.rows.append(r)
        names = {r["scene"] for r in self.rows}
        for sc in SCENES:
            if sc["name"] in names:
                self.reference(sc)

    def write_csv(self):
        path = os.path.join(self.work, "results.csv")
        keys = ["scene", "group", "config", "sampler", "mode", "spp",
                "mean_spp", "seconds", "wall", "wall_max", "cpu", "cpu_raw",
                "runs", "threads",
                "samples", "rays", "camera_rays", "full_camera_rays",
                "lens_pixels", "chroma_pixels", "relmse", "grad_relmse",
                "dssim"]
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            for r in self.rows:
                w.writerow(r)
        log("accuracy: wrote %s (%d renders)" % (path, len(self.rows)))


# ---- rgb mode as three wavelengths of the spectral lens ---------------------

def sellmeier_sf11(nm):
    """SF11's index (Schott's Sellmeier coefficients, as lib/lens.c)."""
    b = (1.73759695, 0.313747346, 1.89878101)
    c = (0.013188707, 0.0623068142, 155.23629)
    l2 = (nm / 1000.0) ** 2
    return math.sqrt(1 + sum(bi * l2 / (l2 - ci) for bi, ci in zip(b, c)))


def rgb_mode_sets(scene_file):
    """rgb mode made physically equal to the spectral render at three
    wavelengths.  The spectral thin lens has power P = 1000 / F at the d
    line and the sensor where the d line is sharp at s.  rgb mode's
    reference is green: so give it green's power, P (n_g - 1) / (n_d - 1)
    (lensmaker), with the aperture radius kept, and the focus distance at
    which green is sharp on that same sensor; red and blue then get
    exactly the spectral lens's power at their wavelengths."""
    with open(scene_file) as f:
        cam = json.load(f)["camera"]
    chrom = cam["chromatic"]
    assert chrom.get("glass") == "SF11" and chrom.get("focal_model") == "lensmaker"
    F = cam["focal_length_mm"]
    s = cam["focus_distance"]
    radius = F / 1000.0 / (2 * cam["f_number"])
    nd = sellmeier_sf11(587.5618)
    nr, ng, nb = (sellmeier_sf11(w) for w in RGB_WAVELENGTHS)
    P = 1000.0 / F
    a = (ng - 1) / (nd - 1)
    s_green = 1.0 / (1.0 / s + P * (a - 1))
    chromatic = {"mode": "rgb", "focal_model": "lensmaker",
                 "ior": [round(nr, 7), round(ng, 7), round(nb, 7)]}
    return {"camera.chromatic": json.dumps(chromatic),
            "camera.f_number": "0",
            "camera.aperture_radius": repr(radius),
            "camera.focal_length_mm": repr(F / a),
            "camera.focus_distance": repr(s_green)}


# ---- analysis ---------------------------------------------------------------

def curve(rows, scene, config, x="seconds", y="relmse"):
    pts = [(r[x], r[y], r) for r in rows
           if r["scene"] == scene and r["config"] == config]
    return sorted(pts, key=lambda p: p[2]["spp"])


def fit_slope(points, floor):
    """Least-squares slope of log(err) on log(spp) over the points with
    spp >= FIT_MIN_SPP and err >= FLOOR_FACTOR * floor; (slope, n)."""
    xs, ys = [], []
    for x, y, r in points:
        if r["spp"] >= FIT_MIN_SPP and y >= FLOOR_FACTOR * floor and y > 0:
            xs.append(math.log(x))
            ys.append(math.log(y))
    if len(xs) < 3:
        return None, len(xs)
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((a - mx) ** 2 for a in xs)
    if sxx == 0:
        return None, len(xs)
    return sum((a - mx) * (b - my) for a, b in zip(xs, ys)) / sxx, len(xs)


def time_to(points, target):
    """Time at which the error first reaches target, interpolated in
    log-log between ladder steps; None if it never does."""
    prev = None
    for t, e, _ in points:
        if e <= target:
            if prev is None:
                return t
            t0, e0 = prev
            if e0 <= e or t0 <= 0:
                return t
            f = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0)))
        prev = (t, e)
    return None


def error_at(points, t_star):
    """Error at time t_star, interpolated in log-log; None outside."""
    pts = sorted((t, e) for t, e, _ in points)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if t0 <= t_star <= t1 and t1 > t0 and e0 > 0 and e1 > 0:
            f = (math.log(t_star) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(e0) + f * (math.log(e1) - math.log(e0)))
    return None


class Report:
    def __init__(self, h):
        self.h = h
        self.rows = h.rows
        self.blocks = {}

    def configs(self, scene, group="main"):
        seen = []
        for r in self.rows:
            if r["scene"] == scene and r["group"] == group and r["config"] not in seen:
                seen.append(r["config"])
        return seen

    def ref_note(self, target, floor):
        return target < 3 * floor

    def time_cell(self, scene, config, target):
        pts = curve(self.rows, scene, config)
        if not pts:
            return "not available in this build"
        floor = self.h.refs[scene]["floor"]
        t = time_to(pts, target)
        if t is None:
            best = min(pts, key=lambda p: p[1])
            return "not reached (%s at %s)" % (fmt_e(best[1]), fmt_t(best[0]))
        s = fmt_t(t)
        if pts[0][1] <= target:
            s = "<= " + s
        if self.ref_note(target, floor):
            s += " (ref. noise)"
        return s

    # -- the blocks --

    def block_run(self):
        h = self.h
        lines = []
        ver = subprocess.run([h.lensray, "--version"], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True).stdout.strip()
        cpu = ""
        try:
            with open("/proc/cpuinfo") as f:
                for line in f:
                    if line.startswith("model name"):
                        cpu = line.split(":", 1)[1].strip()
                        break
        except OSError:
            pass
        lines.append("Generated by `make accuracy` on %s, %s (%d cores%s), "
                     "%s; %d renders in %.0f s (references included when "
                     "not cached)." % (
                         datetime.datetime.fromtimestamp(h.started).strftime("%Y-%m-%d %H:%M"),
                         platform.machine(), os.cpu_count() or 0,
                         ", " + cpu if cpu else "", ver or "lensray",
                         len(self.rows), (h.finished or time.time()) - h.started))
        la, lb = h.load_start, h.load_end or os.getloadavg()
        lines.append("")
        lines.append("Load average (1, 5, 15 min) at the start: %.1f, %.1f, %.1f; "
                     "at the end: %.1f, %.1f, %.1f.  Anything above the core "
                     "count means other processes shared the machine and the "
                     "times are inflated (the fastest of the repeated runs is "
                     "kept to limit that)." % (la + lb))
        lines.append("")
        if h.clock == "cpu":
            lines.append("**Times are CPU seconds of the render** (`cpu_seconds` "
                         "of `--stats`: the render's threads together, planning "
                         "included; not starting the process, loading the scene "
                         "or writing the image).  Wall time was %.2f times the "
                         "CPU time per thread (median over the renders of "
                         "50 ms or more)%s.  On an idle machine with %d cores, "
                         "divide by about %d for the wall time."
                         % (h.wall_cpu_ratio or float("nan"),
                            ": the machine was shared, and wall times measured "
                            "the other processes as much as the renders"
                            if (h.wall_cpu_ratio or 0) > 1.3 else "",
                            os.cpu_count() or 0, os.cpu_count() or 1))
        else:
            lines.append("**Times are wall seconds** (`--stats`), on %d threads; "
                         "median wall time over CPU time per thread: %s."
                         % (os.cpu_count() or 0,
                            "%.2f" % h.wall_cpu_ratio if h.wall_cpu_ratio else "n/a"))
        lines.append("")
        lines.append("| scene | file | size | ladder (max spp) | reference | reference noise (relMSE) |")
        lines.append("|---|---|---|---|---|---|")
        for sc in SCENES:
            if sc["name"] not in h.refs:
                continue
            ref = h.refs[sc["name"]]
            rs = [r for r in self.rows if r["scene"] == sc["name"]]
            size = "%d x %d" % scene_size(sc["file"])
            sets = ", ".join("%s=%s" % kv for kv in sc["ref_sets"].items())
            lines.append("| %s | `%s` | %s | %d | sobol, %d spp%s, seeds %d and %d (%s each) | %s |" % (
                sc["title"], sc["file"], size,
                max([r["spp"] for r in rs if r["group"] == "main"] or [0]),
                ref["spp"], ", " + sets if sets else "",
                REF_SEEDS[0], REF_SEEDS[1],
                fmt_t(statistics.mean(ref["seconds"])), fmt_e(ref["floor"])))
        if h.failures:
            lines.append("")
            lines.append("Not measured:")
            lines.append("")
            for what, msg in h.failures:
                lines.append("- %s: %s" % (what, msg))
        self.blocks["run"] = "\n".join(lines)

    def block_slopes(self):
        lines = ["| sampler | theory (relMSE vs spp) | " +
                 " | ".join(sc["title"].split(" (")[0] for sc in SCENES
                            if sc["name"] in self.h.refs) + " |",
                 "|---|---|" + "---|" * len(self.h.refs)]
        for sampler in SAMPLERS:
            cells = []
            for sc in SCENES:
                if sc["name"] not in self.h.refs:
                    continue
                pts = curve(self.rows, sc["name"], sampler + " full", x="mean_spp")
                s, n = fit_slope(pts, self.h.refs[sc["name"]]["floor"])
                cells.append("%.2f (%d pts)" % (s, n) if s is not None else "n/a")
            lines.append("| %s | %s | %s |" % (sampler, THEORY[sampler][0],
                                               " | ".join(cells)))
        lines.append("")
        lines.append("The same fit for every configuration (relMSE against "
                     "the mean samples per pixel actually taken; the "
                     "edge-aware gradient error in brackets):")
        lines.append("")
        lines.append("| configuration | " + " | ".join(
            sc["name"] for sc in SCENES if sc["name"] in self.h.refs) + " |")
        lines.append("|---|" + "---|" * len(self.h.refs))
        for sampler in SAMPLERS:
            for mode in MODE_NAMES:
                cfg = "%s %s" % (sampler, mode)
                cells = []
                for sc in SCENES:
                    if sc["name"] not in self.h.refs:
                        continue
                    ref = self.h.refs[sc["name"]]
                    pts = curve(self.rows, sc["name"], cfg, x="mean_spp")
                    if not pts:
                        cells.append("not available in this build")
                        continue
                    s, _ = fit_slope(pts, ref["floor"])
                    g, _ = fit_slope(curve(self.rows, sc["name"], cfg,
                                           x="mean_spp", y="grad_relmse"),
                                     ref["grad_floor"])
                    cells.append("%s (%s)" % ("%.2f" % s if s is not None else "n/a",
                                              "%.2f" % g if g is not None else "n/a"))
                lines.append("| %s | %s |" % (cfg, " | ".join(cells)))
        self.blocks["slopes"] = "\n".join(lines)

    def block_time_to(self, scene):
        lines = ["| configuration | " + " | ".join(
            "relMSE %s" % fmt_e(t).replace("1.00e-0", "1e-") for t in ERROR_TARGETS) +
            " | relMSE at max spp | 1 - SSIM at max spp | samples vs full |",
            "|---|" + "---|" * (len(ERROR_TARGETS) + 3)]
        for cfg in ["%s %s" % (s, m) for s in SAMPLERS for m in MODE_NAMES]:
            pts = curve(self.rows, scene, cfg)
            if not pts:
                lines.append("| %s | %s | | | |" % (
                    cfg, " | ".join(["not available in this build"] * len(ERROR_TARGETS))))
                continue
            last = pts[-1][2]
            full = curve(self.rows, scene, cfg.split()[0] + " full")
            frac = ""
            if full and len(full) == len(pts):
                frac = "%.0f%%" % (100.0 * sum(p[2]["samples"] for p in pts) /
                                   sum(p[2]["samples"] for p in full))
            lines.append("| %s | %s | %s | %s | %s |" % (
                cfg, " | ".join(self.time_cell(scene, cfg, t) for t in ERROR_TARGETS),
                fmt_e(last["relmse"]), fmt_e(last["dssim"]), frac))
        self.blocks["time-" + scene] = "\n".join(lines)

    def speedups(self, scene, target, group="main", configs=None):
        configs = configs or self.configs(scene, group)
        times = {}
        for cfg in configs:
            t = time_to(curve(self.rows, scene, cfg), target)
            if t is not None:
                times[cfg] = t
        return times

    def block_speedups(self):
        lines = ["| scene | relMSE | best configuration | its time | plain random (full) | speed-up | full simulation, same sampler | speed-up | best full simulation | speed-up |",
                 "|---|---|---|---|---|---|---|---|---|---|"]
        for sc in SCENES:
            name = sc["name"]
            if name not in self.h.refs:
                continue
            for target in ERROR_TARGETS:
                times = self.speedups(name, target)
                if not times:
                    lines.append("| %s | %s | none reached it | | | | | | | |" % (name, fmt_e(target)))
                    continue
                best = min(times, key=times.get)
                tb = times[best]
                rnd = times.get("random full")
                same = times.get(best.split()[0] + " full")
                fulls = {c: t for c, t in times.items() if c.endswith(" full")}
                bf = min(fulls, key=fulls.get) if fulls else None
                note = " (ref. noise)" if self.ref_note(target, self.h.refs[name]["floor"]) else ""

                def su(t):
                    return "%.1fx" % (t / tb) if t else "not reached"
                lines.append("| %s | %s%s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
                    name, fmt_e(target), note, best, fmt_t(tb),
                    fmt_t(rnd) if rnd else "not reached", su(rnd),
                    fmt_t(same) if same else "not reached", su(same),
                    "%s, %s" % (bf, fmt_t(fulls[bf])) if bf else "none",
                    su(fulls[bf]) if bf else ""))
        self.blocks["speedups"] = "\n".join(lines)

    def ratio_curve(self, scene, cfg_a, cfg_b, npts=25, x="seconds"):
        """Time (or another cost, x) of cfg_a over that of cfg_b to reach
        the same error, at error levels spread over the range both curves
        cover; list of (error, ratio)."""
        a = curve(self.rows, scene, cfg_a, x=x)
        b = curve(self.rows, scene, cfg_b, x=x)
        if not a or not b:
            return []
        hi = min(max(p[1] for p in a), max(p[1] for p in b))
        lo = max(min(p[1] for p in a), min(p[1] for p in b),
                 FLOOR_FACTOR * self.h.refs[scene]["floor"])
        out = []
        if hi <= lo:
            return out
        for i in range(npts):
            e = math.exp(math.log(hi) + (math.log(lo) - math.log(hi)) * i / (npts - 1))
            ta, tb = time_to(a, e), time_to(b, e)
            if ta and tb:
                out.append((e, ta / tb))
        return out

    def timing_noise(self):
        """How far apart the times of identical work fall: adaptive
        sampling at spp <= 16 gives every pixel spp samples (its minimum,
        16, is capped at spp), so "X adaptive" and "X full", and "X
        plan+adaptive" and "X plan", render the same image with the same
        work there.  Returns the 90th percentile of |time ratio - 1| over
        those pairs (checked to have equal errors), or None."""
        by = {(r["scene"], r["config"], r["spp"]): r for r in self.rows
              if r["group"] == "main"}
        devs = []
        for (scene, cfg, spp), r in by.items():
            sampler, mode = cfg.split(" ", 1)
            if spp > 16 or mode not in ("adaptive", "plan+adaptive"):
                continue
            other = by.get((scene, "%s %s" % (sampler, "full" if mode == "adaptive"
                                              else "plan"), spp))
            if other is None or other["relmse"] != r["relmse"] or other["seconds"] <= 0:
                continue
            devs.append(abs(r["seconds"] / other["seconds"] - 1))
        if len(devs) < 5:
            return None
        devs.sort()
        return devs[min(len(devs) - 1, int(0.9 * len(devs)))]

    def block_targets(self):
        lines = ["| scene | sampler | full: time to 1e-3 | plan+adaptive: time to 1e-3 | speed-up | target | result |",
                 "|---|---|---|---|---|---|---|"]
        self.verdicts = []
        for sampler in SAMPLERS:
            full = curve(self.rows, "focus", sampler + " full")
            pa = curve(self.rows, "focus", sampler + " plan+adaptive")
            tf, tp = time_to(full, 1e-3), time_to(pa, 1e-3)
            if not pa:
                res = "not available in this build"
                lines.append("| focus | %s | %s | | | >= 3x | %s |" % (sampler, fmt_t(tf), res))
                self.verdicts.append(("focus", sampler, None))
                continue
            ok = tf is not None and tp is not None and tf / tp >= 3
            self.verdicts.append(("focus", sampler, ok))
            lines.append("| focus | %s | %s | %s | %s | >= 3x | %s |" % (
                sampler, fmt_t(tf), fmt_t(tp),
                "%.1fx" % (tf / tp) if tf and tp else "n/a", "met" if ok else "missed"))
        noise = self.timing_noise()
        lines.append("")
        lines.append("Timing noise: renders of identical work (adaptive "
                     "sampling at spp <= 16, where it gives every pixel spp "
                     "samples, against the same configuration without it) "
                     "differ in time by up to %s (90th percentile).  A ratio "
                     "above 1.05 but within 1.05 times that is reported as "
                     "met within the timing noise." %
                     ("%.1f%%" % (100 * noise) if noise is not None else "n/a"))
        lines.append("")
        lines.append("| scene | sampler | plan+adaptive over full: time ratio at equal relMSE (worst / median, over the common error range) | at 1e-2 | at 1e-3 | at 1e-4 | target | result |")
        lines.append("|---|---|---|---|---|---|---|---|")
        for sampler in SAMPLERS:
            rc = self.ratio_curve("defocus", sampler + " plan+adaptive", sampler + " full")
            full = curve(self.rows, "defocus", sampler + " full")
            pa = curve(self.rows, "defocus", sampler + " plan+adaptive")
            if not pa:
                lines.append("| defocus | %s | not available in this build | | | | <= 1.05 | |" % sampler)
                self.verdicts.append(("defocus", sampler, None))
                continue
            cells = []
            for t in ERROR_TARGETS:
                a, b = time_to(pa, t), time_to(full, t)
                cells.append("%.3f" % (a / b) if a and b else "n/a")
            worst = max(r for _, r in rc) if rc else None
            med = statistics.median(r for _, r in rc) if rc else None
            ok = worst is not None and worst <= 1.05
            verdict = "met" if ok else "missed"
            if not ok and worst is not None and noise is not None and \
                    worst <= 1.05 * (1 + noise):
                ok = True
                verdict = "met within the timing noise"
            self.verdicts.append(("defocus", sampler, ok))
            lines.append("| defocus | %s | %s | %s | <= 1.05 | %s |" % (
                sampler, "%.3f / %.3f" % (worst, med) if rc else "n/a",
                " | ".join(cells), verdict))
        lines.append("")
        lines.append("Planning alone costs or saves this much at equal samples "
                     "(median time with plan over without, same sampler, over "
                     "the ladder):")
        lines.append("")
        lines.append("| scene | " + " | ".join(SAMPLERS) + " |")
        lines.append("|---|" + "---|" * len(SAMPLERS))
        for sc in SCENES:
            if sc["name"] not in self.h.refs:
                continue
            cells = []
            for sampler in SAMPLERS:
                a = {p[2]["spp"]: p[0] for p in curve(self.rows, sc["name"], sampler + " plan")}
                b = {p[2]["spp"]: p[0] for p in curve(self.rows, sc["name"], sampler + " full")}
                rs = [a[k] / b[k] for k in a if k in b and b[k] > 0]
                cells.append("%.2f" % statistics.median(rs) if rs else "n/a")
            lines.append("| %s | %s |" % (sc["name"], " | ".join(cells)))
        self.blocks["targets"] = "\n".join(lines)

    def block_budget(self):
        """Issue 17's targets for the default (plan+adaptive): at every
        rung its relMSE at most BUDGET_ERROR times the full simulation's
        at the same spp (same sampler), and it reaches every error level
        no later than the full simulation."""
        rungs = sorted({r["spp"] for r in self.rows if r["group"] == "main"})
        lines = ["| scene | sampler | " + " | ".join(str(n) for n in rungs) +
                 " | worst | result |",
                 "|---|---|" + "---|" * len(rungs) + "---|---|"]
        noise = self.timing_noise()
        times = ["| scene | sampler | plan+adaptive over full: time ratio at "
                 "equal relMSE (worst / median, over the common error range) "
                 "| at 1e-2 | at 1e-3 | at 1e-4 | result | samples ratio at "
                 "equal relMSE (worst / median) |",
                 "|---|---|---|---|---|---|---|---|"]
        for sc in SCENES:
            n = sc["name"]
            if n not in self.h.refs:
                continue
            for sampler in SAMPLERS:
                full = {p[2]["spp"]: p[1] for p in curve(self.rows, n, sampler + " full", x="spp")}
                pa = {p[2]["spp"]: p[1] for p in curve(self.rows, n, sampler + " plan+adaptive", x="spp")}
                cells, worst = [], None
                for k in rungs:
                    if k in full and k in pa and full[k] > 0:
                        q = pa[k] / full[k]
                        worst = q if worst is None else max(worst, q)
                        cells.append("%.2f" % q)
                    else:
                        cells.append("")
                res = ("n/a" if worst is None else
                       "met" if worst <= BUDGET_ERROR else "missed")
                lines.append("| %s | %s | %s | %s | %s |" % (
                    n, sampler, " | ".join(cells),
                    "%.2f" % worst if worst is not None else "n/a", res))
                rc = self.ratio_curve(n, sampler + " plan+adaptive", sampler + " full")
                fc = curve(self.rows, n, sampler + " full")
                pc = curve(self.rows, n, sampler + " plan+adaptive")
                at = []
                for t in ERROR_TARGETS:
                    a, b = time_to(pc, t), time_to(fc, t)
                    at.append("%.2f" % (a / b) if a and b else "n/a")
                if rc:
                    w = max(r for _, r in rc)
                    med = statistics.median(r for _, r in rc)
                    verdict = ("faster" if w < 1 else
                               "faster or equal within the timing noise"
                               if noise is not None and w <= 1 + noise
                               else "slower at some levels")
                    cell = "%.2f / %.2f" % (w, med)
                else:
                    verdict, cell = "n/a", "n/a"
                # Samples taken: the work without the timing noise (a
                # pixel's first packet costs more than its later ones, so
                # time ratios sit somewhat above these).
                sc_ = self.ratio_curve(n, sampler + " plan+adaptive",
                                       sampler + " full", x="mean_spp")
                scell = ("%.2f / %.2f" % (max(r for _, r in sc_),
                                          statistics.median(r for _, r in sc_))
                         if sc_ else "n/a")
                times.append("| %s | %s | %s | %s | %s | %s |" % (
                    n, sampler, cell, " | ".join(at), verdict, scell))
        lines.append("")
        lines.append("Time to the same error (lower is faster; timing noise "
                     "%s, as above):" %
                     ("%.1f%%" % (100 * noise) if noise is not None else "n/a"))
        lines.append("")
        lines.extend(times)
        self.blocks["budget"] = "\n".join(lines)

    def block_plan(self):
        lines = ["| scene | pixels sampling the lens | pixels traced per colour | camera rays, plan+adaptive vs full (sobol, max spp) |",
                 "|---|---|---|---|"]
        for sc in SCENES:
            rs = [r for r in self.rows if r["scene"] == sc["name"] and r["group"] == "main"
                  and r["config"] == "sobol plan+adaptive"]
            if not rs:
                continue
            r = max(rs, key=lambda r: r["spp"])
            def pct(v):
                return "%.0f%%" % (100 * float(v)) if v != "" else "n/a"
            cam = ("%.0f%%" % (100.0 * r["camera_rays"] / r["full_camera_rays"])
                   if r["camera_rays"] != "" and r["full_camera_rays"] else "n/a")
            lines.append("| %s | %s | %s | %s |" % (sc["name"], pct(r["lens_pixels"]),
                                                    pct(r["chroma_pixels"]), cam))
        self.blocks["plan"] = "\n".join(lines)

    def block_colour(self):
        scene = COLOUR_SCENE
        # Without colour rows (--skip-colour) the doc keeps its block.
        if scene not in self.h.refs or not self.configs(scene, "colour"):
            return
        cfgs = self.configs(scene, "colour")
        lines = ["| colour model | camera rays per sample | " + " | ".join(
            "relMSE at %s" % fmt_t(t) for t in EQUAL_TIMES) +
            " | " + " | ".join("time to %s" % fmt_e(t) for t in ERROR_TARGETS[:2]) +
            " | relMSE at max spp (bias floor) | slope |",
            "|---|---|" + "---|" * (len(EQUAL_TIMES) + 2 + 2)]
        for model, n, _ in COLOUR_MODELS:
            for mode in COLOUR_MODES:
                cfg = "%s %s" % (model, mode)
                pts = curve(self.rows, scene, cfg)
                if not pts:
                    lines.append("| %s | | %s |" % (cfg, "not available in this build"))
                    continue
                last = pts[-1][2]
                s, _ = fit_slope(curve(self.rows, scene, cfg, x="mean_spp"),
                                 self.h.refs[scene]["floor"])
                # Measured at the top of the ladder: splatting traces one
                # ray a sample (and its margin), whatever n says.
                rps = ("%.1f" % (last["camera_rays"] / last["samples"])
                       if last["camera_rays"] != "" and last["samples"]
                       else "3" if n is None else str(n))
                lines.append("| %s | %s | %s | %s | %s (%d spp) | %s |" % (
                    cfg, rps,
                    " | ".join(fmt_e(error_at(pts, t)) for t in EQUAL_TIMES),
                    " | ".join(self.time_cell(scene, cfg, t) for t in ERROR_TARGETS[:2]),
                    fmt_e(last["relmse"]), last["spp"],
                    "%.2f" % s if s is not None else "n/a"))
        rgb = rgb_mode_sets(dict((s["name"], s["file"]) for s in SCENES)[scene])
        lines.append("")
        lines.append("rgb mode was run with `" + "`, `".join(
            "%s=%s" % kv for kv in rgb.items()) + "`: SF11 at %s nm." %
            " / ".join("%g" % w for w in RGB_WAVELENGTHS))
        self.blocks["colour"] = "\n".join(lines)

    def block_plots(self):
        lines = []
        for sc in SCENES:
            if sc["name"] not in self.h.refs:
                continue
            n = sc["name"]
            lines.append("**%s** (`%s`):" % (sc["title"].capitalize(), sc["file"]))
            lines.append("")
            lines.append("![relative MSE against time, %s](accuracy-%s-time.png)" % (n, n))
            lines.append("![relative MSE against samples per pixel, %s](accuracy-%s-spp.png)" % (n, n))
            lines.append("![edge-aware error against time, %s](accuracy-%s-edge.png)" % (n, n))
            lines.append("")
        if COLOUR_SCENE in self.h.refs:
            lines.append("**rgb against spectral** (`%s`, sobol):" %
                         dict((s["name"], s["file"]) for s in SCENES)[COLOUR_SCENE])
            lines.append("")
            lines.append("![relative MSE against time, colour models](accuracy-colour-time.png)")
            lines.append("![relative MSE against samples per pixel, colour models](accuracy-colour-spp.png)")
        self.blocks["plots"] = "\n".join(lines)

    def build(self):
        self.block_run()
        self.block_plots()
        self.block_slopes()
        for sc in SCENES:
            if sc["name"] in self.h.refs:
                self.block_time_to(sc["name"])
        self.block_speedups()
        self.block_targets()
        self.block_budget()
        self.block_plan()
        self.block_colour()
        return self.blocks


def scene_wavelengths(path):
    with open(path) as f:
        chrom = json.load(f).get("camera", {}).get("chromatic", {})
    return chrom.get("wavelengths", 8) if chrom.get("mode") == "spectral" else None


def scene_size(path):
    with open(path) as f:
        r = json.load(f).get("render", {})
    return r.get("width", 640), r.get("height", 480)


# ---- plots ------------------------------------------------------------------

SAMPLER_COLOURS = {"grid": "#1b9e77", "jittered": "#d95f02",
                   "random": "#7570b3", "sobol": "#e7298a"}
MODE_STYLE = {"full": (1, 7), "plan": (2, 5), "adaptive": (3, 9),
              "plan+adaptive": (4, 13)}  # dashtype, pointtype
COLOUR_COLOURS = ["#000000", "#1b9e77", "#d95f02", "#7570b3", "#e7298a"]


def gp_escape(s):
    return s.replace("\\", "\\\\").replace('"', '\\"')


def write_plot(h, name, title, xlabel, ylabel, series, floor, outdir, docs):
    """series: list of (label, colour, dashtype, pointtype, [(x, y)])."""
    plotdir = os.path.join(h.work, "plots")
    datfile = os.path.join(plotdir, name + ".dat")
    with open(datfile, "w") as f:
        for label, _, _, _, pts in series:
            f.write("# %s\n" % label)
            for x, y in pts:
                f.write("%.6g %.6g\n" % (x, y))
            f.write("\n\n")
    png = os.path.join(docs, "accuracy-%s.png" % name)
    gp = os.path.join(plotdir, name + ".gp")
    cmds = []
    for i, (label, colour, dt, pt, pts) in enumerate(series):
        if not pts:
            continue
        cmds.append("'%s' index %d with linespoints lw 1.6 lc rgb '%s' dt %d pt %d ps 0.8 title \"%s\"" % (
            datfile, i, colour, dt, pt, gp_escape(label)))
    if floor:
        cmds.append("%g with lines lc rgb '#999999' dt 3 lw 1 title \"reference noise\"" % floor)
    with open(gp, "w") as f:
        f.write("""# generated by bench/accuracy/run.py
set terminal pngcairo size 960,600 font 'DejaVu Sans,10' noenhanced
set output '%s'
set title "%s"
set xlabel "%s"
set ylabel "%s"
set logscale xy
set format x '%%g'
set format y '%%.0e'
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key outside right top spacing 1.05 font ',9'
plot %s
""" % (png, gp_escape(title), xlabel, ylabel, ", \\\n     ".join(cmds)))
    p = subprocess.run(["gnuplot", gp], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        h.failures.append(("plot " + name, p.stderr.strip()[-300:]))
        log("accuracy: gnuplot failed on %s: %s" % (gp, p.stderr.strip()[-300:]))
    return png


def make_scene_picture(h, docs):
    """The three scenes side by side (docs/accuracy-scenes.png): each
    rendered once with sobol at 64 spp, put together by gnuplot."""
    pngs = []
    for sc in SCENES:
        if sc["name"] not in h.refs:
            continue
        out = os.path.join(h.work, "plots", "scene-%s.png" % sc["name"])
        try:
            h.render(sc["file"], out, {"render.spp": "64",
                                       "render.sampler": "sobol"})
        except RenderError as e:
            h.failures.append(("picture of " + sc["name"], str(e)))
            continue
        pngs.append((sc, out))
    if not pngs:
        return
    w, ht = scene_size(pngs[0][0]["file"])
    scale = 2
    gp = os.path.join(h.work, "plots", "scenes.gp")
    png = os.path.join(docs, "accuracy-scenes.png")
    with open(gp, "w") as f:
        f.write("set terminal pngcairo size %d,%d font 'DejaVu Sans,10' noenhanced\n"
                % (len(pngs) * w * scale, ht * scale + 24))
        f.write("set output '%s'\nset multiplot layout 1,%d\n" % (png, len(pngs)))
        f.write("unset border; unset tics; unset key; unset colorbox\n")
        f.write("set lmargin 0.5; set rmargin 0.5; set tmargin 2; set bmargin 0\n")
        f.write("set xrange [-0.5:%g]; set yrange [-0.5:%g]; set size ratio -1\n"
                % (w - 0.5, ht - 0.5))
        for sc, path in pngs:
            f.write("set title \"%s\"\n" % gp_escape(sc["title"].split(" (")[0]))
            f.write("plot '%s' binary filetype=png with rgbimage\n" % path)
        f.write("unset multiplot\n")
    p = subprocess.run(["gnuplot", gp], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        h.failures.append(("picture of the scenes", p.stderr.strip()[-300:]))


def time_label(h):
    if h.clock == "cpu":
        return "render time (CPU seconds, all threads together)"
    return "render time (wall seconds, %d threads)" % (os.cpu_count() or 0)


def make_plots(h, docs):
    make_scene_picture(h, docs)
    for sc in SCENES:
        n = sc["name"]
        if n not in h.refs:
            continue
        ref = h.refs[n]
        for kind, x, y, xl, yl, floor in [
                ("time", "seconds", "relmse", time_label(h), "relative MSE", ref["floor"]),
                ("spp", "mean_spp", "relmse", "mean samples per pixel taken", "relative MSE", ref["floor"]),
                ("edge", "seconds", "grad_relmse", time_label(h), "gradient relative MSE (edge-aware)", ref["grad_floor"])]:
            series = []
            for sampler in SAMPLERS:
                for mode in MODE_NAMES:
                    cfg = "%s %s" % (sampler, mode)
                    pts = [(a, b) for a, b, _ in curve(h.rows, n, cfg, x=x, y=y)]
                    dt, pt = MODE_STYLE[mode]
                    series.append((cfg, SAMPLER_COLOURS[sampler], dt, pt, pts))
            write_plot(h, "%s-%s" % (n, kind), "%s: %s against %s" % (
                sc["title"], yl, "time" if x == "seconds" else "samples per pixel"),
                xl, yl, series, floor, None, docs)
    if COLOUR_SCENE in h.refs and any(r["group"] == "colour" for r in h.rows):
        ref = h.refs[COLOUR_SCENE]
        for kind, x, xl in [("time", "seconds", time_label(h)),
                            ("spp", "mean_spp", "mean samples per pixel taken")]:
            series = []
            for i, (model, _, _) in enumerate(COLOUR_MODELS):
                for mode in COLOUR_MODES:
                    cfg = "%s %s" % (model, mode)
                    pts = [(a, b) for a, b, _ in curve(h.rows, COLOUR_SCENE, cfg, x=x)]
                    dt, pt = MODE_STYLE[mode]
                    series.append((cfg, COLOUR_COLOURS[i], dt, pt, pts))
            write_plot(h, "colour-%s" % kind,
                       "chromatic aberration, sobol: rgb against spectral (reference: 32 wavelengths)",
                       xl, "relative MSE", series, ref["floor"], None, docs)


# ---- the document -----------------------------------------------------------

def update_doc(path, blocks):
    with open(path) as f:
        text = f.read()
    missing = []
    for name, body in blocks.items():
        pat = re.compile(r"(<!-- generated: %s -->\n).*?(<!-- end generated: %s -->)"
                         % (re.escape(name), re.escape(name)), re.S)
        if not pat.search(text):
            missing.append(name)
            continue
        text = pat.sub(lambda m: m.group(1) + body + "\n" + m.group(2), text)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    return missing


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lensray", default="build/lensray")
    ap.add_argument("--imgdiff", default="build/accuracy/imgdiff")
    ap.add_argument("--work", default="build/accuracy")
    ap.add_argument("--docs", default="docs")
    ap.add_argument("--doc", default="docs/accuracy.md",
                    help="the document whose generated blocks are rewritten")
    ap.add_argument("--quick", action="store_true",
                    help="short ladders and references, for a smoke test "
                         "(does not touch docs/)")
    ap.add_argument("--scenes", nargs="*", help="only these scenes")
    ap.add_argument("--from-csv", action="store_true",
                    help="rebuild the tables, plots and docs from the last "
                         "run's build/accuracy/results.csv, rendering nothing")
    ap.add_argument("--skip-colour", action="store_true",
                    help="leave out the rgb-against-spectral ladders (about "
                         "half the chroma scene's time); the doc keeps its "
                         "colour block and plots from an earlier run")
    ap.add_argument("--clock", choices=["auto", "wall", "cpu"], default="cpu",
                    help="time measure of the tables: CPU time of the "
                         "render (--stats cpu_seconds, the default), wall "
                         "time (--stats seconds), or auto: wall unless other "
                         "processes visibly shared the machine")
    opts = ap.parse_args()
    if shutil.which("gnuplot") is None:
        sys.exit("accuracy: gnuplot is needed for the plots")
    t0 = time.time()
    h = Harness(opts)
    log("accuracy: %s, %d cores; progress: scene, configuration, then "
        "spp:relMSE/seconds per step" % (opts.lensray, os.cpu_count() or 0))
    if opts.from_csv:
        h.load_previous()
    else:
        h.run_all()
        h.finished = time.time()
        h.load_end = os.getloadavg()
    h.choose_clock()
    if not opts.from_csv:
        h.write_csv()
        h.save_meta()
    docs = opts.docs
    if opts.quick:
        docs = os.path.join(h.work, "plots")
    make_plots(h, docs)
    rep = Report(h)
    blocks = rep.build()
    summary = os.path.join(h.work, "summary.md")
    with open(summary, "w") as f:
        for name, body in blocks.items():
            f.write("## %s\n\n%s\n\n" % (name, body))
    log("accuracy: wrote %s" % summary)
    if not opts.quick and not opts.scenes:
        missing = update_doc(opts.doc, blocks)
        if missing:
            log("accuracy: %s has no markers for: %s" % (opts.doc, ", ".join(missing)))
        log("accuracy: updated %s and its plots docs/accuracy-*.png" % opts.doc)
    for scene, sampler, ok in getattr(rep, "verdicts", []):
        log("accuracy: target %s %s: %s" % (
            scene, sampler, {None: "not measured", True: "met", False: "missed"}[ok]))
    log("accuracy: done in %.0f s" % (time.time() - t0))


if __name__ == "__main__":
    main()
