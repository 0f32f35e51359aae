#!/usr/bin/env python3
"""Noise of a render from two independent renders A, B of the same scene (different --seed).

usage: pfm_noise.py A.pfm B.pfm
Prints, for the luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of the whole image: the mean, the
relative per-pixel noise of ONE render, rms(A − B)/√2 / mean, and the relative standard error of
one render's image mean, (per-pixel noise)/√(pixels) (pixels are independent), and A − B.
Use it on a crop that lies entirely on the object of interest (scripts/milk_closeups.sh).
"""
import sys
import numpy as np


def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF", f"{path}: not an RGB PFM"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return a.astype(np.float64)


a, b = read_pfm(sys.argv[1]), read_pfm(sys.argv[2])
y = np.array([0.2126, 0.7152, 0.0722])
ya, yb = a @ y, b @ y
m = 0.5 * (ya.mean() + yb.mean())
d = (ya - yb).ravel()
pp = np.sqrt(np.mean(d ** 2) / 2) / m
print(f"Y: mean {m:.4f} per-pixel {100 * pp:.1f}% region-mean se {100 * pp / np.sqrt(d.size):.2f}% "
      f"(A-B {100 * (ya.mean() - yb.mean()) / m:+.2f}%)")
