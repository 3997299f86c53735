#!/usr/bin/env python3
"""The farm's schedule alone: what 2 daemons could give against 1 for a
frame's own parts, on a machine with no other effects (bench/farm.sh).

    python3 bench/farm_schedule.py LENSRAY SCENE SPP PARTS FRAMES FIXED_MS

Each of the PARTS bands of rows of SCENE (as `lensray render --remote
--parts PARTS` cuts it) is rendered here alone at SPP samples a pixel on
one thread, and its CPU time taken from `--stats` (cpu_seconds: the
render's own, whatever else the machine runs; least of two).  Then the
farm's dispatch is replayed on those costs: the client keeps K parts in
flight (2 with one daemon, 4 with two, as bench/farm.sh runs them), sends
them in frame order, and nginx gives each to the daemon with the fewest
open requests (least_conn; ties to the first); a daemon renders its
requests one at a time in arrival order, each costing its band's CPU time
plus FIXED_MS (bench/farm.sh's measured fixed cost of a part).  Prints
"one_frame batch": 1 daemon's time over 2 daemons' for one frame and for
FRAMES frames in one queue.  Ratios under 2 here come from the parts'
unequal costs alone: the last parts leave one daemon idle.
"""
import heapq
import json
import os
import subprocess
import sys
import tempfile


def stats(lensray, scene, spp, region):
    """`lensray render --stats` of `region` on one thread, as a dict."""
    with tempfile.TemporaryDirectory() as tmp:
        return json.loads(subprocess.run(
            [lensray, "render", scene, "-o", os.path.join(tmp, "band.exr"),
             "-q", "--stats", "--set", "render.spp=%d" % spp,
             "--set", "render.threads=1",
             "--set", "render.region=[%d,%d,%d,%d]" % tuple(region)],
            check=True, capture_output=True, text=True).stdout)


def band_costs(lensray, scene, spp, parts):
    """CPU seconds of each band, rows [h i / n, h (i + 1) / n) as
    tools/remote.c cuts them."""
    size = stats(lensray, scene, 1, (0, 0, 1, 1))
    w, h = size["width"], size["height"]
    costs = []
    for i in range(parts):
        y0, y1 = h * i // parts, h * (i + 1) // parts
        costs.append(min(stats(lensray, scene, spp, (0, y0, w, y1))
                         ["cpu_seconds"] for _ in range(2)))
    return costs


def makespan(costs, daemons, in_flight, fixed):
    """When the last answer of the parts `costs` (in sending order) is in,
    dispatched as the module's docstring says."""
    free = [0.0] * daemons       # when each daemon's worker is next free
    open_ = [[] for _ in range(daemons)]  # finish times of its requests
    answers = []                 # heap of answer times of parts in flight
    end = 0.0
    pending = list(costs)

    def send(now, cost):
        counts = [sum(f > now for f in open_[d]) for d in range(daemons)]
        d = min(range(daemons), key=lambda k: (counts[k], k))
        finish = max(now, free[d]) + cost + fixed
        free[d] = finish
        open_[d].append(finish)
        heapq.heappush(answers, finish)

    for _ in range(min(in_flight, len(pending))):
        send(0.0, pending.pop(0))
    while answers:  # answers come in time order: the last is the end
        end = heapq.heappop(answers)
        if pending:
            send(end, pending.pop(0))
    return end


def main():
    if len(sys.argv) != 7:
        sys.exit(__doc__)
    lensray, scene = sys.argv[1], sys.argv[2]
    spp, parts, frames = (int(x) for x in sys.argv[3:6])
    fixed = float(sys.argv[6]) / 1000.0
    costs = band_costs(lensray, scene, spp, parts)
    ratios = []
    for n in (1, frames):
        batch = costs * n
        ratios.append(makespan(batch, 1, 2, fixed) /
                      makespan(batch, 2, 4, fixed))
    print("%.3f %.3f %s" % (ratios[0], ratios[1],
                            ",".join("%.0f" % (1000 * c) for c in costs)))


if __name__ == "__main__":
    main()
