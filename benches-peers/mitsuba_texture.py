#!/usr/bin/env python3
"""lucent's image textures against Mitsuba 3's `bitmap` texture on an OBJ mesh, pixel by pixel.

A textured square (an OBJ with `vt`, u across, v up) faces the camera; a diffuse `bitmap`
albedo (an 8-bit sRGB PNG) is lit by a constant environment of spectral radiance 1 in both
renderers (`path`, max_depth 2: the square cannot see itself). The texture is asymmetric: a ramp
in R across u, a ramp in G up v, and a dark block near one corner, so that a flipped or
turned image, or a texel-centre shift, shows. The script prints the ratio lucent / Mitsuba of
the luminance Y and of each sRGB channel: median and 10th–90th percentiles over the pixels
that see the square, with bilinear filtering (`ratio`) and with nearest-texel lookups
(`ratio_nearest`: lucent's `filter = "nearest"`, Mitsuba's `filter_type = "nearest"`).

    /tmp/pyvenv/bin/python benches-peers/mitsuba_texture.py [--lucent target/release/lucent]
        [--spp 64] [--variant scalar_spectral] [--save DIR] [--json]

Needs numpy, pillow and mitsuba==3.9.1.
"""

import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import ROOT, read_pfm, write_pfm, peer_args  # noqa: E402

LUMA = np.array([0.2126, 0.7152, 0.0722])
N_CAM, N_TEX, FOV_DEG, DIST = 64, 16, 40.0, 3.0


def write_inputs(work):
    from PIL import Image

    x = (np.arange(N_TEX) + 0.5) / N_TEX
    X, Y = np.meshgrid(x, x)  # Y: 0 at the top row
    img = np.stack([0.15 + 0.8 * X, 0.15 + 0.8 * (1 - Y), np.full_like(X, 0.5)], axis=2)
    img[1:5, 1:4] = [0.05, 0.05, 0.9]  # a blue block near the top-left corner
    Image.fromarray(np.round(img * 255).astype(np.uint8)).save(os.path.join(work, "tex.png"))
    with open(os.path.join(work, "square.obj"), "w") as f:
        f.write("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n")
        f.write("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n")
        f.write("vn 0 0 -1\nvn 0 0 -1\nvn 0 0 -1\nvn 0 0 -1\n")
        f.write("f 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n")


def render_lucent(lucent, work, spp, filt="bilinear"):
    scene = f"""unit = "m"
camera = {{ eye = [0, 0, -{DIST}], look_at = [0, 0, 0], up = [0, 1, 0], vfov_deg = {FOV_DEG}, width = {N_CAM}, height = {N_CAM} }}
[integrator]
type = "path"
max_depth = 2
[materials.tex]
type = "lambertian"
albedo = {{ texture = "tex.png", filter = "{filt}" }}
[[objects]]
material = "tex"
mesh = "square.obj"
[[lights]]
type = "environment"
radiance = 1.0
"""
    path = os.path.join(work, f"lucent-{filt}.toml")
    with open(path, "w") as f:
        f.write(scene)
    out = os.path.join(work, f"lucent-{filt}.pfm")
    subprocess.run([lucent, "render", path, "--spp", str(spp), "--seed", "1", "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out)


def render_mitsuba(variant, work, spp, filt="bilinear"):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {
            "type": "perspective", "fov": FOV_DEG, "fov_axis": "y",
            "to_world": T().look_at(origin=[0, 0, -DIST], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": N_CAM, "height": N_CAM, "pixel_format": "rgb", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "square": {"type": "obj", "filename": os.path.join(work, "square.obj"),
                   "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "bitmap", "filename": os.path.join(work, "tex.png"), "filter_type": filt}}}},
        "env": {"type": "constant", "radiance": {"type": "spectrum", "value": 1.0}},
    })
    return np.array(mi.render(scene, seed=1), dtype=np.float64)


def main():
    a, work, _tmp = peer_args(__doc__, 64)
    write_inputs(work)
    images = {filt: (render_lucent(a.lucent, work, a.spp, filt), render_mitsuba(a.variant, work, a.spp, filt)) for filt in ("bilinear", "nearest")}
    # Pixels whose footprint lies on the square: the square spans ±1 at distance DIST.
    f = (N_CAM / 2) / np.tan(np.radians(FOV_DEG / 2))
    half = f / DIST  # pixels per metre at the square
    c = np.abs(np.arange(N_CAM) + 0.5 - N_CAM / 2)
    inside = c < half - 1.0
    mask = inside[:, None] & inside[None, :]
    res = {"mitsuba_variant": a.variant, "spp": a.spp, "pixels": int(mask.sum())}
    for filt, (L, M) in images.items():
        key = "ratio" if filt == "bilinear" else "ratio_nearest"
        res[key] = {}
        for label, w in [("R", np.eye(3)[0]), ("G", np.eye(3)[1]), ("B", np.eye(3)[2]), ("Y", LUMA)]:
            r = (L @ w)[mask] / (M @ w)[mask]
            res[key][label] = [float(x) for x in np.percentile(r, [10, 50, 90])]
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        print(f"Mitsuba 3 {a.variant}, {a.spp} spp, {res['pixels']} pixels on the square; lucent / Mitsuba, median (10th–90th percentile):")
        for key in ("ratio", "ratio_nearest"):
            print(f"  {'bilinear' if key == 'ratio' else 'nearest '}: " + "  ".join(f"{c} {m[1]:.4f} ({m[0]:.3f}–{m[2]:.3f})" for c, m in res[key].items()))


if __name__ == "__main__":
    sys.exit(main())
