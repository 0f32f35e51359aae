"""What the Mitsuba 3 comparison scripts share: PFM input and output, and their command line."""

import argparse
import os
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def write_pfm(path, rgb):
    """An RGB image (rows top to bottom) as a little-endian PFM."""
    h, w, _ = rgb.shape
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(rgb[::-1], dtype="<f4").tobytes())


def read_pfm(path):
    """An RGB PFM as float64, rows top to bottom."""
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF", f"{path}: not an RGB PFM"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return a[::-1].astype(np.float64)


def peer_args(doc, spp):
    """--lucent, --spp, --variant, --save, --json; returns the arguments, the work folder and the
    temporary directory that holds it (None with --save; keep it alive while working)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--lucent", default=os.environ.get("LUCENT", os.path.join(ROOT, "target", "release", "lucent")))
    ap.add_argument("--spp", type=int, default=spp)
    ap.add_argument("--variant", default="scalar_spectral")
    ap.add_argument("--save", help="keep the scenes and images in this folder")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    if a.save:
        os.makedirs(a.save, exist_ok=True)
        return a, a.save, None
    tmp = tempfile.TemporaryDirectory()
    return a, tmp.name, tmp
