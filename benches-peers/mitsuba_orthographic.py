#!/usr/bin/env python3
"""lucent's orthographic camera against Mitsuba 3's `orthographic`, pixel by pixel.

Two diffuse spheres (albedo 0.7 and 0.3, radii 0.3 and 0.15, one off the axis so that a flipped
or shifted view shows) over a diffuse floor, under a constant environment of spectral radiance 1,
seen from 5 m by an orthographic camera 1.6 m wide (96 × 64 pixels, box filter), `path` with
max_depth 4 in both. Mitsuba's camera spans [−1, 1] in x and [−1/aspect, 1/aspect] in y before
its `to_world`, so `look_at(...) @ scale(w/2, w/2, 1)` is lucent's `view_width = w`. Prints the
ratio lucent / Mitsuba of the luminance over 4 × 4 blocks that see an object (median, 10th–90th
percentile) and the same statistic between two seeds of each renderer (their noise).

    /tmp/pyvenv/bin/python benches-peers/mitsuba_orthographic.py [--lucent target/release/lucent]
        [--spp 256] [--variant scalar_spectral] [--save DIR] [--json]

Needs numpy and mitsuba==3.9.1.
"""

import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import LUMA, blocks, read_pfm, peer_args  # noqa: E402

W, H, VIEW_W = 96, 64, 1.6
EYE, AT = [0.4, 1.2, -5.0], [0.1, 0.2, 0.0]
SPHERES = [([0.0, 0.3, 0.0], 0.3, 0.7), ([0.45, 0.15, -0.2], 0.15, 0.3)]


def render_lucent(lucent, work, spp, seed):
    objs = "".join(f"""[materials.m{k}]\ntype = "lambertian"\nalbedo = {a}\n[[objects]]\nmaterial = "m{k}"\nsphere = {{ center = {c}, radius = {r} }}\n"""
                   for k, (c, r, a) in enumerate(SPHERES))
    scene = f"""unit = "m"
[camera]
model = "orthographic"
eye = {EYE}
look_at = {AT}
view_width = {VIEW_W}
width = {W}
height = {H}
[integrator]
type = "path"
max_depth = 4
{objs}[materials.floor]
type = "lambertian"
albedo = 0.5
[[objects]]
material = "floor"
quad = [[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]
[[lights]]
type = "environment"
radiance = 1.0
"""
    path = os.path.join(work, "lucent.toml")
    with open(path, "w") as f:
        f.write(scene)
    out = os.path.join(work, f"lucent-{seed}.pfm")
    subprocess.run([lucent, "render", path, "--spp", str(spp), "--seed", str(seed), "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out) @ np.array(LUMA)


def render_mitsuba(variant, spp, seed):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {
            "type": "orthographic",
            "to_world": T().look_at(origin=EYE, target=AT, up=[0, 1, 0]) @ T().scale([VIEW_W / 2, VIEW_W / 2, 1]),
            "film": {"type": "hdrfilm", "width": W, "height": H, "pixel_format": "rgb", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90) @ T().scale(3),
                  "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.5}}}},
        "env": {"type": "constant", "radiance": {"type": "spectrum", "value": 1.0}},
    }
    for k, (c, r, a) in enumerate(SPHERES):
        d[f"s{k}"] = {"type": "sphere", "center": c, "radius": r, "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": a}}}
    return np.array(mi.render(mi.load_dict(d), seed=seed), dtype=np.float64) @ np.array(LUMA)


def main():
    a, work, _tmp = peer_args(__doc__, 256)
    l1, l2 = (render_lucent(a.lucent, work, a.spp, s) for s in (1, 2))
    m1, m2 = (render_mitsuba(a.variant, a.spp, s) for s in (1, 2))
    L, M = blocks((l1 + l2) / 2), blocks((m1 + m2) / 2)
    keep = M > 0.05
    q = lambda r: [float(x) for x in np.percentile(r[keep], [10, 50, 90])]
    res = {"mitsuba_variant": a.variant, "spp": a.spp, "blocks": int(keep.sum()),
           "lucent_over_mitsuba_p10_p50_p90": q(L / M),
           "lucent_seed1_over_seed2": q(blocks(l1) / blocks(l2)), "mitsuba_seed1_over_seed2": q(blocks(m1) / blocks(m2)),
           "mean_Y": [float(L.mean()), float(M.mean())]}
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        p = res["lucent_over_mitsuba_p10_p50_p90"]
        print(f"Mitsuba 3 {a.variant}, {a.spp} spp × 2 seeds, {res['blocks']} 4 × 4 blocks: lucent / Mitsuba {p[1]:.4f} ({p[0]:.4f}–{p[2]:.4f});"
              f" lucent seeds {res['lucent_seed1_over_seed2']}, Mitsuba seeds {res['mitsuba_seed1_over_seed2']}; mean Y {res['mean_Y']}")


if __name__ == "__main__":
    sys.exit(main())
