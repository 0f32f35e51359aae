"""What the Mitsuba 3 comparison scripts share: PFM input and output, and their command line."""

import argparse
import json
import os
import subprocess
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LUMA = [0.2126, 0.7152, 0.0722]  # Y of linear sRGB


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


def blocks(a, k=4):
    h, w = a.shape
    return a[: h - h % k, : w - w % k].reshape(h // k, k, w // k, k).mean(axis=(1, 3))


def stats(l, m):
    """Ratios over the pixels above 1 % of the peer's maximum; pixels that are not finite in either
    image are left out (Mitsuba 3.9.1's `roughdielectric` leaves a few NaN pixels at high spp)."""
    finite = np.isfinite(l) & np.isfinite(m)
    keep = finite & (np.where(finite, m, 0.0) > 0.01 * np.max(m[finite]))
    r = l[keep] / m[keep]
    p10, p50, p90 = np.percentile(r, [10, 50, 90])
    return {"median": p50, "p10": p10, "p90": p90, "pixels": int(keep.sum()), "mean_ratio": l[keep].sum() / m[keep].sum()}


def compare_cases(a, cases, lucent, mitsuba):
    """Render each case with `lucent(case)` and `mitsuba(case)` (luminance images) and print, or with
    --json dump, the ratio statistics per pixel and over 4 × 4 blocks."""
    report = {}
    for case in cases:
        l, m = lucent(case), mitsuba(case)
        report[case] = {"pixels": stats(l, m), "blocks_4x4": stats(blocks(l), blocks(m))}
    if a.json:
        print(json.dumps(report, indent=2))
        return report
    for case, r in report.items():
        p, b = r["pixels"], r["blocks_4x4"]
        print(f"{case:12s} lucent / Mitsuba: pixels median {p['median']:.4f} ({p['p10']:.4f}–{p['p90']:.4f}), "
              f"4×4 blocks median {b['median']:.4f} ({b['p10']:.4f}–{b['p90']:.4f}), sum ratio {p['mean_ratio']:.4f} over {p['pixels']} pixels")
    return report


def render_rgb(binary, work, name, scene_text, spp, seed=1):
    """Write `scene_text` to WORK/NAME.toml, render it with lucent at `spp` and `seed`, and return
    the linear sRGB image (rows top to bottom, 3 channels)."""
    path = os.path.join(work, f"{name}.toml")
    with open(path, "w") as f:
        f.write(scene_text)
    out = os.path.join(work, f"{name}.pfm")
    subprocess.run([binary, "render", path, "--spp", str(spp), "--seed", str(seed), "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out)


def render_luminance(binary, work, name, scene_text, spp, seed=1):
    """[`render_rgb`]'s image as luminance (Y of linear sRGB)."""
    return render_rgb(binary, work, name, scene_text, spp, seed) @ np.array(LUMA)
