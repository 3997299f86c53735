"""Reads the EXR files `lensray render` writes (lib/image/image_exr.c): one part,
scanlines, float32 channels, ZIP (16 lines a block) or ZIPS (1 line) or no
compression.  After the OpenEXR file layout ("The OpenEXR File Layout",
openexr.com/en/latest/OpenEXRFileLayout.html) and its ZIP scheme (zlib
data whose bytes were delta-predicted and split into even and odd
halves, OpenEXR's internal_zip.c).  Anything else is an error.

    read_exr(path) -> {channel name: numpy float64 array [height, width]}

The arrays span the display window; pixels outside the data window (a
render's region) are 0.
"""
import struct
import zlib

import numpy as np

LINES = {0: 1, 2: 1, 3: 16}  # compression -> scanlines per block


def _header(buf):
    if buf[:4] != b"\x76\x2f\x31\x01":
        raise ValueError("not an OpenEXR file")
    if buf[5] & 0x1e:  # version flags: tiled, long names, deep, multipart
        raise ValueError("only single-part scanline EXR files are read")
    pos, attrs = 8, {}
    while buf[pos] != 0:
        end = buf.index(b"\0", pos)
        name = buf[pos:end].decode()
        tend = buf.index(b"\0", end + 1)
        typ = buf[end + 1:tend].decode()
        (size,) = struct.unpack_from("<i", buf, tend + 1)
        attrs[name] = (typ, buf[tend + 5:tend + 5 + size])
        pos = tend + 5 + size
    return attrs, pos + 1


def _channels(raw):
    out, pos = [], 0
    while raw[pos] != 0:
        end = raw.index(b"\0", pos)
        (ptype,) = struct.unpack_from("<i", raw, end + 1)
        if ptype != 2:
            raise ValueError("channel %r is not float32" % raw[pos:end])
        out.append(raw[pos:end].decode())
        pos = end + 17
    return out


def _unzip(data, size):
    t = np.frombuffer(zlib.decompress(data), dtype=np.uint8)
    if t.size != size:
        raise ValueError("a ZIP block holds %d bytes, not %d" % (t.size, size))
    # Undo the predictor: each byte after the first was stored as its
    # difference from the one before plus 128 (modulo 256), so byte i is
    # the first plus the sum of (stored - 128) up to i.
    t = ((np.cumsum(t.astype(np.int64) - 128) + 128) & 0xff).astype(np.uint8)
    # Undo the split: even-numbered bytes first, then the odd ones.
    out = np.empty_like(t)
    half = (size + 1) // 2
    out[0::2], out[1::2] = t[:half], t[half:]
    return out.tobytes()


def read_exr(path):
    buf = open(path, "rb").read()
    attrs, pos = _header(buf)
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"][1])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    names = _channels(attrs["channels"][1])
    comp = attrs["compression"][1][0]
    if comp not in LINES:
        raise ValueError("compression %d is not read here" % comp)
    lines = LINES[comp]
    nblocks = (h + lines - 1) // lines
    offsets = struct.unpack_from("<%dQ" % nblocks, buf, pos)
    d = struct.unpack("<4i", attrs["displayWindow"][1])
    img = np.zeros((len(names), d[3] - d[1] + 1, d[2] - d[0] + 1))
    for off in offsets:
        y, size = struct.unpack_from("<ii", buf, off)
        n = min(lines, y1 + 1 - y)
        want = n * len(names) * w * 4
        data = buf[off + 8:off + 8 + size]
        if comp != 0 and size < want:
            data = _unzip(data, want)
        a = np.frombuffer(data, dtype="<f4").reshape(n, len(names), w)
        img[:, y - d[1]:y - d[1] + n, x0 - d[0]:x1 + 1 - d[0]] = \
            a.transpose(1, 0, 2)
    return {c: img[k] for k, c in enumerate(names)}
