#!/usr/bin/env python3
"""Writes the textures scenes/textured.json uses into scenes/textures/
(run by make; generated, never committed).  PNG chunks are built with the
standard library's zlib and struct (PNG specification, ISO/IEC 15948):
8-bit sRGB colour for albedo and emission, 16-bit grey for roughness.
Usage: make-textures.py OUTDIR"""
import math
import os
import struct
import sys
import zlib


def png(path, w, h, depth, ctype, pixel):
    """pixel(x, y) -> tuple of channel codes; row 0 is the top."""
    fmt = '>' + ('H' if depth == 16 else 'B') * {0: 1, 2: 3}[ctype]
    raw = b''.join(b'\0' + b''.join(struct.pack(fmt, *pixel(x, y))
                                    for x in range(w)) for y in range(h))

    def chunk(kind, data):
        return (struct.pack('>I', len(data)) + kind + data +
                struct.pack('>I', zlib.crc32(kind + data) & 0xffffffff))
    with open(path + '.tmp', 'wb') as f:
        f.write(b'\x89PNG\r\n\x1a\n' +
                chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, depth, ctype,
                                           0, 0, 0)) +
                chunk(b'IDAT', zlib.compress(raw, 9)) + chunk(b'IEND', b''))
    os.replace(path + '.tmp', path)


def tiles(x, y):
    """8 x 8 terracotta and cream tiles with dark grout, 64 px each."""
    if x % 64 < 3 or y % 64 < 3:
        return (40, 36, 32)
    if (x // 64 + y // 64) % 2:
        return (178, 84, 52)
    return (226, 214, 186)


def globe(x, y):
    """A beach ball as a lat-long map: six coloured gores, white caps."""
    lat = 90 - 180 * (y + 0.5) / 128
    if abs(lat) > 70:
        return (240, 240, 236)
    gore = int(6 * (x + 0.5) / 256) % 6
    return [(220, 40, 40), (250, 200, 30), (40, 110, 210),
            (245, 245, 240), (40, 170, 80), (245, 120, 20)][gore]


def sign(x, y):
    """An emission panel: three glowing bars on black."""
    u, v = (x + 0.5) / 256, (y + 0.5) / 64
    if not 0.2 < v < 0.8:
        return (0, 0, 0)
    bar = int(u * 7)
    if bar % 2 == 0:
        return (0, 0, 0)
    return [(255, 120, 40), (60, 200, 255), (255, 60, 160)][bar // 2 % 3]


def scratches(x, y):
    """Perceptual roughness 0.15 to 0.9 in bands, with fine streaks."""
    band = 0.15 + 0.75 * (0.5 + 0.5 * math.sin(2 * math.pi * y / 64))
    streak = 0.1 * math.sin(x * 0.9 + 3 * math.sin(y * 0.05))
    r = min(1.0, max(0.0, band + streak))
    return (round(r * 65535),)


out = sys.argv[1] if len(sys.argv) > 1 else 'scenes/textures'
os.makedirs(out, exist_ok=True)
png(os.path.join(out, 'tiles.png'), 512, 512, 8, 2, tiles)
png(os.path.join(out, 'globe.png'), 256, 128, 8, 2, globe)
png(os.path.join(out, 'sign.png'), 256, 64, 8, 2, sign)
png(os.path.join(out, 'scratches.png'), 256, 256, 16, 0, scratches)
