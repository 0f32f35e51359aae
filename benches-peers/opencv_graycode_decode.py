"""Time OpenCV on the work `lucent scan decode` does: read one capture of Gray-code frames
(`graycode_00.png` …, as in ../shared/data/structured-light/procam-sample/capture_N) and decode
every camera pixel the way kamino410/procam-calibration's calibrate.py does for its corner
patches: lit where white − black > 40, then `GrayCodePattern.getProjPixel` (integer projector
column and row; bits with |pattern − inverse| < 5 are an error). Prints JSON: seconds for reading,
for decoding, valid pixels. With --patterns DIR it also checks that DIR/pattern_NN.png (as
`lucent scan patterns` writes them) equal OpenCV's `generate()` images plus white and black.
Usage: pip install opencv-contrib-python-headless numpy
       python3 benches-peers/opencv_graycode_decode.py CAPTURE_DIR [--projector 1024x768]
           [--threads N] [--patterns DIR] [--save MAPS.npz]"""
import argparse
import glob
import json
import os
import time

import cv2
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("capture")
ap.add_argument("--projector", default="1024x768")
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--patterns")
ap.add_argument("--black-thr", type=int, default=40)
ap.add_argument("--white-thr", type=int, default=5)
ap.add_argument("--save", help="write the integer column and row maps (-1 invalid) to this .npz")
a = ap.parse_args()
pw, ph = (int(v) for v in a.projector.lower().split("x"))
cv2.setNumThreads(a.threads)

gc = cv2.structured_light.GrayCodePattern.create(pw, ph)
gc.setBlackThreshold(a.black_thr)
gc.setWhiteThreshold(a.white_thr)
out = {"opencv": cv2.__version__}

if a.patterns:
    ok, pats = gc.generate()
    pats = list(pats) + [np.full((ph, pw), 255, np.uint8), np.zeros((ph, pw), np.uint8)]
    mine = sorted(glob.glob(os.path.join(a.patterns, "pattern_*.png")))
    assert len(mine) == len(pats), (len(mine), len(pats))
    for f, p in zip(mine, pats):
        q = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        assert q.shape == p.shape and (q == p).all(), f
    out["patterns_equal"] = len(pats)

t0 = time.perf_counter()
files = sorted(glob.glob(os.path.join(a.capture, "graycode_*")))
imgs = [cv2.imread(f, cv2.IMREAD_GRAYSCALE) for f in files]
t1 = time.perf_counter()
black = imgs.pop()
white = imgs.pop()
assert len(imgs) == gc.getNumberOfPatternImages()
lit = (white.astype(np.int32) - black.astype(np.int32)) > a.black_thr
ys, xs = np.nonzero(lit)
valid = 0
col = np.full(white.shape, -1, np.int32)
row = np.full(white.shape, -1, np.int32)
for x, y in zip(xs.tolist(), ys.tolist()):
    err, p = gc.getProjPixel(imgs, x, y)
    if not err:
        valid += 1
        col[y, x], row[y, x] = p
t2 = time.perf_counter()
out.update({"read_s": t1 - t0, "decode_s": t2 - t1, "total_s": t2 - t0, "lit_pixels": int(lit.sum()),
            "valid_pixels": valid, "valid_fraction": valid / white.size})
if a.save:
    np.savez(a.save, col=col, row=row)
print(json.dumps(out))
