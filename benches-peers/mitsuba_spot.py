#!/usr/bin/env python3
"""lucent's spot light with `falloff = "linear"` against Mitsuba 3's `spot` emitter, pixel by pixel.

A spot at the origin (cone 30°, falloff from 20°, Mitsuba: cutoff_angle 30, beam_width 20) lights
a Lambertian plane (albedo 0.5) 2 m ahead, seen by a 64 × 64 pinhole camera at the spot with a
80° field of view; `direct` integrator in both, white = D65 (lucent: `rgb = [1, 1, 1]`). Prints
the ratio lucent / Mitsuba of the luminance over the pixels lit above 1 % of the peak (median and
10th–90th percentile), for the linear falloff and, for comparison, lucent's default smoothstep.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_spot.py [--lucent target/release/lucent] [--spp 16]

Needs numpy and mitsuba==3.9.1.
"""
import argparse, os, subprocess, sys, tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import read_pfm  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LUMA = np.array([0.2126, 0.7152, 0.0722])
N, FOV = 64, 80.0


def lucent(binary, work, falloff, spp):
    path = os.path.join(work, f"{falloff}.toml")
    with open(path, "w") as f:
        f.write(f"""unit = "m"
camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], up = [0, 1, 0], vfov_deg = {FOV}, width = {N}, height = {N} }}
[integrator]
type = "direct"
[materials.m]
type = "lambertian"
albedo = 0.5
[[objects]]
material = "m"
quad = [[-5, -5, 2], [5, -5, 2], [5, 5, 2], [-5, 5, 2]]
[[lights]]
type = "spot"
position = [0, 0, 0]
look_at = [0, 0, 1]
cone_deg = 30
falloff_start_deg = 20
falloff = "{falloff}"
intensity = {{ rgb = [1, 1, 1] }}
""")
    out = os.path.join(work, f"{falloff}.pfm")
    subprocess.run([binary, "render", path, "--spp", str(spp), "--seed", "1", "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out) @ LUMA


def mitsuba(spp):
    import mitsuba as mi

    mi.set_variant("scalar_spectral")
    T = mi.ScalarTransform4f
    look = T().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0])
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "direct"},
        "sensor": {"type": "perspective", "fov": FOV, "fov_axis": "y", "to_world": look,
                   "film": {"type": "hdrfilm", "width": N, "height": N, "pixel_format": "rgb", "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "plane": {"type": "rectangle", "to_world": T().translate([0, 0, 2]) @ T().scale([5, 5, 1]),
                  "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.5}}}},
        "spot": {"type": "spot", "to_world": look, "cutoff_angle": 30.0, "beam_width": 20.0, "intensity": {"type": "d65", "scale": 1.0}},
    })
    return np.array(mi.render(scene, seed=1), dtype=np.float64) @ LUMA


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lucent", default=os.path.join(ROOT, "target", "release", "lucent"))
    ap.add_argument("--spp", type=int, default=16)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as work:
        m = mitsuba(a.spp)
        lit = m > 0.01 * m.max()
        for falloff in ("linear", "smoothstep"):
            r = lucent(a.lucent, work, falloff, a.spp)[lit] / m[lit]
            p10, p50, p90 = np.percentile(r, [10, 50, 90])
            print(f"falloff = {falloff}: lucent / Mitsuba median {p50:.4f} (10th–90th percentile {p10:.4f}–{p90:.4f}) over {lit.sum()} pixels")


if __name__ == "__main__":
    main()
