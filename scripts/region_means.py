#!/usr/bin/env python3
"""Mean linear-sRGB radiance over fixed image regions of PFM renders, and the relative differences.

usage: region_means.py REFERENCE.pfm OTHER.pfm [OTHER2.pfm ...] --regions NAME:x0,y0,x1,y1 ...
Regions are fractions of the image width/height (x right, y down). Prints a Markdown table of the
luminance-like mean (R+G+B)/3 per region with its standard error (from 8×8-pixel block means) and
the relative difference of each OTHER to REFERENCE. With --channels, one table row per region and
channel (R, G, B of linear sRGB) instead of the (R+G+B)/3 mean.

An argument A.pfm+B.pfm+… is one estimate made of independent renders (different seeds): its mean
is their mean and its standard error the spread of their region means / √n. Use this for BSSRDF
renders: every pixel of a pass shares the pass's point cloud, so their error is correlated across
the image and the 8×8-block estimate understates it.
"""
import sys
import numpy as np


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    ch = 3 if kind == b"PF" else 1
    img = data.reshape(h, w, ch)[::-1]  # PFM rows are bottom-to-top
    return img


def stats(img, r, channel=None):
    if isinstance(img, list):
        if len(img) == 1:
            return stats(img[0], r, channel)
        ms = [stats(i, r, channel)[0] for i in img]
        return float(np.mean(ms)), float(np.std(ms, ddof=1) / np.sqrt(len(ms)))
    h, w = img.shape[:2]
    x0, y0, x1, y1 = r
    sub = img[int(y0 * h):int(y1 * h), int(x0 * w):int(x1 * w)]
    sub = sub.mean(axis=2) if channel is None else sub[:, :, channel]
    bh, bw = max(1, sub.shape[0] // 8), max(1, sub.shape[1] // 8)
    blocks = [sub[i:i + bh, j:j + bw].mean() for i in range(0, sub.shape[0] - bh + 1, bh) for j in range(0, sub.shape[1] - bw + 1, bw)]
    return sub.mean(), np.std(blocks, ddof=1) / np.sqrt(len(blocks))


def main():
    args = sys.argv[1:]
    channels = [None]
    if "--channels" in args:
        args.remove("--channels")
        channels = [0, 1, 2]
    k = args.index("--regions")
    files, regs = args[:k], args[k + 1:]
    imgs = [[read_pfm(p) for p in f.split("+")] for f in files]
    regions = []
    for r in regs:
        name, box = r.split(":")
        regions.append((name, tuple(float(v) for v in box.split(","))))
    files = [f if "+" not in f else f"{f.split('+')[0]}+{len(f.split('+')) - 1} more" for f in files]
    head = "| region | " + " | ".join(files) + " | " + " | ".join(f"Δ {f}" for f in files[1:]) + " |"
    print(head)
    print("|" + "---|" * (1 + 2 * len(files) - 1))
    for name, r in regions:
        for c in channels:
            s = [stats(im, r, c) for im in imgs]
            ref = s[0][0]
            cells = [f"{m:.4f} ± {e:.4f}" for m, e in s]
            rel = [f"{100 * (m - ref) / ref:+.1f} %" for m, _ in s[1:]]
            label = name if c is None else f"{name} {'RGB'[c]}"
            print(f"| {label} | " + " | ".join(cells) + " | " + " | ".join(rel) + " |")


if __name__ == "__main__":
    main()
