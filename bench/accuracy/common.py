"""Small helpers of the accuracy harness: its log line, number and time
formats, and the error a failed render raises."""

import math


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


class RenderError(Exception):
    pass
