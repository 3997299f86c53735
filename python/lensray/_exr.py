"""A small reader for the EXR files lensrayd sends, for Pythons without
the ``OpenEXR`` package (Blender's): one part, scanlines, channels of
half, float or uint, compression none, ZIPS or ZIP (lensray's default).
Anything else is an error that says to install OpenEXR.

The layout is OpenEXR's "OpenEXR File Layout" document: the magic and
version, attributes (name, type, size, value) up to an empty name, the
table of chunk offsets, then chunks of (y, byte count, data), each
holding its scanlines' channels one after another in name order.
"""

from __future__ import annotations

import struct
import zlib
from typing import Optional

import numpy as np

_MAGIC = b"\x76\x2f\x31\x01"
_PIXEL_TYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
# compression code -> scanlines per chunk
_LINES = {0: 1, 2: 1, 3: 16}


def _fail(why: str) -> ValueError:
    return ValueError(f"EXR: {why} (install the OpenEXR package to read "
                      "any EXR: pip install OpenEXR)")


def _cstring(data: bytes, at: int) -> tuple[str, int]:
    end = data.index(b"\0", at)
    return data[at:end].decode("latin-1"), end + 1


def _unzip(chunk: bytes, expected: int) -> bytes:
    # ZIP and ZIPS: zlib, then OpenEXR's predictor (each byte a difference
    # from the one before, plus 128) and its split (the even bytes first,
    # then the odd ones) undone.
    d = np.frombuffer(zlib.decompress(chunk), np.uint8).astype(np.int64)
    if d.size != expected:
        raise _fail(f"a chunk inflates to {d.size} bytes, not {expected}")
    d[1:] -= 128
    t = (np.cumsum(d) & 0xFF).astype(np.uint8)
    out = np.empty_like(t)
    half = (t.size + 1) // 2
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


def read(data: bytes) -> dict[str, np.ndarray]:
    """The channels of an EXR file's bytes, by name: float32 (H, W) arrays,
    rows from the top."""
    if data[:4] != _MAGIC:
        raise _fail("not an OpenEXR file")
    if data[5] & 0x1E:  # tiled, long names, deep or multi-part
        raise _fail("only single-part scanline files are read")
    at = 8
    channels: list[tuple[str, np.dtype]] = []
    compression: Optional[int] = None
    window: Optional[tuple[int, int, int, int]] = None
    while data[at] != 0:
        name, at = _cstring(data, at)
        _type, at = _cstring(data, at)
        size = struct.unpack_from("<i", data, at)[0]
        value = data[at + 4:at + 4 + size]
        at += 4 + size
        if name == "channels":
            k = 0
            while value[k] != 0:
                cname, k = _cstring(value, k)
                ptype = struct.unpack_from("<i", value, k)[0]
                xs, ys = struct.unpack_from("<ii", value, k + 8)
                k += 16
                if ptype not in _PIXEL_TYPES or (xs, ys) != (1, 1):
                    raise _fail(f"channel {cname}: pixel type {ptype}, "
                                f"sampling {xs}x{ys}")
                channels.append((cname, _PIXEL_TYPES[ptype]))
        elif name == "compression":
            compression = value[0]
        elif name == "dataWindow":
            window = struct.unpack("<4i", value)
    at += 1
    if compression not in _LINES:
        raise _fail(f"compression {compression}")
    if window is None or not channels:
        raise _fail("no dataWindow or no channels")
    x0, y0, x1, y1 = window
    w, h = x1 - x0 + 1, y1 - y0 + 1
    lines = _LINES[compression]
    chunks = -(-h // lines)
    offsets = struct.unpack_from(f"<{chunks}Q", data, at)
    out = {c: np.empty((h, w), np.float32) for c, _ in channels}
    row_bytes = sum(w * t.itemsize for _, t in channels)
    for off in offsets:
        y, n = struct.unpack_from("<ii", data, off)
        rows = min(lines, y1 + 1 - y)
        chunk = data[off + 8:off + 8 + n]
        if len(chunk) != rows * row_bytes:
            chunk = _unzip(chunk, rows * row_bytes)
        k = 0
        for r in range(y - y0, y - y0 + rows):
            for c, t in channels:
                out[c][r] = np.frombuffer(chunk, t, w, k)
                k += w * t.itemsize
    return out
