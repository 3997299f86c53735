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

The parts, by concept: experiment.py (what is rendered), measure.py
(running the CLI and imgdiff, the rows), reference.py (the references),
analysis.py (curves, fits, times to an error), report.py (the doc's
tables and the rewriting of docs/accuracy.md), plots.py (gnuplot);
common.py holds the log and number formats.

Only the Python standard library is used.  See docs/accuracy.md for
what is measured and why.
"""

import argparse
import os
import shutil
import sys
import time

from common import log
from measure import Harness
from plots import make_plots
from report import Report, update_doc


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
