#!/usr/bin/env python3
"""lucent's pixel filters against Mitsuba 3's reconstruction filters (`rfilter`), pixel by pixel.

An emitting sphere (radiance 1, `direct`: the camera sees the emitter or black) fills part of a
48 × 48 image, so every pixel on its outline is a partial coverage that the filter decides. For
the box, tent (radius 1) and Gaussian (stddev 0.5, Mitsuba's default) filters the script renders
the scene in both renderers, each with two seeds, and prints for the pixels within 3 px of the
outline: the rms difference lucent − Mitsuba in luminance, the rms that the two renderers' own
noise explains (from the seed pairs), and the same difference against Mitsuba with the box
filter, to show how much the filter changes the edge. The scene is symmetric about the vertical
axis, so the renderers' left–right conventions do not enter.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_filter.py [--lucent target/release/lucent]
        [--spp 1024] [--variant scalar_spectral] [--save DIR] [--json]

Needs numpy and mitsuba==3.9.1.
"""

import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import LUMA, read_pfm, peer_args  # noqa: E402

N, FOV_DEG, CENTRE, RADIUS = 48, 40.0, (0.0, 0.2, 3.0), 0.7
FILTERS = {
    "box": ('"box"', {"type": "box"}),
    "tent": ('"tent"', {"type": "tent", "radius": 1.0}),
    "gaussian": ('"gaussian"', {"type": "gaussian", "stddev": 0.5}),
}


def render_lucent(lucent, work, filt, spp, seed):
    c = CENTRE
    scene = f"""unit = "m"
[camera]
eye = [0, 0, 0]
look_at = [0, 0, 1]
up = [0, 1, 0]
vfov_deg = {FOV_DEG}
width = {N}
height = {N}
filter = {FILTERS[filt][0]}
[integrator]
type = "direct"
max_depth = 1
[materials.black]
type = "lambertian"
albedo = 0
[[objects]]
name = "lamp"
material = "black"
sphere = {{ center = [{c[0]}, {c[1]}, {c[2]}], radius = {RADIUS} }}
[[lights]]
type = "area"
object = "lamp"
radiance = 1
"""
    path = os.path.join(work, f"lucent-{filt}.toml")
    with open(path, "w") as f:
        f.write(scene)
    out = os.path.join(work, f"lucent-{filt}-{seed}.pfm")
    subprocess.run([lucent, "render", path, "--spp", str(spp), "--seed", str(seed), "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out) @ np.array(LUMA)


def render_mitsuba(variant, filt, spp, seed):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "perspective", "fov": FOV_DEG, "fov_axis": "y",
            "to_world": T().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": N, "height": N, "pixel_format": "rgb", "rfilter": FILTERS[filt][1]},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "lamp": {"type": "sphere", "center": list(CENTRE), "radius": RADIUS,
                 "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.0}},
                 "emitter": {"type": "area", "radiance": {"type": "spectrum", "value": 1.0}}},
    })
    return np.array(mi.render(scene, seed=seed), dtype=np.float64) @ np.array(LUMA)


def edge_mask():
    """Pixels within 3 px of the sphere's projected outline (film centre at (N/2, N/2))."""
    f = (N / 2) / np.tan(np.radians(FOV_DEG / 2))
    x, y, z = CENTRE
    d = np.sqrt(x * x + y * y + z * z)
    # Outline radius in pixels (small-angle: the sphere's angular radius over the focal length),
    # centre projected with y up in the scene and down in the image.
    cx, cy = N / 2 + f * x / z, N / 2 - f * y / z
    r = f * np.tan(np.arcsin(RADIUS / d))
    j, i = np.mgrid[0:N, 0:N] + 0.5
    # Away from the image border, where Mitsuba (without `sample_border`) places no samples
    # beyond the film and so truncates the filter.
    inner = (i > 3) & (i < N - 3) & (j > 3) & (j < N - 3)
    return (np.abs(np.hypot(i - cx, j - cy) - r) < 3.0) & inner


def main():
    a, work, _tmp = peer_args(__doc__, 1024)
    mask = edge_mask()
    rms = lambda v: float(np.sqrt(np.mean(v[mask] ** 2)))
    report = {"mitsuba_variant": a.variant, "spp": a.spp, "edge_pixels": int(mask.sum()), "filters": {}}
    mits_box = None
    for filt in FILTERS:
        l1, l2 = (render_lucent(a.lucent, work, filt, a.spp, s) for s in (1, 2))
        m1, m2 = (render_mitsuba(a.variant, filt, a.spp, s) for s in (1, 2))
        if filt == "box":
            mits_box = m1
        noise = np.sqrt(rms(l1 - l2) ** 2 / 2 + rms(m1 - m2) ** 2 / 2)
        report["filters"][filt] = {
            "rms_lucent_minus_mitsuba": rms(l1 - m1),
            "rms_expected_from_noise": float(noise),
            "rms_against_mitsuba_box": rms(l1 - mits_box),
            "mean_ratio": float(l1[mask].sum() / m1[mask].sum()),
        }
    if a.json:
        print(json.dumps(report, indent=1))
        return
    print(f"Mitsuba 3 {a.variant}, {a.spp} spp, {report['edge_pixels']} pixels within 3 px of the outline (luminance, emitter 1):")
    for filt, r in report["filters"].items():
        print(f"  {filt:9s} rms(lucent − Mitsuba) {r['rms_lucent_minus_mitsuba']:.4f}, from noise {r['rms_expected_from_noise']:.4f}; "
              f"against Mitsuba's box {r['rms_against_mitsuba_box']:.4f}; sum ratio {r['mean_ratio']:.4f}")


if __name__ == "__main__":
    sys.exit(main())
