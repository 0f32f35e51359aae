"""Direct-only copy of a Gray-code capture: the global light measured by the complementary pairs,
removed from every frame (after Nayar, Krishnan, Grossberg and Raskar, "Fast separation of direct
and global components of a scene using high frequency illumination", SIGGRAPH 2006).

Usage: python3 scripts/procam_separate.py CAPTURE_DIR OUT_DIR [--bits 5] [--margin 40]

Needs numpy and pillow. CAPTURE_DIR holds the 42 frames of a 1024 x 768 OpenCV Gray-code capture
(`graycode_00.png` ... `graycode_41.png`: column bits, row bits, each with its inverse, then white
and black). Writes the same 42 frames to OUT_DIR as 16-bit grey PNG (code x 257, so that a reader
that scales 16-bit to full scale sees the same codes), which `lucent fit photo --capture` reads.

1. The white frame's global component G: in each of the `--bits` coarsest column and row bits, a
   pixel more than `--margin` pixels from the lit region's edge and lit in one frame of the pair
   (codes differ by more than 10) is dark in the other; there its code minus black is the global
   light from the lit half of the scene. G = 2 x the mean over the pairs (each pair lights half of
   the projector), filled by a 31 x 31 box average where no pair qualifies, capped at white - black.
2. Frame k: its global part g_k is measured where the pixel is dark in k (code - black) and is
   G minus the inverse frame's measurement where it is lit, away from the pattern's edges (6 px);
   at the edges g_k is the 25 x 25 box average of those values. The frame written is the frame
   minus g_k; the white frame minus G; the black frame unchanged.
The global share G / (white - black) over the lit pixels is printed (median, 10th, 90th
percentile).
"""
import os
import sys

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from procam_irradiance_check import parse_options  # noqa: E402
from procam_paper_checks import box, far_from_edges  # noqa: E402


def main(argv):
    opts, (src, dst) = parse_options(argv, {'--bits': '5', '--margin': '40'}, __doc__.strip().splitlines()[4], npos=2)
    bits, margin, contrast = int(opts['--bits']), int(opts['--margin']), 10.0
    frames = []
    for k in range(42):
        path = os.path.join(src, f'graycode_{k:02d}.png')
        try:
            frames.append(np.asarray(Image.open(path).convert('L')).astype(float))
        except OSError as e:
            sys.exit(f'{path}: cannot read ({e})')
    white, black = frames[40], frames[41]
    acc, cnt = np.zeros(white.shape), np.zeros(white.shape)
    for base in (0, 20):
        for j in range(bits):
            a, c = frames[base + 2 * j], frames[base + 2 * j + 1]
            ok = far_from_edges(a > c, margin) & (np.abs(a - c) > contrast)
            acc[ok] += 2 * np.maximum(np.minimum(a, c) - black, 0)[ok]
            cnt[ok] += 1
    valid = cnt > 0
    G = np.where(valid, acc / np.maximum(cnt, 1), 0.0)
    num, den = box(G * valid, 15), box(valid.astype(float), 15)
    G = np.where(valid, G, np.where(den > 0, num / np.maximum(den, 1e-9), 0.0))
    G = np.minimum(G, np.maximum(white - black, 0))
    os.makedirs(dst, exist_ok=True)
    out = {40: white - G, 41: black}
    for k in range(40):
        a, c = frames[k], frames[k ^ 1]
        lit = a > c
        g = np.clip(np.where(lit, G - (c - black), a - black), 0, G)
        sure = far_from_edges(lit, 6) & (np.abs(a - c) > contrast)
        num, den = box(g * sure, 12), box(sure.astype(float), 12)
        out[k] = a - np.where(sure, g, np.where(den > 0, num / np.maximum(den, 1e-9), G / 2))
    for k, v in out.items():
        Image.fromarray(np.clip(np.round(v * 257), 0, 65535).astype(np.uint16)).save(os.path.join(dst, f'graycode_{k:02d}.png'))
    lit = (white - black) > 40
    share = (G / np.maximum(white - black, 1))[lit]
    print(f'{src}: global share of white - black over the lit pixels: median {np.median(share):.3f}, '
          f'10th-90th percentile {np.percentile(share, 10):.3f}-{np.percentile(share, 90):.3f}')


if __name__ == '__main__':
    main(sys.argv[1:])
