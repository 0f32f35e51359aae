#!/usr/bin/env python3
"""Writes cloud.vol next to this script: a 24 × 24 × 24 density grid (Mitsuba's "VOL" format,
version 3, float32, one channel) of five soft blobs with a rippled surface, for
scenes/cloud-box.toml; and cloud-dye.vol: an 8 × 8 × 8 grid of single-scattering albedos in
linear sRGB (three channels), each blob's dye colour blended by the blobs' weights, for
scenes/dyed-cloud.toml. Standard library only; the same files on every run.

    python3 scenes/volumes/make_cloud_vol.py
"""
import math
import os
import struct

N = 24
BLOBS = [  # centre in the unit cube, radius, density
    ((0.50, 0.42, 0.50), 0.26, 1.0),
    ((0.32, 0.55, 0.45), 0.20, 0.9),
    ((0.68, 0.52, 0.55), 0.19, 0.9),
    ((0.50, 0.66, 0.40), 0.17, 0.8),
    ((0.45, 0.35, 0.66), 0.16, 0.7),
]
DYES = [  # single-scattering albedo (linear sRGB) of each blob's dye
    (0.99, 0.97, 0.95),
    (0.98, 0.55, 0.45),
    (0.45, 0.90, 0.95),
    (0.97, 0.90, 0.35),
    (0.70, 0.55, 0.97),
]
N_DYE = 8


def density(x, y, z):
    ripple = 0.06 * math.sin(17 * x + 3) * math.sin(13 * y + 1) * math.sin(19 * z + 2)
    total = 0.0
    for (cx, cy, cz), r, rho in BLOBS:
        d = math.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / r + ripple
        total += rho * max(0.0, 1.0 - d * d) ** 1.5
    return min(total, 1.5)


def dye(x, y, z):
    """The blobs' dye colours weighted by exp(−(distance / radius)²)."""
    weights = [math.exp(-(((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / r ** 2)) for (cx, cy, cz), r, _ in BLOBS]
    total = sum(weights)
    return [sum(w * d[c] for w, d in zip(weights, DYES)) / total for c in range(3)]


def write(path, n, channels, values):
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]))
        f.write(struct.pack("<5i", 1, n, n, n, channels))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(struct.pack(f"<{len(values)}f", *values))


def main():
    values = []
    for k in range(N):
        for j in range(N):
            for i in range(N):
                values.append(density((i + 0.5) / N, (j + 0.5) / N, (k + 0.5) / N))
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "cloud.vol")
    write(path, N, 1, values)
    print(f"wrote {path}: {N}³ cells, densities {min(values):.3f}–{max(values):.3f}")
    colours = []
    for k in range(N_DYE):
        for j in range(N_DYE):
            for i in range(N_DYE):
                colours.extend(dye((i + 0.5) / N_DYE, (j + 0.5) / N_DYE, (k + 0.5) / N_DYE))
    path = os.path.join(here, "cloud-dye.vol")
    write(path, N_DYE, 3, colours)
    print(f"wrote {path}: {N_DYE}³ cells of RGB albedo, components {min(colours):.3f}–{max(colours):.3f}")


if __name__ == "__main__":
    main()
