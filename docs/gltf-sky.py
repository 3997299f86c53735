#!/usr/bin/env python3
"""gltf-sky.py: writes the dusk sky that lights the glTF gallery figure
(docs/figures.sh): a latitude-longitude OpenEXR image, RGB float,
uncompressed, from a formula (no download).

    python3 docs/gltf-sky.py OUT.exr

The file layout follows "The OpenEXR File Layout" (openexr.com): magic,
version, header attributes, the line offset table, then one chunk per
scanline (y, byte count, then each channel's row, channels in name order).
"""
import math
import struct
import sys

W, H = 256, 128


def sky(theta):
    """Radiance at polar angle theta (0 = zenith): a deep blue zenith,
    a warm glow at the horizon, a dark ground."""
    if theta > math.pi / 2:
        return (0.01, 0.01, 0.012)
    h = 1 - theta / (math.pi / 2)           # 0 at the horizon, 1 above
    glow = math.exp(-h * 9)
    return (0.03 + 0.9 * glow, 0.04 + 0.35 * glow, 0.10 + 0.12 * glow)


def attr(name, kind, data):
    return name.encode() + b"\0" + kind.encode() + b"\0" + \
        struct.pack("<i", len(data)) + data


def write_exr(path, w, h, row):
    """Writes a w x h image whose row y is row(y): (r, g, b) lists of w
    floats each."""
    chans = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1)
                     for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (struct.pack("<ii", 20000630, 2) +
              attr("channels", "chlist", chans) +
              attr("compression", "compression", b"\0") +
              attr("dataWindow", "box2i", box) +
              attr("displayWindow", "box2i", box) +
              attr("lineOrder", "lineOrder", b"\0") +
              attr("pixelAspectRatio", "float", struct.pack("<f", 1)) +
              attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0)) +
              attr("screenWindowWidth", "float", struct.pack("<f", 1)) +
              b"\0")
    rows = []
    for y in range(h):
        r, g, b = row(y)
        data = b"".join(struct.pack("<%df" % w, *c) for c in (b, g, r))
        rows.append(struct.pack("<ii", y, len(data)) + data)
    at = len(header) + 8 * h
    offsets = b""
    for row_ in rows:
        offsets += struct.pack("<Q", at)
        at += len(row_)
    with open(path, "wb") as f:
        f.write(header + offsets + b"".join(rows))


def main(path):
    def row(y):
        return [[c] * W for c in sky(math.pi * (y + 0.5) / H)]
    write_exr(path, W, H, row)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: gltf-sky.py OUT.exr")
    main(sys.argv[1])
