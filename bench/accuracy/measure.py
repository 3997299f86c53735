"""Measuring: the lensray CLI run for every rung of every ladder (timed,
short renders repeated), each image compared with the reference by
bench/accuracy/imgdiff, one row per render; the clock of the tables; the
rows and run facts saved to, and read back from, WORK/results.csv and
WORK/run.json."""

import csv
import json
import os
import re
import resource
import subprocess
import sys
import time

import reference
from common import RenderError, fmt_e, fmt_t, log
from experiment import (COLOUR_MODELS, COLOUR_MODES, COLOUR_SCENE, MODES,
                        MODE_NAMES, SAMPLERS, SCENES, ladder, rgb_mode_sets,
                        scene_wavelengths)

# Timing: renders shorter than MIN_TIMED seconds are repeated (at least
# 3, at most MAX_REPEATS runs, until MIN_TIMED seconds were spent) and the
# fastest run is kept.
MIN_TIMED = 1.0
MAX_REPEATS = 7


def sets_args(sets):
    args = []
    for k, v in sets.items():
        args += ["--set", "%s=%s" % (k, v)]
    return args


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
        """Renders (or finds in the cache) the scene's two references
        (reference.py); returns them, kept in self.refs."""
        return reference.load_or_render(self, sc)

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
