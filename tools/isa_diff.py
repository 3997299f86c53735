#!/usr/bin/env python3
"""isa_diff.py: how far apart two runs of the pixel-hash matrix are,
image by image (tools/isa-matrix.sh: the same renders on two code paths,
kept as EXR files of the same names in two folders).

    python3 tools/isa_diff.py DIR_A DIR_B

For each image that differs: the mean |a - b| over the mean |a| (the
picture's shift), the share of pixels where some channel differs by
more than 1% (|a - b| / (max(|a|, |b|) + 0.01)) and the largest such
difference.  The same picture, as far as a farm stitching parts from
both machines can show, is: every image's mean within 1e-3, and at most
1 pixel in 1000 off by more than 1% (a light path's visibility flipped
on a sphere's rim by the last bit of a hit).  Prints the worst images
and a verdict; exits 1 when an image is beyond these bounds.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                "..", "tests", "lenses"))
from exr import read_exr  # noqa: E402

MEAN_MAX = 1e-3
FAR_MAX = 1e-3


def rgb(path):
    ch = read_exr(path)
    return np.stack([ch[c] for c in "RGB"], -1).astype(np.float64)


def main():
    a_dir, b_dir = sys.argv[1], sys.argv[2]
    rows = []
    for name in sorted(os.listdir(a_dir)):
        a, b = rgb(os.path.join(a_dir, name)), rgb(os.path.join(b_dir, name))
        if np.array_equal(a, b):
            continue
        d = np.abs(a - b)
        rel = (d / (np.maximum(np.abs(a), np.abs(b)) + 0.01)).max(-1)
        rows.append((name, d.mean() / max(np.abs(a).mean(), 1e-12),
                     float((rel > 0.01).mean()), float(rel.max())))
    rows.sort(key=lambda r: -max(r[1] / MEAN_MAX, r[2] / FAR_MAX))
    for r in rows[:5]:
        print("  %-36s mean %.1e  pixels off > 1%%: %.5f  largest %.3f" % r)
    bad = [r for r in rows if r[1] > MEAN_MAX or r[2] > FAR_MAX]
    print("  %d images differ, %d beyond the bounds (mean %g, pixels %g)" %
          (len(rows), len(bad), MEAN_MAX, FAR_MAX))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
