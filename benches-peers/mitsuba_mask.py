#!/usr/bin/env python3
"""lucent's `mask` material against Mitsuba 3's `mask` BSDF, pixel by pixel.

A square of rough gold (GGX α 0.2) masked by a smooth opacity texture (0.1–0.9, linear EXR) stands
in front of a diffuse wall (albedo 0.5), under an environment map with one bright patch, so that
the square both shows its opacity and casts a partial shadow (`path`, max_depth 4 in both; no
delta light, because Mitsuba's `path` lets shadow rays stop at a mask, which is unbiased only
where BSDF samples can find the light too). It prints lucent / Mitsuba of the luminance over
4 × 4 blocks (median, 10th–90th percentile) and of the image sums, and Mitsuba's own image with
the mask over its image without it, as the check that the mask matters.

    /tmp/py/bin/python benches-peers/mitsuba_mask.py [--lucent target/release/lucent] [--spp 256]
        [--variant scalar_spectral] [--save DIR] [--json]

Needs numpy and mitsuba==3.9.1.
"""

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import LUMA, blocks, peer_args, render_luminance  # noqa: E402

SCENE = """unit = "m"
camera = { eye = [0, 0, -3], look_at = [0, 0, 0], up = [0, 1, 0], vfov_deg = 40, width = 96, height = 96 }
[integrator]
type = "path"
max_depth = 4
[materials.gold]
type = "rough_conductor"
metal = "au"
alpha = 0.2
masking = "separable"
two_sided = false
[materials.leaf]
type = "mask"
material = "gold"
opacity = { texture = "opacity.exr" }
[materials.wall]
type = "lambertian"
albedo = 0.5
[[objects]]
material = "leaf"
mesh = "square.obj"
[[objects]]
material = "wall"
quad = [[-3, -3, 1], [-3, 3, 1], [3, 3, 1], [3, -3, 1]]
[[lights]]
type = "envmap"
file = "env.exr"
"""


def write_inputs(work):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    x = (np.arange(64) + 0.5) / 64
    U, V = np.meshgrid(x, 1.0 - x)
    o = 0.5 + 0.25 * U * np.sin(2 * np.pi * 4 * U) + 0.15 * np.cos(2 * np.pi * 3 * V)
    mi.Bitmap(np.repeat(o[:, :, None], 3, axis=2).astype(np.float32)).write(os.path.join(work, "opacity.exr"))
    env = np.full((32, 64, 3), 0.2, np.float32)
    env[8:14, 28:36] = 30.0
    mi.Bitmap(env).write(os.path.join(work, "env.exr"))
    with open(os.path.join(work, "square.obj"), "w") as f:
        f.write("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n")
        f.write("vn 0 0 -1\nvn 0 0 -1\nvn 0 0 -1\nvn 0 0 -1\nf 1/1/1 3/3/3 2/2/2\nf 1/1/1 4/4/4 3/3/3\n")


def render_mitsuba(variant, work, spp, masked):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    bsdf = {"type": "roughconductor", "material": "Au", "alpha": 0.2, "distribution": "ggx"}
    if masked:
        bsdf = {"type": "mask", "opacity": {"type": "bitmap", "raw": True, "filename": os.path.join(work, "opacity.exr")}, "bsdf": bsdf}
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 40, "fov_axis": "y", "to_world": T().look_at(origin=[0, 0, -3], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 96, "height": 96, "pixel_format": "rgb", "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "square": {"type": "obj", "filename": os.path.join(work, "square.obj"), "bsdf": bsdf},
        "wall": {"type": "rectangle", "to_world": T().translate([0, 0, 1]) @ T().scale(3),
                 "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.5}}}},
        "env": {"type": "envmap", "filename": os.path.join(work, "env.exr")},
    })
    return np.array(mi.render(scene, seed=1), dtype=np.float64) @ np.array(LUMA)


def main():
    a, work, _tmp = peer_args(__doc__, 256)
    write_inputs(work)
    L = render_luminance(a.lucent, work, "lucent-mask", SCENE, a.spp)
    M = render_mitsuba(a.variant, work, a.spp, True)
    P = render_mitsuba(a.variant, work, a.spp, False)
    res = {"mitsuba_variant": a.variant, "spp": a.spp,
           "ratio_blocks": [float(x) for x in np.percentile(blocks(L) / blocks(M), [10, 50, 90])],
           "ratio_sum": float(L.sum() / M.sum()),
           "mitsuba_mask_over_no_mask": [float(x) for x in np.percentile(blocks(M) / blocks(P), [10, 50, 90])]}
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        r, p = res["ratio_blocks"], res["mitsuba_mask_over_no_mask"]
        print(f"Mitsuba 3 {a.variant}, {a.spp} spp: lucent / Mitsuba over 4 x 4 blocks {r[1]:.4f} ({r[0]:.3f}-{r[2]:.3f}), "
              f"sums {res['ratio_sum']:.4f}; Mitsuba masked / unmasked {p[1]:.3f} ({p[0]:.3f}-{p[2]:.3f})")


if __name__ == "__main__":
    sys.exit(main())
