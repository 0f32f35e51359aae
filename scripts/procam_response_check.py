"""Is the camera of a Gray-code capture linear? A geometry-free check from complementary frames.

Usage: python3 scripts/procam_response_check.py CAPTURE_DIR [CAPTURE_DIR ...]

Needs numpy and pillow. For a projector pixel p and its complement 1 − p, the irradiances of the
two frames sum to those of the white (40) and black (41) frames, whatever the blur. For a
response g, g⁻¹(a) + g⁻¹(c) = g⁻¹(white) + g⁻¹(black). With a linear camera,
(a + c − white − black) / (white − black) is 0 at every level. For code ∝ E^(1/γ) it is
x^(1/γ) + (1 − x)^(1/γ) − 1 at the irradiance fraction x: +24 % at x = ½ for γ = 1.46. The
script prints that quantity per frame pair over the bright pixels: its mean, and its mean over
the pixels whose code is 10–70 % of white (mixed levels, where a curved response shows most).
"""
import os
import sys

import numpy as np
from PIL import Image


def main(dirs):
    if not dirs:
        sys.exit(__doc__.strip().splitlines()[2])
    for d in dirs:
        def f(n):
            path = os.path.join(d, f'graycode_{n:02d}.png')
            if not os.path.isfile(path):
                sys.exit(f'{path}: no such frame (a capture holds graycode_00.png … graycode_41.png)')
            return np.asarray(Image.open(path).convert('L'), float)
        w, b = f(40), f(41)
        m = (w - b) > 0.8 * np.percentile(w - b, 95)
        w, b = w[m], b[m]
        print(d)
        for j in range(20):
            a, c = f(2 * j)[m], f(2 * j + 1)[m]
            s = (a + c - w - b) / (w - b)
            t = (a - b) / (w - b)
            mid = (t > 0.1) & (t < 0.7)
            print(f'  frames {2 * j:2d},{2 * j + 1:2d}: mean {s.mean():+.3f}, at codes 10–70 % of white '
                  f'{s[mid].mean() if mid.any() else float("nan"):+.3f} ({mid.mean() * 100:.0f} % of pixels)')


if __name__ == '__main__':
    main(sys.argv[1:])
