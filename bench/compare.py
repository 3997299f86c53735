#!/usr/bin/env python3
"""compare.py: how far apart two renders of the same scene are.

Usage: compare.py OURS.exr REFERENCE.exr [--threshold 0.01] [--diff out.png]
                  [--label NAME]

Reads both EXRs (Mitsuba's Bitmap reader, in the bench's virtual
environment) and prints, over the RGB channels:

  * mean_rel: the mean over pixels of |a - b| / b (b = the reference's
    luminance-like mean of R, G, B; a the same for ours), over the pixels
    where b > threshold (dark pixels would divide noise by nothing);
  * mean_rel_rgb: the same per channel, averaged over channels;
  * image_mean_rel: the relative difference of the image means, per
    channel (the biggest), which noise hardly touches;
  * frac_over_5pct: the fraction of those pixels more than 5% apart.

With --diff it writes a picture of the relative difference (grey = equal,
red = ours brighter, blue = ours darker, full colour at 10%).

Prints one line prefixed with "COMPARE " holding JSON.
"""
import argparse
import json


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('ours')
    ap.add_argument('reference')
    ap.add_argument('--threshold', type=float, default=0.01)
    ap.add_argument('--diff', default='')
    ap.add_argument('--label', default='')
    a = ap.parse_args()

    import numpy as np
    import mitsuba as mi
    mi.set_variant('scalar_rgb')

    def load(path):
        bmp = mi.Bitmap(path)
        names = list(bmp.struct_()[i].name for i in range(len(bmp.struct_())))
        img = np.array(bmp, dtype=np.float64)
        if img.ndim == 2:
            img = img[:, :, None]
        idx = [names.index(c) for c in ('R', 'G', 'B') if c in names]
        if len(idx) != 3:
            idx = [0, 1, 2]
        return img[:, :, idx]

    x = load(a.ours)
    y = load(a.reference)
    if x.shape != y.shape:
        raise SystemExit('compare: %s is %s but %s is %s' %
                         (a.ours, x.shape, a.reference, y.shape))
    lx, ly = x.mean(axis=2), y.mean(axis=2)
    m = ly > a.threshold
    rel = np.abs(lx - ly)[m] / ly[m]
    rel_rgb = []
    for c in range(3):
        mc = y[:, :, c] > a.threshold
        rel_rgb.append(float((np.abs(x[:, :, c] - y[:, :, c])[mc] / y[:, :, c][mc]).mean()))
    mean_x = x.reshape(-1, 3).mean(axis=0)
    mean_y = y.reshape(-1, 3).mean(axis=0)
    image_rel = (mean_x - mean_y) / mean_y
    res = {
        'label': a.label,
        'ours': a.ours,
        'reference': a.reference,
        'threshold': a.threshold,
        'pixels_compared': int(m.sum()),
        'pixels': int(m.size),
        'mean_rel': float(rel.mean()),
        'median_rel': float(np.median(rel)),
        'mean_rel_rgb': float(np.mean(rel_rgb)),
        'image_mean_rel': float(np.max(np.abs(image_rel))),
        'image_mean_rel_rgb': [float(v) for v in image_rel],
        'frac_over_5pct': float((rel > 0.05).mean()),
        'mean_ours': [float(v) for v in mean_x],
        'mean_reference': [float(v) for v in mean_y],
    }
    if a.diff:
        d = np.zeros(ly.shape)
        d[m] = (lx[m] - ly[m]) / ly[m]
        t = np.clip(d / 0.10, -1, 1)
        img = np.full(ly.shape + (3,), 0.5)
        img[:, :, 0] += 0.5 * np.clip(t, 0, 1) - 0.5 * np.clip(-t, 0, 1)
        img[:, :, 2] += 0.5 * np.clip(-t, 0, 1) - 0.5 * np.clip(t, 0, 1)
        img[:, :, 1] -= 0.5 * np.abs(t)
        img[~m] = 0.0
        out = (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8)
        mi.Bitmap(out, mi.Bitmap.PixelFormat.RGB).write(a.diff)
        res['diff'] = a.diff
    print('COMPARE ' + json.dumps(res))


if __name__ == '__main__':
    main()
