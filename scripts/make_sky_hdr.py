#!/usr/bin/env python3
"""Writes scenes/maps/sky.hdr: a procedural latitude-longitude sky (Mitsuba 3 envmap layout:
row j at polar angle pi*j/(H-1) from +y, column i at azimuth 2*pi*(i+0.5)/W from -z towards +x)
with a blue gradient above the horizon, a warm sun 30 degrees above it towards +x, and a dim brown
ground. Radiance RGBE, flat scanlines, pure Python (no dependencies).

    python3 scripts/make_sky_hdr.py [out.hdr]
"""
import math
import sys

W, H = 128, 65
SUN_ELEVATION_DEG = 30.0
SUN_RADIUS_DEG = 2.5
SUN_RGB = (900.0, 800.0, 620.0)


def texel(i, j):
    theta = math.pi * j / (H - 1)
    phi = 2.0 * math.pi * (i + 0.5) / W
    d = (math.sin(phi) * math.sin(theta), math.cos(theta), -math.cos(phi) * math.sin(theta))
    if d[1] < 0.0:
        return (0.12, 0.09, 0.06)  # ground
    h = d[1]
    sky = (0.25 + 0.35 * (1 - h), 0.45 + 0.3 * (1 - h), 0.9 + 0.1 * (1 - h))
    e = math.radians(SUN_ELEVATION_DEG)
    sun = (math.cos(e), math.sin(e), 0.0)
    c = sum(a * b for a, b in zip(d, sun))
    if c > math.cos(math.radians(SUN_RADIUS_DEG)):
        return SUN_RGB
    return sky


def rgbe(rgb):
    m = max(rgb)
    if m < 1e-32:
        return bytes(4)
    f, e = math.frexp(m)
    k = f * 256.0 / m
    return bytes([min(255, int(c * k)) for c in rgb] + [e + 128])


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "scenes/maps/sky.hdr"
    data = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (H, W))
    for j in range(H):
        row = b"".join(rgbe(texel(i, j)) for i in range(W))
        # A flat scanline must not start like a run-length one (2, 2, byte < 128).
        assert not (row[0] == 2 and row[1] == 2 and row[2] < 128)
        data += row
    with open(out, "wb") as f:
        f.write(data)


if __name__ == "__main__":
    main()
