#!/usr/bin/env python3
"""python_overhead.py: what rendering from Python costs over the CLI.

Usage: PYTHON bench/python_overhead.py [--lensray build/lensray]
       [--scene scenes/bench.json] [--seconds 1] [--repeat 5]

Run with the Python of the package's virtual environment
(build/python/venv, made by `make python`); bench/run.sh does.  It picks
the spp that makes one render of the scene take about --seconds, then, in
turns, renders it --repeat times each way:
  * the CLI (`lensray render ... --stats`): the render's own wall time and
    CPU time as the library measures them inside the CLI;
  * Python, the scene loaded once: the wall time of `scene.render(...)`
    (its thread, the progress callback and tqdm bar, the copy into numpy)
    and the CPU time of the whole process over that call (every thread);
    once with the default progress bar and once with progress=False.
Each turn's Python times are divided by the CLI's of the same turn, and
the median of those ratios is the overhead: turns share the machine's
load, so pairing cancels most of it, and CPU time is the figure that other
processes on the cores change least.  The time spent outside the library
(Python's wall time minus the library's own, in the same call) is printed
too: it is the wrapper's cost without any run-to-run noise.
Prints one line per measurement and a final line
"PYTHON_OVERHEAD spp=N ... wall_overhead=... cpu_overhead=...
wrapper_seconds=..." (overheads as fractions: 0.01 is 1%).
"""
import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import lensray


def cpu_now():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lensray", default="build/lensray")
    ap.add_argument("--scene", default="scenes/bench.json")
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()

    scene = lensray.load(a.scene)
    # Calibrate: the spp for a render of about a.seconds on a quiet
    # machine, i.e. CPU time / threads (the wall time grows when other
    # processes share the cores).
    spp = 16
    while True:
        _, st = scene.render(render={"spp": spp}, stats=True, progress=False)
        quiet = st["cpu_seconds"] / max(st["threads"], 1)
        if quiet >= a.seconds / 2 or spp >= 1 << 16:
            spp = max(1, round(spp * a.seconds / max(quiet, 1e-6)))
            break
        spp *= 4
    render = {"spp": spp}

    cli = {"wall": [], "cpu": []}
    py = {True: {"wall": [], "cpu": [], "lib": []}, False: {"wall": [], "cpu": [], "lib": []}}
    with tempfile.TemporaryDirectory() as tmp:
        def run_cli() -> None:
            out = subprocess.run(
                [a.lensray, "render", a.scene, "-o", f"{tmp}/cli.exr", "--quiet",
                 "--stats", "--set", f"render.spp={spp}"],
                check=True, capture_output=True, text=True).stdout
            s = json.loads(next(l for l in out.splitlines() if l.startswith("{")))
            cli["wall"].append(s["seconds"])
            cli["cpu"].append(s["cpu_seconds"])

        for turn in range(a.repeat):
            # The CLI goes first in even turns and last in odd ones, and
            # the two Python runs take turns going first, so that no run
            # always follows another (a cold start, a core just busy).
            # With the CLI first in every turn, the library's own time in
            # Python came out 4 to 5% over the CLI's, though it runs the
            # same code (callgrind: 0.3% more instructions in the shared
            # library than in the static CLI).
            if turn % 2 == 0:
                run_cli()
            for bar in ((True, False) if turn % 2 == 0 else (False, True)):
                c0, t0 = cpu_now(), time.perf_counter()
                _, st = scene.render(render=render, stats=True,
                                     progress=None if bar else False)
                t1, c1 = time.perf_counter(), cpu_now()
                py[bar]["wall"].append(t1 - t0)
                py[bar]["cpu"].append(c1 - c0)
                py[bar]["lib"].append(st["seconds"])
            if turn % 2 == 1:
                run_cli()

    def best(xs):
        return min(xs)

    def paired(mode, key):
        """Median over the runs of Python's time / the CLI's in the same
        turn: turns share the machine's load, so pairing cancels most of it."""
        return statistics.median(p / c for p, c in zip(py[mode][key], cli[key])) - 1

    print(f"python_overhead: {a.scene}, spp {spp}, {a.repeat} turns")
    print(f"  CLI lr_render:                     best wall {best(cli['wall']):.4f} s, "
          f"cpu {best(cli['cpu']):.4f} s")
    for bar in (True, False):
        d = py[bar]
        label = "with the tqdm bar" if bar else "progress=False   "
        wrap = statistics.median(w - l for w, l in zip(d["wall"], d["lib"]))
        print(f"  Python render() {label}: best wall {best(d['wall']):.4f} s, "
              f"cpu {best(d['cpu']):.4f} s; over the CLI (median of turns): "
              f"wall {100 * paired(bar, 'wall'):+.2f}%, cpu {100 * paired(bar, 'cpu'):+.2f}%; "
              f"outside the library {1000 * wrap:.1f} ms")
    wrap = statistics.median(w - l for w, l in zip(py[True]["wall"], py[True]["lib"]))
    print(f"PYTHON_OVERHEAD spp={spp} cli_seconds={best(cli['wall']):.4f} "
          f"python_seconds={best(py[True]['wall']):.4f} "
          f"wall_overhead={paired(True, 'wall'):.4f} cpu_overhead={paired(True, 'cpu'):.4f} "
          f"wall_overhead_nobar={paired(False, 'wall'):.4f} "
          f"cpu_overhead_nobar={paired(False, 'cpu'):.4f} wrapper_seconds={wrap:.4f}")


if __name__ == "__main__":
    sys.exit(main())
