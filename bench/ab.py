#!/usr/bin/env python3
"""ab.py: two lensray builds on the same scenes, side by side.

    python3 bench/ab.py --old OLD/lensray --new build/lensray \\
        [--rounds 5] [--set PATH=VALUE ...] SCENE.json ...

For each scene, each round renders with the old binary, then the new
(the order alternates between rounds, so a trend in the machine's load
falls on both), and reads the render's CPU seconds (both threads,
planning included) from --stats.  Prints per scene the medians, their
ratio (new / old: above 1 is slower) and whether the two images are
byte-identical.  CPU time, not wall time: other processes competing for
the cores do not inflate it (bench/cputime.py).

Used for issue 27's "scenes without small bright emitters keep today's
speed" (old: main before the issue), and for any change that must keep
speed within noise.
"""
import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys


def render(binary, scene, extra, out):
    cmd = [binary, "render", scene, "-o", out, "-q", "--stats"] + extra
    p = subprocess.run(cmd, check=True, capture_output=True, text=True)
    stats = None
    for line in (p.stdout + p.stderr).splitlines():
        if line.startswith("{") and '"cpu_seconds"' in line:
            stats = json.loads(line)
    if stats is None:
        raise RuntimeError("no --stats line from %s" % " ".join(cmd))
    with open(out, "rb") as fh:
        digest = hashlib.sha256(fh.read()).hexdigest()
    return stats["cpu_seconds"], digest


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old", required=True)
    ap.add_argument("--new", required=True)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--work", default="build/bench/ab")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("scenes", nargs="+")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    extra = sum((["--set", s] for s in args.set), [])
    print("%-28s %9s %9s %7s  %s" % ("scene", "old CPU s", "new CPU s", "new/old",
                                      "same bytes"))
    ratios = []
    for scene in args.scenes:
        times = {"old": [], "new": []}
        digest = {}
        for r in range(args.rounds):
            order = ("old", "new") if r % 2 == 0 else ("new", "old")
            for which in order:
                out = os.path.join(args.work, "%s.exr" % which)
                t, digest[which] = render(getattr(args, which), scene, extra, out)
                times[which].append(t)
        mo, mn = statistics.median(times["old"]), statistics.median(times["new"])
        ratios.append(mn / mo)
        print("%-28s %9.3f %9.3f %7.3f  %s" % (os.path.basename(scene), mo, mn, mn / mo,
                                               "yes" if digest["old"] == digest["new"]
                                               else "no"), flush=True)
    print("geometric mean of new/old: %.3f" % statistics.geometric_mean(ratios))
    return 0


if __name__ == "__main__":
    sys.exit(main())
