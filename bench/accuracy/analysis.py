"""The numbers read off a ladder: its curve of error against time (or
samples), the slope of a log-log fit, the time at which an error is
first reached and the error at a given time (both interpolated in
log-log)."""

import math

# Points used for the slope fits: spp >= FIT_MIN_SPP (below that every
# sampler is in its pre-asymptotic regime) and an error at least
# FLOOR_FACTOR times the reference's own noise.
FIT_MIN_SPP = 4
FLOOR_FACTOR = 10.0


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
