#!/usr/bin/env python3
"""ghosts.py: what camera.ghosts costs, ghosts off against on.

    python3 bench/ghosts.py [--bin build/lensray] [--rounds 7] \\
        [--set PATH=VALUE ...] SCENE.json

Each round renders the scene with camera.ghosts false, then true (the
order alternates between rounds, so a trend in the machine's load falls
on both), and reads the render's CPU seconds (all threads, planning
included) from --stats.  Prints the CPU model, each side's median and
its spread, the ratio of the medians (issue 29's speed target: at most
1.5), and the ghosts' counts and flux from the last "on" render.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile


def cpu_model():
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def render(binary, scene, extra, out):
    cmd = [binary, "render", scene, "-o", out, "-q", "--stats"] + extra
    p = subprocess.run(cmd, check=True, capture_output=True, text=True)
    for line in (p.stdout + p.stderr).splitlines():
        if line.startswith("{") and '"cpu_seconds"' in line:
            return json.loads(line)
    raise RuntimeError("no --stats line from %s" % " ".join(cmd))


def parser(doc):
    """The arguments this script and ghost_noise.py share."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--bin", default="build/lensray")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("scene")
    return ap


def sets(a):
    """--set PATH=VALUE ... as lensray's arguments."""
    extra = []
    for s in a.set:
        extra += ["--set", s]
    return extra


def main():
    ap = parser(__doc__)
    ap.add_argument("--rounds", type=int, default=7)
    a = ap.parse_args()
    extra = sets(a)
    times = {"false": [], "true": []}
    last = None
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.exr")
        for r in range(a.rounds):
            order = ["false", "true"] if r % 2 == 0 else ["true", "false"]
            for g in order:
                st = render(a.bin, a.scene,
                            extra + ["--set", "camera.ghosts=" + g], out)
                times[g].append(st["cpu_seconds"])
                if g == "true":
                    last = st
    print("cpu: %s, %d rounds, %s" % (cpu_model(), a.rounds, a.scene))
    med = {}
    for g in ("false", "true"):
        med[g] = statistics.median(times[g])
        print("ghosts %-5s: median %.4f s CPU (min %.4f, max %.4f)" %
              (g, med[g], min(times[g]), max(times[g])))
    print("ratio on / off: %.3f" % (med["true"] / med["false"]))
    plan = last["plan"]
    keys = ["ghost_lights", "ghost_paths", "ghost_landed", "ghost_flux"]
    print(", ".join("%s %s" % (k, plan[k]) for k in keys if k in plan))
    return 0


if __name__ == "__main__":
    sys.exit(main())
