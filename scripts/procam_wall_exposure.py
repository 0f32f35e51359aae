#!/usr/bin/env python3
"""Exposure of the shared projector–camera captures from the wall, with its indirect light removed.

The wall is seen and lit directly left of the plate in capture_0 and capture_1 (columns 0–47,
rows 0–799) and right of the plate in capture_2 (columns 1120–1279, rows 600–799), where
capture_0 sees it through the plate. For each region it prints the mean of white − black
(frames 40 and 41) and the indirect share I of the white frame there, measured as
`procam_paper_checks.py` measures it on the paper (`indirect_share`: twice the mean over the five coarsest
column and row bits of the frame in which the pixel is dark, 40 px or more from a lit edge), and the
direct part (white − black)·(1 − I). docs/digitization.md, "The exposure did not change".

    python3 scripts/procam_wall_exposure.py [CAPTURES_DIR]    # numpy and pillow
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from procam_paper_checks import frame, indirect_share  # noqa: E402

REGIONS = [("capture_0", "left wall", slice(0, 800), slice(0, 48)),
           ("capture_1", "left wall", slice(0, 800), slice(0, 48)),
           ("capture_0", "right wall, through the plate", slice(600, 800), slice(1120, 1280)),
           ("capture_2", "right wall", slice(600, 800), slice(1120, 1280))]


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data", "structured-light", "procam-sample")
    for name, what, ys, xs in REGIONS:
        cap = os.path.join(root, name)
        white, black = frame(cap, 40), frame(cap, 41)
        yy, xx = np.mgrid[ys, xs]
        px = np.stack([xx.ravel(), yy.ravel()], 1).astype(float)
        share = indirect_share(cap, white, black, px)
        wb = float(np.mean((white - black)[ys, xs]))
        i = float(np.nanmedian(share))
        print(f"{name} {what}: white − black {wb:.1f}, indirect share {i:.3f} "
              f"(10th–90th percentile {np.nanpercentile(share, 10):.3f}–{np.nanpercentile(share, 90):.3f}), direct {wb * (1 - i):.1f}")


if __name__ == "__main__":
    main()
